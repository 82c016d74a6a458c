"""Elasticity forms of problem (P) without contact: (2.17)-(2.21) with the stress law (2.18)/(2.37)

    tau_ij = c*_ijkl(u) e_kl(u) - beta_ij (T - T0) + sigma0_ij,    c* = lam (A1/A_ref + delta)^(lam-1) c,

A1 = c_ijkl e_ij e_kl (2.1)-(2.5), written with the strain energy (Voigt vectors, engineering shear)

    W(e) = (A_ref/2) ((A1/A_ref + delta)^lam - delta^lam) - beta (T - T0) . e + sigma0 . e,

so that dW/de = tau; lam = 1 is linear elasticity with c (the seed's c = C/2, A1 measured in units of
A_ref = the A1 of a uniaxial strain eps_ref). Loads: body forces rho g and f (per region), tractions P and
pressure -p n on boundaries (2.19), prescribed displacements u0 per component (2.20)-(2.21), symmetry u_n = 0, tau_t = 0
(2.16): on boundaries along a coordinate axis as a component constraint, on oblique straight boundaries
with a multiplier (the normal traction, Pa) <mu, u.n> + <lambda, v.n>.

Models: plane strain and plane stress (x, y), axisymmetric (r = x, z = y; e_thetatheta = u_r / r, weight
r, u_r = 0 on the axis) and 3D. Units: u in m, stresses in Pa, T in K (or degC), beta in Pa/K.

Material data may vary in space (the seed's c_ijkl(x), beta(x), T0(x); E also with the given temperature T): a
region of varying data integrates c(x), beta(x), T0(x) and rho(x) as CoefficientFunctions built by the formulas of
the number path (:func:`~.materials.elastic_tensors`); a region of numbers keeps its constant matrices.

Near incompressibility: the displacement formulation's mean stress K tr e(u_h) is K times a small,
badly approximated number when nu -> 1/2 (P2: error ~ h / (1 - 2 nu)). Isotropic linear regions (lam = 1) can
use a mixed displacement-pressure formulation instead (``ElasticSetup.formulation``; :func:`mixed_regions`):
the mean stress p (Pa) is an unknown, the stress is

    sigma = 2 mu dev e(u) + p I - dev(beta) (T - T0) + sigma0,

with dev and tr of the full 3x3 strain (plane strain: e_zz = 0 counts in the trace and sigma_zz = -2 mu tr e / 3
+ p; axisymmetric: the hoop strain u_r / r counts), and p = K (tr e(u) - (tr beta / 3K) (T - T0)) holds weakly:

    int w [2 mu dev e(u) : dev e(v) + p tr e(v)] = loads + int w (T - T0) dev(beta) : e(v),
    int w q [tr e(u) - p / K] - s(p, q) = int w q (tr beta / 3K) (T - T0)     for all q,

(tr beta / 3K = 3 alpha for isotropic alpha), which stays valid at K -> infinity (the p q / K term vanishes).
Spaces: Taylor-Hood for order k >= 2 (u in P_k, p continuous P_{k-1}); for P1 the equal-order pair P1-P1 with
the Brezzi-Pitkaranta stabilization s(p, q) = int w ALPHA_P1 h^2 / mu grad p . grad q (MINI's bubbles condensed
give a term of this form; kept on P1 so that u stays in the plain P1 space the contact operators are built
on). One pressure space per mixed region (p jumps across material interfaces). The pressure unknown is scaled
by a modulus (``pressure_scale``) so that its rows are forces like the displacement rows. The compressible
problem is the same continuous problem (eliminating p gives K tr e tr e(v)), so results differ from the
displacement formulation by discretization error only.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .. import parallel
from ..fem.coefficients import TimeFunction, material_cf, regions_regex
from ..scene import expressions
from .choices import FORMULATIONS
from .materials import (
    ElasticProperties,
    ElasticTensors,
    axisymmetric,
    deviatoric_split,
    elastic_tensors,
    plane_strain,
    plane_stress,
    reduce_tensors,
    to_voigt_stress,
)

MODELS = ("plane_strain", "plane_stress", "axisymmetric", "3d")
MIXED_POISSON = 0.45
"""Poisson ratio above which ``formulation = "auto"`` solves an isotropic linear region with the mixed
formulation (see :func:`mixed_regions`; the measurements are in tests/test_incompressible.py)."""
ALPHA_P1 = 0.05
"""Brezzi-Pitkaranta stabilization factor of the P1-P1 pair (s(p, q) = ALPHA_P1 h^2 / mu grad p . grad q)."""
_TRACE = {"plane_strain": (1, 1, 0), "axisymmetric": (1, 1, 1, 0), "3d": (1, 1, 1, 0, 0, 0)}


@dataclass
class ElasticSetup:
    """Plain inputs of the elastic forms.

    ``dirichlet`` maps boundary names to one TimeFunction or None (free) per component (m); ``traction``
    to a TimeFunction per component (Pa); ``pressure`` to a TimeFunction (Pa); ``symmetry`` lists boundary
    names with u_n = 0; ``axis`` lists boundaries on the axis of an axisymmetric model (u_r = 0);
    ``initial_stress`` is a dim x dim list of TimeFunctions (Pa, in-plane/axisymmetric components);
    ``initial_stress_zz`` the plane-strain out-of-plane prestress (a TimeFunction, Pa, or None: no zz part);
    ``interpolate_T0`` maps a CF into the temperature's space as the thermal part sets its initial temperature
    (None: a varying T0 stays a CF): a varying T0 is then that field, so T - T0 = 0 at t = 0 exactly when T0 is
    the initial temperature (the seed's T0 in H1; a CF T0 would leave its interpolation error as thermal stress);
    ``temperature`` is a CoefficientFunction of T (K) for the thermal stress, or None; ``body_force`` maps
    region names to a TimeFunction per component (N/m^3), a volume load added to rho g.
    """

    props: dict[str, ElasticProperties]
    model: str
    order: int = 1
    dirichlet: dict[str, list] = field(default_factory=dict)
    traction: dict[str, list] = field(default_factory=dict)
    pressure: dict[str, TimeFunction] = field(default_factory=dict)
    symmetry: list[str] = field(default_factory=list)
    axis: list[str] = field(default_factory=list)
    gravity: tuple | None = None
    initial_stress: list | None = None
    initial_stress_zz: object | None = None
    interpolate_T0: object | None = None
    temperature: object | None = None
    regularization: float = 1e-6
    body_force: dict[str, list] = field(default_factory=dict)
    formulation: str = "auto"

    @property
    def nonlinear(self) -> bool:
        return any(p.lam != 1.0 for p in self.props.values())


def mixed_regions(setup: ElasticSetup) -> tuple[list[str], list[str]]:
    """(the regions solved with the mixed displacement-pressure formulation, notes for the user).

    ``formulation`` "displacement": none. "auto": the isotropic regions with nu > MIXED_POISSON, provided every
    region is linear (lam = 1) and the model is not plane stress (sigma_zz = 0 leaves no volumetric
    constraint: no locking); a region with nu > MIXED_POISSON the mixed formulation cannot take (anisotropic,
    or lam != 1 somewhere) is named in a note (the displacement formulation's mean stress may be inaccurate).
    "mixed": every isotropic region; a nonlinear region or plane stress raise ValueError, anisotropic regions
    keep the displacement formulation (named in a note)."""
    f = setup.formulation
    if f not in FORMULATIONS:
        raise ValueError(f"unknown formulation {f!r} (one of {', '.join(FORMULATIONS)})")
    if f == "displacement":
        return [], []
    iso = {name: p.youngs_modulus_and_poisson() for name, p in setup.props.items()}
    if f == "mixed":
        if setup.model == "plane_stress":
            raise ValueError("the mixed displacement-pressure formulation is for plane strain, axisymmetric and 3D "
                             "models (plane stress has no volumetric constraint)")
        bad = [name for name, p in setup.props.items() if p.lam != 1.0]
        if bad:
            raise ValueError(f"the mixed displacement-pressure formulation needs the linear law (rheology_lambda = 1):"
                             f" regions {', '.join(bad)}")
        notes = [f"materials.{name}: anisotropic: the mixed formulation covers isotropic materials only, this region "
                 "keeps the displacement formulation" for name, c in iso.items() if c is None]
        return [name for name, c in iso.items() if c is not None], notes
    high = [name for name, p in setup.props.items() if p.max_poisson > MIXED_POISSON + 1e-9]
    if not high or setup.model == "plane_stress":
        return [], []
    nonlinear = [name for name, p in setup.props.items() if p.lam != 1.0]
    notes = []
    for name in high:
        nu = setup.props[name].max_poisson
        why = ("is anisotropic (the mixed formulation covers isotropic materials only)" if iso[name] is None else
               f"has rheology_lambda != 1 in {', '.join(nonlinear)} (the mixed formulation needs the linear law)"
               if nonlinear else "")
        if why:
            notes.append(f"materials.{name}: Poisson ratio {nu:.4f} > {MIXED_POISSON}: the region {why}; it keeps the "
                         "displacement formulation, whose mean stress is inaccurate near nu = 0.5 "
                         "(error ~ h / (1 - 2 nu))")
    if nonlinear:
        return [], notes
    return [name for name in high if iso[name] is not None], notes


@dataclass
class _Mixed:
    """The data of one region of the mixed formulation: bulk and shear moduli (Pa), the deviatoric reduced
    stiffness Ddev = D - K m m^T (Pa), the deviatoric thermal vector bdev = b - b_m m (Pa/K), b_m / K (1/K),
    b_m = tr(beta)/3, the plane strain sigma_zz row and thermal coefficient of the deviatoric part, and the
    index of the region's pressure space in X."""

    K: float
    mu: float
    Ddev: np.ndarray
    bdev: np.ndarray
    bm_over_K: float
    bm: float
    zz: tuple | None
    index: int


@dataclass
class FloatingBody:
    """A body with rigid motions no displacement or symmetry condition holds (see
    :meth:`ElasticForms.floating_bodies`): its ``regions``, the ``names`` of the free motions and their
    coefficient vectors as the columns of ``modes`` (X-sized; translations in m per m, rotations in rad)."""

    regions: list
    names: list
    modes: np.ndarray


def _axis_aligned_normal(mesh, name: str) -> tuple[int, np.ndarray] | None:
    """(component, normal) when boundary ``name`` is straight and normal to a coordinate axis, else the
    normal (component None) when it is straight; raises ValueError when it is not straight."""
    normals = []
    dim = mesh.dim
    for el in mesh.Boundaries(name).Elements():
        pts = np.array([mesh[v].point for v in el.vertices])
        if dim == 2:
            t = pts[1] - pts[0]
            n = np.array([t[1], -t[0]])
        else:
            n = np.cross(pts[1] - pts[0], pts[2] - pts[0])
        normals.append(n / np.linalg.norm(n))
    normals = [n for part in parallel.allgather(mesh, normals) for n in part]   # a distributed mesh: every part's
    if not normals:
        raise ValueError(f"boundary {name!r} has no elements")
    n0 = normals[0]
    if any(abs(abs(float(np.dot(n, n0))) - 1) > 1e-8 for n in normals):
        raise ValueError(f"symmetry boundary {name!r} is not straight (planar)")
    k = int(np.argmax(np.abs(n0)))
    if abs(abs(n0[k]) - 1) < 1e-10:
        return k, n0
    return None, n0


def _region_groups(mesh) -> list[list[str]]:
    """The bodies of a distributed mesh as groups of region names: regions sharing a node (glued interfaces,
    one conforming mesh) belong to one body. Each region's nodes are marked in a P1 vector on the elements of
    this rank's part and summed over the ranks (a node on a part boundary sees the regions of both parts)."""
    names = list(mesh.GetMaterials())
    V = ngs.H1(mesh, order=1)
    marks = []
    for name in names:
        gf = ngs.GridFunction(V)
        arr = gf.vec.FV().NumPy()
        for el in mesh.Materials(name).Elements():
            arr[[v.nr for v in el.vertices]] = 1.0
        gf.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
        gf.vec.Cumulate()
        marks.append(gf.vec.FV().NumPy() > 0)
    pairs = {(i, j) for i in range(len(names)) for j in range(i + 1, len(names)) if np.any(marks[i] & marks[j])}
    pairs = set().union(*parallel.allgather(mesh, pairs))
    present = parallel.allgather(mesh, {i for i in range(len(names)) if marks[i].any()})
    present = set().union(*present)
    parent = list(range(len(names)))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for i, j in pairs:
        parent[root(i)] = root(j)
    groups: dict[int, list[str]] = {}
    for i in sorted(present):
        groups.setdefault(root(i), []).append(names[i])
    return list(groups.values())


def _rigid_modes(model: str, dim: int, center=(0.0, 0.0, 0.0)) -> dict:
    """The rigid motions of a model as CoefficientFunction components, rotations about ``center`` (m):
    axisymmetric the axial translation, plane 2 translations and the rotation, 3D 3 + 3."""
    x, y = ngs.x - center[0], ngs.y - center[1]
    z = ngs.z - center[2] if dim == 3 else 0
    if model == "axisymmetric":
        return {"translation along z": (0, 1)}
    if dim == 3:
        return {"translation along x": (1, 0, 0), "translation along y": (0, 1, 0),
                "translation along z": (0, 0, 1), "rotation about x": (0, -z, y),
                "rotation about y": (z, 0, -x), "rotation about z": (-y, x, 0)}
    return {"translation along x": (1, 0), "translation along y": (0, 1), "rotation about z": (-y, x)}


def _free_combinations(A: np.ndarray, names: list[str]) -> tuple[np.ndarray, list[str]]:
    """The combinations of rigid motions (columns of the constraint matrix A, one row per constrained
    value) that no constraint holds: (rows of coefficients, their names: a motion's name or a weighted sum)."""
    if A.size:
        _, sv, vt = np.linalg.svd(A, full_matrices=True)
        rank = int(np.sum(sv > 1e-10 * max(1.0, float(np.abs(A).max()))))
        null = vt[rank:]
    else:
        null = np.eye(len(names))
    labels = [names[int(np.argmax(np.abs(v)))] if np.count_nonzero(np.abs(v) > 1e-8) == 1
              else " + ".join(f"{c:.2g} x ({n})" for c, n in zip(v, names) if abs(c) > 1e-8) for v in null]
    return null, labels


class ElasticForms:
    """Spaces, state and forms of the elastic problem on a given mesh (builds no mesh, writes no file)."""

    def __init__(self, mesh, setup: ElasticSetup):
        if setup.model not in MODELS:
            raise ValueError(f"unknown model {setup.model!r}")
        self.mesh = mesh
        self.setup = setup
        self.dim = mesh.dim
        self.t = ngs.Parameter(0.0)
        self.linear_switch = ngs.Parameter(0.0)   # 1: the secant form uses c* = c (start of the iterations)
        comp_dirichlet: list[list[str]] = [[] for _ in range(self.dim)]
        for name, comps in setup.dirichlet.items():
            for k, c in enumerate(comps):
                if c is not None:
                    comp_dirichlet[k].append(name)
        self.oblique: list[tuple[str, np.ndarray]] = []
        for name in setup.symmetry:
            k, n = _axis_aligned_normal(mesh, name)
            if k is not None:
                comp_dirichlet[k].append(name)
            else:
                self.oblique.append((name, n))
        for name in setup.axis:
            comp_dirichlet[0].append(name)
        flags = {f"dirichlet{'xyz'[k]}": regions_regex(set(names)) for k, names in enumerate(comp_dirichlet)
                 if names}
        self.fixed_names = comp_dirichlet
        self.V = ngs.VectorH1(mesh, order=setup.order, **flags)
        self.multiplier_spaces = [self._multiplier_space(name, n) for name, n in self.oblique]
        self._material_matrices()
        # the mixed formulation: one pressure space per region, after V and the multipliers
        names, self.formulation_notes = mixed_regions(setup)
        self.pressure_spaces = [ngs.H1(mesh, order=max(setup.order - 1, 1), definedon=mesh.Materials(name))
                                for name in names]
        self.mixed: dict[str, _Mixed] = {}
        for k, name in enumerate(names):
            self.mixed[name] = self._mixed_data(name, 1 + len(self.multiplier_spaces) + k)
        self.pressure_scale = max((float(setup.props[n].C[5, 5]) for n in self.mixed), default=1.0)
        """Pa per unit of the pressure unknowns (the largest shear modulus of the mixed regions; of varying data the
        representative one)."""
        extra = [*self.multiplier_spaces, *self.pressure_spaces]
        self.compound = bool(extra)
        """True when X = [V, multipliers, pressures] (else X = V)."""
        self.X = ngs.FESpace([self.V, *extra]) if extra else self.V
        self.gf = ngs.GridFunction(self.X)
        self.weight = ngs.x if setup.model == "axisymmetric" else ngs.CoefficientFunction(1.0)
        # output points closer to the axis than this (m) take the hoop strain's limit (:meth:`strain_vector`):
        # there u_r / r divides the round-off of u_r = 0 by a round-off r
        self.axis_tolerance = (1e-8 * parallel.allmax(mesh, float(np.max(np.abs(np.asarray(
            mesh.ngmesh.Coordinates())[:, 0]), initial=0.0))) if setup.model == "axisymmetric" else 0.0)
        self.u_frozen = ngs.GridFunction(self.V)   # the last iterate u_n of the secant method
        # one quadrature (order 2 order) for every integral of the energy, the secant form and its right-hand
        # side: NGSolve's default orders differ between energies and linear forms (a P2 temperature in the
        # thermal stress was integrated exactly by the linear form, not by the energy), so Newton and the
        # secant method solved different discrete problems (1e-2 apart in H1 on a thermal P2 case)
        order2 = 2 * setup.order
        if setup.model == "axisymmetric" and order2 < 4:
            # the degree-2 triangle rule has its points on the edge midpoints: on an edge on the axis r = 0 the
            # hoop strain u_r / r was 0 / 0 (NaN in the matrix and the load of every element touching the axis)
            order2 = 4
        self.rule_order = order2
        self.intrules = {et: ngs.IntegrationRule(et, order2) for et in (ngs.ET.TRIG, ngs.ET.QUAD, ngs.ET.TET,
                                                                         ngs.ET.PRISM, ngs.ET.PYRAMID, ngs.ET.HEX)}
        self.bnd_intrules = {et: ngs.IntegrationRule(et, order2) for et in (ngs.ET.SEGM, ngs.ET.TRIG, ngs.ET.QUAD)}
        self._build()

    # -- material data in the model's reduced Voigt form ----------------------------------------------------
    def _multiplier_space(self, name: str, nvec: np.ndarray):
        """The multipliers of u.n = 0 on the oblique symmetry boundary ``name``: H1 on it, of the field order,
        without the dofs where the component conditions already hold u.n = 0 (every component k with n_k != 0
        prescribed there: the row of u.n would vanish). Where only some are (an oblique boundary meeting an
        axis-aligned symmetry boundary or a one-component displacement) the multiplier holds the rest of u.n."""
        Q = ngs.H1(self.mesh, order=self.setup.order, definedon=self.mesh.Boundaries(name))
        ns = ngs.H1(self.mesh, order=self.setup.order).ndof     # component c of V: dofs c * ns + scalar dof
        free_v, free_q = self.V.FreeDofs(), Q.FreeDofs()
        comps = [k for k in range(self.dim) if abs(float(nvec[k])) > 1e-12]
        for i in range(Q.ndof):
            if free_q[i] and not any(free_v[k * ns + i] for k in comps):
                free_q.Clear(i)         # in place: the compound space X, built afterwards, takes it over
        return Q

    def _material_matrices(self):
        """Per region: the reduced stiffness D (Pa), thermal stress vector b (Pa/K) and, for plane strain,
        the sigma_zz row and its thermal coefficient (see :mod:`ngs_geomech.mechanics.materials`); the
        stress-free temperature T0 and the density rho (None: none given).

        Numbers give float arrays. A region of varying data (:attr:`ElasticProperties.varying`) gets object arrays
        of floats and CoefficientFunctions of x, y, z (and of the setup's temperature for E(T)) from the same
        formulas (:func:`~.materials.elastic_tensors`, :func:`~.materials.reduce_tensors`), and CFs for T0 and rho
        where they vary; ``D_ref`` holds the reduced stiffness of the representative numbers (scales, weights:
        equal to D for numbers)."""
        self.D, self.b, self.zz = {}, {}, {}
        self.D_ref, self.T0, self.rho, self.tensors = {}, {}, {}, {}
        for name, p in self.setup.props.items():
            zz = None
            if self.setup.model == "3d":
                D, b = p.C, to_voigt_stress(p.beta)
            elif self.setup.model == "plane_strain":
                red = plane_strain(p.C, p.beta)
                D, b, zz = red.D, red.beta, (red.stress_out[0], red.beta_out[0])
            elif self.setup.model == "plane_stress":
                red = plane_stress(p.C, p.beta)
                D, b = red.Q, red.beta
            else:
                red = axisymmetric(p.C, p.beta, name)
                D, b = red.D, red.beta
            self.D[name], self.b[name], self.zz[name] = np.asarray(D), np.asarray(b), zz
            self.D_ref[name], self.T0[name], self.rho[name] = self.D[name], p.T0, p.density
            if p.varying is not None:
                T = self.setup.temperature
                t = self.tensors[name] = elastic_tensors(
                    p.varying.material, self.dim, lambda v, T=T: material_cf(v, T) if isinstance(v, str) else float(v))
                red = reduce_tensors(self.setup.model, t.C, t.b)
                self.D[name], self.b[name], self.zz[name] = red.D, red.b, red.zz
                self.T0[name], self.rho[name] = t.T0, t.density
        self._interpolate_T0()

    def _interpolate_T0(self) -> None:
        """Replace the varying (CF) T0 of regions by its field in the temperature's space (``interpolate_T0``),
        one field over the whole mesh: per region T0 on that region, the numbers elsewhere (a T0 that jumps
        across a region boundary is smeared over the boundary's elements there). Numbers stay numbers."""
        f = self.setup.interpolate_T0
        varying = [n for n, v in self.T0.items() if isinstance(v, ngs.CoefficientFunction)]
        if f is None or self.setup.temperature is None or not varying:
            return
        field = f(self.mesh.MaterialCF({n: _entry_cf(v) for n, v in self.T0.items()}, default=0.0))
        for name in varying:
            self.T0[name] = field

    @property
    def stiffness_uses_temperature(self) -> bool:
        """Whether a region's stiffness depends on the temperature (E(T)): its matrix changes with T."""
        return any(p.varying is not None and isinstance(p.varying.material.youngs_modulus, str)
                   and expressions.TEMPERATURE in expressions.uses(p.varying.material.youngs_modulus)
                   for p in self.setup.props.values())

    def _mixed_data(self, name: str, index: int) -> _Mixed:
        p = self.setup.props[name]
        if p.varying is not None:
            return self._mixed_varying(name, index, self.tensors[name])
        m = np.asarray(_TRACE[self.setup.model], dtype=float)
        C = np.asarray(p.C, dtype=float)
        mu = float(C[5, 5])
        K = float(C[0, 0] + 2 * C[0, 1]) / 3
        bm = float(np.trace(np.asarray(p.beta, dtype=float))) / 3
        zz = None
        if self.zz[name] is not None:
            row, bz = self.zz[name]
            zz = (np.asarray(row, dtype=float) - K * m, float(bz) - bm)
        return _Mixed(K=K, mu=mu, Ddev=self.D[name] - K * np.outer(m, m), bdev=self.b[name] - bm * m,
                      bm_over_K=bm / K, bm=bm, zz=zz, index=index)

    def _mixed_varying(self, name: str, index: int, t: ElasticTensors) -> _Mixed:
        """:meth:`_mixed_data` of a region of varying data: K, mu, the deviatoric parts as CFs (object arrays)."""
        d = deviatoric_split(t.C, t.b, self.D[name], self.b[name], self.zz[name], _TRACE[self.setup.model])
        return _Mixed(K=d.K, mu=d.mu, Ddev=d.Ddev, bdev=d.bdev, bm_over_K=d.bm / d.K, bm=d.bm, zz=d.zz, index=index)

    def displacement(self, gf=None):
        """The displacement (GridFunction of V) of ``gf`` (a GridFunction of X; default: the solution)."""
        g = gf if gf is not None else self.gf
        return g.components[0] if self.compound else g

    def pressure(self, name: str, gf=None):
        """The mean stress p (Pa) of mixed region ``name`` in ``gf`` (default: the solution), a CF."""
        g = gf if gf is not None else self.gf
        return self.pressure_scale * g.components[self.mixed[name].index]

    def trace_strain(self, e):
        """The trace tr e (-) of a reduced Voigt strain vector e (plane strain: e_zz = 0; axisymmetric: with e_tt)."""
        m = _TRACE[self.setup.model]
        return sum(e[k] for k, c in enumerate(m) if c)

    def strain_vector(self, u, on_axis: bool = False):
        """Reduced Voigt strain: (exx, eyy, gxy) plane; (err, ezz, ett, grz) axisymmetric; 6 in 3D. ``on_axis``
        (output at points, e.g. the vertices of VTK files): the hoop strain u_r / r takes its limit du_r/dr on the
        axis r = 0 (closer than :attr:`axis_tolerance`) instead of 0 / 0 (the forms integrate at interior points
        and keep u_r / r)."""
        G = ngs.grad(u)
        if self.setup.model == "3d":
            return ngs.CoefficientFunction((G[0, 0], G[1, 1], G[2, 2], G[1, 2] + G[2, 1], G[0, 2] + G[2, 0],
                                            G[0, 1] + G[1, 0]))
        if self.setup.model == "axisymmetric":
            hoop = ngs.IfPos(ngs.x - self.axis_tolerance, u[0] / ngs.x, G[0, 0]) if on_axis else u[0] / ngs.x
            return ngs.CoefficientFunction((G[0, 0], G[1, 1], hoop, G[0, 1] + G[1, 0]))
        return ngs.CoefficientFunction((G[0, 0], G[1, 1], G[0, 1] + G[1, 0]))

    def cf_matrix(self, a: np.ndarray):
        """A matrix CF of a float array, or of an object array of floats and CFs (varying data; compiled: the
        entries share their subexpressions, e.g. lambda(x) and mu(x), evaluated once per point: assembly of a P2
        plane problem at 93k dofs took 0.46 s uncompiled, 0.17 s compiled, 0.14 s for a constant matrix)."""
        if a.dtype == object:
            return ngs.CoefficientFunction(tuple(_entry_cf(v) for v in a.flat), dims=a.shape).Compile()
        return ngs.CoefficientFunction(tuple(float(v) for v in a.flatten()), dims=a.shape)

    def cf_vector(self, a: np.ndarray):
        """A vector CF of a float array, or of an object array of floats and CFs (varying data)."""
        if a.dtype == object:
            return ngs.CoefficientFunction(tuple(_entry_cf(v) for v in a))
        return ngs.CoefficientFunction(tuple(float(v) for v in a))

    def delta_T(self, name: str):
        """T - T0 of region ``name`` (a CF), None without a temperature."""
        if self.setup.temperature is None:
            return None
        return self.setup.temperature - self.T0[name]

    def initial_stress_tensor(self):
        """The initial stress (Pa) as a dim x dim CF (in-plane components in 2D), or None without one."""
        s0 = self.setup.initial_stress
        if s0 is None:
            return None
        return ngs.CoefficientFunction(tuple(f(self.t) for row in s0 for f in row), dims=(self.dim, self.dim))

    def sigma0_vector(self):
        """The initial stress (Pa) as the model's reduced Voigt vector, or None without one."""
        s0 = self.setup.initial_stress
        if s0 is None:
            return None
        m = [[f(self.t) for f in row] for row in s0]
        if self.setup.model == "3d":
            return ngs.CoefficientFunction((m[0][0], m[1][1], m[2][2], m[1][2], m[0][2], m[0][1]))
        if self.setup.model == "axisymmetric":
            return ngs.CoefficientFunction((m[0][0], m[1][1], m[0][0], m[0][1]))  # hoop = radial (isotropic)
        return ngs.CoefficientFunction((m[0][0], m[1][1], m[0][1]))

    def factor(self, name: str, e):
        """The secant factor lam (A1/A_ref + delta)^(lam - 1) of region ``name`` for the strain vector e."""
        p = self.setup.props[name]
        if p.lam == 1.0:
            return ngs.CoefficientFunction(1.0)
        return p.secant_factor(self.A1(name, e), self.setup.regularization)

    def A1(self, name: str, e):
        """A1 = e : c : e (Pa) of region ``name`` for the reduced strain vector e (2.2)."""
        return ngs.InnerProduct(e, self.cf_matrix(self.D[name]) * e)

    def stress_vector(self, name: str, u, on_axis: bool = False):
        """Reduced Voigt stress of region ``name`` (Pa), the law (2.18) with the lambda factor. In a region of
        the mixed formulation the volumetric part is the solution's pressure (:meth:`pressure`), whatever u.
        ``on_axis``: the strain of :meth:`strain_vector` with the axis limit (output)."""
        e = self.strain_vector(u, on_axis)
        dT = self.delta_T(name)
        if name in self.mixed:
            mx = self.mixed[name]
            m = self.cf_vector(np.asarray(_TRACE[self.setup.model], dtype=float))
            s = self.cf_matrix(mx.Ddev) * e + self.pressure(name) * m
            if dT is not None:
                s = s - dT * self.cf_vector(mx.bdev)
            s0 = self.sigma0_vector()
            return s if s0 is None else s + s0
        s = self.factor(name, e) * (self.cf_matrix(self.D[name]) * e)
        if dT is not None:
            s = s - dT * self.cf_vector(self.b[name])
        s0 = self.sigma0_vector()
        return s if s0 is None else s + s0

    # -- forms -----------------------------------------------------------------------------------------------
    def _loads(self, v, sign: float = 1.0):
        """The load terms (body forces, tractions, pressure) tested with v, each times ``sign``."""
        s, w = self.setup, sign * self.weight
        terms = []
        if s.gravity is not None:
            for name in s.props:
                rho = self.rho[name]
                if rho is not None and not _is_zero(rho):
                    g = ngs.CoefficientFunction(tuple(rho * gi for gi in s.gravity[:self.dim]))
                    terms.append(w * g * v * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules))
        for name, comps in s.body_force.items():
            f = ngs.CoefficientFunction(tuple(fc(self.t) for fc in comps))
            terms.append(w * f * v * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules))
        n = ngs.specialcf.normal(self.dim)
        for name, comps in s.traction.items():
            P = ngs.CoefficientFunction(tuple(f(self.t) for f in comps))
            terms.append(w * P * v * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules))
        for name, f in s.pressure.items():
            terms.append(-w * f(self.t) * (n * v)
                         * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules))
        return terms

    def _mixed_terms(self, name: str, u, v, pt, qt):
        """(bilinear integrand, load integrand tested with (v, q), Lagrangian integrand in (u, p)) of mixed
        region ``name`` without the weight; pt, qt the pressure trial and test functions of X (unknowns in units
        of ``pressure_scale``)."""
        mx = self.mixed[name]
        ps = self.pressure_scale
        p, q = ps * pt, ps * qt
        eu, ev = self.strain_vector(u), self.strain_vector(v)
        Dd = self.cf_matrix(mx.Ddev)
        tu, tv = self.trace_strain(eu), self.trace_strain(ev)
        a = ngs.InnerProduct(Dd * eu, ev) + p * tv + q * tu - p * q / mx.K
        lag = 0.5 * ngs.InnerProduct(Dd * eu, eu) + p * tu - p * p / (2 * mx.K)
        if self.setup.order == 1:
            h = ngs.specialcf.mesh_size
            stab = ALPHA_P1 * h * h / mx.mu
            a = a - ps * ps * stab * ngs.InnerProduct(ngs.grad(pt), ngs.grad(qt))
            lag = lag - 0.5 * ps * ps * stab * ngs.InnerProduct(ngs.grad(pt), ngs.grad(pt))
        f = ngs.CoefficientFunction(0.0)
        dT = self.delta_T(name)
        if dT is not None:
            f = dT * (ngs.InnerProduct(self.cf_vector(mx.bdev), ev) + mx.bm_over_K * q)
            lag = lag - dT * (ngs.InnerProduct(self.cf_vector(mx.bdev), eu) + mx.bm_over_K * p)
        return a, f, lag

    def trial_test(self):
        """(u, v, trials, tests): displacement trial/test functions and those of X (tuples when compound)."""
        trials, tests = self.X.TnT()
        if self.compound:
            return trials[0], tests[0], trials, tests
        return trials, tests, (trials,), (tests,)

    def _build(self):
        s, w = self.setup, self.weight
        u, v, trials, tests = self.trial_test()
        # energy (Newton) -------------------------------------------------------------------------
        energy = 0
        for name, p in s.props.items():
            if name in self.mixed:     # the Lagrangian: its derivative is the residual of the mixed system
                k = self.mixed[name].index
                _, _, lag = self._mixed_terms(name, u, v, trials[k], tests[k])
                s0 = self.sigma0_vector()
                if s0 is not None:
                    lag = lag + ngs.InnerProduct(s0, self.strain_vector(u))
                energy += w * lag * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules)
                continue
            e = self.strain_vector(u)
            W = p.energy(self.A1(name, e), s.regularization)
            dT = self.delta_T(name)
            if dT is not None:
                W = W - dT * ngs.InnerProduct(self.cf_vector(self.b[name]), e)
            s0 = self.sigma0_vector()
            if s0 is not None:
                W = W + ngs.InnerProduct(s0, e)
            energy += w * W * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules)
        for term in self._loads(u, -1.0):
            energy += term
        for k, (name, nvec) in enumerate(self.oblique):
            lam = trials[1 + k]
            nn = ngs.CoefficientFunction(tuple(float(c) for c in nvec[:self.dim]))
            energy += w * lam * (nn * u) * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules)
        self.newton_form = ngs.BilinearForm(self.X)
        self.newton_form += ngs.Variation(energy)
        # secant modules method: coefficients frozen at u_n (2.32)-(2.34) --------------------------------
        sec = ngs.BilinearForm(self.X)
        rhs = ngs.LinearForm(self.X)
        for name in s.props:
            mdx = ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules)
            if name in self.mixed:
                k = self.mixed[name].index
                a, f, _ = self._mixed_terms(name, u, v, trials[k], tests[k])
                sec += w * a * mdx
                if self.delta_T(name) is not None:
                    rhs += w * f * mdx
            else:
                D = self.cf_matrix(self.D[name])
                fac = self.linear_switch + (1 - self.linear_switch) * self.factor(name,
                                                                                  self.strain_vector(self.u_frozen))
                sec += w * fac * ngs.InnerProduct(D * self.strain_vector(u), self.strain_vector(v)) * mdx
            dT = self.delta_T(name)
            if dT is not None and name not in self.mixed:
                rhs += w * dT * ngs.InnerProduct(self.cf_vector(self.b[name]), self.strain_vector(v)) * mdx
            s0 = self.sigma0_vector()
            if s0 is not None:
                rhs += -w * ngs.InnerProduct(s0, self.strain_vector(v)) * mdx
        for term in self._loads(v):
            rhs += term
        for k, (name, nvec) in enumerate(self.oblique):
            lam, mu = trials[1 + k], tests[1 + k]
            nn = ngs.CoefficientFunction(tuple(float(c) for c in nvec[:self.dim]))
            sec += (w * (lam * (nn * v) + mu * (nn * u))
                    * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules))
        self.secant_form, self.secant_rhs = sec, rhs

    def unheld_rigid_motions(self) -> list[str]:
        """The rigid motions the displacement and symmetry conditions do not hold (empty: all held).

        Each rigid motion of the model (plane: 2 translations and the rotation; axisymmetric: the axial
        translation; 3D: 3 translations and 3 rotations) is evaluated on the constrained dofs and, for oblique
        symmetry boundaries, as u.n there; the combinations vanishing on all of them are free. A mesh of several
        bodies (parts not joined by glued interfaces) is checked body by body (``'<motion> of body <regions>'``):
        a rigid motion of the whole mesh is held as soon as one body is, which left a second, unsupported body
        free (a singular system solved without a word).
        """
        if parallel.distributed(self.mesh):
            return self._unheld_distributed()
        if self._bodies()[0] > 1:
            return [f"{name} of body {'+'.join(fb.regions)}" for fb in self.floating_bodies() for name in fb.names]
        return self._unheld_whole_mesh()

    def _body_modes(self, regions) -> dict:
        """The rigid motions of the body made of ``regions`` (:func:`_rigid_modes`), rotations about its centroid
        (global integrals: the same on every rank of a distributed mesh)."""
        where = self.mesh.Materials(regions_regex(set(regions)))
        vol = ngs.Integrate(ngs.CoefficientFunction(1.0), self.mesh, definedon=where)
        c = np.array([ngs.Integrate(cx, self.mesh, definedon=where) / vol for cx in (ngs.x, ngs.y, ngs.z)[:self.dim]])
        return _rigid_modes(self.setup.model, self.dim, c)

    def _unheld_distributed(self) -> list[str]:
        """:meth:`unheld_rigid_motions` on a distributed mesh (:meth:`_distributed_bodies`)."""
        bodies = self._distributed_bodies()
        out = []
        for regions, _, _, _, names in bodies:
            label = f" of body {'+'.join(sorted(regions))}" if len(bodies) > 1 else ""
            out += [f"{name}{label}" for name in names]
        return out

    def _distributed_bodies(self) -> list[tuple]:
        """The bodies of a distributed mesh and their free rigid motions: per body (regions, its rigid motions
        (:meth:`_body_modes`), the mask of its dofs on this rank, the null combinations and their names of
        :func:`_free_combinations`). The bodies are the groups of regions sharing a node (:func:`_region_groups`),
        and each body's constraint matrix A (rows on this rank's constrained dofs and oblique-symmetry vertices)
        enters through its Gram matrix A^T A summed over the ranks (same null space)."""
        mesh, dim = self.mesh, self.dim
        groups = _region_groups(mesh)
        fixed = ~np.array(list(self.V.FreeDofs()), dtype=bool)
        g = ngs.GridFunction(self.V)
        out = []
        for regions in groups:
            modes = self._body_modes(regions)
            mask = np.zeros(self.V.ndof, dtype=bool)
            for el in mesh.Elements(ngs.VOL):
                if el.mat in regions:
                    mask[[d for d in self.V.GetDofNrs(el) if d >= 0]] = True
            body_fixed = fixed & mask
            obl = [(np.array(mesh[v].point[:dim]), nvec[:dim]) for name, nvec in self.oblique
                   for el in mesh.Boundaries(name).Elements() for v in el.vertices
                   if any(e.mat in regions for e in mesh[v].elements)] if self.oblique else []
            columns = []
            for comps in modes.values():
                cf = ngs.CoefficientFunction(comps)
                g.Set(cf)
                col = list(g.vec.FV().NumPy()[body_fixed])
                col += [float(np.dot(np.array(cf(mesh(*p))).ravel(), nvec)) for p, nvec in obl]
                columns.append(col)
            A = np.array(columns, dtype=float).reshape(len(modes), -1).T
            gram = parallel.allsum(mesh, A.T @ A)
            w, vec = np.linalg.eigh(gram)
            a_eff = (vec * np.sqrt(np.maximum(w, 0.0))).T        # same singular values and vectors as A
            null, names = _free_combinations(a_eff, list(modes))
            out.append((regions, modes, mask, null, names))
        return out

    def _floating_distributed(self) -> list[FloatingBody]:
        """:meth:`floating_bodies` on a distributed mesh: the modes as global arrays
        (:class:`~ngs_geomech.parallel.GlobalDofs` of V, the numbering of the distributed contact solve)."""
        dofs = parallel.GlobalDofs(self.V)
        g = ngs.GridFunction(self.V)
        out = []
        for regions, modes, mask, null, names in self._distributed_bodies():
            if len(null) == 0:
                continue
            vecs = []
            for comps in modes.values():
                g.Set(ngs.CoefficientFunction(comps))
                vecs.append(dofs.gather(np.where(mask, g.vec.FV().NumPy(), 0.0)))
            out.append(FloatingBody(sorted(regions), names, np.array(vecs).T @ null.T))
        return out

    def _bodies(self):
        """(number of bodies, body label per vertex, body label per volume element, region name per volume
        element): the connected parts of the mesh. The element vertices come from netgen's element arrays (a
        Python loop over NGSolve's elements took 9 s of a 3D contact set-up at 130k P2 dofs)."""
        from scipy.sparse.csgraph import connected_components
        mesh = self.mesh
        arr = (mesh.ngmesh.Elements3D() if mesh.dim == 3 else mesh.ngmesh.Elements2D()).NumPy()
        nodes = np.asarray(arr["nodes"], dtype=np.int64)
        if len(nodes) != mesh.ne:
            raise AssertionError("floating bodies: netgen's element array does not match the mesh")
        valid = nodes > 0
        rows = np.repeat(np.arange(mesh.ne), valid.sum(axis=1))
        cols = nodes[valid] - 1
        inc = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(mesh.ne, mesh.nv))
        ncomp, labels = connected_components(inc.T @ inc, directed=False)
        materials = np.array(mesh.GetMaterials(), dtype=object)
        return ncomp, labels, labels[nodes[:, 0] - 1], materials[np.asarray(arr["index"], dtype=np.int64) - 1]

    def _body_dofs(self, body: int, elem_body: np.ndarray, elem_region: np.ndarray) -> np.ndarray:
        """The dofs of V on the elements of ``body``: the dofs of its regions when no region is shared with
        another body (the usual case), else element by element."""
        regions = set(elem_region[elem_body == body])
        if not any(set(elem_body[elem_region == r]) != {body} for r in regions):
            mask = np.array(list(self.V.GetDofs(self.mesh.Materials(regions_regex(regions)))), dtype=bool)
            return np.where(mask)[0]
        return np.unique([d for nr in np.where(elem_body == body)[0]
                          for d in self.V.GetDofNrs(ngs.ElementId(ngs.VOL, int(nr))) if d >= 0])

    def _unheld_whole_mesh(self) -> list[str]:
        modes = _rigid_modes(self.setup.model, self.dim)
        fixed = ~np.array(list(self.V.FreeDofs()), dtype=bool)
        g = ngs.GridFunction(self.V)
        oblique_points = []
        for name, nvec in self.oblique:
            pts = {v.nr: np.array(self.mesh[v].point) for el in self.mesh.Boundaries(name).Elements()
                   for v in el.vertices}
            oblique_points += [(p, nvec[:self.dim]) for p in pts.values()]
        columns = []
        for comps in modes.values():
            cf = ngs.CoefficientFunction(comps)
            g.Set(cf)
            col = list(g.vec.FV().NumPy()[fixed])
            for p, nvec in oblique_points:   # u.n = 0 at the vertices of oblique symmetry boundaries
                col.append(float(np.dot(np.array(cf(self.mesh(*p))).ravel(), nvec)))
            columns.append(col)
        return _free_combinations(np.array(columns, dtype=float).T, list(modes))[1]

    def rigid_mode_vectors(self) -> np.ndarray:
        """The rigid motions of the model (:func:`_rigid_modes`: axisymmetric the axial translation, plane 2
        translations and the rotation, 3D 3 + 3; rotations about the vertices' centroid) as coefficient vectors of
        V, one column each: e.g. the near-null space of an algebraic multigrid."""
        pts = np.array([v.point for v in self.mesh.vertices], dtype=float)
        center = tuple(pts.mean(axis=0)) + (0.0,) * (3 - pts.shape[1])
        g = ngs.GridFunction(self.V)
        cols = []
        for comps in _rigid_modes(self.setup.model, self.dim, center).values():
            g.Set(ngs.CoefficientFunction(comps))
            cols.append(np.array(g.vec.FV().NumPy()))
        return np.column_stack(cols)

    def floating_bodies(self) -> list[FloatingBody]:
        """The bodies (connected parts of the mesh: blocks joined by glued interfaces) with rigid motions the
        displacement and symmetry conditions do not hold: semi-coercive bodies that only contact can hold.

        Per body its regions, the names of its free rigid motions (rotations about the body's centroid) and
        their coefficient vectors in X (columns of ``modes``, zero outside the body)."""
        if parallel.distributed(self.mesh):
            return self._floating_distributed()
        mesh, dim = self.mesh, self.dim
        ncomp, labels, elem_body, elem_region = self._bodies()
        if ncomp == 1 and not self._unheld_whole_mesh():
            return []
        fixed = ~np.array(list(self.V.FreeDofs()), dtype=bool)
        pts = np.array([mesh[ngs.NodeId(ngs.VERTEX, k)].point[:dim] for k in range(mesh.nv)])
        obl = [(k, nvec[:dim]) for name, nvec in self.oblique
               for k in {v.nr for el in mesh.Boundaries(name).Elements() for v in el.vertices}]
        g = ngs.GridFunction(self.V)
        out = []
        for b in range(ncomp):
            dofs = self._body_dofs(b, elem_body, elem_region)
            regions = sorted(set(elem_region[elem_body == b]))
            modes = self._body_modes(regions)
            vecs, cons = [], []
            bfixed = dofs[fixed[dofs]]
            for comps in modes.values():
                cf = ngs.CoefficientFunction(comps)
                g.Set(cf)
                v = np.zeros(self.X.ndof)
                v[dofs] = g.vec.FV().NumPy()[dofs]
                vecs.append(v)
                col = list(v[bfixed])
                for k, nvec in obl:
                    if labels[k] == b:
                        col.append(float(np.dot(np.array(cf(mesh(*pts[k]))).ravel(), nvec)))
                cons.append(col)
            null, names = _free_combinations(np.array(cons, dtype=float).T, list(modes))
            if len(null) == 0:
                continue
            R = np.array(vecs).T @ null.T
            out.append(FloatingBody(regions, names, R))
        return out

    def dirichlet_values(self):
        """Vector boundary CF of the prescribed displacements at the current time (free components 0)."""
        vals = {}
        for name, comps in self.setup.dirichlet.items():
            vals[name] = ngs.CoefficientFunction(tuple(f(self.t) if f is not None else 0.0 for f in comps))
        if not vals:
            return None
        return self.mesh.BoundaryCF(vals, default=ngs.CoefficientFunction((0.0,) * self.dim))

    # -- post-processing --------------------------------------------------------------------------------------
    def stress_tensor(self, u=None):
        """The full 3x3 stress tensor (Pa) as one CoefficientFunction over all regions: plane strain with
        sigma_zz (the zz prestress ``initial_stress_zz``, if any, plus the elastic and thermal part of e_zz = 0),
        plane stress with sigma_zz = 0, axisymmetric in (r, z, theta) axes."""
        u = u if u is not None else self.displacement()
        per_region = {}
        for name in self.setup.props:
            sv = self.stress_vector(name, u, on_axis=True)
            m = self.setup.model
            if m == "3d":
                comps = (sv[0], sv[5], sv[4], sv[5], sv[1], sv[3], sv[4], sv[3], sv[2])
            elif m == "axisymmetric":
                comps = (sv[0], sv[3], 0, sv[3], sv[1], 0, 0, 0, sv[2])
            else:
                szz = self.plane_strain_zz(name, u) if m == "plane_strain" else 0
                comps = (sv[0], sv[2], 0, sv[2], sv[1], 0, 0, 0, szz)
            per_region[name] = ngs.CoefficientFunction(tuple(ngs.CoefficientFunction(c) for c in comps),
                                                       dims=(3, 3))
        return self.mesh.MaterialCF(per_region, default=ngs.CoefficientFunction((0.0,) * 9, dims=(3, 3)))

    def plane_strain_zz(self, name: str, u):
        """sigma_zz (Pa) of region ``name`` in plane strain: the row of e_zz = 0 (with the lambda factor, or the
        mixed pressure), minus beta_zz (T - T0), plus the out-of-plane prestress ``initial_stress_zz``."""
        row, bz = self.zz[name] if name not in self.mixed else self.mixed[name].zz
        e = self.strain_vector(u)
        szz = self.factor(name, e) * ngs.InnerProduct(self.cf_vector(np.asarray(row)), e)
        if name in self.mixed:
            szz = szz + self.pressure(name)
        dT = self.delta_T(name)
        if dT is not None:
            szz = szz - dT * (float(bz) if isinstance(bz, (int, float)) else bz)
        if self.setup.initial_stress_zz is not None:
            szz = szz + self.setup.initial_stress_zz(self.t)
        return szz

    def strain_energy_density(self, u=None):
        """W of the elastic part (J/m^3): (A_ref/2)((A1/A_ref + delta)^lam - delta^lam), per region."""
        u = u if u is not None else self.displacement()
        vals = {}
        for name, p in self.setup.props.items():
            e = self.strain_vector(u, on_axis=True)
            if name in self.mixed:    # 1/2 e : C : e = mu dev e : dev e + (K tr e)^2 / (2K), K tr e = p + b_m dT
                mx = self.mixed[name]
                dT = self.delta_T(name)
                ktr = self.pressure(name) + (mx.bm * dT if dT is not None else 0.0)
                vals[name] = 0.5 * ngs.InnerProduct(self.cf_matrix(mx.Ddev) * e, e) + ktr * ktr / (2 * mx.K)
                continue
            vals[name] = p.energy(self.A1(name, e), self.setup.regularization)
        return self.mesh.MaterialCF(vals, default=0.0)


def _entry_cf(v):
    """A CF of an array entry: a number, or a CF as it is."""
    return v if isinstance(v, ngs.CoefficientFunction) else ngs.CoefficientFunction(float(v))


def _is_zero(v) -> bool:
    return isinstance(v, (int, float)) and v == 0


def stress_measures(sigma):
    """Von Mises stress, mean stress (Pa) and the principal stresses sigma_1 >= sigma_2 >= sigma_3 (Pa) of a
    3x3 stress CoefficientFunction (tension positive)."""
    s = sigma
    mean = (s[0, 0] + s[1, 1] + s[2, 2]) / 3
    dev = s - mean * ngs.Id(3)
    vm = ngs.sqrt(1.5 * ngs.InnerProduct(dev, dev))
    eig = s.Eig()               # NGSolve's eigenvalues are not always in order (nearly diagonal tensors): sort
    a, b, c = eig[9], eig[10], eig[11]
    high = _larger(_larger(a, b), c)
    low = _smaller(_smaller(a, b), c)
    return {"von_mises": vm, "mean_stress": mean, "sigma_1": high, "sigma_2": a + b + c - high - low, "sigma_3": low}


def _larger(a, b):
    return ngs.IfPos(a - b, a, b)


def _smaller(a, b):
    return ngs.IfPos(a - b, b, a)
