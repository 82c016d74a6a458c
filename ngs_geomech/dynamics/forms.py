"""Forms of the global evolutionary model (seed (2.6)-(2.7)): inertia, short-memory (Kelvin-Voigt) viscosity and
long-memory (rate-type, Prony series) viscoelasticity on top of :class:`~ngs_geomech.mechanics.forms.ElasticForms`.

The stress law (2.7) with the optional long-memory term (Voigt vectors of the model, as in ElasticForms):

    tau = C e(u) + C^v e(u_t) + sum_k q_k - beta (T - T0) + sigma0,          rho u_tt = div tau + F,

    q_k = C_k (e(u) - e_k^v),   d e_k^v/dt = (e(u) - e_k^v) / tau_k           (Maxwell branch k, q_k(0) = 0),

i.e. q_k(t) = C_k e(t) - int_0^t (C_k/tau_k) exp(-(t - s)/tau_k) e(u(s)) ds for a body unstrained at t = 0: the
seed's memory kernel is b(t) = -sum_k (C_k / tau_k) exp(-t/tau_k), its instantaneous modulus C + sum_k C_k, and C
(the elastic stiffness of ElasticForms) is the relaxed (long-term) modulus. One branch with C^v = 0 is the standard
linear solid (Zener); no branch and C^v != 0 is the Kelvin-Voigt solid.

No history is stored: branch k of region R has the internal variable h_k = e(u) - e_k^v, which is linear in the
strain history, so it is the strain of a displacement-like field w_k in the displacement space,
h_k = e(w_k), updated per time step by the recursion of the branch ODE dh/dt = de/dt - h/tau_k:

    w_k^{n+1} = a w_k^n + c (u^{n+1} - u^n),
    exponential rule (exact for a strain linear over the step; second order): a = exp(-dt/tau), c = (1 - a) tau/dt,
    backward Euler (first order, dissipative):                                 a = c = 1 / (1 + dt/tau),

a jump (dt = 0, an instantaneous load change): a = c = 1. The branch stress is q_k = C_k e(w_k) on region R.

Power densities (W/m^3) for the heat equation (2.6): the dissipation

    D = e(u_t) . C^v e(u_t) + sum_k q_k . (C_k)^{-1} q_k / tau_k
      = e(u_t) . C^v e(u_t) + sum_k e(w_k) . C_k e(w_k) / tau_k,

(:meth:`ViscoelasticForms.dissipation_density`) is the heat source of viscous origin, >= 0 for positive
semi-definite C^v and C_k. Tensors are 6x6 Voigt matrices (engineering shear) in the global axes, reduced to the
model like the elastic stiffness (plane strain, plane stress, axisymmetric; each tensor reduced on its own, which
for plane stress is exact when C^v and C_k are proportional to C). Units: rho kg/m^3, C^v Pa s, C_k Pa, tau_k s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..fem.coefficients import Steady
from ..mechanics.forms import ElasticForms
from ..mechanics.materials import axisymmetric, plane_strain, plane_stress

BRANCH_RULES = ("exponential", "backward_euler")


@dataclass(frozen=True)
class PronyBranch:
    """One Maxwell branch: stiffness ``C`` (6x6 Voigt, Pa) and relaxation time ``tau`` (s)."""

    C: np.ndarray
    tau: float

    def __post_init__(self):
        if not (self.tau > 0 and math.isfinite(self.tau)):
            raise ValueError(f"a Prony branch needs a positive relaxation time tau (s), got {self.tau}")
        _check_psd(self.C, "Prony branch stiffness C_k")


@dataclass(frozen=True)
class ViscousProperties:
    """Rate-dependent data of one region: ``viscosity`` C^v (6x6 Voigt, Pa s; None: no Kelvin-Voigt term),
    ``branches`` (Prony series, :class:`PronyBranch`), ``density`` rho (kg/m^3; None: the elastic forms' density,
    a CoefficientFunction where it varies)."""

    viscosity: np.ndarray | None = None
    branches: tuple = ()
    density: float | None = None

    def __post_init__(self):
        if self.viscosity is not None:
            _check_psd(self.viscosity, "viscosity C^v")
        if self.density is not None and not (self.density > 0 and math.isfinite(self.density)):
            raise ValueError(f"density must be positive (kg/m^3), got {self.density}")


def _check_psd(C, what: str) -> None:
    C = np.asarray(C, dtype=float)
    if C.shape != (6, 6) or not np.all(np.isfinite(C)) or np.max(np.abs(C - C.T)) > 1e-10 * max(np.max(np.abs(C)), 1):
        raise ValueError(f"{what} must be a finite symmetric 6x6 Voigt matrix")
    if np.min(np.linalg.eigvalsh(C)) < -1e-10 * max(float(np.max(np.abs(C))), 1e-300):
        raise ValueError(f"{what} must be positive semi-definite")


def isotropic_viscosity(shear_viscosity: float, bulk_viscosity: float = 0.0) -> np.ndarray:
    """C^v (6x6 Voigt, Pa s) of an isotropic viscous stress 2 eta (e_t - tr(e_t)/3 I) + zeta tr(e_t) I."""
    eta, zeta = float(shear_viscosity), float(bulk_viscosity)
    lam = zeta - 2 * eta / 3
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[[0, 1, 2], [0, 1, 2]] += 2 * eta
    C[[3, 4, 5], [3, 4, 5]] = eta
    return C


def branch_coefficients(dt: float, tau: float, rule: str = "exponential") -> tuple[float, float]:
    """(a, c) of the branch recursion w^{n+1} = a w^n + c (u^{n+1} - u^n) (module docstring); dt = 0: a jump."""
    if rule not in BRANCH_RULES:
        raise ValueError(f"unknown branch rule {rule!r}; choose one of {', '.join(BRANCH_RULES)}")
    if dt == 0:
        return 1.0, 1.0
    x = dt / tau
    if rule == "backward_euler":
        return 1.0 / (1.0 + x), 1.0 / (1.0 + x)
    a = math.exp(-x)
    return a, -math.expm1(-x) / x


def _reduce(model: str, C: np.ndarray, name: str) -> np.ndarray:
    """A 6x6 Voigt tensor reduced to the model's strain vector, as ElasticForms reduces the stiffness."""
    z = np.zeros((3, 3))
    if model == "3d":
        return np.asarray(C, dtype=float)
    if model == "plane_strain":
        return np.asarray(plane_strain(C, z).D)
    if model == "plane_stress":
        return np.asarray(plane_stress(C, z).Q)
    return np.asarray(axisymmetric(C, z, name).D)


@dataclass
class Branch:
    """Branch ``k`` of region ``region`` inside the forms: reduced stiffness ``D`` (Pa), ``tau`` (s), the
    internal variable ``w`` (a GridFunction of the displacement space V) and the assembled matrix ``K`` =
    int_R w e(u) . D e(v) dx (scipy, X x X)."""

    region: str
    index: int
    D: np.ndarray
    tau: float
    w: object = None
    K: sp.csr_matrix | None = None


@dataclass
class ViscoelasticForms:
    """Mass, Kelvin-Voigt damping and Prony branch forms of the regions of ``elastic`` (builds no mesh, writes
    no file). ``viscous`` maps region names to :class:`ViscousProperties` (regions left out are purely elastic
    with the ElasticProperties' density). The elastic law must be linear (lam = 1): the dynamic and viscous
    solvers use the stiffness C of ElasticForms as a constant matrix.

    Attributes after construction: ``M``, ``C``, ``K`` (scipy CSR on X: mass, damping, elastic stiffness
    including the oblique-symmetry multiplier rows), ``branches`` (:class:`Branch`), ``free`` (bool mask of X),
    ``velocity`` (GridFunction of V: set by the solvers, the field u_t for :meth:`dissipation_density`)."""

    elastic: ElasticForms
    viscous: dict = field(default_factory=dict)
    inertia: bool = True
    """False: no mass matrix (``M`` is zero; the quasi-static viscous problem needs no density)."""

    def __post_init__(self):
        ef, s = self.elastic, self.elastic.setup
        if s.nonlinear:
            raise ValueError("the dynamic and viscous forms need the linear elastic law (lam = 1 in every region)")
        unknown = set(self.viscous) - set(s.props)
        if unknown:
            raise ValueError(f"viscous data for unknown regions: {sorted(unknown)} (regions: {sorted(s.props)})")
        self.model = s.model
        self.mesh = ef.mesh
        self.velocity = ngs.GridFunction(ef.V)
        self.Dv: dict[str, np.ndarray] = {}
        self.density: dict[str, float | None] = {}
        self.branches: list[Branch] = []
        for name in s.props:
            vp = self.viscous.get(name, ViscousProperties())
            self.density[name] = vp.density if vp.density is not None else ef.rho[name]   # a CF where it varies
            if vp.viscosity is not None:
                self.Dv[name] = _reduce(self.model, vp.viscosity, name)
            for k, b in enumerate(vp.branches):
                self.branches.append(Branch(name, k, _reduce(self.model, b.C, name), float(b.tau),
                                            w=ngs.GridFunction(ef.V)))
        self._assemble()

    # -- helpers -----------------------------------------------------------------------------------------------
    def _u(self, trial):
        return trial[0] if self.elastic.oblique else trial

    def _dx(self, name):
        ef = self.elastic
        return ngs.dx(definedon=self.mesh.Materials(name), intrules=ef.intrules)

    def _to_scipy(self, form) -> sp.csr_matrix:
        form.Assemble()
        r, c, v = form.mat.COO()
        n = self.elastic.X.ndof
        return sp.csr_matrix((np.asarray(v), (np.asarray(r), np.asarray(c))), shape=(n, n))

    def _assemble(self):
        ef = self.elastic
        X, w = ef.X, ef.weight
        u, v = X.TnT()
        u, v = self._u(u), self._u(v)
        if self.inertia:
            mform = ngs.BilinearForm(X)
            missing = []
            for name, rho in self.density.items():
                if rho is None:
                    missing.append(name)
                    continue
                mform += w * rho * ngs.InnerProduct(u, v) * self._dx(name)
            if missing:
                raise ValueError(f"the mass matrix needs a density (kg/m^3) in regions {missing}")
            self.M = self._to_scipy(mform)
        else:
            self.M = sp.csr_matrix((X.ndof, X.ndof))
        cform = ngs.BilinearForm(X)
        for name, D in self.Dv.items():
            cform += w * ngs.InnerProduct(ef.cf_matrix(D) * ef.strain_vector(u), ef.strain_vector(v)) * self._dx(name)
        self.C = self._to_scipy(cform) if self.Dv else sp.csr_matrix(self.M.shape)
        switch = ef.linear_switch.Get()
        ef.linear_switch.Set(1.0)          # c* = c (the law is linear; no dependence on u_frozen)
        self.K = self._to_scipy(ef.secant_form)
        ef.linear_switch.Set(switch)
        for b in self.branches:
            bform = ngs.BilinearForm(X)
            Db = ef.cf_matrix(b.D)
            bform += w * ngs.InnerProduct(Db * ef.strain_vector(u), ef.strain_vector(v)) * self._dx(b.region)
            b.K = self._to_scipy(bform)
        self.free = np.array(list(X.FreeDofs()), dtype=bool)
        self.nv = ef.V.ndof
        self.steady_data = self._steady_data()
        self._load_cache = None

    def _steady_data(self) -> bool:
        """True when no load, prescribed displacement or initial stress depends on time and there is no
        temperature field (the load vector and the Dirichlet values are then computed once)."""
        s = self.elastic.setup
        funcs = [f for comps in list(s.dirichlet.values()) + list(s.traction.values()) + list(s.body_force.values())
                 for f in comps if f is not None]
        funcs += list(s.pressure.values()) + [f for row in (s.initial_stress or []) for f in row]
        return s.temperature is None and all(isinstance(f, Steady) for f in funcs)

    def load_vector(self, t: float) -> np.ndarray:
        """The load vector f(t) (X; body forces, tractions, pressure, thermal and initial stress) at time t (s)."""
        if self.steady_data and self._load_cache is not None:
            return self._load_cache.copy()
        ef = self.elastic
        ef.t.Set(t)
        ef.secant_rhs.Assemble()
        out = np.array(ef.secant_rhs.vec.FV().NumPy())
        if self.steady_data:
            self._load_cache = out.copy()
        return out

    # -- fields ------------------------------------------------------------------------------------------------
    def branch_stress(self, branch: Branch):
        """q_k = C_k e(w_k) (reduced Voigt vector, Pa) on the branch's region (zero elsewhere)."""
        ef = self.elastic
        q = ef.cf_matrix(branch.D) * ef.strain_vector(branch.w)
        zero = ngs.CoefficientFunction((0.0,) * branch.D.shape[0])
        return self.mesh.MaterialCF({branch.region: q}, default=zero)

    def viscous_stress(self, velocity=None):
        """C^v e(u_t) (reduced Voigt vector, Pa) per region; ``velocity`` defaults to :attr:`velocity`."""
        ef = self.elastic
        vel = velocity if velocity is not None else self.velocity
        n = len(next(iter(ef.D.values())))
        vals = {name: ef.cf_matrix(D) * ef.strain_vector(vel) for name, D in self.Dv.items()}
        return self.mesh.MaterialCF(vals, default=ngs.CoefficientFunction((0.0,) * n))

    def dissipation_density(self, velocity=None):
        """The viscous power density D (W/m^3, module docstring) as a CoefficientFunction: the heat source of
        (2.6) of viscous origin. ``velocity`` (a displacement-space field, m/s) defaults to :attr:`velocity`."""
        ef = self.elastic
        vel = velocity if velocity is not None else self.velocity
        vals: dict[str, object] = {}
        for name, D in self.Dv.items():
            e = ef.strain_vector(vel)
            vals[name] = ngs.InnerProduct(e, ef.cf_matrix(D) * e)
        for b in self.branches:
            e = ef.strain_vector(b.w)
            term = ngs.InnerProduct(e, ef.cf_matrix(b.D) * e) / b.tau
            vals[b.region] = vals[b.region] + term if b.region in vals else term
        return self.mesh.MaterialCF(vals, default=0.0) if vals else ngs.CoefficientFunction(0.0)

    def kinetic_energy_density(self, velocity=None):
        """The kinetic energy density rho |u_t|^2 / 2 (J/m^3)."""
        vel = velocity if velocity is not None else self.velocity
        return self.mesh.MaterialCF({n: 0.5 * r * ngs.InnerProduct(vel, vel) for n, r in self.density.items()},
                                    default=0.0)
