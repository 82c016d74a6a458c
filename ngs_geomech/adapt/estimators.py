"""A posteriori error estimators and refinement indicators, one value per volume element.

Estimators (``kind = "estimator"``) bound the discretization error in the energy norm of the problem,

    heat:        ||e||^2 = int w grad e . kappa f(T) grad e dx              (W/K per m of depth in 2D; W/K in 3D)
    elasticity:  ||e||^2 = int w eps(e) : C : eps(e) dx                     (J per m of depth in 2D; J in 3D)

(w = r in axisymmetric models, else 1), element by element: eta = sqrt(sum_T eta_T^2).

* ``zz`` (Zienkiewicz-Zhu flux/stress recovery): the flux q_h = kappa f(T_h) grad T_h (W/m^2), or the reduced
  Voigt stress s_h (Pa), is recovered region by region into a continuous field q*, and

      eta_T^2 = int_T w (q* - q_h) . (kappa f)^{-1} (q* - q_h) dx,   eta_T^2 = int_T w (s* - s_h) . D^{-1} (s* - s_h) dx

  (the complementary energy of the difference; D the region's reduced stiffness, its linear part for the
  lambda law). Recovery per region keeps the normal-flux / traction kinks of material interfaces out of q*.
  Recoveries (``recovery``; default "average" for P1, "spr" for P2 and higher):

  - ``"average"``: NGSolve's local averaging interpolation into H1 of order p (P1) or p + 1 (``recovery_order``),
    the classical nodal averaging. Exact enough for P1 (effectivity ~1.0); for P2 it underestimates and drifts
    (0.63, 0.50, 0.43 heat at h = 0.2, 0.1, 0.05): the averaged field of a discontinuous P1 flux is
    essentially the continuous P1 one, whose error is of the same order h^2 as q_h's.
  - ``"l2"``: the global L2 projection into that space (worse for P2: 0.25-0.37).
  - ``"spr"`` (superconvergent patch recovery, Zienkiewicz-Zhu 1992, with partition-of-unity blending): per
    vertex a of the region a polynomial P_a of degree p (``recovery_order``) fitted to q_h by weighted least
    squares over the quadrature points (order 2p + 2) of the vertex patch (the local L2 projection onto P_p;
    on vertices of the region's boundary the patch is widened by the elements of the neighbouring vertices),
    and q* = sum_a lambda_a P_a with the element's barycentric coordinates lambda_a: continuous, of degree
    p + 1 per element, exact for fluxes of degree p; integrated with the same quadrature points (the true
    Jacobian, curved elements included). Effectivity 1.01-1.04 (P2) and 1.02-1.34 (P3) on the manufactured
    heat and thermo-elastic problems, not drifting with h. Simplicial meshes only (others fall back to
    averaging). Cost ~0.5 s at 24k P2 elements (the residual estimator's: 0.8 s).
* ``residual`` (explicit residual estimator, Verfuerth's standard weights):

      eta_T^2 = h_T^2 / k_T ||R_T||_T^2 + sum_{E in dT} c_E h_E / k_T ||J_E||_E^2,

  R_T = Q + div(kappa f grad T_h) (- rho c (T_h - T_old)/dt in a time step), resp. f + div sigma_h; J_E the jump
  of the normal flux kappa f grad T_h . n (traction sigma_h n) across interior facets (c_E = 1/2: half to each
  neighbour), and on boundaries with natural conditions the misfit against the data (flux q0, Robin
  h (T_amb - T), traction, pressure; unnamed boundaries are insulated / traction free; c_E = 1); none on
  Dirichlet boundaries (per component for elasticity) and on contact interface sides. h_T is the element's
  longest edge, h_E the facet's (m); k_T = trace(kappa)/dim (W/(m K)) or trace of the in-plane normal block of
  D / dim (Pa) of the element's region. A conductivity that varies (an expression of x, y, z, T) enters R_T with
  its derivatives (d_i kappa_ij + d kappa_ij/dT d_i T_h) d_j T_h, and the weights (k_T, the ZZ norm's kappa^-1)
  with its mean over the region (an equivalent norm, within the contrast of kappa in the region). Elastic data
  that vary (C(x, T), beta(x), T0(x), rho(x)) enter R_T as (d_k D) e(u_h) - d_k (b (T - T0)) + rho g (the
  derivative in x_k with T held plus d/dT times d_k T_h for a temperature GridFunction), the ZZ norm with D(x)^-1
  pointwise (SPR: the region's representative D), k_T with the representative D. Jumps are
  computed with a facet space of the solution's order - 1 (exact on straight facets; the one-sided normal fluxes
  summed over the element boundaries, divided by the facet mass).

Indicators (``kind = "indicator"``, values 1 on the flagged elements, 0 elsewhere; the loop refines them in
addition to what the marker picks from the estimator):

* ``contact_zone``: the elements touching the contact nodes where the contact status (0 open, 1 stick, 2 slip,
  as in the contact output) changes between neighbouring nodes of a side (the boundary of the active set and
  the stick/slip transitions), on the multiplier side and the facing elements of the opposite side.
* ``phase_front``: the elements the iso-line ``level`` (1/2) of a nodal P1 liquid fraction crosses (the
  phase boundary of :class:`~ngs_geomech.stefan.forms.StefanForms`), and ``layers`` rings of elements around
  them (the front's next steps); with ``predicted`` (a second nodal field, e.g. the liquid fraction
  extrapolated one step ahead) also the elements that field's iso-line crosses.

Estimators and indicators are chosen by name from :data:`ESTIMATORS` (:func:`get_estimator`), so a scene key can
name them; each entry says what it needs (``needs``: ``"forms"`` the heat or elastic forms, ``"contact"`` the
mesh with the contact operators and their nodal status, ``"phase"`` the nodal liquid fraction).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .. import parallel
from ..contact.laws import slip_bound
from ..fem.coefficients import tensor_cf
from ..heat.forms import HeatForms
from ..mechanics.forms import ElasticForms

C_VOLUME = 1.0 / math.pi ** 2
"""Constant of the residual estimator's element term h_T^2/p^2 ||R||^2: the Payne-Weinberger Poincare constant
(h/pi)^2 of a convex element."""
C_JUMP = 1.0 / 12.0
"""Constant of the jump term h_E/p ||J||^2 (summed once per facet): deal.II's Kelly estimator's h/24 per side,
calibrated for P1 (measured here: the jump term alone then has effectivity ~1.0 on smooth P1 problems)."""
STATUS_OPEN, STATUS_STICK, STATUS_SLIP = 0, 1, 2
"""Nodal contact status codes, as in the contact output (:mod:`ngs_geomech.contact.problem`)."""


@dataclass
class Estimate:
    """Element values of one estimator or indicator: ``eta`` (one per volume element, in the units of the energy
    norm for an estimator: sqrt(W/K) per sqrt(m) heat, sqrt(J) per sqrt(m) elasticity in 2D; 0/1 for an
    indicator), its ``name`` and ``kind`` ("estimator" or "indicator")."""

    name: str
    kind: str
    eta: np.ndarray

    @property
    def total(self) -> float:
        """sqrt(sum_T eta_T^2): the estimated energy-norm error (an indicator: the square root of the count)."""
        return float(math.sqrt(float(np.sum(self.eta ** 2))))


@dataclass(frozen=True)
class EstimatorEntry:
    """A registered estimator: ``function(source, **options) -> Estimate`` where ``source`` is what ``needs``
    names (``"forms"``, ``"contact"``, ``"phase"``)."""

    name: str
    kind: str
    needs: str
    function: Callable


ESTIMATORS: dict[str, EstimatorEntry] = {}
"""The registry: name -> :class:`EstimatorEntry` (filled by :func:`register`)."""


def register(name: str, kind: str, needs: str):
    """Decorator: register an estimator (``kind="estimator"``) or indicator (``"indicator"``) under ``name``."""
    if kind not in ("estimator", "indicator"):
        raise ValueError(f"kind must be 'estimator' or 'indicator', got {kind!r}")

    def wrap(fn):
        ESTIMATORS[name] = EstimatorEntry(name, kind, needs, fn)
        return fn
    return wrap


def get_estimator(name: str) -> EstimatorEntry:
    """The registered estimator ``name``; a ValueError naming the known ones (and the closest) otherwise."""
    if name in ESTIMATORS:
        return ESTIMATORS[name]
    close = difflib.get_close_matches(name, list(ESTIMATORS), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise ValueError(f"unknown estimator {name!r}{hint}; known: {', '.join(sorted(ESTIMATORS))}")


# ------------------------------------------------------------------------------------------------------------
# mesh helpers
# ------------------------------------------------------------------------------------------------------------

def element_vertices(mesh) -> np.ndarray:
    """Vertex numbers of every volume element (ne x vertices per element), in element order (simplex meshes
    from netgen's arrays; other meshes element by element)."""
    try:
        arr = mesh.ngmesh.Elements2D() if mesh.dim == 2 else mesh.ngmesh.Elements3D()
        nodes = np.asarray(arr.NumPy()["nodes"], dtype=np.int64)[:, :mesh.dim + 1] - 1
        if nodes.shape[0] == mesh.ne and np.all(nodes >= 0):
            return nodes
    except (AttributeError, KeyError, TypeError, ValueError):
        pass
    return np.array([[v.nr for v in el.vertices] for el in mesh.Elements(ngs.VOL)], dtype=np.int64)


def vertex_coords(mesh) -> np.ndarray:
    try:
        xy = np.asarray(mesh.ngmesh.Coordinates(), dtype=float)
        if xy.shape[0] == mesh.nv:
            return xy[:, :mesh.dim]
    except (AttributeError, TypeError):
        pass
    return np.array([mesh[ngs.NodeId(ngs.VERTEX, k)].point for k in range(mesh.nv)], dtype=float)[:, :mesh.dim]


def element_sizes(mesh) -> np.ndarray:
    """h_T: the longest edge of every volume element (straight-sided measure), m."""
    if mesh.ne == 0:                    # rank 0 of a distributed mesh
        return np.zeros(0)
    xy = vertex_coords(mesh)
    ev = element_vertices(mesh)
    k = ev.shape[1]
    return np.max([np.linalg.norm(xy[ev[:, a]] - xy[ev[:, b]], axis=1) for a in range(k) for b in range(a + 1, k)],
                  axis=0)


def _p0_field(mesh, values: np.ndarray):
    """A piecewise constant GridFunction (L2 order 0) with one value per volume element."""
    g = ngs.GridFunction(ngs.L2(mesh, order=0))
    g.vec.FV().NumPy()[:] = values
    return g


class _FacetData:
    """Facet sizes h_E (m; the length in 2D, sqrt(2 area) in 3D) and facet weights as order-0 facet
    GridFunctions, from two assembled vectors (no loop over facets): int_{dT} v summed over the elements
    (count x |E|) and int v ds over the boundary (|E| on boundary facets, 0 inside). On a distributed mesh the
    assembled vectors are cumulated (a facet between two parts gets both elements' parts), and ``share`` is the
    fraction of a facet's elements on this rank (1 on a serial mesh): the local facet mass matrix is ``share``
    times the whole mesh's."""

    def __init__(self, mesh):
        self.mesh = mesh
        self.F0 = ngs.FacetFESpace(mesh, order=0)
        v = self.F0.TestFunction()
        both = ngs.LinearForm(self.F0)
        both += v * ngs.dx(element_boundary=True)
        both.Assemble()
        bnd = ngs.LinearForm(self.F0)
        bnd += v * ngs.ds
        bnd.Assemble()
        local = np.array(both.vec.FV().NumPy())
        _cumulate(mesh, both.vec, bnd.vec)
        a = np.array(both.vec.FV().NumPy())
        b = np.array(bnd.vec.FV().NumPy())
        self.share = None
        if parallel.distributed(mesh):
            self.share = ngs.GridFunction(self.F0)
            self.share.vec.FV().NumPy()[:] = np.divide(local, a, out=np.ones_like(a), where=a > 0)
        self.boundary = b > 0
        self.mass0 = a
        size = np.where(self.boundary, a, 0.5 * a)     # interior facets are integrated from both sides
        self.h = ngs.GridFunction(self.F0)
        self.h.vec.FV().NumPy()[:] = size if mesh.dim == 2 else np.sqrt(2.0 * size)

    def weights(self, zero_on: list[str]):
        """c_E as a facet GridFunction: 2 on interior facets (the one-sided fluxes sum to the jump, see
        :func:`_jump_terms`), 1 on boundary facets, 0 on the boundaries ``zero_on`` (names)."""
        w = ngs.GridFunction(self.F0)
        arr = w.vec.FV().NumPy()
        arr[:] = np.where(self.boundary, 1.0, 2.0)
        if zero_on:
            v = self.F0.TestFunction()
            lf = ngs.LinearForm(self.F0)
            lf += v * ngs.ds(definedon=self.mesh.Boundaries("|".join(sorted(set(zero_on)))))
            lf.Assemble()
            _cumulate(self.mesh, lf.vec)
            arr[np.array(lf.vec.FV().NumPy()) > 0] = 0.0
        return w


def _cumulate(mesh, *vectors) -> None:
    """Make assembled (distributed) vectors of a distributed mesh cumulated: every copy of a shared dof holds the
    sum of the ranks' parts (nothing on a serial mesh)."""
    if parallel.distributed(mesh):
        for vec in vectors:
            vec.Cumulate()


def _jump_terms(mesh, order: int, normal_fluxes: list, data: list[list], weights: list, scale, facets: _FacetData,
                weight_cf) -> np.ndarray:
    """Per element sum_c int_{dT} scale w c_E,c h_E J_c^2 ds for the normal flux components ``normal_fluxes``
    (CFs evaluated with the element's outward normal) and the boundary data ``data[c]`` = [(boundary, g)]
    (the natural-condition value of component c). J_c is the L2 projection onto the facet space of order
    ``order`` (the solution's order - 1: exact on straight facets) of the one-sided flux summed over the element
    boundaries: on interior facets half the jump
    (hence c_E = 2 there, i.e. h_E ||jump||^2 / 2 per neighbour), on boundary facets the misfit q.n - g."""
    if order == 0:       # the facet mass is diagonal: int_{dT} v summed over the elements
        F, minv = facets.F0, None
    else:
        F = ngs.FacetFESpace(mesh, order=order)
        uf, vf = F.TnT()
        m = ngs.BilinearForm(F)
        m += uf * vf * ngs.dx(element_boundary=True)
        m.Assemble()
        # block diagonal (one block per facet): a distributed mesh inverts this rank's part, J scaled by share below
        mat = m.mat.local_mat if parallel.distributed(mesh) else m.mat
        minv = mat.Inverse(inverse="sparsecholesky") if F.ndof else None
    vf = F.TestFunction()
    total = ngs.CoefficientFunction(0.0)
    for qn, bdata, w in zip(normal_fluxes, data, weights):
        lf = ngs.LinearForm(F)
        lf += qn * vf * ngs.dx(element_boundary=True)
        for name, g in bdata:
            lf += -g * vf * ngs.ds(definedon=mesh.Boundaries(name))
        lf.Assemble()
        _cumulate(mesh, lf.vec)
        J = ngs.GridFunction(F)
        if order == 0:
            J.vec.FV().NumPy()[:] = np.divide(lf.vec.FV().NumPy(), facets.mass0, out=np.zeros(F.ndof),
                                              where=facets.mass0 > 0)
        elif facets.share is not None:
            if minv is not None:
                J.vec.local_vec.data = minv * lf.vec.local_vec
            J = facets.share * J
        else:
            J.vec.data = minv * lf.vec
        total = total + w * J * J
    integrand = weight_cf * scale * facets.h * total
    return np.asarray(ngs.Integrate(integrand * ngs.dx(element_boundary=True, bonus_intorder=2), mesh,
                                    element_wise=True), dtype=float)


def _element_integral(mesh, cf, definedon=None) -> np.ndarray:
    measure = ngs.dx(bonus_intorder=2) if definedon is None else ngs.dx(definedon=definedon, bonus_intorder=2)
    return np.asarray(ngs.Integrate(cf * measure, mesh, element_wise=True), dtype=float)


def _recover(mesh, cf, ncomp: int, order: int, region, recovery: str):
    """q*: the CF ``cf`` (ncomp components) recovered into a continuous H1 field of ``order`` on ``region``."""
    Q = ngs.H1(mesh, order=order, dim=ncomp, definedon=region) if ncomp > 1 else \
        ngs.H1(mesh, order=order, definedon=region)
    g = ngs.GridFunction(Q)
    if recovery == "average":
        g.Set(cf, definedon=region)
    elif recovery == "l2":
        u, v = Q.TnT()
        m = ngs.BilinearForm(Q)
        m += ngs.InnerProduct(u, v) * ngs.dx(definedon=region)
        rhs = ngs.LinearForm(Q)
        rhs += ngs.InnerProduct(cf, v) * ngs.dx(definedon=region, bonus_intorder=2)
        m.Assemble()
        rhs.Assemble()
        g.vec.data = m.mat.Inverse(Q.FreeDofs(), inverse="sparsecholesky") * rhs.vec
    else:
        raise ValueError(f"recovery must be 'average' or 'l2', got {recovery!r}")
    return g


def _recovery_kind(order: int, wanted: str | None) -> str:
    if wanted is None:
        return "average" if order == 1 else "spr"
    if wanted not in ("average", "l2", "spr"):
        raise ValueError(f"recovery must be 'average', 'l2' or 'spr', got {wanted!r}")
    return wanted


def _spr_degree(order: int, wanted: int | None) -> int:
    return wanted if wanted is not None else order


def _recovery_order(order: int, wanted: int | None) -> int:
    return wanted if wanted is not None else (order if order == 1 else order + 1)


def cf_matrix(a: np.ndarray):
    return ngs.CoefficientFunction(tuple(float(v) for v in np.asarray(a).flatten()), dims=np.asarray(a).shape)


# ------------------------------------------------------------------------------------------------------------
# superconvergent patch recovery (SPR)
# ------------------------------------------------------------------------------------------------------------

_SIMPLEX = {2: ngs.TRIG, 3: ngs.TET}
_CHUNK = 2_000_000
"""Entries (points x monomials) per block of the vectorized SPR steps: bounds the work arrays (~16 MB each)."""


def _exponents(dim: int, degree: int) -> np.ndarray:
    """The exponents of the monomials of total degree <= ``degree`` in ``dim`` variables (n x dim)."""
    out = [e for e in np.ndindex(*(degree + 1,) * dim) if sum(e) <= degree]
    return np.array(sorted(out, key=lambda e: (sum(e), tuple(-k for k in e))), dtype=np.int64)


def _monomials(z: np.ndarray, exps: np.ndarray) -> np.ndarray:
    """The monomials ``exps`` at the (scaled) points z (..., dim) -> (..., n)."""
    out = None
    for c in range(z.shape[-1]):
        powers = np.ones(z.shape[:-1] + (int(exps[:, c].max()) + 1,))
        for k in range(1, powers.shape[-1]):
            powers[..., k] = powers[..., k - 1] * z[..., c]
        factor = powers[..., exps[:, c]]
        out = factor if out is None else out * factor
    return out


def _region_elements(mesh, region) -> np.ndarray:
    inside = np.asarray(ngs.Integrate(ngs.CoefficientFunction(1.0) * ngs.dx(definedon=region), mesh,
                                      element_wise=True), dtype=float)
    return np.flatnonzero(inside > 0)


def _simplicial(mesh) -> bool:
    """Whether the mesh part is simplicial (a part without elements is)."""
    if mesh.ne == 0:
        return mesh.dim in _SIMPLEX
    try:
        ev = element_vertices(mesh)
    except ValueError:                                  # mixed element types
        return False
    return ev.ndim == 2 and ev.shape[1] == mesh.dim + 1 and mesh.dim in _SIMPLEX


def _spr_eta2(mesh, cf, region, degree: int, scale_cf, metric: np.ndarray) -> np.ndarray | None:
    """Per element int_T scale (q* - q_h) . metric (q* - q_h) dx on ``region`` (0 elsewhere) with q* the
    superconvergent patch recovery of the field ``cf`` (module docstring): per vertex a least-squares fit P_a of
    degree ``degree`` to cf over the vertex patch (quadrature points, weighted: the local L2 projection; the
    patch of the region's boundary vertices widened by one ring of elements), blended by the barycentric
    coordinates, q* = sum_a lambda_a P_a (continuous, of degree ``degree`` + 1). None when the mesh is not
    simplicial.

    On a distributed mesh the patches of the vertices on the parts' borders span several ranks: the workers send
    their quadrature samples to rank 0, which fits the patches of the whole region (:func:`_spr_whole`) and sends
    each worker its elements' values (the serial numbers up to round-off; rank 0 holds the region's samples
    meanwhile)."""
    if parallel.anyof(mesh, not _simplicial(mesh)):
        return None
    elems = _region_elements(mesh, region)
    eta2 = np.zeros(mesh.ne)
    if parallel.distributed(mesh):
        samples = _spr_samples(mesh, cf, region, elems, degree, scale_cf) if elems.size else None
        eta2[elems] = _spr_whole(mesh, samples, degree, metric)
        return eta2
    if elems.size == 0:
        return eta2
    eta2[elems] = _spr_fit(*_spr_samples(mesh, cf, region, elems, degree, scale_cf), degree, metric)
    return eta2


def _spr_whole(mesh, samples, degree: int, metric: np.ndarray) -> np.ndarray:
    """This rank's values of the SPR fit over the samples of all ranks (fitted on rank 0; collective). The
    vertices are named by their coordinates (the parts hold exact copies of the whole mesh's)."""
    com = parallel.comm(mesh)
    gathered = com.gather(samples, root=0)
    pieces = None
    if com.rank == 0:
        parts = [g for g in gathered if g is not None]
        counts = [0 if g is None else len(g[0]) for g in gathered]
        pieces = [np.zeros(0)] * len(gathered)
        if parts:
            offsets = np.cumsum([0] + [len(g[1]) for g in parts[:-1]])
            _, number = np.unique(np.concatenate([g[1] for g in parts]), axis=0, return_index=False,
                                  return_inverse=True)
            number = np.asarray(number).ravel()
            xv = np.zeros((int(number.max()) + 1, parts[0][1].shape[1]))
            xv[number] = np.concatenate([g[1] for g in parts])
            ev = np.concatenate([number[off + g[0]] for off, g in zip(offsets, parts)])
            stack = [np.concatenate([g[k] for g in parts]) for k in range(2, 7)]
            whole = _spr_fit(ev, xv, *stack, degree, metric)
            pieces = np.split(whole, np.cumsum(counts)[:-1])
    return np.asarray(com.scatter(pieces, root=0), dtype=float)


def _spr_samples(mesh, cf, region, elems: np.ndarray, degree: int, scale_cf) -> tuple:
    """What the patch fit needs of the elements ``elems`` of ``region`` (all simplices): their vertices (numbers
    into the second entry, the vertex coordinates), sizes h_T, and at the quadrature points of order 2 degree + 2
    the values of ``cf``, the points, the weights (|det J| w_i) and ``scale_cf``."""
    dim = mesh.dim
    ir = ngs.IntegrationRule(_SIMPLEX[dim], 2 * degree + 2)
    nip = len(ir.points)
    pts = mesh.MapToAllElements(ir, ngs.VOL)
    q = np.asarray(cf(pts), dtype=float).reshape(mesh.ne, nip, cf.dim)[elems]
    xyz = np.column_stack([c(pts) for c in (ngs.x, ngs.y, ngs.z)[:dim]]).reshape(mesh.ne, nip, dim)[elems]
    jac = np.asarray(ngs.specialcf.JacobianMatrix(dim)(pts), dtype=float).reshape(mesh.ne, nip, dim, dim)[elems]
    wq = np.abs(np.linalg.det(jac)) * np.asarray(ir.weights, dtype=float)
    s = np.asarray(ngs.CoefficientFunction(scale_cf)(pts), dtype=float).reshape(mesh.ne, nip)[elems]
    used, ev = np.unique(element_vertices(mesh)[elems], return_inverse=True)    # the region's vertices
    ev = np.asarray(ev).reshape(len(elems), dim + 1)
    return ev, vertex_coords(mesh)[used], element_sizes(mesh)[elems], q, xyz, wq, s


def _spr_fit(ev, xv, hT, q, xyz, wq, s, degree: int, metric: np.ndarray) -> np.ndarray:
    """The SPR values eta_T^2 of the elements ``ev`` (vertex numbers into ``xv``) from their samples
    (:func:`_spr_samples`): the patch fits, blended by the barycentric coordinates, against the samples."""
    ne, dim = ev.shape[0], xv.shape[1]
    nv, nip = len(xv), q.shape[1]
    ir = ngs.IntegrationRule(_SIMPLEX[dim], 2 * degree + 2)
    ref = np.array([tuple(p) for p in ir.points], dtype=float)[:, :dim]
    lam = np.column_stack([ref, 1.0 - ref.sum(axis=1)])                  # barycentric, in element vertex order
    coef = _spr_coefficients(ev, xv, hT, q, xyz, wq, degree)
    hv = _vertex_sizes(ev, hT, nv)
    exps = _exponents(dim, degree)
    nm = len(exps)
    metric = np.asarray(metric, dtype=float)
    eta2 = np.zeros(ne)
    chunk = max(256, _CHUNK // (nip * nm * (dim + 1)))
    for lo in range(0, ne, chunk):
        sl = slice(lo, lo + chunk)
        e = ev[sl]                                                          # n x (dim+1)
        z = (xyz[sl][:, None, :, :] - xv[e][:, :, None, :]) / hv[e][:, :, None, None]
        vals = np.einsum("nkim,nkmc->nkic", _monomials(z, exps), coef[e])  # n x verts x nip x ncomp
        qs = np.einsum("ik,nkic->nic", lam, vals)
        d = qs - q[sl]
        eta2[sl] = np.einsum("ni,nic->n", wq[sl] * s[sl], (d @ metric) * d)
    return eta2


def _vertex_sizes(ev: np.ndarray, hT: np.ndarray, nv: int) -> np.ndarray:
    """Per vertex the largest h_T of its elements (m): the scale of its patch polynomial."""
    hv = np.zeros(nv)
    np.maximum.at(hv, ev.ravel(), np.repeat(hT, ev.shape[1]))
    hv[hv == 0] = 1.0
    return hv


def _spr_coefficients(ev, xv, hT, q, xyz, wq, degree: int) -> np.ndarray:
    """The patch polynomials' coefficients (nv x monomials x components): per vertex the weighted least-squares
    fit over its patch (its elements; on the region's boundary vertices also their neighbours' elements)."""
    ne, dim = ev.shape[0], xv.shape[1]
    nv, nip, ncomp = len(xv), q.shape[1], q.shape[2]
    # patches: vertex -> elements (sparse), widened on the region's boundary vertices
    inc = sp.csr_matrix((np.ones(ev.size), (np.repeat(np.arange(ne), dim + 1), ev.ravel())), shape=(ne, nv))
    facets = np.sort(np.concatenate([np.delete(ev, k, axis=1) for k in range(dim + 1)]), axis=1)
    uniq, count = np.unique(facets, axis=0, return_counts=True)
    boundary = np.zeros(nv, dtype=bool)
    boundary[uniq[count == 1].ravel()] = True
    ring1 = inc.T.tocsr()                                                 # vertex -> its elements
    ring2 = (ring1 @ inc) @ inc.T                                         # -> the elements of its neighbours
    patch = (sp.diags((~boundary).astype(float)) @ ring1 + sp.diags(boundary.astype(float)) @ ring2).tocsr()
    patch.eliminate_zeros()
    patch = patch.tocoo()
    hv = _vertex_sizes(ev, hT, nv)
    exps = _exponents(dim, degree)
    nm = len(exps)
    A = np.zeros((nv, nm, nm))
    b = np.zeros((nv, nm, ncomp))
    va, te = patch.row, patch.col                                         # (vertex, element) pairs
    chunk = max(256, _CHUNK // (nip * nm))
    for lo in range(0, len(va), chunk):
        a, t = va[lo:lo + chunk], te[lo:lo + chunk]
        m = _monomials((xyz[t] - xv[a][:, None, :]) / hv[a][:, None, None], exps)     # pairs x nip x nm
        mw = m * wq[t][..., None]
        mwt = mw.transpose(0, 2, 1)
        np.add.at(A, a, mwt @ m)
        np.add.at(b, a, mwt @ q[t])
    return np.linalg.pinv(A, rcond=1e-10, hermitian=True) @ b


# ------------------------------------------------------------------------------------------------------------
# heat
# ------------------------------------------------------------------------------------------------------------

def _heat_parts(forms: HeatForms):
    T = forms.temperature()
    f = forms.conductivity_factor(T)
    return T, f, f * (forms.kappa * ngs.grad(T))


def heat_energy_error(forms: HeatForms, gradient_exact: dict, order: int | None = None) -> float:
    """The true error sqrt(int w grad e . kappa f grad e) of the computed temperature against the exact gradient
    (``gradient_exact``: region -> vector CF, K/m), integrated region by region; the energy norm of the
    estimators (``order``: quadrature order, default 2p + 6)."""
    T, f, _ = _heat_parts(forms)
    q = order or 2 * forms.setup.order + 6
    tot = 0.0
    for name, g in gradient_exact.items():
        e = ngs.grad(T) - g
        tot += float(ngs.Integrate(forms.weight * f * ngs.InnerProduct(forms.kappa * e, e), forms.mesh, order=q,
                                   definedon=forms.mesh.Materials(name)))
    return math.sqrt(max(tot, 0.0))


def zz_heat(forms: HeatForms, *, recovery: str | None = None, recovery_order: int | None = None) -> Estimate:
    """Zienkiewicz-Zhu estimator of the heat forms' current temperature (module docstring)."""
    mesh, s = forms.mesh, forms.setup
    T, f, q = _heat_parts(forms)
    eta2 = np.zeros(mesh.ne)
    recovery = _recovery_kind(s.order, recovery)
    for name in s.props:
        region = mesh.Materials(name)
        kinv = np.linalg.inv(region_kappa(forms, name))
        if recovery == "spr":
            part = _spr_eta2(mesh, q, region, _spr_degree(s.order, recovery_order), forms.weight / f, kinv)
            if part is not None:
                eta2 += part
                continue
        qs = _recover(mesh, q, mesh.dim, _recovery_order(s.order, recovery_order), region,
                      "average" if recovery == "spr" else recovery)
        d = qs - q
        eta2 += _element_integral(mesh, forms.weight / f * ngs.InnerProduct(cf_matrix(kinv) * d, d), region)
    return Estimate("zz", "estimator", np.sqrt(np.maximum(eta2, 0.0)))


def region_kappa(forms: HeatForms, name: str) -> np.ndarray:
    """The conductivity tensor of a region (W/(m K)): its constant, or for data that vary the mean of
    kappa(x, T_h) over the region."""
    p = forms.setup.props[name]
    if p.kappa.dtype != object:
        return np.asarray(p.kappa, dtype=float)
    region, dim = forms.mesh.Materials(f"^{name}$"), forms.mesh.dim
    k = tensor_cf(p.kappa, forms.temperature())
    total = np.array(ngs.Integrate(k, forms.mesh, definedon=region), dtype=float).reshape(dim, dim)
    return total / float(ngs.Integrate(ngs.CoefficientFunction(1.0), forms.mesh, definedon=region))


def _varying_conductivity_terms(forms: HeatForms, T):
    """(d_i kappa_ij + d kappa_ij/dT d_i T) d_j T in the regions whose conductivity varies, else None: what
    div(kappa grad T) holds beyond kappa : hess T (NGSolve's Diff by a coordinate holds T_h fixed)."""
    parts, g, dim = {}, ngs.grad(T), forms.mesh.dim
    coords = (ngs.x, ngs.y, ngs.z)[:dim]
    for name, p in forms.setup.props.items():
        if p.kappa.dtype != object:
            continue
        k = tensor_cf(p.kappa, T)
        term = ngs.CoefficientFunction(0.0)
        for i in range(dim):
            for j in range(dim):
                dk = k[i, j].Diff(coords[i])
                if p.conductivity_uses_temperature:
                    dk = dk + k[i, j].Diff(T) * g[i]
                term = term + dk * g[j]
        parts[name] = term
    if not parts:
        return None
    cf = forms.mesh.MaterialCF(parts, default=0.0)
    return forms.pressure_factor * cf if forms.gf_pressure is not None else cf


def _heat_sources(forms: HeatForms):
    parts = {}
    for region, funcs in forms.setup.sources.items():
        for fn in (funcs if isinstance(funcs, list) else [funcs]):
            parts[region] = parts.get(region, 0) + fn(forms.t_new)
    return forms.mesh.MaterialCF(parts, default=0.0) if parts else ngs.CoefficientFunction(0.0)


def residual_heat(forms: HeatForms, *, c_volume: float = C_VOLUME, c_jump: float = C_JUMP) -> Estimate:
    """Explicit residual estimator of the heat forms' current temperature at t_new (module docstring)."""
    mesh, s, w = forms.mesh, forms.setup, forms.weight
    dim = mesh.dim
    T, f, q = _heat_parts(forms)
    # R_T = Q + div(kappa f grad T) (- rho c (T - T_old)/dt)
    R = _heat_sources(forms)
    if s.order >= 2:
        H = T.Operator("hesse")
        R = R + f * sum(forms.kappa[i, j] * H[i, j] for i in range(dim) for j in range(dim))
    if s.nonlinear:
        slope = mesh.MaterialCF({n: p.b for n, p in s.props.items()}, default=0.0)
        R = R + slope * ngs.InnerProduct(forms.kappa * ngs.grad(T), ngs.grad(T))
    varying = _varying_conductivity_terms(forms, T)
    if varying is not None:
        R = R + f * varying
    if s.axisymmetric:
        R = R + q[0] / ngs.x
    if not s.steady:
        R = R - forms.rho_c * forms.inv_dt * (T - forms.temperature(forms.gf_old))
    k = mesh.MaterialCF({n: float(np.trace(region_kappa(forms, n))) / dim for n in s.props}, default=1.0)
    p = s.order
    hT = _p0_field(mesh, element_sizes(mesh))
    eta2 = c_volume / p ** 2 * _element_integral(mesh, w * hT * hT / (k * f) * R * R)
    # normal flux jumps and boundary misfits
    n = ngs.specialcf.normal(dim)
    data = [(name, g(forms.t_new)) for name, g in s.flux.items()]
    data += [(name, h * (amb(forms.t_new) - T)) for name, (h, amb) in s.robin.items()]
    facets = _FacetData(mesh)
    zero = list(s.dirichlet) + [b for pair in s.contacts for b in pair]
    eta2 += c_jump / p * _jump_terms(mesh, p - 1, [q * n], [data], [facets.weights(zero)], 1 / (k * f), facets, w)
    return Estimate("residual", "estimator", np.sqrt(np.maximum(eta2, 0.0)))


# ------------------------------------------------------------------------------------------------------------
# elasticity
# ------------------------------------------------------------------------------------------------------------

def _voigt_index(dim: int):
    if dim == 2:
        return {(0, 0): 0, (1, 1): 1, (0, 1): 2, (1, 0): 2}
    return {(0, 0): 0, (1, 1): 1, (2, 2): 2, (1, 2): 3, (2, 1): 3, (0, 2): 4, (2, 0): 4, (0, 1): 5, (1, 0): 5}


def elastic_energy_error(forms: ElasticForms, strain_exact: dict, order: int | None = None) -> float:
    """The true error sqrt(int w (e_h - e)^T D (e_h - e)) (reduced Voigt strains, engineering shear) of the
    computed displacement against ``strain_exact`` (region -> reduced Voigt strain CF), region by region: the
    energy norm of the estimators (linear part of the law)."""
    u = forms.displacement()
    q = order or 2 * forms.setup.order + 6
    tot = 0.0
    for name, e in strain_exact.items():
        d = forms.strain_vector(u) - e
        tot += float(ngs.Integrate(forms.weight * ngs.InnerProduct(forms.cf_matrix(forms.D[name]) * d, d), forms.mesh,
                                   order=q, definedon=forms.mesh.Materials(name)))
    return math.sqrt(max(tot, 0.0))


def zz_elastic(forms: ElasticForms, *, recovery: str | None = None, recovery_order: int | None = None) -> Estimate:
    """Zienkiewicz-Zhu stress recovery estimator of the elastic forms' current displacement (module docstring)."""
    mesh, s = forms.mesh, forms.setup
    u = forms.displacement()
    eta2 = np.zeros(mesh.ne)
    recovery = _recovery_kind(s.order, recovery)
    for name in s.props:
        region = mesh.Materials(name)
        sh = forms.stress_vector(name, u)
        D = forms.D_ref[name]           # varying data: the representative stiffness weights the patch recovery
        if recovery == "spr":
            part = _spr_eta2(mesh, sh, region, _spr_degree(s.order, recovery_order), forms.weight, np.linalg.inv(D))
            if part is not None:
                eta2 += part
                continue
        ss = _recover(mesh, sh, D.shape[0], _recovery_order(s.order, recovery_order), region,
                      "average" if recovery == "spr" else recovery)
        d = ss - sh
        Dinv = cf_matrix(np.linalg.inv(D)) if forms.D[name] is D else ngs.Inv(forms.cf_matrix(forms.D[name]))
        eta2 += _element_integral(mesh, forms.weight * ngs.InnerProduct(Dinv * d, d), region)
    return Estimate("zz", "estimator", np.sqrt(np.maximum(eta2, 0.0)))


def _stiffness_scale(D: np.ndarray, dim: int) -> float:
    return float(np.trace(D[:dim, :dim])) / dim


def _varying_divergence(forms: ElasticForms, name: str, u, div: list) -> list:
    """``div`` plus the divergence terms of varying elastic data in region ``name``: (d_k D) e(u_h) and
    -d_k (b (T - T0)), each d_k the derivative in x_k with T held, plus d/dT times d_k T_h where T is a
    GridFunction (E(T), and the temperature gradient of the thermal stress)."""
    s = forms.setup
    dim = forms.dim
    vi = _voigt_index(dim)
    coords = (ngs.x, ngs.y, ngs.z)[:dim]
    T = s.temperature if isinstance(s.temperature, ngs.GridFunction) else None

    def total(cf, k):
        d = cf.Diff(coords[k])
        return d + cf.Diff(T) * ngs.grad(T)[k] if T is not None else d

    e = forms.strain_vector(u)
    D = forms.cf_matrix(forms.D[name])
    dT = forms.delta_T(name)
    thermal = forms.cf_vector(forms.b[name]) * dT if dT is not None else None
    out = list(div)
    for k in range(dim):
        dsk = total(D, k) * e
        if thermal is not None:
            dsk = dsk - total(thermal, k)
        for i in range(dim):
            out[i] = out[i] + dsk[vi[(i, k)]]
    return out


def residual_elastic(forms: ElasticForms, *, c_volume: float = C_VOLUME, c_jump: float = C_JUMP) -> Estimate:
    """Explicit residual estimator of the elastic forms' current displacement (module docstring): plane strain,
    plane stress and 3D, linear law (lam = 1). The thermal stress enters the element residual when the setup's
    temperature is a GridFunction (its gradient), the initial stress through its expression's derivatives."""
    mesh, s = forms.mesh, forms.setup
    dim = mesh.dim
    if s.model == "axisymmetric":
        raise ValueError("the residual estimator covers plane and 3D models; use 'zz' for axisymmetric ones")
    if s.nonlinear:
        raise ValueError("the residual estimator covers the linear law (lam = 1); use 'zz' for the lambda law")
    u = forms.displacement()
    vi = _voigt_index(dim)
    coords = (ngs.x, ngs.y, ngs.z)[:dim]
    # element residual f + div sigma_h, region by region
    R_parts = {}
    for name, p in s.props.items():
        D = forms.cf_matrix(forms.D[name])
        div = [ngs.CoefficientFunction(0.0) for _ in range(dim)]
        if s.order >= 2:
            H = [u.components[c].Operator("hesse") for c in range(dim)]
            for k in range(dim):
                de = [None] * len(forms.b[name])
                for (i, j), a in vi.items():
                    if i <= j:
                        de[a] = H[i][j, k] if i == j else H[i][j, k] + H[j][i, k]
                dsk = D * ngs.CoefficientFunction(tuple(de))
                for i in range(dim):
                    div[i] = div[i] + dsk[vi[(i, k)]]
        dT = forms.delta_T(name)
        if p.varying is not None:
            div = _varying_divergence(forms, name, u, div)
        elif dT is not None and isinstance(s.temperature, ngs.GridFunction):
            gT = ngs.grad(s.temperature)
            for i in range(dim):
                for k in range(dim):
                    div[i] = div[i] - float(forms.b[name][vi[(i, k)]]) * gT[k]
        s0 = forms.sigma0_vector()
        if s0 is not None:
            for i in range(dim):
                for k in range(dim):
                    div[i] = div[i] + s0[vi[(i, k)]].Diff(coords[k])
        rho = forms.rho[name] if p.varying is not None else p.density
        if s.gravity is not None and rho is not None and (p.varying is not None or p.density):
            for i in range(dim):
                div[i] = div[i] + rho * s.gravity[i]
        for bname, comps in s.body_force.items():
            if bname == name:
                for i in range(dim):
                    div[i] = div[i] + comps[i](forms.t)
        R_parts[name] = ngs.CoefficientFunction(tuple(div))
    R = mesh.MaterialCF(R_parts, default=ngs.CoefficientFunction((0.0,) * dim))
    k = mesh.MaterialCF({n: _stiffness_scale(forms.D_ref[n], dim) for n in s.props}, default=1.0)
    p = s.order
    hT = _p0_field(mesh, element_sizes(mesh))
    eta2 = c_volume / p ** 2 * _element_integral(mesh, forms.weight * hT * hT / k * ngs.InnerProduct(R, R))
    # traction jumps and boundary misfits, per component
    n = ngs.specialcf.normal(dim)
    sig = mesh.MaterialCF({name: forms.stress_vector(name, u) for name in s.props},
                          default=ngs.CoefficientFunction((0.0,) * len(next(iter(forms.b.values())))))
    fluxes = [sum(sig[vi[(c, j)]] * n[j] for j in range(dim)) for c in range(dim)]
    data = [[] for _ in range(dim)]
    for name, comps in s.traction.items():
        for c in range(dim):
            data[c].append((name, comps[c](forms.t)))
    for name, fp in s.pressure.items():
        for c in range(dim):
            data[c].append((name, -fp(forms.t) * n[c]))
    facets = _FacetData(mesh)
    oblique = [name for name, _ in forms.oblique]
    weights = [facets.weights(list(forms.fixed_names[c]) + oblique) for c in range(dim)]
    eta2 += c_jump / p * _jump_terms(mesh, p - 1, fluxes, data, weights, 1 / k, facets, forms.weight)
    return Estimate("residual", "estimator", np.sqrt(np.maximum(eta2, 0.0)))


# ------------------------------------------------------------------------------------------------------------
# registry: estimators
# ------------------------------------------------------------------------------------------------------------

@register("zz", "estimator", "forms")
def zz_estimator(forms, *, recovery: str | None = None, recovery_order: int | None = None) -> Estimate:
    """Zienkiewicz-Zhu flux (heat) or stress (elasticity) recovery estimator."""
    if isinstance(forms, HeatForms):
        return zz_heat(forms, recovery=recovery, recovery_order=recovery_order)
    if isinstance(forms, ElasticForms):
        return zz_elastic(forms, recovery=recovery, recovery_order=recovery_order)
    raise TypeError(f"the zz estimator needs HeatForms or ElasticForms, got {type(forms).__name__}")


@register("residual", "estimator", "forms")
def residual_estimator(forms, *, c_volume: float = C_VOLUME, c_jump: float = C_JUMP) -> Estimate:
    """Explicit residual estimator (element residual and flux/traction jumps)."""
    if isinstance(forms, HeatForms):
        return residual_heat(forms, c_volume=c_volume, c_jump=c_jump)
    if isinstance(forms, ElasticForms):
        return residual_elastic(forms, c_volume=c_volume, c_jump=c_jump)
    raise TypeError(f"the residual estimator needs HeatForms or ElasticForms, got {type(forms).__name__}")


# ------------------------------------------------------------------------------------------------------------
# indicators
# ------------------------------------------------------------------------------------------------------------

def contact_status(kind: str, lam_n: np.ndarray, lam_t: np.ndarray, bound=None) -> np.ndarray:
    """Nodal status (0 open, 1 stick, 2 slip) from the multipliers (Pa) of a contact law ``kind``
    ("frictionless", "tresca", "coulomb"; ``bound`` the slip bound g_c or the friction coefficient), as the
    contact output reports it."""
    lam_n = np.asarray(lam_n, dtype=float)
    q = np.linalg.norm(lam_t, axis=1) if np.ndim(lam_t) == 2 else np.abs(np.asarray(lam_t, dtype=float))
    if kind == "frictionless":
        return np.where(lam_n > 0, STATUS_SLIP, STATUS_OPEN)
    b = np.broadcast_to(np.asarray(bound, dtype=float), lam_n.shape)
    if kind == "coulomb":
        b = slip_bound(b, lam_n)
    sliding = (lam_n > 0) & (q >= b * (1 - 1e-9))
    return np.where(sliding, STATUS_SLIP, np.where(lam_n > 0, STATUS_STICK, STATUS_OPEN))


def side_edges(mesh, side: str) -> list[tuple[int, ...]]:
    return [tuple(v.nr for v in el.vertices) for el in mesh.Boundaries(side).Elements()]


@register("contact_zone", "indicator", "contact")
def contact_zone(contacts, *, layers: int = 0, active: bool = False, local_reach: bool = False) -> Estimate:
    """Flag the elements at the boundary of the active set and at stick/slip transitions (module docstring).

    ``contacts``: (mesh, [(ContactOperator, nodal status array)]) (status 0 open, 1 stick, 2 slip; e.g.
    :func:`contact_status` or the contact output's ``status``); ``layers`` extra rings of elements around the
    flagged ones; ``active``: flag the whole contact zone (every element touching a side segment with a node in
    contact), not only its boundary and transitions (for quantities inside the zone, e.g. the peak pressure).
    The opposite side's segments are flagged within twice the interface's longest nodal length of a flagged
    segment, or with ``local_reach`` within that segment's own length (on a graded mesh the global reach takes
    coarse elements far from a transition: the meshes that follow contact zones over time use the local one)."""
    mesh, contacts = contacts
    xy = vertex_coords(mesh)
    inc = _incidence(mesh)
    vmark = np.zeros(mesh.nv, dtype=bool)
    for op, status in contacts:
        status = np.asarray(status).astype(int)
        index = {int(v): j for j, v in enumerate(op.nodes)}
        points, lengths = [], []
        for seg in side_edges(mesh, op.side):
            js = [index[v] for v in seg if v in index]
            changes = len(js) >= 2 and len({int(status[j]) for j in js}) > 1
            if changes or (active and any(status[j] > 0 for j in js)):
                vmark[list(seg)] = True
                points.append(np.mean(xy[list(seg)], axis=0))
                lengths.append(float(np.linalg.norm(xy[seg[0]] - xy[seg[1]])))
        if op.opposite and points:
            if local_reach:
                reach = np.array(lengths)
            else:
                reach = np.full(len(points), 2.0 * float(np.max(op.length)) if op.size else 0.0)
            pts = np.array(points)
            for seg in side_edges(mesh, op.opposite):
                c = np.mean(xy[list(seg)], axis=0)
                if np.any(np.linalg.norm(pts - c, axis=1) <= reach):
                    vmark[list(seg)] = True
    flags = _grow(inc @ vmark > 0, inc, layers)
    return Estimate("contact_zone", "indicator", flags.astype(float))


def _incidence(mesh) -> sp.csr_matrix:
    """The element-vertex incidence matrix (ne x nv, ones)."""
    ev = element_vertices(mesh)
    rows = np.repeat(np.arange(ev.shape[0]), ev.shape[1])
    return sp.csr_matrix((np.ones(ev.size), (rows, ev.ravel())), shape=(mesh.ne, mesh.nv))


def _grow(flags: np.ndarray, inc: sp.csr_matrix, layers: int) -> np.ndarray:
    """``flags`` widened by ``layers`` rings of elements (sharing a vertex)."""
    flags = np.asarray(flags, dtype=bool)
    for _ in range(layers):
        flags = inc @ (inc.T @ flags.astype(float) > 0) > 0
    return flags


@register("phase_front", "indicator", "phase")
def phase_front(liquid_fraction, *, level: float = 0.5, layers: int = 1, predicted=None) -> Estimate:
    """Flag the elements the iso-line ``level`` of the nodal P1 field ``liquid_fraction`` (a GridFunction of an
    order-1 H1 space, dof = vertex) crosses, plus ``layers`` rings around them, and the elements the iso-line of
    ``predicted`` (the same kind of field, or None) crosses (module docstring)."""
    mesh = liquid_fraction.space.mesh
    ev = element_vertices(mesh)
    flags = np.zeros(mesh.ne, dtype=bool)
    for g in (liquid_fraction, predicted):
        if g is None:
            continue
        vals = np.asarray(g.vec.FV().NumPy())[:mesh.nv][ev]
        lo, hi = vals.min(axis=1), vals.max(axis=1)
        flags |= (lo <= level) & (hi >= level) & (lo < hi)
    flags = _grow(flags, _incidence(mesh), layers)
    return Estimate("phase_front", "indicator", flags.astype(float))
