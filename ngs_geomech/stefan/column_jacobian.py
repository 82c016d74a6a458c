"""The serial linear algebra of the Stefan Newton steps: :class:`ColumnJacobian`, a direct solver with low-rank
column updates (a :class:`ngs_geomech.stefan.jacobian.NewtonJacobian`).

The Newton system of :mod:`ngs_geomech.stefan.solver` is solved as the larger, block triangular system on all free
nodes in mixed unknowns (dT_j on a non-mushy node, a multiple of de_j on a mushy one), whose column j is
(m_j C_j/dt) e_j + sum_g K_g[:, j] dtheta_g(T_j), without its off-diagonal part when j is mushy. In that form a
column belongs to one node, so the Newton matrices of all iterations and steps differ from a factored reference
matrix only in the columns of the nodes whose branch changed since it was factored, a few per step: they are
solved exactly (to round-off) with one sparse LU factorization (SuperLU) kept over many steps and a
Sherman-Morrison-Woodbury correction of the size of the changed set (two solves per iteration and one solve per
newly changed node). It is refactored when the changed set is large, when dt changes, or when a node outside the
factored set (mushy nodes far from any sensible one are left out: a one-phase solid at Theta_R) turns sensible.
Keeping the diagonal of a mushy column equal to the sensible one makes the correction of a node entering or
leaving the flat part a change of off-diagonal entries only: with the bare m_j C_j/dt the corrected solves of the
one-phase problem left residuals of 1e-11 instead of 1e-14 and Newton needed more iterations (mean 1.35 instead
of 1.10 at h = 0.003125).

Measured in one run against a solver with one sparse Cholesky or UMFPACK factorization of the reduced system per
Newton iteration whose branches differ from the last one, on the Neumann strips of
:mod:`ngs_geomech.verification.stefan`, P1, dt = 0.2 h s/m, one NGSolve and one BLAS thread: the same Newton
iterations and errors (the states agree to the Newton tolerance, max |de| <= 7e-13 J/m^3), 0.02 - 0.07
factorizations per step (0.5 - 1.8 there), time per step two-phase 0.80 -> 0.32, 8.8 -> 1.2, 20.6 -> 4.5,
148 -> 34 ms (h = 0.05, 0.0125, 0.00625, 0.003125 m; 215 ... 42k nodes), one-phase 0.49 -> 0.30,
2.0 -> 0.7, 12.2 -> 7.8 ms (h = 0.05, 0.0125, 0.003125): 2 - 3.6 linear heat steps (factorization reused)
instead of 4 - 24. Two BLAS threads on a busy 2-core machine made the steps up to 1.8 x slower (SuperLU's
multi-column solves and the small dense systems): run with one.

Window mode (factored sets of at least 8000 unknowns, see :class:`ColumnJacobian`). The correction columns are
the nodes the front sweeps, one solve each, about 1/h per step with dt ~ h (5.3 per step at 42k nodes, 11.7 at
170k): on fine meshes they were the largest part of a step (time ratio 4.1 - 4.6 at 170k nodes), and no
refactoring policy removes them (after a factorization each node that changes needs its column again). The
large meshes therefore factor M0 outside a window around the front and solve the window's Schur complement,
factored per changed Newton matrix (sparse, of the window's size); a placement (the factorization and about two
solves per node across the front, for the window's interface) lasts until the front leaves the window, about
100 - 200 steps. Measured (``studies/stefan_performance`` level 2, one run on the busy shared machine): the same
iterations, states within 1.2e-12 J/m^3 (42k nodes), 0.5 - 0.6 interface solves and 0.006 - 0.014
factorizations per step (5.3 and 11.7 correction columns, 0.025 - 0.029 factorizations with the Woodbury
correction alone), time ratio against a linear heat step 1.65, 2.18, 1.76 at 10.8k, 42k, 170k nodes (2.78, 3.46,
4.61 with the Woodbury correction alone); both in one process at 170k nodes (first 500 steps): 2.9 x faster per
step, final states within 1.5e-13 J/m^3.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .forms import StefanForms
from .jacobian import NewtonJacobian


def lu_nnz(lu) -> int:
    """Non-zeros of the factors of a SuperLU object (L's unit diagonal not counted)."""
    return int(lu.L.nnz + lu.U.nnz - lu.shape[0])


def lu_work(lu) -> float:
    """Multiply-adds of the factorization of a SuperLU object, counted from its factors: the sum over the pivots
    j of (entries of L's column j below the diagonal) x (entries of U's row j), plus nnz(L + U)."""
    below = np.diff(lu.L.indptr) - 1
    right = np.bincount(lu.U.indices, minlength=lu.shape[0])
    return float(np.dot(below, right) + lu_nnz(lu))


class ColumnJacobian(NewtonJacobian):
    """Solves with M = diag(d) + sum_g (K_g - diag K_g) diag(w_g) on the free nodes, reusing one factorization.

    Every Newton matrix of the Stefan solvers has that form: column j belongs to node j alone (its diagonal d_j and the
    off-diagonal stiffness entries K_g[:, j] scaled by w_gj), so a matrix differs from the last factored one, M0,
    only in the columns of the nodes S whose (d_j, w_j) changed since: M = M0 + U E_S^T with U = (M - M0) E_S
    sparse (the stiffness neighbours of S). The Sherman-Morrison-Woodbury formula gives, exactly up to round-off,

        M^-1 b = M0^-1 (b - U t),    (I + E_S^T M0^-1 U) t = E_S^T M0^-1 b,

    two solves with M0 and a dense |S| x |S| system. Its matrix is built from the rows v_i = M0^-T e_i, i in S
    (one solve per node, cached until the next factorization, whatever branches the node visits), taken only
    at the non-zeros of U. Columns without off-diagonal part (w_j = 0: the mushy nodes of the Stefan solver)
    decouple: the rows of such nodes do not enter the other unknowns, so M0 is factored only on the nodes with
    w_j != 0 and a halo of ``HALO`` stiffness neighbours around them (where a front can move to before the
    next factorization); the other unknowns are returned as 0 (their values are not used). Of the rows v_i only
    the entries within ``BAND`` stiffness neighbours of the nodes that changed in the last cycle are kept (all
    entries after the first factorization): the changes of the next cycle lie there, ahead of a moving front.
    M is factored again (SuperLU, scipy; M0^T, whose single solves and multi-column solves are the faster ones)
    when more than ``max_changed`` nodes have been cached (default: (6 nnz(LU))^(1/3), where the dense system
    costs about what a solve does, and at most 1.6e7 / (rows kept), to bound the cache at 128 MB), when a
    changed column reaches rows that were not kept, when a node outside the factored set gets w_j != 0, when dt
    changes (every diagonal entry does), or when the small system is singular. (Keeping every row, the 128 MB
    bound forced a factorization every 5 steps at 170k unknowns: 830 instead of 390 ms per step.)

    Window mode (factored sets of at least ``WINDOW_MIN`` unknowns, ``max_changed`` not given). The correction
    above costs one solve per node that changed since the factorization, and those are the nodes a front sweeps:
    about 1/h per step with dt ~ h, whatever the refactoring policy (after a factorization every node that changes
    again needs its row). Instead M0 is factored on R = A - C only, C being a window of ``_width`` stiffness
    neighbours around the nodes that changed in the last solve, and the columns of C may change freely: with I
    the nodes of R next to C (two lines of nodes across a front) and Z = (M0_RR^-1)_II (|I| solves per placement),

        z = M_RR^-1 b_R,   (M_CC - M_CI Z M_IC) x_C = b_C - M_CI z_I,   x_R = z - M_RR^-1 (M_RC x_C)

    (block elimination, exact to round-off; M_RR and M_CI are fixed, M_CC and M_IC are read from the current
    columns). The Schur complement S has the window's sparse pattern plus a dense block on the nodes of C next to
    R; it is factored (SuperLU, its ordering computed once per placement, no relaxed supernodes) when the
    window's columns changed. The window is placed again when a column outside it changes (the front has left
    it), when a node outside A turns sensible, when dt changes, or as a plain factorization (empty window) when
    there is no last change to centre it on; a singular S falls back to the correction above. The width is
    adapted at each placement to the costs of the last cycle (:meth:`_adapt_width`, counted from the factors, not
    timed: two runs of the same problem take the same placements, to the last bit). ``factorizations``
    counts the factorizations of M0_RR, ``corrections`` the solves for Z, ``window_factorizations`` those of S.
    """

    HALO = 8
    BAND = 16
    WINDOW = 16
    WINDOW_RANGE = (4, 64)
    WINDOW_MIN = 8000
    WINDOW_FRACTION = 0.5
    SCHUR_WEIGHT = 2.0
    """Seconds per counted work of a Schur complement factorization (with the assembly of its matrix) over those
    of a placement. Measured on the two-phase Neumann strips (one thread, per cycle): 3.2 and 3.4 at 10.8k nodes,
    1.3 at 42k nodes; the width follows the square root of the cost ratio, so a factor 1.6 off moves it by
    1.3 x at most."""

    def __init__(self, forms: StefanForms, max_changed: int | None = None):
        super().__init__(forms)
        f = forms
        nF = self.nF
        pos = np.full(f.n, -1)
        pos[self.free] = np.arange(nF)
        r, c = pos[f.pattern_rows], pos[f.pattern_cols]
        keep = np.nonzero((r >= 0) & (c >= 0))[0]
        sel = keep[np.lexsort((r[keep], c[keep]))]            # the free x free pattern in CSC order
        self._rows = r[sel]
        self._cols = c[sel]
        self._indptr = np.concatenate([[0], np.cumsum(np.bincount(self._cols, minlength=nF))])
        self._diag = np.nonzero(self._rows == self._cols)[0]
        if len(self._diag) != nF:
            raise AssertionError("Stefan Jacobian: a diagonal entry is missing from the pattern")
        self._sel = sel
        self._load_stiffness()
        self._transpose = np.lexsort((self._cols, self._rows))
        if not (np.array_equal(self._rows[self._transpose], self._cols)
                and np.array_equal(self._cols[self._transpose], self._rows)):
            raise AssertionError("Stefan Jacobian: the stiffness pattern is not symmetric")
        self._graph = sp.csr_matrix((np.ones(len(self._rows), dtype=np.int32), self._rows, self._indptr),
                                    shape=(nF, nF))
        self.max_changed = None if max_changed is None else int(max_changed)
        # ``corrections`` counts the solves for the rows v_i (one per node and factorization)
        self.lu = None
        self.dt0 = math.nan
        self._d0 = self._w0 = None
        self._A = np.zeros(0, dtype=int)                # the factored unknowns (free numbering)
        self._amap = np.full(nF, -1)                    # free -> factored numbering, -1: not factored
        self._full = False
        self._slot = np.full(nF, -1)                    # node -> its column of _store (v_i), -1: none yet
        self._used = 0
        self._store = np.zeros((0, 0))
        self._band = None                               # factored rows kept of v_i (factored numbering), None: all
        self._bmap = np.zeros(0, dtype=int)             # factored -> row of _store, -1: not kept
        self._limit = 0
        self._win = None                                # the window (Schur complement) mode's data, None: Woodbury
        self._last = None                               # (d, w) of the last solve in window mode
        self.window_factorizations = 0
        self._width = None                              # the window's width (stiffness neighbours), adapted
        self._cycle = [0.0, 0.0]                        # work of the last placement, of Schur factorizations since
        """Sparse LU factorizations of the window's Schur complement (window mode, one per changed matrix)."""

    @property
    def factored_size(self) -> int:
        """The number of unknowns in the factored set A (the others decouple, see the class docstring)."""
        return len(self._A)

    @property
    def banded(self) -> bool:
        """Whether only a band of rows of the correction vectors v_i is kept (Woodbury mode)."""
        return self._band is not None

    @property
    def window_size(self) -> int | None:
        """The number of nodes in the window C (window mode), None outside window mode."""
        return None if self._win is None else self._win["nC"]

    def _load_stiffness(self) -> None:
        """The stiffness values in the free x free pattern (again after the forms' matrices changed)."""
        f = self.forms
        self.version = f.version
        self._kdata = [K.data[self._sel] for K in f.stiffness]
        self._kdiag = [kd[self._diag].copy() for kd in self._kdata]
        for kd in self._kdata:
            kd[self._diag] = 0.0                      # the off-diagonal part; the diagonal is d

    def _factor(self, d: np.ndarray, w: np.ndarray, dt: float, where: str, recent: np.ndarray | None = None,
                window: bool = True) -> None:
        """Factor M0 = M(d, w); ``recent`` (free nodes, bool): the nodes whose columns changed in the last cycle,
        around which the next changes are expected (the rows of v_i kept, see the class docstring)."""
        # how M0 was made and the rows v_i solved since, in their batches: what :meth:`capture` keeps
        self._made = (None if recent is None else recent.copy(), window)
        self._batches: list[np.ndarray] = []
        offdiag = np.any(w != 0.0, axis=1)
        inA = offdiag.copy()
        for _ in range(self.HALO):
            if inA.all():
                break
            inA |= (self._graph @ inA.astype(np.int32)) > 0
        self._A = np.nonzero(inA)[0]
        nA = len(self._A)
        self._full = nA == self.nF
        self._amap[:] = -1
        self._amap[self._A] = np.arange(nA)
        self._win = None
        if window and self.max_changed is None and nA >= self.WINDOW_MIN:
            inC = np.zeros(self.nF, dtype=bool)
            if recent is not None:
                self._adapt_width()
                inC = recent & inA
                for _ in range(self._width):
                    inC |= (self._graph @ inC.astype(np.int32)) > 0
                inC &= inA
            if np.count_nonzero(inC) <= self.WINDOW_FRACTION * nA:
                self._place(d, w, dt, where, inA, inC)
                return
        data = np.zeros(len(self._rows))
        for g, kd in enumerate(self._kdata):
            data += kd * w[self._cols, g]
        data[self._diag] += d
        data = data[self._transpose]                  # M0^T in the same (symmetric) pattern
        self.lu = None
        self._slot[:] = -1
        self._used = 0
        self.dt0, self._d0, self._w0 = dt, d.copy(), w.copy()
        if nA == 0:
            return
        if self._full:
            mat = sp.csc_matrix((data, self._rows, self._indptr), shape=(nA, nA))
        else:
            keep = inA[self._rows] & inA[self._cols]
            cols = self._amap[self._cols[keep]]
            indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=nA))])
            mat = sp.csc_matrix((data[keep], self._amap[self._rows[keep]], indptr), shape=(nA, nA))
        self.lu = self._splu(mat, where)
        self._band = None
        if recent is not None and np.any(recent):
            band = recent & inA
            for _ in range(self.BAND):
                band |= (self._graph @ band.astype(np.int32)) > 0
            band &= inA
            if np.count_nonzero(band) < nA // 2:
                self._band = self._amap[np.nonzero(band)[0]]
        rows = nA if self._band is None else len(self._band)
        if self._band is not None:
            self._bmap = np.full(nA, -1)
            self._bmap[self._band] = np.arange(rows)
        if self.max_changed is not None:
            self._limit = max(self.max_changed, 0)
        else:
            self._limit = int(max(16, min((6.0 * self.lu.nnz) ** (1 / 3), 1.6e7 / rows)))
        if self._store.shape[0] != rows:
            self._store = np.zeros((rows, 0))

    def _splu(self, mat, where: str):
        """A counted SuperLU factorization of a (block of the) Newton matrix: minimum degree on the symmetric
        pattern A + A^T (the pattern is the stiffness pattern): 19 % less fill and 15 - 30 % faster solves than
        SuperLU's default COLAMD (42k unknowns: nnz(LU) 2.26M against 2.79M, transposed solve 2.4 against 2.8 ms)."""
        try:
            lu = spla.splu(mat, permc_spec="MMD_AT_PLUS_A")
        except RuntimeError as exc:                   # "Factor is exactly singular"
            raise SolverError(f"Stefan Newton step at {where}: the factorization failed ({exc}); check the "
                              "material data (capacities and conductivities must be > 0) and the time step.") from None
        self.factorizations += 1
        return lu

    def _adapt_width(self) -> None:
        """The window's width for the next placement, from the counted work of the last cycle: a placement
        (factorization and interface solves, T_p) against the Schur complement factorizations during the cycle
        (T_s); work as counted by :func:`lu_work` and :func:`lu_nnz` (a solve: two multiply-adds per factor
        entry), the Schur complement's weighted by ``SCHUR_WEIGHT``, so that the widths, and the run, are the
        same in every run. The cycle lasts about as many steps as the front needs to cross the width w, and the Schur
        complement grows like w, so the cost per step is about a/w + b w, least at w* = w sqrt(T_p / T_s)
        (changed by at most a factor 2 per cycle, within WINDOW_RANGE)."""
        if self._width is None:
            self._width = int(self.WINDOW)
        tp, ts = self._cycle
        if tp > 0:
            lo, hi = self.WINDOW_RANGE
            ratio = 2.0 if ts <= 0 else min(2.0, max(0.5, math.sqrt(tp / ts)))
            self._width = int(min(hi, max(lo, round(self._width * ratio))))
        self._cycle = [0.0, 0.0]

    def _place(self, d: np.ndarray, w: np.ndarray, dt: float, where: str, inA: np.ndarray, inC: np.ndarray) -> None:
        """Window mode: factor M0 on R = A - C (SuperLU, M0_RR^T as in :meth:`_factor`) and prepare the Schur
        complement on the window C (free nodes, bool ``inC``), whose columns may change until the next placement.
        With I the nodes of R next to C and Z = (M0_RR^-1)_II (|I| solves), every M that differs from M0 only
        in the columns of C is solved by block elimination (:meth:`_wsolve`):

            z = M_RR^-1 b_R,   (M_CC - M_CI Z M_IC) x_C = b_C - M_CI z_I,   x_R = z - M_RR^-1 (M_RC x_C),

        M_CI being constant (columns in R), M_CC and M_IC read from the current columns."""
        nF = self.nF
        rows, cols = self._rows, self._cols
        self.lu = None
        self._slot[:] = -1
        self._used = 0
        self._band = None
        self.dt0, self._d0, self._w0 = dt, d.copy(), w.copy()
        inR = inA & ~inC
        R, C = np.nonzero(inR)[0], np.nonzero(inC)[0]
        nR, nC = len(R), len(C)
        rpos = np.full(nF, -1)
        rpos[R] = np.arange(nR)
        cpos = np.full(nF, -1)
        cpos[C] = np.arange(nC)
        lu = None
        if nR:
            data = np.zeros(len(rows))
            for g, kd in enumerate(self._kdata):
                data += kd * w[cols, g]
            data[self._diag] += d
            data = data[self._transpose]              # M0^T in the same (symmetric) pattern
            keep = inR[rows] & inR[cols]
            c = rpos[cols[keep]]
            indptr = np.concatenate([[0], np.cumsum(np.bincount(c, minlength=nR))])
            mat = sp.csc_matrix((data[keep], rpos[rows[keep]], indptr), shape=(nR, nR))
            lu = self._splu(mat, where)
        cc = np.nonzero(inC[rows] & inC[cols])[0]     # M_CC entries (pattern positions)
        ic = np.nonzero(inR[rows] & inC[cols])[0]     # M_RC entries: change with the columns of C
        ci = np.nonzero(inC[rows] & inR[cols])[0]     # M_CR entries: constant
        I_ = np.unique(rows[ic])
        B_ = np.unique(cols[ic])                      # the nodes of C next to R
        nI, nB = len(I_), len(B_)
        ipos = np.full(nF, -1)
        ipos[I_] = np.arange(nI)
        bpos = np.full(nF, -1)
        bpos[B_] = np.arange(nB)
        Zt = np.zeros((nI, nI))
        for k in range(0, nI, 32):                    # columns of M_RR^-T e_i, i in I, in chunks (memory)
            chunk = np.arange(k, min(k + 32, nI))
            E = np.zeros((nR, len(chunk)))
            E[rpos[I_[chunk]], np.arange(len(chunk))] = 1.0
            Zt[:, chunk] = lu.solve(E)[rpos[I_]]
        self.corrections += nI
        vci = np.zeros(len(ci))
        for g, kd in enumerate(self._kdata):
            vci += kd[ci] * w[cols[ci], g]
        Mci = sp.csr_matrix((vci, (bpos[rows[ci]], ipos[cols[ci]])), shape=(nB, nI))
        P = np.asarray(Mci @ Zt.T) if nI else np.zeros((nB, 0))   # M_CI Z on the rows of C next to R
        # the pattern of S: M_CC's and the dense block on B x B, CSC order
        lin = np.concatenate([cpos[cols[cc]] * nC + cpos[rows[cc]],
                              np.tile(cpos[B_], nB) * nC + np.repeat(cpos[B_], nB)])
        uniq, inv = np.unique(lin, return_inverse=True)
        self._win = {
            "R": R, "C": C, "nR": nR, "nC": nC, "lu": lu, "rpos": rpos, "cpos": cpos,
            "cc": cc, "cc_rows": cpos[rows[cc]], "cc_diag": np.nonzero(rows[cc] == cols[cc])[0],
            "ic": ic, "ic_rows": rpos[rows[ic]], "ic_cols": cpos[cols[ic]],
            "ic_i": ipos[rows[ic]], "ic_b": bpos[cols[ic]],
            "ci_rows": cpos[rows[ci]], "ci_cols": rpos[cols[ci]], "vci": vci, "P": P, "nI": nI, "nB": nB,
            "S_inv": inv, "S_nnz": len(uniq), "S_indices": uniq % nC if nC else uniq,
            "S_indptr_cols": uniq // max(nC, 1), "perm": None, "S_order": None,
            "S_indptr": np.concatenate([[0], np.cumsum(np.bincount(uniq // max(nC, 1), minlength=nC))]),
            "S": None, "S_key": None, "vic": None, "S_work": None}
        self._win["cc_diag_node"] = C[self._win["cc_rows"][self._win["cc_diag"]]]
        self._last = (d.copy(), w.copy())
        self._cycle = [lu_work(lu) + 2.0 * nI * lu_nnz(lu) if lu is not None else 0.0, 0.0]

    def _factor_schur(self, d: np.ndarray, w: np.ndarray) -> bool:
        """Factor the window's Schur complement S of the columns (d, w) (:meth:`_wsolve`); False when singular."""
        W = self._win
        C, nC = W["C"], W["nC"]
        cols = self._cols
        cc, ic = W["cc"], W["ic"]
        vcc = np.zeros(len(cc))
        vic = np.zeros(len(ic))
        for g, kd in enumerate(self._kdata):
            vcc += kd[cc] * w[cols[cc], g]
            vic += kd[ic] * w[cols[ic], g]
        vcc[W["cc_diag"]] += d[W["cc_diag_node"]]
        Mic = np.zeros((W["nI"], W["nB"]))
        Mic[W["ic_i"], W["ic_b"]] = vic
        blk = W["P"] @ Mic
        data = np.bincount(W["S_inv"], weights=np.concatenate([vcc, -blk.ravel()]), minlength=W["S_nnz"])
        try:
            if W["perm"] is None:
                # the fill-reducing ordering of S's pattern, once per placement: S is then factored already
                # permuted, without ordering, and without relaxed supernodes (1239 unknowns at 42k nodes:
                # 2.1 ms against 4.9 ms with SuperLU's ordering and default relaxation)
                S = sp.csc_matrix((data, W["S_indices"], W["S_indptr"]), shape=(nC, nC))
                perm = spla.splu(S, permc_spec="MMD_AT_PLUS_A", relax=1).perm_c
                lin = perm[W["S_indptr_cols"]] * nC + perm[W["S_indices"]]
                order = np.argsort(lin)
                W["perm"], W["S_order"] = perm, order
                W["S_indices"] = lin[order] % nC
                W["S_indptr"] = np.concatenate([[0], np.cumsum(np.bincount(lin[order] // nC, minlength=nC))])
            S = sp.csc_matrix((data[W["S_order"]], W["S_indices"], W["S_indptr"]), shape=(nC, nC))
            W["S"] = spla.splu(S, permc_spec="NATURAL", relax=1)
        except RuntimeError:
            W["S"] = None
            return False
        W["S_key"] = (d[C].copy(), w[C].copy())
        W["vic"] = vic
        self.window_factorizations += 1
        if W["S_work"] is None:                   # the same pattern and ordering all placement long
            W["S_work"] = self.SCHUR_WEIGHT * lu_work(W["S"])
        self._cycle[1] += W["S_work"]
        return True

    def _wsolve(self, b: np.ndarray, d: np.ndarray, w: np.ndarray, where: str) -> np.ndarray:
        """M x = b in window mode (:meth:`_place`); None when the Schur complement is singular."""
        W = self._win
        R, C, nR, nC, lu = W["R"], W["C"], W["nR"], W["nC"], W["lu"]
        x = np.zeros(self.nF)
        if nC == 0:
            x[R] = lu.solve(b[R], trans="T")
            return x
        dC, wC = d[C], w[C]
        if W["S"] is None or not (np.array_equal(dC, W["S_key"][0]) and np.array_equal(wC, W["S_key"][1])):
            if not self._factor_schur(d, w):
                return None
        if nR:
            z = lu.solve(b[R], trans="T")
            rhs = b[C] - np.bincount(W["ci_rows"], weights=W["vci"] * z[W["ci_cols"]], minlength=nC)
        else:
            z, rhs = np.zeros(0), b[C].copy()
        rp = np.empty(nC)
        rp[W["perm"]] = rhs
        xC = W["S"].solve(rp)[W["perm"]]
        if not np.all(np.isfinite(xC)):
            return None
        x[C] = xC
        if nR:
            x[R] = z - lu.solve(np.bincount(W["ic_rows"], weights=W["vic"] * xC[W["ic_cols"]], minlength=nR),
                                trans="T")
        return x

    def _fresh(self, b: np.ndarray, d: np.ndarray, w: np.ndarray, where: str) -> np.ndarray:
        """M x = b right after a factorization (either mode)."""
        if self._win is None:
            return self._solve0(b)
        x = self._wsolve(b, d, w, where)
        if x is None:                                 # the window's Schur complement is singular: no window
            self._factor(d, w, self.dt0, where, window=False)
            return self._solve0(b)
        return x

    def _solve_window(self, b: np.ndarray, d: np.ndarray, w: np.ndarray, dt: float, where: str,
                      changed: np.ndarray) -> np.ndarray:
        """solve() in window mode: placed anew (around the nodes that changed since the last solve) when a column
        outside the window changed or a node outside the factored set turned sensible."""
        W = self._win
        since = (d != self._last[0]) | np.any(w != self._last[1], axis=1)
        self._last = (d.copy(), w.copy())
        outside = changed & (self._amap < 0)
        if (np.any(changed & (W["rpos"] >= 0))
                or (np.any(outside) and np.any(w[outside] != 0.0))):
            self._factor(d, w, dt, where, since)
            return self._fresh(b, d, w, where)
        x = self._wsolve(b, d, w, where)
        if x is None:
            self._factor(d, w, dt, where, window=False)
            return self._solve0(b)
        return x

    def _solve0(self, b: np.ndarray) -> np.ndarray:
        """M0^-1 b (free numbering; 0 outside the factored set)."""
        if self._full:
            return self.lu.solve(b, trans="T")
        x = np.zeros(self.nF)
        if self.lu is not None:
            x[self._A] = self.lu.solve(b[self._A], trans="T")
        return x

    def _columns(self, S: np.ndarray, d: np.ndarray, w: np.ndarray):
        """The non-zeros of (M - M0) E_S in the factored rows, column by column: rows (factored numbering),
        values, the owning column (0 .. |S|-1) and where each column starts."""
        starts, ends = self._indptr[S], self._indptr[S + 1]
        lens = ends - starts
        first = np.cumsum(lens) - lens
        pos = np.arange(int(lens.sum())) - np.repeat(first, lens) + np.repeat(starts, lens)
        owner = np.repeat(np.arange(len(S)), lens)
        vals = np.zeros(len(pos))
        for g, kd in enumerate(self._kdata):
            dw = w[S, g] - self._w0[S, g]
            if np.any(dw):
                vals += kd[pos] * dw[owner]
        vals[first + self._diag[S] - starts] += d[S] - self._d0[S]
        rows = self._amap[self._rows[pos]]
        if not self._full:                            # rows of unfactored (decoupled) nodes are not needed
            kept = rows >= 0
            rows, vals, owner = rows[kept], vals[kept], owner[kept]
            lens = np.bincount(owner, minlength=len(S))
            first = np.cumsum(lens) - lens
        return rows, vals, owner, first

    def _add_rows(self, new: np.ndarray) -> None:
        """v_i = M0^-T e_i for the nodes ``new`` (not cached yet): one batch of solves."""
        used, nA = self._used, len(self._A)
        if used + len(new) > self._store.shape[1]:
            grown = np.zeros((self._store.shape[0], min(self._limit, max(2 * self._store.shape[1], used + len(new),
                                                                             32))))
            grown[:, :used] = self._store[:, :used]
            self._store = grown
        E = np.zeros((nA, len(new)))
        E[self._amap[new], np.arange(len(new))] = 1.0
        V = self.lu.solve(E)
        self._store[:, used:used + len(new)] = V if self._band is None else V[self._band]
        self._slot[new] = np.arange(used, used + len(new))
        self._used = used + len(new)
        self.corrections += len(new)
        self._batches.append(np.array(new, dtype=np.int64))

    def capture(self) -> dict:
        """The reuse state as plain arrays: the data M0 was factored from (d0, w0, dt0, the recent nodes, the
        window flag; in window mode its width and the last solve's (d, w)) and the nodes whose rows v_i were
        solved since, batch by batch. {} before the first factorization or when the stiffness changed since
        (the next solve factors anew either way). :meth:`restore` factors the same M0 again and repeats the same
        solves, so that the Newton steps after it are those of an uninterrupted run to the last bit."""
        if self._d0 is None or self.version != self.forms.version:
            return {}
        recent, window = self._made
        sizes = [len(b) for b in self._batches]
        out = {"dt0": np.array(self.dt0), "d0": self._d0.copy(), "w0": self._w0.copy(), "window": np.array(window),
               "rows_nodes": np.concatenate(self._batches) if sizes else np.zeros(0, dtype=np.int64),
               "rows_batches": np.array(sizes, dtype=np.int64)}
        if recent is not None:
            out["recent"] = recent.copy()
        if self._win is not None:
            out["width"] = np.array(self._width if self._width is not None else self.WINDOW)
            out["last_d"], out["last_w"] = self._last[0].copy(), self._last[1].copy()
            out["cycle"] = np.array(self._cycle, dtype=float)
            if self._win["S"] is not None:
                out["schur_d"], out["schur_w"] = self._win["S_key"][0].copy(), self._win["S_key"][1].copy()
        return out

    def restore(self, state: dict) -> None:
        """The reuse state of :meth:`capture` (counted as one more factorization and the rows' solves)."""
        if not state:
            return
        if self.version != self.forms.version:
            self._load_stiffness()
        if "width" in state:
            self._width, self._cycle = int(np.ravel(state["width"])[0]), [0.0, 0.0]     # kept by _adapt_width
        recent = np.asarray(state["recent"], dtype=bool) if "recent" in state else None
        self._factor(np.asarray(state["d0"], dtype=float), np.asarray(state["w0"], dtype=float),
                     float(np.ravel(state["dt0"])[0]), "the resumed state", recent, bool(np.ravel(state["window"])[0]))
        if self._win is not None and "last_d" in state:
            self._last = (np.asarray(state["last_d"], dtype=float), np.asarray(state["last_w"], dtype=float))
            if "schur_d" in state:                    # the Schur complement factored then (not counted again)
                d, w = self._last[0].copy(), self._last[1].copy()
                C = self._win["C"]
                d[C], w[C] = np.asarray(state["schur_d"], dtype=float), np.asarray(state["schur_w"], dtype=float)
                if self._factor_schur(d, w):
                    self.window_factorizations -= 1
            if "cycle" in state:
                self._cycle = [float(v) for v in np.ravel(state["cycle"])]
        nodes = np.asarray(state["rows_nodes"], dtype=np.int64)
        for batch in np.split(nodes, np.cumsum(state["rows_batches"])[:-1]) if len(state["rows_batches"]) else []:
            self._add_rows(batch)

    def solve(self, mc: np.ndarray, wd: np.ndarray, w: np.ndarray, b: np.ndarray, dt: float,
              where: str) -> np.ndarray:
        """Solve M x = b on the free nodes, M = diag(d) + sum_g (K_g - diag K_g) diag(w_g) with the diagonal
        d = ``mc`` / dt + sum_g diag(K_g) ``wd``_g (``mc``: m times a capacity; ``wd``, ``w``: free nodes x
        groups; the diagonal weights ``wd`` may differ from ``w``). The unknowns of nodes with w_j = 0 come out
        as 0 when they are not factored (see the class docstring). A dt within 1e-12 relative of the factored one
        is taken as that one (the steps t1 - t0 of a constant schedule differ in the last bits)."""
        if self.nF == 0:
            return np.zeros(0)
        stale = self.version != self.forms.version     # the conductivities changed: factor anew
        if stale:
            self._load_stiffness()
        if self._d0 is not None and abs(dt - self.dt0) <= 1e-12 * self.dt0:
            dt = self.dt0
        d = mc / dt
        for g, kd in enumerate(self._kdiag):
            d = d + kd * wd[:, g]
        if self._d0 is None or dt != self.dt0 or stale:
            self._factor(d, w, dt, where)
            return self._fresh(b, d, w, where)
        changed = (d != self._d0) | np.any(w != self._w0, axis=1)
        if self._win is not None:
            return self._solve_window(b, d, w, dt, where, changed)
        recent = changed | (self._slot >= 0)
        if not self._full:
            outside = changed & (self._amap < 0)
            if np.any(outside) and np.any(w[outside] != 0.0):
                self._factor(d, w, dt, where, recent)
                return self._fresh(b, d, w, where)
            changed &= self._amap >= 0
        S = np.nonzero(changed)[0]
        if not len(S):
            return self._solve0(b)
        new = S[self._slot[S] < 0]
        if self._used + len(new) > self._limit:
            self._factor(d, w, dt, where, recent)
            return self._fresh(b, d, w, where)
        rows, vals, owner, first = self._columns(S, d, w)
        if self._band is not None:
            kept = self._bmap[rows]
            if np.any(kept < 0):                      # a change outside the rows kept: the front moved on
                self._factor(d, w, dt, where, recent)
                return self._fresh(b, d, w, where)
        else:
            kept = rows
        if len(new):
            self._add_rows(new)
        # E_S^T M0^-1 U: the rows v_i (i in S) at the non-zeros of U, summed per column of U
        small = np.add.reduceat(self._store[kept, :self._used][:, self._slot[S]] * vals[:, None], first, axis=0).T
        small.flat[::len(S) + 1] += 1.0
        bA = b if self._full else b[self._A]
        y = self.lu.solve(bA, trans="T")
        try:
            t = np.linalg.solve(small, y[self._amap[S]])
        except np.linalg.LinAlgError:
            t = None
        if t is None or not np.all(np.isfinite(t)):
            self._factor(d, w, dt, where, recent)
            return self._fresh(b, d, w, where)
        xA = self.lu.solve(bA - np.bincount(rows, weights=vals * t[owner], minlength=len(self._A)), trans="T")
        if self._full:
            return xA
        x = np.zeros(self.nF)
        x[self._A] = xA
        return x
