"""Discrete contact operators of problem (P): non-penetration and friction on Gamma_c^kl (2.23)-(2.27) between
two bodies with independent, non-matching meshes (2D: plane and axisymmetric).

Small deformations (the seed's setting): the contact geometry is that of the reference configuration, so the
operators are constant matrices. Mortar discretization with the traction as multiplier on the contact side
S (the interface's ``master`` block side; the other side O is the opposite): dual (biorthogonal) piecewise
linear multipliers (Wohlmuth)

    p = sum_j lam_n,j psi_j   (normal pressure, Pa, compression positive: the contact force on S is -p n),
    q = sum_j lam_t,j psi_j   (tangential traction, Pa: the force on S is -q t),

psi_j = 2 phi_j - phi_k on each segment (weighted by w ds), so int_S w psi_j phi_k ds = delta_jk weight_j:
lam_j are nodal tractions and the conditions decouple node by node (with the standard hat functions phi_j
the nodal pressures of the Hertz test oscillated by +-10 %). phi_j is the hat function of vertex j of S
(also for P2 displacements), n the outward unit normal of S's body,
t = (-n_y, n_x). A point x of S sees the point x_o of O where the ray x + g n meets O; g0(x) = (x_o - x).n is
the initial gap. The weighted gap and slip of node j (m^2 plane, m^3 axisymmetric: w = r)

    g_j = int_S w psi_j (g0 + (u(x_o) - u(x)).n) ds = g0_j + (Bn u)_j,
    s_j = int_S w psi_j (u(x_o) - u(x)).t ds         = (Bt u)_j,

enter the nodal complementarity conditions (2.23)-(2.26): g_j >= 0, lam_n,j >= 0, g_j lam_n,j = 0 and
|lam_t,j| <= bound_j (Tresca g_c(x_j), Coulomb F_c lam_n,j) with s_j = 0 where |lam_t,j| < bound_j, and
lam_t,j s_j <= 0 (the traction opposes the slip). The equilibrium reads K u = f + Bn^T lam_n + Bt^T lam_t.

The integrals are split where O's nodes project onto S (segment-based, as in :mod:`.mortar`), so each piece
integrates polynomials; curved sides (order >= 2 geometry) use their mapped points and normals.
"""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import numpy.polynomial.polynomial as npp
import scipy.sparse as sp

from .. import parallel
from ..fem.mortar import Segment, SegmentCurve


@dataclass
class ContactOperator:
    """The discrete operators of one contact interface (see the module docstring).

    ``nodes``: mesh vertex numbers of S's multiplier nodes; ``coords`` (m x 2, m); ``Bn``, ``Bt``: sparse
    (m x ndof of the vector space); ``g0``: weighted initial gaps (m x 1); ``weight``: int_S w phi_j ds (so
    g_j / weight_j is a nodal gap in m, and sum_j lam_j weight_j = int_S w p ds); ``length``: int_S phi_j ds
    (m, the nodal mesh size); ``coverage``: the fraction of int_S w phi_j ds whose rays meet O (the solver
    constrains only fully covered nodes); ``search_distance``: the largest |g0| seen (m; the default's value
    when none was given)."""

    name: str
    side: str
    opposite: str
    nodes: np.ndarray
    coords: np.ndarray
    Bn: sp.csr_matrix
    Bt: sp.csr_matrix
    g0: np.ndarray
    weight: np.ndarray
    length: np.ndarray
    coverage: np.ndarray
    Bt2: sp.csr_matrix | None = None
    search_distance: float | None = None

    @property
    def size(self) -> int:
        return len(self.nodes)

    @property
    def constrained(self) -> np.ndarray:
        """The nodes a solver constrains (bool per node): those whose whole support is covered by the opposite
        side (the dual multipliers need the whole support projected)."""
        return self.coverage > 1.0 - 1e-6


def _ray_hit(seg: Segment, p: np.ndarray, n: np.ndarray) -> tuple[float, float] | None:
    """(gap g, reference coordinate t) where the ray p + g n meets ``seg``, or None (parallel / misses)."""
    q0, q1 = seg.p0, seg.p1
    d = q1 - q0
    A = np.array([[n[0], -d[0]], [n[1], -d[1]]])
    det = float(np.linalg.det(A))
    if abs(det) < 1e-14 * float(np.dot(d, d)):
        return None
    g, t = np.linalg.solve(A, q0 - p)
    if seg.curved:   # Newton on cross(q(t) - p, n) = 0
        for _ in range(10):
            e = 1e-7
            ta, tb = max(t - e, 0.0), min(t + e, 1.0)
            if not 0.0 <= t <= 1.0:
                break
            q = seg.point(t)
            dq = (seg.point(tb) - seg.point(ta)) / (tb - ta)
            F = (q[0] - p[0]) * n[1] - (q[1] - p[1]) * n[0]
            dF = dq[0] * n[1] - dq[1] * n[0]
            if abs(dF) < 1e-300:
                break
            step = F / dF
            t -= step
            if abs(step) < 1e-13:
                break
        if -1e-9 <= t <= 1 + 1e-9:
            t = min(max(t, 0.0), 1.0)
            g = float(np.dot(seg.point(t) - p, n))
    if not -1e-9 <= t <= 1 + 1e-9:
        return None
    return float(g), float(min(max(t, 0.0), 1.0))


def _outward_signs(mesh, side: str, segments) -> tuple[list[float], int]:
    """(+1 or -1 per boundary element of ``side``: the factor that makes NGSolve's normal point out of the body
    the element bounds, the number of elements without a volume element of this part behind them: +1). (The
    normal of a boundary segment follows the segment's orientation; on the copied sides of a contact interface
    it pointed into the body for one of the two blocks, which turned contact into adhesion.)"""
    els = list(mesh.Boundaries(side).Elements())
    wanted = {frozenset(v.nr for v in el.vertices) for el in els}
    centroid = {}
    for el in mesh.Elements(ngs.VOL):
        vs = [v.nr for v in el.vertices]
        for a in range(len(vs)):
            key = frozenset((vs[a], vs[(a + 1) % len(vs)]))
            if key in wanted:
                centroid[key] = np.mean([mesh[v].point[:2] for v in el.vertices], axis=0)
    nrm = ngs.specialcf.normal(2)
    out, missing = [], 0
    for el, sg in zip(els, segments):
        c = centroid.get(frozenset(v.nr for v in el.vertices))
        missing += c is None
        mip = sg.trafo(0.5)
        n = np.array(nrm(mip)).ravel()[:2]
        p = np.array([ngs.x(mip), ngs.y(mip)])
        out.append(-1.0 if c is not None and float(np.dot(n, c - p)) > 0 else 1.0)
    return out, missing


def scalar_space(mesh, V, dim: int, message: str):
    """(order, the scalar H1 space of V's shapes and dofs, its ndof ns): component c of the VectorH1 space ``V``
    has dof c * ns + the scalar dof. ``message``: the error when ``V`` is not a ``dim``-component VectorH1."""
    order = V.globalorder
    S = ngs.H1(mesh, order=order)
    ns = S.ndof
    if V.ndof != dim * ns:
        raise ValueError(message)
    return order, S, ns


def foundation_plane(name: str, obstacle: tuple | None, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """(a point of the rigid foundation, its outward unit normal) from ``obstacle`` = (point, normal); plane
    scenes (``dim`` 2) take the first two components of each."""
    if obstacle is None:
        raise ValueError(f"contact interface {name!r}: neither an opposite side nor a rigid foundation")
    if dim == 2:
        q_ob = np.asarray(obstacle[0], dtype=float)[:2]
        n_ob = np.asarray(obstacle[1], dtype=float)[:2]
        return q_ob, n_ob / np.linalg.norm(n_ob)
    q_ob = np.asarray(obstacle[0], dtype=float).ravel()
    n_ob = np.asarray(obstacle[1], dtype=float).ravel()
    if q_ob.shape != (dim,) or n_ob.shape != (dim,) or not np.linalg.norm(n_ob) > 0:
        raise ValueError(f"contact interface {name!r}: the foundation needs a point and a nonzero normal with "
                         f"{dim} components, got {obstacle!r}")
    return q_ob, n_ob / np.linalg.norm(n_ob)


def default_search_distance(points: np.ndarray) -> float:
    """The default search distance (m): a quarter of the extent of the contact side's ``points`` (k, dim)."""
    return 0.25 * float(np.max(np.ptp(points, axis=0)))


def mortar_matrix(rows: np.ndarray, cols: np.ndarray, vals: np.ndarray, shape: tuple[int, int]) -> sp.csr_matrix:
    """The sparse operator of the COO entries (rows, cols, vals), duplicates summed."""
    B = sp.coo_matrix((vals, (rows, cols)), shape=shape).tocsr()
    B.sum_duplicates()
    return B


def covered_fraction(covered: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """``coverage`` of :class:`ContactOperator`: covered / weight, 0 where the weight vanishes."""
    return np.divide(covered, weight, out=np.zeros(len(weight)), where=weight > 0)


def _side_nodes(mesh, side: str, sides: list[Segment]):
    """The multiplier nodes of the contact side: (mesh vertex numbers (m,), coordinates (m, 2), per segment the
    node numbers at its reference coordinates s = 0 and s = 1)."""
    vert: dict[int, int] = {}
    seg_nodes = []
    for el, sg in zip(mesh.Boundaries(side).Elements(), sides):
        vs = [v.nr for v in el.vertices]
        pts = [np.array(mesh[v].point) for v in el.vertices]
        # which vertex sits at s = 0
        if np.linalg.norm(pts[0] - sg.p0) > np.linalg.norm(pts[1] - sg.p0):
            vs = vs[::-1]
        for v in vs:
            vert.setdefault(v, len(vert))
        seg_nodes.append((vert[vs[0]], vert[vs[1]]))
    coords = np.zeros((len(vert), 2))
    for v, j in vert.items():
        coords[j] = mesh[ngs.NodeId(ngs.VERTEX, v)].point[:2]
    return np.array(list(vert), dtype=int), coords, seg_nodes


class _SampledSegment(SegmentCurve):
    """A boundary segment as numbers (gathered from the parts of a distributed mesh): the monomial coefficients
    of its map x(s) (``geo`` (q + 1, 2), the lattice interpolant of NGSolve's map, exact for polynomial maps of
    degree <= q) and of its shapes (``shp`` (order + 1, nloc)), its global scalar dofs, whether it is curved and
    ``turn`` (+1 or -1: the outward normal is turn (x'_y, -x'_x) / |x'|)."""

    def __init__(self, geo: np.ndarray, shp: np.ndarray, dofs: np.ndarray, curved: bool, turn: float):
        self.geo, self.shp, self.dofs, self.curved, self.turn = geo, shp, [int(d) for d in dofs], curved, turn
        self.p0, self.p1 = self.point(0.0), self.point(1.0)

    def point(self, s: float) -> np.ndarray:
        return npp.polyval(s, self.geo)

    def shape(self, s: float) -> np.ndarray:
        return npp.polyval(s, self.shp)

    def speed(self, s: float) -> float:
        """|dx/ds| (m per unit reference length) of the polynomial map (the serial :class:`.mortar.Segment` takes a
        central difference of step 1e-6 on curved segments: the two differ by its round-off, ~1e-10 relative)."""
        return float(np.linalg.norm(npp.polyval(s, npp.polyder(self.geo))))

    def frame(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(the point, the outward unit normal (2,)) at the reference coordinate s."""
        d = npp.polyval(s, npp.polyder(self.geo))
        n = self.turn * np.array([d[1], -d[0]])
        return self.point(s), n / np.linalg.norm(n)


def _segment_arrays(mesh, S, name: str, order: int, numbering) -> dict:
    """This part's segments of the boundary ``name`` as the arrays of :class:`_SampledSegment` (global dofs
    through ``numbering``), with ``ends`` (the global vertex numbers at s = 0, 1), their points ``at`` (k, 2, 2)
    and ``missing`` (segments without the volume element behind them on this part)."""
    q = max(order, mesh.GetCurveOrder(), 1)
    lat, lat_u = np.linspace(0.0, 1.0, q + 1), np.linspace(0.0, 1.0, order + 1)
    sides = [Segment(mesh, S, el.nr) for el in mesh.Boundaries(name).Elements()]
    signs, missing = _outward_signs(mesh, name, sides)
    out = {"geo": np.zeros((0, q + 1, 2)), "shp": np.zeros((0, order + 1, order + 1)),
           "dofs": np.zeros((0, order + 1), dtype=int), "curved": np.zeros(0, dtype=bool), "turn": np.zeros(0),
           "ends": np.zeros((0, 2), dtype=int), "at": np.zeros((0, 2, 2)), "missing": missing}
    if not sides:
        return out
    geo = np.array([npp.polyfit(lat, np.array([sg.point(t) for t in lat]), q) for sg in sides])
    shp = np.array([npp.polyfit(lat_u, np.array([sg.shape(t) for t in lat_u]), order) for sg in sides])
    turn, ends, at = [], [], []
    for el, sg, sign, c in zip(mesh.Boundaries(name).Elements(), sides, signs, geo):
        d = npp.polyval(0.5, npp.polyder(c))
        turn.append(1.0 if float(np.dot(sign * sg.frame(0.5)[1], [d[1], -d[0]])) > 0 else -1.0)
        vs = [v.nr for v in el.vertices]
        pts = [np.array(mesh[v].point)[:2] for v in el.vertices]
        if np.linalg.norm(pts[0] - sg.p0) > np.linalg.norm(pts[1] - sg.p0):     # the vertex at s = 0 first
            vs, pts = vs[::-1], pts[::-1]
        ends.append(numbering.scalar[vs])
        at.append(pts)
    out.update(geo=geo, shp=shp, dofs=numbering.scalar[np.array([sg.dofs for sg in sides], dtype=int)],
               curved=np.array([sg.curved for sg in sides]), turn=np.array(turn), ends=np.array(ends),
               at=np.array(at))
    return out


def _gathered_segments(mesh, S, name: str, order: int, numbering) -> tuple[list, dict]:
    """The segments of the boundary ``name`` of all parts of a distributed mesh, gathered in rank order onto every
    rank (a segment found on two parts counted once): (:class:`_SampledSegment` list, their arrays)."""
    parts = parallel.allgather(mesh, _segment_arrays(mesh, S, name, order, numbering))
    held = [p for p in parts if len(p["ends"])] or parts[:1]       # the parts' curve orders may differ
    a = {k: np.concatenate([p[k] for p in held]) for k in parts[0] if k != "missing"}
    a["missing"] = sum(p["missing"] for p in parts)
    if len(a["ends"]):
        keep = np.sort(np.unique(np.sort(a["ends"], axis=1), axis=0, return_index=True)[1])
        a = {k: (v[keep] if k != "missing" else v) for k, v in a.items()}
    return [_SampledSegment(*args) for args in zip(a["geo"], a["shp"], a["dofs"], a["curved"], a["turn"])], a


def _gathered_sides(name: str, mesh, S, side: str, opposite: str | None, order: int, numbering):
    """(sides, their outward signs, nodes, coords, per segment its nodes, opposite segments) of a distributed
    mesh, as :func:`_side_nodes` gives them on a serial one (``nodes``: global vertex numbers)."""
    sides, a = _gathered_segments(mesh, S, side, order, numbering)
    opps = [] if opposite is None else _gathered_segments(mesh, S, opposite, order, numbering)[0]
    if sides and a["missing"]:
        raise ValueError(f"contact interface {name!r}: the volume element behind a segment of {side!r} lies on "
                         "another part of the distributed mesh")
    vert: dict[int, int] = {}
    coords, seg_nodes = [], []
    for (v0, v1), pts in zip(a["ends"], a["at"]):
        for v, p in ((v0, pts[0]), (v1, pts[1])):
            if int(v) not in vert:
                vert[int(v)] = len(vert)
                coords.append(p)
        seg_nodes.append((vert[int(v0)], vert[int(v1)]))
    return (sides, [1.0] * len(sides), np.array(list(vert), dtype=int), np.array(coords).reshape(-1, 2),
            seg_nodes, opps)


class _Opposite2D:
    """What the rays of the contact side meet: the segments of the opposite side O, or (``plane`` = (point,
    outward unit normal)) a rigid straight foundation; rays longer than ``reach`` (m) are ignored."""

    def __init__(self, opps: list[Segment], plane: tuple | None, reach: float):
        self.opps, self.plane, self.reach = opps, plane, reach
        self.omin = np.array([np.minimum(o.p0, o.p1) for o in opps]).reshape(-1, 2)
        self.omax = np.array([np.maximum(o.p0, o.p1) for o in opps]).reshape(-1, 2)

    def candidates(self, sg: Segment) -> np.ndarray:
        """The O segments whose bounding boxes come within ``reach`` of the segment ``sg``."""
        lo, hi = np.minimum(sg.p0, sg.p1), np.maximum(sg.p0, sg.p1)
        reach = self.reach
        return np.where(np.all(self.omin <= hi + reach, axis=1) & np.all(self.omax >= lo - reach, axis=1))[0]

    def cuts(self, sg: Segment, cand: np.ndarray) -> list[float]:
        """The reference coordinates of ``sg`` splitting it where the nodes of the candidates project onto it."""
        cuts = {0.0, 1.0}
        for k in cand:
            for q in (self.opps[k].p0, self.opps[k].p1):
                s = sg.locate(q)
                if 0.0 < s < 1.0:
                    cuts.add(s)
        return sorted(cuts)

    def nearest(self, p: np.ndarray, n: np.ndarray, cand: np.ndarray) -> tuple[float, float, int] | None:
        """(gap g, reference coordinate t on O, O segment or -1 for the foundation) of the nearest crossing of the
        ray p + g n within ``reach``, or None."""
        best = None
        if self.plane is not None:
            q_ob, n_ob = self.plane
            nn = float(np.dot(n, n_ob))
            if nn < -1e-12:   # facing the foundation
                g = float(np.dot(q_ob - p, n_ob)) / nn
                if abs(g) <= self.reach:
                    best = (g, 0.0, -1)
        for k in cand:
            hit = _ray_hit(self.opps[k], p, n)
            if hit is not None and abs(hit[0]) <= self.reach and (best is None or abs(hit[0]) < abs(best[0])):
                best = (hit[0], hit[1], k)
        return best

    def shapes(self, k: int, t: float) -> tuple[list, np.ndarray]:
        """(scalar dofs, shape values) of O at the point t of its segment ``k`` (none for the foundation)."""
        if k < 0:
            return [], np.zeros(0)
        return self.opps[k].dofs, self.opps[k].shape(t)


class _Mortar2D:
    """The sums of the 2D mortar integrals (module docstring) of one contact side, segment by segment: the COO
    entries of Bn and Bt and the nodal g0, weight, length and covered weight of ``m`` multiplier nodes."""

    def __init__(self, m: int, ns: int, order: int, axisymmetric: bool):
        gx, gw = np.polynomial.legendre.leggauss(order + 3)
        self.gx, self.gw = (gx + 1) / 2, gw / 2
        self.ns, self.axisymmetric = ns, axisymmetric
        self.rows, self.cols, self.vn, self.vt = [], [], [], []
        self.g0, self.weight, self.length, self.covered = (np.zeros(m) for _ in range(4))

    def dual_basis(self, sg: Segment) -> np.ndarray:
        """The dual (biorthogonal) basis on the segment: psi_a = sum_b A_ab phi_b with
        int psi_a phi_b w ds = delta_ab D_a; returns A."""
        Me = np.zeros((2, 2))
        for xq, wq in zip(self.gx, self.gw):
            pq = sg.point(xq)
            wt = wq * sg.speed(xq) * (pq[0] if self.axisymmetric else 1.0)
            ph = np.array([1.0 - xq, xq])
            Me += wt * np.outer(ph, ph)
        return np.diag(Me.sum(axis=1)) @ np.linalg.inv(Me)

    def add_segment(self, sg: Segment, nodes: tuple[int, int], sign: float, opposite: _Opposite2D) -> None:
        """Integrate over the segment ``sg`` (its multiplier ``nodes`` at s = 0, 1; ``sign`` the factor of its
        outward normal), piece by piece between the projections of O's nodes."""
        dual = self.dual_basis(sg)
        cand = opposite.candidates(sg)
        cuts = opposite.cuts(sg, cand)
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b - a <= 1e-12:
                continue
            for xq, wq in zip(self.gx, self.gw):
                s = a + (b - a) * xq
                p, n = sg.frame(s)
                n = sign * n / np.linalg.norm(n)
                wt = wq * (b - a) * sg.speed(s) * (p[0] if self.axisymmetric else 1.0)
                phi = (1.0 - s, s)
                for j, ph in zip(nodes, phi):
                    self.weight[j] += wt * ph
                    self.length[j] += wq * (b - a) * sg.speed(s) * ph
                best = opposite.nearest(p, n, cand)
                if best is not None:
                    self.add_point(sg, nodes, dual @ np.array(phi), s, wt, n, best, opposite)

    def add_point(self, sg: Segment, nodes: tuple[int, int], psi: np.ndarray, s: float, wt: float, n: np.ndarray,
                  hit: tuple[float, float, int], opposite: _Opposite2D) -> None:
        """The integrands of g0, Bn and Bt at the point s of ``sg`` (quadrature weight ``wt``, dual shapes ``psi``
        of its ``nodes``, unit normal ``n``) whose ray meets O at ``hit`` = (g, t, k)."""
        g, t, k = hit
        tvec = np.array([-n[1], n[0]])
        NS = sg.shape(s)
        odofs, NO = opposite.shapes(k, t)
        for j, ph, ps in zip(nodes, (1.0 - s, s), psi):
            self.covered[j] += wt * ph
            c = wt * ps
            self.g0[j] += c * g
            for comp in range(2):
                off = comp * self.ns
                dofs = [off + d for d in odofs] + [off + d for d in sg.dofs]
                shp = np.concatenate([NO, -NS]) * c
                self.rows += [j] * len(dofs)
                self.cols += dofs
                self.vn += list(shp * n[comp])
                self.vt += list(shp * tvec[comp])

    def matrices(self, shape: tuple[int, int]) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """(Bn, Bt) of the summed entries."""
        rows = np.array(self.rows, dtype=int)
        cols = np.array(self.cols, dtype=int)
        return mortar_matrix(rows, cols, np.array(self.vn), shape), mortar_matrix(rows, cols, np.array(self.vt), shape)


def contact_operator_2d(mesh, V, name: str, side: str, opposite: str | None, *, axisymmetric: bool,
                        obstacle: tuple | None = None, search_distance: float | None = None) -> ContactOperator:
    """Assemble the operators of :class:`ContactOperator` for contact side ``side`` (multipliers) against
    the boundary ``opposite`` of another body, or (``opposite`` None) against a rigid straight foundation
    ``obstacle`` = (point, outward unit normal of the foundation) that does not move; ``V`` is the VectorH1
    displacement space. ``search_distance`` (m): rays longer than this (|g0| larger) are ignored (default: a
    quarter of the extent of the side; the nearest crossing of O counts). On a distributed mesh (collective)
    every rank gets the same operator of the whole interface in the global numbering of
    :class:`.parallel.GlobalDofs` ``(V)`` (``nodes``: the global scalar dofs of the vertices), from the parts'
    boundary segments gathered in rank order."""
    order, S, ns = scalar_space(mesh, V, 2, "contact_operator_2d needs a 2D VectorH1 space")
    numbering = parallel.GlobalDofs(V) if parallel.distributed(mesh) else None
    if numbering is None:
        sides = [Segment(mesh, S, el.nr) for el in mesh.Boundaries(side).Elements()]
        opps = [] if opposite is None else [Segment(mesh, S, el.nr) for el in mesh.Boundaries(opposite).Elements()]
    else:
        sides, outward, nodes, coords, seg_nodes, opps = _gathered_sides(name, mesh, S, side, opposite, order,
                                                                         numbering)
    if not sides or (opposite is not None and not opps):
        raise ValueError(f"contact interface {name!r}: side {side!r} or {opposite!r} has no boundary elements")
    plane = foundation_plane(name, obstacle, 2) if opposite is None else None
    if numbering is None:
        outward = _outward_signs(mesh, side, sides)[0]
        nodes, coords, seg_nodes = _side_nodes(mesh, side, sides)
    if search_distance is None:
        search_distance = default_search_distance(np.array([p for sg in sides for p in (sg.p0, sg.p1)]))
    reach = float(search_distance)
    found = _Opposite2D(opps, plane, reach)
    sums = _Mortar2D(len(nodes), ns if numbering is None else numbering.n_scalar, order, axisymmetric)
    for sg, jj, sign in zip(sides, seg_nodes, outward):
        sums.add_segment(sg, jj, sign, found)
    Bn, Bt = sums.matrices((len(nodes), V.ndof if numbering is None else numbering.size))
    return ContactOperator(name, side, opposite, nodes, coords, Bn, Bt, sums.g0, sums.weight, sums.length,
                           covered_fraction(sums.covered, sums.weight), search_distance=reach)
