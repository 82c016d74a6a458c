"""The Neumann similarity solutions of the one- and two-phase Stefan problems (../shared/notes/verification.md,
section 1; Crank 1984 section 1.3, Carslaw & Jaeger 1959 section 11.2) and a driver that runs the enthalpy
method of :mod:`ngs_geomech.stefan.solver` (seed (2.46)-(2.51), (2.55)) against them.

Closed form (melting). A semi-infinite solid x > 0 at T_S <= Theta_R, face x = 0 held at T_L > Theta_R from
t = 0; volumetric heat capacities C_l, C_s (J/(m^3 K)), conductivities k_l, k_s (W/(m K)), diffusivities
a = k/C (m^2/s), volumetric latent heat L (J/m^3), St_L = C_l (T_L - Theta_R)/L, St_S = C_s (Theta_R - T_S)/L,
nu = sqrt(a_l/a_s):

    front     s(t) = 2 lam sqrt(a_l t)                                                             (m)
    liquid    T = T_L - (T_L - Theta_R) erf(x / (2 sqrt(a_l t))) / erf(lam),              x < s(t)
    solid     T = T_S + (Theta_R - T_S) erfc(x / (2 sqrt(a_s t))) / erfc(nu lam),         x > s(t)
    lam:      St_L / (sqrt(pi) e^{lam^2} erf(lam)) - St_S / (nu sqrt(pi) erfcx(nu lam)) = lam,

(the Stefan condition (2.46): L ds/dt = -k_l T_x(s-) + k_s T_x(s+)); one phase (T_S = Theta_R):
sqrt(pi) lam e^{lam^2} erf(lam) = St_L. The heat entering at x = 0 per unit area between t0 and t1 is
int q dt = 2 k_l (T_L - Theta_R) (sqrt(t1) - sqrt(t0)) / (erf(lam) sqrt(pi a_l))  (J/m^2).

Driver (:func:`neumann_strip`): a strip [0, length] x [0, height] (m), 2D P1 on a netgen mesh of size h,
insulated top and bottom, T = T_L on x = 0 ('hot'), T = T_S on x = length ('far'; the length is chosen so that
the exact solution differs from T_S there by less than 1e-6 (Theta_R - T_S) at t1), started at t0 > 0 from the
nodal values of the exact solution (nodes behind the front liquid) and run with constant steps dt to t1.
Measured at t1: the front from the temperatures (where T_h crosses Theta_R along the bottom edge, linear
interpolation between nodes; a mushy node is at Theta_R, so this front moves from node to node) and from the
melted volume (lumped liquid fractions / height), the L2 temperature error, the energy balance, Newton
iterations per step and the wall time per step against a linear heat step (:class:`HeatSolver`, constant
liquid properties, its factorization reused as in a linear run) on the same mesh in the same run (blocks of
Stefan steps and of linear steps alternate, so that both see the same load of the machine).

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
from netgen.occ import OCCGeometry, Rectangle, X, Y
from scipy.optimize import brentq
from scipy.special import erf, erfc, erfcinv, erfcx

from ..fem.coefficients import expression_function
from ..fem.timesteps import schedule
from ..heat.forms import HeatForms, HeatSetup
from ..heat.materials import ThermalProperties
from ..heat.solver import HeatSolver
from ..linalg.threads import blas_threads
from ..stefan.apparent import ApparentHeatCapacitySolver
from ..stefan.forms import StefanForms, StefanSetup
from ..stefan.materials import PhaseChangeMaterial
from ..stefan.solver import StefanSolver
from .study import observed_order, one_ngsolve_thread

SQRT_PI = math.sqrt(math.pi)


# -- closed forms -------------------------------------------------------------------------------------------
def transcendental_residual(lam: float, st_liquid: float, st_solid: float, nu: float) -> float:
    """St_L/(sqrt(pi) e^{lam^2} erf(lam)) - St_S/(nu sqrt(pi) erfcx(nu lam)) - lam (dimensionless)."""
    return (st_liquid / (SQRT_PI * math.exp(lam * lam) * math.erf(lam))
            - st_solid / (nu * SQRT_PI * erfcx(nu * lam)) - lam)


def neumann_lambda(st_liquid: float, st_solid: float = 0.0, nu: float = 1.0) -> float:
    """The root lam of the two-phase transcendental equation (module docstring) by brentq on (1e-9, 10).

    ``st_liquid`` > 0 and ``st_solid`` >= 0 are the Stefan numbers, ``nu`` = sqrt(a_l/a_s) > 0; st_solid = 0
    is the one-phase problem. The left side falls from +inf to -inf on the bracket, so the root is unique.
    """
    if not st_liquid > 0:
        raise ValueError(f"st_liquid must be > 0 (the face must be above the melting temperature), got {st_liquid}")
    if st_solid < 0:
        raise ValueError(f"st_solid must be >= 0 (the solid must not be above the melting temperature), "
                         f"got {st_solid}")
    if not nu > 0:
        raise ValueError(f"nu must be > 0, got {nu}")
    return float(brentq(transcendental_residual, 1e-9, 10.0, args=(st_liquid, st_solid, nu), xtol=1e-15,
                        rtol=4 * np.finfo(float).eps, maxiter=200))


def one_phase_lambda(st: float) -> float:
    """The root of sqrt(pi) lam e^{lam^2} erf(lam) = St (one-phase Neumann problem) by brentq."""
    if not st > 0:
        raise ValueError(f"the Stefan number must be > 0, got {st}")
    return float(brentq(lambda lam: SQRT_PI * lam * math.exp(lam * lam) * math.erf(lam) - st, 1e-12, 10.0,
                        xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200))


@dataclass(frozen=True)
class NeumannProblem:
    """Melting of a half space by the Neumann solution: ``material`` (a :class:`PhaseChangeMaterial`),
    face temperature ``t_hot`` T_L and initial temperature ``t_cold`` T_S (K; T_S = Theta_R: one phase)."""

    material: PhaseChangeMaterial
    t_hot: float
    t_cold: float

    def __post_init__(self):
        tm = self.material.melting_temperature
        if not self.t_hot > tm:
            raise ValueError(f"t_hot = {self.t_hot} must be above the melting temperature {tm}")
        if self.t_cold > tm:
            raise ValueError(f"t_cold = {self.t_cold} must not be above the melting temperature {tm}")
        if not self.material.latent_heat > 0:
            raise ValueError(f"the Neumann solution needs a latent heat > 0, got {self.material.latent_heat}")

    @property
    def one_phase(self) -> bool:
        return self.t_cold == self.material.melting_temperature

    @property
    def stefan_liquid(self) -> float:
        m = self.material
        return m.rho_c_liquid * (self.t_hot - m.melting_temperature) / m.latent_heat

    @property
    def stefan_solid(self) -> float:
        m = self.material
        return m.rho_c_solid * (m.melting_temperature - self.t_cold) / m.latent_heat

    @property
    def nu(self) -> float:
        return math.sqrt(self.material.diffusivity_liquid / self.material.diffusivity_solid)

    @property
    def lam(self) -> float:
        return neumann_lambda(self.stefan_liquid, self.stefan_solid, self.nu)

    def front(self, t: float) -> float:
        """s(t) = 2 lam sqrt(a_l t), m."""
        return 2.0 * self.lam * math.sqrt(self.material.diffusivity_liquid * t)

    def temperature(self, x, t: float):
        """T(x, t), K (numpy; x in m, t > 0 in s)."""
        m, lam = self.material, self.lam
        x = np.asarray(x, dtype=float)
        tm = m.melting_temperature
        liquid = self.t_hot - (self.t_hot - tm) * erf(x / (2 * math.sqrt(m.diffusivity_liquid * t))) / math.erf(lam)
        solid = self.t_cold + (tm - self.t_cold) * erfc(x / (2 * math.sqrt(m.diffusivity_solid * t))) / erfc(
            self.nu * lam)
        return np.where(x < self.front(t), liquid, solid)

    def temperature_cf(self, t: float):
        """T(x, t) as a CoefficientFunction of x (K)."""
        m, lam = self.material, self.lam
        tm = m.melting_temperature
        liquid = self.t_hot - (self.t_hot - tm) * ngs.erf(ngs.x / (2 * math.sqrt(m.diffusivity_liquid * t))) \
            / math.erf(lam)
        solid = self.t_cold + (tm - self.t_cold) * (1 - ngs.erf(ngs.x / (2 * math.sqrt(m.diffusivity_solid * t)))) \
            / erfc(self.nu * lam)
        return ngs.IfPos(self.front(t) - ngs.x, liquid, solid)

    def sensible_enthalpy_cf(self, t: float):
        """The continuous part of the exact enthalpy, C_l (T - Theta_R) behind and C_s (T - Theta_R) ahead of
        the front, as a CoefficientFunction of x (J/m^3); the latent part is L for x < s(t)."""
        m = self.material
        d = self.temperature_cf(t) - m.melting_temperature
        return ngs.IfPos(self.front(t) - ngs.x, m.rho_c_liquid * d, m.rho_c_solid * d)

    def boundary_heat(self, t0: float, t1: float) -> float:
        """Heat entering through x = 0 per unit area between t0 and t1, J/m^2."""
        m = self.material
        return (2 * m.conductivity_liquid * (self.t_hot - m.melting_temperature) * (math.sqrt(t1) - math.sqrt(t0))
                / (math.erf(self.lam) * math.sqrt(math.pi * m.diffusivity_liquid)))

    def domain_length(self, t1: float, tol: float = 1e-6) -> float:
        """A strip length (m) at which the exact T differs from T_S by less than tol (Theta_R - T_S) up to t1
        (one phase: 1.5 s(t1) + 0.05 m; the offset keeps the exact front off the mesh nodes of every level, where
        2/3 of the length would coincide with a node whenever the node count is a multiple of 3)."""
        if self.one_phase:
            return 1.5 * self.front(t1) + 0.05
        z = erfcinv(tol * erfc(self.nu * self.lam))
        return max(2 * math.sqrt(self.material.diffusivity_solid * t1) * float(z), 1.5 * self.front(t1))


TWO_PHASE = NeumannProblem(PhaseChangeMaterial(melting_temperature=0.0, latent_heat=2.0, rho_c_solid=3.0,
                                               rho_c_liquid=1.0, conductivity_solid=1.5, conductivity_liquid=1.0),
                           t_hot=1.0, t_cold=-0.5)
"""Two-phase test case: Theta_R = 0, L = 2 J/m^3, C_s = 3, C_l = 1 J/(m^3 K), k_s = 1.5, k_l = 1 W/(m K)
(a_s = 0.5, a_l = 1 m^2/s: conductivity and capacity differ between the phases), T_L = 1, T_S = -0.5:
St_L = 0.5, St_S = 0.75, nu = sqrt(2)."""

ONE_PHASE = NeumannProblem(PhaseChangeMaterial(melting_temperature=0.0, latent_heat=1.0, rho_c_solid=1.0,
                                               rho_c_liquid=1.0, conductivity_solid=1.0, conductivity_liquid=1.0),
                           t_hot=1.0, t_cold=0.0)
"""One-phase test case: St = 1 (lam = 0.620063), solid at the melting temperature."""


# -- the strip ----------------------------------------------------------------------------------------------
def strip_mesh(length: float, height: float, h: float):
    """The strip [0, length] x [0, height] (m), region 'pcm', boundaries 'hot' (x = 0), 'far' (x = length),
    'bottom', 'top', meshed by netgen with maxh = h."""
    face = Rectangle(length, height).Face()
    face.faces.name = "pcm"
    face.edges.Min(X).name = "hot"
    face.edges.Max(X).name = "far"
    face.edges.Min(Y).name = "bottom"
    face.edges.Max(Y).name = "top"
    return ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=h))


def front_from_temperature(mesh, T: np.ndarray, melt: float, boundary: str = "bottom") -> float:
    """X (m) where the nodal temperatures along ``boundary`` first fall to ``melt`` coming from x = 0, by
    linear interpolation between the last node above and the next one (melting: hot side at x = 0)."""
    nodes = sorted({v.nr for el in mesh.Boundaries(boundary).Elements() for v in el.vertices},
                   key=lambda i: mesh.vertices[i].point[0])
    xs = np.array([mesh.vertices[i].point[0] for i in nodes])
    Ts = T[nodes]
    below = np.nonzero(Ts <= melt)[0]
    if len(below) == 0:
        return float(xs[-1])
    j = int(below[0])
    if j == 0:
        return float(xs[0])
    a, b = Ts[j - 1], Ts[j]
    return float(xs[j - 1] + (a - melt) / (a - b) * (xs[j] - xs[j - 1]))


def hat_integrals_left_of(mesh, s: float) -> np.ndarray:
    """int_{x < s} phi_i dx for every vertex i of a triangle mesh (P1 hats, m^2), exactly: the elements cut by
    the line x = s are clipped and their pieces integrated with the centroid rule (exact for linear phi_i)."""
    pts = np.array([v.point[:2] for v in mesh.vertices])
    out = np.zeros(len(pts))
    for el in mesh.Elements(ngs.VOL):
        vs = [v.nr for v in el.vertices]
        if len(vs) != 3:
            raise ValueError("hat_integrals_left_of needs a triangle mesh")
        P = pts[vs]
        B = np.column_stack([P[1] - P[0], P[2] - P[0]])
        area = abs(np.linalg.det(B)) / 2
        if P[:, 0].max() <= s:
            out[vs] += area / 3
            continue
        if P[:, 0].min() >= s:
            continue
        poly = []                      # Sutherland-Hodgman against x <= s
        for a, b in zip(P, np.roll(P, -1, axis=0)):
            if a[0] <= s:
                poly.append(a)
            if (a[0] - s) * (b[0] - s) < 0:
                poly.append(a + (s - a[0]) / (b[0] - a[0]) * (b - a))
        for k in range(1, len(poly) - 1):
            tri = np.array([poly[0], poly[k], poly[k + 1]])
            piece = abs(np.linalg.det(np.column_stack([tri[1] - tri[0], tri[2] - tri[0]]))) / 2
            l1, l2 = np.linalg.solve(B, tri.mean(axis=0) - P[0])
            out[vs] += piece * np.array([1 - l1 - l2, l1, l2])
    return out


def initial_enthalpy(forms: StefanForms, problem: NeumannProblem, t: float) -> np.ndarray:
    """Nodal enthalpies (J/m^3) at time t: the lumped L2 projection of the exact enthalpy, e_i = int e phi_i / m_i,
    so that the heat content of the initial state is the exact one. The sensible part (continuous, with a kink at
    the front) is integrated with a high-order rule, the latent part L 1[x < s(t)] exactly
    (:func:`hat_integrals_left_of`)."""
    latent = problem.material.latent_heat * hat_integrals_left_of(forms.mesh, problem.front(t)) / forms.mass
    return forms.project_enthalpy(problem.sensible_enthalpy_cf(t)) + latent


class _LinearReference:
    """Steps of :class:`HeatSolver` on the same mesh with the liquid's constant properties and the strip's
    Dirichlet data, from the initial temperatures ``T0``: :meth:`step` times one backward Euler step with the
    factorization reused (as in a linear run with constant dt; the first call, the set-up, factors),
    :meth:`fresh` one with the cache cleared (assembly and factorization included). Wall and CPU (process) s."""

    def __init__(self, mesh, problem: NeumannProblem, T0: np.ndarray):
        m = problem.material
        setup = HeatSetup(props={"pcm": ThermalProperties(kappa=m.conductivity_liquid * np.eye(2),
                                                          rho_c=m.rho_c_liquid)},
                          dirichlet={"hot": expression_function(problem.t_hot),
                                     "far": expression_function(problem.t_cold)})
        self.forms = HeatForms(mesh, setup)
        self.solver = HeatSolver(self.forms)
        self.forms.gf.vec.FV().NumPy()[:] = T0

    def step(self, a: float, b: float, fresh: bool = False) -> tuple[float, float]:
        forms = self.forms
        if fresh:
            self.solver.forget_factorizations()
        start, cpu = time.perf_counter(), time.process_time()
        forms.gf_old.vec.data = forms.gf.vec
        forms.t_old.Set(a)
        forms.t_new.Set(b)
        forms.inv_dt.Set(1.0 / (b - a))
        self.solver.solve(f"linear reference step to t = {b:g} s")
        return time.perf_counter() - start, time.process_time() - cpu

    def fresh(self, a: float, b: float) -> tuple[float, float]:
        return self.step(a, b, fresh=True)


def single_threaded_blas():
    """Every OpenBLAS of the process at one thread while the context lasts
    (:func:`ngs_geomech.linalg.threads.blas_threads`): with two BLAS threads on the shared 2-core machine the
    Stefan steps at 16k nodes took 14 instead of 8 ms (SuperLU's multi-column solves and the small dense systems),
    the threads spinning while the other core was busy."""
    return blas_threads(1)


def neumann_strip(problem: NeumannProblem, h: float, dt: float, t0: float, t1: float, height: float = 0.1,
                  method: str = "enthalpy", delta: float | None = None, linear_reference: bool = True,
                  initial: str = "project") -> dict:
    """Run the strip (module docstring) with mesh size ``h`` (m) and step ``dt`` (s) from ``t0`` to ``t1``.

    ``method``: 'enthalpy' (semi-smooth Newton, :class:`StefanSolver`) or 'apparent' (smeared heat capacity
    with half width ``delta`` K, :class:`ApparentHeatCapacitySolver`). Returns ``front_exact``,
    ``front_temperature`` and ``front_volume`` (m) with their errors ``front_error_temperature``,
    ``front_error_volume`` (m), ``l2`` (K m) and ``l2_rel`` (relative to the L2 norm of T - T_S),
    ``energy_gain`` (J/m: sum m_i (e_i(t1) - e_i(t0))), ``boundary_heat`` (J/m: the heat that entered at the
    Dirichlet nodes, from the nodal residuals), ``boundary_heat_exact`` (J/m, the closed form times the height),
    ``energy_imbalance_rel`` = |gain - boundary heat| / boundary heat (the scheme's conservation),
    ``energy_error_rel`` = |gain - exact heat| / exact heat (discretization error),
    ``initial_energy_error_rel`` (the initial heat content above T_S against the exact heat input up to t0:
    the initial state, by default ``initial='project'``, the lumped projection of the exact enthalpy, so that
    the latent heat of the element cut by the front is counted; 'interpolate' takes e(T) at the nodes), ``newton_mean``,
    ``newton_max``, ``steps``, ``ndofs``, ``time_per_step`` (s), ``linear_step_time`` (s, factorization
    reused), ``linear_step_time_factor`` (s, with assembly and factorization), the ratios ``time_ratio`` and
    ``time_ratio_factor``, the same in CPU (process) time ``cpu_time_per_step``, ``linear_step_cpu_time``,
    ``time_ratio_cpu`` (factorization reused; less disturbed by other jobs on the machine), ``factorizations``
    (and ``factorizations_per_step``), ``corrections_per_step`` (the Newton solver's extra solves: low-rank
    correction columns, one solve each, or in window mode (factored sets of 8000 unknowns and more) the solves for
    the window's boundary nodes when a window is set up; :class:`ngs_geomech.stefan.column_jacobian.ColumnJacobian`) and
    ``phase_changes_per_step`` (nodes changing between solid, mushy and liquid).
    Runs on one NGSolve thread and one BLAS thread (:func:`single_threaded_blas`; the timings compare like with
    like; idle worker threads made sparse Cholesky 30 times slower at 500 dofs).
    """
    if method not in ("enthalpy", "apparent"):
        raise ValueError(f"method must be 'enthalpy' or 'apparent', got {method!r}")
    if not 0 < t0 < t1:
        raise ValueError(f"need 0 < t0 < t1, got t0 = {t0}, t1 = {t1}")
    with one_ngsolve_thread(), single_threaded_blas():
        return _neumann_strip(problem, h, dt, t0, t1, height, method, delta, linear_reference, initial)


def _neumann_strip(problem, h, dt, t0, t1, height, method, delta, linear_reference, initial) -> dict:
    mat = problem.material
    length = problem.domain_length(t1)
    mesh = strip_mesh(length, height, h)
    setup = StefanSetup(materials={"pcm": mat}, dirichlet={"hot": problem.t_hot, "far": problem.t_cold})
    forms = StefanForms(mesh, setup)
    xs = np.array([v.point[0] for v in mesh.vertices])
    T0 = problem.temperature(xs, t0)
    solver, energy0 = _strip_solver(problem, forms, method, delta, t0, T0, (xs < problem.front(t0)).astype(float),
                                    initial)
    steps = list(schedule(t0, t1, dt))
    reference = _LinearReference(mesh, problem, T0) if linear_reference else None
    if reference is not None:
        reference.step(*steps[0])                     # set-up and factorization, not counted
    boundary_heat, iters, times, cpus, changes, lin = _timed_steps(solver, steps, reference)
    cpu_per_step = float(np.sum(cpus)) / len(steps)
    if method == "enthalpy":
        T = solver.temperature()
        e1 = solver.e
        energy1 = forms.heat_content(e1)
        front_volume = forms.melted_volume(e1) / height
    else:
        T = solver.T
        energy1 = forms.heat_content(solver.enthalpy())
        frac = np.clip((T - mat.melting_temperature + delta) / (2 * delta), 0.0, 1.0)
        front_volume = float(forms.mass @ frac) / height
    Th = ngs.GridFunction(forms.V)
    Th.vec.FV().NumPy()[:] = T
    exact = problem.temperature_cf(t1)
    l2 = math.sqrt(float(ngs.Integrate((Th - exact) ** 2, mesh, order=12)))
    norm = math.sqrt(float(ngs.Integrate((exact - problem.t_cold) ** 2, mesh, order=12)))
    s_exact = problem.front(t1)
    s_T = front_from_temperature(mesh, T, mat.melting_temperature)
    gain = energy1 - energy0
    q_exact = problem.boundary_heat(t0, t1) * height
    e_cold = forms.heat_content(forms.enthalpy_of(np.full(forms.n, problem.t_cold)))
    q_initial = problem.boundary_heat(0.0, t0) * height
    out = {"method": method, "h": float(h), "dt": float(dt), "t0": t0, "t1": t1, "length": length,
           "height": height, "ndofs": int(forms.n), "steps": len(steps), "lam": problem.lam,
           "front_exact": s_exact, "front_temperature": s_T, "front_volume": front_volume,
           "front_error_temperature": abs(s_T - s_exact), "front_error_volume": abs(front_volume - s_exact),
           "l2": l2, "l2_rel": l2 / norm,
           "energy_gain": gain, "boundary_heat": boundary_heat, "boundary_heat_exact": q_exact,
           "energy_imbalance_rel": abs(gain - boundary_heat) / abs(boundary_heat),
           "energy_error_rel": abs(gain - q_exact) / q_exact,
           "initial_energy_error_rel": abs(energy0 - e_cold - q_initial) / q_initial,
           "newton_mean": float(np.mean(iters)), "newton_max": int(np.max(iters)),
           "factorizations": int(solver.factorizations), "time_per_step": float(np.mean(times)),
           "cpu_time_per_step": cpu_per_step,
           "factorizations_per_step": solver.factorizations / len(steps),
           "corrections_per_step": solver.jac.corrections / len(steps),
           "phase_changes_per_step": float(np.mean(changes))}
    if reference is not None:
        lin = np.array(lin)
        reused, reused_cpu = float(np.mean(lin[:, 0])), float(np.mean(lin[:, 1]))
        fresh = float(np.mean([reference.fresh(a, b)[0] for a, b in steps[:3]]))
        out.update(linear_step_time=reused, linear_step_time_factor=fresh,
                   time_ratio=out["time_per_step"] / reused, time_ratio_factor=out["time_per_step"] / fresh,
                   linear_step_cpu_time=reused_cpu, time_ratio_cpu=cpu_per_step / reused_cpu)
    return out


def _strip_solver(problem, forms, method, delta, t0, T0, liquid, initial) -> tuple:
    """The strip's solver of ``method`` at its initial state (nodal temperatures ``T0``, K; ``liquid`` fractions
    deciding the nodes at the melting temperature) and its initial heat content (J/m)."""
    if method == "enthalpy":
        solver = StefanSolver(forms)
        if initial == "project":
            solver.set_initial_enthalpy(initial_enthalpy(forms, problem, t0))
        else:
            solver.set_initial(T0, liquid)
        return solver, forms.heat_content(solver.e)
    if delta is None or not delta > 0:
        raise ValueError(f"the apparent heat capacity method needs delta > 0 K, got {delta}")
    solver = ApparentHeatCapacitySolver(forms, delta)
    solver.set_initial(T0)
    return solver, forms.heat_content(solver.enthalpy())


def _timed_steps(solver, steps, reference) -> tuple:
    """Take the ``steps`` (t_old, t_new) with ``solver``, timed, alternating with the linear ``reference``'s steps:
    the boundary heat (J/m), the lists of Newton iterations, wall times (s), CPU times of the blocks (s) and
    phase changes per step, and the reference's (wall, CPU) times per step."""
    boundary_heat = 0.0
    iters, times, cpus, changes, lin = [], [], [], [], []
    block = max(25, -(-len(steps) // 5))
    for k in range(0, len(steps), block):
        # five blocks of Stefan steps and of as many linear steps alternate, so that both are timed under the
        # same load of the shared machine (the linear step alone varied by 40 % between runs); shorter blocks
        # slowed the linear steps more than the Stefan ones (caches cold at each switch: blocks of 18 steps
        # at 10.8k nodes, linear +15 %, Stefan +1 %), 5 blocks within the noise
        cpu = time.process_time()
        for a, b in steps[k:k + block]:
            start = time.perf_counter()
            info = solver.step(a, b)
            times.append(time.perf_counter() - start)
            iters.append(info.iterations)
            changes.append(info.phase_changes)
            boundary_heat += info.boundary_heat
        cpus.append(time.process_time() - cpu)
        if reference is not None:
            lin += [reference.step(a, b) for a, b in steps[k:k + block]]
    return boundary_heat, iters, times, cpus, changes, lin


def neumann_convergence(problem: NeumannProblem, hs, dt_over_h: float, t0: float, t1: float,
                        height: float = 0.1, method: str = "enthalpy", delta_over_h: float | None = None,
                        linear_reference: bool = True) -> dict:
    """:func:`neumann_strip` at mesh sizes ``hs`` with dt = dt_over_h * h (s/m; h and dt refined together;
    the apparent method with delta = delta_over_h * h K/m). Returns the per-level results under ``levels``,
    the lists ``h``, ``front_error_temperature``, ``front_error_volume``, ``l2``, ``energy_error_rel`` and the
    fitted orders ``order_front_temperature``, ``order_front_volume``, ``order_l2``, ``order_energy``."""
    levels = []
    for h in hs:
        delta = None if delta_over_h is None else delta_over_h * h
        levels.append(neumann_strip(problem, h, dt_over_h * h, t0, t1, height=height, method=method, delta=delta,
                                    linear_reference=linear_reference))
    out = {"method": method, "levels": levels, "h": [float(h) for h in hs]}
    for key in ("front_error_temperature", "front_error_volume", "l2", "energy_error_rel"):
        out[key] = [lv[key] for lv in levels]
    out["order_front_temperature"] = observed_order(hs, out["front_error_temperature"])
    out["order_front_volume"] = observed_order(hs, out["front_error_volume"])
    out["order_l2"] = observed_order(hs, out["l2"])
    out["order_energy"] = observed_order(hs, out["energy_error_rel"])
    return out
