"""Principal stresses drawn as crosses (after Nedoma 2001, Fig. 1): at sample points two perpendicular bars
along the principal directions, each as long as its principal stress is large, compression and extension
in different colours.

Everything works on plain arrays (:class:`~.meshdata.MeshArrays` and numpy arrays of stress components), so
the caller decides how the stresses are evaluated: exactly at the sample points (e.g. a GridFunction or an
analytic field there), or by :func:`interpolate` from vertex values. Interpolate the *components*
``sxx, syy, sxy`` and then call :func:`principal_2d`; principal values and angles do not interpolate linearly.

Stresses are in Pa with tension positive; the legend states the bar scale in ``stress_unit`` (MPa, or GPa from
1 GPa on, by default: :func:`~.scales.stress_scale`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .figures import line_collection, new_figure, save_figure, shown_box, titled, window_range
from .layout import Frame, colorbar, frame_axes, tight
from .meshdata import MeshArrays
from .scales import stress_scale

COMPRESSION_COLOR = "#1f4fd6"   # blue
EXTENSION_COLOR = "#d62728"     # red


def principal_2d(sxx, syy, sxy):
    """Principal stresses of plane tensors: ``(s1, s2, theta1)`` with ``s1 >= s2`` and ``theta1`` in
    ``(-pi/2, pi/2]`` the angle of the ``s1`` direction from the x axis; ``s2`` acts along ``theta1 + pi/2``.

    Vectorized over broadcastable arrays. An isotropic state (``sxx == syy``, ``sxy == 0``) gives
    ``s1 == s2 == sxx`` exactly and ``theta1 == 0`` (every direction is principal).
    """
    sxx, syy, sxy = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (sxx, syy, sxy)))
    centre = 0.5 * sxx + 0.5 * syy          # exact (== sxx) when sxx == syy, no overflow
    half_diff = 0.5 * sxx - 0.5 * syy
    radius = np.hypot(half_diff, sxy)        # Mohr circle radius, >= 0
    s1 = centre + radius
    s2 = centre - radius
    theta1 = 0.5 * np.arctan2(sxy, half_diff)
    theta1 = np.where(theta1 <= -0.5 * np.pi, theta1 + np.pi, theta1)  # (-pi/2, pi/2]
    return s1, s2, theta1


class Samples(NamedTuple):
    """Sample points inside a triangulation: coordinates ``xy`` (n, 2), the containing triangle (n,)
    (row of ``MeshArrays.triangles``), and the grid spacing they were laid out with (``nan`` if unknown)."""

    xy: np.ndarray
    triangle: np.ndarray
    spacing: float = math.nan


def _triangulation(m: MeshArrays):
    from matplotlib.tri import Triangulation

    return Triangulation(m.points[:, 0], m.points[:, 1], m.triangles)


def find_triangles(m: MeshArrays, xy) -> np.ndarray:
    """The triangle (row of ``m.triangles``) containing each point of ``xy`` (n, 2), -1 outside the mesh."""
    from matplotlib.tri import TrapezoidMapTriFinder

    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    try:
        finder = TrapezoidMapTriFinder(_triangulation(m))
    except RuntimeError:    # duplicate vertices (the two sides of a contact interface): matplotlib refuses them
        return _find_triangles_direct(m, xy)
    return np.asarray(finder(xy[:, 0], xy[:, 1]), dtype=int)


def _find_triangles_direct(m: MeshArrays, xy: np.ndarray, chunk: int = 256) -> np.ndarray:
    """The first triangle whose barycentric coordinates of the point are all >= -1e-12 (-1: none)."""
    p = m.points[m.triangles]                      # (nt, 3, 2)
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    out = np.full(len(xy), -1, dtype=int)
    for s in range(0, len(xy), chunk):
        q = xy[s:s + chunk, None, :]               # (k, 1, 2)
        l1 = ((b[:, 0] - q[..., 0]) * (c[:, 1] - q[..., 1]) - (c[:, 0] - q[..., 0]) * (b[:, 1] - q[..., 1])) / det
        l2 = ((c[:, 0] - q[..., 0]) * (a[:, 1] - q[..., 1]) - (a[:, 0] - q[..., 0]) * (c[:, 1] - q[..., 1])) / det
        inside = (l1 >= -1e-12) & (l2 >= -1e-12) & (1 - l1 - l2 >= -1e-12)
        hit = inside.any(axis=1)
        out[s:s + chunk][hit] = np.argmax(inside[hit], axis=1)
    return out


def grid_samples(m: MeshArrays, spacing: float, window=None) -> Samples:
    """Points of a regular square grid of ``spacing`` that lie inside the triangulation (holes and the outside
    are left out), with their triangles. The grid fills the mesh bounding box, or its intersection with
    ``window`` = [xmin, xmax, ymin, ymax], like cell centres: centred, at least ``spacing / 2`` from its
    edges, so crosses of the default size stay inside it."""
    if not spacing > 0:
        raise ValueError(f"spacing must be positive, got {spacing!r}")
    lo = m.points.min(axis=0)
    hi = m.points.max(axis=0)
    if window is not None:
        lo = np.maximum(lo, [window[0], window[2]])
        hi = np.minimum(hi, [window[1], window[3]])
    if np.any(hi < lo):
        return Samples(np.empty((0, 2)), np.empty(0, dtype=int), float(spacing))
    axes = []
    for a, b in zip(lo, hi):  # cell centres: at least spacing / 2 from the box edges
        n = max(1, int(math.floor((b - a) / spacing + 1e-9)))
        start = a + 0.5 * ((b - a) - (n - 1) * spacing)
        axes.append(start + spacing * np.arange(n))
    gx, gy = np.meshgrid(*axes)
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    tri = find_triangles(m, xy)
    keep = tri >= 0
    return Samples(xy[keep], tri[keep], float(spacing))


def interpolate(m: MeshArrays, vertex_values, samples) -> np.ndarray:
    """Linear (barycentric) interpolation of vertex values at sample points.

    ``vertex_values`` is (nv,) or (nv, ...) for several fields at once; ``samples`` is a :class:`Samples`
    (or an ``(xy, triangle)`` pair) or a plain (n, 2) array of points, which are then located in the mesh.
    Points outside the mesh (triangle -1) get ``nan``.
    """
    if isinstance(samples, tuple):
        xy, tri = np.asarray(samples[0], dtype=float), np.asarray(samples[1], dtype=int)
    else:
        xy = np.atleast_2d(np.asarray(samples, dtype=float))
        tri = find_triangles(m, xy)
    values = np.asarray(vertex_values, dtype=float)
    if values.shape[0] != len(m.points):
        raise ValueError(f"{values.shape[0]} vertex values for {len(m.points)} vertices")
    inside = tri >= 0
    verts = m.triangles[np.where(inside, tri, 0)]                 # (n, 3)
    p0, p1, p2 = (m.points[verts[:, k]] for k in range(3))
    e1, e2, d = p1 - p0, p2 - p0, xy - p0
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    l1 = (d[:, 0] * e2[:, 1] - d[:, 1] * e2[:, 0]) / det
    l2 = (e1[:, 0] * d[:, 1] - e1[:, 1] * d[:, 0]) / det
    l0 = 1.0 - l1 - l2
    lam = np.column_stack([l0, l1, l2]).reshape((len(xy), 3) + (1,) * (values.ndim - 1))
    out = np.sum(lam * values[verts], axis=1)
    out[~inside] = np.nan
    return out


def cross_segments(samples_xy, s1, s2, theta1, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Bars of the crosses: segments (2n, 2, 2) centred at the samples, first along ``theta1`` with length
    ``scale * |s1|``, then along ``theta1 + pi/2`` with length ``scale * |s2|``; and their stresses (2n,)."""
    xy = np.asarray(samples_xy, dtype=float).reshape(-1, 2)
    s = np.concatenate([np.ravel(s1), np.ravel(s2)]).astype(float)
    th = np.concatenate([np.ravel(theta1), np.ravel(theta1) + 0.5 * np.pi]).astype(float)
    centre = np.concatenate([xy, xy])
    half = 0.5 * scale * np.abs(s)
    d = np.column_stack([np.cos(th), np.sin(th)]) * half[:, None]
    return np.stack([centre - d, centre + d], axis=1), s


def _nice_below(x: float) -> float:
    """The largest 1, 2 or 5 times a power of ten that is <= x (x > 0)."""
    p = 10.0 ** math.floor(math.log10(x))
    for f in (5.0, 2.0, 1.0):
        if f * p <= x * (1 + 1e-12):
            return f * p
    return p


def _estimate_spacing(xy: np.ndarray, m: MeshArrays) -> float:
    if len(xy) >= 2:
        from scipy.spatial import cKDTree

        dist, _ = cKDTree(xy).query(xy, k=2)
        nn = dist[:, 1][dist[:, 1] > 0]
        if len(nn):
            return float(nn.min())
    ext = m.points.max(axis=0) - m.points.min(axis=0)
    return float(ext.max()) / 20.0


def _light_greys():
    from matplotlib import colormaps
    from matplotlib.colors import LinearSegmentedColormap

    base = colormaps["Greys"]
    return LinearSegmentedColormap.from_list("light_greys", base(np.linspace(0.0, 0.55, 256)))


def principal_stress_crosses(m: MeshArrays, samples_xy, s1, s2, theta1, path: Path, *, title: str,
                             axis_labels=("x (m)", "y (m)"), window=None, scale=None, background=None,
                             background_label=None, spacing=None, stress_unit=None,
                             cmap=None, linewidth=1.4):
    """Principal stress crosses over the region outlines, optionally over a background field.

    At each sample of ``samples_xy`` (n, 2) (or a :class:`Samples`) two perpendicular bars centred at the
    point: along ``theta1`` for ``s1`` and along ``theta1 + pi/2`` for ``s2`` (as from :func:`principal_2d`),
    each ``scale * |s|`` long (``scale`` in length per Pa); compression (s < 0) blue, extension (s > 0) red.
    By default the longest bar is 0.9 times the sample ``spacing`` (taken from a :class:`Samples`, else the
    smallest distance between samples), so neighbouring crosses do not touch. ``background`` are vertex
    values drawn as a filled field with a colour bar as tall as the axes labelled ``background_label`` (light
    greys unless ``cmap``). The legend below the axes gives the colours and a reference bar for a round stress
    in ``stress_unit`` = (name, Pa per unit; default MPa or GPa by the largest stress). ``window`` = [xmin,
    xmax, ymin, ymax] limits the view (and the colour range); lengths are in m or km as fits, drawn to scale
    (bar directions are angles). Returns the figure.
    """
    if isinstance(samples_xy, Samples):
        if spacing is None and math.isfinite(samples_xy.spacing):
            spacing = samples_xy.spacing
        samples_xy = samples_xy.xy
    xy = np.asarray(samples_xy, dtype=float).reshape(-1, 2)
    s1, s2, theta1 = (np.ravel(np.asarray(a, dtype=float)) for a in (s1, s2, theta1))
    if not (len(s1) == len(s2) == len(theta1) == len(xy)):
        raise ValueError(f"{len(xy)} samples but {len(s1)}, {len(s2)}, {len(theta1)} values of s1, s2, theta1")
    smax = float(np.max(np.abs(np.concatenate([s1, s2])), initial=0.0))
    if scale is None:
        if spacing is None:
            spacing = _estimate_spacing(xy, m)
        scale = 0.9 * spacing / smax if smax > 0 else 0.0

    frame = Frame.of(*shown_box(m.points, window), stretch=False)
    band = 0.45
    w, h = frame.figsize()
    fig, ax = new_figure((w, h + band))
    pc = None
    if background is not None:
        pc = _background(ax, m, background, window, cmap)
    ax.add_collection(line_collection(m.outline, colors="k", linewidths=0.9))

    segs, s = cross_segments(xy, s1, s2, theta1, scale)
    drawn = np.abs(s) > 0
    colours = np.where(s < 0, COMPRESSION_COLOR, EXTENSION_COLOR)
    ax.add_collection(line_collection(segs[drawn], colors=colours[drawn], linewidths=linewidth,
                                     capstyle="butt", zorder=3))
    frame_axes(ax, frame, axis_labels, pad=0.02 if window is None else 0.0)
    titled(fig, ax, title)
    if pc is not None:
        colorbar(fig, ax, pc, background_label or "")
    _legend(fig, ax, smax, scale, stress_unit or tuple(stress_scale([smax])), linewidth)
    tight(fig, band)
    save_figure(fig, path)
    return fig


def _background(ax, m: MeshArrays, background, window, cmap):
    """The vertex values ``background`` as a filled field, its colour range that of ``window``."""
    values = np.asarray(background, dtype=float)
    vmin, vmax = window_range(m.points, values, window)
    return ax.tripcolor(_triangulation(m), values, shading="gouraud", cmap=cmap or _light_greys(),
                        vmin=vmin, vmax=vmax)


def _legend(fig, ax, smax: float, scale: float, stress_unit, linewidth: float) -> None:
    """In the band at the figure's bottom: the colours of compression and extension (left), and a reference bar
    of a round stress (``stress_unit`` = (name, Pa per unit)) drawn to the axes' scale (right)."""
    from matplotlib.lines import Line2D
    from matplotlib.offsetbox import AnchoredOffsetbox, AuxTransformBox, HPacker, TextArea

    unit_name, unit = stress_unit
    bottom = 0.12 / fig.get_size_inches()[1]
    handles = [Line2D([], [], color=COMPRESSION_COLOR, lw=2 * linewidth, label="compression (σ < 0)"),
               Line2D([], [], color=EXTENSION_COLOR, lw=2 * linewidth, label="extension (σ > 0)")]
    fig.legend(handles=handles, loc="lower left", bbox_to_anchor=(0.02, bottom), ncol=2, fontsize=8,
               frameon=False, borderaxespad=0.0)
    if smax > 0 and scale > 0:
        ref = _nice_below(smax / unit)
        length = ref * unit * scale
        line = AuxTransformBox(ax.transData)  # drawn in data lengths (the offset is left out)
        line.add_artist(Line2D([0.0, length], [0.0, 0.0], color="k", lw=linewidth, solid_capstyle="butt"))
        box = HPacker(children=[TextArea(f"bar length {ref:g} {unit_name}:", textprops={"size": 8}), line],
                      align="center", pad=0, sep=5)
        anchored = AnchoredOffsetbox(loc="lower right", child=box, pad=0.2, borderpad=0.0, frameon=False,
                                     bbox_to_anchor=(0.98, bottom), bbox_transform=fig.transFigure)
        fig.add_artist(anchored)
