"""How the field figures are laid out so that a reader can use them: the figure's size from the shape of what
is shown, lengths in m or km (:mod:`.scales`), a short side stretched when the domain is very thin (and the
labels say so), colour bars as tall (or, below a wide domain, as wide) as the axes, and legends outside the
axes, where they cover no data."""

from __future__ import annotations

import math
from typing import NamedTuple

from .scales import Scale, length_scale, with_unit

MAX_DISPLAY_ASPECT = 4.0
"""The longest a field figure's axes are against their short side: a thinner domain (permafrost's 20 m x 1000 m
column) is drawn with its short side stretched (by the ratio over this), which its axis label states."""

THIN = 8.0
"""Long over short side from which a domain is a thin column (or strip): it gets a profile along its axis."""

WIDE = 0.3
"""Axes height over width below which the colour bar goes under the axes (horizontal), not beside them."""


class Frame(NamedTuple):
    """What a field figure shows: the box ``lo`` = (xmin, ymin), ``hi`` = (xmax, ymax) in m, the length unit
    (:class:`~.scales.Scale`), the stretch of the short side (1: none; ``stretched`` 0 for x, 1 for y)."""

    lo: tuple[float, float]
    hi: tuple[float, float]
    scale: Scale
    stretch: float
    stretched: int

    @classmethod
    def of(cls, lo, hi, stretch: bool = True) -> Frame:
        """The frame of the box (lo, hi), its short side stretched when ``stretch`` and the box is thinner than
        :data:`MAX_DISPLAY_ASPECT`."""
        w, h = float(hi[0] - lo[0]), float(hi[1] - lo[1])
        ratio = max(w, h) / max(min(w, h), 1e-300)
        factor = ratio / MAX_DISPLAY_ASPECT if stretch and ratio > MAX_DISPLAY_ASPECT else 1.0
        return cls((float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1])), length_scale(max(w, h)), factor,
                   0 if w < h else 1)

    @property
    def shown(self) -> tuple[float, float]:
        """The drawn width and height (m, the short side stretched)."""
        w, h = self.hi[0] - self.lo[0], self.hi[1] - self.lo[1]
        return (w * self.stretch, h) if self.stretched == 0 else (w, h * self.stretch)

    @property
    def aspect(self) -> float:
        """Matplotlib's aspect of the axes: the drawn length of one y unit over that of one x unit."""
        if self.stretch == 1.0:
            return 1.0
        return 1.0 / self.stretch if self.stretched == 0 else self.stretch

    def figsize(self, extra_width: float = 1.9, extra_height: float = 1.3, width: float = 5.6,
                height: float = 6.4) -> tuple[float, float]:
        """A figure size (in) whose axes hold the shown box: ``width`` x ``height`` in at most, plus the
        margins for the colour bar and labels (``extra_width``) and the title and x label (``extra_height``)."""
        w, h = self.shown
        ax_w = min(width, height * w / h)
        ax_h = ax_w * h / w
        return max(ax_w + extra_width, 4.8), max(ax_h + extra_height, 3.0)


def frame_axes(ax, frame: Frame, labels: tuple[str, str], pad: float = 0.0) -> None:
    """Limits (the frame's box, ``pad`` times its longest side around it), aspect, axis labels in the frame's
    length unit (a stretched side says by how much) and tick labels in that unit."""
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    w, h = frame.hi[0] - frame.lo[0], frame.hi[1] - frame.lo[1]
    p = pad * max(w, h)
    ax.set_xlim(frame.lo[0] - p, frame.hi[0] + p)
    ax.set_ylim(frame.lo[1] - p, frame.hi[1] + p)
    ax.set_aspect(frame.aspect)
    unit = frame.scale
    for k, (axis, label) in enumerate(zip((ax.xaxis, ax.yaxis), labels)):
        text = with_unit(label, unit.unit)
        if frame.stretch != 1.0 and k == frame.stretched:
            text += f", stretched {frame.stretch:.3g}x"
        axis.set_label_text(text)
        axis.set_major_locator(MaxNLocator(nbins="auto", steps=[1, 2, 2.5, 5, 10]))
        if unit.factor != 1.0:
            axis.set_major_formatter(FuncFormatter(lambda v, _pos, f=unit.factor: f"{v / f:g}"))


def colorbar(fig, ax, mappable, label: str):
    """A colour bar as tall as the axes beside them, or (axes lower than :data:`WIDE` times their width) as wide
    as the axes below them; returns its axes."""
    from matplotlib.ticker import ScalarFormatter
    from mpl_toolkits.axes_grid1 import axes_size
    from mpl_toolkits.axes_grid1.axes_divider import AxesDivider

    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    aspect = ax.get_aspect()
    aspect = 1.0 if aspect == "auto" else float(aspect)
    below = abs(y1 - y0) * aspect < WIDE * abs(x1 - x0)
    # make_axes_locatable's divider sizes the axes as for equal aspect; with the axes' own aspect the colour bar
    # keeps the height (width) of a stretched frame too
    divider = AxesDivider(ax, xref=axes_size.AxesX(ax), yref=axes_size.AxesY(ax, aspect=aspect))
    ax.set_axes_locator(divider.new_locator(nx=0, ny=0))
    cax = divider.append_axes("bottom", size=0.14, pad=0.55) if below else \
        divider.append_axes("right", size=0.16, pad=0.12)
    bar = fig.colorbar(mappable, cax=cax, label=label, orientation="horizontal" if below else "vertical")
    plain = ScalarFormatter(useOffset=False)     # no offset or power text: it would sit on the title or x label
    plain.set_powerlimits((-99, 99))
    bar.formatter = plain
    return cax


def legend_right(ax, **kwargs):
    """The axes' legend outside them, to the right of their top (covers no data); None without labelled
    artists."""
    handles, _ = ax.get_legend_handles_labels()
    if not handles:
        return None
    opts = {"fontsize": 8, "loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0}
    return ax.legend(**{**opts, **kwargs})


def legend_below(fig, handles, ncol: int = 3):
    """A figure legend of ``handles`` centred at the figure's bottom, in the band :func:`tight` keeps free."""
    height = fig.get_size_inches()[1]
    return fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.1 / height), ncol=ncol,
                      fontsize=8, frameon=False, borderaxespad=0.0)


def tight(fig, band: float = 0.0) -> None:
    """tight_layout, keeping a band of ``band`` in free at the bottom (for :func:`legend_below`)."""
    height = fig.get_size_inches()[1]
    fig.tight_layout(rect=(0.0, min(band / height, 0.5), 1.0, 1.0))


def thin(lo, hi) -> int | None:
    """The axis (0 x, 1 y, 2 z) along which the box (lo, hi) is a thin column or strip (its longest side at least
    :data:`THIN` times the next longest), or None."""
    ext = sorted(((float(b) - float(a), k) for k, (a, b) in enumerate(zip(lo, hi))), reverse=True)
    if len(ext) < 2 or not ext[0][0] > 0:
        return None
    return ext[0][1] if ext[0][0] >= THIN * max(ext[1][0], 1e-300) and math.isfinite(ext[0][0]) else None
