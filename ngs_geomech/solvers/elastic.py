"""Solving the elastic problem: linear (factored once), the secant modules method (2.32)-(2.34) and Newton
on the strain energy with a backtracking line search."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..physics.coefficients import regions_regex
from ..physics.elasticity import ElasticForms
from .linear import check_finite


@dataclass
class NonlinearInfo:
    """Iteration history of one nonlinear solve: relative H1 changes ||u_{n+1} - u_n||_1 / ||u_{n+1}||_1
    (the quantity of (2.35)), residual norms, wall time."""

    method: str
    iterations: int = 0
    changes: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    wall_s: float = 0.0


class ElasticSolver:
    """Drives :class:`ElasticForms`: Dirichlet data, linear solves, secant and Newton iterations."""

    def __init__(self, forms: ElasticForms, *, method: str = "newton", tol: float = 1e-8, maxit: int = 100):
        if method not in ("newton", "secant"):
            raise ValueError(f"unknown nonlinear solver {method!r}")
        self.f = forms
        self.method = method
        self.tol = tol
        self.maxit = maxit
        self._tmp = ngs.GridFunction(forms.V)
        self._fixed = ngs.Projector(forms.V.FreeDofs(), False)
        self._linear_inverse = None
        self.factorizations = 0
        self.history: list[NonlinearInfo] = []

    def set_dirichlet(self) -> None:
        cf = self.f.dirichlet_values()
        u = self.f.displacement()
        self._tmp.vec[:] = 0.0
        if cf is not None:
            # per component, only on the boundaries fixing that component: a joint Set over all of them
            # averaged at shared corners (e.g. u_x = d at x = L with a symmetry boundary u_y = 0 along y = 0
            # gave u_x = d/2 at the corner vertex, so a one-element-wide edge got half its displacement)
            for k, names in enumerate(self.f.fixed_names):
                if names:
                    self._tmp.components[k].Set(cf[k], ngs.BND,
                                                definedon=self.f.mesh.Boundaries(regions_regex(set(names))))
        u.vec.data += self._fixed * (self._tmp.vec - u.vec)

    def _h1(self, u) -> float:
        return math.sqrt(ngs.Integrate(ngs.InnerProduct(u, u) + ngs.InnerProduct(ngs.grad(u), ngs.grad(u)),
                                       self.f.mesh))

    def _solve_secant_system(self, where: str, reuse: bool):
        """One linear solve with the coefficients frozen at u_frozen; returns nothing (updates gf)."""
        f = self.f
        if not (reuse and self._linear_inverse is not None):
            f.secant_form.Assemble()
            self._linear_inverse = f.secant_form.mat.Inverse(f.X.FreeDofs(), inverse="umfpack")
            self.factorizations += 1
        f.secant_rhs.Assemble()
        r = f.secant_rhs.vec.CreateVector()
        r.data = f.secant_rhs.vec - f.secant_form.mat * f.gf.vec
        f.gf.vec.data += self._linear_inverse * r
        check_finite(f.gf.vec, f"elastic solve at {where}", "Check the elastic data and the supports: a body "
                     "without enough displacement conditions has a rigid motion.")

    def solve(self, where: str) -> NonlinearInfo:
        """Solve at the current time (f.t set; temperature CF up to date)."""
        tic = time.perf_counter()
        self.set_dirichlet()
        f = self.f
        if not f.setup.nonlinear:
            f.u_frozen.vec[:] = 0.0
            self._solve_secant_system(where, reuse=True)
            info = NonlinearInfo("linear", 1, wall_s=time.perf_counter() - tic)
        elif self.method == "secant":
            info = self._secant(where)
        else:
            info = self._newton(where)
        info.wall_s = time.perf_counter() - tic
        self.history.append(info)
        return info

    def _secant(self, where: str) -> NonlinearInfo:
        """Secant modules method (2.32)-(2.34): each iteration a linear problem with c* frozen at u_n; it
        starts from the linear elastic solution (c* = c) and stops when the relative H1 change < tol."""
        f = self.f
        info = NonlinearInfo("secant")
        u = f.displacement()
        linear = _Linearized(f)
        with linear:
            self._solve_secant_system(where, reuse=False)
        prev = ngs.GridFunction(f.V)
        for it in range(1, self.maxit + 1):
            prev.vec.data = u.vec
            f.u_frozen.vec.data = u.vec
            self._solve_secant_system(where, reuse=False)
            norm = self._h1(u)
            diff = ngs.GridFunction(f.V)
            diff.vec.data = u.vec - prev.vec
            change = self._h1(diff) / max(norm, 1e-300)
            info.changes.append(change)
            info.iterations = it
            if change < self.tol:
                return info
            if not math.isfinite(change) or (it > 5 and change > 1e3 * info.changes[0]):
                break
        raise SolverError(f"secant modules method at {where} did not converge in {info.iterations} iterations "
                          f"(last relative H1 change {info.changes[-1]:.3e}). Try nonlinear_solver = 'newton', "
                          "a larger regularization, or max_iterations.")

    def _newton(self, where: str) -> NonlinearInfo:
        """Newton's method on the energy W (exact Hessian), from the linear elastic solution, with a
        backtracking line search on the residual norm; stops when the update is < tol relative to u."""
        f = self.f
        info = NonlinearInfo("newton")
        with _Linearized(f):
            self._solve_secant_system(where, reuse=False)
        x = f.gf.vec
        free = np.array(list(f.X.FreeDofs()), dtype=bool)
        res, du, trial = x.CreateVector(), x.CreateVector(), x.CreateVector()

        def residual(vec) -> float:
            f.newton_form.Apply(vec, res)
            arr = res.FV().NumPy()
            arr[~free] = 0.0
            return float(ngs.Norm(res))
        r = residual(x)
        r0 = max(r, 1e-300)
        for it in range(1, self.maxit + 1):
            f.newton_form.AssembleLinearization(x)
            inv = f.newton_form.mat.Inverse(f.X.FreeDofs(), inverse="umfpack")
            self.factorizations += 1
            du.data = inv * res
            step = 1.0
            while True:
                trial.data = x - step * du
                rn = residual(trial)
                if math.isfinite(rn) and (rn < (1 - 1e-4 * step) * r or rn < 1e-12 * r0):
                    break
                step /= 2
                if step < 1e-6:
                    break
            x.data = trial
            r = rn
            change = step * float(ngs.Norm(du)) / max(float(ngs.Norm(x)), 1e-300)
            info.changes.append(change)
            info.residuals.append(r / r0)
            info.iterations = it
            if not math.isfinite(r):
                break
            if change < self.tol or r / r0 < self.tol * 1e-3:
                residual(x)
                check_finite(x, f"elastic Newton at {where}")
                return info
            if step < 1e-6:
                break
            residual(x)
        raise SolverError(f"Newton for the lambda law at {where} did not converge in {info.iterations} iterations "
                          f"(relative residual {info.residuals[-1] if info.residuals else float('nan'):.3e}). "
                          "Check rheology_lambda (> 0.5 keeps the law monotone) and the regularization.")


class _Linearized:
    """Context: the secant form with c* = c (linear elasticity), to start an iteration."""

    def __init__(self, forms: ElasticForms):
        self.f = forms

    def __enter__(self):
        self.f.linear_switch.Set(1.0)
        return self

    def __exit__(self, *exc):
        self.f.linear_switch.Set(0.0)
        return False
