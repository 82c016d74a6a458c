"""The Krylov linear algebra of the Stefan Newton steps: :class:`KrylovJacobian`, preconditioned GMRES on
distributed meshes and on serial ones with ``linear="iterative"`` (a
:class:`ngs_geomech.stefan.jacobian.NewtonJacobian`).

Distributed meshes (MPI). The Newton step (m C/dt + A'(T))_NN dT_N = -R_N of :mod:`ngs_geomech.stefan.solver`
is solved in the mixed unknowns of :mod:`ngs_geomech.stefan.column_jacobian`: the Newton matrix written into the
local matrices of an NGSolve ParallelMatrix (column j of the local stiffness scaled by dtheta_j, the lumped m C/dt
on the owner rank's diagonal), and GMRES (``ngsolve.krylovspace``, relative tolerance 1e-12 on the preconditioned
residual; its true residual is checked) on the non-mushy free nodes, the mushy ones held as fixed dofs
(dT_M = 0, left out by the preconditioner's projection; de_M then from their rows). Preconditioners: "bddc"
(default), NGSolve's BDDC on the symmetric form int kappa grad u . grad v + lumped C/dt (kappa the P1 interpolant
of the nodal dtheta, the mushy nodes pinned), built again only when dt changed by more than 25 %, GMRES needed
more than 30 iterations, or a pinned node turned sensible (it would be a near-null direction of the old
preconditioner: GMRES then converged in its norm, not in the residual's, which the true-residual check caught);
and "jacobi" (the global diagonal, nothing to build). Measured on ``melting_block``
(tests/mpi_cases/stefan_case.py, steps of 5 days, 3 ranks = 2 workers on the busy 2-core machine, one run each):
the same Newton iterations as the serial solver in every step, temperatures within 2e-15 (BDDC) / 2e-13 (Jacobi)
relative at 246 vertices; GMRES iterations per Newton solve, mean (max), BDDC against Jacobi: 10.9 (14) /
54.5 (59) at 246 vertices, 14.8 (17) / 99 (109) at 918, 18.4 (22) / 178 (203) at 3459 (six steps); 16.6 (21)
over 24 steps at 918 (52 Newton iterations as serially). BDDC was built once per run there (at the first solve,
with no mushy node; with a rebuild after 12 iterations instead of 30 it was built 24 times in 29 solves at 3459
vertices, 11.5 s against 8.7 s). Time of the whole case at 3459 vertices (meshing and set-up included, rank 0
idling in the collectives on one of the 2 cores): 10 s with BDDC, 70 s with Jacobi, 2.7 s serially (SuperLU with
the Woodbury updates): on this machine the distributed path is slower than the serial one. Jacobi's count grows
like 1/h, BDDC's slowly; with P1 BDDC's coarse problem is the whole form, factored directly (NGSolve's coarse
inverse), so its builds do not scale like the Krylov part to very large meshes. The Neumann strips of
:mod:`ngs_geomech.verification.stefan` (h = 0.05 m, dt = 0.2 h s/m, 40 steps): the same Newton iterations per
step as serially, temperatures within 5e-15; one-phase (the solid at Theta_R, mushy ahead of the front) GMRES 3
per solve and BDDC built 20 times in 42 solves (pinned nodes turning sensible), two-phase 13 per solve, built
once; 3.4 and 4.8 s against 0.1 s serially (142 and 362 vertices: the per-iteration overheads of the Python GMRES
and the collectives dominate). The whole pipeline (``mpiexec -n 3 ngs-geomech run melting_block``, 60 days,
h = 0.3 m, the probes left out) gave the serial summary's melted volumes and heats to 5e-13 relative.

Serial meshes with ``linear="iterative"`` (the scene's ``solver.linear``; "auto" above
:data:`ngs_geomech.stefan.problem.AUTO_NODES`) take the same :class:`KrylovJacobian` with NGSolve's ``h1amg`` on
the same symmetric form instead of BDDC (whose P1 coarse problem is the whole form, factored). Measured on the
two-phase Neumann strip (tests/test_stefan_iterative.py): the same Newton iterations and temperatures to 4e-14;
GMRES 13 - 14 per solve at 1k nodes, 14 - 16 at 4k; 0.17 s per step against 0.013 s with SuperLU at 12k nodes
(2D, one thread): in 2D the direct path stays faster.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import SolverError
from .forms import StefanForms
from .jacobian import NewtonJacobian


class _JacobiPreconditioner(ngs.BaseMatrix):
    """x -> D^-1 x on the Krylov unknowns, 0 elsewhere, on NGSolve parallel vectors: the input is cumulated
    first (any status accepted), ``inverse`` (cumulated: the global diagonal's inverse, 0 outside the
    unknowns) is applied entrywise, the output is cumulated. (NGSolve's Python ParallelMatrix has no
    ``CreateSmoother``, and its "local" preconditioner needs an assembled form: M's values are written directly.)"""

    def __init__(self, inverse: np.ndarray, prototype):
        super().__init__()
        self.inverse = inverse
        self.prototype = prototype

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return len(self.inverse)

    def Width(self) -> int:
        return len(self.inverse)

    def CreateRowVector(self):
        return self.prototype.CreateVector()

    def CreateColVector(self):
        return self.prototype.CreateVector()

    def Mult(self, x, y):
        x.Cumulate()                                  # the same vector, its other representation
        y.FV().NumPy()[:] = self.inverse * x.FV().NumPy()
        y.SetParallelStatus(ngs.PARALLEL_STATUS.CUMULATED)


class KrylovJacobian(NewtonJacobian):
    """The Krylov counterpart of :class:`ngs_geomech.stefan.column_jacobian.ColumnJacobian` (same matrices
    M = diag(d) + sum_g (K_g - diag K_g) diag(w_g) on the free nodes): M is an NGSolve parallel matrix, solved by
    preconditioned GMRES (``ngsolve.krylovspace.GMRESSolver``) on the nodes with w_j != 0.

    Assembly. A BilinearForm with the stiffness pattern (``grad u grad v dx`` on the P1 space, assembled once)
    lends its ParallelMatrix; in every solve the values of its local matrix (``mat.local_mat``) are overwritten
    with this rank's part of M: the local stiffness values of each group times w_g of the column (column scaling
    commutes with the sum over the ranks, w being cumulated), the diagonal with diag(K_g) wd_g and the lumped
    mass term m C/dt on the vertices this rank owns only (so that the ranks' parts add up to m C/dt).

    Preconditioners (``preconditioner``). "jacobi": the diagonal of M cumulated over the ranks (the exact global
    diagonal), nothing to build. "bddc": NGSolve's BDDC on a symmetric form close to M, assembled from element
    matrices with the current nodal coefficients (:meth:`_bddc_form`: kappa_g the P1 interpolant of dtheta_g, so
    its element matrix is the element mean of the column factors; the lumped m C/dt; the nodes out of the Krylov
    system pinned by PIN times their diagonal), applied between projections on the Krylov unknowns. With P1 every
    dof is a vertex of BDDC's wirebasket, so its coarse problem is the whole form, factored directly (NGSolve's
    coarse inverse): a parallel direct solve of the symmetric approximation, M^-1 up to the column factors that
    vary inside an element (near the front) and the changes since it was built. It is built again only when dt or
    the forms changed, after a solve needing more than REBUILD_ITERATIONS, or when a node pinned in it is a Krylov
    unknown now (:meth:`_preconditioner`) (``factorizations`` counts the builds; measured in the module
    docstring).

    Unknowns. Nodes with w_j = 0 (the mushy nodes of the Stefan solver) are left out of the Krylov system (the
    preconditioner is 0 there, so the iterates stay 0 there): their columns have no off-diagonal part, so the
    other unknowns are those of the full system (block triangular, see :mod:`ngs_geomech.stefan.solver`), and their own
    unknowns come out as 0 (not used, as the unfactored nodes of the direct solver).

    ``tol`` is GMRES's reduction of the preconditioned residual (relative to its initial value); ``maxiter`` the
    largest number of GMRES iterations (no restart). ``krylov_iterations`` lists the GMRES iterations per solve,
    ``residuals`` the true relative residual of each (:meth:`_check`). ``corrections`` stays 0.
    """

    PRECONDITIONERS = ("jacobi", "bddc", "h1amg")
    REBUILD_ITERATIONS = 30
    """BDDC: the preconditioner is built again for the next solve after a solve needing more GMRES iterations."""
    REBUILD_DT = 1.25
    """BDDC: ... and when dt differs from the one it was built with by more than this factor (either way)."""
    PIN = 1e8
    """BDDC: the nodes left out of the Krylov system (mushy) get this many times their diagonal in the
    preconditioner's form (held nearly fixed, as they are in the Newton step)."""

    def __init__(self, forms: StefanForms, tol: float = 1e-12, maxiter: int = 500, preconditioner: str = "bddc"):
        if preconditioner not in self.PRECONDITIONERS:
            raise ValueError(f"Stefan Krylov solver: preconditioner must be one of {self.PRECONDITIONERS}, "
                             f"got {preconditioner!r}")
        super().__init__(forms)
        f = forms
        self.tol = float(tol)
        self.maxiter = int(maxiter)
        self.preconditioner = preconditioner
        u, v = f.V.TnT()
        self._form = ngs.BilinearForm(f.V)
        self._form += ngs.grad(u) * ngs.grad(v) * ngs.dx          # its pattern only: the values are overwritten
        self._form.Assemble()
        _, cols, ptr = self._form.mat.local_mat.CSR()
        cols = np.asarray(cols, dtype=np.int64)
        ptr = np.asarray(ptr, dtype=np.int64)
        if not (np.array_equal(cols, f.pattern_cols)
                and np.array_equal(np.repeat(np.arange(f.n), np.diff(ptr)), f.pattern_rows)):
            raise AssertionError("Stefan Krylov Jacobian: the Newton matrix's pattern is not the stiffness pattern")
        self._rows, self._cols, self._diag = f.pattern_rows, f.pattern_cols, f.diagonal_positions
        self._load_stiffness()
        self.krylov_iterations: list[int] = []
        """GMRES iterations of each solve."""
        self.unconverged = 0
        """Solves whose true relative residual stayed above CHECK (the Newton test still decides the step)."""
        self.residuals: list[float] = []
        """True relative residual |b - M x| / |b| of each solve."""
        self._bddc = None
        self._bddc_key = None                         # (dt, forms version) of the BDDC built
        self._rebuild = True
        if preconditioner in ("bddc", "h1amg"):
            self._bddc_form()

    def _bddc_form(self) -> None:
        """The symmetric form the BDDC preconditioner is built on (module docstring): sum_g int_{Omega_g}
        kappa_g grad u . grad v + int (lumped) c u v, kappa_g (W/(m K)) the P1 interpolant of the nodal dtheta_g
        (its element mean for P1), c (J/(m^3 K s)) the nodal C/dt, pinned at the nodes out of the Krylov system."""
        f = self.forms
        u, v = f.V.TnT()
        self._kappa = [ngs.GridFunction(f.V) for _ in f.groups]
        self._c = ngs.GridFunction(f.V)
        form = ngs.BilinearForm(f.V)
        for g, names in enumerate(f.group_regions):
            indicator = f.mesh.MaterialCF({n: 1.0 for n in names}, default=0.0)
            form += f.group_integrand(g, indicator * self._kappa[g], u, v) * ngs.dx
        form += f.lumped(self._c * u * v)
        self._pform = form
        # "h1amg" (serial meshes: NGSolve's AMG is serial) on the same form; BDDC's P1 coarse problem is the whole
        # form, factored
        self._bddc = ngs.Preconditioner(form, "h1amg" if self.preconditioner == "h1amg" else "bddc")

    def _build_bddc(self, mc: np.ndarray, wd: np.ndarray, on: np.ndarray, diag: np.ndarray, dt: float) -> None:
        """Assemble the BDDC form with the current nodal coefficients (the coarse problem is factored: counted in
        ``factorizations``)."""
        f = self.forms
        for g, gf in enumerate(self._kappa):
            k = np.full(f.n, float(np.max(f.group_conductivity[g])))     # Dirichlet nodes: k at T_ref
            k[self.free] = wd[:, g]
            gf.vec.FV().NumPy()[:] = k
        c = np.zeros(f.n)
        c[self.free] = mc / dt / f.mass[self.free]
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(f.free & ~on, self.PIN * diag / f.mass, c)
        self._c.vec.FV().NumPy()[:] = c
        self._pinned = f.free & ~on
        self._pform.Assemble()
        self.factorizations += 1
        self._bddc_key = (dt, f.version)
        self._rebuild = False

    def _preconditioner(self, mc, wd, on, diag, inverse, dt, prototype):
        """The preconditioner of this solve: Jacobi, or BDDC between projections on the Krylov unknowns, built
        again when dt or the forms changed, after a solve needing more than REBUILD_ITERATIONS, or when a node
        pinned in it is a Krylov unknown now (it would be a near-null direction of the preconditioner: GMRES
        then converged in its norm, not in the residual's). The decision is the same on every rank."""
        if self.preconditioner == "jacobi":
            return _JacobiPreconditioner(inverse, prototype)
        key = self._bddc_key
        stale = key is None or key[1] != self.forms.version or max(dt / key[0], key[0] / dt) > self.REBUILD_DT
        released = key is not None and parallel.anyof(self.forms.mesh, bool(np.any(on & self._pinned)))
        if self._rebuild or released or stale:
            self._build_bddc(mc, wd, on, diag, dt)
        proj = ngs.Projector(ngs.BitArray(on), True)
        return proj @ self._bddc @ proj

    CHECK = 1e-8
    """A solve whose true relative residual |b - M x| / |b| (Euclidean, global) stays above this is counted in
    ``unconverged``."""

    def _check(self, mat, rhs, sol, on: np.ndarray) -> None:
        """The true residual of a solve on the Krylov unknowns ``on`` (GMRES's own is the preconditioned one, and
        it stops without a last check on a lucky breakdown): kept in ``residuals``, counted in ``unconverged``
        above CHECK."""
        r = rhs.CreateVector()
        r.data = rhs - mat * sol
        r.Distribute()
        r.FV().NumPy()[~on] = 0.0
        scale = ngs.Norm(rhs)
        rel = ngs.Norm(r) / scale if scale > 0 else 0.0
        self.residuals.append(float(rel))
        if not rel <= self.CHECK:
            self.unconverged += 1

    def _load_stiffness(self) -> None:
        """The local stiffness values (again after the forms' matrices changed): off-diagonal part and diagonal."""
        f = self.forms
        self.version = f.version
        self._kdata = [K.data.copy() for K in f.stiffness]
        self._kdiag = [kd[self._diag].copy() for kd in self._kdata]
        for kd in self._kdata:
            kd[self._diag] = 0.0

    def _newton_matrix(self, mc: np.ndarray, wd: np.ndarray, w: np.ndarray, dt: float) -> np.ndarray:
        """Write this rank's part of M into the ParallelMatrix; returns its cumulated (global) diagonal."""
        f = self.forms
        G = len(self._kdata)
        W = np.zeros((f.n, G))
        W[self.free] = w
        WD = np.zeros((f.n, G))
        WD[self.free] = wd
        data = np.zeros(len(self._cols))
        for g, kd in enumerate(self._kdata):
            data += kd * W[self._cols, g]
        diag = np.zeros(f.n)
        for g, kdg in enumerate(self._kdiag):
            diag += kdg * WD[:, g]
        mass = np.zeros(f.n)
        mass[self.free] = mc / dt
        diag += np.where(f.owned, mass, 0.0)          # m C/dt once over the ranks
        data[self._diag] = diag
        self._form.mat.local_mat.AsVector().FV().NumPy()[:] = data
        return f.cumulate(diag)

    def capture(self) -> dict:
        """Nothing to keep: every solve builds its preconditioner from the current matrix."""
        return {}

    def restore(self, state: dict) -> None:
        pass

    def solve(self, mc: np.ndarray, wd: np.ndarray, w: np.ndarray, b: np.ndarray, dt: float,
              where: str) -> np.ndarray:
        """Solve M x = b on the free nodes (arguments as :meth:`NewtonJacobian.solve`, local free nodes, all
        cumulated); collective: every rank calls it. The unknowns of nodes with w_j = 0 come out as 0."""
        from ngsolve.krylovspace import GMRESSolver

        f = self.forms
        if self.version != f.version:
            self._load_stiffness()
        on = np.zeros(f.n, dtype=bool)
        on[self.free] = np.any(w != 0.0, axis=1)
        diag = self._newton_matrix(mc, wd, w, dt)
        with np.errstate(divide="ignore", invalid="ignore"):
            inverse = np.where(on, 1.0 / np.where(on, diag, 1.0), 0.0)
        mat = self._form.mat
        rhs = mat.CreateColVector()
        full = np.zeros(f.n)
        full[self.free] = b
        rhs.FV().NumPy()[:] = np.where(on & f.owned, full, 0.0)     # distributed: each value once
        rhs.SetParallelStatus(ngs.PARALLEL_STATUS.DISTRIBUTED)
        sol = mat.CreateColVector()
        sol.FV().NumPy()[:] = 0.0
        sol.SetParallelStatus(ngs.PARALLEL_STATUS.CUMULATED)
        pre = self._preconditioner(mc, wd, on, diag, inverse, dt, sol)
        solver = GMRESSolver(mat=mat, pre=pre, tol=self.tol, maxiter=self.maxiter, printrates=False)
        solver.Solve(rhs=rhs, sol=sol, initialize=False)
        self.krylov_iterations.append(int(solver.iterations))
        self._rebuild = solver.iterations > self.REBUILD_ITERATIONS
        self._check(mat, rhs, sol, on)
        sol.Cumulate()
        x = sol.FV().NumPy()[self.free].copy()
        if parallel.anyof(f.mesh, not np.all(np.isfinite(x))):
            raise SolverError(f"Stefan Newton step at {where}: the Krylov solve gave non-finite values; check the "
                              "material data (capacities and conductivities must be > 0) and the time step.")
        return np.where(on[self.free], x, 0.0)
