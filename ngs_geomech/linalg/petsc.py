"""PETSc's conjugate gradients with algebraic multigrid (GAMG, aggregation with the rigid-body near-null space) for
the SPD heat and elasticity systems, serial or on a distributed mesh: the distributed preconditioner of the
package (NGSolve's ``h1amg`` takes no distributed matrix, and its BDDC is about twice as slow as the serial
two-level AMG; ``studies/distributed_contact``). Needs petsc4py (the optional extra ``petsc``).

The matrix is the assembled NGSolve matrix: on a distributed mesh each rank's local matrix (their sum is the global
matrix, PETSc's MATIS), converted to a parallel AIJ matrix. The components of a node are interleaved (block size =
the value dimension, as aggregation wants them; global node numbers from NGSolve's ``EnumerateGlobally``, whose
ranges are contiguous per rank, so each worker owns the rows of its master dofs). The rows and columns of the fixed
(Dirichlet) dofs are cleared but for their diagonal: the solve runs on the free dofs, with the same scaling.

The near-null space of a vector problem is the rigid-body motions (3 in 2D, 6 in 3D), set at the vertex dofs from
the vertex coordinates; NGSolve's H1 basis is hierarchical, so the higher-order dofs of a linear field are zero.
Aggregation is unsmoothed (``pc_gamg_agg_nsmooths 0``): at 513k P2 elastic dofs the smoothed variant halved the
iterations but its set-up cost more than the whole unsmoothed solve.

The PETSc objects live on the communicator of the **workers**: netgen keeps no elements on rank 0, and a rank 0
inside every PETSc reduction busy-waits in MPI and takes a core from the workers (on 2 cores, 2 workers were
2.7 times slower than one). Rank 0 waits in a polled barrier instead (:func:`wait_polled`) and receives the
iteration count from rank 1.

Convergence: the unpreconditioned residual below ``tol`` times the largest of |f|, |A x0| and the first residual
(the reference of :class:`~ngs_geomech.linalg.iterative.PCG`).
"""

from __future__ import annotations

import logging
import math
import time

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..parallel import wait_polled

KRYLOV = {"ksp_type": "cg", "ksp_norm_type": "unpreconditioned"}
"""PETSc options of the Krylov method (every solve)."""
ONE_LEVEL = {"pc_type": "gamg", "pc_gamg_agg_nsmooths": 0, "pc_gamg_threshold": 0.01,
             "mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi"}
"""PETSc options of the preconditioner of order 1: GAMG on the whole matrix."""
TWO_LEVEL = {"pc_type": "fieldsplit", "pc_fieldsplit_type": "additive", "fieldsplit_v_ksp_type": "preonly",
             "fieldsplit_v_pc_type": "gamg", "fieldsplit_v_pc_gamg_agg_nsmooths": 0,
             "fieldsplit_v_pc_gamg_threshold": 0.01, "fieldsplit_v_mg_levels_ksp_type": "chebyshev",
             "fieldsplit_v_mg_levels_pc_type": "jacobi", "fieldsplit_e_ksp_type": "preonly",
             "fieldsplit_e_pc_type": "jacobi"}
"""PETSc options of the preconditioner of order >= 2 (:meth:`GamgCG._two_level`)."""
PREFIX = {False: "ngs_geomech_amg_", True: "ngs_geomech_twolevel_"}
"""Options prefix of the two forms (each form's options apply to its solves only)."""

_SUBCOMMS: dict = {}
_log = logging.getLogger(__name__)


def available() -> bool:
    """Whether petsc4py can be imported (mpi4py first: PETSc then initializes on MPI's world)."""
    try:
        import mpi4py  # noqa: F401
        import petsc4py  # noqa: F401
    except ImportError:
        return False
    return True


def petsc_module():
    """petsc4py's PETSc (after mpi4py), or a SolverError naming the extra to install."""
    try:
        from mpi4py import MPI  # noqa: F401  (before PETSc: it takes the initialized MPI)
        from petsc4py import PETSc
    except ImportError as exc:
        raise SolverError("the preconditioner 'gamg' needs petsc4py: pip install -e '.[petsc]' "
                          "(see docs/install.md)") from exc
    return PETSc


def workers(comm):
    """The communicator of the ranks holding elements (all but rank 0) of the world communicator ``comm``, created
    once (collective over ``comm``); None on rank 0."""
    key = id(comm)
    if key not in _SUBCOMMS:
        from mpi4py import MPI

        _SUBCOMMS[key] = comm.Split(0 if comm.rank > 0 else MPI.UNDEFINED, comm.rank)
    sub = _SUBCOMMS[key]
    return None if sub == _null_comm() else sub


def _null_comm():
    from mpi4py import MPI

    return MPI.COMM_NULL


def rigid_modes(xyz: np.ndarray) -> np.ndarray:
    """(nv, dim, modes) values of the rigid-body motions at the vertices ``xyz`` (nv, dim), m: dim translations and
    1 (2D) or 3 (3D) rotations about the origin (the same field on every rank; orthonormalized later)."""
    nv, dim = xyz.shape
    modes = [np.tile(np.eye(dim)[k], (nv, 1)) for k in range(dim)]
    x = xyz
    if dim == 2:
        modes.append(np.column_stack([-x[:, 1], x[:, 0]]))
    else:
        zero = np.zeros(nv)
        modes += [np.column_stack([-x[:, 1], x[:, 0], zero]), np.column_stack([zero, -x[:, 2], x[:, 1]]),
                  np.column_stack([x[:, 2], zero, -x[:, 0]])]
    return np.stack(modes, axis=2)


def vertex_coordinates(mesh) -> np.ndarray:
    """(nv, dim) coordinates of this part's vertices, m."""
    if mesh.nv == 0:
        return np.zeros((0, mesh.dim))
    xyz = np.asarray(mesh.ngmesh.Coordinates(), dtype=float)
    if len(xyz) != mesh.nv:
        xyz = np.array([v.point for v in mesh.vertices], dtype=float)
    return xyz[:, :mesh.dim]


class GamgCG:
    """CG with GAMG on one assembled form on ``space`` (H1 or VectorH1; module docstring): :meth:`solve` takes the
    arguments of :meth:`~ngs_geomech.linalg.iterative.PCG.solve` without the preconditioner, is collective over the
    mesh's ranks, and builds the PETSc matrix and multigrid at the first solve after :meth:`update`."""

    def __init__(self, space, vector: bool, tol: float, maxit: int):
        self.space = space
        self.bs = len(space.components) if vector else 1
        self.tol, self.maxit = tol, maxit
        mesh = space.mesh
        self.world = mesh.comm.mpi4py if mesh.comm.size > 1 else None
        self._layout = None
        self._ksp = None
        self._pattern = None
        self.setup_s = 0.0
        """Time of the last set-up (matrix conversion and multigrid), s."""

    def update(self) -> None:
        """The form was re-assembled: the next solve converts its matrix and rebuilds the multigrid."""
        self._ksp = None

    # -- numbering -------------------------------------------------------------------------------------------------
    def _build_layout(self) -> None:
        """Global indices (node-interleaved) of the local dofs, the scatter between a rank's dofs and the global
        vector, and the fixed-dof mask (collective over the mesh's ranks)."""
        PETSc = petsc_module()
        space, bs = self.space, self.bs
        comp = space.components[0] if bs > 1 else space
        nc = comp.ndof
        if space.ndof != bs * nc:
            raise AssertionError("GAMG: the vector space's components differ in size")
        if self.world is not None:
            glob, nglob = comp.ParallelDofs().EnumerateGlobally(None)
            glob = np.asarray(glob, dtype=np.int64)
            master = np.array(list(comp.ParallelDofs().MasterDofs()), dtype=bool) if nc else np.zeros(0, bool)
            owned = int(np.count_nonzero(master))
            sub = workers(self.world)
        else:
            glob, nglob, sub = np.arange(nc, dtype=np.int64), nc, PETSc.COMM_SELF
            master = np.ones(nc, dtype=bool)
            owned = nc
        self._sub = sub
        free = np.array(list(space.FreeDofs()), dtype=bool)
        # NGSolve orders a vector space by component (dof k * nc + i); PETSc gets node i's components together
        gidx = (bs * np.tile(glob, bs) + np.repeat(np.arange(bs), nc)).astype(PETSc.IntType)
        nv = space.mesh.nv
        # the owned rows of the vertex dofs (NGSolve numbers a component's vertex dofs first): the P1 part
        vertex_rows = np.sort(bs * glob[:nv][master[:nv]][:, None] + np.arange(bs)[None, :], axis=None)
        self._layout = dict(nc=nc, nglob=int(nglob), owned=owned, free=free, gidx=gidx,
                            vertex_rows=vertex_rows.astype(PETSc.IntType), higher=nc > nv)
        if sub is None:
            return
        n_own, n_glob = bs * owned, bs * int(nglob)
        self._gvec = PETSc.Vec().create(comm=sub)
        self._gvec.setSizes((n_own, n_glob), bsize=bs)
        self._gvec.setUp()
        self._lvec = PETSc.Vec().createSeq(space.ndof, comm=PETSc.COMM_SELF)
        iglob = PETSc.IS().createGeneral(gidx, comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(self._lvec, None, self._gvec, iglob)
        self._lgmap = PETSc.LGMap().create(gidx, comm=sub)

    def _to_petsc(self, local: np.ndarray):
        """A rank's distributed values (numpy, NGSolve order; fixed dofs zeroed) summed into a new global vector."""
        PETSc = petsc_module()
        out = self._gvec.duplicate()
        out.set(0.0)
        vals = np.where(self._layout["free"], local, 0.0)
        self._lvec.setArray(vals)
        self._scatter.scatter(self._lvec, out, addv=PETSc.InsertMode.ADD_VALUES, mode=PETSc.ScatterMode.FORWARD)
        return out

    def _to_local(self, gvec) -> np.ndarray:
        PETSc = petsc_module()
        self._lvec.set(0.0)
        self._scatter.scatter(gvec, self._lvec, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.REVERSE)
        return self._lvec.getArray().copy()

    # -- matrix and multigrid -------------------------------------------------------------------------------------
    def _build_solver(self, mat) -> None:
        """The global AIJ matrix of ``mat`` (fixed rows and columns cleared but their diagonal), its near-null
        space and the KSP (workers only). The matrix is assembled from the ranks' local entries in PETSc's
        coordinate format (off-rank entries summed); its pattern is kept, so a re-assembled form (a Newton step,
        a new time step size) only sends new values."""
        PETSc = petsc_module()
        tic = time.perf_counter()
        lay = self._layout
        local = mat.local_mat if self.world is not None else mat
        vals, cols, ptr = local.CSR()
        vals, cols, ptr = np.array(vals, dtype=float), np.asarray(cols, dtype=np.int64), np.asarray(ptr, dtype=np.int64)
        n = local.height
        pattern = (n, len(vals), int(ptr[-1]), hash(cols[:: max(1, len(cols) // 1000)].tobytes()))
        if getattr(self, "_pattern", None) != pattern:
            rows = np.repeat(np.arange(n), np.diff(ptr))
            fixed = ~lay["free"]
            self._clear = (fixed[rows] | fixed[cols]) & (rows != cols)
            gidx = lay["gidx"]
            n_own, n_glob = self.bs * lay["owned"], self.bs * lay["nglob"]
            A = PETSc.Mat().create(comm=self._sub)
            A.setSizes(((n_own, n_glob), (n_own, n_glob)), bsize=self.bs)
            A.setType(PETSc.Mat.Type.AIJ)
            A.setPreallocationCOO(gidx[rows], gidx[cols])
            if self.bs > 1:
                A.setNearNullSpace(self._near_null_space())
            self._A, self._pattern, self._ksp_obj = A, pattern, None
        vals[self._clear] = 0.0
        self._A.setValuesCOO(vals, addv=PETSc.InsertMode.INSERT_VALUES)
        matrix_s = time.perf_counter() - tic
        if self._ksp_obj is None:
            two_level = self._layout["higher"]
            opts = PETSc.Options(PREFIX[two_level])
            for key, value in {**KRYLOV, **(TWO_LEVEL if two_level else ONE_LEVEL)}.items():
                opts[key] = value
            ksp = PETSc.KSP().create(comm=self._sub)
            ksp.setOptionsPrefix(PREFIX[two_level])
            ksp.setOperators(self._A)
            if two_level:
                self._two_level(ksp)
            ksp.setFromOptions()
            ksp.setConvergenceHistory(length=self.maxit + 2)
            self._ksp_obj = ksp
        else:
            self._ksp_obj.setOperators(self._A)
        self._ksp_obj.setUp()
        self._ksp = self._ksp_obj
        self.setup_s = time.perf_counter() - tic
        _log.debug("GAMG set-up: matrix %.2f s, preconditioner %.2f s", matrix_s, self.setup_s - matrix_s)

    def _two_level(self, ksp) -> None:
        """Order >= 2: an additive field split, GAMG on the vertex (P1) block and Jacobi on the higher-order dofs:
        the two-level preconditioner of :mod:`.iterative` with PETSc's AMG on its P1 part."""
        PETSc = petsc_module()
        lay = self._layout
        lo, hi = self._A.getOwnershipRange()
        rows = np.arange(lo, hi, dtype=PETSc.IntType)
        is_v = PETSc.IS().createGeneral(lay["vertex_rows"], comm=self._sub)
        is_e = PETSc.IS().createGeneral(np.setdiff1d(rows, lay["vertex_rows"]).astype(PETSc.IntType), comm=self._sub)
        is_v.setBlockSize(self.bs)
        if self.bs > 1:
            ns = self._A.getNearNullSpace()
            vecs = []
            for w in ns.getVecs():
                sub_w = w.getSubVector(is_v)
                c = sub_w.copy()
                w.restoreSubVector(is_v, sub_w)
                for w0 in vecs:
                    c.axpy(-c.dot(w0), w0)
                c.normalize()
                vecs.append(c)
            is_v.compose("nearnullspace", PETSc.NullSpace().create(vectors=vecs, comm=self._sub))
        pc = ksp.getPC()
        pc.setType("fieldsplit")
        pc.setFieldSplitIS(("v", is_v), ("e", is_e))

    def _near_null_space(self):
        """The rigid-body motions at the vertex dofs (zero elsewhere), orthonormalized over the ranks."""
        PETSc = petsc_module()
        mesh, nc, bs = self.space.mesh, self._layout["nc"], self.bs
        xyz = vertex_coordinates(mesh)
        modes = rigid_modes(xyz)
        vecs = []
        for m in range(modes.shape[2]):
            local = np.zeros(bs * nc)
            for k in range(bs):
                local[k * nc:k * nc + len(xyz)] = modes[:, k, m]
            gv = self._gvec.duplicate()
            gv.set(0.0)
            self._lvec.setArray(local)
            self._scatter.scatter(self._lvec, gv, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.FORWARD)
            for w in vecs:
                gv.axpy(-gv.dot(w), w)
            gv.normalize()
            vecs.append(gv)
        return PETSc.NullSpace().create(vectors=vecs, comm=self._sub)

    # -- the solve -------------------------------------------------------------------------------------------------
    def solve(self, mat, rhs, x, what: str, hint: str = ""):
        """Solve ``mat`` x = ``rhs`` on the free dofs (x's fixed values kept), collective; returns the iterations,
        the final relative residual and its history."""
        if self._layout is None:
            self._build_layout()
        r, ax = rhs.CreateVector(), rhs.CreateVector()
        ax.data = mat * x
        r.data = rhs - ax
        result = None
        if self._sub is not None:
            result = self._solve_workers(mat, _distributed_local(rhs), _distributed_local(ax), _distributed_local(r),
                                         x)
        if self.world is not None:
            wait_polled(self.world)
            result = self.world.bcast(result, root=1)
            x.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)
        its, res, history, reason = result
        hint = f" {hint}" if hint else ""
        if reason < 0:
            why = _REASONS.get(reason, f"reason {reason}")
            raise SolverError(f"{what}: PETSc CG with GAMG stopped after {its} iterations ({why}, relative residual "
                              f"{res:.3e}, tolerance {self.tol:.1e}).{hint}")
        return its, res, history

    def _solve_workers(self, mat, f_loc, ax_loc, r_loc, x):
        if self._ksp is None:
            self._build_solver(mat)
        b = self._to_petsc(r_loc)
        ref = max(self._to_petsc(f_loc).norm(), self._to_petsc(ax_loc).norm(), b.norm())
        if not math.isfinite(ref):
            return 0, math.inf, [], -4
        self._ksp.setTolerances(rtol=self.tol, atol=self.tol * ref, max_it=self.maxit)
        dx = b.duplicate()
        dx.set(0.0)
        self._ksp.solve(b, dx)
        its = self._ksp.getIterationNumber()
        reason = int(self._ksp.getConvergedReason())
        hist = [float(h) / ref if ref > 0 else 0.0 for h in self._ksp.getConvergenceHistory()]
        if reason >= 0:
            x.FV().NumPy()[:] += self._to_local(dx)
        return its, (hist[-1] if hist else 0.0), hist, reason


_REASONS = {-3: "iteration limit", -4: "diverged: the residual grew", -5: "breakdown", -7: "the matrix is not "
            "symmetric", -8: "the preconditioner is not positive definite", -9: "the residual is not finite",
            -10: "the matrix is not positive definite (a rigid motion without supports?)",
            -11: "the preconditioner's set-up failed"}
"""PETSc's KSPConvergedReason codes of divergence, in words."""


def _distributed_local(vec) -> np.ndarray:
    """This rank's entries of ``vec`` in the distributed sense (a cumulated vector distributed first: the ranks'
    entries then sum to the global value)."""
    status = vec.GetParallelStatus() if hasattr(vec, "GetParallelStatus") else None
    if status == ngs.la.PARALLEL_STATUS.CUMULATED:
        w = vec.CreateVector()
        w.data = vec
        w.Distribute()
        return w.FV().NumPy().copy()
    return vec.FV().NumPy().copy()
