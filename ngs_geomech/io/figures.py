"""PNG figures with matplotlib: fields with region outlines, probe time curves.

Figures are drawn with matplotlib's object-oriented API on an Agg canvas of their own (no ``pyplot``, no
``matplotlib.use``), so the caller's backend and pyplot state stay as they are; matplotlib is imported only
when a figure is drawn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import replacing
from .meshdata import MeshArrays


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


def field_figure(m: MeshArrays, values: np.ndarray, path: Path, *, title: str, label: str,
                 axis_labels=("x (m)", "y (m)"), window=None, cmap="inferno", lines: np.ndarray | None = None,
                 lines_label: str = "") -> None:
    """A filled plot of vertex values with the region outlines; ``window`` = [xmin, xmax, ymin, ymax];
    ``lines`` (k x 2 x 2 segment coordinates, e.g. an iso-line) are drawn over it, labelled ``lines_label``."""
    from matplotlib.tri import Triangulation

    fig, ax = new_figure((7, 5.5))
    tri = Triangulation(m.points[:, 0], m.points[:, 1], m.triangles)
    vmin = vmax = None
    if window is not None:  # colour range of what is shown
        inside = ((m.points[:, 0] >= window[0]) & (m.points[:, 0] <= window[1])
                  & (m.points[:, 1] >= window[2]) & (m.points[:, 1] <= window[3]))
        if inside.any():
            vmin, vmax = float(values[inside].min()), float(values[inside].max())
    pc = ax.tripcolor(tri, values, shading="gouraud", cmap=cmap, vmin=vmin, vmax=vmax)
    ax.add_collection(line_collection(m.outline, colors="white", linewidths=0.8))
    if lines is not None and len(lines):
        ax.add_collection(line_collection(np.asarray(lines)[:, :, :2], colors="cyan", linewidths=1.8,
                                         label=lines_label or None))
        if lines_label:
            ax.legend(loc="best", fontsize=8, framealpha=0.8)
    fig.colorbar(pc, ax=ax, label=label)
    if window is not None:
        ax.set_xlim(window[0], window[1])
        ax.set_ylim(window[2], window[3])
    ax.set_aspect("equal")
    ax.set_xlabel(axis_labels[0])
    ax.set_ylabel(axis_labels[1])
    ax.set_title(title)
    fig.tight_layout()
    save_figure(fig, path)


def time_curves(times: np.ndarray, curves: dict[str, np.ndarray], path: Path, *, title: str,
                ylabel: str, time_unit: float = 1.0, time_label: str = "t (s)",
                hlines: dict[str, float] | None = None) -> None:
    """Curves over time (one per probe), optional horizontal reference lines (e.g. a design limit)."""
    fig, ax = new_figure((7, 4.5))
    t = np.asarray(times) / time_unit
    for name, vals in curves.items():
        ax.plot(t, vals, label=name, marker="." if len(t) < 40 else None)
    for name, y in (hlines or {}).items():
        ax.axhline(y, color="k", linestyle="--", linewidth=0.8, label=name)
    ax.set_xlabel(time_label)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)


def interface_profiles(s: np.ndarray, panels: list[dict[str, np.ndarray]], path: Path, *, title: str,
                       ylabels: list[str], xlabel: str = "arc length along the interface (m)",
                       status: np.ndarray | None = None) -> None:
    """Quantities along an interface: one panel per dict of curves (e.g. pressure and traction, gap and
    slip) over the arc length ``s``; ``status`` (0 open, 1 stick, 2 slip, 3 prescribed: held by the supports)
    shades the panels' background."""
    fig, axes = new_figure((7, 2.6 * len(panels) + 0.6), len(panels), 1, sharex=True, squeeze=False)
    for ax, curves, ylabel in zip(axes[:, 0], panels, ylabels):
        for name, vals in curves.items():
            ax.plot(s, vals, label=name, marker="." if len(s) < 60 else None, linewidth=1.0)
        if status is not None and len(s) > 1:
            mids = np.concatenate([[s[0]], 0.5 * (s[1:] + s[:-1]), [s[-1]]])   # each node's share of the line
            for k, (color, lab) in enumerate((("0.85", "open"), ("#cfe8cf", "stick"), ("#f6c8a6", "slip"),
                                              ("#c9d6ef", "prescribed"))):
                labelled = ax is not axes[0, 0]
                for j in np.where(status == k)[0]:
                    ax.axvspan(mids[j], mids[j + 1], color=color, alpha=0.7, linewidth=0,
                               label=None if labelled else lab)
                    labelled = True
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel(xlabel)
    axes[0, 0].set_title(title)
    fig.tight_layout()
    save_figure(fig, path)


def convergence_figure(dofs, curves: dict[str, list], path: Path, *, title: str, ylabel: str) -> None:
    """Log-log curves against the number of unknowns (e.g. an adaptive run's estimates)."""
    fig, ax = new_figure((6.5, 4.5))
    for name, vals in curves.items():
        ax.loglog(dofs, vals, marker="o", label=name)
    ax.set_xlabel("unknowns")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
