"""Iterative solves of the contact Newton steps: the saddle-point systems of
:class:`ngs_geomech.contact.solver.ContactSolver` solved by GMRES with an augmented-Lagrangian block
preconditioner and algebraic multigrid, for contact problems too large for a direct factorization (3D).

The Newton-step matrix of the semi-smooth Newton / active-set iteration (module docstring of
:mod:`.contact`) has the blocks

    M = [[K, C], [R, D]],    C = -[Bn^T, Bt^T (, Bt2^T)],   R: the constraint rows,   D: the multiplier block,

K the elastic stiffness (N/m), the multipliers in Pa. An exact constraint row (a node in contact: -Bn u = g0,
a sticking node: -Bt u = 0) has a zero diagonal in D. The preconditioner is the block upper triangular

    P = [[S, C], [0, D~]],    D~ = D with each zero diagonal replaced by -w_j / c_j,    S = K - C D~^-1 R,

(w_j the nodal weight, c_j the augmentation of the row, Pa/m: the same scale as the penalty rows), i.e. the
augmented-Lagrangian preconditioner of Benzi and Olshanskii (SIAM J. Sci. Comput. 28 (2006)) with the
augmentation c: S is K plus the penalty c B^T W^-1 B of the constrained rows (K + c Bn^T W^-1 Bn for the
nodes in contact), and with S inverted exactly the eigenvalues of M P^-1 on the exact rows are
c s / (1 + c s) for the eigenvalues s of the Schur complement B K^-1 B^T W^-1: in [1/2, 1) whenever
c >= 1 / s_min, which the default augmentation c = E / h ensures on every mesh (s_min ~ h / E): the GMRES
iterations do not grow under refinement. D~ is block diagonal, one block per multiplier node (1 x 1 frictionless,
2 x 2 / 3 x 3 with friction: the Coulomb coupling lam_t <- lam_n and the 3D slip rows), inverted exactly.

S^-1 is replaced by one V-cycle of smoothed-aggregation AMG (PyAMG) built on the symmetric part of S with the
rigid motions as near-null space, on the vertex (P1) dofs, in node-interleaved blocks; for order >= 2 a two-level
cycle with symmetric Gauss-Seidel on all dofs around the AMG of the vertex block (NGSolve's hierarchical basis:
the vertex dofs span P1). The AMG hierarchy is built once per contact solve and its coarse operators are formed
again from each Newton step's S (:class:`_TwoLevelAMG`). AMG sees the contact coupling between the bodies through
the penalty part of S, so a body held only by contact is no harder than a supported one. NGSolve's own AMG
(``h1amg``) is built from element matrices and cannot see that coupling, hence PyAMG on the assembled S.

Measured (``studies/scaling``, the 3D Coulomb punch of
:func:`ngs_geomech.verification.contact_problems.punch_3d`, one thread): GMRES iterations per Newton
step, max (mean of the main solves), and the contact solve's wall time against the direct solves:

    P1  h = 0.2 / 0.1 / 0.05 / 0.025:  663 / 3.5k / 19k / 121k dofs, GMRES 41 (24) / 43 (29) / 52 (39) / 90 (55),
        0.6 / 2.3 / 13.9 / 177 s; direct 0.2 / 1.1 / 60 s (not run at 121k)
    P2  h = 0.2 / 0.1 / 0.05:          3.8k / 22k / 130k dofs, GMRES 54 / 51 / 99 (one step; the others 41 - 60),
        0.9 / 6.3 / 67.5 s; direct 0.7 / 8.1 / 399 s (5.8 GB resident)

The same sets and solutions as the direct solves (largest relative difference of u, lam_n, lam_t 7e-10). The
iterations grow slowly under refinement (P1: the smoothed-aggregation AMG's own CG count on the first step's S
goes 13 / 17 / 21 from 3k to 115k dofs); P2's main solves stay at 41 - 60.

GMRES is scipy's (``scipy.sparse.linalg.gmres``, restarted), right preconditioned, on the system scaled so that
every row is a force (N): the multiplier rows (m^3 in 3D, m^2 in 2D) times their c. It stops when the scaled
residual falls below ``tol`` times the reference (the scaled right-hand side of the Newton step). Units: u m,
multipliers Pa. Right preconditioning on scipy's GMRES costs one preconditioner application per restart cycle for
its true-residual check (measured on the punch, one thread: the same iterations and solutions to 1e-14 as a
flexible GMRES that keeps the preconditioned vectors, 5 % more GMRES time, 1 % more contact-solve time).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from ..linalg.iterative import vertex_dofs

DEFAULT_TOL = 1e-10
"""Relative residual (scaled, Euclidean) at which GMRES stops."""

RESTART = 60
"""GMRES restart length (Krylov vectors kept)."""


def near_null_space(forms) -> tuple[np.ndarray, np.ndarray, int]:
    """What the AMG needs of the elastic problem ``forms`` (:class:`ngs_geomech.mechanics.forms.ElasticForms`):
    its rigid motions as vectors of V (:meth:`~ngs_geomech.mechanics.forms.ElasticForms.rigid_mode_vectors`),
    the bool mask of V's vertex dofs (:func:`.iterative.vertex_dofs`) and the mesh dimension."""
    V = forms.V
    vertex = np.zeros(V.ndof, dtype=bool)
    vertex[vertex_dofs(V, "iterative contact solver").ravel()] = True
    return forms.rigid_mode_vectors(), vertex, V.mesh.dim


@dataclass
class KrylovStats:
    """Iterations of the GMRES solves of one contact solve, and the set-up and solve times (s)."""

    iterations: list = field(default_factory=list)
    amg_setups: int = 0
    """AMG hierarchies built (aggregation and prolongators; the later Newton steps only refresh the operators)."""
    setup_s: float = 0.0
    solve_s: float = 0.0


class SaddleKrylov:
    """GMRES with the augmented-Lagrangian AMG preconditioner (module docstring) for the Newton-step matrices of
    one contact solve. ``n``: displacement dofs; ``free``: bool over all N unknowns (Dirichlet dofs and unused
    multipliers excluded); ``row_scale``: c per multiplier row (Pa/m, N - n); ``diag_aug``: the -w / c that
    replaces a zero multiplier diagonal (N - n); ``node_blocks``: (m, b) index arrays into the multiplier
    unknowns (the rows of one node: normal, tangential), one per interface; ``modes``, ``vertex``, ``dim``: from
    :func:`near_null_space`."""

    def __init__(self, n: int, free: np.ndarray, row_scale: np.ndarray, diag_aug: np.ndarray, node_blocks: list,
                 modes: np.ndarray, vertex: np.ndarray, dim: int, *, tol: float = DEFAULT_TOL,
                 maxit: int = 3000, restart: int = RESTART):
        self.n = n
        self.free = np.asarray(free, dtype=bool)
        self.fu = np.where(self.free[:n])[0]
        self.fl = np.where(self.free[n:])[0]
        self.f_all = np.where(self.free)[0]
        self.scale = np.concatenate([np.ones(n), np.asarray(row_scale, dtype=float)])[self.f_all]
        self.diag_aug = np.asarray(diag_aug, dtype=float)
        self.node_blocks = node_blocks
        self.modes = modes
        self.vertex = vertex
        self.dim = dim
        self.tol = tol
        self.maxit = maxit
        self.restart = restart
        self.stats = KrylovStats()
        self._amg = None
        self._free_q = None

    # -- preconditioner -------------------------------------------------------------------------------------
    def set_matrix(self, M: sp.csr_matrix, free_motions: np.ndarray | None = None) -> None:
        """Build the preconditioner for the Newton-step matrix ``M`` (scipy CSR, N x N). ``free_motions``: an
        orthonormal basis (n x k) of rigid motions that nothing holds; the preconditioner's output is kept
        orthogonal to them (the caller keeps the iterate so)."""
        self._free_q = None if free_motions is None else free_motions[self.fu]
        tic = time.perf_counter()
        n = self.n
        Mf = M[self.f_all][:, self.f_all].tocsr()
        self.M = Mf
        nu = len(self.fu)
        K = Mf[:nu, :nu]
        C = Mf[:nu, nu:]
        R = Mf[nu:, :nu]
        Dfull = M[n:, n:].tocsr()
        # D~: the zero diagonal of the exact rows replaced by -w / c
        d = Dfull.diagonal()
        d = np.where(d == 0.0, self.diag_aug, d)
        Dt = Dfull.tolil()
        Dt.setdiag(d)
        Dinv_full = block_inverse(Dt.tocsr(), self.node_blocks)
        Dinv = Dinv_full[self.fl][:, self.fl].tocsr()
        S = (K - C @ Dinv @ R).tocsr()
        self.C, self.Dinv = C.tocsr(), Dinv
        # the AMG hierarchy (aggregates, prolongators) of the first Newton step, its operators formed anew from each
        # step's S (keeping the whole AMG of an earlier step while its GMRES counts stayed within 1.5 x those of its
        # first solve was tried: up to 173 instead of 60 iterations on the P2 punch at 130k dofs, 70 s against
        # 63.5 s with a new AMG per step)
        fresh = self._amg is None
        self._amg = _TwoLevelAMG(S, self.modes[self.fu], self.vertex[self.fu], self.dim, self.fu, n,
                                 previous=self._amg)
        self.stats.amg_setups += fresh
        self.stats.setup_s += time.perf_counter() - tic

    def _apply_pre(self, v: np.ndarray) -> np.ndarray:
        """P^-1 v on the free unknowns (v unscaled)."""
        nu = len(self.fu)
        zl = self.Dinv @ v[nu:]
        zu = self._amg(v[:nu] - self.C @ zl)
        if self._free_q is not None:
            zu -= self._free_q @ (self._free_q.T @ zu)
        return np.concatenate([zu, zl])

    # -- GMRES ----------------------------------------------------------------------------------------------
    def solve(self, r: np.ndarray, ref: float | None, what: str) -> np.ndarray:
        """The correction dx (N) with M dx = r on the free unknowns (r zero elsewhere) to ``tol`` x ``ref`` (the
        scaled norm of the Newton step's right-hand side; None: of r). GMRES is scipy's on the right-preconditioned
        scaled operator y -> s M P^-1 (y / s), whose residual is that of the scaled system, then dx = P^-1 (y / s)."""
        tic = time.perf_counter()
        s = self.scale
        b = r[self.f_all] * s
        bnorm = float(np.linalg.norm(b))
        ref = bnorm if ref is None else max(ref, 1e-300)
        target = self.tol * ref
        if not math.isfinite(bnorm):
            raise SolverError(f"{what}: GMRES diverged (the residual is not finite after 0 iterations)")
        count = [0]

        def watch(pr_norm: float) -> None:       # scipy's residual estimate relative to |b|, once per iteration
            count[0] += 1
            res = pr_norm * bnorm
            if not math.isfinite(res):
                raise SolverError(f"{what}: GMRES diverged (the residual is not finite in iteration {count[0]})")
            if count[0] >= self.maxit and res > target:
                raise _IterationLimit(res)

        size = len(self.f_all)
        last = {}                             # the last operator input y and its P^-1 (y / s)

        def matvec(y: np.ndarray) -> np.ndarray:
            z = self._apply_pre(y / s)
            last["y"], last["z"] = y.copy(), z
            return s * (self.M @ z)

        op = spla.LinearOperator((size, size), dtype=float, matvec=matvec)
        if bnorm > target:
            try:
                y, info = spla.gmres(op, b, rtol=0.0, atol=target, restart=min(self.restart, self.maxit),
                                     maxiter=self.maxit, callback=watch, callback_type="pr_norm")
            except _IterationLimit as stop:
                res = stop.residual
            else:
                # scipy's last product is its residual check of the y it returns: P^-1 (y / s) is dx
                x = last["z"] if "y" in last and np.array_equal(last["y"], y) else self._apply_pre(y / s)
                # scipy's test on the true residual of y: |b - s M x| <= target (info 0)
                res = target if info == 0 else float(np.linalg.norm(b - s * (self.M @ x)))
        else:
            x = np.zeros(size)
            res = bnorm
        self.stats.iterations.append(count[0])
        self.stats.solve_s += time.perf_counter() - tic
        if not res <= target:
            raise SolverError(f"{what}: GMRES did not converge in {count[0]} iterations (relative residual "
                              f"{res / ref:.1e}, tolerance {self.tol:.0e}); use the direct contact solver "
                              "(solver.linear = 'direct') or a finer mesh on the contact zone")
        out = np.zeros(len(self.free))
        out[self.f_all] = x
        return out

    def reference(self, b: np.ndarray) -> float:
        """The scaled norm of a Newton step's right-hand side b (N), the reference of the stopping test."""
        return float(np.linalg.norm(b[self.f_all] * self.scale))


def block_inverse(D: sp.csr_matrix, node_blocks: list) -> sp.csr_matrix:
    """The inverse of the block-diagonal multiplier matrix ``D`` (one dense block per node: ``node_blocks`` per
    interface the (m, b) indices of each node's rows)."""
    rows, cols, vals = [], [], []
    for idx in node_blocks:                         # (m, b)
        m, b = idx.shape
        blocks = np.zeros((m, b, b))
        for p in range(b):
            for q in range(b):
                blocks[:, p, q] = np.asarray(D[idx[:, p], idx[:, q]]).ravel()
        try:
            inv = np.linalg.inv(blocks)
        except np.linalg.LinAlgError:
            inv = np.linalg.pinv(blocks)
        for p in range(b):
            for q in range(b):
                rows.append(idx[:, p])
                cols.append(idx[:, q])
                vals.append(inv[:, p, q])
    size = D.shape[0]
    if not rows:
        return sp.csr_matrix((size, size))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))


class _IterationLimit(Exception):
    """GMRES reached ``maxit`` iterations above the tolerance (raised from scipy's callback to stop it there)."""

    def __init__(self, residual: float):
        super().__init__(residual)
        self.residual = residual


_SMOOTHER = ("gauss_seidel", {"sweep": "symmetric"})
PROLONGATION_SMOOTHING = "energy"


class _TwoLevelAMG:
    """S^-1 approximated by smoothed-aggregation AMG on the vertex dofs (node-interleaved, the rigid motions as
    near-null space, energy-minimizing prolongation smoothing). Order 1: one AMG V-cycle. Order >= 2: a two-level
    V-cycle whose fine level is the whole S (one symmetric Gauss-Seidel sweep before and after) and whose coarse
    correction is the AMG cycle on the vertex block (NGSolve's hierarchical basis: the vertex dofs span P1). The
    additive form (Jacobi on the higher-order dofs plus AMG) took 92 - 235 GMRES iterations on the 3D P2 punch
    against 40 - 60 with this one.

    ``previous``: the AMG of an earlier Newton step of the same solve: its aggregates and prolongators are kept and
    only the Galerkin coarse operators R S P are formed anew (S changes only in the rows of the contact nodes).
    Measured on the P1 punch's first Newton-step S (CG with the AMG alone to 1e-8): the default Jacobi-smoothed
    prolongation 14 / 21 / 30 iterations at 3k / 17k / 115k dofs (set-up 2.0 s at 115k), the energy-minimizing
    one 13 / 17 / 21 (set-up 6.4 s): built once per solve, the better one pays."""

    def __init__(self, S: sp.csr_matrix, modes: np.ndarray, vertex: np.ndarray, dim: int, fu: np.ndarray, n: int,
                 previous: _TwoLevelAMG | None = None):
        import pyamg
        from pyamg.multilevel import MultilevelSolver
        from pyamg.relaxation.smoothing import change_smoothers

        Ssym = ((S + S.T) * 0.5).tocsr()
        Ssym.sort_indices()
        self.S = Ssym
        self.higher = not np.all(vertex)
        if previous is None:
            vid = np.where(vertex)[0]
            # node-interleaved ordering of the vertex dofs (component-major in NGSolve): the free dofs of one vertex
            # together, as smoothed aggregation wants them
            comp_size = n // dim
            node = fu[vid] % comp_size
            comp = fu[vid] // comp_size
            self.perm = vid[np.lexsort((comp, node))]
        else:
            self.perm = previous.perm
        A = Ssym[self.perm][:, self.perm].tocsr()
        if previous is None:
            B = modes[self.perm]
            B = B[:, np.linalg.norm(B, axis=0) > 0]
            self.ml = pyamg.smoothed_aggregation_solver(A, B=B, symmetry="symmetric", smooth=PROLONGATION_SMOOTHING,
                                                        presmoother=_SMOOTHER, postsmoother=_SMOOTHER,
                                                        improve_candidates=None, max_coarse=300,
                                                        coarse_solver="splu")
        else:
            levels = []
            for old in previous.ml.levels[:-1]:
                lvl = MultilevelSolver.Level()
                lvl.A, lvl.P, lvl.R = A, old.P, old.R
                levels.append(lvl)
                A = (old.R @ A @ old.P).tocsr()
            last = MultilevelSolver.Level()
            last.A = A
            levels.append(last)
            self.ml = MultilevelSolver(levels, coarse_solver="splu")
            change_smoothers(self.ml, _SMOOTHER, _SMOOTHER)
        self.pre = self.ml.aspreconditioner(cycle="V")
        self.levels = len(self.ml.levels) + self.higher

    def __call__(self, r: np.ndarray) -> np.ndarray:
        if not self.higher:
            z = np.zeros_like(r)
            z[self.perm] = self.pre @ r[self.perm]
            return z
        from pyamg.relaxation.relaxation import gauss_seidel

        z = np.zeros_like(r)
        gauss_seidel(self.S, z, r, iterations=1, sweep="forward")
        res = r - self.S @ z
        z[self.perm] += self.pre @ res[self.perm]
        gauss_seidel(self.S, z, r, iterations=1, sweep="backward")
        return z
