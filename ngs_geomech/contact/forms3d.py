"""Discrete contact operators of problem (P) in 3D: the operators of :class:`.contact.ContactOperator` for a
contact side S (tetrahedral mesh, triangular boundary) against the boundary O of another body with an
independent, non-matching surface mesh, or against a rigid plane foundation.

Same formulation as the 2D :func:`.contact.contact_operator_2d` (see :mod:`.contact`): small deformations,
dual (biorthogonal) P1 multipliers on S's vertices,

    p = sum_j lam_n,j psi_j,   psi_j = 4 phi_j - 1 on each flat triangle of S,

(psi_a = sum_b D_aa (M^-1)_ab phi_b with the triangle's P1 mass matrix M = |T|/12 (1 + delta_ab) and
D = diag(M 1) = |T|/3, so int_T psi_a phi_b dA = delta_ab |T|/3), phi_j the hat function of vertex j (also for
P2 displacements). A point x of S sees the point x_o where the ray x + g n (n the outward unit normal of S's
body) meets O; g0 = (x_o - x).n. Per multiplier node j

    (Bn u)_j  = int_S psi_j (u(x_o) - u(x)).n  dA,      g0_j = int_S psi_j g0 dA,
    (Bt u)_j  = int_S psi_j (u(x_o) - u(x)).t1 dA,      (Bt2 u)_j = the same with t2 = n x t1,

integrated over the part of S whose rays meet O (closer than ``search_distance``); ``weight`` = int_S phi_j dA
(m^2), ``length`` = sqrt(weight) (m, the nodal mesh size: h on a uniform mesh, the 2D int phi_j ds),
``coverage`` = int_{S covered} phi_j dA / weight. t1 is the projection of e_x onto the tangent plane (e_y where
|n_x| > 0.9), so it is the same on all triangles of a flat side.

Segment-based integration (the 3D analogue of the 2D splitting, cf. :func:`.mortar.mortar_coupling_3d`): each
triangle of S is clipped (Sutherland-Hodgman) against the projections of O's triangles along S's normal onto
its plane; the convex pieces are fanned into triangles and integrated with a collapsed Gauss rule exact for
polynomials of degree 2 order + 2. On flat triangles the ray map is affine, so every piece integrates a
polynomial (degree order + 1) exactly and the patch test holds to round-off on non-matching meshes.

Assumptions: the triangles are taken flat (through their corner points; a curved side carries an O(h^2)
geometry error), O's triangles facing away from S (n_O . n_S >= -1e-3) are ignored, and overlapping
projections of several facing O triangles (a folded O) are not resolved to the nearest one (all count).

Shape functions are NGSolve's own: per boundary element the H1 shapes are sampled at the order's lattice
points (``GetFE(...).CalcShape``) and written as monomials, so the quadrature is vectorized with numpy.
Dof layout: component c of the VectorH1 space has dof c * ns + the scalar H1 dof (ns = H1(mesh, order).ndof).
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .. import parallel
from .forms import (
    ContactOperator,
    covered_fraction,
    default_search_distance,
    foundation_plane,
    mortar_matrix,
    scalar_space,
)

_FACING = -1e-3      # O triangles count when n_O . n_S < this (they face S)


def _lattice(order: int) -> np.ndarray:
    """Unisolvent points (xi, eta) of the polynomials of degree <= order on the reference triangle."""
    return np.array([(i / order, j / order) for i in range(order + 1) for j in range(order + 1 - i)], dtype=float)


def _monomials(xi: np.ndarray, order: int) -> np.ndarray:
    """(Q, nloc) values of xi^a eta^b, a + b <= order, at the points xi (Q, 2)."""
    return np.stack([xi[:, 0] ** a * xi[:, 1] ** b for a in range(order + 1) for b in range(order + 1 - a)], axis=1)


def _duffy_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Collapsed Gauss rule on the triangle (0,0), (1,0), (0,1): points (n^2, 2), weights summing to 1/2;
    exact for degree <= 2 n - 2."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = (x + 1) / 2, w / 2
    u, v = np.meshgrid(x, x, indexing="ij")
    wu, wv = np.meshgrid(w, w, indexing="ij")
    pts = np.column_stack([u.ravel(), (v * (1 - u)).ravel()])
    return pts, (wu * wv * (1 - u)).ravel()


class _Surface:
    """The flat triangles of one boundary as arrays: corners X (NGSolve's reference vertices (1,0), (0,1), (0,0)
    map to el.vertices 0, 1, 2), the affine map x = P + J xi, outward unit normals n of the body, the vertex
    numbers ``verts`` and scalar H1 dofs ``dofs`` (global numbers on a distributed mesh) and the monomial
    coefficients of the shapes (N(xi) = monomials(xi) @ coef)."""

    def __init__(self, verts: np.ndarray, X: np.ndarray, n: np.ndarray, dofs: np.ndarray, coef: np.ndarray):
        self.verts, self.X, self.n, self.dofs, self.coef = verts, X, n, dofs, coef
        self.P = self.X[:, 2]
        self.J = np.stack([self.X[:, 0] - self.P, self.X[:, 1] - self.P], axis=2)     # (nt, 3, 2)
        self.area2 = np.linalg.norm(np.cross(self.J[:, :, 0], self.J[:, :, 1]), axis=1)   # twice the area
        self.lo, self.hi = self.X.min(axis=1), self.X.max(axis=1)

    def __len__(self) -> int:
        return len(self.verts)


def _outward(mesh, pts: np.ndarray, els: list, X: np.ndarray) -> tuple[np.ndarray, int]:
    """(unit normals of the flat triangles ``els`` (corners X) pointing away from the one volume element behind
    each face, the number of faces without exactly one volume element of this part behind them)."""
    nrm = np.cross(X[:, 0] - X[:, 2], X[:, 1] - X[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        n = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    inner = np.empty((len(els), 3))
    inside = 0
    for k, el in enumerate(els):
        vols = mesh[el.faces[0]].elements
        inside += len(vols) != 1
        inner[k] = pts[[v.nr for v in mesh[vols[0]].vertices]].mean(axis=0) if vols else X[k].mean(axis=0)
    flip = np.einsum("ij,ij->i", n, X.mean(axis=1) - inner) < 0
    n[flip] *= -1
    return n, inside


def _surface_arrays(mesh, pts: np.ndarray, space, name: str, order: int, numbering) -> dict:
    """This part's triangles of the boundary ``name`` as the arrays of :class:`_Surface` (vertex numbers and dofs
    global through ``numbering``, a :class:`.parallel.GlobalDofs`, when given), with ``corners`` (the largest
    corner count) and ``inside`` (faces between two volume elements)."""
    els = list(mesh.Boundaries(name).Elements())
    nloc = (order + 1) * (order + 2) // 2
    corners = max((len(el.vertices) for el in els), default=3)
    out = {"corners": corners, "inside": 0, "verts": np.zeros((0, 3), dtype=int), "X": np.zeros((0, 3, 3)),
           "n": np.zeros((0, 3)), "dofs": np.zeros((0, nloc), dtype=int), "coef": np.zeros((0, nloc, nloc))}
    if not els or corners != 3:
        return out
    verts = np.array([[v.nr for v in el.vertices] for el in els], dtype=int)
    X = pts[verts]                                        # (nt, 3 corners, 3)
    n, inside = _outward(mesh, pts, els, X)
    lat = _lattice(order)
    vand = _monomials(lat, order)
    dofs, shapes = [], []
    for el in els:
        ei = ngs.ElementId(ngs.BND, el.nr)
        fe = space.GetFE(ei)
        dofs.append(list(space.GetDofNrs(ei)))
        shapes.append([np.array(fe.CalcShape(float(a), float(b))) for a, b in lat])
    dofs = np.array(dofs, dtype=int)
    if numbering is not None:      # a vertex's dof is its number (NGSolve numbers the vertex dofs first)
        verts, dofs = numbering.scalar[verts], numbering.scalar[dofs]
    out.update(inside=inside, verts=verts, X=X, n=n, dofs=dofs, coef=np.linalg.solve(vand[None], np.array(shapes)))
    return out


def _surface(mesh, pts: np.ndarray, space, name: str, order: int, what: str, iname: str, numbering) -> _Surface:
    """The :class:`_Surface` of the whole boundary ``name``: on a distributed mesh (``numbering`` given) every
    part's triangles, gathered in rank order onto every rank (each face of an outer boundary lies on one part,
    with the volume element behind it; a face found on two parts lies between two volume elements)."""
    a = _surface_arrays(mesh, pts, space, name, order, numbering)
    if numbering is not None:
        parts = parallel.allgather(mesh, a)
        a = {k: (np.concatenate([p[k] for p in parts]) if isinstance(a[k], np.ndarray) else
                 (max if k == "corners" else sum)(p[k] for p in parts)) for k in a}
        keys = np.sort(a["verts"], axis=1)
        a["inside"] += len(keys) - len(np.unique(keys, axis=0))
    if not len(a["verts"]) and a["corners"] == 3:
        raise ValueError(f"contact interface {iname!r}: the {what} boundary {name!r} has no boundary elements "
                         f"(boundaries of the mesh: {sorted(set(mesh.GetBoundaries()))})")
    if a["corners"] != 3:
        raise ValueError(f"contact interface {iname!r}: boundary {name!r} must consist of triangles")
    sf = _Surface(a["verts"], a["X"], a["n"], a["dofs"], a["coef"])
    if np.any(sf.area2 <= 0):
        raise ValueError(f"contact interface {iname!r}: boundary {name!r} has degenerate triangles")
    if a["inside"]:
        raise ValueError(f"contact interface {iname!r}: boundary {name!r} is not on the outer boundary of "
                         "a body (a face between two volume elements): contact sides need independent "
                         "meshes (netgen.occ Compound, not Glue)")
    return sf


def _clip(poly: np.ndarray, eps: float = 1e-13) -> np.ndarray:
    """Sutherland-Hodgman: the part of the convex polygon ``poly`` (k, 2) inside the reference triangle
    xi >= 0, eta >= 0, 1 - xi - eta >= 0 (either orientation)."""
    out = [p for p in poly]
    for f in (lambda p: p[0], lambda p: p[1], lambda p: 1.0 - p[0] - p[1]):
        if not out:
            break
        inp, out = out, []
        vals = [f(p) for p in inp]
        for j in range(len(inp)):
            cur, prev = inp[j], inp[j - 1]
            fc, fp = vals[j], vals[j - 1]
            if fc >= -eps:
                if fp < -eps:
                    out.append(prev + (cur - prev) * (fp / (fp - fc)))
                out.append(cur)
            elif fp >= -eps:
                if fp > eps:
                    out.append(prev + (cur - prev) * (fp / (fp - fc)))
    return np.array(out) if len(out) >= 3 else np.empty((0, 2))


def _tangent(n: np.ndarray) -> np.ndarray:
    """First tangential direction t1 per row of n: e_x projected onto the tangent plane (e_y where |n_x| > 0.9)."""
    e = np.zeros_like(n)
    use_y = np.abs(n[:, 0]) > 0.9
    e[~use_y, 0] = 1.0
    e[use_y, 1] = 1.0
    t = e - np.einsum("ij,ij->i", e, n)[:, None] * n
    return t / np.linalg.norm(t, axis=1)[:, None]


def _check_names(name: str, side, opposite) -> None:
    """The boundary names of the interface are nonempty strings (``opposite`` None: a foundation)."""
    for what, bnd in (("contact side", side), ("opposite", opposite)):
        if bnd is None and what == "opposite":
            continue
        if not isinstance(bnd, str) or not bnd.strip():
            raise ValueError(f"contact interface {name!r}: the {what} boundary name {bnd!r} is empty")


def _facing_pieces(sf: _Surface, n_ob: np.ndarray) -> tuple[list, list, list]:
    """The pieces against a rigid plane of outward normal ``n_ob``: the whole triangles of S facing it."""
    facing = np.where(sf.n @ n_ob < -1e-12)[0]
    return list(facing), [-1] * len(facing), [np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])] * len(facing)


def _fan(piece: np.ndarray) -> list[np.ndarray]:
    """The non-degenerate triangles (3, 2) of the fan of the convex polygon ``piece`` from its first corner."""
    out = []
    for k in range(1, len(piece) - 1):
        a, b, cc = piece[0], piece[k], piece[k + 1]
        det = (b[0] - a[0]) * (cc[1] - a[1]) - (b[1] - a[1]) * (cc[0] - a[0])
        if abs(det) > 1e-14:
            out.append(np.array([a, b, cc]))
    return out


def _clipped_pieces(sf: _Surface, of: _Surface, reach: float) -> tuple[list, list, list]:
    """The pieces against the opposite surface ``of`` (module docstring): each S triangle clipped against the
    projections of the facing O triangles within ``reach`` of it, fanned into triangles."""
    p_tri, p_opp, p_abc = [], [], []
    JtJ = np.einsum("tki,tkj->tij", sf.J, sf.J)
    pinv = np.linalg.solve(JtJ, np.transpose(sf.J, (0, 2, 1)))        # (nt, 2, 3)
    tol_box = 1e-9 * float(np.max(np.ptp(sf.X.reshape(-1, 3), axis=0)))
    for t in range(len(sf)):
        ends = np.concatenate([sf.X[t] - reach * sf.n[t], sf.X[t] + reach * sf.n[t]])
        lo, hi = ends.min(axis=0) - tol_box, ends.max(axis=0) + tol_box
        cand = np.where(np.all(of.lo <= hi, axis=1) & np.all(of.hi >= lo, axis=1)
                        & (of.n @ sf.n[t] < _FACING))[0]
        if not len(cand):
            continue
        R = np.einsum("ij,ckj->cki", pinv[t], of.X[cand] - sf.P[t])      # O corners in S's coordinates
        L3 = 1.0 - R.sum(axis=2)
        eps = 1e-12
        out = (np.all(R[:, :, 0] <= eps, axis=1) | np.all(R[:, :, 1] <= eps, axis=1)
               | np.all(L3 <= eps, axis=1))
        for c, poly in zip(cand[~out], R[~out]):
            for tri in _fan(_clip(poly)):
                p_tri.append(t)
                p_opp.append(int(c))
                p_abc.append(tri)
    return p_tri, p_opp, p_abc


def _shapes_at(surface: _Surface, tri: np.ndarray, ref: np.ndarray, order: int) -> np.ndarray:
    """(np, nq, nloc) values of the shapes of ``surface``'s triangles ``tri`` at the reference points ``ref``."""
    npc, nq = ref.shape[:2]
    return np.einsum("pqk,pki->pqi", _monomials(ref.reshape(-1, 2), order).reshape(npc, nq, -1), surface.coef[tri])


class _Pieces:
    """The quadrature of the pieces of S (S triangle ``tri``, O triangle ``opp`` or -1 for the foundation,
    corners ``abc`` (np, 3, 2) in S's reference coordinates): the points ``xi`` (np, nq, 2) in S's reference
    coordinates, ``x`` (np, nq, 3) in space, the weights ``w`` (np, nq) (dA) and S's normals ``n`` (np, 3)."""

    def __init__(self, sf: _Surface, tri: np.ndarray, opp: np.ndarray, abc: np.ndarray, order: int):
        self.tri, self.opp = tri, opp
        qx, qw = _duffy_rule(order + 2)
        e1, e2 = abc[:, 1] - abc[:, 0], abc[:, 2] - abc[:, 0]
        det = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        self.xi = abc[:, None, 0] + qx[None, :, 0, None] * e1[:, None] + qx[None, :, 1, None] * e2[:, None]
        self.w = qw[None, :] * det[:, None] * sf.area2[tri][:, None]
        self.x = sf.P[tri][:, None] + np.einsum("pij,pqj->pqi", sf.J[tri], self.xi)
        self.n = sf.n[tri]                                               # constant per flat triangle

    def __len__(self) -> int:
        return len(self.tri)

    def rays(self, of: _Surface | None, plane: tuple | None) -> tuple[np.ndarray, np.ndarray | None]:
        """(gaps g (np, nq), the hit points r (np, nq, 2) in O's reference coordinates or None on the foundation
        ``plane``) of the rays x + g n."""
        x, n = self.x, self.n
        if of is None:
            q_ob, n_ob = plane
            return np.einsum("pqi,i->pq", q_ob - x, n_ob) / (n @ n_ob)[:, None], None
        A = np.stack([of.J[self.opp][:, :, 0], of.J[self.opp][:, :, 1], -n], axis=2)     # (np, 3, 3)
        rg = np.einsum("pij,pqj->pqi", np.linalg.inv(A), x - of.P[self.opp][:, None])
        return rg[:, :, 2], rg[:, :, :2]


def _mortar_3d(pieces: _Pieces, sf: _Surface, of: _Surface | None, plane: tuple | None, reach: float,
               tri_nodes: np.ndarray, m: int, order: int):
    """The local mortar integrals of the pieces: (g0 (m,), covered (m,), rows (np, 3) of their multiplier nodes,
    the coupling M (np, 3, nl) of the dual shapes with (u(x_o) - u(x)) and its scalar dofs (np, nl))."""
    g, r = pieces.rays(of, plane)
    w = np.where(np.abs(g) <= reach, pieces.w, 0.0)
    xi = pieces.xi
    phi = np.concatenate([xi, 1.0 - xi.sum(axis=2, keepdims=True)], axis=2)     # (np, nq, 3) hats
    psi = 4.0 * phi - 1.0                                            # dual basis (flat triangles)
    rows3 = tri_nodes[pieces.tri]                                    # (np, 3)
    g0, covered = np.zeros(m), np.zeros(m)
    np.add.at(covered, rows3, np.einsum("pq,pqa->pa", w, phi))
    np.add.at(g0, rows3, np.einsum("pq,pqa,pq->pa", w, psi, g))
    NS = _shapes_at(sf, pieces.tri, xi, order)
    M = [-np.einsum("pq,pqa,pqi->pai", w, psi, NS)]                 # (np, 3, nloc)
    dofs = [sf.dofs[pieces.tri]]
    if of is not None:
        NO = _shapes_at(of, pieces.opp, r, order)
        M.append(np.einsum("pq,pqa,pqi->pai", w, psi, NO))
        dofs.append(of.dofs[pieces.opp])
    return g0, covered, rows3, np.concatenate(M, axis=2), np.concatenate(dofs, axis=1)


def _mortar_matrices(rows3: np.ndarray, M: np.ndarray, dofs: np.ndarray, directions, ns: int,
                     shape: tuple[int, int]) -> list[sp.csr_matrix]:
    """The operators (one per direction d (np, 3): n, t1, t2) with the entries M d_c on the dofs c ns + dofs."""
    npc, nl = dofs.shape
    rows = np.broadcast_to(rows3[:, :, None, None], (npc, 3, nl, 3))
    cols = np.broadcast_to(dofs[:, None, :, None] + ns * np.arange(3)[None, None, None, :], (npc, 3, nl, 3))
    return [mortar_matrix(rows.ravel(), cols.ravel(), (M[:, :, :, None] * d[:, None, None, :]).ravel(), shape)
            for d in directions]


def contact_operator_3d(mesh, V, name: str, side: str, opposite: str | None, *, obstacle: tuple | None = None,
                        search_distance: float | None = None) -> ContactOperator:
    """Assemble the operators of :class:`ContactOperator` (3D, module docstring) for the contact side ``side``
    (multipliers on its vertices) against the boundary ``opposite`` of another body, or (``opposite`` None)
    against the rigid plane ``obstacle`` = (a point of it, its outward unit normal, pointing towards the body);
    ``V`` is the 3D VectorH1 displacement space (any order; the multipliers are P1). ``search_distance`` (m):
    rays longer than this (|g0| larger) are ignored (default: a quarter of the extent of the side). The
    extra field ``Bt2`` holds the second tangential direction t2 = n x t1 (``Bt`` holds t1).

    On a distributed mesh (collective) every rank gets the same operator of the whole interface in the global
    numbering of :class:`.parallel.GlobalDofs` ``(V)``: columns c * n_scalar + the global scalar dof, ``nodes``
    the global scalar dofs of the vertices; the parts' boundary triangles are gathered in rank order."""
    if mesh.dim != 3:
        raise ValueError(f"contact interface {name!r}: contact_operator_3d needs a 3D mesh (got dim {mesh.dim})")
    _check_names(name, side, opposite)
    order, S, ns = scalar_space(mesh, V, 3, f"contact interface {name!r}: contact_operator_3d needs a 3D "
                                            "VectorH1 space")
    plane = foundation_plane(name, obstacle, 3) if opposite is None else None
    numbering = parallel.GlobalDofs(V) if parallel.distributed(mesh) else None
    ndof = V.ndof if numbering is None else numbering.size
    ns = ns if numbering is None else numbering.n_scalar
    pts = np.asarray(mesh.ngmesh.Coordinates(), dtype=float)[:mesh.nv]     # vertex k = point k + 1 of netgen
    sf = _surface(mesh, pts, S, side, order, "contact side", name, numbering)
    of = None if opposite is None else _surface(mesh, pts, S, opposite, order, "opposite", name, numbering)
    nodes, first, tri_nodes = np.unique(sf.verts, return_index=True, return_inverse=True)
    tri_nodes = tri_nodes.reshape(len(sf), 3)
    m = len(nodes)
    if search_distance is None:
        search_distance = default_search_distance(sf.X.reshape(-1, 3))
    reach = float(search_distance)
    weight = np.zeros(m)
    np.add.at(weight, tri_nodes, np.repeat(sf.area2[:, None] / 6.0, 3, axis=1))
    p_tri, p_opp, p_abc = _facing_pieces(sf, plane[1]) if of is None else _clipped_pieces(sf, of, reach)
    g0, covered = np.zeros(m), np.zeros(m)
    Bs = [sp.csr_matrix((m, ndof)) for _ in range(3)]
    if len(p_tri):
        pieces = _Pieces(sf, np.array(p_tri, dtype=int), np.array(p_opp, dtype=int), np.array(p_abc), order)
        g0, covered, rows3, M, dofs = _mortar_3d(pieces, sf, of, plane, reach, tri_nodes, m, order)
        t1 = _tangent(sf.n)
        directions = (pieces.n, t1[pieces.tri], np.cross(sf.n, t1)[pieces.tri])
        Bs = _mortar_matrices(rows3, M, dofs, directions, ns, (m, ndof))
    coords = sf.X.reshape(-1, 3)[first]                   # the vertices' points
    return ContactOperator(name, side, opposite, nodes.astype(int), coords, Bs[0], Bs[1], g0, weight,
                           np.sqrt(weight), covered_fraction(covered, weight), Bt2=Bs[2], search_distance=reach)
