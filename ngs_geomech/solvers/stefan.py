"""Time steps of the Stefan problem in enthalpy form (:mod:`ngs_geomech.physics.stefan`), seed (2.55):
a semi-smooth Newton method on the nodal enthalpy, and the smeared apparent-heat-capacity method for
comparison.

Semi-smooth Newton (:class:`StefanSolver`). One backward Euler step solves, for the free nodal enthalpies e,

    R(e) = m (e - e_old)/dt + A(beta(e)) - F = 0,

with beta the nodal inverse enthalpy graph (piecewise linear and Lipschitz) and A(T) = sum_g K_g theta_g(T)
(piecewise linear too). The generalized derivative of beta is 1/C_s, 0 (mushy), 1/C_l node by node (the flat
parts are closed: a node at a kink counts as mushy, see :meth:`StefanForms.nodal_state`), and that of theta_g
is k_s or k_l of the node's interval. With D = dT/de, a Newton step J de = -R, J = m/dt + A'(T) D, is computed
on the temperatures of the non-mushy free nodes N (dT = 0 on the mushy ones M, de_N = dT_N / D_N):

    (m C/dt + A'(T))_NN dT_N = -R_N,        de_M = -(dt/m)(R + A'(T) dT)_M,

the first a symmetric positive definite system when no PCM has k_s != k_l (sparse Cholesky), else a general
one (UMFPACK). R is piecewise linear in e: once every node is on its final branch (solid, mushy or liquid) the
next Newton step is exact, so Newton ends after a small number of iterations, about one more than the number of
element layers the phase boundary crosses in the step (each iteration moves it by about one layer). With dt
refined with h that number stays O(1): this is why the unknown is the enthalpy (single valued, Lipschitz
inverse graph, exact per-node semismoothness) rather than the temperature with the multivalued graph.

Two cheap aids, both exact: the first iterate is the old state plus dt times the last step's rate of change
(a predictor: fewer nodes change branch during the iteration), and the last factorization is reused when the
branches of all nodes and dt are unchanged. No damping or line search: none was needed in the measurements.

Measured (Neumann strips of :mod:`ngs_geomech.verification.stefan`, P1, h = 0.05 .. 0.0125 m, dt = 0.2 h s/m):
mean 1.1-1.9 and max 2-5 iterations per step, 1.5-1.8 factorizations per step at the finest level; with dt = 4 h
(the front crosses several layers per step) mean 8, max 13; a step asking the front to cross dozens of layers
does not converge in 25 iterations and raises SolverError. The stopping test is on the nodal residual: the
enthalpy defect max_i |R_i| dt/m_i (J/m^3) of the free nodes below ``tol`` times the enthalpy scale of the
step (the largest latent heat or C times the temperature range, whichever is larger); when it passes the defect
is at rounding level, since the last step was exact. A step that does not converge raises SolverError with the
residual history and the nodes that still switch branch (never NaN).

Smeared variant (:class:`ApparentHeatCapacitySolver`): the apparent heat capacity method with the capacity
lagged, m C_app(T_old)(T - T_old)/dt + A(T) = F with C_app = C + L/(2 delta) for |T - Theta_R| < delta, solved by
Newton's method for the Kirchhoff kink of A (one linear solve when k_s = k_l). The fully implicit form
C_app(T)(T - T_old) was tried first: its residual jumps at Theta_R +- delta and Newton cycled between two
iterates from the first steps of the Neumann problems (delta = h, 4 h and 0.05 K), so it is not offered. The
lagged form is not conservative (C_app(T_old)(T - T_old) is not the change of the smeared enthalpy e_delta) and
misses latent heat when a node jumps over the band in one step; :mod:`ngs_geomech.verification.stefan`
measures both methods on the same problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..physics.stefan import NodalState, PhaseChangeMaterial, StefanForms
from .linear import inverse


@dataclass
class StefanStepInfo:
    """What one step did: ``iterations`` (linear solves), the final ``residual`` (max nodal enthalpy defect,
    J/m^3), ``boundary_heat`` (heat that entered through the Dirichlet nodes during the step, J per metre of
    depth in 2D, J in 3D), ``source_heat`` (sources and fluxes, same units) and ``phase_changes`` (nodes whose
    branch, solid/mushy/liquid, changed in the step)."""

    iterations: int
    residual: float
    boundary_heat: float
    source_heat: float
    phase_changes: int


class _Jacobian:
    """(m C/dt + A'(T)) on the common stiffness pattern, factored on a set of free nodes."""

    def __init__(self, forms: StefanForms):
        self.f = forms
        self.values = forms.jacobian.AsVector().FV().NumPy()
        self.rhs = forms.jacobian.CreateColVector()
        self.factorizations = 0
        self._key = None
        self._inv = None

    def conduction_values(self, dtheta: np.ndarray) -> np.ndarray:
        """Values of A'(T) = sum_g K_g diag(dtheta_g) in CSR order."""
        f = self.f
        vals = np.zeros(len(f.pattern_cols))
        for g, K in enumerate(f.stiffness):
            vals += K.data * dtheta[f.pattern_cols, g]
        return vals

    def solve(self, key: tuple, vals, diag, active: np.ndarray, rhs: np.ndarray, where: str):
        """Solve with the matrix of ``vals`` (CSR order) + ``diag`` on the ``active`` nodes. ``key`` (arrays
        and numbers that determine the matrix: the nodal branches and dt) lets the last factorization be
        reused when nothing changed; ``vals`` and ``diag`` may be callables, evaluated only when needed."""
        f = self.f
        if self._key is None or not _same_key(self._key, key):
            self.values[:] = vals() if callable(vals) else vals
            self.values[f.diagonal_positions] += diag() if callable(diag) else diag
            self._inv = inverse(f.jacobian, ngs.BitArray(active.tolist()), f.symmetric,
                                what=f"Stefan Newton step at {where}",
                                hint="a region without Dirichlet data is entirely mushy; reduce the time step.")
            self._key = key
            self.factorizations += 1
        inv = self._inv
        self.rhs.FV().NumPy()[:] = rhs
        out = (inv * self.rhs).Evaluate().FV().NumPy().copy()
        out[~active] = 0.0
        return out


def _same_key(a: tuple, b: tuple) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def _conduction_derivative_apply(forms: StefanForms, dtheta: np.ndarray, dT: np.ndarray) -> np.ndarray:
    return sum(K @ (dtheta[:, g] * dT) for g, K in enumerate(forms.stiffness))


class StefanSolver:
    """Backward Euler steps of the enthalpy formulation by the semi-smooth Newton method (module docstring).

    ``e`` holds the nodal enthalpy (J/m^3); set it with :meth:`set_initial`. ``tol`` is relative to the
    enthalpy scale, ``maxit`` the largest number of Newton iterations per step.
    """

    def __init__(self, forms: StefanForms, tol: float = 1e-10, maxit: int = 25, predictor: bool = True):
        self.f = forms
        self.tol = tol
        self.maxit = maxit
        self.predictor = predictor
        self.e = np.zeros(forms.n)
        self._last_change = None          # (e_new - e_old)/dt of the last step
        self.jac = _Jacobian(forms)
        self.iterations: list[int] = []

    @property
    def factorizations(self) -> int:
        return self.jac.factorizations

    def set_initial(self, temperature, liquid_fraction=None) -> None:
        """Initial state from nodal temperatures (array, K) or a CoefficientFunction interpolated at the nodes;
        ``liquid_fraction`` (array or CF, 0..1) decides nodes exactly at a phase-change temperature
        (default solid)."""
        T = self._nodal(temperature)
        f = None if liquid_fraction is None else self._nodal(liquid_fraction)
        self.e = self.f.enthalpy_of(T, f)
        self._last_change = None
        self.f.store(self.e)

    def set_initial_enthalpy(self, e) -> None:
        """Initial state from nodal enthalpies (array, J/m^3), e.g. :meth:`StefanForms.project_enthalpy`."""
        self.e = self._nodal(e)
        self._last_change = None
        self.f.store(self.e)

    def _nodal(self, value) -> np.ndarray:
        if isinstance(value, ngs.CoefficientFunction):
            pts = np.array([v.point for v in self.f.mesh.vertices])
            mp = self.f.mesh(*pts.T) if pts.shape[1] == 3 else self.f.mesh(pts[:, 0], pts[:, 1])
            return np.asarray(value(mp), dtype=float).ravel()
        arr = np.asarray(value, dtype=float)
        if arr.shape != (self.f.n,):
            raise ValueError(f"nodal values must have shape ({self.f.n},), got {arr.shape}")
        return arr

    def temperature(self) -> np.ndarray:
        """Nodal temperatures of the current state, K."""
        return self.f.nodal_state(self.e).T

    def _scale(self, T: np.ndarray) -> float:
        f = self.f
        lat = max([f.groups[g].latent_heat for g in f.pcm_groups] + [0.0])
        span = float(np.max(T) - np.min(T)) if T.size else 0.0
        return max(lat, float(np.max(f.capacity)) * span, 1e-300)

    def step(self, t_old: float, t_new: float) -> StefanStepInfo:
        """One backward Euler step from t_old to t_new (s): Dirichlet data, sources and fluxes at t_new."""
        f = self.f
        dt = float(t_new) - float(t_old)
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"Stefan step: dt must be positive and finite, got {dt} (t_old {t_old}, t_new {t_new})")
        where = f"t = {t_new:g} s"
        e_old = self.e.copy()
        st_old = f.nodal_state(e_old)
        e = e_old.copy()
        if self.predictor and self._last_change is not None:
            e[f.free] += dt * self._last_change[f.free]
        if len(f.dirichlet_dofs):
            T_D = f.dirichlet_temperatures(t_new)
            d = f.dirichlet_dofs
            T = st_old.T.copy()
            T[d] = T_D
            e_new = f.enthalpy_of(T)
            changed = T_D != st_old.T[d]
            e[d[changed]] = e_new[d[changed]]
        F = f.loads(t_new)
        free = f.free
        m = f.mass
        scale = self._scale(np.concatenate([st_old.T, f.nodal_state(e).T]))
        history = []
        last_switch = np.zeros(0, dtype=int)
        prev_branch = None
        it = 0
        while True:
            st = f.nodal_state(e)
            R = m * (e - e_old) / dt + f.conduction(st.T) - F
            defect = np.abs(R[free]) * dt / m[free]
            res = float(np.max(defect)) if defect.size else 0.0
            if not math.isfinite(res):
                raise SolverError(f"Stefan Newton step at {where}: the residual is not finite "
                                  f"(history {history}). Check the material data and the time step.")
            history.append(res)
            branch = np.where(st.mushy, -1 - st.segment, st.segment)
            if prev_branch is not None:
                last_switch = np.nonzero(branch != prev_branch)[0]
            prev_branch = branch
            if res <= self.tol * scale:
                break
            if it >= self.maxit:
                raise SolverError(self._diagnosis(where, history, last_switch, st, scale))
            dtheta = f.kirchhoff_derivatives(st)
            active = free & ~st.mushy
            capacity = f.capacity[np.arange(f.n), st.segment]      # 1/D on the non-mushy nodes
            dT = self.jac.solve((active, st.segment, dt), lambda: self.jac.conduction_values(dtheta),
                                lambda: np.where(active, m * capacity / dt, 1.0), active,
                                -np.where(active, R, 0.0), where)
            y = _conduction_derivative_apply(f, dtheta, dT)
            de = np.zeros(f.n)
            de[active] = dT[active] / st.dT_de[active]
            mushy_free = free & st.mushy
            de[mushy_free] = -(dt / m[mushy_free]) * (R[mushy_free] + y[mushy_free])
            e = e + de
            it += 1
        boundary_heat = float(dt * np.sum(R[~free]))
        self._last_change = (e - e_old) / dt
        self.e = e
        f.store(e)
        old_branch = np.where(st_old.mushy, -1 - st_old.segment, st_old.segment)
        self.iterations.append(max(it, 1))
        return StefanStepInfo(iterations=max(it, 1), residual=res, boundary_heat=boundary_heat,
                              source_heat=float(dt * np.sum(F)),
                              phase_changes=int(np.count_nonzero(branch != old_branch)))

    def _diagnosis(self, where, history, switching, st: NodalState, scale) -> str:
        f = self.f
        pts = np.array([v.point for v in f.mesh.vertices])
        at = "; ".join(f"node {i} at {tuple(round(float(c), 4) for c in pts[i])} T = {st.T[i]:.4g}"
                       for i in switching[:5])
        hist = ", ".join(f"{h:.3e}" for h in history[-6:])
        return (f"Stefan Newton step at {where} did not converge in {self.maxit} iterations: nodal enthalpy "
                f"defect (J/m^3) history ... {hist}, tolerance {self.tol * scale:.3e}; "
                f"{len(switching)} node(s) still switch between solid, mushy and liquid"
                + (f" ({at})" if at else "") + ". Each Newton iteration moves the phase boundary by about one "
                "element layer, so a step in which it crosses many layers needs as many iterations: reduce the time "
                "step to about h / (front speed), or check that the mesh has no obtuse angles (the stiffness matrix "
                "should be an M-matrix).")


class ApparentHeatCapacitySolver:
    """Backward Euler steps of the smeared apparent-heat-capacity method, capacity lagged (module docstring).

    ``delta`` (K) is the half width of the smeared band; the state is the nodal temperature ``T`` (K).
    """

    def __init__(self, forms: StefanForms, delta: float, tol: float = 1e-10, maxit: int = 25):
        if not (delta > 0 and math.isfinite(delta)):
            raise ValueError(f"delta (half width of the smeared band) must be > 0 K, got {delta}")
        if not any(isinstance(m, PhaseChangeMaterial) for m in forms.groups):
            raise ValueError("the apparent heat capacity method needs a PhaseChangeMaterial")
        self.f = forms
        self.delta = float(delta)
        self.tol = tol
        self.maxit = maxit
        self.T = np.zeros(forms.n)
        self.jac = _Jacobian(forms)
        self.iterations: list[int] = []

    @property
    def factorizations(self) -> int:
        return self.jac.factorizations

    def set_initial(self, temperature: np.ndarray) -> None:
        self.T = np.asarray(temperature, dtype=float).copy()

    def enthalpy(self) -> np.ndarray:
        """Nodal smeared enthalpy e_delta(T), J/m^3."""
        return self.f.smeared_enthalpy(self.T, self.delta)

    def step(self, t_old: float, t_new: float) -> StefanStepInfo:
        f = self.f
        dt = float(t_new) - float(t_old)
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"apparent heat capacity step: dt must be positive and finite, got {dt}")
        where = f"t = {t_new:g} s"
        T_old = self.T.copy()
        T = T_old.copy()
        if len(f.dirichlet_dofs):
            T[f.dirichlet_dofs] = f.dirichlet_temperatures(t_new)
        F = f.loads(t_new)
        free, m = f.free, f.mass
        lat = max([f.groups[g].latent_heat for g in f.pcm_groups] + [0.0])
        scale = max(lat, float(np.max(f.capacity)) * float(np.ptp(np.concatenate([T_old, T]))), 1e-300)
        history = []
        it = 0
        K = len(f.breakpoints)
        c = f.apparent_capacity(T_old, self.delta)
        while True:
            R = m * c * (T - T_old) / dt + f.conduction(T) - F
            res = float(np.max(np.abs(R[free]) * dt / m[free])) if free.any() else 0.0
            history.append(res)
            if not math.isfinite(res):
                raise SolverError(f"apparent heat capacity step at {where}: non-finite residual")
            if res <= self.tol * scale:
                break
            if it >= self.maxit:
                hist = ", ".join(f"{h:.3e}" for h in history[-6:])
                raise SolverError(f"apparent heat capacity Newton at {where} did not converge in {self.maxit} "
                                  f"iterations (defect history ... {hist} J/m^3); reduce the time step.")
            seg = np.minimum(np.count_nonzero(T[:, None] > f.breakpoints[None, :], axis=1), K)
            dtheta = f.group_conductivity[:, seg].T
            dT = self.jac.solve((seg, c, dt), lambda: self.jac.conduction_values(dtheta), m * c / dt, free,
                                -np.where(free, R, 0.0), where)
            T = T + dT
            it += 1
        self.T = T
        self.iterations.append(max(it, 1))
        return StefanStepInfo(iterations=max(it, 1), residual=res, boundary_heat=float(dt * np.sum(R[~free])),
                              source_heat=float(dt * np.sum(F)), phase_changes=0)
