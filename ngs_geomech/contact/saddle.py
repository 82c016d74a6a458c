"""The saddle-point matrix of a contact solve with one sparsity pattern for all its Newton steps
(:class:`SaddlePattern`), and its symmetric quasi-definite companion. Unknowns: u (m), then per interface the
multiplier blocks lam_n, lam_t (, lam_t2 in 3D) (Pa)."""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

QUASI_DEFINITE = 1e8   # symmetric systems: the exact rows' zero diagonal -w / c becomes -w / (c x 1e8) when factored


class SaddlePattern:
    """The saddle-point matrix of a solve with one sparsity pattern for all iterations: K (with the shift eps
    on the floating bodies' free dofs), the columns -Bn^T, -Bt^T, the constraint rows -Bn, -Bt of every node,
    the multipliers' diagonal and the Coulomb coupling (lam_t, lam_n); in 3D also -Bt2^T, the rows of t1 and
    t2 on the union of the node's Bt and Bt2 entries, the 2 x 2 multiplier blocks and the coupling of t2 to
    lam_n; an iteration only changes values (the
    rows of the multipliers it fixes are left out of the factorization by the free-dof mask). Building the
    matrix once saves NGSolve's CreateFromCOO at every iteration (0.75 s of 2.2 s per iteration at 140k dofs).
    The entries are distinct by construction (the blocks are disjoint), so the storage order is a permutation
    of the COO order, read back once from the values 1, 2, ..., nnz."""

    def __init__(self, n: int, N: int, kr, kc, kv, reg_dofs, eps: float, ifs: list, bulk=None):
        self.kr, self.kc, self.N = kr.copy(), kc.copy(), N
        kv_in = kv
        kv = self._shifted(n, kr, kc, kv, reg_dofs, eps)
        rows, cols, vals = [kr], [kc], [kv]
        count = len(kr)
        self.segments = []

        def add(r, c, v) -> slice:
            nonlocal count
            rows.append(np.asarray(r, dtype=np.int64))
            cols.append(np.asarray(c, dtype=np.int64))
            vals.append(np.asarray(v, dtype=float))
            sl = slice(count, count + len(rows[-1]))
            count += len(rows[-1])
            return sl

        for it in ifs:
            self.segments.append(_segment(it, add))
        R, C = np.concatenate(rows), np.concatenate(cols)
        self.values = np.concatenate(vals)
        nk = len(kr)
        mat = _numbered_matrix(n, N, R, C, nk, bulk, kv_in)
        stored = mat.AsVector().FV().NumPy()
        if mat.nze != len(R):
            raise AssertionError("contact saddle-point pattern: repeated entries")
        self.order = np.rint(stored).astype(np.int64) - 1
        self.matrix = mat
        self.rows = R
        self.cols = C
        self._columns = None
        self._csr = None

    @staticmethod
    def _shifted(n: int, kr, kc, kv, reg_dofs, eps: float) -> np.ndarray:
        kv = np.array(kv, dtype=float)
        if len(reg_dofs):
            diag = np.where(kr == kc)[0]
            shift = np.zeros(n)
            shift[reg_dofs] = eps
            kv[diag] += shift[kr[diag]]
        return kv

    def matches(self, N: int, kr, kc) -> bool:
        """Whether a bulk matrix has this pattern's sparsity (the next solve of a time series or secant loop)."""
        return N == self.N and len(kr) == len(self.kr) and np.array_equal(kr, self.kr) and np.array_equal(kc, self.kc)

    def set_bulk(self, n: int, kv, reg_dofs, eps: float) -> None:
        """New values of K (the multiplier entries are set by every iteration)."""
        self.values[:len(self.kr)] = self._shifted(n, self.kr, self.kc, kv, reg_dofs, eps)

    def changed_rows(self, reference: np.ndarray) -> np.ndarray:
        """The matrix rows whose values differ from ``reference`` (COO values)."""
        return np.unique(self.rows[np.nonzero(self.values != reference)[0]])

    def csr(self) -> sp.csr_matrix:
        """The current matrix as a scipy CSR matrix (the iterative solver's; its storage order computed once)."""
        if self._csr is None:
            A = sp.csr_matrix((np.arange(1.0, len(self.rows) + 1.0), (self.rows, self.cols)), shape=(self.N, self.N))
            self.csr_order = np.rint(A.data).astype(np.int64) - 1
            self._csr = A
        self._csr.data = self.values[self.csr_order]
        return self._csr

    def update(self, values: np.ndarray | None = None) -> None:
        """Copy the current COO values (or ``values``) into the matrix."""
        self.matrix.AsVector().FV().NumPy()[:] = (self.values if values is None else values)[self.order]

    def symmetric(self, ifs: list) -> np.ndarray | None:
        """The COO values of the symmetric quasi-definite companion of the current matrix, or None when it has
        none (a Coulomb slip row couples lam_t to lam_n; a 3D frictional interface's tangential rows are not
        the transposes of its columns). The companion has (1) each multiplier column -B^T equal to its row:
        zero for a fixed multiplier (open node, Tresca slip), whose row fixes it alone, so the solution of the
        refinement below is that of the matrix once the fixed values are in the iterate; (2) the zero diagonal of
        the exact rows (-B u = g) replaced by -w / (c QUASI_DEFINITE). A symmetric quasi-definite matrix
        [[K, -B^T], [-B, -D]] (K positive definite, D > 0) has an LDL^T factorization for every symmetric ordering
        (Vanderbei, SIAM J. Optim. 5 (1995)), so NGSolve's sparse Cholesky (LDL^T, no pivoting) factors it; the
        solve is then the exact system's to about 1 / QUASI_DEFINITE, and one refinement step with the exact
        residual takes it to round-off. The bulk K must be symmetric (the caller checks it)."""
        v = self.values.copy()
        for it, seg in zip(ifs, self.segments):
            if seg["mirror"] is None or ("couple" in seg and np.any(v[seg["couple"]] != 0.0)):
                return None
            v[seg["cols"]] = v[seg["mirror"]]
            for key, c in (("diag_n", it.c), ("diag_t", it.ct)):
                if key in seg:
                    d = v[seg[key]]
                    v[seg[key]] = np.where(d == 0.0, -it.w / (c * QUASI_DEFINITE), d)
        return v

    def _coupled(self, values: np.ndarray) -> np.ndarray:
        """Bool over the unknowns: the multiplier rows that do not fix their multiplier alone in ``values`` (a -B
        entry or a Coulomb coupling not zero)."""
        out = np.zeros(self.N, dtype=bool)
        for seg in self.segments:
            for key in ("mirror", "couple"):
                if seg.get(key) is not None:
                    sel = seg[key] if key == "mirror" else span(seg[key])
                    np.logical_or.at(out, self.rows[sel], values[sel] != 0.0)
        return out

    def column(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """The entries of the matrix's column of multiplier ``j`` in the equilibrium rows: (row indices, values)."""
        if self._columns is None:
            sel = np.concatenate([span(seg["cols"]) for seg in self.segments] or [np.zeros(0, dtype=np.int64)])
            order = np.argsort(self.cols[sel], kind="stable")
            self._columns = (sel[order], self.cols[sel][order])
        sel, col = self._columns
        lo, hi = np.searchsorted(col, j), np.searchsorted(col, j, side="right")
        return self.rows[sel[lo:hi]], self.values[sel[lo:hi]]

    def zero_columns(self, sym: np.ndarray) -> np.ndarray:
        """Bool over the unknowns: the multiplier rows whose column the companion ``sym`` left out."""
        rows = np.zeros(self.N, dtype=bool)
        for seg in self.segments:
            if seg["mirror"] is not None:
                rows[self.rows[seg["mirror"]]] = True
        return rows & ~self._coupled(sym)

    def entering(self, rows: np.ndarray, zeroed: np.ndarray) -> np.ndarray:
        """Of the changed ``rows``, those whose multiplier is no longer fixed while the factored companion left
        its column out (a node newly in contact or sticking): a Woodbury update must add their columns too."""
        rows = np.asarray(rows, dtype=np.int64)
        return rows[zeroed[rows] & self._coupled(self.values)[rows]]


def _segment(it, add) -> dict:
    """The entries of one interface in the pattern, added by ``add(rows, cols, values) -> slice``: per block its
    slice of the COO values and what :func:`.active_set.assemble_rows` needs to set them (node of each row entry,
    the constant -B values); ``mirror``: the row entries the columns -B^T mirror (None in 3D with friction)."""
    on, ot = it.offset, it.offset + it.m
    seg = {}
    j = np.arange(it.m)
    cn = it.Bn.tocoo()
    frictional = it.law.kind != "frictionless"
    tr, tc, tv = it.transposed
    if not frictional:      # only the normal columns
        keep = tc < ot
        tr, tc, tv = tr[keep], tc[keep], tv[keep]
    seg["cols"] = add(tr, tc, tv)
    seg["rows_n"] = add(on + cn.row, cn.col, -cn.data)
    seg["rows_n_values"] = -cn.data
    seg["rows_n_node"] = cn.row
    seg["diag_n"] = add(on + j, on + j, np.zeros(it.m))
    if frictional and it.dim3:
        # the rows of t1 and t2 combine -Bt u and -Bt2 u of the node: the union of their patterns
        c1, c2 = it.Bt.tocoo(), it.Bt2.tocoo()
        U = sp.csr_matrix((np.ones(len(c1.row) + len(c2.row)),
                           (np.concatenate([c1.row, c2.row]), np.concatenate([c1.col, c2.col]))),
                          shape=it.Bt.shape).tocoo()
        a1 = -np.asarray(it.Bt[U.row, U.col]).ravel()
        a2 = -np.asarray(it.Bt2[U.row, U.col]).ravel()
        nz = (a1 != 0) | (a2 != 0)         # the operators store the zero components of t1, t2
        ot2 = ot + it.m
        seg["rows_t"] = add(ot + U.row[nz], U.col[nz], np.zeros(int(nz.sum())))
        seg["rows_t2"] = add(ot2 + U.row[nz], U.col[nz], np.zeros(int(nz.sum())))
        seg["rows_t_node"] = U.row[nz]
        seg["rows_t_a"], seg["rows_t_b"] = a1[nz], a2[nz]
        seg["diag_t"] = add(ot + j, ot + j, np.zeros(it.m))
        seg["off_t"] = add(ot + j, ot2 + j, np.zeros(it.m))
        seg["off_t2"] = add(ot2 + j, ot + j, np.zeros(it.m))
        seg["diag_t2"] = add(ot2 + j, ot2 + j, np.zeros(it.m))
        seg["couple"] = add(ot + j, on + j, np.zeros(it.m))
        seg["couple2"] = add(ot2 + j, on + j, np.zeros(it.m))
    elif frictional:
        ct = it.Bt.tocoo()
        seg["rows_t"] = add(ot + ct.row, ct.col, -ct.data)
        seg["rows_t_values"] = -ct.data
        seg["rows_t_node"] = ct.row
        seg["diag_t"] = add(ot + j, ot + j, np.zeros(it.m))
        seg["couple"] = add(ot + j, on + j, np.zeros(it.m))
    # the columns -Bn^T (, -Bt^T) mirror the rows -Bn (, -Bt) entry by entry (both from the same tocoo());
    # a 3D frictional interface has no such mirror (its tangential rows combine t1 and t2)
    if not frictional:
        seg["mirror"] = span(seg["rows_n"])
    elif not it.dim3:
        seg["mirror"] = np.concatenate([span(seg["rows_n"]), span(seg["rows_t"])])
    else:
        seg["mirror"] = None
    return seg


def _numbered_matrix(n: int, N: int, R: np.ndarray, C: np.ndarray, nk: int, bulk, kv_in) -> ngs.la.SparseMatrixd:
    """The saddle-point matrix (N x N) of the COO entries (R, C), its values the entries' numbers 1, 2, ... (the
    first ``nk`` those of K); built as K embedded plus the multiplier entries when K's COO is its storage order."""
    if bulk is not None and bulk.nze == nk and np.array_equal(np.asarray(bulk.AsVector().FV().NumPy()), kv_in):
        # K's COO is its storage order: the sum of K embedded and the multiplier entries as a sparse matrix
        # (0.05 s at 140k dofs; CreateFromCOO of the whole took 1.2 s)
        numbered = bulk.CreateMatrix()
        numbered.AsVector().FV().NumPy()[:] = np.arange(1.0, nk + 1.0)
        emb = ngs.la.Embedding(N, ngs.IntRange(0, n))
        extra = ngs.la.SparseMatrixd.CreateFromCOO(R[nk:], C[nk:], np.arange(nk + 1.0, len(R) + 1.0), N, N)
        mat = (emb @ numbered @ emb.T + extra).CreateSparseMatrix()
    else:
        mat = ngs.la.SparseMatrixd.CreateFromCOO(R, C, np.arange(1.0, len(R) + 1.0), N, N)
    return mat


def span(sl: slice) -> np.ndarray:
    return np.arange(sl.start, sl.stop)
