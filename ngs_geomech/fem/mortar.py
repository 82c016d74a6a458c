"""Segment-based mortar coupling matrices for 2D contact interfaces with non-matching meshes.

The mortar constraint of a contact interface Gamma (seed (2.22): T^k = T^l, equal fluxes) couples the
multiplier lambda on the master side with the jump of the temperature:

    b(lambda, T) = int_Gamma w lambda (T_m - T_s) ds,

w = 1 (plane) or r (axisymmetric). The minion trace T_s is piecewise polynomial on the minion mesh, so on a
master element it has kinks wherever a minion node lies; a Gauss rule over master elements (what NGSolve's
``ContactBoundary`` integrators do) then converges only like n^-2 in the number of points and leaves an
O(1) relative error in the coupling entries: P2 lost its orders (measured H1 O(h^0.7)). Here the integrals
are split at the minion nodes (segment-based integration: every master element is cut into the pieces
where one minion element lies opposite), so each piece integrates polynomials and is exact up to the
geometry of curved elements.

NGSolve has no segment-based mortar assembly, hence this module: it only computes matrix entries with
NGSolve's own finite elements (``GetFE(...).CalcShape``) and element transformations. In 3D the master
triangles are clipped against the minion triangles projected onto their plane (Sutherland-Hodgman).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np


class SegmentCurve:
    """What a boundary segment computes from its map ``point(s)`` (s in [0, 1]): the speed and the closest point;
    ``p0``, ``p1`` (its end points) and ``curved`` are set by the subclass."""

    p0: np.ndarray
    p1: np.ndarray
    curved: bool

    def point(self, s: float) -> np.ndarray:
        raise NotImplementedError

    def speed(self, s: float) -> float:
        """|dx/ds| (m per unit reference length)."""
        if not self.curved:
            return float(np.linalg.norm(self.p1 - self.p0))
        e = 1e-6
        a, b = max(s - e, 0.0), min(s + e, 1.0)
        return float(np.linalg.norm(self.point(b) - self.point(a)) / (b - a))

    def locate(self, p: np.ndarray) -> float:
        """Reference coordinate of the point of this segment closest to p (clipped to [0, 1])."""
        d = self.p1 - self.p0
        s = float(np.clip(np.dot(p - self.p0, d) / np.dot(d, d), 0.0, 1.0))
        if self.curved:
            for _ in range(8):  # Newton on |x(s) - p|^2 with a finite-difference tangent
                e = 1e-7
                x0 = self.point(s)
                t = (self.point(min(s + e, 1.0)) - self.point(max(s - e, 0.0))) / (min(s + e, 1.0) - max(s - e, 0.0))
                step = float(np.dot(x0 - p, t) / np.dot(t, t))
                s = float(np.clip(s - step, 0.0, 1.0))
                if abs(step) < 1e-13:
                    break
        return s


class Segment(SegmentCurve):
    """One boundary segment: its id, dofs, finite element and a map from the reference coordinate."""

    _normal = None

    def __init__(self, mesh, space, nr: int):
        self.ei = ngs.ElementId(ngs.BND, nr)
        self.trafo = mesh.GetTrafo(self.ei)
        self.curved = bool(self.trafo.curved)
        self.fe = space.GetFE(self.ei)
        self.dofs = list(space.GetDofNrs(self.ei))
        self.p0 = self.point(0.0)
        self.p1 = self.point(1.0)

    def point(self, s: float) -> np.ndarray:
        mip = self.trafo(s)
        return np.array([ngs.x(mip), ngs.y(mip)])

    def shape(self, s: float) -> np.ndarray:
        return np.array(self.fe.CalcShape(s))

    def frame(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(the point, NGSolve's normal of the boundary element there (2,)) at the reference coordinate s."""
        if Segment._normal is None:
            Segment._normal = ngs.specialcf.normal(2)
        mip = self.trafo(s)
        return np.array([ngs.x(mip), ngs.y(mip)]), np.array(Segment._normal(mip)).ravel()[:2]


def mortar_coupling_2d(mesh, V, L, master: str, minion: str, *, axisymmetric: bool, order: int,
                       merge: dict[int, int] | None = None, minions: list | None = None, numbering=None,
                       elements: list[int] | None = None):
    """COO entries (rows, cols, values) of b(mu, T) = int w mu (T_m - T_s) over the master boundary.

    Rows are dofs of the multiplier space ``L``, columns dofs of the temperature space ``V``. ``merge`` maps
    multiplier dofs whose basis function is added to another's (the modified mortar space at cross points:
    mu_1 + mu_0 is constant on the end element); merged dofs get no row.

    On a distributed mesh: ``minions`` the minion side gathered from all parts
    (:func:`~ngs_geomech.fem.gathered.gathered_boundary`), ``elements`` the numbers of the master elements this
    part integrates (default all of its own) and ``numbering`` (a :class:`~ngs_geomech.parallel.GlobalDofs` of V):
    the columns are then global dofs (the rows stay L's local dofs); a part without master elements gives no
    entries (the caller checks the sides of the whole mesh).
    """
    merge = merge or {}
    sides = _sides(Segment, mesh, V, L, master, minion, minions, numbering, elements)
    if sides is None:
        return _finish(([], [], []), 0.0, 0.0, master, minion)
    masters, minions, lfe = sides
    gx, gw = np.polynomial.legendre.leggauss(order + 2)
    gx = (gx + 1) / 2
    gw = gw / 2
    ss_len = [float(np.linalg.norm(s.p1 - s.p0)) for s in minions]
    mins = np.array([np.minimum(s.p0, s.p1) for s in minions])
    maxs = np.array([np.maximum(s.p0, s.p1) for s in minions])
    entries = ([], [], [])
    covered = 0.0
    total = 0.0
    for sm in masters:
        lo, hi = np.minimum(sm.p0, sm.p1), np.maximum(sm.p0, sm.p1)
        pad = 0.25 * float(np.linalg.norm(sm.p1 - sm.p0))
        cand = np.where(np.all(mins <= hi + pad, axis=1) & np.all(maxs >= lo - pad, axis=1))[0]
        lshape_fe, ldofs = lfe[sm.ei.nr]
        length = sum(gw[k] * sm.speed(gx[k]) for k in range(len(gx)))
        total += length
        for j in cand:
            ss = minions[j]
            a, b = sorted((sm.locate(ss.p0), sm.locate(ss.p1)))
            if b - a <= 1e-12:
                continue
            for xq, wq in zip(gx, gw):
                s = a + (b - a) * xq
                p = sm.point(s)
                t = ss.locate(p)
                if np.linalg.norm(ss.point(t) - p) > 0.5 * max(pad, ss_len[j]) + 1e-12:
                    # not opposite each other (a sanity check: on curved interfaces the two sides'
                    # discretized curves differ by the geometry error, O(h^2) for straight segments)
                    continue
                wt = wq * (b - a) * sm.speed(s) * (p[0] if axisymmetric else 1.0)
                covered += wq * (b - a) * sm.speed(s)
                _add_point(entries, wt, np.array(lshape_fe.CalcShape(s)), [merge.get(d, d) for d in ldofs],
                           sm.shape(s), sm.dofs, ss.shape(t), ss.dofs)
    return _finish(entries, covered, total, master, minion)


def _add_point(entries, wt, mu, ldofs, tm, mdofs, ts, sdofs) -> None:
    """Add one quadrature point's contribution wt mu_i (T_m - T_s) to the COO lists ``entries``."""
    rows, cols, vals = entries
    for i, di in enumerate(ldofs):
        if mu[i] == 0.0:
            continue
        rows += [di] * (len(mdofs) + len(sdofs))
        cols += list(mdofs) + list(sdofs)
        vals += list(wt * mu[i] * np.asarray(tm)) + list(-wt * mu[i] * np.asarray(ts))


def _sides(kind, mesh, V, L, master: str, minion: str, minions, numbering, elements):
    """The master side's elements of this part (``kind``: :class:`Segment` or :class:`Triangle`; their dofs in
    ``numbering`` when given) with the multiplier elements of ``L`` on them (element number -> (finite element,
    dofs)), and the minion side's elements (this mesh's, or the gathered ``minions``); None on a part of a
    distributed mesh without master elements."""
    own = _master_elements(mesh, master, elements)
    masters = [kind(mesh, V, el.nr) for el in own]
    if minions is None:
        minions = [kind(mesh, V, el.nr) for el in mesh.Boundaries(minion).Elements()]
    elif not masters:
        return None
    _globalize(masters, numbering)
    if not masters or not minions:
        raise ValueError(f"contact interface sides {master!r} / {minion!r} have no boundary elements")
    lfe = {el.nr: (L.GetFE(ngs.ElementId(ngs.BND, el.nr)), list(L.GetDofNrs(ngs.ElementId(ngs.BND, el.nr))))
           for el in own}
    return masters, minions, lfe


def _master_elements(mesh, master: str, elements: list[int] | None) -> list:
    """The master boundary's elements of this part (those numbered in ``elements`` when given)."""
    els = list(mesh.Boundaries(master).Elements())
    if elements is None:
        return els
    keep = set(elements)
    return [el for el in els if el.nr in keep]


def _globalize(elements: list, numbering) -> None:
    """Give the elements' ``dofs`` in the global numbering ``numbering`` (a GlobalDofs; None: kept local)."""
    if numbering is not None:
        for e in elements:
            e.dofs = [int(d) for d in numbering.scalar[np.asarray(e.dofs, dtype=int)]]


def _finish(entries, covered: float, total: float, master: str, minion: str):
    if total > 0 and abs(covered - total) > 1e-3 * total:
        raise ValueError(f"contact interface {master!r}: only {covered / total:.1%} of the master side lies "
                         f"opposite the minion side {minion!r}")
    rows, cols, vals = entries
    return np.array(rows, dtype=int), np.array(cols, dtype=int), np.array(vals)


class Triangle:
    """One (flat) boundary triangle: dofs, finite element, the affine map from reference coordinates."""

    def __init__(self, mesh, space, nr: int):
        self.ei = ngs.ElementId(ngs.BND, nr)
        trafo = mesh.GetTrafo(self.ei)
        pts = []
        for ref in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)):
            mip = trafo(*ref)
            pts.append([ngs.x(mip), ngs.y(mip), ngs.z(mip)])
        self.p0 = np.array(pts[0])
        self.J = np.column_stack([np.array(pts[1]) - self.p0, np.array(pts[2]) - self.p0])   # 3 x 2
        self.fe = space.GetFE(self.ei)
        self.dofs = list(space.GetDofNrs(self.ei))
        self.corners = np.array([self.p0, pts[1], pts[2]])
        n = np.cross(self.J[:, 0], self.J[:, 1])
        self.area2 = float(np.linalg.norm(n))
        self.normal = n / self.area2

    def reference(self, p: np.ndarray) -> np.ndarray:
        """Reference coordinates of the projection of p onto the triangle's plane."""
        return np.linalg.lstsq(self.J, p - self.p0, rcond=None)[0]


"""The boundary triangle under its public name (:mod:`ngs_geomech.fem.interface_quadrature` uses it)."""


def clip_polygon(poly: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: the part of polygon ``poly`` inside the convex counter-clockwise polygon ``clip``
    (both as (n, 2) arrays in one plane)."""
    out = poly
    for i in range(len(clip)):
        a, b = clip[i], clip[(i + 1) % len(clip)]
        edge = b - a
        inp, out = out, []
        if len(inp) == 0:
            break

        def side(p):
            return edge[0] * (p[1] - a[1]) - edge[1] * (p[0] - a[0])
        for j in range(len(inp)):
            cur, prev = inp[j], inp[j - 1]
            sc, sp = side(cur), side(prev)
            if sc >= 0:
                if sp < 0:
                    out.append(prev + (cur - prev) * (sp / (sp - sc)))
                out.append(cur)
            elif sp >= 0:
                out.append(prev + (cur - prev) * (sp / (sp - sc)))
        out = np.array(out) if out else np.empty((0, 2))
    return out




REFERENCE_TRIANGLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
"""The reference triangle (a master triangle in its own coordinates)."""


def overlap_points(tm: Triangle, ts: Triangle, qp: np.ndarray, qw: np.ndarray):
    """The quadrature points of the part of triangle ``tm`` that ``ts`` covers (``ts`` projected onto ``tm``'s
    plane, clipped, the convex piece fanned into triangles with the rule ``qp``, ``qw``): yields (ref, p, wt),
    the point in ``tm``'s reference coordinates, in space, and its weight (m^2)."""
    poly = np.array([tm.reference(c) for c in ts.corners])
    if (poly[1, 0] - poly[0, 0]) * (poly[2, 1] - poly[0, 1]) - \
            (poly[1, 1] - poly[0, 1]) * (poly[2, 0] - poly[0, 0]) < 0:
        poly = poly[::-1]
    piece = clip_polygon(poly, REFERENCE_TRIANGLE)
    for k in range(1, len(piece) - 1):   # fan triangulation of the convex piece
        a, b, c = piece[0], piece[k], piece[k + 1]
        jac = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        if jac < 1e-14:
            continue
        for (s, t), w in zip(qp, qw):
            ref = a + s * (b - a) + t * (c - a)
            yield ref, tm.p0 + tm.J @ ref, w * jac * tm.area2


def mortar_coupling_3d(mesh, V, L, master: str, minion: str, *, order: int, minions: list | None = None,
                       numbering=None, elements: list[int] | None = None):
    """COO entries (rows, cols, values) of b(mu, T) = int mu (T_m - T_s) over the master surface, integrated
    segment-based: each master triangle is intersected with the minion triangles opposite (projected onto its
    plane, Sutherland-Hodgman clipping), and every piece is integrated with a Gauss rule exact for the
    polynomial integrand. Flat triangles are assumed (curved interfaces: an O(h^2) geometry error).
    ``minions``, ``numbering``, ``elements``: on a distributed mesh, as in :func:`mortar_coupling_2d`."""
    sides = _sides(Triangle, mesh, V, L, master, minion, minions, numbering, elements)
    if sides is None:
        return _finish(([], [], []), 0.0, 0.0, master, minion)
    masters, minions, lfe = sides
    ir = ngs.IntegrationRule(ngs.TRIG, 2 * order + 2)
    qp = np.array([(p[0], p[1]) for p in ir.points])
    qw = np.array(list(ir.weights))
    mins = np.array([t.corners.min(axis=0) for t in minions])
    maxs = np.array([t.corners.max(axis=0) for t in minions])
    entries = ([], [], [])
    covered = total = 0.0
    for tm in masters:
        lo, hi = tm.corners.min(axis=0), tm.corners.max(axis=0)
        pad = 0.1 * math.sqrt(tm.area2)
        total += tm.area2 / 2
        cand = np.where(np.all(mins <= hi + pad, axis=1) & np.all(maxs >= lo - pad, axis=1))[0]
        lshape_fe, ldofs = lfe[tm.ei.nr]
        for j in cand:
            ts = minions[j]
            if abs(float(np.dot(ts.normal, tm.normal))) < 0.5:
                continue  # not opposite (another face of the interface)
            for ref, p, wt in overlap_points(tm, ts, qp, qw):
                covered += wt
                rs = ts.reference(p)
                _add_point(entries, wt, np.array(lshape_fe.CalcShape(ref[0], ref[1])), ldofs,
                           np.array(tm.fe.CalcShape(ref[0], ref[1])), tm.dofs,
                           np.array(ts.fe.CalcShape(rs[0], rs[1])), ts.dofs)
    return _finish(entries, covered, total, master, minion)


def boundary_transfer(mesh, V, side: str, opposite: str, *, axisymmetric: bool = False, order: int = 1,
                      reach: float | None = None):
    """The mortar transfer of a surface density onto the opposite side of an interface: for the piecewise linear
    density q = sum_j d_j phi_j on ``side`` (phi_j the hat function of the side's vertex j), the loads
    int_side w q(x) v_k(x') ds on the functions v_k of the scalar space ``V`` traced on ``opposite``, x' the point
    of ``opposite`` opposite x (2D: the closest point; 3D: the projection along the side's normal), w = r in
    axisymmetric scenes. Integrated segment-based as :func:`mortar_coupling_2d` / :func:`mortar_coupling_3d` (the
    side's elements cut where the opposite elements begin), exact for straight sides. Points farther from
    ``opposite`` than half an element (the tolerance of the mortar couplings) or ``reach`` (m; an initial gap
    between the sides), whichever is larger, have no partner.

    Returns (vertices, C, weight, covered): the side's mesh vertex numbers (m,), C (scipy CSR, m x V.ndof) with
    C[j, k] = int_side w phi_j v_k(x') ds, weight_j = int_side w phi_j ds and covered_j the part of weight_j whose
    points found a partner (sum_k C[j, k] over the vertex functions v_k of V)."""
    import scipy.sparse as sp
    P1 = ngs.H1(mesh, order=1)
    if mesh.dim == 2:
        entries, weight, covered = _transfer_2d(mesh, P1, V, side, opposite, axisymmetric, order, reach)
    else:
        entries, weight, covered = _transfer_3d(mesh, P1, V, side, opposite, order, reach)
    vertices = np.array(sorted({v.nr for el in mesh.Boundaries(side).Elements() for v in el.vertices}), dtype=int)
    index = np.full(mesh.nv, -1, dtype=int)
    index[vertices] = np.arange(len(vertices))
    rows, cols, vals = (np.array(e) for e in entries)
    rows = index[rows.astype(int)] if len(rows) else rows.astype(int)
    C = sp.coo_matrix((vals, (rows, cols.astype(int))), shape=(len(vertices), V.ndof)).tocsr()
    C.sum_duplicates()
    return vertices, C, weight[vertices], covered[vertices]


def _transfer_2d(mesh, P1, V, side, opposite, axisymmetric, order, reach):
    """COO entries (vertex rows), weights and covered weights (per mesh vertex) of :func:`boundary_transfer`, 2D."""
    sides = [Segment(mesh, P1, el.nr) for el in mesh.Boundaries(side).Elements()]
    opps = [Segment(mesh, V, el.nr) for el in mesh.Boundaries(opposite).Elements()]
    if not sides or not opps:
        raise ValueError(f"interface sides {side!r} / {opposite!r} have no boundary elements")
    gx, gw = np.polynomial.legendre.leggauss(order + 3)
    gx, gw = (gx + 1) / 2, gw / 2
    mins = np.array([np.minimum(s.p0, s.p1) for s in opps])
    maxs = np.array([np.maximum(s.p0, s.p1) for s in opps])
    lens = [float(np.linalg.norm(s.p1 - s.p0)) for s in opps]
    entries = ([], [], [])
    weight, covered = np.zeros(mesh.nv), np.zeros(mesh.nv)
    for sm in sides:
        pad = 0.25 * float(np.linalg.norm(sm.p1 - sm.p0))
        grow = max(pad, reach or 0.0)
        lo, hi = np.minimum(sm.p0, sm.p1), np.maximum(sm.p0, sm.p1)
        for xq, wq in zip(gx, gw):
            weight[sm.dofs] += wq * sm.speed(xq) * (sm.point(xq)[0] if axisymmetric else 1.0) * sm.shape(xq)
        for j in np.where(np.all(mins <= hi + grow, axis=1) & np.all(maxs >= lo - grow, axis=1))[0]:
            ss = opps[j]
            a, b = sorted((sm.locate(ss.p0), sm.locate(ss.p1)))
            if b - a <= 1e-12:
                continue
            far = max(reach or 0.0, 0.5 * max(pad, lens[j]))
            for xq, wq in zip(gx, gw):
                s = a + (b - a) * xq
                p = sm.point(s)
                t = ss.locate(p)
                if np.linalg.norm(ss.point(t) - p) > far + 1e-12:
                    continue
                wt = wq * (b - a) * sm.speed(s) * (p[0] if axisymmetric else 1.0)
                phi = sm.shape(s)
                covered[sm.dofs] += wt * phi
                _add_product(entries, wt, phi, sm.dofs, ss.shape(t), ss.dofs)
    return entries, weight, covered


def _add_product(entries, wt, phi, rows, v, cols) -> None:
    """Add wt phi_i v_k to the COO lists ``entries`` (rows: the side's vertices, cols: the opposite's dofs)."""
    r, c, val = entries
    for i, di in enumerate(rows):
        r += [di] * len(cols)
        c += list(cols)
        val += list(wt * phi[i] * np.asarray(v))


def _transfer_3d(mesh, P1, V, side, opposite, order, reach):
    """COO entries (vertex rows), weights and covered weights (per mesh vertex) of :func:`boundary_transfer`, 3D:
    each side triangle clipped against the opposite triangles projected onto its plane."""
    sides = [Triangle(mesh, P1, el.nr) for el in mesh.Boundaries(side).Elements()]
    opps = [Triangle(mesh, V, el.nr) for el in mesh.Boundaries(opposite).Elements()]
    if not sides or not opps:
        raise ValueError(f"interface sides {side!r} / {opposite!r} have no boundary elements")
    ir = ngs.IntegrationRule(ngs.TRIG, order + 3)
    qp = np.array([(p[0], p[1]) for p in ir.points])
    qw = np.array(list(ir.weights))
    mins = np.array([t.corners.min(axis=0) for t in opps])
    maxs = np.array([t.corners.max(axis=0) for t in opps])
    entries = ([], [], [])
    weight, covered = np.zeros(mesh.nv), np.zeros(mesh.nv)
    for tm in sides:
        h = math.sqrt(tm.area2)
        grow = max(0.1 * h, reach or 0.0)
        far = max(reach or 0.0, 0.5 * h)
        lo, hi = tm.corners.min(axis=0), tm.corners.max(axis=0)
        weight[tm.dofs] += tm.area2 / 6.0            # int phi_j over a flat triangle: area / 3
        for j in np.where(np.all(mins <= hi + grow, axis=1) & np.all(maxs >= lo - grow, axis=1))[0]:
            ts = opps[j]
            if abs(float(np.dot(ts.normal, tm.normal))) < 0.5:
                continue
            for ref, p, wt in overlap_points(tm, ts, qp, qw):
                if abs(float(np.dot(p - ts.p0, ts.normal))) > far + 1e-12:
                    continue
                phi = np.array(tm.fe.CalcShape(ref[0], ref[1]))
                rs = ts.reference(p)
                covered[tm.dofs] += wt * phi
                _add_product(entries, wt, phi, tm.dofs, np.array(ts.fe.CalcShape(rs[0], rs[1])), ts.dofs)
    return entries, weight, covered
