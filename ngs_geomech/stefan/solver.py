"""Time steps of the Stefan problem in enthalpy form (:mod:`ngs_geomech.stefan.forms`), seed (2.55): a
semi-smooth Newton method on the nodal enthalpy (the smeared apparent-heat-capacity method, for comparison, is in
:mod:`ngs_geomech.stefan.apparent`).

Semi-smooth Newton (:class:`StefanSolver`). One backward Euler step solves, for the free nodal enthalpies e,

    R(e) = m (e - e_old)/dt + A(beta(e)) - F = 0,

with beta the nodal inverse enthalpy graph (piecewise linear and Lipschitz) and A(T) = sum_g K_g theta_g(T)
(piecewise linear too). The generalized derivative of beta is 1/C_s, 0 (mushy), 1/C_l node by node (the flat
parts are closed: a node at a kink counts as mushy, see :meth:`StefanForms.nodal_state`), and that of theta_g
is k_s or k_l of the node's interval. With D = dT/de, a Newton step J de = -R, J = m/dt + A'(T) D, is computed
on the temperatures of the non-mushy free nodes N (dT = 0 on the mushy ones M, de_N = dT_N / D_N):

    (m C/dt + A'(T))_NN dT_N = -R_N,        de_M = -(dt/m)(R + A'(T) dT)_M.

R is piecewise linear in e: once every node is on its final branch (solid, mushy or liquid) the next Newton
step is exact, so Newton ends after a small number of iterations, about one more than the number of element
layers the phase boundary crosses in the step (each iteration moves it by about one layer). With dt refined
with h that number stays O(1): this is why the unknown is the enthalpy (single valued, Lipschitz inverse graph,
exact per-node semismoothness) rather than the temperature with the multivalued graph. The first iterate is the
old state plus dt times the last step's rate of change (a predictor: fewer nodes change branch during the
iteration). No damping or line search: none was needed in the measurements.

Linear algebra. The system above is solved as the larger, block triangular system on all free nodes in mixed
unknowns (dT_j on a non-mushy node, a multiple of de_j on a mushy one), whose column j is
(m_j C_j/dt) e_j + sum_g K_g[:, j] dtheta_g(T_j), without its off-diagonal part when j is mushy (the mushy rows do
not feed back into N, so dT_N is the same; de_M is then taken from the explicit formula above, which keeps exact
zeros ahead of a one-phase front). A strategy of :class:`ngs_geomech.stefan.jacobian.NewtonJacobian` solves it:
:class:`ColumnJacobian` (:mod:`ngs_geomech.stefan.column_jacobian`, serial meshes: one sparse LU kept over many
steps with low-rank updates of the changed columns, or a window around the front on large meshes) or
:class:`KrylovJacobian` (:mod:`ngs_geomech.stefan.krylov_jacobian`, distributed meshes and ``linear="iterative"``:
preconditioned GMRES); the measurements of each are in its module.

Convergence. With dt = 4 h (the front crosses several layers per step) mean 8, max 13 iterations; a step asking
the front to cross dozens of layers does not converge in 25 iterations and raises SolverError. The stopping test
is on the nodal residual: the enthalpy defect max_i |R_i| dt/m_i (J/m^3) of the free nodes below ``tol`` times
the enthalpy scale of the step (the largest latent heat or C times the temperature range, whichever is larger).
A step that does not converge raises SolverError with the residual history and the nodes that still switch branch
(never NaN). ``studies/stefan_performance`` measures iterations and the time per step against a linear heat step.

Temperature-dependent conductivity (b != 0, :mod:`ngs_geomech.stefan.forms`). theta is then quadratic on each
branch, and the Newton matrix's column j carries k_g(T_j) = k_g (1 + b_g (T_j - T_ref)), which changes at every
node in every iteration: the same :class:`ColumnJacobian` gives the exact Newton step, but it refactors in
practically every iteration (the changed set is everything), so a step costs Newton iterations x one sparse LU.
Two safeguards, used only when b != 0 (the b = 0 path is unchanged, bit for bit): the update of a non-mushy node
is taken in its Kirchhoff variable (the step's change of theta, k dT, mapped back through the node's quadratic
theta, :meth:`StefanSolver._kirchhoff_update`; taken in T, a node far from the solution came back by halves as on
a parabola), and each node's increment is cut so that its factor 1 + b (T - T_ref) stays above 0.1 of its value
(:meth:`StefanSolver._in_range`; beyond f = 0 lies a spurious root with k < 0, where undamped iterations went).
Measured (``tests/test_stefan_kirchhoff.py``, melting strip, b = 0.01 1/K, dt = 0.4 h): Newton mean 3.3 - 4.0 per
step against 1.4 - 2.4 with b = 0, 3.3 - 4.0 factorizations per step against 0.04 - 0.11, 6.2, 11.5, 28.6 ms
per step against 1.5, 1.2, 5.3 ms (h = 0.05, 0.025, 0.0125 m; 4 - 9 times; one run on the shared machine). On the
steady slab (steps doubling up to 1e12 s) some steps near the diffusion time of the mesh did not converge and were
split (6 and 13 splits at h = 0.05, 0.025 against 0 and 3 with b = 0); the mushy nodes' cycling seen there is
not specific to b != 0.

Distributed meshes (MPI; :mod:`ngs_geomech.parallel`, selected by ``parallel.distributed(mesh)`` only, the serial
path above unchanged). The same iteration on the same unknown: every rank holds the nodal arrays of its vertices
with cumulated values (:class:`StefanForms`: masses, loads and A(T) cumulated over the ranks), so the branches, the
nodal states, the predictor and the mushy update de_M stay pointwise numpy; after each update the enthalpy of a
shared vertex is set to its owner's value (the same bits on every rank, so the ranks take the same branch there).
The stopping test, the round-off floor and the enthalpy scale are maxima over the ranks (``parallel.allmax``), the
heats and counts of :class:`StefanStepInfo` sums over the owned vertices (``parallel.allsum``), so every rank takes
the same branches around the collective calls, raises the same SolverError (the diagnosis gathers the switching
nodes of all ranks) and never sees NaN. The Newton steps are solved by :class:`KrylovJacobian` there
(:mod:`ngs_geomech.stefan.krylov_jacobian`). Not available there: contact interfaces (the mortar penalty: refused
by :class:`StefanForms`), the smeared :class:`ngs_geomech.stefan.apparent.ApparentHeatCapacitySolver`, and the
SuperLU-specific options (``max_changed``, window mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NoReturn

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import SolverError
from .column_jacobian import ColumnJacobian
from .forms import NodalState, StefanForms, time_function
from .jacobian import NewtonJacobian
from .krylov_jacobian import KrylovJacobian


@dataclass
class StefanStepInfo:
    """What one step did: ``iterations`` (linear solves), the final ``residual`` (max nodal enthalpy defect,
    J/m^3), ``boundary_heat`` (heat that entered through the Dirichlet nodes during the step, J per metre of
    depth in 2D, J in 3D), ``source_heat`` (sources and fluxes, same units), ``phase_changes`` (nodes whose
    branch, solid/mushy/liquid, changed in the step), ``factorizations`` (sparse LU factorizations in the step;
    on a distributed mesh the BDDC preconditioners built),
    ``corrections`` (new low-rank correction columns, one solve each; in window mode the solves for the
    window's interface; see :class:`ColumnJacobian`) and ``robin_heat`` (the heat that entered through the heat
    transfer conditions, dt sum_i (h T_amb - h T)_i at t_new, same units as the other heats), ``front_nodes``
    (nodes mushy at the start or the end of the step: the front's layer, against which ``phase_changes`` measures
    its travel, :mod:`ngs_geomech.stefan.stepping`)."""

    iterations: int
    residual: float
    boundary_heat: float
    source_heat: float
    phase_changes: int
    factorizations: int = 0
    corrections: int = 0
    robin_heat: float = 0.0
    front_nodes: int = 0

def _branch(st: NodalState) -> np.ndarray:
    """Per node: the interval index on a sensible branch, -1 - the flat part's index on a mushy one."""
    return np.where(st.mushy, -1 - st.segment, st.segment)


def _conduction_derivative_apply(forms: StefanForms, dtheta: np.ndarray, dT: np.ndarray) -> np.ndarray:
    """A'(T) dT = sum_g K_g (dtheta_g dT) (cumulated on a distributed mesh)."""
    if forms.distributed:
        return forms.cumulate(sum((K @ (dtheta[:, g] * dT) for g, K in enumerate(forms.stiffness)), np.zeros(forms.n)))
    return sum(K @ (dtheta[:, g] * dT) for g, K in enumerate(forms.stiffness))


class StefanSolver:
    """Backward Euler steps of the enthalpy formulation by the semi-smooth Newton method (module docstring).

    ``e`` holds the nodal enthalpy (J/m^3); set it with :meth:`set_initial`. ``tol`` is relative to the
    enthalpy scale, ``maxit`` the largest number of Newton iterations per step, ``max_changed`` the number of
    changed nodes after which the Newton matrix is factored again (default: see :class:`ColumnJacobian`).
    On a distributed mesh (MPI), and on a serial one with ``linear="iterative"``, the Newton steps are solved by
    GMRES (:class:`KrylovJacobian`) with ``krylov_preconditioner`` "bddc" (the distributed
    default), "h1amg" (the serial default: NGSolve's AMG on the same symmetric form, serial only) or "jacobi";
    ``max_changed`` is not used there. On a distributed mesh every method that steps or sets the state is
    collective (every rank calls it).
    """

    def __init__(self, forms: StefanForms, tol: float = 1e-10, maxit: int = 25, predictor: bool = True,
                 max_changed: int | None = None, krylov_preconditioner: str | None = None, linear: str = "direct"):
        self.f = forms
        self.tol = tol
        self.maxit = maxit
        self.predictor = predictor
        self.e = np.zeros(forms.n)
        self._last_change = None          # (e_new - e_old)/dt of the last step
        self.distributed = forms.distributed
        """Distributed mesh (MPI): the Newton steps are solved by :class:`KrylovJacobian` (module docstring)."""
        if linear not in ("direct", "iterative"):
            raise ValueError(f"the Stefan solver's linear solver must be 'direct' or 'iterative', got {linear!r}")
        self.linear = "iterative" if self.distributed else linear
        """'iterative': the Newton steps by GMRES (:class:`KrylovJacobian`; always on a distributed mesh)."""
        self.jac: NewtonJacobian
        """The linear solver of the Newton steps."""
        if self.linear == "iterative":
            pre = krylov_preconditioner or ("bddc" if self.distributed else "h1amg")
            self.jac = KrylovJacobian(forms, preconditioner=pre)
        else:
            self.jac = ColumnJacobian(forms, max_changed)
        self.iterations: list[int] = []
        self._state = None                # (e, NodalState of e) of the last step's end
        self._dirichlet_static = all(getattr(time_function(v), "time_dependent", True) is False
                                     for v in forms.setup.dirichlet.values())
        self._dirichlet_cache = None

    @property
    def factorizations(self) -> int:
        return self.jac.factorizations

    def set_initial(self, temperature, liquid_fraction=None) -> None:
        """Initial state from nodal temperatures (array, K) or a CoefficientFunction interpolated at the nodes;
        ``liquid_fraction`` (array or CF, 0..1) decides nodes exactly at a phase-change temperature
        (default solid)."""
        T = self._nodal(temperature)
        self.f.check_conductivity(T, " at the initial state")
        f = None if liquid_fraction is None else self._nodal(liquid_fraction)
        self.e = self.f.consistent(self.f.enthalpy_of(T, f))
        self._last_change = None
        self.f.store(self.e)

    def set_initial_enthalpy(self, e) -> None:
        """Initial state from nodal enthalpies (array, J/m^3), e.g. :meth:`StefanForms.project_enthalpy`."""
        self.e = self.f.consistent(self._nodal(e))
        self.f.check_conductivity(self.f.nodal_state(self.e).T, " at the initial state")
        self._last_change = None
        self.f.store(self.e)

    def _nodal(self, value) -> np.ndarray:
        if isinstance(value, ngs.CoefficientFunction):
            if self.f.n == 0:                         # a rank without vertices (rank 0 of a distributed mesh)
                return np.zeros(0)
            pts = np.array([v.point for v in self.f.mesh.vertices])
            mp = self.f.mesh(*pts.T) if pts.shape[1] == 3 else self.f.mesh(pts[:, 0], pts[:, 1])
            return np.asarray(value(mp), dtype=float).ravel()
        arr = np.asarray(value, dtype=float)
        if arr.shape != (self.f.n,):
            raise ValueError(f"nodal values must have shape ({self.f.n},), got {arr.shape}")
        return arr

    def mark(self) -> tuple:
        """The solver's state between steps (enthalpy, predictor rate, cached nodal state, step count)."""
        return (self.e.copy(), None if self._last_change is None else self._last_change.copy(), self._state,
                len(self.iterations))

    def rewind(self, mark: tuple) -> None:
        """Back to a state from :meth:`mark`: the next :meth:`step` repeats the step taken since."""
        e, rate, state, n = mark
        self.e = e.copy()
        self._last_change = None if rate is None else rate.copy()
        self._state = state
        del self.iterations[n:]
        self.f.store(self.e)

    def capture(self) -> dict:
        """The state between steps as plain arrays: the enthalpy, the predictor rate and the Newton matrix's
        reuse state (``jacobian/...``, :meth:`NewtonJacobian.capture`)."""
        out = {"enthalpy": np.array(self.e, dtype=float)}
        if self._last_change is not None:
            out["rate"] = self._last_change.copy()
        out.update({f"jacobian/{k}": v for k, v in self.jac.capture().items()})
        return out

    def restore(self, state: dict) -> None:
        """Continue from a state of :meth:`capture` (a checkpoint's; a missing rate or reuse state starts the
        next step without them)."""
        self.set_initial_enthalpy(np.array(state["enthalpy"], dtype=float))
        if "rate" in state:
            self._last_change = np.array(state["rate"], dtype=float)
        self.jac.restore({k.split("/", 1)[1]: v for k, v in state.items() if k.startswith("jacobian/")})

    def temperature(self) -> np.ndarray:
        """Nodal temperatures of the current state, K."""
        return self.f.nodal_state(self.e).T

    def _scale(self, T: np.ndarray) -> float:
        f = self.f
        lat = max([f.groups[g].latent_heat for g in f.pcm_groups] + [0.0])
        if self.distributed:                          # the same scale on every rank
            span = f.nodal_max(T) + f.nodal_max(-T)  # max T - min T over the ranks
            return max(lat, f.nodal_max(f.capacity, 0.0) * span, 1e-300)
        span = float(np.max(T) - np.min(T)) if T.size else 0.0
        return max(lat, float(np.max(f.capacity)) * span, 1e-300)

    def _old_state(self, e: np.ndarray) -> NodalState:
        """The nodal state of ``e``: the last step's final state when ``e`` is still its result."""
        if self._state is not None and np.array_equal(self._state[0], e):
            return self._state[1]
        return self.f.nodal_state(e)

    def _dirichlet_temperatures(self, t: float) -> np.ndarray:
        """Dirichlet temperatures at t (interpolated once when none depends on t)."""
        if not self._dirichlet_static:
            return self.f.dirichlet_temperatures(t)
        if self._dirichlet_cache is None:
            self._dirichlet_cache = self.f.dirichlet_temperatures(t)
        return self._dirichlet_cache

    def step(self, t_old: float, t_new: float, extra_load: np.ndarray | None = None) -> StefanStepInfo:
        """One backward Euler step from t_old to t_new (s): Dirichlet data, sources, fluxes and ambient
        temperatures at t_new.
        ``extra_load`` (nodal, W per metre of depth in 2D, W in 3D; e.g. the deformation heating of (2.49)) is
        added to the loads and counted in ``source_heat``; on a distributed mesh it holds this rank's vertices with
        cumulated values (the full nodal value at a shared vertex, as a GridFunction's vector), and the call is
        collective."""
        f = self.f
        dt = float(t_new) - float(t_old)
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"Stefan step: dt must be positive and finite, got {dt} (t_old {t_old}, t_new {t_new})")
        where = f"t = {t_new:g} s"
        counts = (self.jac.factorizations, self.jac.corrections)
        e_old = self.e.copy()
        st_old = self._old_state(e_old)
        e = self._first_iterate(e_old, st_old, dt, t_new)
        F = self._loads(t_new, extra_load)
        F_robin = f.robin_loads(t_new)              # the ambient side of the heat transfer conditions, or None
        F_all = F if F_robin is None else F + F_robin
        dt_m = dt / f.mass
        history = []
        prev_st = None
        seen = {} if self._cycles_exact else None     # branch pattern -> the iteration that had it
        it = 0
        while True:
            st = f.nodal_state(e)
            if it == 0:
                scale = self._scale(np.concatenate([st_old.T, st.T]))
            R = f.mass * (e - e_old) / dt + f.conduction(st.T) - F_all
            res = self._defect(R, dt_m, history, where)
            if self._converged(res, scale, it, e, e_old, st, F_all, dt_m):
                break
            if it >= self.maxit:
                self._fail(where, history, st, prev_st, scale)
            if seen is not None:
                self._check_cycle(seen, _branch(st).tobytes(), it, where, history, st, prev_st, scale)
            prev_st = st
            e = self._newton_update(e, st, R, dt, dt_m, where)
            it += 1
        f.check_conductivity(st.T, f" at {where}")
        robin_heat = 0.0 if F_robin is None else dt * f.robin_heat_rate(F_robin, st.T)
        if self.distributed:
            info = self._finish_distributed(e, e_old, st, st_old, R, F, dt, it, res, counts)
            info.robin_heat = robin_heat
            return info
        boundary_heat = float(dt * np.sum(R[~f.free]))
        self._keep(e, e_old, st, dt, it)
        return StefanStepInfo(iterations=max(it, 1), residual=res, boundary_heat=boundary_heat,
                              source_heat=float(dt * np.sum(F)),
                              phase_changes=int(np.count_nonzero(_branch(st) != _branch(st_old))),
                              factorizations=self.jac.factorizations - counts[0],
                              corrections=self.jac.corrections - counts[1], robin_heat=robin_heat,
                              front_nodes=int(np.count_nonzero(st.mushy | st_old.mushy)))

    def _first_iterate(self, e_old: np.ndarray, st_old: NodalState, dt: float, t_new: float) -> np.ndarray:
        """The Newton iteration's first iterate: the old state plus dt times the last step's rate (the predictor;
        kept in range by :meth:`_in_range` when a conductivity depends on T), the Dirichlet nodes whose temperature
        changed set to the enthalpy of their temperature at t_new."""
        f = self.f
        e = e_old.copy()
        if self.predictor and self._last_change is not None:
            e[f.free] += dt * self._last_change[f.free]
            if f.temperature_dependent:
                e = e_old + self._in_range(e_old, e - e_old, st_old)
        if len(f.dirichlet_dofs):
            T_D = self._dirichlet_temperatures(t_new)
            d = f.dirichlet_dofs
            changed = T_D != st_old.T[d]
            if np.any(changed):
                T = st_old.T.copy()
                T[d] = T_D
                e[d[changed]] = f.enthalpy_of(T)[d[changed]]
        return e

    def _loads(self, t_new: float, extra_load: np.ndarray | None) -> np.ndarray:
        """F at t_new (sources and fluxes) plus ``extra_load`` (nodal, W per metre of depth in 2D, W in 3D)."""
        F = self.f.loads(t_new)
        if extra_load is not None:
            F = F + np.asarray(extra_load, dtype=float)
        return F

    def _defect(self, R: np.ndarray, dt_m: np.ndarray, history: list, where: str) -> float:
        """The enthalpy defect max_i |R_i| dt/m_i of the free nodes (J/m^3; ``dt_m`` = dt/m), appended to
        ``history``; on a distributed mesh the maximum over the ranks, so that every rank takes the same branches.
        SolverError when it is not finite."""
        jfree = self.jac.free
        res = float(np.max(np.abs(R[jfree]) * dt_m[jfree])) if len(jfree) else 0.0
        if self.distributed:
            res = self.f.nodal_max(np.array([res if math.isfinite(res) else math.inf]), 0.0)
        if not math.isfinite(res):
            raise SolverError(f"Stefan Newton step at {where}: the residual is not finite "
                              f"(history {history}). Check the material data and the time step.")
        history.append(res)
        return res

    def _converged(self, res: float, scale: float, it: int, e: np.ndarray, e_old: np.ndarray, st: NodalState,
                   F: np.ndarray, dt_m: np.ndarray) -> bool:
        """Whether the defect ``res`` (J/m^3) meets the tolerance relative to the step's enthalpy ``scale``, or,
        from the third iterate on, the round-off floor of the terms the residual is made of."""
        if res <= self.tol * scale:
            return True
        if it < 2:
            return False
        # the defect cannot fall below the round-off of the terms it is made of (steps far longer than the
        # diffusion time of the mesh, large interface penalties): accept it there
        f = self.f
        jfree = self.jac.free
        terms = (np.abs(e) + np.abs(e_old) + dt_m * (f.conduction_magnitude(st.T) + np.abs(F)))[jfree]
        floor = 64 * np.finfo(float).eps * (f.nodal_max(terms, 0.0) if self.distributed else float(np.max(terms)))
        return res <= floor

    @property
    def _cycles_exact(self) -> bool:
        """Whether a repeated branch pattern proves a cycle (:meth:`_check_cycle`): serial meshes with
        conductivities independent of T (R piecewise linear in e)."""
        return not self.distributed and not self.f.temperature_dependent

    def _check_cycle(self, seen: dict, pattern: bytes, it: int, where: str, history: list, st: NodalState,
                     prev_st: NodalState | None, scale: float) -> None:
        """Raise the step's SolverError at once when the branch pattern (solid / mushy / liquid per node) of
        iterate ``it`` is one an earlier iterate j had. With k independent of T the residual R is linear on
        each branch pattern, so the Newton update from a pattern is the root of that pattern's linear model
        whatever the iterate: iterate it + 1 repeats iterate j + 1 (to round-off), which did not converge, and
        the iteration cycles until ``maxit``. Stopping here saves those iterations (the same failure, found
        earlier). The first iterate's pattern is not kept: iterate 1 is not tested against the round-off floor of
        :meth:`_converged` (from iterate 2 on), so its not converging proves nothing."""
        if it < 1:
            return
        j = seen.setdefault(pattern, it)
        if j == it:
            return
        self._fail(where, history, st, prev_st, scale, cycle=(j, it))

    def _fail(self, where: str, history: list, st: NodalState, prev_st: NodalState | None,
              scale: float, cycle: tuple[int, int] | None = None) -> NoReturn:
        """Raise the error of a step that did not converge in ``maxit`` iterations: ConductivityRangeError when a
        conductivity factor was held at the edge of its range, SolverError with :meth:`_diagnosis` otherwise."""
        self.f.check_conductivity(st.T, f" at {where}", floor=self.RANGE_FLOOR)
        switching = (np.zeros(0, dtype=int) if prev_st is None
                     else np.nonzero(_branch(st) != _branch(prev_st))[0])
        raise SolverError(self._diagnosis(where, history, switching, st, scale, cycle))

    def _newton_update(self, e: np.ndarray, st: NodalState, R: np.ndarray, dt: float, dt_m: np.ndarray,
                       where: str) -> np.ndarray:
        """The next Newton iterate from ``e`` (its nodal state ``st``, its residual ``R``; module docstring)."""
        f = self.f
        jfree = self.jac.free
        dtheta = f.kirchhoff_derivatives(st)
        capacity = f.capacity[np.arange(f.n), st.segment]      # 1/D on the non-mushy nodes
        # the Newton matrix in mixed unknowns (dT on the non-mushy nodes, a multiple of de on the mushy ones):
        # column j is (m_j C_j/dt) e_j + sum_g K_g[:, j] dtheta_gj, without its off-diagonal part when j is
        # mushy (the diagonal kept, so that a node entering or leaving the flat part changes only the
        # off-diagonal entries of its column: a well-conditioned update); the mushy rows decouple
        # (block triangular), so dT on the non-mushy nodes is the Schur-reduced Newton step
        sensible = ~st.mushy[jfree]
        dth = dtheta[jfree]
        x = self.jac.solve((f.mass * capacity)[jfree], dth, dth * sensible[:, None], -R[jfree] * sensible, dt, where)
        dT = np.zeros(f.n)
        dT[jfree] = x * sensible
        y = _conduction_derivative_apply(f, dtheta, dT)
        # de = C dT on the non-mushy nodes; on the mushy ones from their rows: -(dt/m)(R + A'(T) dT)
        if f.temperature_dependent:
            # the update of a non-mushy node taken in its Kirchhoff variable (see _kirchhoff_update)
            de = np.where(st.mushy, -dt_m * (R + y), self._kirchhoff_update(st, dT, dtheta) * capacity)
            de[~f.free] = 0.0
            de = self._in_range(e, de, st)
        else:
            de = np.where(st.mushy, -dt_m * (R + y), dT * capacity)
            de[~f.free] = 0.0
        e = e + de
        if self.distributed:
            e = f.consistent(e)                   # a shared vertex: the same bits on every rank
        return e

    def _keep(self, e: np.ndarray, e_old: np.ndarray, st: NodalState, dt: float, it: int) -> None:
        """Keep the state at the end of a step: the enthalpy, its nodal state, the predictor's rate."""
        self._last_change = (e - e_old) / dt
        self.e = e
        self._state = (e.copy(), st)
        self.f.store(e, st)                          # st is the nodal state of the final e
        self.iterations.append(max(it, 1))

    def _finish_distributed(self, e, e_old, st, st_old, R, F, dt, it, res, counts) -> StefanStepInfo:
        """The end of :meth:`step` on a distributed mesh: the state kept, the heats and counts summed over the
        global vertices (each once), the same on every rank."""
        f = self.f
        self._keep(e, e_old, st, dt, it)
        changes = (_branch(st) != _branch(st_old)).astype(float)
        return StefanStepInfo(iterations=max(it, 1), residual=res,
                              boundary_heat=dt * f.nodal_sum(np.where(f.free, 0.0, R)),
                              source_heat=dt * f.nodal_sum(F), phase_changes=int(round(f.nodal_sum(changes))),
                              factorizations=self.jac.factorizations - counts[0],
                              front_nodes=int(round(f.nodal_sum((st.mushy | st_old.mushy).astype(float)))))

    def _kirchhoff_update(self, st: NodalState, dT: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """The temperature change of each node for the Newton step ``dT`` taken in the node's Kirchhoff variable.

        Per node the m-weighted Kirchhoff map of its materials on its current branch (extended past the branch's
        end) is exactly quadratic: theta(T + d) - theta(T) = a d + c d^2/2 with a = sum_g w_g k_g(T) and
        c = sum_g w_g k_g b_g. The Newton step asks for the change a dT of it (the linearization); this returns
        the d that gives it, d = 2 a dT / (a + sqrt(a^2 + 2 c a dT)) (= dT when c = 0; where the quadratic cannot
        reach a dT the turning point, cut by :meth:`_in_range`). Taking the step in T instead (d = dT) converged
        like the bisection far from the solution: with steps much longer than the diffusion time the step equation
        is nearly K theta = F, linear in theta, and a node overshooting to 1e8 K came back by halves."""
        f = self.f
        b, _ = f.group_law
        G = len(f.groups)
        w = f.weights
        a = np.sum(w * dtheta[:, :G], axis=1)
        k_ref = f.group_conductivity[:G, st.segment].T
        c = np.sum(w * k_ref * b[None, :G], axis=1)
        target = a * dT
        disc = a * a + 2.0 * c * target
        with np.errstate(invalid="ignore", divide="ignore"):
            d = np.where(disc > 0, 2.0 * target / (a + np.sqrt(np.maximum(disc, 0.0))),
                         np.where(c != 0, -a / np.where(c != 0, c, 1.0), dT))
        return np.where(a > 0, d, dT)

    RANGE_FLOOR = 1e-6
    """A step that does not converge with a node's factor 1 + b (T - T_ref) below this was held at the edge of
    the range by :meth:`_in_range` (each iteration keeps RANGE_FRACTION of the factor): its solution needs k <= 0,
    reported as such (ConductivityRangeError naming the key) instead of a non-converging Newton."""

    RANGE_FRACTION = 0.1
    """A Newton update keeps every free node's conductivity factor 1 + b (T - T_ref) at least this fraction of
    its value before the update (:meth:`_in_range`)."""

    def _in_range(self, e: np.ndarray, de: np.ndarray, st: NodalState) -> np.ndarray:
        """``de`` with each free node's increment cut so that its factor f = 1 + b (T - T_ref) (for every
        temperature-dependent material touching it) stays >= RANGE_FRACTION times its value at e (``st``: the
        nodal state of e): a bound on T per node, turned into one on e by the (monotone) nodal enthalpy graph.

        The Kirchhoff map of such a material is quadratic and turns back where f = 0 (T = T_ref - 1/b): beyond,
        a second, unphysical root of the step equation exists (k < 0), and undamped Newton steps from far away
        (steps much longer than the diffusion time of the mesh) went there. A global damping factor did not do:
        a mushy node whose increment overshoots by orders of magnitude (normal in the semi-smooth iteration)
        then stalled every other node, and the iteration cycled. The true solution lies inside the range (T stays
        between the data's extremes without sources), so near it nothing is cut and the convergence is Newton's."""
        f = self.f
        b, tref = f.group_law
        lo = np.full(f.n, -np.inf)
        hi = np.full(f.n, np.inf)
        for g, m in enumerate(f.groups):
            if b[g] == 0.0:
                continue
            on = (f.weights[:, g] > 0) & f.free
            f0 = m.conductivity_factor(st.T[on])
            lim = tref[g] + (self.RANGE_FRACTION * f0 - 1.0) / b[g]
            if b[g] > 0:
                lo[on] = np.maximum(lo[on], lim)
            else:
                hi[on] = np.minimum(hi[on], lim)
        e_new = e + de
        out = de
        for bound, frac, side in ((lo, 0.0, 1.0), (hi, 1.0, -1.0)):
            where = np.isfinite(bound)
            if not np.any(where):
                continue
            e_b = f.enthalpy_of(np.where(where, bound, st.T), frac)
            cut = where & (side * (e_new - e_b) < 0)
            if np.any(cut):
                out = out.copy() if out is de else out
                out[cut] = e_b[cut] - e[cut]
        return out

    def _diagnosis(self, where, history, switching, st: NodalState, scale, cycle=None) -> str:
        """The message of a step that did not converge (collective on a distributed mesh: the switching nodes of
        all ranks, the vertices each rank owns)."""
        f = self.f
        pts = np.array([v.point for v in f.mesh.vertices])
        if self.distributed:
            switching = switching[f.owned[switching]]
            local = [(tuple(round(float(c), 4) for c in pts[i]), float(st.T[i])) for i in switching[:5]]
            count = int(round(f.nodal_sum(np.isin(np.arange(f.n), switching).astype(float))))
            nodes = [item for part in parallel.allgather(f.mesh, local) for item in part][:5]
            at = "; ".join(f"node at {p} T = {T:.4g}" for p, T in nodes)
            switching = np.zeros(count)
        else:
            at = "; ".join(f"node {i} at {tuple(round(float(c), 4) for c in pts[i])} T = {st.T[i]:.4g}"
                           for i in switching[:5])
        hist = ", ".join(f"{h:.3e}" for h in history[-6:])
        how = (f"did not converge in {self.maxit} iterations" if cycle is None else
               f"cycles (iterate {cycle[1]} has the solid/mushy/liquid pattern of iterate {cycle[0]}, so the "
               "iterates repeat)")
        return (f"Stefan Newton step at {where} {how}: nodal enthalpy "
                f"defect (J/m^3) history ... {hist}, tolerance {self.tol * scale:.3e}; "
                f"{len(switching)} node(s) still switch between solid, mushy and liquid"
                + (f" ({at})" if at else "") + ". Each Newton iteration moves the phase boundary by about one "
                "element layer, so a step in which it crosses many layers needs as many iterations: reduce the time "
                "step to about h / (front speed), or check that the mesh has no obtuse angles (the stiffness matrix "
                "should be an M-matrix).")
