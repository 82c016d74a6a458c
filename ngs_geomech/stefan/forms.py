"""The two-phase Stefan problem in enthalpy form, seed (2.46)-(2.51), (2.55): the nodal enthalpy graph and the
lumped P1 forms of one backward Euler step (builds no mesh, writes no file; the materials' laws are in
:mod:`ngs_geomech.stefan.materials`).

Model. In a phase-change material (PCM) with phase-change temperature Theta_R (K or degC), volumetric latent
heat L (J/m^3), heat capacities C_s, C_l (rho c of the solid and of the liquid, J/(m^3 K)) and conductivities
k_s, k_l (W/(m K)), the Stefan conditions (2.46) (T continuous and equal to Theta_R on the phase boundary,
the jump of the normal heat flux equal to L times the normal speed of the boundary) are the weak form of

    d e/dt - div(grad theta) = W,    e in H(T),    theta = theta(T),                           (2.49)

with the enthalpy graph H = dPhi of (2.48) (e = C_s (T - Theta_R) for T < Theta_R, e in [0, L] at
T = Theta_R, e = L + C_l (T - Theta_R) for T > Theta_R, J/m^3) and the Kirchhoff variable
theta(T) = int_{Theta_R}^T k(s) ds (W/m). The conductivity of each phase follows the product's linear law
k_s(T) = k_s f(T), k_l(T) = k_l f(T), f(T) = 1 + b (T - T_ref) (b = ``conductivity_temperature_coefficient``,
1/K; T_ref = ``reference_temperature``, K; k_s, k_l the values at T_ref), so that

    theta(T) = k_phase (T - Theta_R) (1 + b/2 (T + Theta_R - 2 T_ref))     (k_phase = k_s below, k_l above Theta_R):

piecewise quadratic in T with a kink at Theta_R (piecewise linear when b = 0: constant k per phase). It is
monotone only where f > 0 (T > T_ref - 1/b for b > 0): the solver keeps its iterates there and stops with
:class:`ConductivityRangeError` (naming the regions and the law) when a temperature reached leaves that range.
A plain material (no phase change) has e = C T and theta = k T (k (T - T_ref)(1 + b/2 (T - T_ref)) with b != 0,
the same up to a constant). W is a volumetric source (W/m^3).
Without deformation heating, the term rho beta Theta_0 e(u_t) of (2.49) is not included here.

Unknown. The enthalpy graph is multivalued in T, but its inverse T = beta(e) is a Lipschitz, piecewise
linear function (slope 1/C_s, 0 on the mushy interval [0, L], 1/C_l). The unknown is therefore the nodal
enthalpy e, and the step equation is single valued and piecewise linear in e (b = 0), or piecewise quadratic
(b != 0: d theta/de = k(T)/C on a sensible branch, no longer constant per branch). The seed's B z - d + dPhi(z) = 0
(z = Theta, dPhi = M H) is the same equation written in the multivalued direction.

Discretization. P1 elements; the storage term and the loads are integrated with the vertex rule (the nodes of
the element as points, weights |element|/(d + 1): mass lumping), so the enthalpy law holds node by node, and
the conduction term is the P1 stiffness applied to the nodal Kirchhoff values of each region,

    m_i (e_i - e_i^old)/dt + sum_regions (K_r theta_r(T))_i = F_i(t_new),    T_i = beta_i(e_i),      (2.55)

with m_i = int phi_i (lumped, m^2 in 2D, m^3 in 3D), K_r the stiffness matrix of region r for unit
conductivity (int K_hat grad phi_j . grad phi_i with the region's shape K_hat, the identity when isotropic:
the conductivity tensor of each phase is k_phase K_hat, the phases scaling one anisotropy, so that the flux
-k_phase K_hat grad T = -K_hat grad theta keeps one Kirchhoff variable per region) and F_i = int W phi_i +
int_flux q phi_i (W per metre of depth in 2D). At a node shared by several regions the nodal enthalpy is the
m-weighted mean e_i = sum_r (m_i^r / m_i) e_r(T_i): still a monotone graph in T_i (with a flat part per
phase-change temperature of the touching PCMs), whose inverse beta_i is what the solver uses. T is continuous across
regions; the Kirchhoff variable is taken per region, so different conductivity laws may meet.
With lumping and a non-obtuse mesh the scheme keeps the discrete maximum principle (K_r is an M-matrix).

Conductivities that vary in x, y, z (``variation`` G(x) of :mod:`ngs_geomech.stefan.materials`: the phases' tensors
k_s G(x), k_l G(x), sharing the variation) give K_r = int G grad phi_j . grad phi_i (the element rule of P1
gradients: G at the element's centroid, a positive multiple of the element's constant stiffness): the conduction
term is div(G grad theta) with the same Kirchhoff variable, exact for this class; K_r stays an M-matrix on a
non-obtuse mesh when G = g(x) I with g > 0, and its columns still sum to zero (energy conservation unchanged).

Contact interfaces (two bodies meshed independently, non-matching nodes on the two sides) pass heat by a
penalty on the temperature jump, approximating the continuity T^k = T^l, equal fluxes of (2.43):

    A_Gamma(T) = gamma_c B^T D^-1 B T,     (B T)_i = int_Gamma mu_i (T_m - T_s) ds,   D_i = int_Gamma mu_i ds,

with mu_i the P1 hat functions of the master side (segment-based mortar integrals,
:mod:`ngs_geomech.fem.mortar`), i.e. gamma_c times the squared jump averaged around each master node: an
interface conductance gamma_c (W/(m^2 K)). Its columns sum to zero (the heat leaving one side enters the
other: the energy balance stays exact) and it is symmetric positive semi-definite (the step stays monotone).
gamma_c = penalty * k_max / h (k_max the larger conductivity of the two sides at T_ref, h the mean length of the master
segments; ``penalty`` dimensionless, default 1e3): the jump is then about 1/penalty of the temperature drop over
one element (measured in tests/test_stefan_interfaces.py). It enters the Newton matrix as one more "group"
with a linear Kirchhoff map (theta = T). It is not an M-matrix (neighbouring minion nodes get positive
couplings), so the discrete maximum principle holds only up to O(1/penalty) at the interface.

Heat transfer (Robin) conditions q = h (T_amb - T) (h in W/(m^2 K)) are lumped on their boundaries: the nodal
conductances r_i = int_Gamma w h phi_i ds (the row sums of the boundary mass) join the interface penalty as the
linear "group" (theta = T), so that r_i T_i enters the residual and, through dT/de, the Newton matrix, and
int_Gamma w h T_amb phi_i ds is a load of its own (:meth:`StefanForms.robin_loads`): the heat they bring in,
sum_i (h T_amb - r T)_i per unit time (:meth:`StefanForms.robin_heat_rate`), is counted apart in the energy
balance. Lumped, they keep the step monotone.

Axisymmetric problems (``StefanSetup.axisymmetric``; a 2D mesh of the (r, z) half plane, r = x): every integral
carries the weight w = r, as in the heat forms (energies and heats per radian). The lumped masses and sources are
the row sums of the r-weighted mass, m_i = int r phi_i (an exact rule; the vertex rule would give the nodes on
the axis no storage), the fluxes and heat transfer conditions are weighted by r on their boundaries, and the
stiffness int r K_hat grad phi_j . grad phi_i keeps the signs of its plane counterpart (the M-matrix property).

Backward Euler with any step dt (the seed's time discretization (2.55)). Energy is conserved exactly by the
discrete equations: sum_i m_i (e_i - e_i^old) = dt (sum_i F_i + boundary inflow at the Dirichlet nodes), since
the columns of every K_r sum to zero.

Distributed meshes (MPI, :mod:`ngs_geomech.parallel`). Every nodal array of this class (``mass``,
``mass_by_group``, ``weights``, the graph, ``loads``, :meth:`conduction`, the states) holds this rank's local
vertices with *cumulated* values (a vertex shared by several ranks has its full value on each), so the nodal maps
stay pointwise numpy. The assembled parts (the lumped masses, the loads, K_r theta: the local matrix ``stiffness``
of a rank, ``a.mat.local_mat``, applied to a cumulated vector gives a distributed one) are cumulated with
:meth:`cumulate`; sums over nodes (:meth:`heat_content`, :meth:`melted_volume`, :meth:`latent_heat_stored`,
:meth:`nodal_sum`) count the vertices this rank owns and add over the ranks, so they are global on every rank.
Contact interfaces (the mortar penalty) are refused there (ValueError): not supported under MPI.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .. import parallel
from ..fem.coefficients import Steady, expression_function, regions_regex, tensor_cf
from ..heat.conductance import InterfaceConductance
from .conductance import NodalConductances
from .materials import (
    ConductivityRangeError,
    PhaseChangeMaterial,
    PlainThermalMaterial,
    StefanMaterial,
    check_number,
)


def time_function(value) -> Callable:
    """A TimeFunction (make(t) -> CF) from a number, an expression string or a TimeFunction."""
    if isinstance(value, (int, float, str)):
        return expression_function(value)
    if callable(value):
        return value
    raise ValueError(f"expected a number, an expression or a function of t, got {value!r}")


@dataclass
class StefanSetup:
    """Plain inputs of the Stefan forms.

    ``materials`` maps every region of the mesh to a :class:`PhaseChangeMaterial` or a
    :class:`PlainThermalMaterial`; ``dirichlet`` maps boundary names to temperatures (K; number, expression
    in x, y, z, t or TimeFunction); ``flux`` maps boundary names to the heat flux into the body (W/m^2);
    ``sources`` maps region names to power densities (W/m^3). Unnamed boundaries are insulated.
    ``interfaces`` lists contact interfaces as (master boundary, minion boundary, penalty): heat passes by the
    jump penalty of the module docstring (penalty dimensionless, > 0). ``pressure_coefficients`` maps regions
    to c_p (1/Pa): their conductivities (both phases) are multiplied by 1 + c_p p, p the mean pressure given by
    :meth:`StefanForms.set_pressure` (compression > 0). ``robin`` maps boundary names to (h, T_amb): the heat
    transfer condition q = h (T_amb - T) (h in W/(m^2 K), > 0; T_amb in K: number, expression or TimeFunction).
    ``axisymmetric``: a 2D mesh of the (r, z) half plane (r = x >= 0), every integral weighted by r (per radian).
    """

    materials: dict[str, StefanMaterial]
    dirichlet: dict[str, object] = field(default_factory=dict)
    flux: dict[str, object] = field(default_factory=dict)
    sources: dict[str, object] = field(default_factory=dict)
    interfaces: list[tuple[str, str, float]] = field(default_factory=list)
    pressure_coefficients: dict[str, float] = field(default_factory=dict)
    robin: dict[str, tuple[float, object]] = field(default_factory=dict)
    axisymmetric: bool = False
    conductances: list[InterfaceConductance] = field(default_factory=list)
    """Contact interfaces that pass heat by a contact conductance (:mod:`.conductance`) instead of the penalty."""


DEFAULT_INTERFACE_PENALTY = 1e3
"""gamma_c = penalty * k_max / h of a contact interface (module docstring)."""


def vertex_rules(dim: int) -> dict:
    """The vertex (lumping) rules: the element's vertices as points, weights |reference element|/n_vertices."""
    if dim == 2:
        return {ngs.TRIG: ngs.IntegrationRule([(0, 0), (1, 0), (0, 1)], [1 / 6] * 3),
                ngs.QUAD: ngs.IntegrationRule([(0, 0), (1, 0), (1, 1), (0, 1)], [1 / 4] * 4)}
    return {ngs.TET: ngs.IntegrationRule([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [1 / 24] * 4),
            ngs.HEX: ngs.IntegrationRule([(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)], [1 / 8] * 8)}


def shape_cf(material: StefanMaterial, dim: int):
    """The shape of a material's conductivity tensors as a dim x dim CoefficientFunction: K_hat (``anisotropy``)
    or G(x) (``variation``, its expressions of x, y, z, r), None for the identity (isotropic, constant)."""
    if material.variation is not None:
        return tensor_cf(np.array(material.variation, dtype=object))
    if material.anisotropy is not None:
        return ngs.CoefficientFunction(tuple(float(c) for row in material.anisotropy for c in row), dims=(dim, dim))
    return None


@dataclass
class NodalState:
    """The nodal temperature and its generalized derivative for a vector of nodal enthalpies.

    ``T`` (K), ``dT_de`` (K m^3/J: 1/C on the sensible branches, 0 on the mushy ones), ``mushy`` (bool: the
    node lies on a flat part, T = a phase-change temperature), ``segment`` (index of the temperature interval
    between the sorted phase-change temperatures, or of the flat part for mushy nodes)."""

    T: np.ndarray
    dT_de: np.ndarray
    mushy: np.ndarray
    segment: np.ndarray


class StefanForms:
    """Spaces, lumped masses, stiffness matrices, the nodal enthalpy graph and the loads of one Stefan problem.

    Groups: regions with equal material data share one stiffness matrix. The nodal graph is held as arrays over
    the sorted phase-change temperatures Theta_0 < ... < Theta_{K-1} of the PCMs present (a virtual breakpoint
    at 0 when there is none): per node the enthalpies just below and above each breakpoint (``e_lo``, ``e_hi``,
    n x K, J/m^3) and the heat capacity on each interval between them (``capacity``, n x (K + 1), J/(m^3 K)).
    """

    def __init__(self, mesh, setup: StefanSetup):
        self.mesh = mesh
        self.setup = setup
        regions = set(mesh.GetMaterials())
        missing = sorted(regions - set(setup.materials))
        if missing:
            raise ValueError(f"Stefan problem: no material for the region(s) {missing}")
        unknown = sorted(set(setup.materials) - regions)
        if unknown:
            raise ValueError(f"Stefan problem: material(s) for region(s) {unknown} that are not in the mesh "
                             f"(regions: {sorted(regions)})")
        boundaries = set(mesh.GetBoundaries())
        for kind in ("dirichlet", "flux", "robin"):
            bad = sorted(set(getattr(setup, kind)) - boundaries)
            if bad:
                raise ValueError(f"Stefan problem: {kind} boundary(ies) {bad} not in the mesh "
                                 f"(boundaries: {sorted(boundaries)})")
        bad = sorted(set(setup.sources) - regions)
        if bad:
            raise ValueError(f"Stefan problem: source region(s) {bad} not in the mesh")
        if (setup.interfaces or setup.conductances) and parallel.distributed(mesh):
            raise ValueError("Stefan problem: contact interfaces (the heat penalty on the temperature jump between "
                             f"touching blocks, {[m for m, _, _ in setup.interfaces]}) are not supported on a "
                             "distributed mesh (MPI): run this scene serially")
        for master, minion, penalty in setup.interfaces:
            bad = sorted({master, minion} - boundaries)
            if bad:
                raise ValueError(f"Stefan problem: interface side(s) {bad} not in the mesh")
            check_number(f"penalty of interface {master!r}", penalty, positive=True)
        for name, (h, _) in setup.robin.items():
            check_number(f"heat transfer coefficient of boundary {name!r}", h, positive=True)
        for name, mat in setup.materials.items():
            if not isinstance(mat, (PhaseChangeMaterial, PlainThermalMaterial)):
                raise ValueError(f"Stefan problem: material of region {name!r} must be a PhaseChangeMaterial or a "
                                 f"PlainThermalMaterial, got {type(mat).__name__}")
            for what in ("anisotropy", "variation"):
                shape = getattr(mat, what)
                if shape is not None and np.shape(np.array(shape, dtype=object)) != (mesh.dim, mesh.dim):
                    raise ValueError(f"Stefan problem: the {what} of region {name!r} must be {mesh.dim}x{mesh.dim}, "
                                     f"got shape {np.shape(np.array(shape, dtype=object))}")
        if setup.axisymmetric and mesh.dim != 2:
            raise ValueError(f"Stefan problem: an axisymmetric problem needs a 2D (r, z) mesh, got dim {mesh.dim}")
        self.dim = mesh.dim
        self.distributed = parallel.distributed(mesh)
        """Whether the mesh is a part of a distributed mesh (MPI): see the module docstring."""
        self.version = 0
        """Changes when the stiffness matrices change (:meth:`set_pressure`)."""
        self.rules = vertex_rules(self.dim)
        types = {el.type for el in mesh.Elements(ngs.VOL)}
        if not types <= set(self.rules):
            raise ValueError(f"Stefan problem: element types {sorted(map(str, types - set(self.rules)))} have no "
                             "vertex rule here (triangles, quadrilaterals, tetrahedra and hexahedra do)")
        self.axisymmetric = bool(setup.axisymmetric)
        self.weight = ngs.x if self.axisymmetric else None
        """The weight of every integral: r = x in axisymmetric problems (per radian), None (1) otherwise."""
        if self.axisymmetric:
            # row sums of the r-weighted mass, int r phi_i (exact: degree 2 on triangles, 2 x 2 on quads): the
            # vertex rule would give the nodes on the axis (r = 0) no storage at all. Interior points only: a
            # source like the deformation heating holds u_r / r, undefined on the axis
            self.rules = {ngs.TRIG: ngs.IntegrationRule([(1 / 6, 1 / 6), (2 / 3, 1 / 6), (1 / 6, 2 / 3)], [1 / 6] * 3),
                          ngs.QUAD: ngs.IntegrationRule(ngs.QUAD, 4)}
        self.dx_lumped = ngs.dx(intrules=self.rules)
        self.V = ngs.H1(mesh, order=1, dirichlet=regions_regex(setup.dirichlet) if setup.dirichlet else "")
        self.n = self.V.ndof
        if self.n != mesh.nv:
            raise AssertionError("Stefan forms: P1 dofs are expected to be the mesh vertices")
        self.free = np.array(list(self.V.FreeDofs()), dtype=bool)
        self.dirichlet_dofs = np.nonzero(~self.free)[0]
        self.owned = parallel.owned(self.V)
        """The local vertices this rank owns (all on a serial mesh): each global vertex is owned once."""
        self._work = ngs.GridFunction(self.V).vec.CreateVector() if self.distributed else None
        self._group_materials()
        self._assemble_matrices()
        self._build_graph()
        self.t_load = ngs.Parameter(0.0)
        self._build_loads()
        self.gf_temperature = ngs.GridFunction(self.V)
        self.gf_enthalpy = ngs.GridFunction(self.V)
        self.gf_liquid_fraction = ngs.GridFunction(self.V)
        self._dir_tmp = ngs.GridFunction(self.V)

    # -- set-up ---------------------------------------------------------------------------------------------
    def _group_materials(self):
        self.groups: list[StefanMaterial] = []
        self.group_regions: list[list[str]] = []
        for name, mat in self.setup.materials.items():
            if mat in self.groups:
                self.group_regions[self.groups.index(mat)].append(name)
            else:
                self.groups.append(mat)
                self.group_regions.append([name])
        self.pcm_groups = [g for g, m in enumerate(self.groups) if isinstance(m, PhaseChangeMaterial)]

    def _assemble_matrices(self):
        u, v = self.V.TnT()
        G = len(self.groups)
        masses = np.zeros((self.n, G))
        self.gf_pressure = None
        pressure_factor = None
        if any(c != 0.0 for c in self.setup.pressure_coefficients.values()):
            self.gf_pressure = ngs.GridFunction(ngs.L2(self.mesh, order=0))
            pressure_factor = self.mesh.MaterialCF({n: 1 + c * self.gf_pressure
                                                    for n, c in self.setup.pressure_coefficients.items()},
                                                   default=1.0)
        self._group_forms = []
        for g, names in enumerate(self.group_regions):
            where = self.mesh.Materials(regions_regex(names))
            lf = ngs.LinearForm(self.V)
            lf += self.lumped(v, where)
            lf.Assemble()
            masses[:, g] = self.cumulate(lf.vec.FV().NumPy())
            # the whole mesh with an indicator (not definedon), so that all groups share one sparsity pattern
            indicator = self.mesh.MaterialCF({n: 1.0 for n in names}, default=0.0)
            if pressure_factor is not None:
                indicator = indicator * pressure_factor
            a = ngs.BilinearForm(self.V)
            a += self.group_integrand(g, indicator, u, v) * ngs.dx
            self._group_forms.append(a)
        self.interface_conductance: list[float] = []
        self._interface = self._penalty = self._interface_matrix() if self.setup.interfaces else None
        self._interface_structure = self._interface
        self.conductances = None
        """The contact-conductance interfaces (:class:`.conductance.NodalConductances`), or None."""
        if self.setup.conductances:
            self.conductances = NodalConductances(self.mesh, self.V, self.setup.conductances,
                                                  axisymmetric=self.setup.axisymmetric)
            self._interface_structure = self._with_penalty(self.conductances.matrix(structure=True))
            self._interface = self._with_penalty(self.conductances.matrix())
        self._robin = self._robin_matrix() if self.setup.robin else None
        pattern = self._collect_stiffness()
        self.pattern_cols = pattern[0]
        self.pattern_rows = np.repeat(np.arange(self.n), np.diff(pattern[1]))
        self.diagonal_positions = np.nonzero(self.pattern_rows == self.pattern_cols)[0]
        if len(self.diagonal_positions) != self.n:
            raise AssertionError("Stefan forms: a diagonal entry is missing from the stiffness pattern")
        self.mass = masses.sum(axis=1)
        if np.any(self.mass <= 0):
            raise AssertionError("Stefan forms: a vertex without elements (zero lumped mass)")
        self.mass_by_group = masses
        self.weights = masses / self.mass[:, None]

    def lumped(self, integrand, definedon=None):
        """``integrand`` (linear in the test function) on the lumped measure: the vertex rule (plane, 3D), or
        w = r times it with the rule exact for r phi_i (axisymmetric: row-sum lumping of the r-weighted mass).
        ``definedon``: a region (None: the whole mesh)."""
        dx = (ngs.dx(intrules=self.rules) if definedon is None
              else ngs.dx(definedon=definedon, intrules=self.rules))
        return (integrand if self.weight is None else self.weight * integrand) * dx

    def group_integrand(self, g: int, coefficient, u, v):
        """The integrand of group g's stiffness for unit conductivity, ``coefficient`` (a CF) times
        grad u . grad v, K_hat grad u . grad v for an anisotropic material, G(x) grad u . grad v for a conductivity
        that varies in x, y, z (``variation``), times r in axisymmetric problems."""
        K = shape_cf(self.groups[g], self.dim)
        if K is None:
            form = coefficient * ngs.grad(u) * ngs.grad(v)
        else:
            form = coefficient * ngs.InnerProduct(K * ngs.grad(u), ngs.grad(v))
        return form if self.weight is None else self.weight * form

    def _collect_stiffness(self) -> tuple:
        """Assemble the groups' stiffness matrices (with the pressure factors) into ``stiffness`` (CSR, one
        shared pattern; the linear terms (the interface penalty, the heat transfer conditions) last, in the
        union pattern); returns the pattern."""
        self.stiffness = []
        pattern = None
        for a in self._group_forms:
            a.Assemble()
            # distributed: this rank's local matrix (applied to a cumulated vector: a distributed result)
            vals, cols, ptr = (a.mat.local_mat if self.distributed else a.mat).CSR()
            K = sp.csr_matrix((np.array(vals), np.array(cols), np.array(ptr)), shape=(self.n, self.n))
            if pattern is None:
                pattern = (K.indices.copy(), K.indptr.copy())
            elif not (np.array_equal(pattern[0], K.indices) and np.array_equal(pattern[1], K.indptr)):
                raise AssertionError("Stefan forms: the region stiffness matrices do not share one pattern")
            self.stiffness.append(K)
        linear = [M for M in (self._interface, self._robin) if M is not None]
        if linear:
            KG = linear[0] if len(linear) == 1 else (linear[0] + linear[1]).tocsr()
            K0 = self.stiffness[0]
            ones = [sp.csr_matrix((np.ones(len(M.indices)), M.indices, M.indptr), shape=(self.n, self.n))
                    for M in (K0, self._interface_structure, self._robin) if M is not None]
            union = sum(ones[1:], ones[0]).tocsr()           # structural union (no cancellation)
            union.sort_indices()
            rows = np.repeat(np.arange(self.n), np.diff(union.indptr))

            def values(K):                  # K's entries in the union pattern (none on a rank without vertices)
                return np.asarray(K[rows, union.indices]).ravel() if len(rows) else np.zeros(0)
            self.stiffness = [sp.csr_matrix((values(K), union.indices.copy(), union.indptr.copy()),
                                            shape=(self.n, self.n)) for K in self.stiffness + [KG]]
            pattern = (union.indices.copy(), union.indptr.copy())
        self.__dict__.pop("_abs_stiffness", None)
        return pattern

    def set_pressure(self, pressure) -> tuple[float, float]:
        """The mean pressure p (Pa, compression > 0; a CoefficientFunction) of k(p) = k (1 + c_p p) in the
        regions with a pressure coefficient (element averages): the stiffness matrices are assembled again
        (same pattern) and ``version`` changes, so that the solver refactors. Returns the (min, max) of the
        factors; ValueError naming the region when one is not positive."""
        from ..heat.forms import check_pressure_factors

        if self.gf_pressure is None:
            raise ValueError("set_pressure: no region has a pressure coefficient")
        self.gf_pressure.Set(pressure)

        def changed():
            self._collect_stiffness()
            self.version += 1
        return check_pressure_factors(self.mesh, self.gf_pressure, self.setup.pressure_coefficients, changed)

    def _with_penalty(self, K: sp.csr_matrix) -> sp.csr_matrix:
        """K plus the penalty interfaces' matrix (when there are any)."""
        return (K + self._penalty).tocsr() if self._penalty is not None else K

    def set_contact_state(self, states) -> None:
        """The contact state of the mechanics per interface name (:class:`~ngs_geomech.heat.conductance.ContactNodes`;
        None or a missing name: the geometry's) for the contact-conductance interfaces: their matrix is assembled
        again (same pattern) and ``version`` changes."""
        if self.conductances is not None and self.conductances.set_state(states):
            self._conductances_changed()

    def lag_radiation(self, T: np.ndarray) -> None:
        """The linearized radiation conductances at the nodal temperatures ``T`` (the start of a step)."""
        if self.conductances is not None and self.conductances.lagged_radiation:
            self.conductances.lag(T)
            self._conductances_changed()

    def _conductances_changed(self) -> None:
        self._interface = self._with_penalty(self.conductances.matrix())
        self._collect_stiffness()
        self.version += 1

    def _interface_matrix(self) -> sp.csr_matrix:
        """gamma_c B^T D^-1 B summed over the contact interfaces (module docstring), W/K per metre of depth in
        2D; sets ``interface_conductance`` (gamma_c per interface, W/(m^2 K))."""
        from ..fem.mortar import mortar_coupling_2d, mortar_coupling_3d

        total = sp.csr_matrix((self.n, self.n))
        cond = {}
        for name, m in self.setup.materials.items():
            cond[name] = (max(m.conductivity_solid, m.conductivity_liquid) if isinstance(m, PhaseChangeMaterial)
                          else m.conductivity)
        for master, minion, penalty in self.setup.interfaces:
            L = ngs.H1(self.mesh, order=1, definedon=self.mesh.Boundaries(master))
            if self.dim == 2:
                r, c, v = mortar_coupling_2d(self.mesh, self.V, L, master, minion, axisymmetric=self.axisymmetric,
                                             order=2)
            else:
                r, c, v = mortar_coupling_3d(self.mesh, self.V, L, master, minion, order=1)
            B = sp.csr_matrix((v, (r, c)), shape=(L.ndof, self.n))
            lengths, touching = [], set()
            for el in self.mesh.Boundaries(master).Elements():
                pts = np.array([self.mesh[vv].point for vv in el.vertices])
                lengths.append(float(np.linalg.norm(pts[1] - pts[0])) if self.dim == 2
                               else math.sqrt(0.5 * float(np.linalg.norm(np.cross(pts[1] - pts[0], pts[2] - pts[0])))))
            for side in (master, minion):
                for el in self.mesh.Boundaries(side).Elements():
                    for vol in self.mesh[el.vertices[0]].elements:
                        touching.add(self.mesh[vol].mat)
            h = float(np.mean(lengths))
            gamma = float(penalty) * max(cond[r_] for r_ in touching) / h
            self.interface_conductance.append(gamma)
            own = np.zeros(self.n, dtype=bool)
            for el in self.mesh.Boundaries(master).Elements():
                for d in self.V.GetDofNrs(el):
                    own[d] = True
            D = np.asarray(B[:, own].sum(axis=1)).ravel()          # int mu_i over the interface
            keep = D > 0
            B = B[keep]
            total = total + gamma * (B.T @ sp.diags(1.0 / D[keep]) @ B)
        return total.tocsr()

    def _robin_matrix(self) -> sp.csr_matrix:
        """The heat transfer conditions' nodal conductances r_i = sum int_Gamma w h phi_i ds as a diagonal
        matrix (W/K per metre of depth in 2D, per radian axisymmetric; this rank's part on a distributed mesh): the
        row sums of the boundary mass, lumped, so that the step stays monotone; ``robin_conductance`` holds them
        cumulated. The ambient side h T_amb is the load :meth:`robin_loads`."""
        _, v = self.V.TnT()
        w = 1.0 if self.weight is None else self.weight
        lf = ngs.LinearForm(self.V)
        for name, (h, _) in self.setup.robin.items():
            lf += float(h) * w * v * ngs.ds(definedon=self.mesh.Boundaries(name))
        lf.Assemble()
        local = lf.vec.FV().NumPy().copy()
        self.robin_conductance = self.cumulate(local.copy())
        return sp.diags(local).tocsr()

    def _build_graph(self):
        pcm = [self.groups[g] for g in self.pcm_groups]
        self.breakpoints = np.array(sorted({m.melting_temperature for m in pcm})) if pcm else np.array([0.0])
        K = len(self.breakpoints)
        G = len(self.groups)
        e_lo = np.zeros((G, K))
        e_hi = np.zeros((G, K))
        cap = np.zeros((G, K + 1))
        cond = np.zeros((G, K + 1))
        for g, m in enumerate(self.groups):
            for k, tk in enumerate(self.breakpoints):
                e_lo[g, k] = m.enthalpy(tk, 0.0)
                e_hi[g, k] = m.enthalpy(tk, 1.0)
            for s in range(K + 1):
                if isinstance(m, PhaseChangeMaterial):
                    solid = s < K and self.breakpoints[s] <= m.melting_temperature
                    cap[g, s] = m.rho_c_solid if solid else m.rho_c_liquid
                    cond[g, s] = m.conductivity_solid if solid else m.conductivity_liquid
                else:
                    cap[g, s] = m.rho_c
                    cond[g, s] = m.conductivity
        self.e_lo = self.weights @ e_lo
        self.e_hi = self.weights @ e_hi
        self.jump = self.e_hi - self.e_lo
        self.capacity = self.weights @ cap
        if self._interface is not None or self.setup.robin:    # the linear "group": theta = T (its matrix is last)
            cond = np.vstack([cond, np.ones((1, K + 1))])
        self.group_conductivity = cond              # G (+ 1 with interfaces) x (K + 1), W/(m K), at T_ref
        coef = np.array([m.conductivity_temperature_coefficient for m in self.groups]
                        + [0.0] * (cond.shape[0] - G))
        self.group_law = (coef, np.array([m.reference_temperature for m in self.groups] + [0.0] * (cond.shape[0] - G)))
        """b (1/K) and T_ref (K) of k(T) = k (1 + b (T - T_ref)) per group (the interface group: 0, 0)."""
        self.temperature_dependent = bool(np.any(coef != 0.0))
        """Whether some conductivity depends on T: theta is then piecewise quadratic, and the Newton matrix
        changes with T at every node (see :mod:`ngs_geomech.stefan.solver`)."""
        self.symmetric = bool(np.all(cond == cond[:, :1])) and not self.temperature_dependent
        """Whether the Jacobian is symmetric: no PCM has k_s != k_l and no k depends on T (each region's
        Kirchhoff map is linear)."""

    def _build_loads(self):
        s = self.setup
        _, v = self.V.TnT()
        self._loads = None
        # assembled once only when every load is Steady (a Separable source, e.g. a decaying canister, is also
        # flagged time_dependent = False for the heat forms, which scale its vector; here it must be reassembled)
        self._loads_static = all(isinstance(time_function(f), Steady)
                                 for f in list(s.sources.values()) + list(s.flux.values()))
        self._build_robin_loads(v)
        if not s.sources and not s.flux:
            return
        lf = ngs.LinearForm(self.V)
        for region, f in s.sources.items():
            lf += self.lumped(time_function(f)(self.t_load) * v, self.mesh.Materials(region))
        for name, f in s.flux.items():
            flux = time_function(f)(self.t_load) * v
            lf += (flux if self.weight is None else self.weight * flux) * ngs.ds(definedon=self.mesh.Boundaries(name))
        self._loads = lf
        self._loads_assembled = False

    def _build_robin_loads(self, v) -> None:
        """The linear form of the heat transfer conditions' ambient side, sum int_Gamma w h T_amb(t) phi_i ds."""
        robin = self.setup.robin
        self._robin_loads = None
        if not robin:
            return
        w = 1.0 if self.weight is None else self.weight
        self._robin_static = all(isinstance(time_function(a), Steady) for _, a in robin.values())
        lf = ngs.LinearForm(self.V)
        for name, (h, amb) in robin.items():
            lf += float(h) * w * time_function(amb)(self.t_load) * v * ngs.ds(definedon=self.mesh.Boundaries(name))
        self._robin_loads = lf
        self._robin_assembled = False

    def robin_loads(self, t: float) -> np.ndarray | None:
        """The ambient side of the heat transfer conditions at time t, int w h T_amb phi_i ds (W per metre of
        depth in 2D, W per radian axisymmetric, W in 3D; cumulated); None without heat transfer conditions. The
        exchange with the ambient is this minus ``robin_conductance`` T (:meth:`robin_heat_rate`)."""
        if self._robin_loads is None:
            return None
        if not (self._robin_static and self._robin_assembled):
            self.t_load.Set(t)
            self._robin_loads.Assemble()
            self._robin_assembled = True
        return self.cumulate(self._robin_loads.vec.FV().NumPy().copy())

    def robin_heat_rate(self, F_robin: np.ndarray, T: np.ndarray) -> float:
        """The heat flow into the body through the heat transfer conditions, sum_i (F_robin,i - r_i T_i) (W per
        metre of depth in 2D, per radian axisymmetric, W in 3D; global on a distributed mesh)."""
        return self.nodal_sum(F_robin - self.robin_conductance * T)

    # -- nodal maps -----------------------------------------------------------------------------------------
    def nodal_state(self, e: np.ndarray) -> NodalState:
        """T = beta(e) node by node with its generalized derivative (see :class:`NodalState`).

        Choice at the kinks: the flat parts are closed (e = e_lo or e = e_hi of a breakpoint with latent heat
        counts as mushy, dT/de = 0), so a node resting at the phase-change temperature (the solid of a
        one-phase problem, ahead of the front) keeps T = Theta_R in a Newton step and takes up heat as latent
        heat; a node exactly at a breakpoint without latent heat takes the slope below it. Measured against the
        open choice (the ends on the sensible branches): the same errors, fewer iterations (one-phase Neumann,
        h = 0.0125: mean 1.54 against 2.12 per step), and with steps far too large for the mesh the closed choice
        converges slowly where the open one cycled.
        """
        K = len(self.breakpoints)
        rows = np.arange(self.n)
        s = np.count_nonzero(e[:, None] > self.e_hi, axis=1)
        k = np.minimum(s, K - 1)
        mushy = (s < K) & (e >= self.e_lo[rows, k]) & (self.jump[rows, k] > 0)
        c = self.capacity[rows, s]
        anchor_e = np.where(s == 0, self.e_lo[:, 0], self.e_hi[rows, np.maximum(s - 1, 0)])
        anchor_T = self.breakpoints[np.maximum(s - 1, 0)]
        T = np.where(mushy, self.breakpoints[k], anchor_T + (e - anchor_e) / c)
        dT = np.where(mushy, 0.0, 1.0 / c)
        return NodalState(T, dT, mushy, s)

    def enthalpy_of(self, T: np.ndarray, liquid_fraction=None) -> np.ndarray:
        """Nodal enthalpy e(T) (J/m^3) of nodal temperatures; at a phase-change temperature exactly the node
        takes e_lo + f (e_hi - e_lo) with f = ``liquid_fraction`` (default 0: solid)."""
        T = np.asarray(T, dtype=float)
        f = np.zeros(self.n) if liquid_fraction is None else np.broadcast_to(np.asarray(liquid_fraction, float),
                                                                             (self.n,))
        e = np.zeros(self.n)
        for g, m in enumerate(self.groups):
            e += self.weights[:, g] * m.enthalpy(T, f)
        return e

    def project_enthalpy(self, e_cf, order: int = 30) -> np.ndarray:
        """Nodal enthalpies e_i = int e phi_i / m_i (J/m^3) of an enthalpy field ``e_cf`` (CoefficientFunction):
        the lumped L2 projection, which keeps the heat content sum_i m_i e_i = int e of the field (up to the
        quadrature of ``order``; use a high order when e jumps inside elements, as across a phase boundary)."""
        _, v = self.V.TnT()
        lf = ngs.LinearForm(self.V)
        lf += (e_cf if self.weight is None else self.weight * e_cf) * v * ngs.dx(bonus_intorder=order)
        lf.Assemble()
        return self.cumulate(lf.vec.FV().NumPy()) / self.mass

    def kirchhoff_derivatives(self, state: NodalState) -> np.ndarray:
        """D theta_g / dT per node and group (n x G, W/(m K)): the conductivity of the node's interval (the
        interval below the breakpoint for mushy nodes, where it multiplies dT = 0), times
        f_g(T) = 1 + b_g (T - T_ref,g) at the node's temperature when k_g depends on T."""
        return self.kirchhoff_slopes(state.T, state.segment)

    def kirchhoff_slopes(self, T: np.ndarray, segment: np.ndarray) -> np.ndarray:
        """k_g(T) of the interval ``segment`` per node and group (n x G, W/(m K)), see
        :meth:`kirchhoff_derivatives`."""
        k = self.group_conductivity[:, segment].T
        if not self.temperature_dependent:
            return k
        b, tref = self.group_law
        return k * (1.0 + b[None, :] * (np.asarray(T, dtype=float)[:, None] - tref[None, :]))

    def conductivity_factors(self, T: np.ndarray) -> np.ndarray:
        """f_g(T) = 1 + b_g (T - T_ref,g) per node and temperature-dependent group (n x G_b; +inf where the node
        does not touch the group): the factor that must stay positive."""
        cols = [np.where(self.weights[:, g] > 0, m.conductivity_factor(T), np.inf)
                for g, m in enumerate(self.groups) if m.temperature_dependent]
        return np.column_stack(cols) if cols else np.full((self.n, 0), np.inf)

    def check_conductivity(self, T: np.ndarray, where: str = "", floor: float = 0.0) -> None:
        """ConductivityRangeError naming the regions, the temperature and the law when a temperature-dependent
        conductivity k (1 + b (T - T_ref)) is not positive at a node of its regions (``where``: added to the
        message, e.g. the time; ``floor`` > 0: when its factor 1 + b (T - T_ref) is not above it, the edge of
        the range a Newton iteration is held in). On a distributed mesh raised on every rank when a node of some
        rank fails."""
        if not self.temperature_dependent:
            return
        if self.distributed:
            try:
                self._check_conductivity(T, where, floor)
                error = None
            except ConductivityRangeError as exc:
                error = (str(exc), exc.regions)
            errors = [err for err in parallel.allgather(self.mesh, error) if err is not None]
            if errors:
                raise ConductivityRangeError(*errors[0])
            return
        self._check_conductivity(T, where, floor)

    def _check_conductivity(self, T: np.ndarray, where: str, floor: float = 0.0) -> None:
        for g, m in enumerate(self.groups):
            if not m.temperature_dependent:
                continue
            on = self.weights[:, g] > 0
            f = m.conductivity_factor(T[on])
            bad = np.nonzero(~(f > floor))[0]
            if len(bad):
                i = bad[np.argmin(f[bad])]
                b, tr = m.conductivity_temperature_coefficient, m.reference_temperature
                limit = tr - 1.0 / b
                names = self.group_regions[g]
                what = "is not positive" if not f[i] > 0 else ("vanishes (the Newton iteration is held at the "
                                                               "edge of the range where k > 0: the step needs k <= 0)")
                raise ConductivityRangeError(
                    f"conductivity of region(s) {names}{where}: the factor 1 + b (T - T_ref) = {f[i]:.3g} of "
                    f"k(T) = k (1 + b (T - T_ref)) {what} at T = {T[on][i]:.6g} "
                    f"(conductivity_temperature_coefficient b = {b:g} 1/K, reference_temperature T_ref = {tr:g}: "
                    f"k > 0 only for T {'>' if b > 0 else '<'} {limit:.6g}): the linear temperature law has left "
                    "its range; change conductivity_temperature_coefficient or reference_temperature", names)

    def conduction(self, T: np.ndarray) -> np.ndarray:
        """A(T) = sum_g K_g theta_g(T), W per metre of depth (2D) or W (3D)."""
        out = np.zeros(self.n)
        for K, m in zip(self.stiffness, self.groups):
            out += K @ m.kirchhoff(T)
        if len(self.stiffness) > len(self.groups):            # contact interfaces: the jump penalty, linear in T
            out += self.stiffness[-1] @ T
        return self.cumulate(out)

    def conduction_magnitude(self, T: np.ndarray) -> np.ndarray:
        """sum_g |K_g| |theta_g(T)| (entrywise absolute values): the size of the terms that make up
        :meth:`conduction`, for the round-off floor of a residual (same units)."""
        if not hasattr(self, "_abs_stiffness"):
            self._abs_stiffness = [abs(K) for K in self.stiffness]
        out = np.zeros(self.n)
        for K, m in zip(self._abs_stiffness, self.groups):
            out += K @ np.abs(m.kirchhoff(T))
        if len(self._abs_stiffness) > len(self.groups):
            out += self._abs_stiffness[-1] @ np.abs(T)
        return self.cumulate(out)

    def liquid_fractions(self, e: np.ndarray, state: NodalState | None = None) -> np.ndarray:
        """Liquid fraction per node and PCM group (n x G; 0 for plain groups): 1 above the group's Theta_R,
        0 below, (e - e_lo)/(e_hi - e_lo) on its flat part."""
        st = state if state is not None else self.nodal_state(e)
        out = np.zeros((self.n, len(self.groups)))
        rows = np.arange(self.n)
        k = np.minimum(st.segment, len(self.breakpoints) - 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.clip((e - self.e_lo[rows, k]) / self.jump[rows, k], 0.0, 1.0)
        for g in self.pcm_groups:
            tm = self.groups[g].melting_temperature
            out[:, g] = np.where(st.mushy & (self.breakpoints[k] == tm), frac, (st.T > tm).astype(float))
        return out

    def melted_volume(self, e: np.ndarray) -> float:
        """Liquid volume (lumped), m^2 per metre of depth in 2D, m^3 in 3D (global on a distributed mesh)."""
        if self.distributed:
            return self.nodal_sum(np.sum(self.mass_by_group * self.liquid_fractions(e), axis=1))
        return float(np.sum(self.mass_by_group * self.liquid_fractions(e)))

    def latent_heat_stored(self, e: np.ndarray) -> float:
        """Latent heat held by the liquid (lumped), J per metre of depth in 2D, J in 3D."""
        L = np.array([m.latent_heat if isinstance(m, PhaseChangeMaterial) else 0.0 for m in self.groups])
        if self.distributed:
            return self.nodal_sum(np.sum(self.mass_by_group * self.liquid_fractions(e) * L, axis=1))
        return float(np.sum(self.mass_by_group * self.liquid_fractions(e) * L))

    def heat_content(self, e: np.ndarray) -> float:
        """sum_i m_i e_i: the (lumped) enthalpy of the body, J per metre of depth in 2D, J in 3D (global on a
        distributed mesh)."""
        if self.distributed:
            return self.nodal_sum(self.mass * e)
        return float(self.mass @ e)

    # -- distributed meshes ---------------------------------------------------------------------------------
    def cumulate(self, values: np.ndarray) -> np.ndarray:
        """The cumulated nodal array of a distributed one (each rank's local part of an assembled vector, e.g. a
        linear form or K theta: a shared vertex holds a part on each rank): the full value at every local vertex,
        a new array. On a serial mesh ``values`` itself."""
        if not self.distributed:
            return values
        w = self._work
        w.FV().NumPy()[:] = values
        w.SetParallelStatus(ngs.PARALLEL_STATUS.DISTRIBUTED)
        w.Cumulate()
        return w.FV().NumPy().copy()

    def consistent(self, values: np.ndarray) -> np.ndarray:
        """A nodal array with every shared vertex at its owner's value on every rank (the same bits: the other
        ranks' zeros are added), so that the ranks take the same branch at a shared vertex. Serial: ``values``."""
        if not self.distributed:
            return values
        return self.cumulate(np.where(self.owned, values, 0.0))

    def nodal_sum(self, values: np.ndarray) -> float:
        """The sum over the global vertices of a cumulated nodal array (one value per local vertex), each vertex
        counted once (the owned ones, added over the ranks): the same on every rank. Serial: the plain sum."""
        values = np.asarray(values, dtype=float)
        if not self.distributed:
            return float(np.sum(values))
        return float(parallel.allsum(self.mesh, float(np.sum(values[self.owned]))))

    def nodal_max(self, values: np.ndarray, default: float = -math.inf) -> float:
        """The largest entry of a nodal array over all ranks (``default`` where a rank has none)."""
        local = float(np.max(values)) if np.size(values) else default
        return float(parallel.allmax(self.mesh, local)) if self.distributed else local

    # -- data at a time -------------------------------------------------------------------------------------
    def loads(self, t: float) -> np.ndarray:
        """F(t): sources and boundary fluxes against the lumped test functions, W/m (2D) or W (3D)."""
        if self._loads is None:
            return np.zeros(self.n)
        if not (self._loads_static and self._loads_assembled):
            self.t_load.Set(t)
            self._loads.Assemble()
            self._loads_assembled = True
        if self.distributed:
            return self.cumulate(self._loads.vec.FV().NumPy())
        return self._loads.vec.FV().NumPy().copy()

    def dirichlet_temperatures(self, t: float) -> np.ndarray:
        """The Dirichlet temperatures (K) at time t at the Dirichlet dofs (in the order of ``dirichlet_dofs``)."""
        if not self.setup.dirichlet:
            return np.zeros(0)
        self.t_load.Set(t)
        cf = self.mesh.BoundaryCF({n: time_function(f)(self.t_load) for n, f in self.setup.dirichlet.items()},
                                  default=0.0)
        self._dir_tmp.Set(cf, ngs.BND, definedon=self.mesh.Boundaries(regions_regex(self.setup.dirichlet)))
        return self._dir_tmp.vec.FV().NumPy()[self.dirichlet_dofs].copy()

    def store(self, e: np.ndarray, state: NodalState | None = None) -> None:
        """Copy a nodal enthalpy and what follows from it into the GridFunctions ``gf_enthalpy`` (J/m^3),
        ``gf_temperature`` (K) and ``gf_liquid_fraction`` (0..1, :meth:`nodal_liquid_fraction`)."""
        st = state if state is not None else self.nodal_state(e)
        self.gf_enthalpy.vec.FV().NumPy()[:] = e
        self.gf_temperature.vec.FV().NumPy()[:] = st.T
        self.gf_liquid_fraction.vec.FV().NumPy()[:] = self.nodal_liquid_fraction(self.liquid_fractions(e, st))

    def nodal_liquid_fraction(self, frac: np.ndarray) -> np.ndarray:
        """One liquid fraction per node (0..1) from the per-group fractions ``frac`` (n x G): the mean over the
        PCM groups touching the node weighted by their latent heat m_i^r L_r; at a node whose PCMs all have
        L = 0 (a phase change of the conductivity and heat capacity only, the phase set by T against Theta_R)
        weighted by m_i^r alone; 0 at nodes without a PCM."""
        pcm = np.zeros(len(self.groups))
        pcm[list(self.pcm_groups)] = 1.0
        L = np.array([m.latent_heat if isinstance(m, PhaseChangeMaterial) else 0.0 for m in self.groups])
        wl = self.weights * L
        wl = np.where(wl.sum(axis=1, keepdims=True) > 0, wl, self.weights * pcm)
        total = wl.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0, (wl * frac).sum(axis=1) / total, 0.0)

    # -- the smeared (apparent heat capacity) variant ----------------------------------------------------------
    def apparent_capacity(self, T: np.ndarray, delta: float) -> np.ndarray:
        """Nodal C_app(T) = C(T) + L/(2 delta) for |T - Theta_R| < delta (J/(m^3 K)), m-weighted over groups."""
        out = np.zeros(self.n)
        for g, m in enumerate(self.groups):
            if isinstance(m, PhaseChangeMaterial):
                d = T - m.melting_temperature
                c = np.where(d < 0, m.rho_c_solid, m.rho_c_liquid) + np.where(np.abs(d) < delta,
                                                                              m.latent_heat / (2 * delta), 0.0)
            else:
                c = np.full(self.n, m.rho_c)
            out += self.weights[:, g] * c
        return out

    def smeared_enthalpy(self, T: np.ndarray, delta: float) -> np.ndarray:
        """The enthalpy of the smeared law, e_delta(T) = int C_app (J/m^3, same reference as e)."""
        out = np.zeros(self.n)
        for g, m in enumerate(self.groups):
            if isinstance(m, PhaseChangeMaterial):
                d = np.asarray(T, float) - m.melting_temperature
                lat = m.latent_heat * np.clip((d + delta) / (2 * delta), 0.0, 1.0)
                e = np.where(d < 0, m.rho_c_solid * d, m.rho_c_liquid * d) + lat
            else:
                e = m.rho_c * np.asarray(T, float)
            out += self.weights[:, g] * e
        return out
