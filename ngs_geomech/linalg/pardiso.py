"""Sparse symmetric positive definite factorizations by oneMKL PARDISO, with the Schur complement of a chosen
set of unknowns (what the condensed contact solver of :mod:`.contact_condensed` is built on).

Why PARDISO: it computes the dense Schur complement S = A_ss - A_si A_ii^-1 A_is of a set s as part of the
factorization (``iparm[35]``) and then solves with A in parts (phases 331 / 332 / 333: the reduced right-hand
side b_s - A_si A_ii^-1 b_i, then the interior given x_s). Neither NGSolve's factorizations (sparsecholesky,
UMFPACK; NGSolve's own PARDISO wrapper, ``ngsolve.solvers.mkl_pardiso``, has no Schur complement) nor scipy's
expose a partial factorization. The library is the ``mkl`` wheel (a dependency on x86-64; NGSolve finds the same
library the same way). Measured at 140k dofs (P2 plane strain, the Hertz cylinder, one thread): analysis 0.64 -
0.95 s (METIS ordering and symbolic factorization), numeric factorization 0.31 - 0.33 s, a solve 0.03 s; with a
Schur set of 650 / 1020 / 1440 / 2900 surface dofs the numeric factorization takes 0.40 / 0.43 - 0.53 / 0.52 /
0.73 s. NGSolve's sparsecholesky takes 1.3 - 1.5 s and 0.1 s per solve on the same matrix. Ordering: minimum
degree (the default, ``ordering="mmd"``) or METIS; three runs each, analysis + factorization: plain 0.88 - 0.90 s
(MMD) against 1.07 - 1.19 s (METIS), with a Schur set of 1020 dofs 1.23 - 1.29 s against 1.23 - 1.50 s; the whole
condensed contact solve of the 148k-dof Coulomb blocks 2.02 - 2.12 s against 2.14 - 2.38 s.

The unknowns are those of ``A`` (the caller restricts to the free dofs); ``A`` must be symmetric, and its block
A_ii (everything but s) positive definite: A itself may be singular along motions that s holds (a floating body
whose contact nodes are in s)."""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import importlib.metadata

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError

_LIB = None
_TRIED = False

ERRORS = {-1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
          -4: "zero pivot (the matrix is singular or not positive definite)", -5: "unclassified internal error",
          -6: "reordering failed", -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
          -9: "not enough memory for the out-of-core solver", -10: "error opening out-of-core files",
          -11: "read/write error with out-of-core files", -12: "wrong pardiso_64 call"}


def _library():
    """The oneMKL runtime library (``mkl_rt``) or None: from the ``mkl`` wheel's files, else the system's (the
    lookup NGSolve does in ``ngsolve.solvers.mkl_pardiso._find_mkl``, whose handle is private to it)."""
    global _LIB, _TRIED
    if _TRIED:
        return _LIB
    _TRIED = True
    names = []
    try:
        dist = importlib.metadata.distribution("mkl")
        names = [str(dist.locate_file(f)) for f in (dist.files or []) if "mkl_rt" in str(f)]
    except importlib.metadata.PackageNotFoundError:
        pass
    found = ctypes.util.find_library("mkl_rt")
    names += [found] if found else []
    for name in names:
        try:
            lib = ctypes.CDLL(name)
            lib.pardiso.restype = None
            lib.MKL_Set_Num_Threads_Local.restype = ctypes.c_int
            lib.MKL_Set_Num_Threads_Local.argtypes = [ctypes.c_int]
        except (OSError, AttributeError):
            continue
        _LIB = lib
        break
    return _LIB


def available() -> bool:
    """Whether oneMKL PARDISO can be loaded (the ``mkl`` package is installed)."""
    return _library() is not None


@contextlib.contextmanager
def _threads(n: int):
    lib = _library()
    old = lib.MKL_Set_Num_Threads_Local(max(int(n), 1))
    try:
        yield
    finally:
        lib.MKL_Set_Num_Threads_Local(old)


def _upper(A: sp.spmatrix, upper: bool) -> sp.csr_matrix:
    """The upper triangle of ``A`` in CSR with sorted indices (PARDISO's input for symmetric types)."""
    U = A.tocsr() if upper else sp.triu(A, format="csr")
    U.sort_indices()
    return U


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(ctypes.c_void_p)


class SchurFactorization:
    """PARDISO's factorization of a symmetric positive (semi-)definite sparse matrix ``A`` (n x n, scipy) with the
    dense Schur complement ``S`` (m x m, numpy) of the unknowns ``schur`` (m indices; empty: a plain Cholesky
    factorization, then :meth:`solve`). ``threads``: MKL threads for every call (default: NGSolve's count).

    The analysis (ordering, symbolic factorization) is done once; :meth:`factor` with new values of the same
    pattern repeats only the numeric phase (the next secant iteration or time step)."""

    MTYPE = 2       # real symmetric positive definite

    ORDERINGS = {"mmd": 0, "metis": 2}

    def __init__(self, A: sp.spmatrix, schur=(), threads: int | None = None, what: str = "factorization",
                 upper: bool = False, ordering: str = "mmd"):
        lib = _library()
        if lib is None:
            raise SolverError(f"{what}: oneMKL PARDISO is not available (install the 'mkl' package)")
        if threads is None:
            import ngsolve as ngs
            threads = ngs.GetNumThreads()
        self.threads, self.what = threads, what
        n = A.shape[0]
        self.n = n
        U = _upper(A, upper)
        self._ia = U.indptr.astype(np.int32)
        self._ja = U.indices.astype(np.int32)
        self._a = np.array(U.data, dtype=float)            # PARDISO's own copy of the values (never the caller's)
        self.schur = np.asarray(schur, dtype=np.int64)
        self.m = len(self.schur)
        self._perm = np.zeros(n, dtype=np.int32)
        self._pt = np.zeros(64, dtype=np.int64)
        self._iparm = np.zeros(64, dtype=np.int32)
        ip = self._iparm
        ip[0] = 1           # not the defaults:
        ip[1] = self.ORDERINGS[ordering]      # fill-reducing ordering (module docstring)
        ip[9] = 13          # pivot perturbation 1e-13 (not used by the SPD type)
        ip[34] = 1          # zero-based indices
        if self.m:
            self._perm[self.schur] = 1
            ip[35] = 1      # the Schur complement of the unknowns with perm = 1, returned dense
        self.S = np.zeros((self.m, self.m))
        self._alive = False
        self._call(11, np.zeros(1), np.zeros(1))          # analysis
        self._alive = True
        self.factor()

    def _call(self, phase: int, b: np.ndarray, x: np.ndarray, nrhs: int = 1) -> None:
        err = ctypes.c_int(0)
        c = lambda v: ctypes.byref(ctypes.c_int(v))  # noqa: E731
        with _threads(self.threads):
            _library().pardiso(_ptr(self._pt), c(1), c(1), c(self.MTYPE), c(phase), c(self.n), _ptr(self._a),
                               _ptr(self._ia), _ptr(self._ja), _ptr(self._perm), c(nrhs), _ptr(self._iparm), c(0),
                               _ptr(b), _ptr(x), ctypes.byref(err))
        if err.value:
            raise SolverError(f"{self.what}: PARDISO phase {phase} failed ({ERRORS.get(err.value, err.value)})")

    def compare(self, A: sp.spmatrix, upper: bool = False) -> str:
        """How ``A`` (``upper``: its upper triangle already) differs from the factored matrix: "same", "values"
        (the same pattern, other values: :meth:`factor` takes it) or "pattern"."""
        U = _upper(A, upper)
        if not (U.nnz == len(self._a) and np.array_equal(U.indptr, self._ia) and np.array_equal(U.indices, self._ja)):
            return "pattern"
        return "same" if np.array_equal(U.data, self._a) else "values"

    def factor(self, A: sp.spmatrix | None = None, upper: bool = False) -> None:
        """The numeric factorization (and the Schur complement) of ``A``'s values (None: the matrix given;
        ``upper``: ``A`` is the upper triangle already)."""
        if A is not None:
            if self.compare(A, upper) == "pattern":
                raise ValueError("SchurFactorization.factor: the matrix has another sparsity pattern")
            U = _upper(A, upper)
            self._a[:] = U.data
        out = np.zeros(self.m * self.m) if self.m else np.zeros(1)
        self._call(22, np.zeros(1), out)
        if self.m:
            S = out.reshape(self.m, self.m)
            self.S = 0.5 * (S + S.T)

    def reduce(self, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(b_s - A_si A_ii^-1 b_i, the work vector :meth:`expand` needs) for a right-hand side ``b`` (n)."""
        b = np.ascontiguousarray(b, dtype=float)
        y = np.zeros(self.n)
        self._call(331, b, y)
        y2 = np.zeros(self.n)
        self._call(332, y, y2)
        return y[self.schur].copy(), y2

    def expand(self, work: np.ndarray, x_s: np.ndarray) -> np.ndarray:
        """The whole solution x (n) of A x = b given its Schur part ``x_s`` (the solution of the condensed
        system S x_s = b_s - A_si A_ii^-1 b_i) and :meth:`reduce`'s work vector for b."""
        z = np.array(work)
        z[self.schur] = x_s
        x = np.zeros(self.n)
        self._call(333, z, x)
        return x

    def solve(self, b: np.ndarray) -> np.ndarray:
        """The solution of A x = b (a factorization without a Schur set)."""
        if self.m:
            raise ValueError("SchurFactorization.solve: with a Schur set use reduce / expand")
        b = np.ascontiguousarray(b, dtype=float)
        x = np.zeros(self.n)
        self._call(33, b, x)
        return x

    def close(self) -> None:
        """Free PARDISO's memory (also done when the object is collected)."""
        if self._alive:
            self._alive = False
            with contextlib.suppress(SolverError):
                self._call(-1, np.zeros(1), np.zeros(1))

    def __del__(self):
        with contextlib.suppress(Exception):
            self.close()
