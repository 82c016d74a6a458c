"""Quadrature on a contact interface with non-matching sides, possibly apart (an open gap): points on the
master side Gamma_m with their weights, the values of a space's basis functions of both sides there, and the
P1 hat functions of the master side's vertices.

An interface term such as the contact conductance

    int_Gamma_m w h(x) (T_m - T_s)(v_m - v_s) ds,                 w = 1 (plane, 3D) or r (axisymmetric),

is then J^T diag(weights h) J with J = master - minion (nq x ndof), and a quantity given at the master vertices
(a nodal contact pressure, gap, conductance) is ``nodal`` @ values at the points. The points are placed as in
the segment-based mortar integrals (:mod:`ngs_geomech.fem.mortar`): in 2D every master segment is cut where the
minion nodes project onto it and each piece gets a Gauss rule of ``order + 2`` points; in 3D the master triangles
are clipped against the minion triangles projected onto their plane. The partner of a master point is its closest
point on the minion element opposite (in 2D the nearest one where several minion segments project onto the same
piece, e.g. across a wide reach); ``distance`` holds |x_s - x_m| (m), the geometric gap where the sides are
apart. Points whose partner lies farther than ``reach`` (m) have none: they are left out (no heat crosses there)
and ``covered`` is the fraction of the master side that has a partner. 3D assumes one layer of minion triangles
opposite each master triangle within the reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .mortar import Segment, Triangle, overlap_points


@dataclass
class InterfaceQuadrature:
    """Points on the master side (module docstring).

    ``weights`` (nq,): quadrature weight times the surface element (m in 2D, times r in axisymmetric scenes:
    m^2 per radian; m^2 in 3D); ``points`` (nq, dim), m; ``master``, ``minion``: (nq x ndof) values of the space's
    basis functions on the two sides; ``nodal``: (nq x nv) the P1 hat functions of the master side's vertices
    (columns: mesh vertex numbers); ``distance`` (nq,), m; ``vertices``: the master side's vertex numbers;
    ``covered``: the fraction of the master side (by measure, without w) that has a partner; ``touching`` (nq,):
    the partner lies within half an element (the sides touch there up to the discretization of the geometry)."""

    weights: np.ndarray
    points: np.ndarray
    master: sp.csr_matrix
    minion: sp.csr_matrix
    nodal: sp.csr_matrix
    distance: np.ndarray
    vertices: np.ndarray
    covered: float
    touching: np.ndarray
    area: float = 0.0
    """The master side's measure (m in 2D, m^2 in 3D; without w): the weight of ``covered`` when quadratures of
    the parts of a distributed mesh are joined (:func:`join`)."""

    @property
    def jump(self) -> sp.csr_matrix:
        """T_m - T_s at the points (nq x ndof)."""
        return (self.master - self.minion).tocsr()

    @property
    def size(self) -> int:
        return len(self.weights)


class _Rows:
    """COO lists of the three point matrices, one row per accepted point."""

    def __init__(self):
        self.w, self.pts, self.dist, self.near = [], [], [], []
        self.coo = {"master": ([], [], []), "minion": ([], [], []), "nodal": ([], [], [])}

    def add(self, wt: float, p, d: float, master, minion, nodal, near: bool) -> None:
        q = len(self.w)
        self.w.append(wt)
        self.pts.append(np.asarray(p, dtype=float))
        self.dist.append(d)
        self.near.append(bool(near))
        for key, (vals, dofs) in (("master", master), ("minion", minion), ("nodal", nodal)):
            rows, cols, data = self.coo[key]
            for v, dof in zip(np.asarray(vals, dtype=float).ravel(), dofs):
                if dof >= 0 and v != 0.0:
                    rows.append(q)
                    cols.append(int(dof))
                    data.append(float(v))

    def finish(self, ndof: int, nv: int, dim: int, vertices, covered: float, area: float = 0.0,
               numbering=None) -> InterfaceQuadrature:
        """The quadrature; with ``numbering`` (a GlobalDofs of the space) the master and nodal columns (this part's
        dofs and vertices) are given in its global numbering and ``ndof``, ``nv`` are the global counts."""
        nq = len(self.w)

        def matrix(key, ncols, local: bool):
            rows, cols, data = self.coo[key]
            if numbering is not None and local:
                cols = numbering.scalar[np.asarray(cols, dtype=int)]
            return sp.csr_matrix((data, (rows, cols)), shape=(nq, ncols))
        if numbering is not None:
            vertices = numbering.scalar[np.asarray(sorted(vertices), dtype=int)] if vertices else []
        return InterfaceQuadrature(np.array(self.w), np.array(self.pts).reshape(nq, dim),
                                   matrix("master", ndof, True), matrix("minion", ndof, False),
                                   matrix("nodal", nv, True), np.array(self.dist),
                                   np.array(sorted(vertices), dtype=int), covered, np.array(self.near, dtype=bool),
                                   area)


def join(parts: list[InterfaceQuadrature]) -> InterfaceQuadrature:
    """The quadratures of the parts of a distributed mesh (each in the global numbering) as one, in part order."""
    area = sum(q.area for q in parts)
    covered = sum(q.covered * q.area for q in parts) / area if area > 0 else 0.0
    def stack(key):
        return sp.vstack([getattr(q, key) for q in parts]).tocsr()
    return InterfaceQuadrature(np.concatenate([q.weights for q in parts]), np.concatenate([q.points for q in parts]),
                               stack("master"), stack("minion"), stack("nodal"),
                               np.concatenate([q.distance for q in parts]),
                               np.unique(np.concatenate([q.vertices for q in parts])).astype(int), covered,
                               np.concatenate([q.touching for q in parts]), area)


def _outward(mesh, nr: int, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centroid, unit outward normal) of boundary element ``nr`` with the vertex coordinates ``corners``: the
    normal of its (flat) element pointing away from the volume element behind it."""
    el = mesh[ngs.ElementId(ngs.BND, nr)]
    node = el.edges[0] if mesh.dim == 2 else el.faces[0]
    vol = mesh[mesh[node].elements[0]]
    inner = np.mean([mesh[v].point[:mesh.dim] for v in vol.vertices], axis=0)
    c = corners.mean(axis=0)
    if mesh.dim == 2:
        d = corners[1] - corners[0]
        n = np.array([-d[1], d[0]])
    else:
        n = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    n = n / np.linalg.norm(n)
    return c, (n if float(np.dot(n, c - inner)) >= 0 else -n)


def _in_front(cm: np.ndarray, nm: np.ndarray, cs: np.ndarray, size: float) -> bool:
    """Whether a minion element with centroid ``cs`` lies on the outer side of a master element (centroid ``cm``,
    outward normal ``nm``, size ``size``), up to half its size (touching sides of curved interfaces cross): the
    elements behind it (the far side of a canister) are not its partners."""
    return float(np.dot(cs - cm, nm)) >= -0.5 * size


def interface_quadrature(mesh, V, master: str, minion: str, *, order: int, axisymmetric: bool = False,
                         reach: float | None = None, minions: list | None = None, numbering=None,
                         elements: list[int] | None = None) -> InterfaceQuadrature:
    """The points of the interface between the boundaries ``master`` and ``minion`` (module docstring) for the
    scalar space ``V``, exact for polynomials of degree ``order`` on each piece (flat elements). ``reach`` (m): the
    largest distance to a partner point (None: half an element, the sides touch).

    On a distributed mesh: ``minions`` the minion side of all parts (:mod:`ngs_geomech.fem.gathered`), ``elements``
    the master elements this part integrates and ``numbering`` (a GlobalDofs of V): this part's points in the
    global numbering (the caller checks the sides of the whole mesh and joins the parts, :func:`join`)."""
    if minions is None:
        for side in (master, minion):
            if not list(mesh.Boundaries(side).Elements()):
                raise ValueError(f"contact interface side {side!r} has no boundary elements")
    P1 = ngs.H1(mesh, order=1)
    sel = (minions, numbering, elements)
    if mesh.dim == 2:
        return _quadrature_2d(mesh, V, P1, master, minion, order, axisymmetric, reach, *sel)
    return _quadrature_3d(mesh, V, P1, master, minion, order, reach, *sel)


def _masters(mesh, master: str, elements) -> list:
    """This part's master elements (those numbered in ``elements`` when given)."""
    els = list(mesh.Boundaries(master).Elements())
    return els if elements is None else [el for el in els if el.nr in set(elements)]


def _sizes(mesh, V, numbering) -> tuple[int, int]:
    """(columns of the point matrices, columns of the nodal matrix): local, or global with ``numbering``."""
    return (V.ndof, mesh.nv) if numbering is None else (numbering.n_scalar, numbering.n_scalar)


def _quadrature_2d(mesh, V, P1, master, minion, order, axisymmetric, reach, minions=None, numbering=None,
                   elements=None) -> InterfaceQuadrature:
    masters = [Segment(mesh, V, el.nr) for el in _masters(mesh, master, elements)]
    if minions is None:
        minions = [Segment(mesh, V, el.nr) for el in mesh.Boundaries(minion).Elements()]
    gx, gw = np.polynomial.legendre.leggauss(order + 2)
    gx, gw = (gx + 1) / 2, gw / 2
    lengths = [float(np.linalg.norm(s.p1 - s.p0)) for s in minions]
    mins = np.array([np.minimum(s.p0, s.p1) for s in minions])
    maxs = np.array([np.maximum(s.p0, s.p1) for s in minions])
    rows = _Rows()
    covered = total = 0.0
    vertices = set()
    for sm in masters:
        fe1, dofs1 = P1.GetFE(sm.ei), list(P1.GetDofNrs(sm.ei))
        vertices.update(dofs1)
        pad = max(0.25 * float(np.linalg.norm(sm.p1 - sm.p0)), reach or 0.0)
        lo, hi = np.minimum(sm.p0, sm.p1) - pad, np.maximum(sm.p0, sm.p1) + pad
        total += sum(gw[k] * sm.speed(gx[k]) for k in range(len(gx)))
        cm, nm = _outward(mesh, sm.ei.nr, np.array([sm.p0, sm.p1]))
        size = float(np.linalg.norm(sm.p1 - sm.p0))
        cand = [j for j in np.where(np.all(mins <= hi, axis=1) & np.all(maxs >= lo, axis=1))[0]
                if _in_front(cm, nm, 0.5 * (minions[j].p0 + minions[j].p1), size)]
        for s0, s1, j in _pieces(sm, [minions[j] for j in cand], cand):
            ss = minions[j]
            near = 0.5 * max(0.25 * float(np.linalg.norm(sm.p1 - sm.p0)), lengths[j])
            limit = reach if reach is not None else near + 1e-12
            for xq, wq in zip(gx, gw):
                s = s0 + (s1 - s0) * xq
                p = sm.point(s)
                t = ss.locate(p)
                d = float(np.linalg.norm(ss.point(t) - p))
                if d > limit:
                    continue
                ds = wq * (s1 - s0) * sm.speed(s)
                covered += ds
                rows.add(ds * (p[0] if axisymmetric else 1.0), p, d, (sm.shape(s), sm.dofs),
                         (ss.shape(t), ss.dofs), (fe1.CalcShape(s), dofs1), d <= near + 1e-12)
    return rows.finish(*_sizes(mesh, V, numbering), 2, vertices, covered / total if total > 0 else 0.0, total,
                       numbering)


def _pieces(sm: Segment, cands: list[Segment], index) -> list[tuple[float, float, int]]:
    """The master segment ``sm`` cut where the candidate minion segments' ends project onto it: (s0, s1, the index
    of the nearest minion segment whose projection covers the piece) per piece that one covers."""
    spans = [tuple(sorted((sm.locate(ss.p0), sm.locate(ss.p1)))) for ss in cands]
    cuts = sorted({0.0, 1.0, *[x for span in spans for x in span]})
    out = []
    for s0, s1 in zip(cuts, cuts[1:]):
        if s1 - s0 <= 1e-12:
            continue
        mid = 0.5 * (s0 + s1)
        p = sm.point(mid)
        best, dist = None, np.inf
        for ss, (a, b), j in zip(cands, spans, index):
            if a - 1e-12 <= mid <= b + 1e-12 and b - a > 1e-12:
                d = float(np.linalg.norm(ss.point(ss.locate(p)) - p))
                if d < dist:
                    best, dist = j, d
        if best is not None:
            out.append((s0, s1, int(best)))
    return out


def _quadrature_3d(mesh, V, P1, master, minion, order, reach, minions=None, numbering=None,
                   elements=None) -> InterfaceQuadrature:
    masters = [Triangle(mesh, V, el.nr) for el in _masters(mesh, master, elements)]
    if minions is None:
        minions = [Triangle(mesh, V, el.nr) for el in mesh.Boundaries(minion).Elements()]
    ir = ngs.IntegrationRule(ngs.TRIG, 2 * order + 2)
    qp = np.array([(p[0], p[1]) for p in ir.points])
    qw = np.array(list(ir.weights))
    mins = np.array([t.corners.min(axis=0) for t in minions])
    maxs = np.array([t.corners.max(axis=0) for t in minions])
    rows = _Rows()
    covered = total = 0.0
    vertices = set()
    for tm in masters:
        fe1, dofs1 = P1.GetFE(tm.ei), list(P1.GetDofNrs(tm.ei))
        vertices.update(dofs1)
        pad = max(0.1 * math.sqrt(tm.area2), reach or 0.0)
        near = 0.5 * math.sqrt(tm.area2)
        limit = reach if reach is not None else near + 1e-12
        lo, hi = tm.corners.min(axis=0) - pad, tm.corners.max(axis=0) + pad
        total += tm.area2 / 2
        cm, nm = _outward(mesh, tm.ei.nr, tm.corners)
        for j in np.where(np.all(mins <= hi, axis=1) & np.all(maxs >= lo, axis=1))[0]:
            ts = minions[j]
            if abs(float(np.dot(ts.normal, tm.normal))) < 0.5 or \
                    not _in_front(cm, nm, ts.corners.mean(axis=0), math.sqrt(tm.area2)):
                continue  # not opposite (another face of the interface, or behind the master triangle)
            for ref, p, wt in overlap_points(tm, ts, qp, qw):
                rs = ts.reference(p)
                d = float(np.linalg.norm(ts.p0 + ts.J @ rs - p))
                if d > limit:
                    continue
                covered += wt
                rows.add(wt, p, d, (tm.fe.CalcShape(ref[0], ref[1]), tm.dofs),
                         (ts.fe.CalcShape(rs[0], rs[1]), ts.dofs), (fe1.CalcShape(ref[0], ref[1]), dofs1),
                         d <= near + 1e-12)
    return rows.finish(*_sizes(mesh, V, numbering), 3, vertices, covered / total if total > 0 else 0.0, total,
                       numbering)
