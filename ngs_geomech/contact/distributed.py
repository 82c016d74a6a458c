"""Contact solves on a distributed mesh: the semi-smooth Newton (active-set) iteration of
:class:`.solver.ContactSolver` runs unchanged and replicated on every rank, on global arrays (the displacement in
the numbering of :class:`~ngs_geomech.parallel.GlobalDofs`, the multipliers); only the bulk K and the linear solves
of the Newton steps are distributed. Every rank then takes the same decisions (the sets, the floating bodies'
checks) from the same numbers, and the contact operators (replicated, in global numbering:
:func:`.problem.contact_specs`) are those of the serial run.

* :class:`DistributedBulk`: K as the contact solver reads it, this rank's local (subdomain) entries in global
  numbering; the ranks' parts sum to K.
* :class:`SummedOperator`: the saddle-point matrix-vector product of the Newton loop (its residuals), the local
  product with K summed over the ranks.
* :class:`PetscSaddle`: the Newton-step systems solved by PETSc's GMRES on the workers' communicator (rank 0
  holds no elements and waits), right preconditioned with the augmented-Lagrangian block preconditioner of
  :mod:`.krylov` (z_lam = D~^-1 v_lam, z_u = S^-1 (v_u - C z_lam), S = K - C D~^-1 R), S^-1 one cycle of GAMG
  with the rigid-body near-null space. Rows and columns of the fixed unknowns (Dirichlet dofs, fixed multipliers)
  are identity rows; the system is scaled so that every row is a force (the multiplier rows by their c), as the
  serial GMRES is, with the same stopping test (the scaled residual below tol times the Newton step's reference).
"""

from __future__ import annotations

import math
import time

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .. import parallel
from ..errors import SolverError
from ..linalg.petsc import petsc_module, rigid_modes, vertex_coordinates, workers
from .krylov import RESTART, KrylovStats, block_inverse
from .steps import SPARSE_SHIFT, KrylovSteps, NewtonSteps, free_motions, multiplier_scaling

GMRES_TOL = 1e-10
"""Default relative residual of the distributed Newton-step solves (as the serial GMRES)."""


class DistributedBulk:
    """The bulk matrix K of a contact solve on a distributed mesh (``mat``: NGSolve's parallel matrix of the
    displacement space numbered by ``dofs``, a :class:`~ngs_geomech.parallel.GlobalDofs`): this rank's local
    entries in global numbering (COO ``kr``, ``kc``, ``kv`` in the storage order of ``matrix``, an NGSolve sparse
    matrix of the global size), and the same as a scipy CSR matrix."""

    def __init__(self, mat, dofs):
        local = mat.local_mat if parallel.distributed(dofs.mesh) else mat
        r, c, v = (np.asarray(a) for a in local.COO())
        n = dofs.size
        glob = ngs.la.SparseMatrixd.CreateFromCOO(dofs.vector[r.astype(np.int64)], dofs.vector[c.astype(np.int64)],
                                                  np.asarray(v, dtype=float), n, n)
        kr, kc, kv = (np.asarray(a) for a in glob.COO())
        self.kr, self.kc, self.kv = kr.astype(np.int64), kc.astype(np.int64), np.array(kv, dtype=float)
        self.matrix = glob
        self.csr = sp.csr_matrix((self.kv, (self.kr, self.kc)), shape=(n, n))
        self.dofs = dofs
        self.mesh = dofs.mesh

    @staticmethod
    def newton_steps(tol: float | None, maxit: int) -> DistributedKrylovSteps:
        """The Newton-step strategy of a solve with this bulk (:func:`.steps.newton_steps`)."""
        return DistributedKrylovSteps(tol, maxit)


class SummedOperator(ngs.BaseMatrix):
    """The saddle-point matrix of a distributed contact solve as an operator on replicated vectors (size N): the
    multiplier entries and the shift of the pattern (the same on every rank) plus K, the sum of the ranks' parts
    (one reduction of n numbers per product). Every rank computes the same numbers in the same order, so the
    replicated Newton loop takes the same decisions everywhere (a product with this rank's pattern minus its own
    K part differed between the ranks by round-off, and the ranks' active sets parted)."""

    def __init__(self, s, bulk: DistributedBulk):
        super().__init__()
        self.s, self.bulk, self.n, self.N = s, bulk, s.n, s.N
        self.nk = len(bulk.kr)
        self.counts: dict = {}
        """The time (s) and number of values of the reductions (ContactInfo.communication)."""

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.N

    def Width(self) -> int:
        return self.N

    def CreateRowVector(self):
        return self.s.pattern.matrix.CreateRowVector()

    def CreateColVector(self):
        return self.s.pattern.matrix.CreateColVector()

    def Mult(self, x, y) -> None:
        pat, n, nk, s = self.s.pattern, self.n, self.nk, self.s
        xs = x.FV().NumPy()
        extra = sp.csr_matrix((pat.values[nk:], (pat.rows[nk:], pat.cols[nk:])), shape=(self.N, self.N))
        out = extra @ xs
        kx = self.bulk.csr @ xs[:n]
        tic = time.perf_counter()
        out[:n] += parallel.allsum(self.bulk.mesh, kx)
        self.counts["reduce_s"] = self.counts.get("reduce_s", 0.0) + time.perf_counter() - tic
        self.counts["reduced_values"] = self.counts.get("reduced_values", 0) + n
        if len(s.reg_dofs):
            out[s.reg_dofs] += s.eps * xs[s.reg_dofs]
        y.FV().NumPy()[:] = out


class DistributedKrylovSteps(NewtonSteps):
    """The Newton steps of a contact solve on a distributed mesh (:func:`.steps.newton_steps` picks it for a
    :class:`DistributedBulk`): PETSc's GMRES with the augmented-Lagrangian GAMG preconditioner
    (:class:`PetscSaddle`); the rigid motions no row holds are kept out of the iterates as in the serial Krylov
    steps."""

    shift = SPARSE_SHIFT

    def __init__(self, tol: float | None, maxit: int):
        self.tol, self.maxit = tol or GMRES_TOL, maxit
        self.saddle = None

    @staticmethod
    def bulk_coo(matrix):
        return matrix.kr, matrix.kc, matrix.kv

    @staticmethod
    def diagonal(matrix, n: int, kr, kc, kv) -> np.ndarray:
        diag = np.zeros(n)
        np.add.at(diag, kr[kr == kc], kv[kr == kc])
        return parallel.allsum(matrix.mesh, diag)

    @staticmethod
    def pattern_bulk(matrix):
        return matrix.matrix

    def operator(self, s, matrix):
        self.saddle = PetscSaddle(s, matrix, self.tol, self.maxit)
        self.tol_floor = 100.0 * self.tol
        op = SummedOperator(s, matrix)
        op.counts = s.info.communication         # the solve's record of reductions and gathers
        self.saddle.counts = s.info.communication
        return op

    def step(self, s, b: np.ndarray, it_nr: int):
        return DistributedStep(self.saddle, s, b, f"{s.what}, iteration {it_nr}")

    project = staticmethod(KrylovSteps.project)


class DistributedStep:
    """A Newton step solved by :class:`PetscSaddle` with the preconditioner of the current matrix; the tolerance is
    relative to the step's right-hand side ``b`` (or the first residual when larger), as :class:`.steps.KrylovStep`."""

    usable = True
    exact = True

    def __init__(self, saddle: PetscSaddle, s, b: np.ndarray, what: str):
        self.saddle, self.what, self.info = saddle, what, s.info
        M = s.pattern.csr()
        self.free_motions = free_motions(s.rigid, M, s.n)
        saddle.set_matrix(s, M, self.free_motions)
        self.info.amg_setups = saddle.stats.amg_setups
        self.ref = saddle.reference(b)
        self.first = True

    def apply(self, r, dx) -> bool:
        ra = np.array(r.FV().NumPy())
        if self.first:
            self.ref = max(self.ref, self.saddle.reference(ra))
            self.first = False
        dx.FV().NumPy()[:] = self.saddle.solve(ra, self.ref, self.what)
        self.info.gmres_iterations.append(self.saddle.stats.iterations[-1])
        return True


class PetscSaddle:
    """PETSc's GMRES with the augmented-Lagrangian GAMG preconditioner for the Newton-step systems of one contact
    solve on a distributed mesh (module docstring). PETSc numbers the displacement dofs node by node (component c
    of global scalar dof g: 3 g + c in 3D), each worker owning its master dofs' rows; the multipliers follow, owned
    by the last worker. ``s``: the solve's :class:`.steps.NewtonSystem`; ``bulk``: its :class:`DistributedBulk`."""

    def __init__(self, s, bulk: DistributedBulk, tol: float, maxit: int):
        self.n, self.N, self.tol, self.maxit = s.n, s.N, tol, maxit
        self.bulk, self.dofs, self.mesh = bulk, bulk.dofs, bulk.mesh
        self.world = parallel.comm(self.mesh)
        self.stats = KrylovStats()
        scale, self.diag_aug, self.node_blocks = multiplier_scaling(s)
        self.scale = np.concatenate([np.ones(s.n), scale])
        self.free = np.asarray(s.freemask, dtype=bool)
        petsc_module()          # PETSc initializes collectively over all ranks: every rank imports it here
        if self.world is not None:
            self.sub = workers(self.world)
        else:
            from mpi4py import MPI

            self.sub = MPI.COMM_SELF
        self._ksp = None
        self._free_q = self._free_q_all = None
        self._pattern = None
        self.counts: dict = {}
        if self.sub is not None:
            self._layout()

    # -- numbering ---------------------------------------------------------------------------------------------
    def _layout(self) -> None:
        """The PETSc number of every global unknown (``perm``), this rank's owned PETSc rows and, for each, the
        global unknown it holds (``own``)."""
        dofs, n, N = self.dofs, self.n, self.N
        bs, ns = dofs.components, dofs.n_scalar
        idx = np.arange(n)
        self.perm = np.concatenate([bs * (idx % ns) + idx // ns, np.arange(n, N)]).astype(np.int64)
        mine = np.sort(dofs.scalar[dofs.master])
        counts = self.sub.allgather(len(mine))
        first = sum(counts[:self.sub.rank])
        if len(mine) and not np.array_equal(mine, np.arange(first, first + len(mine))):
            raise AssertionError("distributed contact: a rank's master dofs are not one contiguous global range")
        last = self.sub.rank == self.sub.size - 1
        rows_u = bs * first + np.arange(bs * len(mine))
        self.rows = np.concatenate([rows_u, np.arange(n, N) if last else np.zeros(0, dtype=np.int64)])
        inv = np.empty(N, dtype=np.int64)
        inv[self.perm] = np.arange(N)
        self.perm_inverse = inv
        """The global unknown of each PETSc number (PETSc's vector in rank order is the global vector permuted)."""
        self.own = inv[self.rows]
        self.n_own_u, self.last = len(rows_u), last
        self.own_u = self.own[:self.n_own_u]

    # -- matrices ----------------------------------------------------------------------------------------------
    def set_matrix(self, s, M: sp.csr_matrix, free_q: np.ndarray | None) -> None:
        """Build the PETSc matrix of the Newton-step matrix (the pattern of ``s``, and ``M``: the same as scipy CSR)
        and the preconditioner; ``free_q``: the rigid motions no row holds (orthonormal, n x k) or None."""
        if self.sub is None:
            return
        tic = time.perf_counter()
        PETSc = petsc_module()
        N, f = self.N, self.free
        pat = s.pattern
        nk = len(self.bulk.kr)
        r, c, v = pat.rows, pat.cols, pat.values.copy()
        # this rank's K entries (unshifted); the shift and the multiplier entries (the same on every rank) once
        if self.sub.rank != 0:
            v[:nk] = self.bulk.kv
            v[nk:] = 0.0
        v[~(f[r] & f[c])] = 0.0
        # the fixed unknowns: identity rows, from the rank owning the row
        r = np.concatenate([r, self.own])
        c = np.concatenate([c, self.own])
        v = np.concatenate([v, np.where(f[self.own], 0.0, 1.0)])
        v *= self.scale[r]
        self._A = self._coo_matrix(PETSc, "A", r, c, v, N, len(self.rows))
        self._free_q = None if free_q is None else free_q[self.own_u]
        self._free_q_all = free_q
        self._schur(PETSc, s, M)
        self.stats.setup_s += time.perf_counter() - tic

    def _coo_matrix(self, PETSc, key: str, r, c, v, size: int, local: int):
        """A PETSc AIJ matrix of the COO entries (global unknowns ``r``, ``c``; PETSc numbering by ``perm``), its
        pattern kept for the next matrix with the same entries."""
        pr, pc = self.perm[r], self.perm[c]
        cache = self._pattern if isinstance(self._pattern, dict) else {}
        sig = (len(r), hash(pr[:: max(1, len(pr) // 997)].tobytes()), hash(pc[:: max(1, len(pc) // 997)].tobytes()))
        mat = cache.get(key)
        from mpi4py import MPI

        # a new pattern on any rank (the augmentation's entries follow the sets, on one rank) is built by all
        if self.sub.allreduce(int(mat is None or mat[0] != sig), op=MPI.MAX):
            A = PETSc.Mat().create(comm=self.sub)
            A.setSizes(((local, size), (local, size)))
            A.setType(PETSc.Mat.Type.AIJ)
            A.setPreallocationCOO(pr.astype(PETSc.IntType), pc.astype(PETSc.IntType))
            cache[key] = mat = (sig, A)
            self._pattern = cache
        mat[1].setValuesCOO(v, addv=PETSc.InsertMode.INSERT_VALUES)
        return mat[1]

    def _schur(self, PETSc, s, M: sp.csr_matrix) -> None:
        """S = K - C D~^-1 R on the free unknowns (the fixed: identity rows), its GAMG; C, D~^-1 for the
        preconditioner's multiplier part."""
        n, f = self.n, self.free
        fu, fl = f[:n].astype(float), f[n:].astype(float)
        D = M[n:, n:].tocsr()
        d = D.diagonal()
        D = D.tolil()
        D.setdiag(np.where(d == 0.0, self.diag_aug, d))
        Dinv = block_inverse(D.tocsr(), self.node_blocks)
        Dinv = sp.diags(fl) @ Dinv @ sp.diags(fl) + sp.diags(1.0 - fl)       # fixed multipliers: identity
        C = sp.diags(fu) @ M[:n, n:] @ sp.diags(fl)
        R = sp.diags(fl) @ M[n:, :n] @ sp.diags(fu)
        self.Dinv, self.C_own = Dinv.tocsr(), C.tocsr()[self.own_u]
        aug = (-(C @ Dinv @ R)).tocoo() if self.sub.rank == 0 else sp.coo_matrix((n, n))
        Kc = self.bulk.csr.tocoo()
        kv = np.array(Kc.data)
        kv[~(f[Kc.row] & f[Kc.col])] = 0.0
        r = np.concatenate([Kc.row, aug.row, self.own_u]).astype(np.int64)
        c = np.concatenate([Kc.col, aug.col, self.own_u]).astype(np.int64)
        shift = np.zeros(n)
        if len(s.reg_dofs):
            shift[s.reg_dofs] = s.eps
        v = np.concatenate([kv, aug.data, np.where(f[self.own_u], shift[self.own_u], 1.0)])
        self._S = self._coo_matrix(PETSc, "S", r, c, v, n, self.n_own_u)
        self._S.setBlockSize(self.dofs.components)
        self._setup_ksp(PETSc)


    def _near_null_space(self, PETSc):
        """The rigid-body motions on S's rows (vertex dofs from the vertex coordinates, zero elsewhere),
        orthonormalized over the workers."""
        dofs, ns = self.dofs, self.dofs.n_scalar
        xyz = vertex_coordinates(self.mesh)
        modes = rigid_modes(xyz)
        local_of = np.full(ns, -1, dtype=np.int64)
        local_of[dofs.scalar] = np.arange(len(dofs.scalar))
        comp, scal = self.own_u // ns, local_of[self.own_u % ns]
        vertex = (scal >= 0) & (scal < len(xyz))
        vecs = []
        for k in range(modes.shape[2]):
            vals = np.zeros(self.n_own_u)
            vals[vertex] = modes[scal[vertex], comp[vertex], k]
            w = self._S.createVecRight()
            w.setArray(vals)
            for w0 in vecs:
                w.axpy(-w.dot(w0), w0)
            w.normalize()
            vecs.append(w)
        return PETSc.NullSpace().create(vectors=vecs, comm=self.sub)

    def _setup_ksp(self, PETSc) -> None:
        """The outer GMRES (right preconditioned by :meth:`apply`) and the GAMG of S, built anew for each S."""
        fresh = self._ksp is None
        if fresh:
            opts = PETSc.Options(S_PREFIX)
            for key, value in S_OPTIONS.items():
                opts[key] = value
            self._ksp_s = PETSc.KSP().create(comm=self.sub)
            self._ksp_s.setOptionsPrefix(S_PREFIX)
            ksp = PETSc.KSP().create(comm=self.sub)
            ksp.setType("gmres")
            ksp.setGMRESRestart(RESTART)
            ksp.setPCSide(PETSc.PC.Side.RIGHT)
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            pc = ksp.getPC()
            pc.setType("python")
            pc.setPythonContext(self)
            self._ksp = ksp
            ksp.setFromOptions()  # DEBUG
            self._S.setNearNullSpace(self._near_null_space(PETSc))
        self._ksp_s.setOperators(self._S)
        self._ksp_s.setFromOptions()
        self._ksp_s.setUp()
        if self._free_q is None:
            self._ksp.setOperators(self._A)
        else:                               # GMRES on Q A: the residual's part along q is not the step's
            op = PETSc.Mat().createPython(self._A.getSizes(), _Projected(self._A, self._free_q, self.sub),
                                          comm=self.sub)
            op.setUp()
            self._ksp.setOperators(op, self._A)
        self._w_u, self._z_u = self._S.createVecs()
        self.stats.amg_setups += fresh

    def apply(self, pc, x, y) -> None:
        """The preconditioner y = P^-1 x on the scaled system (PETSc's python preconditioner): z_lam = D~^-1 v_lam,
        z_u = Q S^-1 Q (v_u - C z_lam), v = x / scale, Q the projection orthogonal to the free rigid motions."""
        xa = x.getArray(readonly=True) / self.scale[self.own]
        nu = self.n_own_u
        v_l = self.sub.bcast(xa[nu:] if self.last else None, root=self.sub.size - 1)
        z_l = self.Dinv @ v_l
        w_u = xa[:nu] - self.C_own @ z_l
        if self._free_q is not None:        # S q = eps q: S^-1 would amplify w's part along q by 1 / eps
            w_u -= self._free_q @ self.sub.allreduce(self._free_q.T @ w_u)
        self._w_u.setArray(w_u)
        self._ksp_s.solve(self._w_u, self._z_u)
        z_u = self._z_u.getArray().copy()
        if self._free_q is not None:
            z_u -= self._free_q @ self.sub.allreduce(self._free_q.T @ z_u)
        y.setArray(np.concatenate([z_u, z_l if self.last else np.zeros(0)]))

    # -- the solve ---------------------------------------------------------------------------------------------
    def reference(self, b: np.ndarray) -> float:
        """The scaled norm of a Newton step's right-hand side b (N), the reference of the stopping test."""
        return float(np.linalg.norm(np.where(self.free, b * self.scale, 0.0)))

    def solve(self, r: np.ndarray, ref: float, what: str) -> np.ndarray:
        """The correction dx (N, replicated) with M dx = r on the free unknowns (r zero elsewhere) to ``tol`` x
        ``ref``; collective over the mesh's ranks."""
        tic = time.perf_counter()
        target = self.tol * max(ref, 1e-300)
        result = None
        if self.sub is not None:
            b = np.where(self.free, r * self.scale, 0.0)
            q = self._free_q_all
            if q is not None:       # r's force on the free rigid motions: rounding of the summed K x, no step
                b[:self.n] -= q @ (q.T @ b[:self.n])
            result = self._solve_workers(b, target)
        if self.world is not None:
            parallel.wait_polled(self.world)
            result = self.world.bcast(result, root=1)
        dx, its, res, costs = result
        reason = costs.pop("reason", 0)
        for key, value in costs.items():
            self.counts[key] = self.counts.get(key, 0) + value
        self.stats.iterations.append(its)
        self.stats.solve_s += time.perf_counter() - tic
        if not res <= target:
            raise SolverError(f"{what}: GMRES did not converge in {its} iterations (relative residual "
                              f"{res / max(ref, 1e-300):.1e}, tolerance {self.tol:.0e}; PETSc reason "
                              f"{_reason_name(reason)}); refine the mesh on the contact zone or change the "
                              "augmentation")
        return dx

    def _solve_workers(self, b_scaled: np.ndarray, target: float):
        if not math.isfinite(float(np.sum(b_scaled))):
            return np.zeros(self.N), 0, math.inf, {}
        tic = time.perf_counter()
        b = self._A.createVecRight()
        b.setArray(b_scaled[self.own])
        x = b.duplicate()
        x.set(0.0)
        norm = b.norm()
        its = 0
        if norm > target:
            # GMRES on b / |b|: its happy-breakdown test compares Krylov vectors' norms with an absolute 1e-30,
            # which right-hand sides of tiny norm (scaled newtons) reach before the tolerance
            b.scale(1.0 / norm)
            self._ksp.setTolerances(rtol=0.0, atol=target / norm, max_it=self.maxit)
            self._ksp.solve(b, x)
            x.scale(norm)
            its = self._ksp.getIterationNumber()
        res = self._ksp.getResidualNorm() * norm if its else norm
        reason = int(self._ksp.getConvergedReason()) if its else 0
        if reason < 0:
            res = max(res, 2.0 * target)
        gmres_s = time.perf_counter() - tic
        tic = time.perf_counter()
        parts = self.sub.allgather(x.getArray().copy())
        dx = np.zeros(self.N)
        dx[self.perm_inverse] = np.concatenate(parts)
        dx[~self.free] = 0.0
        costs = {"gmres_s": gmres_s, "gather_s": time.perf_counter() - tic, "gathered_values": self.N,
                 "setup_s": self.stats.setup_s, "reason": reason}
        self.stats.setup_s = 0.0
        return dx, its, res, costs


class _Projected:
    """PETSc's python matrix Q A of a Newton step with free rigid motions q (orthonormal; u rows this rank owns):
    A y less its part along q. Nothing holds q, so that part of a residual is no step's (the iterate is kept
    orthogonal to q, :meth:`.steps.KrylovSteps.project`); in A y it is the rounding of K's rows summed over the
    ranks, on which GMRES would stall."""

    def __init__(self, A, q: np.ndarray, comm):
        self.A, self.q, self.comm = A, q, comm

    def mult(self, mat, x, y) -> None:
        self.A.mult(x, y)
        a = y.getArray()
        nu = len(self.q)
        a[:nu] -= self.q @ self.comm.allreduce(self.q.T @ a[:nu])


def _reason_name(reason: int) -> str:
    """PETSc's name of a KSP converged reason (e.g. DIVERGED_BREAKDOWN), or its number without petsc4py."""
    try:
        names = {v: k for k, v in vars(petsc_module().KSP.ConvergedReason).items() if isinstance(v, int)}
    except Exception:                                     # noqa: BLE001 - the number is still a diagnosis
        names = {}
    return names.get(reason, str(reason))


S_PREFIX = "ngs_geomech_contact_s_"
S_OPTIONS = {"ksp_type": "preonly", "pc_type": "gamg", "pc_gamg_agg_nsmooths": 1, "pc_gamg_threshold": 0.01,
             "mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi"}
"""PETSc options of S's preconditioner in the Newton steps of a distributed contact solve: one cycle of smoothed
aggregation (the contact coupling through the augmentation makes S harder than K)."""
