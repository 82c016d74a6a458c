"""The smeared apparent-heat-capacity method for the Stefan problem (:class:`ApparentHeatCapacitySolver`), for
comparison with the semi-smooth Newton method on the enthalpy (:mod:`ngs_geomech.stefan.solver`).

Backward Euler with the capacity lagged, m C_app(T_old)(T - T_old)/dt + A(T) = F with C_app = C + L/(2 delta) for
|T - Theta_R| < delta, solved by Newton's method for the Kirchhoff kink of A (one linear solve when k_s = k_l),
with the linear algebra of :class:`ngs_geomech.stefan.column_jacobian.ColumnJacobian` (its columns change where
C_app(T_old) or the Kirchhoff slope changes). The fully implicit form C_app(T)(T - T_old) was tried first: its
residual jumps at Theta_R +- delta and Newton cycled between two iterates from the first steps of the Neumann
problems (delta = h, 4 h and 0.05 K), so it is not offered. The lagged form is not conservative
(C_app(T_old)(T - T_old) is not the change of the smeared enthalpy e_delta) and misses latent heat when a node
jumps over the band in one step; :mod:`ngs_geomech.verification.stefan` measures both methods on the same problem.
Serial meshes only.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SolverError
from .column_jacobian import ColumnJacobian
from .forms import StefanForms
from .materials import PhaseChangeMaterial
from .solver import StefanStepInfo


class ApparentHeatCapacitySolver:
    """Backward Euler steps of the smeared apparent-heat-capacity method, capacity lagged (module docstring).

    ``delta`` (K) is the half width of the smeared band; the state is the nodal temperature ``T`` (K).
    """

    def __init__(self, forms: StefanForms, delta: float, tol: float = 1e-10, maxit: int = 25):
        if not (delta > 0 and math.isfinite(delta)):
            raise ValueError(f"delta (half width of the smeared band) must be > 0 K, got {delta}")
        if not any(isinstance(m, PhaseChangeMaterial) for m in forms.groups):
            raise ValueError("the apparent heat capacity method needs a PhaseChangeMaterial")
        if forms.distributed:
            raise ValueError("the apparent heat capacity method is not available on a distributed mesh (MPI): "
                             "use StefanSolver or run serially")
        self.f = forms
        self.delta = float(delta)
        self.tol = tol
        self.maxit = maxit
        self.T = np.zeros(forms.n)
        self.jac = ColumnJacobian(forms)
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
        F_src = f.loads(t_new)
        F_robin = f.robin_loads(t_new)              # heat transfer conditions: the ambient side, or None
        F = F_src if F_robin is None else F_src + F_robin
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
            dtheta = f.kirchhoff_slopes(T, seg)
            jf = self.jac.free
            dT = np.zeros(f.n)
            dT[jf] = self.jac.solve((m * c)[jf], dtheta[jf], dtheta[jf], -R[jf], dt, where)
            T = T + dT
            it += 1
        self.T = T
        self.iterations.append(max(it, 1))
        return StefanStepInfo(iterations=max(it, 1), residual=res, boundary_heat=float(dt * np.sum(R[~free])),
                              source_heat=float(dt * np.sum(F_src)), phase_changes=0,
                              robin_heat=0.0 if F_robin is None else dt * f.robin_heat_rate(F_robin, T))
