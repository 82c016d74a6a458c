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
import scipy.sparse as sp

from ..fem.mortar import Segment


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


def _outward_signs(mesh, side: str, segments) -> list[float]:
    """+1 or -1 per boundary element of ``side``: the factor that makes NGSolve's normal point out of the body
    the element bounds. (The normal of a boundary segment follows the segment's orientation; on the copied
    sides of a contact interface it pointed into the body for one of the two blocks, which turned contact
    into adhesion.)"""
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
    out = []
    for el, sg in zip(els, segments):
        c = centroid.get(frozenset(v.nr for v in el.vertices))
        mip = sg.trafo(0.5)
        n = np.array(nrm(mip)).ravel()[:2]
        p = np.array([ngs.x(mip), ngs.y(mip)])
        out.append(-1.0 if c is not None and float(np.dot(n, c - p)) > 0 else 1.0)
    return out


def contact_operator_2d(mesh, V, name: str, side: str, opposite: str | None, *, axisymmetric: bool,
                        obstacle: tuple | None = None, search_distance: float | None = None) -> ContactOperator:
    """Assemble the operators of :class:`ContactOperator` for contact side ``side`` (multipliers) against
    the boundary ``opposite`` of another body, or (``opposite`` None) against a rigid straight foundation
    ``obstacle`` = (point, outward unit normal of the foundation) that does not move; ``V`` is the VectorH1
    displacement space. ``search_distance`` (m): rays longer than this (|g0| larger) are ignored (default: a
    quarter of the extent of the side; the nearest crossing of O counts)."""
    order = V.globalorder
    S = ngs.H1(mesh, order=order)       # scalar shapes and dofs: component c of V has dof c * ns + scalar dof
    ns = S.ndof
    if V.ndof != 2 * ns:
        raise ValueError("contact_operator_2d needs a 2D VectorH1 space")
    sides = [Segment(mesh, S, el.nr) for el in mesh.Boundaries(side).Elements()]
    opps = [] if opposite is None else [Segment(mesh, S, el.nr) for el in mesh.Boundaries(opposite).Elements()]
    if not sides or (opposite is not None and not opps):
        raise ValueError(f"contact interface {name!r}: side {side!r} or {opposite!r} has no boundary elements")
    if opposite is None:
        if obstacle is None:
            raise ValueError(f"contact interface {name!r}: neither an opposite side nor a rigid foundation")
        q_ob = np.asarray(obstacle[0], dtype=float)[:2]
        n_ob = np.asarray(obstacle[1], dtype=float)[:2]
        n_ob = n_ob / np.linalg.norm(n_ob)
    nrm = ngs.specialcf.normal(2)
    outward = _outward_signs(mesh, side, sides)
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
    m = len(vert)
    coords = np.zeros((m, 2))
    for v, j in vert.items():
        coords[j] = mesh[ngs.NodeId(ngs.VERTEX, v)].point[:2]
    gx, gw = np.polynomial.legendre.leggauss(order + 3)
    gx, gw = (gx + 1) / 2, gw / 2
    omin = np.array([np.minimum(o.p0, o.p1) for o in opps]).reshape(-1, 2)
    omax = np.array([np.maximum(o.p0, o.p1) for o in opps]).reshape(-1, 2)
    opp_pts = [(o.p0, o.p1) for o in opps]
    if search_distance is None:   # default: a quarter of the extent of the contact side
        ext = np.ptp(np.array([p for sg in sides for p in (sg.p0, sg.p1)]), axis=0)
        search_distance = 0.25 * float(np.max(ext))
    reach = float(search_distance)
    rows_n, cols, vn, vt = [], [], [], []
    g0 = np.zeros(m)
    weight = np.zeros(m)
    length = np.zeros(m)
    covered = np.zeros(m)
    for sg, (j0, j1), sign in zip(sides, seg_nodes, outward):
        # dual (biorthogonal) basis on this segment: psi_a = sum_b A_ab phi_b, int psi_a phi_b w = delta_ab D_a
        Me = np.zeros((2, 2))
        for xq, wq in zip(gx, gw):
            pq = sg.point(xq)
            wt = wq * sg.speed(xq) * (pq[0] if axisymmetric else 1.0)
            ph = np.array([1.0 - xq, xq])
            Me += wt * np.outer(ph, ph)
        dual = np.diag(Me.sum(axis=1)) @ np.linalg.inv(Me)
        lo, hi = np.minimum(sg.p0, sg.p1), np.maximum(sg.p0, sg.p1)
        cand = np.where(np.all(omin <= hi + reach, axis=1) & np.all(omax >= lo - reach, axis=1))[0]
        cuts = {0.0, 1.0}
        for k in cand:
            for q in opp_pts[k]:
                s = sg.locate(q)
                if 0.0 < s < 1.0:
                    cuts.add(s)
        cuts = sorted(cuts)
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b - a <= 1e-12:
                continue
            for xq, wq in zip(gx, gw):
                s = a + (b - a) * xq
                mip = sg.trafo(s)
                p = np.array([ngs.x(mip), ngs.y(mip)])
                n = np.array(nrm(mip)).ravel()[:2]
                n = sign * n / np.linalg.norm(n)
                tvec = np.array([-n[1], n[0]])
                wt = wq * (b - a) * sg.speed(s) * (p[0] if axisymmetric else 1.0)
                phi = (1.0 - s, s)
                for j, ph in zip((j0, j1), phi):
                    weight[j] += wt * ph
                    length[j] += wq * (b - a) * sg.speed(s) * ph
                best = None
                if opposite is None:
                    nn = float(np.dot(n, n_ob))
                    if nn < -1e-12:   # facing the foundation
                        g = float(np.dot(q_ob - p, n_ob)) / nn
                        if abs(g) <= reach:
                            best = (g, 0.0, -1)
                for k in cand:
                    hit = _ray_hit(opps[k], p, n)
                    if hit is not None and abs(hit[0]) <= reach and (best is None or abs(hit[0]) < abs(best[0])):
                        best = (hit[0], hit[1], k)
                if best is None:
                    continue
                g, t, k = best
                NS = np.array(sg.fe.CalcShape(s))
                psi = dual @ np.array(phi)
                if k >= 0:
                    odofs, NO = opps[k].dofs, np.array(opps[k].fe.CalcShape(t))
                else:
                    odofs, NO = [], np.zeros(0)
                for j, ph, ps in zip((j0, j1), phi, psi):
                    covered[j] += wt * ph
                    c = wt * ps
                    g0[j] += c * g
                    for comp in range(2):
                        off = comp * ns
                        dofs = [off + d for d in odofs] + [off + d for d in sg.dofs]
                        shp = np.concatenate([NO, -NS]) * c
                        rows_n += [j] * len(dofs)
                        cols += dofs
                        vn += list(shp * n[comp])
                        vt += list(shp * tvec[comp])
    rows = np.array(rows_n, dtype=int)
    cols = np.array(cols, dtype=int)
    Bn = sp.csr_matrix((np.array(vn), (rows, cols)), shape=(m, V.ndof))
    Bt = sp.csr_matrix((np.array(vt), (rows, cols)), shape=(m, V.ndof))
    Bn.sum_duplicates()
    Bt.sum_duplicates()
    coverage = np.divide(covered, weight, out=np.zeros(m), where=weight > 0)
    return ContactOperator(name, side, opposite, np.array(list(vert), dtype=int), coords, Bn, Bt, g0, weight, length,
                           coverage, search_distance=reach)
