"""The boundary elements of a distributed mesh's parts as numbers, gathered onto every rank: what an interface
integral needs of the side opposite a part's own elements (:mod:`ngs_geomech.fem.mortar`,
:mod:`ngs_geomech.fem.interface_quadrature`), whose elements may lie on any part.

A part describes each of its boundary elements of a region by the monomial coefficients of its map (2D: x(s),
the lattice interpolant of NGSolve's map, exact for polynomial maps; 3D: the affine map of a flat triangle) and of
the shape functions of an H1 space (exact: they are polynomials of the element's order in its reference
coordinates), with the element's dofs in the global numbering of :class:`ngs_geomech.parallel.GlobalDofs`. The
gathered elements evaluate as :class:`~.mortar.Segment` and :class:`~.mortar.Triangle` do, in the same reference
coordinates, so the interface integrals take them unchanged. An element held by several parts (a segment of a 2D
part boundary) is kept once, from the first part (in rank order) that holds the volume element behind it.
"""

from __future__ import annotations

import numpy as np
import numpy.polynomial.polynomial as npp

from .. import parallel
from .mortar import Segment, SegmentCurve, Triangle


class GatheredSegment(SegmentCurve):
    """A boundary segment as numbers: ``geo`` (q + 1, 2) the monomial coefficients of x(s), ``shp`` (p + 1, nloc)
    those of the shapes, ``dofs`` (global), ``curved``, ``key`` (its sorted global vertex numbers)."""

    def __init__(self, geo: np.ndarray, shp: np.ndarray, dofs, curved: bool, key: tuple):
        self.geo, self.shp, self.dofs, self.curved, self.key = geo, shp, [int(d) for d in dofs], bool(curved), key
        self.p0, self.p1 = self.point(0.0), self.point(1.0)

    def point(self, s: float) -> np.ndarray:
        return npp.polyval(s, self.geo)

    def shape(self, s: float) -> np.ndarray:
        return npp.polyval(s, self.shp)


class _MonomialShapes:
    """CalcShape of a triangle's shapes given by monomial coefficients ``coef`` (nterms, nloc) in (x, y)."""

    def __init__(self, coef: np.ndarray, order: int):
        self.coef, self.order = coef, order

    def CalcShape(self, x: float, y: float) -> np.ndarray:  # noqa: N802 (NGSolve's name)
        return monomials(np.array([[x, y]]), self.order)[0] @ self.coef


class GatheredTriangle(Triangle):
    """A flat boundary triangle as numbers: ``corners`` (3, 3) the images of the reference points (0, 0), (1, 0),
    (0, 1), ``dofs`` (global), the shapes' monomial coefficients ``coef``, ``key`` (its sorted global vertices)."""

    def __init__(self, corners: np.ndarray, dofs, coef: np.ndarray, order: int, key: tuple):
        self.corners = np.asarray(corners, dtype=float)
        self.p0 = self.corners[0]
        self.J = np.column_stack([self.corners[1] - self.p0, self.corners[2] - self.p0])
        self.dofs = [int(d) for d in dofs]
        self.fe = _MonomialShapes(coef, order)
        n = np.cross(self.J[:, 0], self.J[:, 1])
        self.area2 = float(np.linalg.norm(n))
        self.normal = n / self.area2
        self.key = key


def monomials(xi: np.ndarray, order: int) -> np.ndarray:
    """(Q, nterms) values of x^a y^b, a + b <= order, at the points xi (Q, 2)."""
    return np.stack([xi[:, 0] ** a * xi[:, 1] ** b for a in range(order + 1) for b in range(order + 1 - a)], axis=1)


def lattice(order: int) -> np.ndarray:
    """The points (i/p, j/p), i + j <= p, of the reference triangle (p = max(order, 1))."""
    p = max(order, 1)
    return np.array([(i / p, j / p) for i in range(p + 1) for j in range(p + 1 - i)])


def _behind(mesh, el) -> bool:
    """Whether this part holds a volume element behind the boundary element ``el``."""
    node = el.edges[0] if mesh.dim == 2 else el.faces[0]
    return len(mesh[node].elements) > 0


def _segment_record(mesh, V, el, order: int, q: int, numbering) -> tuple:
    sg = Segment(mesh, V, el.nr)
    lat, lat_u = np.linspace(0.0, 1.0, q + 1), np.linspace(0.0, 1.0, order + 1)
    geo = npp.polyfit(lat, np.array([sg.point(t) for t in lat]), q)
    shp = npp.polyfit(lat_u, np.array([sg.shape(t) for t in lat_u]), order)
    key = tuple(sorted(int(numbering.scalar[v.nr]) for v in el.vertices))
    return geo, shp, numbering.scalar[np.array(sg.dofs, dtype=int)], sg.curved, key


def _triangle_record(mesh, V, el, order: int, numbering) -> tuple:
    tr = Triangle(mesh, V, el.nr)
    lat = lattice(order)
    shapes = np.array([np.array(tr.fe.CalcShape(float(a), float(b))) for a, b in lat])
    coef = np.linalg.solve(monomials(lat, max(order, 1)), shapes)
    key = tuple(sorted(int(numbering.scalar[v.nr]) for v in el.vertices))
    return tr.corners, numbering.scalar[np.array(tr.dofs, dtype=int)], coef, key


def owned_elements(mesh, name: str, numbering) -> list[int]:
    """The numbers of this part's boundary elements of ``name`` that this part handles: each element of the whole
    boundary by one part, the first (in rank order) holding the volume element behind it (collective)."""
    els = [el for el in mesh.Boundaries(name).Elements() if _behind(mesh, el)]
    keys = [tuple(sorted(int(numbering.scalar[v.nr]) for v in el.vertices)) for el in els]
    taken: set = set()
    mine = None
    for rank, part in enumerate(parallel.allgather(mesh, keys)):
        if rank == (mesh.comm.rank if parallel.distributed(mesh) else 0):
            mine = [el.nr for el, k in zip(els, keys) if k not in taken]
        taken.update(part)
    return mine or []


def gathered_boundary(mesh, V, name: str, numbering) -> list:
    """The elements of the boundary ``name`` of all parts (:class:`GatheredSegment` in 2D, :class:`GatheredTriangle`
    in 3D; flat triangles) for the scalar H1 space ``V`` with the global numbering ``numbering`` (a
    :class:`~ngs_geomech.parallel.GlobalDofs` of V), the same list on every rank (collective)."""
    order = V.globalorder
    mine = set(owned_elements(mesh, name, numbering))
    els = [el for el in mesh.Boundaries(name).Elements() if el.nr in mine]
    if mesh.dim == 2:
        q = max(order, mesh.GetCurveOrder(), 1)
        local = [_segment_record(mesh, V, el, order, q, numbering) for el in els]
        return [GatheredSegment(*r) for part in parallel.allgather(mesh, local) for r in part]
    local = [_triangle_record(mesh, V, el, order, numbering) for el in els]
    return [GatheredTriangle(c, d, coef, max(order, 1), k) for part in parallel.allgather(mesh, local)
            for c, d, coef, k in part]
