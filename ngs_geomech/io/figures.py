"""PNG figures with matplotlib: fields with region outlines (2D meshes and plane sections of 3D ones), profiles
along a line, probe time curves, quantities along an interface, convergence curves.

Figures are drawn with matplotlib's object-oriented API on an Agg canvas of their own (no ``pyplot``, no
``matplotlib.use``), so the caller's backend and pyplot state stay as they are; matplotlib is imported only
when a figure is drawn. They are laid out by :mod:`.layout`: lengths in m or km, colour bars no taller (or wider)
than their axes, legends outside the data. Each drawing function returns its figure (for tests).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import replacing
from .layout import Frame, colorbar, frame_axes, legend_below, legend_right, tight
from .meshdata import MeshArrays
from .scales import length_scale, with_unit, without_unit


def new_figure(figsize: tuple[float, float], nrows: int = 1, ncols: int = 1, **subplots):
    """A figure on its own Agg canvas and its axes: ``(fig, ax)``, or ``(fig, axes)`` with ``subplots``
    keywords of :meth:`matplotlib.figure.Figure.subplots` (``squeeze=False``, ``sharex=True``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **subplots)


def save_figure(fig, path: Path) -> None:
    """Write ``fig`` as PNG (130 dpi) to ``path`` completely or not at all (:func:`.atomic.replacing`)."""
    with replacing(path, ".png") as tmp:
        fig.savefig(tmp, dpi=130)


def line_collection(segments, **kwargs):
    """A :class:`matplotlib.collections.LineCollection` of ``segments`` (k x 2 x 2)."""
    from matplotlib.collections import LineCollection

    return LineCollection(segments, **kwargs)


def titled(fig, ax, title: str, fontsize: float = 11.0) -> None:
    """The axes' title, broken into lines that fit the figure's width."""
    import textwrap

    chars = max(20, int(fig.get_size_inches()[0] * 72 / (0.6 * fontsize)) - 4)
    ax.set_title("\n".join(textwrap.fill(line, chars) for line in title.split("\n")), fontsize=fontsize)


def shown_box(points: np.ndarray, window=None) -> tuple[np.ndarray, np.ndarray]:
    """The box a field figure shows: ``window`` = [xmin, xmax, ymin, ymax], else the points' bounding box."""
    if window is not None:
        return np.array([window[0], window[2]], dtype=float), np.array([window[1], window[3]], dtype=float)
    return points[:, :2].min(axis=0), points[:, :2].max(axis=0)


def window_range(points: np.ndarray, values: np.ndarray, window=None) -> tuple[float | None, float | None]:
    """The colour range of the values at the points inside ``window`` (None, None: the whole range)."""
    if window is None:
        return None, None
    inside = ((points[:, 0] >= window[0]) & (points[:, 0] <= window[1])
              & (points[:, 1] >= window[2]) & (points[:, 1] <= window[3]))
    if not inside.any():
        return None, None
    return float(np.nanmin(values[inside])), float(np.nanmax(values[inside]))


def field_figure(m: MeshArrays, values: np.ndarray, path: Path, *, title: str, label: str,
                 axis_labels=("x (m)", "y (m)"), window=None, cmap="inferno", lines: np.ndarray | None = None,
                 lines_label: str = ""):
    """A filled plot of vertex values with the region outlines; ``window`` = [xmin, xmax, ymin, ymax];
    ``lines`` (k x 2 x 2 segment coordinates, e.g. an iso-line) are drawn over it, labelled ``lines_label`` in
    a legend below the axes. Lengths in m or km, a very thin domain's short side stretched
    (:class:`~.layout.Frame`), the colour bar as tall as the axes. Returns the figure."""
    from matplotlib.lines import Line2D
    from matplotlib.tri import Triangulation

    frame = Frame.of(*shown_box(m.points, window))
    drawn = lines is not None and len(lines) > 0
    band = 0.4 if drawn and lines_label else 0.0
    w, h = frame.figsize()
    fig, ax = new_figure((w, h + band))
    tri = Triangulation(m.points[:, 0], m.points[:, 1], m.triangles)
    vmin, vmax = window_range(m.points, values, window)
    pc = ax.tripcolor(tri, values, shading="gouraud", cmap=cmap, vmin=vmin, vmax=vmax)
    ax.add_collection(line_collection(m.outline, colors="white", linewidths=0.8))
    if drawn:
        ax.add_collection(line_collection(np.asarray(lines)[:, :, :2], colors="cyan", linewidths=1.8))
    frame_axes(ax, frame, axis_labels)
    titled(fig, ax, title)
    colorbar(fig, ax, pc, label)
    if band:
        legend_below(fig, [Line2D([], [], color="cyan", lw=1.8, label=lines_label)])
    tight(fig, band)
    save_figure(fig, path)
    return fig


def section_figure(u: np.ndarray, v: np.ndarray, values: np.ndarray, path: Path, *, title: str, label: str,
                   axis_labels: tuple[str, str], outline: np.ndarray | None = None, cmap="inferno"):
    """A field on a plane section of a 3D domain: ``values`` (len(v), len(u)) sampled at the grid of in-plane
    coordinates ``u`` x ``v`` (m), NaN outside the domain (left blank); ``outline`` (k x 2 x 2, in-plane m) the
    cut of the region boundaries and interfaces. Returns the figure."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    frame = Frame.of((u[0], v[0]), (u[-1], v[-1]))
    fig, ax = new_figure(frame.figsize())
    pc = ax.pcolormesh(u, v, np.ma.masked_invalid(values), shading="gouraud" if len(u) > 1 else "nearest",
                       cmap=cmap)
    if outline is not None and len(outline):
        ax.add_collection(line_collection(outline, colors="white", linewidths=0.8))
    frame_axes(ax, frame, axis_labels)
    titled(fig, ax, title)
    colorbar(fig, ax, pc, label)
    tight(fig)
    save_figure(fig, path)
    return fig


def profile_figure(coord: np.ndarray, profiles: dict[str, np.ndarray], path: Path, *, title: str,
                   value_label: str, coord_label: str, vertical: bool = True):
    """Profiles of a quantity along a line (a thin column's axis): one curve per entry of ``profiles`` (e.g.
    per output time) over the coordinate ``coord`` (m, in m or km as fits), drawn upright (``vertical``: the
    coordinate on the vertical axis, as a depth profile) or along x; NaN values (outside the domain) leave gaps.
    The legend is outside the axes. Returns the figure."""
    coord = np.asarray(coord, dtype=float)
    scale = length_scale(float(np.nanmax(coord) - np.nanmin(coord)) if len(coord) else 0.0)
    fig, ax = new_figure((6.8, 6.4) if vertical else (8.2, 4.5))
    for name, vals in profiles.items():
        x, y = (np.asarray(vals, dtype=float), scale(coord)) if vertical else (scale(coord), vals)
        ax.plot(x, y, label=name, linewidth=1.3)
    labels = (value_label, with_unit(coord_label, scale.unit))
    ax.set_xlabel(labels[0] if vertical else labels[1])
    ax.set_ylabel(labels[1] if vertical else labels[0])
    ax.grid(True, alpha=0.3)
    titled(fig, ax, title)
    legend_right(ax)
    tight(fig)
    save_figure(fig, path)
    return fig


def time_curves(times: np.ndarray, curves: dict[str, np.ndarray], path: Path, *, title: str,
                ylabel: str, time_unit: float = 1.0, time_label: str = "t (s)",
                hlines: dict[str, float] | None = None):
    """Curves over time (one per probe), optional horizontal reference lines (e.g. a design limit); the legend
    outside the axes. Returns the figure."""
    fig, ax = new_figure((8.4, 4.5))
    t = np.asarray(times) / time_unit
    for name, vals in curves.items():
        ax.plot(t, vals, label=name, marker="." if len(t) < 40 else None)
    for name, y in (hlines or {}).items():
        ax.axhline(y, color="k", linestyle="--", linewidth=0.8, label=name)
    ax.set_xlabel(time_label)
    ax.set_ylabel(ylabel)
    titled(fig, ax, title)
    ax.grid(True, alpha=0.3)
    legend_right(ax)
    tight(fig)
    save_figure(fig, path)
    return fig


STATUS_SHADES = (("0.85", "open"), ("#cfe8cf", "stick"), ("#f6c8a6", "slip"), ("#c9d6ef", "prescribed"))
"""Background colour and name of each contact status (0 open, 1 stick, 2 slip, 3 prescribed)."""


def interface_profiles(s: np.ndarray, panels: list[dict[str, np.ndarray]], path: Path, *, title: str,
                       ylabels: list[str], xlabel: str = "arc length along the interface (m)",
                       status: np.ndarray | None = None, start=None):
    """Quantities along an interface: one panel per dict of curves (e.g. pressure and traction, gap and
    slip) over the arc length ``s`` (m; drawn in m or km as fits, and so is ``start``, the point (x, y) in m
    the arc length is counted from, added to the x label); ``status`` (0 open, 1 stick, 2 slip, 3 prescribed:
    held by the supports) shades the panels' background. Legends outside the panels. Returns the figure."""
    s = np.asarray(s, dtype=float)
    scale = length_scale(float(s.max() - s.min()) if len(s) else 0.0)
    xlabel = with_unit(xlabel, scale.unit) if start is None else \
        f"{without_unit(xlabel)} from ({start[0] / scale.factor:.4g}, {start[1] / scale.factor:.4g}) ({scale.unit})"
    sk = scale(s)
    fig, axes = new_figure((8.4, 2.6 * len(panels) + 0.6), len(panels), 1, sharex=True, squeeze=False)
    for ax, curves, ylabel in zip(axes[:, 0], panels, ylabels):
        for name, vals in curves.items():
            ax.plot(sk, vals, label=name, marker="." if len(s) < 60 else None, linewidth=1.0)
        if status is not None and len(s) > 1:
            _shade_status(ax, sk, np.asarray(status), labelled=ax is not axes[0, 0])
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        legend_right(ax, fontsize=7)
    axes[-1, 0].set_xlabel(xlabel)
    titled(fig, axes[0, 0], title)
    tight(fig)
    save_figure(fig, path)
    return fig


def _shade_status(ax, s: np.ndarray, status: np.ndarray, labelled: bool) -> None:
    """Each node's share of the line shaded in the colour of its status; labelled for the legend unless
    ``labelled`` already (one legend entry per status in the first panel)."""
    mids = np.concatenate([[s[0]], 0.5 * (s[1:] + s[:-1]), [s[-1]]])
    for k, (color, lab) in enumerate(STATUS_SHADES):
        done = labelled
        for j in np.where(status == k)[0]:
            ax.axvspan(mids[j], mids[j + 1], color=color, alpha=0.7, linewidth=0, label=None if done else lab)
            done = True


def convergence_figure(dofs, curves: dict[str, list], path: Path, *, title: str, ylabel: str):
    """Log-log curves against the number of unknowns (e.g. an adaptive run's estimates); the legend outside
    the axes. Returns the figure."""
    fig, ax = new_figure((8.0, 4.5))
    for name, vals in curves.items():
        ax.loglog(dofs, vals, marker="o", label=name)
    ax.set_xlabel("unknowns")
    ax.set_ylabel(ylabel)
    titled(fig, ax, title)
    ax.grid(True, which="both", alpha=0.3)
    legend_right(ax)
    tight(fig)
    save_figure(fig, path)
    return fig
