"""Iso-lines of piecewise linear fields on triangles (marching triangles) and level crossings along a sampled
line: plain numpy on arrays (no mesh objects, no physics, no files).

Used for the phase boundary of the Stefan problem (the liquid fraction = 1/2 iso-line of the P1 field) and the
front probes, but nothing here knows about either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_EDGES = np.array([[0, 1], [1, 2], [2, 0]])


@dataclass
class IsoLines:
    """Segments of an iso-line: ``points`` (m x d), ``segments`` (k x 2 indices into points) and, per point, the
    mesh edge it lies on (``i0``, ``i1`` vertex numbers) with the weight ``t``: the point is
    (1 - t) p[i0] + t p[i1], so any other vertex field interpolates as (1 - t) f[i0] + t f[i1]."""

    points: np.ndarray
    segments: np.ndarray
    i0: np.ndarray
    i1: np.ndarray
    t: np.ndarray

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """A vertex field (n values) at the iso-line's points."""
        v = np.asarray(values, dtype=float)
        return (1 - self.t) * v[self.i0] + self.t * v[self.i1]

    def as_segments(self) -> np.ndarray:
        """The segments as coordinates (k x 2 x d), e.g. for a LineCollection."""
        return self.points[self.segments] if len(self.segments) else np.zeros((0, 2, self.points.shape[1]))


def iso_segments(points: np.ndarray, triangles: np.ndarray, values: np.ndarray, level: float) -> IsoLines:
    """The iso-line ``values = level`` of the linear interpolant of vertex ``values`` on ``triangles`` (t x 3
    vertex numbers into ``points``, n x d).

    A vertex counts as above the level when value >= level, so every triangle is cut by 0 or 2 of its edges and
    gives at most one segment; the crossing points are shared between neighbouring triangles (one point per
    mesh edge, or per vertex when the iso-line passes through it), so the segments join into polylines.
    Degenerate segments (both ends at one vertex) and doubled ones (along a mesh edge at the level) are dropped.
    """
    pts = np.asarray(points, dtype=float)
    tris = np.asarray(triangles, dtype=int).reshape(-1, 3)
    v = np.asarray(values, dtype=float)
    empty = IsoLines(np.zeros((0, pts.shape[1])), np.zeros((0, 2), dtype=int), np.zeros(0, dtype=int),
                     np.zeros(0, dtype=int), np.zeros(0))
    if len(tris) == 0:
        return empty
    above = v[tris] >= level
    count = above.sum(axis=1)
    cut = (count == 1) | (count == 2)
    if not cut.any():
        return empty
    tris, above = tris[cut], above[cut]
    crosses = above[:, _EDGES[:, 0]] != above[:, _EDGES[:, 1]]          # (c, 3), two True per row
    which = np.argsort(~crosses, axis=1, kind="stable")[:, :2]           # the two crossing edges of each row
    a = np.take_along_axis(tris, _EDGES[which][..., 0], axis=1)          # (c, 2) edge end vertices
    b = np.take_along_axis(tris, _EDGES[which][..., 1], axis=1)
    i0, i1 = np.minimum(a, b).ravel(), np.maximum(a, b).ravel()
    t = (level - v[i0]) / (v[i1] - v[i0])
    # one key per crossing point: the edge, or the vertex when the crossing is at one
    at0, at1 = t <= 0.0, t >= 1.0
    k0 = np.where(at0, i0, np.where(at1, i1, i0))
    k1 = np.where(at0 | at1, -1, i1)
    keys = np.column_stack([k0, k1])
    uniq, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    j0, j1 = i0[first], i1[first]
    tt = np.clip(t[first], 0.0, 1.0)
    segs = inverse.reshape(-1, 2)
    segs = segs[segs[:, 0] != segs[:, 1]]
    if len(segs):
        segs = np.unique(np.sort(segs, axis=1), axis=0)
    out_pts = (1 - tt)[:, None] * pts[j0] + tt[:, None] * pts[j1]
    return IsoLines(out_pts, segs.astype(int), j0, j1, tt)


def first_crossing(s: np.ndarray, values: np.ndarray, level: float) -> float | None:
    """The first s where ``values`` (sampled at increasing ``s``) crosses ``level``, by linear interpolation
    between the samples on either side; samples that are NaN (e.g. outside the mesh) are skipped. The side of
    the first valid sample (value >= level: above) is where the crossing starts from. None when there is no
    crossing (or no valid sample)."""
    s = np.asarray(s, dtype=float)
    v = np.asarray(values, dtype=float)
    ok = np.isfinite(v)
    s, v = s[ok], v[ok]
    if len(v) < 2:
        return None
    side = v >= level
    change = np.nonzero(side[1:] != side[0])[0]
    if len(change) == 0:
        return None
    j = int(change[0]) + 1
    a, b = v[j - 1], v[j]
    w = (level - a) / (b - a) if b != a else 0.0
    return float(s[j - 1] + w * (s[j] - s[j - 1]))
