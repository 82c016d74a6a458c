"""Solving the heat forms: steady solves and theta time steps, linear (factor once per dt) or with
Newton's method for the Kirchhoff-transformed k(T) law."""

from __future__ import annotations

import math
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import SolverError
from ..fem.coefficients import material_cf, regions_regex, tensor_cf
from ..linalg.direct import check_finite, inverse, not_finite, solve_watched
from ..linalg.iterative import DEFAULT_TOL, PCG, Preconditioned, choose_solver
from .forms import HeatForms


@dataclass
class StepInfo:
    """What one solve did: Newton iterations (1 for linear solves) and the final relative residual;
    ``cg_iterations`` the CG iterations of an iterative linear solve (0 for direct solves); ``residuals`` the
    relative residual before each Newton iteration and after the last (empty for linear solves)."""

    iterations: int
    residual: float
    factorized: bool
    cg_iterations: int = 0
    residuals: tuple = ()


class HeatSolver:
    """Drives :class:`HeatForms`: Dirichlet data, assembly, factorization cache, Newton."""

    def __init__(self, forms: HeatForms, newton_tol: float = 1e-10, newton_maxit: int = 30, *,
                 solver: str = "auto", tol: float = DEFAULT_TOL, maxit: int = 2000, preconditioner: str = "auto"):
        """``solver``: "direct" (sparse Cholesky, UMFPACK), "iterative" (preconditioned CG to the relative
        residual ``tol``, at most ``maxit`` iterations; :mod:`~ngs_geomech.linalg.iterative`) or "auto"
        (iterative above ``iterative.AUTO_DOFS`` dofs). Only the linear problem without contact interfaces (an SPD
        step matrix) is solved iteratively; k(T) Newton and the mortar saddle point stay direct.
        ``preconditioner``: of CG, one of :data:`~ngs_geomech.linalg.choices.PRECONDITIONERS`."""
        self.f = forms
        self.preconditioner = preconditioner
        self.distributed = forms.mesh.comm.size > 1
        self._gathered = self._interface_solve(forms) if self.distributed else None
        self.solver = choose_solver(solver, forms.X.ndof, forms.mesh.dim, spd=self.symmetric_for(forms),
                                    distributed=self.distributed)
        self._pcg = PCG(tol, maxit) if self.solver == "iterative" else None
        self._pre = None
        self._pre_gmres = None
        self.cg_iterations: list[int] = []
        """CG iterations of every iterative solve, in order."""
        self.newton_tol = newton_tol
        self.newton_maxit = newton_maxit
        self._cache: dict[str, tuple] = {}
        self._tmp = ngs.GridFunction(forms.V)
        self._fixed = ngs.Projector(forms.V.FreeDofs(), False)   # onto the Dirichlet dofs
        self._dirichlet_ready = False
        self.factorizations = 0
        self._free_mask = None
        self._region_vertices = None
        self._vertex_temperature = None
        self.backward_euler_steps = 0
        """The next this many steps take theta = 1 whatever the scheme (a restart after the state was carried to
        a new mesh without the old interface multipliers: :mod:`ngs_geomech.adapt.contact_following`)."""
        forms.update_contact_pairs()

    @staticmethod
    def _interface_solve(forms: HeatForms):
        """The solve of a distributed mesh with contact interfaces (:class:`.distributed.GatheredSolve`), or None
        without interfaces."""
        s = forms.setup
        if not (s.contacts or s.conductances):
            return None
        from .distributed import GatheredSolve

        return GatheredSolve(forms)

    @property
    def symmetric(self) -> bool:
        return self.symmetric_for(self.f)

    @staticmethod
    def symmetric_for(forms: HeatForms) -> bool:
        s = forms.setup
        return not s.nonlinear and not s.contacts and not s.conductances

    def set_dirichlet(self) -> None:
        """Put the Dirichlet temperatures at t_new into the state's Dirichlet dofs (other dofs untouched).

        Time-independent data are interpolated once; later calls only copy them into the state.
        """
        f = self.f
        if not f.setup.dirichlet:
            return
        static = all(getattr(g, "time_dependent", True) is False for g in f.setup.dirichlet.values())
        if not (static and self._dirichlet_ready):
            cf = f.dirichlet_values(f.t_new)
            self._tmp.Set(cf, ngs.BND, definedon=f.mesh.Boundaries(regions_regex(f.setup.dirichlet)))
            if not_finite(self._tmp.vec):
                self._name_not_finite_dirichlet()
            self._dirichlet_ready = True
        T = f.temperature()
        T.vec.data += self._fixed * (self._tmp.vec - T.vec)

    def _name_not_finite_dirichlet(self) -> None:
        """Raise SolverError naming the boundary whose temperature is not finite at a point of its interpolation
        (validation samples a coarse set of points; a singularity between them shows here)."""
        f = self.f
        g = ngs.GridFunction(f.V)
        for name, tf in f.setup.dirichlet.items():
            g.vec[:] = 0.0
            g.Set(tf(f.t_new), ngs.BND, definedon=f.mesh.Boundaries(f"^{name}$"))
            if not_finite(g.vec):
                raise SolverError(f"boundary_conditions.{name}.temperature is not finite at some points of the "
                                  f"boundary at t = {f.t_new.Get():g} s (between the points validation samples): "
                                  "a singularity or a function outside its domain")
        raise SolverError("the boundary temperatures are not finite at some points of the mesh")

    def forget_factorizations(self) -> None:
        """Drop the cached step operators: the next step assembles and factors anew (for timing a step with its
        factorization)."""
        self._cache.clear()
        if self._gathered is not None:
            self._gathered.forget()

    def _system(self, key: str):
        """(matrix, inverse) of the step operator for one dt, cached for the last two dts."""
        hit = self._cache.get(key)
        if hit is not None:
            return hit[0], hit[1], False
        self.f.lhs.Assemble()
        mat = with_coupling(self.f.lhs.mat, self.f.coupling)
        inv = inverse(mat, self.f.freedofs, self.symmetric)
        self.factorizations += 1
        if len(self._cache) >= 2:
            self._cache.pop(next(iter(self._cache)))
        self._cache[key] = (mat, inv)
        return mat, inv, True

    def solve_steady(self, where: str) -> StepInfo:
        """The steady problem of transient forms: the step operator with the caller's inv_dt = 0 and theta = 1
        (kept: :meth:`solve` would set theta from the scheme)."""
        return self._solve_step(where)

    def solve(self, where: str) -> StepInfo:
        """Solve for the new state (t_new, inv_dt already set, old state in gf_old). Steps ending by
        ``setup.startup_until`` take theta = 1 (the start-up of Crank-Nicolson), and so do the next
        ``backward_euler_steps``."""
        s = self.f.setup
        if not s.steady:
            t1 = self.f.t_new.Get()
            startup = s.startup_until is not None and t1 <= s.startup_until * (1 + 1e-12) + 1e-300
            theta = 1.0 if startup or self.backward_euler_steps > 0 else s.theta
            self.backward_euler_steps = max(0, self.backward_euler_steps - 1)
            if theta != self.f.theta.Get():
                self.f.theta.Set(theta)
        return self._solve_step(where)

    def _solve_step(self, where: str) -> StepInfo:
        """The new state with the forms' current inv_dt and theta."""
        self.set_dirichlet()
        self.f.prepare_step()
        rhs = self.f.right_hand_side()
        if self._gathered is not None and self.f.nonlinear:
            it, rel, history = self._gathered.newton(where, rhs, self.newton_tol, self.newton_maxit)
            self.factorizations += it
            self.check_conductivity(where)
            return StepInfo(max(it, 1), rel, True, residuals=history)
        if self._gathered is not None:
            fresh = self._gathered.solve(where, rhs)
            self.factorizations += fresh
            return StepInfo(1, 0.0, fresh)
        if self.solver == "iterative" and not self.f.nonlinear:
            return self._solve_iterative(where, rhs)
        if not self.f.nonlinear:
            mat, inv, fresh = self._system(f"{self.f.inv_dt.Get():.14g}:{self.f.theta.Get():g}:{self.f.version}")
            if self._free_mask is None:
                self._free_mask = np.array(list(self.f.freedofs), dtype=bool)
            solve_watched(mat, inv, rhs, self.f.gf.vec, self._free_mask, f"heat solve at {where}",
                          "Check the material data and boundary conditions of the scene (conductivity contrasts "
                          "beyond 1e12, time steps far below the diffusion time of an element).")
            return StepInfo(1, 0.0, fresh)
        return self._newton(where, rhs)

    def _solve_iterative(self, where: str, rhs) -> StepInfo:
        """Preconditioned CG on the step matrix (the form's own matrix: its preconditioner is rebuilt with each
        assembly, so one dt is kept, not two)."""
        f = self.f
        key = f"{f.inv_dt.Get():.14g}:{f.theta.Get():g}:{f.version}"
        fresh = key != getattr(self, "_iter_key", None)
        if self._pre is None:
            self._pre = Preconditioned(f.lhs, f.V, f.setup.order, vector=False, choice=self.preconditioner)
        if fresh:
            try:
                f.lhs.Assemble()
            except Exception as exc:  # NgException from the preconditioner's set-up
                raise SolverError(f"heat solve at {where}: the preconditioner ({self._pre.kind}) could not be "
                                  f"built ({exc}). Check the material data and boundary conditions.") from None
            self._pre.update()
            self._iter_key = key
            self.factorizations += 1
        info = self._pre.cg(self._pcg, f.lhs.mat, rhs, f.gf.vec, f"heat solve at {where}",
                            "Check the material data and boundary conditions of the scene, or use the direct solver.")
        check_finite(f.gf.vec, f"heat solve at {where}")
        self.cg_iterations.append(info.iterations)
        return StepInfo(1, info.residual, fresh, info.iterations)

    def _newton(self, where: str, rhs) -> StepInfo:
        f, gf = self.f, self.f.gf
        free = f.freedofs
        fixed = ~np.array(list(free), dtype=bool)
        res = gf.vec.CreateVector()
        du = gf.vec.CreateVector()
        trial = gf.vec.CreateVector()

        def residual(vec) -> float:
            f.lhs.Apply(vec, res)
            f.add_coupling(vec, res)
            res.data -= rhs
            arr = res.FV().NumPy()
            arr[fixed] = 0.0
            return float(ngs.Norm(res))
        r0 = residual(gf.vec)
        scale = max(r0, float(ngs.Norm(rhs)), 1e-300)
        rel = r0 / scale
        history = [rel]
        it = 0
        while rel > self.newton_tol:
            if it >= self.newton_maxit:
                raise SolverError(f"Newton for the k(T) heat problem at {where} did not converge in "
                                  f"{self.newton_maxit} iterations (relative residual {rel:.3e}). "
                                  "Reduce the time step or check that kappa(T) stays positive.")
            if self.solver == "iterative":         # a distributed mesh (choose_solver): GMRES, BDDC of J
                self._linearized_solve(gf.vec, res, du, where)
            else:
                f.lhs.AssembleLinearization(gf.vec)
                inv = inverse(with_coupling(f.lhs.mat, f.coupling_jacobian(gf.vec)), free, symmetric=False)
                du.data = inv * res
            self.factorizations += 1
            step, new_rel = 1.0, math.inf
            while step > 1e-4:
                trial.data = gf.vec - step * du
                rn = residual(trial)
                new_rel = rn / scale
                if math.isfinite(new_rel) and new_rel < (1 - 1e-4 * step) * rel:
                    break
                step /= 2
            if not math.isfinite(new_rel) or new_rel >= rel:
                if rel < 1e3 * self.newton_tol:
                    break
                self.check_conductivity(where, trial)
                self.check_conductivity(where)
                raise SolverError(f"Newton for the k(T) heat problem at {where} stagnated at relative "
                                  f"residual {rel:.3e}. Reduce the time step or check kappa(T) > 0.")
            gf.vec.data = trial
            rel = new_rel
            history.append(rel)
            it += 1
        check_finite(gf.vec, f"heat solve at {where}")
        self.check_conductivity(where)
        return StepInfo(max(it, 1), rel, True, residuals=tuple(history))

    def check_conductivity(self, where: str, state=None) -> None:
        """Raise SolverError naming the material and the temperature where f(T) = 1 + b (T - T_ref) of k(T) is
        not positive at a vertex of its region, or where a conductivity or heat capacity given as an expression of
        T is not positive (definite) there (``state``: a state vector, default the solver's). The vertex dofs of
        the H1 temperature hold its values at the vertices. On a distributed mesh raised on every rank when a
        vertex of some rank fails."""
        f = self.f
        if self._region_vertices is None:
            self._region_vertices = {n: np.unique([v.nr for el in f.mesh.Materials(f"^{n}$").Elements()
                                                   for v in el.vertices]).astype(int)
                                     for n, p in f.setup.props.items() if p.nonlinear}
        values = f.temperature().vec.FV().NumPy()
        if state is not None:                   # a compound state (contacts) holds the temperature first
            values = state.FV().NumPy()[:len(values)]
        error = self._conductivity_error(values) or self._temperature_law_error(values)
        errors = [e for e in parallel.allgather(f.mesh, error) if e is not None]
        if errors:
            raise SolverError(f"heat solve at {where}: {errors[0]}")

    def _conductivity_error(self, values: np.ndarray) -> str | None:
        """The message for the first region whose k(T) factor is not positive at a vertex (None: none)."""
        for name, verts in self._region_vertices.items():
            p = self.f.setup.props[name]
            if p.b == 0.0:
                continue
            temps = values[verts]
            factor = 1 + p.b * (temps - p.t_ref)
            bad = np.nonzero(~(factor > 0))[0]
            if len(bad):
                worst = temps[bad[np.argmin(factor[bad])]] if np.all(np.isfinite(factor[bad])) else temps[bad[0]]
                return (f"the conductivity of material {name!r}, k(T) = k (1 + b (T - T_ref)) with b = {p.b:g} 1/K "
                        f"and T_ref = {p.t_ref:g}, is not positive at T = {worst:.6g} (it is positive only for T "
                        f"{'>' if p.b > 0 else '<'} {p.t_ref - 1 / p.b:.6g}). Check materials.{name}."
                        "conductivity_temperature_coefficient and the temperatures the scene reaches (boundary "
                        "values, sources).")
        return None

    def _temperature_law_error(self, values: np.ndarray) -> str | None:
        """The message for the first region whose conductivity (smallest eigenvalue) or heat capacity, given as an
        expression of T, is not positive at a vertex with the temperatures ``values`` (None: none)."""
        f = self.f
        laws = {n: p for n, p in f.setup.props.items()
                if p.conductivity_uses_temperature or p.capacity_uses_temperature}
        if not laws:
            return None
        if self._vertex_temperature is None:
            self._vertex_temperature = ngs.GridFunction(f.V)
        T = self._vertex_temperature
        T.vec.FV().NumPy()[:] = values[:f.V.ndof]
        for name, p in laws.items():
            verts = self._region_vertices[name]
            if len(verts) == 0:
                continue
            pts = np.array([f.mesh.vertices[int(v)].point for v in verts])
            mips = f.mesh(*pts.T)
            checks = []
            if p.conductivity_uses_temperature:
                k = np.asarray(tensor_cf(p.kappa, T)(mips), dtype=float).reshape(len(verts), f.mesh.dim, f.mesh.dim)
                finite = np.isfinite(k).all(axis=(1, 2))
                smallest = np.full(len(verts), np.nan)
                smallest[finite] = np.linalg.eigvalsh(k[finite])[:, 0]
                checks.append(("conductivity", smallest))
            if p.capacity_uses_temperature:
                checks.append(("heat capacity", np.asarray(material_cf(p.rho_c, T)(mips), dtype=float).ravel()))
            for what, v in checks:
                bad = np.nonzero(~(v > 0))[0]
                if len(bad):
                    i = bad[0]
                    at = ", ".join(f"{c}={x:.6g}" for c, x in zip("xyz", pts[i]))
                    key, value = ("conductivity (or conductivity_principal)", "smallest eigenvalue") \
                        if what == "conductivity" else ("rho_c (or density, specific_heat)", "value")
                    return (f"the {what} of material {name!r} is not positive at {at} where T = "
                            f"{values[verts[i]]:.6g} ({value} {v[i]:.4g}). Check materials.{name}.{key} and the "
                            "temperatures the scene reaches (boundary values, sources).")
        return None

    def _linearized_solve(self, state, res, du, where: str) -> None:
        """Solve J du = res for the Newton step of the k(T) problem on a distributed mesh: J assembled at ``state``
        (its preconditioner, registered on the form, is rebuilt with it), GMRES to the relative residual of the
        CG solves (J is not symmetric: k'(T) grad T . grad dT)."""
        f = self.f
        if self._pre_gmres is None:       # GMRES needs the preconditioner as an operator: NGSolve's BDDC
            self._pre_gmres = Preconditioned(f.lhs, f.V, f.setup.order, vector=False, choice="bddc")
        f.lhs.AssembleLinearization(state)
        du[:] = 0.0
        solver = ngs.krylovspace.GMRESSolver(f.lhs.mat, self._pre_gmres.mat, tol=self._pcg.tol,
                                             maxiter=self._pcg.maxit, restart=200)
        solver.Solve(rhs=res, sol=du)
        self.cg_iterations.append(solver.iterations)
        r = solver.residuals
        rel = r[-1] / max(r[0], 1e-300) if r else math.nan
        if not rel <= self._pcg.tol:
            raise SolverError(f"Newton for the k(T) heat problem at {where}: GMRES did not converge in "
                              f"{solver.iterations} iterations (relative residual {rel:.3e}). Reduce the time step "
                              "or check kappa(T) > 0.")


def with_coupling(mat, coupling):
    """An assembled copy of ``mat`` (+ ``coupling`` when given), so cached operators stay valid when the
    bilinear form is assembled again for another time step."""
    r, c, v = (np.array(a) for a in mat.COO())
    if coupling is not None:
        r2, c2, v2 = (np.array(a) for a in coupling.COO())
        r, c, v = np.concatenate([r, r2]), np.concatenate([c, c2]), np.concatenate([v, v2])
    return ngs.la.SparseMatrixd.CreateFromCOO(r.tolist(), c.tolist(), v.tolist(), mat.height, mat.width)
