"""The linear algebra of one Newton step of a contact solve: the step solvers (a factorization of the
saddle-point matrix or of its companion, a Woodbury update of an older one, the dense elimination of a condensed
problem, GMRES) and the strategies that choose them for a solve (:func:`newton_steps`)."""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..linalg.direct import inverse
from .linear_algebra import is_symmetric
from .saddle import SaddlePattern

SPARSE_SHIFT = 1e-10     # a sparse bulk's relative shift on the floating bodies' free dofs
DENSE_SHIFT = 1e-7       # a dense bulk's (the elimination through S^-1 loses about the shift's inverse; DenseStep)
HINT_UNHELD = "a body is not held by its supports and the nodes in contact now"


@dataclass
class NewtonSystem:
    """What the Newton steps of one solve share: the sizes (n displacement dofs of X, N unknowns with the
    multipliers), the interfaces' states, the history, the load ``f`` (N on free dofs), the free dofs of X and of
    the saddle-point unknowns, the shifted dofs and the shift ``eps`` (Pa/m), the floating bodies' rigid motions
    (n x k) and their largest norm, the pattern and the operator ``mat`` of the saddle-point matrix."""

    n: int
    N: int
    ifs: list
    info: object
    what: str
    f: np.ndarray
    free: np.ndarray
    freemask: np.ndarray
    freedofs: object
    reg_dofs: np.ndarray
    eps: float
    rigid: np.ndarray
    mode_size: float
    pattern: SaddlePattern
    mat: object = None
    u_floor: float = 0.0
    """The displacement (m) below which a solution counts as zero in the floating bodies' refinement (a load in
    equilibrium with the initial stress leaves u = 0, whose relative corrections never fall)."""


class NewtonSteps:
    """The interface of the Newton-step strategies: how a solve reads the bulk K (``bulk_coo``, ``diagonal``,
    ``pattern_bulk``), which dofs get the relative ``shift``, the operator of the saddle-point matrix
    (``operator``, once per solve), the step solver of each iteration (``step``), a new factorization when an
    inexact step does not converge (``refactor``), forgetting a factorization (``forget``), the projection of the
    iterate (``project``) and the floor of the 3D slip rows' tolerance (``tol_floor``). This base reads a sparse
    (NGSolve) bulk; its steps are exact, so it never refactors."""

    shift = SPARSE_SHIFT
    tol_floor = 0.0

    @staticmethod
    def bulk_coo(matrix):
        kr, kc, kv = (np.asarray(a) for a in matrix.COO())
        return kr.astype(np.int64), kc.astype(np.int64), kv

    @staticmethod
    def shift_dofs(reg_dofs: np.ndarray, free: np.ndarray) -> np.ndarray:
        return reg_dofs

    @staticmethod
    def diagonal(matrix, n: int, kr, kc, kv) -> np.ndarray:
        diag = np.zeros(n)
        np.add.at(diag, kr[kr == kc], kv[kr == kc])
        return diag

    @staticmethod
    def pattern_bulk(matrix):
        return matrix

    def operator(self, s: NewtonSystem, matrix):
        raise NotImplementedError

    def step(self, s: NewtonSystem, b: np.ndarray, it_nr: int):
        raise NotImplementedError

    def refactor(self, exact: bool = False):
        raise AssertionError(f"{type(self).__name__}: its steps are exact and always apply")

    def forget(self) -> None:
        """Drop a kept factorization (the next step starts anew)."""

    @staticmethod
    def project(step, xv, n: int) -> None:
        """Nothing to remove from the iterate (the shift fixes the free rigid motions)."""


class SparseDirectSteps(NewtonSteps):
    """Newton steps of a sparse bulk by factorizations: the symmetric quasi-definite companion of the matrix by
    sparse Cholesky when it has one (:meth:`.SaddlePattern.symmetric`; the refinement with the exact residual makes
    the solve exact), else (or when asked ``exact``) the matrix by UMFPACK; an older factorization is reused
    through Woodbury (:class:`WoodburyStep`) while at most ``reuse_rows`` changed rows need new solves."""

    def __init__(self, reuse_rows: int, quasi_definite: bool):
        self.reuse_rows = reuse_rows
        self.quasi_definite = quasi_definite
        self.symmetric_bulk = False
        self.factored = None    # (the inverse, the COO values it was computed from, cached solves, zero columns)
        self.it_nr = 0

    def operator(self, s: NewtonSystem, matrix):
        self.s = s
        self.symmetric_bulk = self.quasi_definite and is_symmetric(matrix)
        return s.pattern.matrix

    def step(self, s: NewtonSystem, b: np.ndarray, it_nr: int):
        """The step of iteration ``it_nr``: the last factorization when the matrix is unchanged, its Woodbury
        update when few rows changed, else a new factorization."""
        self.it_nr = it_nr
        f = self.factored
        if f is not None:
            rows = s.pattern.changed_rows(f[1])
            if not len(rows):                    # the factored matrix itself
                return FactoredStep(f[0], exact=f[3] is None)
            # a companion's factorization: the columns it left out of the nodes now in contact or sticking
            cols = [] if f[3] is None else [int(j) for j in s.pattern.entering(rows, f[3])]
            new = len([j for j in rows if int(j) not in f[2]]) + len([j for j in cols if ("col", j) not in f[2]])
            if new <= self.reuse_rows:
                return WoodburyStep(s.mat, f[0], rows, f[2], s.info, exact=f[3] is None,
                                    columns={j: s.pattern.column(j) for j in cols})
        return self.refactor()

    def refactor(self, exact: bool = False):
        """Factor the current matrix (its companion unless ``exact``)."""
        s = self.s
        what = f"{s.what}, iteration {self.it_nr}"
        sym = None if (exact or not self.symmetric_bulk) else s.pattern.symmetric(s.ifs)
        if sym is not None:
            s.pattern.update(sym)
            try:
                inv = inverse(s.mat, s.freedofs, True, what, HINT_UNHELD)
            finally:
                s.pattern.update()
            s.info.cholesky_factorizations += 1
        else:
            inv = inverse(s.mat, s.freedofs, False, what, HINT_UNHELD)
        s.info.factorizations += 1
        zeroed = s.pattern.zero_columns(sym) if sym is not None else None
        self.factored = (inv, s.pattern.values.copy(), {}, zeroed)
        return FactoredStep(inv, exact=sym is None)

    def forget(self) -> None:
        """Drop the factorization (the next step factors anew)."""
        self.factored = None


class DenseSchurSteps(NewtonSteps):
    """Newton steps of a dense bulk S (the condensed problem of :mod:`.condensed`): u eliminated against one
    Cholesky factorization of the shifted S per solve (:class:`DenseStep`), exact for the shifted matrix. The shift
    goes on every free dof when no floating body is declared (a rigid motion held only by the contact rows)."""

    shift = DENSE_SHIFT

    @staticmethod
    def bulk_coo(matrix):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)

    @staticmethod
    def shift_dofs(reg_dofs: np.ndarray, free: np.ndarray) -> np.ndarray:
        return reg_dofs if len(reg_dofs) else np.where(free)[0].astype(np.int64)

    @staticmethod
    def diagonal(matrix, n: int, kr, kc, kv) -> np.ndarray:
        return np.diag(matrix)

    @staticmethod
    def pattern_bulk(matrix):
        return None

    def operator(self, s: NewtonSystem, matrix):
        shifted = np.array(matrix, dtype=float)
        shifted[s.reg_dofs, s.reg_dofs] += s.eps
        self.bulk = DenseBulk(shifted, s.what)
        return DenseOperator(s.pattern.matrix, shifted)

    def step(self, s: NewtonSystem, b: np.ndarray, it_nr: int):
        return DenseStep(self.bulk, s.pattern, s.n, s.freemask)


class KrylovSteps(NewtonSteps):
    """Newton steps by GMRES with the augmented-Lagrangian AMG preconditioner (:class:`.krylov.SaddleKrylov`):
    no factorization, no reuse; the rigid motions no row holds are kept out of the iterates (:func:`free_motions`).
    ``modes``: a callable giving the near null space of the displacement space (cached by the caller)."""

    def __init__(self, modes, tol: float | None, maxit: int):
        self.modes, self.tol, self.maxit = modes, tol, maxit

    def operator(self, s: NewtonSystem, matrix):
        """The saddle-point matrix, and the GMRES solver of this solve's steps: row scales c, the augmented
        diagonals -w / c and the node blocks of the multipliers."""
        modes, vertex, dim = self.modes()
        n = s.n
        if modes.shape[0] != n:
            raise ValueError(f"the iterative contact solver's displacement space has {modes.shape[0]} dofs, the matrix "
                             f"{n} (the mixed formulation is solved directly)")
        scale, aug, blocks = multiplier_scaling(s)
        # with scipy.sparse.linalg: loaded when the Krylov path runs
        from .krylov import DEFAULT_TOL, SaddleKrylov

        self.krylov = SaddleKrylov(n, s.freemask, scale, aug, blocks, modes, vertex, dim,
                                   tol=self.tol or DEFAULT_TOL, maxit=self.maxit)
        # 3D slip rows: the residual the Newton steps can reach is that of their linear solves (GMRES: 100 x its
        # tolerance; measured 1e-11 ... 2e-11 with 1e-10 on the 3D punch, where the direct solves reach 1e-16)
        self.tol_floor = 100.0 * self.krylov.tol
        return s.pattern.matrix

    def step(self, s: NewtonSystem, b: np.ndarray, it_nr: int):
        return KrylovStep(self.krylov, s.pattern, b, s.info, f"{s.what}, iteration {it_nr}", s.rigid, s.n)

    @staticmethod
    def project(step, xv, n: int) -> None:
        """Keep the iterate orthogonal to the rigid motions no row holds."""
        if step.free_motions is not None:
            q = step.free_motions
            xs = xv.FV().NumPy()
            xs[:n] -= q @ (q.T @ xs[:n])


def multiplier_scaling(s: NewtonSystem) -> tuple[np.ndarray, np.ndarray, list]:
    """What the iterative steps need of the multiplier rows (N - n each): the row scales c (Pa/m), the -w / c that
    replaces an exact row's zero diagonal in the preconditioner, and per interface the (m, blocks) indices of each
    node's rows (into the multiplier unknowns)."""
    n, N = s.n, s.N
    scale = np.ones(N - n)
    aug = np.ones(N - n)
    blocks = []
    for it in s.ifs:
        o = it.offset - n
        m = it.m
        # the rows scaled to forces by their own augmentation; the exact rows' zero diagonal replaced by -w / c
        # with the normal augmentation c = E / h for the tangential rows too (their c_t = E / L is the active-set
        # test's; with it the GMRES iterations of the 3D punch's slip steps grew 86, 130, 212 from h = 0.2 to 0.05)
        cs = [it.c] + [it.ct] * (it.blocks - 1)
        for k, c in enumerate(cs):
            scale[o + k * m:o + (k + 1) * m] = c
            aug[o + k * m:o + (k + 1) * m] = -it.w / it.c
        blocks.append(np.column_stack([o + k * m + np.arange(m) for k in range(it.blocks)]))
    return scale, aug, blocks


def newton_steps(matrix, linear: str, *, reuse_rows: int, quasi_definite: bool, modes, tol: float | None,
                 maxit: int):
    """The strategy for the Newton steps of one solve: the dense elimination for a dense bulk (numpy: the condensed
    problem), GMRES for ``linear="iterative"``, else the sparse factorizations. The one type test of a solve."""
    if isinstance(matrix, np.ndarray):
        return DenseSchurSteps()
    if hasattr(matrix, "newton_steps"):      # a distributed bulk (:class:`.distributed.DistributedBulk`)
        return matrix.newton_steps(tol, maxit)
    if linear == "iterative":
        return KrylovSteps(modes, tol, maxit)
    return SparseDirectSteps(reuse_rows, quasi_definite)


def free_motions(rigid: np.ndarray, M: sp.csr_matrix, n: int) -> np.ndarray | None:
    """Iterative steps: an orthonormal basis (n x k) of the floating bodies' rigid motions that no row of the
    current matrix holds (a frictionless body's sliding, held by nothing), or None. The direct solves fix these
    motions through the shift eps: r^T (K + eps I) u = r^T f = 0 for such a motion r, so their solution has no
    part along it; GMRES leaves it undetermined (it hardly changes the residual) and the AMG's coarse levels,
    shifted by eps too, put into it whatever the residual's round-off says (4e-3 of |u| on the frictionless 3D
    punch, and 111 GMRES iterations): the preconditioner and the iterate are kept orthogonal to them."""
    if not rigid.shape[1]:
        return None
    held = M[n:, :n] @ rigid
    scale = max(float(np.max(np.abs(held), initial=0.0)), 1e-300)
    if held.shape[0]:
        _, sv, vt = np.linalg.svd(held, full_matrices=True)
    else:
        sv, vt = np.zeros(0), np.eye(rigid.shape[1])
    rank = int(np.sum(sv > 1e-10 * scale))
    free = rigid @ vt[rank:].T
    if not free.shape[1]:
        return None
    return np.linalg.qr(free)[0]


def relative_change(dx: np.ndarray, x: np.ndarray, n: int, freemask: np.ndarray) -> float:
    """The larger of the relative corrections of u and of the free multipliers."""
    du = float(np.linalg.norm(dx[:n])) / max(float(np.linalg.norm(x[:n])), 1e-300)
    lam = freemask[n:]
    dl = float(np.linalg.norm(dx[n:][lam])) / max(float(np.linalg.norm(x[n:][lam])), 1e-300)
    return max(du, dl)


def exact_residual(s: NewtonSystem, xv, r) -> np.ndarray:
    """The residual's matrix part M x of the exact system (without the shift eps) into ``r``; returns its array."""
    r.data = s.mat * xv
    ra = r.FV().NumPy()
    ra[s.reg_dofs] -= s.eps * xv.FV().NumPy()[s.reg_dofs]
    return ra


class KrylovStep:
    """A step solved by GMRES (:class:`.krylov.SaddleKrylov`) with the preconditioner of the current
    matrix; the tolerance is relative to the Newton step's right-hand side ``b`` (or the first residual when
    larger: a problem driven by prescribed displacements)."""

    usable = True
    exact = True

    def __init__(self, krylov, pattern, b: np.ndarray, info, what: str, rigid: np.ndarray, n: int):
        self.krylov, self.what, self.info = krylov, what, info
        M = pattern.csr()
        self.free_motions = free_motions(rigid, M, n)
        krylov.set_matrix(M, self.free_motions)
        info.amg_setups = krylov.stats.amg_setups
        self.ref = krylov.reference(b)
        self.first = True

    def apply(self, r, dx) -> bool:
        ra = np.array(r.FV().NumPy())
        if self.first:
            self.ref = max(self.ref, self.krylov.reference(ra))
            self.first = False
        dx.FV().NumPy()[:] = self.krylov.solve(ra, self.ref, self.what)
        self.info.gmres_iterations.append(self.krylov.stats.iterations[-1])
        return True


class DenseBulk:
    """A dense symmetric bulk matrix (the condensed problem's Schur complement S, shifted on the floating bodies'
    dofs, or on all dofs when none is declared) factored once per solve (Cholesky; LU when round-off makes the
    shifted S indefinite), with the solves S^-1 r_j^T of the multiplier rows r_j cached by their values (an exact
    row -B_j keeps its values, so a node's column is computed once per solve)."""

    def __init__(self, S: np.ndarray, what: str):
        import scipy.linalg as sl
        self.n = S.shape[0]
        self._sl = sl
        try:
            self._fac, self._chol = sl.cho_factor(S, lower=True, check_finite=False), True
        except np.linalg.LinAlgError:
            self._fac, self._chol = sl.lu_factor(S, check_finite=False), False
        if not np.all(np.isfinite(self._fac[0])):
            raise SolverError(f"{what}: the condensed stiffness is not finite; check the material data")
        self.cache: dict = {}
        self._store: np.ndarray | None = None
        self._blocks: dict | None = None

    def solve(self, B: np.ndarray) -> np.ndarray:
        if self._chol:
            return self._sl.cho_solve(self._fac, B, check_finite=False)
        return self._sl.lu_solve(self._fac, B, check_finite=False)

    def blocks(self, pattern, n: int, freemask: np.ndarray) -> dict:
        """The sparse blocks C = M[:n, free multipliers], R = M[free multipliers, :n], D and C^T of the pattern
        as matrices whose ``data`` is read from ``pattern.values`` at the stored positions (computed once per
        solve: the pattern and the free multipliers do not change within it)."""
        if self._blocks is not None:
            return self._blocks
        M = pattern.csr()
        T = sp.csr_matrix((np.arange(1.0, M.nnz + 1.0), M.indices, M.indptr), shape=M.shape)   # positions + 1
        order = pattern.csr_order
        idx = np.nonzero(freemask[n:])[0]
        out = {"idx": idx}
        for name, block in (("C", T[:n, n:][:, idx]), ("R", T[n:, :n][idx]), ("D", T[n:, n:][idx][:, idx]),
                            ("CT", T[:n, n:][:, idx].T.tocsr())):
            block = block.tocsr() if name != "C" else block.tocsc()
            block.sort_indices()
            out[name + "_pos"] = order[np.rint(block.data).astype(np.int64) - 1]
            block.data = np.zeros(len(block.data))
            out[name] = block
        R = out["R"]
        out["R_row"] = np.repeat(np.arange(R.shape[0]), np.diff(R.indptr))
        self._blocks = out
        return out

    def row_solves(self, R: sp.csr_matrix, keys: list) -> np.ndarray:
        """S^-1 R^T (n x rows) for the sparse rows ``R``, cached under ``keys`` (one per row) as the columns of
        one growing array."""
        missing = [k for k, key in enumerate(keys) if key not in self.cache]
        if missing:
            Y = self.solve(R[missing].toarray().T)
            used = len(self.cache)
            if self._store is None or used + len(missing) > self._store.shape[1]:
                grown = np.empty((self.n, max(2 * (used + len(missing)), 64)))
                if self._store is not None:
                    grown[:, :used] = self._store[:, :used]
                self._store = grown
            self._store[:, used:used + len(missing)] = Y
            for k, j in enumerate(missing):
                self.cache[keys[j]] = used + k
        if not keys:
            return np.zeros((self.n, 0))
        return self._store[:, [self.cache[key] for key in keys]]


class DenseOperator(ngs.BaseMatrix):
    """The saddle-point matrix of a dense bulk: the pattern's sparse multiplier entries plus S in the top left
    block (for the residuals of the refinement loop)."""

    def __init__(self, sparse, S: np.ndarray):
        super().__init__()
        self.sparse, self.S, self.n = sparse, S, S.shape[0]

    def IsComplex(self):
        return False

    def Height(self):
        return self.sparse.height

    def Width(self):
        return self.sparse.width

    def CreateColVector(self):
        return self.sparse.CreateColVector()

    def CreateRowVector(self):
        return self.sparse.CreateRowVector()

    def Mult(self, x, y):
        y.data = self.sparse * x
        y.FV().NumPy()[:self.n] += self.S @ x.FV().NumPy()[:self.n]


class DenseStep:
    """A Newton step of a dense bulk (:class:`DenseBulk`): M = [[S, C], [R, D]] solved by eliminating u,

        (D - R S^-1 C) lam = r_m - R S^-1 r_u,    u = S^-1 r_u - S^-1 C lam,

    where R S^-1 C = Y^T C has rows only for the multipliers coupled to u (the exact and penalty rows P, Y = S^-1
    R_P^T from the cache), and the other free multipliers (Q: open nodes, slip rows) are eliminated through their
    sparse block D_QQ first, leaving a dense system of the size of P. The columns C_P are the rows R_P transposed
    for the exact rows of a symmetric problem, so S^-1 C_P comes from the same cache; S^-1 C_Q lam_Q is solved only
    when nonzero. No factorization of the saddle-point matrix, so nothing to reuse or refine: the step is exact for
    the shifted matrix."""

    usable = True
    exact = True
    free_motions = None

    def __init__(self, bulk: DenseBulk, pattern, n: int, freemask: np.ndarray):
        import scipy.linalg as sl
        import scipy.sparse.linalg as spla
        self.bulk, self.n = bulk, n
        blocks = bulk.blocks(pattern, n, freemask)
        data = pattern.values
        idx = blocks["idx"]
        self.idx = idx
        Cm, Rm, Dm = (blocks[k].copy() for k in ("C", "R", "D"))     # the structures shared by the solve's steps
        Cm.data = data[blocks["C_pos"]]
        Rm.data = data[blocks["R_pos"]]
        Dm.data = data[blocks["D_pos"]]
        coupled = np.bincount(blocks["R_row"], weights=(Rm.data != 0.0), minlength=len(idx)) > 0
        P, Q = np.nonzero(coupled)[0], np.nonzero(~coupled)[0]
        self.P, self.Q, self.Rm = P, Q, Rm
        RP = Rm[P]
        CP = blocks["CT"][P]
        CP.data = data[blocks["CT_pos"]][rows_entries(blocks["CT"], P)]
        keys_r = [row_key(idx[p], RP, k) for k, p in enumerate(P)]
        keys_c = [row_key(idx[p], CP, k) for k, p in enumerate(P)]
        Y = bulk.row_solves(RP, keys_r)                                         # S^-1 R_P^T
        self.Z = Y if keys_c == keys_r else bulk.row_solves(CP, keys_c)         # S^-1 C_P
        self.C_Q = Cm[:, Q] if len(Q) else None
        YC = (Cm.T @ Y).T                                   # Y^T C = R_P S^-1 C (|P| x free multipliers)
        G_P = Dm[P].toarray() - YC
        H, G_PQ = G_P[:, P], G_P[:, Q]
        self.lu_QQ, self.G_QP, self.G_PQ = None, None, G_PQ
        if len(Q):
            DQ = Dm[Q]
            self.lu_QQ = spla.splu(DQ[:, Q].tocsc())
            G_QP = DQ[:, P].tocsc()
            G_QP.eliminate_zeros()
            if G_QP.nnz and len(P):
                self.G_QP = G_QP
                H = H - G_PQ @ self.lu_QQ.solve(G_QP.toarray())
        self.H_lu = sl.lu_factor(H, check_finite=False) if len(P) else None

    def apply(self, r, dx) -> bool:
        import scipy.linalg as sl
        n, P, Q = self.n, self.P, self.Q
        ra = r.FV().NumPy()
        z = self.bulk.solve(ra[:n])
        t = ra[n:][self.idx] - self.Rm @ z
        lam = np.zeros(len(self.idx))
        wQ = self.lu_QQ.solve(t[Q]) if len(Q) else np.zeros(0)
        if len(P):
            lam[P] = sl.lu_solve(self.H_lu, t[P] - self.G_PQ @ wQ if len(Q) else t[P], check_finite=False)
        if len(Q):
            lam[Q] = self.lu_QQ.solve(t[Q] - self.G_QP @ lam[P]) if self.G_QP is not None else wQ
        out = dx.FV().NumPy()
        out[:] = 0.0
        u = z - self.Z @ lam[P]
        cq = self.C_Q @ lam[Q] if len(Q) and np.any(lam[Q] != 0.0) else None
        if cq is not None and np.any(cq != 0.0):
            u -= self.bulk.solve(cq)
        out[:n] = u
        out[n:][self.idx] = lam
        return True


def rows_entries(A: sp.csr_matrix, rows: np.ndarray) -> np.ndarray:
    """The positions in ``A.data`` of the entries of ``rows`` (in order), i.e. of A[rows].data."""
    starts, ends = A.indptr[rows], A.indptr[np.asarray(rows) + 1]
    if not len(starts):
        return np.zeros(0, dtype=np.int64)
    return np.concatenate([np.arange(a, b) for a, b in zip(starts, ends)]).astype(np.int64)


def row_key(j: int, A: sp.csr_matrix, k: int) -> tuple:
    """A cache key of row ``k`` of ``A`` (the multiplier ``j``'s row or column): its index and its entries."""
    lo, hi = A.indptr[k], A.indptr[k + 1]
    return int(j), A.indices[lo:hi].tobytes(), A.data[lo:hi].tobytes()


class FactoredStep:
    """A step with the factorization of the current matrix (``exact``) or of its quasi-definite companion."""

    usable = True

    def __init__(self, inv, exact: bool = True):
        self.inv = inv
        self.exact = exact

    def apply(self, r, dx) -> bool:
        dx.data = self.inv * r
        return True


class WoodburyStep:
    """A step with the factorization of an earlier matrix M0 of the same solve, which differs from the current
    matrix M in the rows ``rows`` (the multiplier rows of the nodes whose contact state changed since):
    M = M0 + E (N - O) with E the unit columns of those rows, N and O their new and old values. With
    y = M0^-1 b and Z = M0^-1 E (one solve per changed row, cached until the next factorization), and
    O y = E^T b, O Z = I, the Sherman-Morrison-Woodbury formula gives

        x = y - Z t,    (N Z) t = N y - E^T b,

    a dense system of the size of ``rows``. A solve costs about a tenth of a factorization at 100k dofs in 2D,
    so this pays for a few changed rows.

    When M0 is a quasi-definite companion (:meth:`SaddlePattern.symmetric`), the nodes that entered the contact or
    started sticking since also have their columns C_J (the -B^T entries in the equilibrium rows, left out of M0)
    added: M = M0 + U V^T with U = [E, C_J], V^T = [[N - O], [E_J^T]]. With Z = M0^-1 U (Z_C: one more solve per
    such node) and O Z = [I, 0] (C_J has no entries in the multiplier rows), Woodbury gives

        x = y - Z t,    (I + V^T Z) t = [N y - E^T b; y_J],

    which is the formula above when J is empty. (GMRES right preconditioned by M0^-1 converges in as many steps in
    exact arithmetic, but the unknowns mix metres and pascals and its Krylov vectors lost the rank structure
    to round-off: it did not converge at all.)"""

    usable = True

    def __init__(self, mat, inv, rows: np.ndarray, cache: dict, info, exact: bool = True, columns=None):
        self.mat, self.inv, self.rows, self.info = mat, inv, rows, info
        self.exact = exact
        self._v = mat.CreateColVector()
        self._w = mat.CreateColVector()
        columns = columns or {}
        missing = [int(j) for j in rows if int(j) not in cache]
        for j in missing:
            self._v.FV().NumPy()[:] = 0.0
            self._v.FV().NumPy()[j] = 1.0
            self._w.data = inv * self._v
            cache[j] = np.array(self._w.FV().NumPy())
        missing_c = [j for j in columns if ("col", j) not in cache]
        for j in missing_c:
            idx, val = columns[j]
            self._v.FV().NumPy()[:] = 0.0
            self._v.FV().NumPy()[idx] = val
            self._w.data = inv * self._v
            cache[("col", j)] = np.array(self._w.FV().NumPy())
        info.woodbury_columns += len(missing) + len(missing_c)
        self.J = np.array(sorted(columns), dtype=np.int64)
        self.Z = np.column_stack([cache[int(j)] for j in rows] + [cache[("col", int(j))] for j in self.J])
        NZ = np.column_stack([self._rows_of_M(self.Z[:, k]) for k in range(self.Z.shape[1])])
        # I + V^T Z with V^T = [[N - O], [E_J^T]] (module docstring of the class): O Z = [I, 0]
        k = len(rows)
        top = NZ - np.hstack([np.eye(k), np.zeros((k, len(self.J)))])
        self.W = np.eye(self.Z.shape[1]) + np.vstack([top, self.Z[self.J]])

    def _rows_of_M(self, v: np.ndarray) -> np.ndarray:
        self._v.FV().NumPy()[:] = v
        self._w.data = self.mat * self._v
        return np.array(self._w.FV().NumPy()[self.rows])

    def apply(self, r, dx) -> bool:
        b = np.array(r.FV().NumPy())
        self._v.FV().NumPy()[:] = b
        self._w.data = self.inv * self._v
        y = np.array(self._w.FV().NumPy())
        try:
            t = np.linalg.solve(self.W, np.concatenate([self._rows_of_M(y) - b[self.rows], y[self.J]]))
        except np.linalg.LinAlgError:
            self.usable = False
            return False
        x = y - self.Z @ t
        if not np.all(np.isfinite(x)):
            self.usable = False
            return False
        dx.FV().NumPy()[:] = x
        self.info.reused_solves += 1
        return True
