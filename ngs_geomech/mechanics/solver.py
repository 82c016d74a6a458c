"""Solving the elastic problem: linear (factored once), the secant modules method (2.32)-(2.34) and Newton
on the strain energy, both with a line search on the energy.

The lambda law is the minimisation of the energy of :mod:`ngs_geomech.mechanics.forms` (convex for
lam >= 1/2); every step goes along a direction d with the step length s that minimises the energy along
u + s d: :meth:`ElasticSolver._line_search` finds a zero of the directional derivative g(s) = <R(u + s d), d>
(R = the residual, the energy's gradient), which, unlike energy differences, keeps its accuracy down to
round-off. Measured (studies/secant_convergence: quarter plate with a hole stretched by 3 reference strains,
plane strain, P1, h = 0.1 ... 0.025, tolerance 1e-8 on the relative H1 change (2.35)):

* secant modules method: the plain iteration (relaxation 1) is a fixed point map whose linearisation
  I - K_secant^-1 K_tangent has eigenvalues in [0, 2 - 2 lam] (lam < 1) or [2 - 2 lam, 0] (lam > 1): it
  contracts at ~2|1 - lam| (0.50 measured at lam = 0.75, 24 iterations), stalls at lam = 1.5 and diverges
  for larger lam. With the energy line search along the same direction (the default) it converges for every
  lam at the rate of the optimal fixed relaxation 1/lam, |1 - lam|/lam: measured 0.33, 0.31, 0.48 at
  lam = 0.75, 1.5, 2 (15, 15, 22 iterations, independent of h); at lam = 1/2 the rate is ~0.985.
* Newton: the exact Hessian of the energy degenerates for lam -> 1/2 (its eigenvalue along the strain is
  delta/(A1/A_ref + delta) times the secant one: the law is rigid-perfectly plastic for delta -> 0, the
  deformation localizes), and Newton from the linear solution then needs 22, 27, 37, 67 steps (h = 0.1,
  0.05, 0.025, 0.0125) at delta = 1e-6, and ~50 (h = 0.05) or 101 (h = 0.025) at delta = 1e-10. For regions
  with lam < 1 the tangent is therefore built with an independent stress (a primal-dual Newton method in the
  manner of Chan, Golub and Mulet for total variation, :class:`_PrimalDual`), the exact Hessian at
  convergence (quadratic convergence): 12, 15, 20, 24 steps at delta = 1e-6, and 19 (h = 0.05) or 24
  (h = 0.025) at delta = 1e-10, with the dual stress updated along the line-searched step; updated along the
  full Newton direction (the current default): 12, 14, 16 steps (h = 0.1, 0.05, 0.025), same solution to
  1e-13. The target of 10 is not met at lam = 1/2: measured without gain (h = 0.1, 0.05) were the cap 0.8
  ... 0.999 (12, 15), a pointwise or uniform CGM step length of the dual (12, 16 / 16, 24), a start with the
  consistent or half the consistent stress (15, 16 / 12, 15), full or Armijo steps instead of the exact line
  search (15, 18 / 13-15, 15-20), a continuation in delta from 1e-1 or 1e-2 in one solve (12, 14-15 linear
  solves) and in lam from 0.75 or 0.6 (14-19, 17-21). The early line-searched steps shrink like h (0.44,
  0.18, 0.08): the energy's kinks where the strain crosses the rigid range. For lam = 0.75 ... 2 Newton
  takes 4 - 7 steps. What does meet it: nested iteration (``start='current'`` with the solution of the mesh twice as
  coarse, :mod:`ngs_geomech.mechanics.nested`, scene key ``mechanics.nested_levels``): 9, 10, 9 steps at h = 0.1,
  0.05, 0.025 (each coarse solve from h = 0.2 at most 10), the same solution to 6e-15.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..fem.coefficients import regions_regex
from ..linalg.direct import check_finite, inverse, solve_watched
from ..linalg.iterative import DEFAULT_TOL, PCG, Preconditioned, choose_solver
from .choices import NONLINEAR_SOLVERS
from .forms import ElasticForms

_SINGULAR_HINT = ("a body without enough displacement or symmetry conditions has a rigid motion; with "
                  "rheology_lambda <= 0.5 the load may exceed what the law can carry (the stress of the lambda "
                  "law is bounded for lam <= 1/2).")


def h1_norm(u, mesh) -> float:
    """||u||_1 = (int u.u + grad u : grad u dx)^(1/2), the norm of the convergence quantity (2.35)."""
    return math.sqrt(ngs.Integrate(ngs.InnerProduct(u, u) + ngs.InnerProduct(ngs.grad(u), ngs.grad(u)), mesh))


@dataclass
class NonlinearInfo:
    """Iteration history of one nonlinear solve: relative H1 changes ||u_{n+1} - u_n||_1 / ||u_{n+1}||_1
    (the quantity of (2.35)), relative residual norms (Newton), the step lengths of the line search, the
    number of residual evaluations the line searches took, wall time."""

    method: str
    iterations: int = 0
    changes: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    wall_s: float = 0.0
    steps: list = field(default_factory=list)
    line_search_evaluations: int = 0


class ElasticSolver:
    """Drives :class:`ElasticForms`: Dirichlet data, linear solves, secant and Newton iterations."""

    def __init__(self, forms: ElasticForms, *, method: str = "newton", tol: float = 1e-8, maxit: int = 100,
                 relaxation: float | None = None, primal_dual: bool | None = None, solver: str = "auto",
                 linear_tol: float = DEFAULT_TOL, linear_maxit: int = 2000, start: str = "linear",
                 preconditioner: str = "auto"):
        """``relaxation``: None (default) takes the energy-minimising step along the secant direction
        u~_{n+1} - u_n, a number w the fixed step u_{n+1} = u_n + w (u~_{n+1} - u_n) (w = 1: the plain
        secant modules method (2.32)). ``primal_dual``: the Newton tangent with an independent stress for the
        regions with lam < 1 (None: when there are such regions; False: the exact Hessian everywhere).

        ``solver``: the linear solves, "direct" (UMFPACK), "iterative" (preconditioned CG to the relative residual
        ``linear_tol``, at most ``linear_maxit`` iterations; :mod:`~ngs_geomech.linalg.iterative`) or "auto"
        (iterative above ``iterative.AUTO_DOFS`` dofs). Iterative only for the pure displacement formulation
        (X = V: no oblique symmetry multipliers, no mixed pressures) and for the secant systems and the exact Newton
        Hessian; the primal-dual Newton tangent (unsymmetric) stays direct. Contact
        (:mod:`~ngs_geomech.mechanics.contact`) keeps its direct saddle-point solver. ``preconditioner``: of
        CG, one of :data:`~ngs_geomech.linalg.choices.PRECONDITIONERS`."""
        if method not in NONLINEAR_SOLVERS:
            raise ValueError(f"unknown nonlinear solver {method!r}")
        if start not in ("linear", "current"):
            raise ValueError(f"start must be 'linear' or 'current', got {start!r}")
        self.start = start
        """Newton's start: 'linear' (the linear elastic solution) or 'current' (the displacement in the forms, its
        Dirichlet values set: e.g. a coarser mesh's solution carried over, nested iteration)."""
        self.preconditioner = preconditioner
        if relaxation is not None and not relaxation > 0:
            raise ValueError(f"relaxation must be positive, got {relaxation}")
        self.f = forms
        self.method = method
        self.tol = tol
        self.maxit = maxit
        self.relaxation = relaxation
        softening = any(p.lam < 1.0 for p in forms.setup.props.values())
        self.primal_dual = softening if primal_dual is None else bool(primal_dual and softening)
        self._pd = None
        self._free = np.array(list(forms.X.FreeDofs()), dtype=bool)
        self._tmp = ngs.GridFunction(forms.V)
        self._fixed = ngs.Projector(forms.V.FreeDofs(), False)
        self._linear_inverse = None
        self.factorizations = 0
        self.solver = choose_solver(solver, forms.X.ndof, forms.mesh.dim, spd=forms.X is forms.V,
                                    distributed=forms.mesh.comm.size > 1)
        if forms.mesh.comm.size > 1 and (forms.X is not forms.V or (self.primal_dual and method == "newton")):
            raise ValueError("on a distributed mesh the elastic solver takes the displacement formulation and, "
                             "with softening regions (lam < 1), the secant method (the mixed formulation and the "
                             "primal-dual Newton tangent are solved directly)")
        self._pcg = PCG(linear_tol, linear_maxit) if self.solver == "iterative" else None
        self._pre: dict[str, Preconditioned] = {}
        self._secant_ready = False
        self.cg_iterations: list[int] = []
        """CG iterations of every iterative linear solve, in order."""
        self._free_mask = None
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

    def _preconditioner(self, name: str, form) -> Preconditioned:
        """The preconditioner registered on ``form`` (created once, before its next assembly)."""
        pre = self._pre.get(name)
        if pre is None:
            f = self.f
            # displacement decomposition (P1, and the P1 part of the 3D P2 two-level preconditioner): a per-region
            # modulus (the largest diagonal of D; of varying data the representative one) times the secant factor
            # of the lambda law at u_frozen (so the auxiliary forms, re-assembled after every assembly, follow the
            # softening or hardening: with the modulus alone the CG counts of a lam = 1.5 secant run rose from 110
            # to 195), and each component's Dirichlet boundaries
            e = f.strain_vector(f.u_frozen)
            scale = f.mesh.MaterialCF(
                {r: float(np.max(np.diag(np.asarray(f.D_ref[r]))))
                 * (f.linear_switch + (1 - f.linear_switch) * f.factor(r, e)) for r in f.D}, default=1.0)
            pre = self._pre[name] = Preconditioned(form, f.V, f.setup.order, vector=True, scale=scale,
                                                   weight=f.weight,
                                                   dirichlet=[regions_regex(set(n)) for n in f.fixed_names],
                                                   choice=self.preconditioner)
        return pre

    def _assemble(self, form, where: str, linearize_at=None) -> None:
        try:
            if linearize_at is None:
                form.Assemble()
            else:
                form.AssembleLinearization(linearize_at)
        except Exception as exc:  # NgException from the preconditioner's set-up (singular coarse problem)
            raise SolverError(f"elastic solve at {where}: the preconditioner could not be built ({exc}). "
                              f"{_SINGULAR_HINT}") from None

    def _cg(self, mat, pre: Preconditioned, rhs, x, what: str) -> int:
        info = pre.cg(self._pcg, mat, rhs, x, what, "Check the elastic data and the supports (" + _SINGULAR_HINT
                      + "), or use the direct solver.")
        check_finite(x, what)
        self.cg_iterations.append(info.iterations)
        return info.iterations

    def _solve_secant_system(self, where: str, reuse: bool):
        """One linear solve with the coefficients frozen at u_frozen; returns nothing (updates gf)."""
        f = self.f
        if self.solver == "iterative":
            pre = self._preconditioner("secant", f.secant_form)
            if not (reuse and self._secant_ready):
                self._assemble(f.secant_form, where)
                pre.update()
                self._secant_ready = True
                self.factorizations += 1
            f.secant_rhs.Assemble()
            self._cg(f.secant_form.mat, pre, f.secant_rhs.vec, f.gf.vec, f"elastic solve at {where}")
            return
        if not (reuse and self._linear_inverse is not None):
            f.secant_form.Assemble()
            self._linear_inverse = inverse(f.secant_form.mat, f.X.FreeDofs(), False, f"elastic solve at {where}",
                                           _SINGULAR_HINT)
            self.factorizations += 1
        f.secant_rhs.Assemble()
        if self._free_mask is None:
            self._free_mask = np.array(list(f.X.FreeDofs()), dtype=bool)
        solve_watched(f.secant_form.mat, self._linear_inverse, f.secant_rhs.vec, f.gf.vec, self._free_mask,
                      f"elastic solve at {where}", "Check the elastic data and the supports: a body without enough "
                      "displacement conditions has a rigid motion; a Poisson ratio near 1/2 or stiffness contrasts "
                      "beyond 1e10 make the system ill-conditioned.")

    def solve(self, where: str) -> NonlinearInfo:
        """Solve at the current time (f.t set; temperature CF up to date)."""
        tic = time.perf_counter()
        self.set_dirichlet()
        f = self.f
        if not f.setup.nonlinear:
            f.u_frozen.vec[:] = 0.0
            # E(T): the matrix follows the temperature, assembled and factored at every solve
            self._solve_secant_system(where, reuse=not f.stiffness_uses_temperature)
            info = NonlinearInfo("linear", 1, wall_s=time.perf_counter() - tic)
        elif self.method == "secant":
            info = self._secant(where)
        else:
            info = self._newton(where)
        info.wall_s = time.perf_counter() - tic
        self.history.append(info)
        return info

    # -- nonlinear iterations ----------------------------------------------------------------------------------
    def _residual(self, vec, out) -> None:
        """Set out = R(vec), the gradient of the energy (newton_form), zero on the fixed dofs."""
        self.f.newton_form.Apply(vec, out)
        out.FV().NumPy()[~self._free] = 0.0

    def _line_search(self, x, d, g0: float, info: NonlinearInfo, res, trial) -> float:
        """Step s > 0 with |g(s)| <= 0.1 |g(0)|, g(s) = <R(x + s d), d> (g0 = g(0) < 0): the minimum of the
        (convex) energy along d. s = 1 when it qualifies; else a bracket by doubling from 1 up to 16 and
        Brent's method on g (which, unlike regula falsi, copes with the extreme convexity of the lambda law
        far from the solution, e.g. an energy ~ eps^4 two decades above its minimum)."""
        class _Found(Exception):
            pass

        target = 0.1 * abs(g0)
        known = {0.0: g0}

        def g(s: float) -> float:
            if s in known:
                return known[s]
            trial.data = x + s * d
            self._residual(trial, res)
            info.line_search_evaluations += 1
            val = float(ngs.InnerProduct(res, d))
            if not math.isfinite(val):
                val = math.inf
            elif abs(val) <= target:
                raise _Found(s)
            known[s] = val
            return val

        try:
            a, b, gb = 0.0, 1.0, g(1.0)
            while gb < 0:
                if b >= 16.0:
                    return b
                a, b, gb = b, 2 * b, g(2 * b)
            hi = b
            while math.isinf(gb):                    # overflow at b: bisect towards a finite g > 0
                if hi - a <= 1e-12 * hi:
                    return a if a > 0 else hi
                m = 0.5 * (a + hi)
                gm = g(m)
                if math.isinf(gm):
                    hi = m
                elif gm < 0:
                    a = m
                else:
                    b, gb = m, gm
            # scipy.optimize costs 0.1-0.2 s of start-up: loaded when used
            from scipy.optimize import brentq

            s_opt = brentq(g, a, b, xtol=1e-14 * b, rtol=1e-10, maxiter=200)
        except _Found as found:
            return float(found.args[0])
        except (RuntimeError, ValueError):
            return 0.5 * (a + b)
        return float(s_opt)

    def _relative_change(self, step_vec, dgf) -> float:
        """||s d||_1 / ||u||_1 of the displacement parts (the quantity of (2.35))."""
        f = self.f
        dgf.vec.data = step_vec
        du = f.displacement(dgf)
        return h1_norm(du, f.mesh) / max(h1_norm(f.displacement(), f.mesh), 1e-300)

    def _secant(self, where: str) -> NonlinearInfo:
        """Secant modules method (2.32)-(2.34): each iteration a linear problem with c* frozen at u_n, whose
        solution u~_{n+1} gives the direction d = u~_{n+1} - u_n; u_{n+1} = u_n + s d with s from the energy
        line search (or the fixed ``relaxation``). It starts from the linear elastic solution (c* = c) and
        stops when the relative H1 change ||u_{n+1} - u_n||_1 / ||u_{n+1}||_1 < tol."""
        f = self.f
        info = NonlinearInfo("secant")
        u = f.displacement()
        with Linearized(f):
            self._solve_secant_system(where, reuse=False)
        x = f.gf.vec
        prev, d, res, trial = x.CreateVector(), x.CreateVector(), x.CreateVector(), x.CreateVector()
        dgf = ngs.GridFunction(f.X)
        for it in range(1, self.maxit + 1):
            prev.data = x
            f.u_frozen.vec.data = u.vec
            self._solve_secant_system(where, reuse=False)
            d.data = x - prev
            x.data = prev
            if self.relaxation is not None:
                s = self.relaxation
            else:
                self._residual(x, res)
                g0 = float(ngs.InnerProduct(res, d))
                s = self._line_search(x, d, g0, info, res, trial) if g0 < 0 else 1.0
            d.data *= s
            x.data += d
            change = self._relative_change(d, dgf)
            info.steps.append(s)
            info.changes.append(change)
            info.iterations = it
            if change < self.tol:
                check_finite(x, f"secant modules method at {where}")
                return info
            if not math.isfinite(change) or (it > 5 and change > 1e3 * info.changes[0]):
                break
        raise SolverError(f"secant modules method at {where} did not converge in {info.iterations} iterations "
                          f"(last relative H1 change {info.changes[-1]:.3e}). Try nonlinear_solver = 'newton', "
                          "a larger regularization, or max_iterations.")

    def _newton(self, where: str) -> NonlinearInfo:
        """Newton's method on the energy W from the linear elastic solution, each step along the Newton
        direction with the energy line search; the tangent is the exact Hessian, or for regions with
        lam < 1 the primal-dual one (:class:`_PrimalDual`). Stops when the relative H1 change of a step is
        < tol (or the residual has dropped by tol * 1e-3)."""
        f = self.f
        info = NonlinearInfo("newton")
        if self.start == "linear":
            with Linearized(f):
                self._solve_secant_system(where, reuse=False)
        x = f.gf.vec
        res, d, trial = x.CreateVector(), x.CreateVector(), x.CreateVector()
        dgf = ngs.GridFunction(f.X)
        pd = None
        if self.primal_dual:
            if self._pd is None:
                self._pd = _PrimalDual(f)
            pd = self._pd
            pd.reset()
        self._residual(x, res)
        r0 = max(float(ngs.Norm(res)), 1e-300)
        for it in range(1, self.maxit + 1):
            if pd is None and self.solver == "iterative":     # the exact Hessian is SPD: CG
                pre = self._preconditioner("newton", f.newton_form)
                self._assemble(f.newton_form, where, linearize_at=x)
                pre.update()
                self.factorizations += 1
                rhs = res.CreateVector()
                rhs.data = -1.0 * res
                d[:] = 0.0
                self._cg(f.newton_form.mat, pre, rhs, d, f"elastic Newton at {where}")
            else:
                mat = pd.assemble() if pd is not None else _assembled_hessian(f, x)
                inv = inverse(mat, f.X.FreeDofs(), False, f"elastic Newton at {where}", _SINGULAR_HINT)
                self.factorizations += 1
                d.data = -1.0 * (inv * res)
            g0 = float(ngs.InnerProduct(res, d))
            if g0 > 0 or not math.isfinite(g0):
                if pd is not None and not pd.is_reset:   # not with a positive tangent; restart from the secant
                    pd.reset()
                    continue
                raise SolverError(f"Newton for the lambda law at {where}: the Newton direction of iteration {it} "
                                  "is not a descent direction of the energy (the Hessian is indefinite: "
                                  "rheology_lambda < 0.5 makes the energy non-convex). Use nonlinear_solver = "
                                  "'secant' or the primal-dual Newton tangent.")
            s = self._line_search(x, d, g0, info, res, trial) if g0 < 0 else 1.0
            d.data *= s
            if pd is not None:
                pd.update_dual(d, x, s)
            x.data += d
            self._residual(x, res)
            r = float(ngs.Norm(res))
            change = self._relative_change(d, dgf)
            info.steps.append(s)
            info.changes.append(change)
            info.residuals.append(r / r0)
            info.iterations = it
            if not (math.isfinite(r) and math.isfinite(change)):
                break
            if change < self.tol or r / r0 < self.tol * 1e-3:
                check_finite(x, f"elastic Newton at {where}")
                return info
        raise SolverError(f"Newton for the lambda law at {where} did not converge in {info.iterations} iterations "
                          f"(relative residual {info.residuals[-1] if info.residuals else float('nan'):.3e}). "
                          "Check rheology_lambda (>= 0.5 keeps the law monotone) and the regularization.")


def _assembled_hessian(forms: ElasticForms, x):
    forms.newton_form.AssembleLinearization(x)
    return forms.newton_form.mat


class _PrimalDual:
    """The Newton tangent with an independent stress sigma for the regions with lam < 1.

    The law sigma = lam (a + delta)^(lam-1) C e (a = A1/A_ref) is written as s(e) sigma - lam C e = 0 with
    s = (a + delta)^(1 - lam); its linearisation in (sigma, e) gives, with the equilibrium equation, the
    displacement step from  int T(sigma, e) e(du) : e(v) = -R(u)(v)  with

        T = (a + delta)^(lam-1) [lam C - c sigma (C e)^T],   c = 2 (1 - lam) (a + delta)^(-lam) / A_ref,

    and the new stress sigma_p(e) + T e(du) (sigma_p = the law at the current strain). With sigma = sigma_p(e)
    T is the Hessian of the energy; during the iteration sigma lags, which keeps the tangent's stiffness
    along the strain that the exact Hessian loses for lam -> 1/2 (Chan, Golub, Mulet 1999 for total
    variation, whose energy is the lam = 1/2 case). The symmetric part of T is positive definite when
    |sigma|_{C^-1} < B = lam sqrt(A_ref) (a + delta)^lam / (2 (1 - lam) sqrt(a)), so the new stress is scaled
    down to max(|sigma_p(e)|, 0.95 B) where larger (never below the consistent stress, which is < B for
    lam >= 1/2). sigma lives at the quadrature points (an IntegrationRuleSpace, one scalar space per
    component); its values are computed with numpy at the mapped points. sigma = 0 to start (the first
    tangent is the secant matrix). Regions with lam >= 1 use sigma = sigma_p(e), i.e. the exact Hessian.
    """

    CAP = 0.95

    def __init__(self, forms: ElasticForms):
        from ngsolve.comp import IntegrationRuleSpace

        f = self.f = forms
        s = f.setup
        mesh = f.mesh
        self.S = IntegrationRuleSpace(mesh, order=f.rule_order // 2)   # the rules of the forms (order 2 order)
        self.intrules = self.S.GetIntegrationRules()
        self.points = mesh.MapToAllElements(self.intrules, ngs.VOL)
        self.nv = len(next(iter(f.D.values())))
        self.sig = [ngs.GridFunction(self.S) for _ in range(self.nv)]
        sig = ngs.CoefficientFunction(tuple(self.sig))
        self.step_gf = ngs.GridFunction(f.V)
        u_gf = f.displacement()
        u, v, trials, tests = f.trial_test()
        w = f.weight
        delta = s.regularization
        form = ngs.BilinearForm(f.X, symmetric=False)
        lin, cons, bound, dinv = {}, {}, {}, {}
        zero_v = ngs.CoefficientFunction((0.0,) * self.nv)
        for name, p in s.props.items():
            D = f.cf_matrix(f.D[name])
            e = f.strain_vector(u_gf)
            De = D * e
            A1 = ngs.InnerProduct(e, De)
            base = A1 / p.A_ref + delta
            fac = p.secant_factor(A1, delta)
            c = 2 * (1 - p.lam) * base ** (-p.lam) / p.A_ref
            dual = sig if p.lam < 1 else fac * De
            mdx = ngs.dx(definedon=mesh.Materials(name), intrules=self.intrules)
            eu, ev = f.strain_vector(u), f.strain_vector(v)
            integrand = w * base ** (p.lam - 1) * (p.lam * ngs.InnerProduct(D * eu, ev)
                                                   - c * ngs.InnerProduct(De, eu) * ngs.InnerProduct(dual, ev))
            form += integrand.Compile() * mdx
            if p.lam < 1:
                de = f.strain_vector(self.step_gf)
                lin[name] = fac * De + base ** (p.lam - 1) * (p.lam * (D * de) - c * ngs.InnerProduct(De, de) * sig)
                cons[name] = fac * ngs.sqrt(A1)
                bound[name] = (p.lam * math.sqrt(p.A_ref) * base ** p.lam
                               / (2 * (1 - p.lam) * ngs.sqrt(A1 / p.A_ref + 1e-300)))
                Dinv = np.linalg.inv(f.D[name])
                dinv[name] = f.cf_matrix(0.5 * (Dinv + Dinv.T))
        for k, (name, nvec) in enumerate(f.oblique):
            lam, mu = trials[1 + k], tests[1 + k]
            nn = ngs.CoefficientFunction(tuple(float(c) for c in nvec[:f.dim]))
            form += w * (lam * (nn * v) + mu * (nn * u)) * ngs.ds(definedon=mesh.Boundaries(name),
                                                                  intrules=f.bnd_intrules)
        self.form = form
        self._lin = mesh.MaterialCF(lin, default=zero_v).Compile()
        self._cons = mesh.MaterialCF(cons, default=0.0).Compile()
        self._bound = mesh.MaterialCF(bound, default=0.0).Compile()
        dinv_all = mesh.MaterialCF(dinv, default=ngs.CoefficientFunction((0.0,) * self.nv ** 2,
                                                                            dims=(self.nv, self.nv)))
        self._dinv = np.asarray(dinv_all(self.points)).reshape(-1, self.nv, self.nv)
        self._mask = np.asarray(mesh.MaterialCF({n: 1.0 for n in lin}, default=0.0)(self.points)).ravel() > 0
        self.is_reset = True

    def reset(self) -> None:
        for g in self.sig:
            g.vec[:] = 0.0
        self.is_reset = True

    def assemble(self):
        self.form.Assemble()
        return self.form.mat

    def update_dual(self, step, x, s: float = 1.0) -> None:
        """Before x += step (the line-searched Newton step s d): sigma <- sigma_p(e) + T e(d) at the current
        strain, the dual Newton update of the full direction d = step / s (not damped by the primal line
        search, whose step is limited by the kinks of the energy where the strain crosses the rigid range:
        at lam = 1/2 this took 12, 14, 16 instead of 12, 15, 20 iterations at h = 0.1, 0.05, 0.025), then
        scaled down where |sigma|_{C^-1} > max(|sigma_p(e_new)|, CAP B(e_new)), with e_new the strain of
        x + step (x is restored)."""
        f = self.f
        tmp = ngs.GridFunction(f.X)
        tmp.vec.data = step
        if s > 0 and math.isfinite(s) and s != 1.0:
            tmp.vec.data *= 1.0 / s
        self.step_gf.vec.data = f.displacement(tmp).vec
        new = np.asarray(self._lin(self.points)).reshape(-1, self.nv)
        x.data += step                      # evaluate the bound at the new strain, then restore x
        cons = np.asarray(self._cons(self.points)).ravel()
        bound = np.asarray(self._bound(self.points)).ravel()
        x.data -= step
        norm = np.sqrt(np.maximum(np.einsum("pi,pij,pj->p", new, self._dinv, new), 0.0))
        allowed = np.where(cons < bound, np.maximum(cons, self.CAP * bound), self.CAP * bound)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(norm > allowed, allowed / norm, 1.0)
        scale = np.where(self._mask & np.isfinite(scale), scale, 0.0)
        new *= scale[:, None]
        for k, g in enumerate(self.sig):
            g.vec.FV().NumPy()[:] = new[:, k]
        self.is_reset = False


class Linearized:
    """Context: the secant form with c* = c (linear elasticity), to start an iteration."""

    def __init__(self, forms: ElasticForms):
        self.f = forms

    def __enter__(self):
        self.f.linear_switch.Set(1.0)
        return self

    def __exit__(self, *exc):
        self.f.linear_switch.Set(0.0)
        return False
