"""The contact problem condensed onto the contact surface (``ContactSolver(linear="condensed")``): one sparse
factorization of K per solve, the active-set iteration on a dense problem of the surface dofs.

Method. The contact rows involve only the dofs of the contact surfaces, so with s those dofs (of the candidate
nodes below) and i the others, the free part of K u = f + B^T lam is condensed exactly onto s:

    S u_s = f_s - K_si K_ii^-1 f_i + B_s^T lam,    S = K_ss - K_si K_ii^-1 K_is    (dense, m x m),

which is a contact problem of the same form (:class:`.contact.ContactSolver` with a dense bulk: every Newton
step eliminates u against one Cholesky factorization of S and solves a dense system of the size of the active
rows). The interior follows from one solve, u_i = K_ii^-1 (f_i - K_is u_s). PARDISO computes S, the reduced load
and the interior solve from one factorization of K (:class:`.pardiso.SchurFactorization`), so the solve costs
about one sparse factorization plus dense work on the surface: the active-set iterations (one factorization of
the saddle-point matrix each, :mod:`.contact`'s direct path) no longer touch the bulk. The floating bodies need
no shift in K: their candidate nodes hold them (A_ii is then definite), and S keeps their rigid motions, which the
dense problem handles as the sparse one does (the shift eps and the refinement with the exact residual).

Candidate nodes. s holds the dofs of the nodes that can touch: per interface, those whose initial nodal gap is
within CANDIDATE_GAP (5e-4) of the interface's extent above the smallest one (all of an interface in initial
contact), the nodes of the last solution's contact set, and for a floating body enough nodes to hold it. Closing
a larger gap takes a relative displacement beyond 5e-4 of the body's size, beyond the small strains of rock
(1e-4 - 1e-3 at failure). The other nodes are open in the condensed problem; the solution is checked at every
node afterwards, and if any of them penetrates, the set grows by the nodes whose deformed gap is within the
window and the solve is repeated (``ContactInfo.candidate_passes``). The result is the solution of the whole
problem whatever the window: the window only decides the cost. Measured on the Hertz cylinder (P2, 140k dofs,
one thread; 160 nodes in contact): windows 3e-4 / 5e-4 / 1e-3 give 315 / 372 / 477 candidate nodes (790 / 1020
/ 1440 surface dofs); the numeric factorization takes 0.45 / 0.38 - 0.53 / 0.49 - 0.67 s (0.31 - 0.47 s without
a Schur set); the dense iteration with 1020 dofs 0.4 s (9 Newton steps). Three cold solves each, against the
fastest plain factorization + solve of K in the same run: 1.56 - 1.84 x with 3e-4, 1.66 - 1.94 x with 5e-4 (an
earlier version of the dense steps; the study's figures are in ``studies/contact_performance``). A window of 3e-4
is just the Hertz zone's (a^2 / 2R = 2e-4 of R); 5e-4 was kept for the margin. A window that misses the zone costs
a second factorization (the test with 1e-7: two passes).

When it applies. Plane (2D) and axisymmetric problems with a symmetric positive semi-definite K (not the mixed
formulation), with oneMKL PARDISO installed (:func:`.pardiso.available`). In 3D the contact surface has
~N^(2/3) dofs and S would be too large to be dense. Anything the condensed problem cannot take (K not definite
on the interior, a candidate set that holds no floating body, a solvability or convergence failure of the
condensed problem, a candidate set still growing after MAX_PASSES, more than MAX_DOFS surface dofs, a residual
of the whole system above RESIDUAL_TOL) falls back to the sparse direct path of :class:`.contact.ContactSolver`,
which then gives its own answer or error (``ContactInfo.condensed_fallback``). Seen in the test suite with the
condensed path the default (155 contact, dynamics, adaptivity and scene tests, all passing, 1603 condensed
solves): 8 needed a second candidate set, 4 fell back (and the test that forces one). Those 4 are floating blocks
on a foundation held by Coulomb friction: a block at half its capacity (P1, 11 nodes), the block scene of
``tests/test_contact_scenes.py`` and the two Uzawa comparisons; the condensed problem's sets "do not hold the
body" at iteration 2 (the dense steps' refinement did not bring the correction below 1e-6 of u; not understood
yet). The fallback costs the condensed attempt on top of the sparse solve. (Two more, the blocks pushed across a
gap by a prescribed displacement, were false alarms of the residual check, whose scale lacked the load of the
prescribed displacements; fixed.)

Units: u m, multipliers Pa, gaps m.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..linalg import pardiso
from .linear_algebra import drop_prescribed_nodes, is_symmetric

CANDIDATE_GAP = 5e-4
"""Candidate nodes: initial nodal gap within this fraction of the interface's extent above its smallest gap."""
MAX_PASSES = 3
"""Candidate sets tried (each a new factorization) before the sparse path takes over."""
MAX_DOFS = 5000
"""The most surface dofs condensed (dense S: 200 MB and ~4e10 flops for its Cholesky factorization at 5000); a
larger candidate set goes to the sparse path."""
PENETRATION_TOL = 1e-12
"""A non-candidate node penetrating by more than this fraction of the interface's extent enlarges the set."""


def applicable(dim: int) -> bool:
    """Whether the condensed path can run here: 2D (plane or axisymmetric) with PARDISO installed."""
    return dim == 2 and pardiso.available()


class CondensedContact:
    """The condensed solves of one :class:`.contact.ContactSolver` (``outer``), which keeps the laws, the
    settings, the warm-start sets (its interfaces) and the history."""

    def __init__(self, outer):
        self.outer = outer
        self._schur: tuple | None = None     # (the Schur dofs as bytes, their SchurFactorization)
        self._inner = None
        self._inner_key = None

    # ------------------------------------------------------------------ candidate sets
    def _extent(self, op) -> float:
        return max(float(np.max(np.ptp(op.coords, axis=0))) if op.size > 1 else 0.0, 1e-300)

    def _candidates(self, ifs, u: np.ndarray | None) -> list[np.ndarray]:
        """Per interface the candidate nodes (module docstring): the gap window on the initial gaps (and on the
        deformed ones of ``u``), the nodes in contact in the outer solver's last sets."""
        out = []
        for it in ifs:
            op = it.op
            g = op.g0 / it.w
            window = CANDIDATE_GAP * self._extent(op)
            keep = it.keep
            cand = np.zeros(it.m, dtype=bool)
            if keep.any():
                cand = keep & (g <= float(np.min(g[keep])) + window)
                if u is not None:
                    gd = (op.g0 + it.Bn @ u) / it.w
                    cand |= keep & (gd <= window)
                if self.outer.converged:
                    cand |= keep & it.active
            out.append(cand)
        return out

    def _hold_floating(self, ifs, cands, n: int, free: np.ndarray) -> bool:
        """Add nodes (by increasing gap) until the Schur dofs hold every floating body's rigid motions (A_ii
        definite); False when even all nodes do not."""
        bodies = self.outer.floating
        if not bodies:
            return True
        for body in bodies:
            modes = body.modes[:n]
            k = modes.shape[1]
            while True:
                cols = self._columns(ifs, cands, n, free)
                if np.linalg.matrix_rank(modes[cols], tol=1e-10 * max(float(np.abs(modes).max()), 1e-300)) >= k:
                    break
                grown = False
                for it, cand in zip(ifs, cands):
                    rest = np.nonzero(it.keep & ~cand)[0]
                    if len(rest):
                        g = it.op.g0[rest] / it.w[rest]
                        cand[rest[np.argsort(g)[:max(2, int(cand.sum()))]]] = True
                        grown = True
                if not grown:
                    return False
        return True

    @staticmethod
    def _columns(ifs, cands, n: int, free: np.ndarray) -> np.ndarray:
        """The free dofs of the candidate nodes' rows (normal and tangential), sorted."""
        parts = []
        for it, cand in zip(ifs, cands):
            for B in (it.Bn, it.Bt, it.Bt2):
                if B is not None and cand.any():
                    parts.append(B[:, :n][cand].tocoo().col)
        cols = np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.int64)
        return cols[free[cols]]

    # ------------------------------------------------------------------ the solve
    def solve(self, matrix, rhs, free: np.ndarray, x0: np.ndarray, where: str):
        """(u, info) of the whole problem, or None when the condensed path cannot take it (the caller then
        solves it with the sparse path)."""
        outer = self.outer
        tic = time.perf_counter()
        n = len(x0)
        ifs = outer.interfaces(n)
        free = np.asarray(free, dtype=bool)
        drop_prescribed_nodes(ifs, free, n)
        f = np.where(free, np.asarray(rhs, dtype=float), 0.0)
        if not np.all(np.isfinite(f)) or not is_symmetric(matrix):
            return None          # the sparse path names the bad load; an unsymmetric K is not for Cholesky
        if outer.floating:
            outer.check_load(ifs, f, where)
        kr, kc, kv = (np.asarray(a) for a in matrix.COO())
        kr, kc, kv = kr.astype(np.int64), kc.astype(np.int64), np.asarray(kv, dtype=float)
        loc = np.full(n, -1, dtype=np.int64)
        fi = np.nonzero(free)[0]
        loc[fi] = np.arange(len(fi))
        up = free[kr] & free[kc] & (kr <= kc)          # the upper triangle of K_ff, PARDISO's input
        Kff = sp.csr_matrix((kv[up], (loc[kr[up]], loc[kc[up]])), shape=(len(fi), len(fi)))
        fd = free[kr] & ~free[kc]                      # the prescribed displacements' load
        b = f[fi] - np.bincount(loc[kr[fd]], weights=kv[fd] * x0[kc[fd]], minlength=len(fi))
        info = None
        u = None
        passes = 0
        factorizations = 0
        while passes < MAX_PASSES:
            passes += 1
            cands = self._candidates(ifs, u)
            if not self._hold_floating(ifs, cands, n, free):
                return None
            cols = self._columns(ifs, cands, n, free)
            if len(cols) > MAX_DOFS:
                return None
            try:
                fac, fresh = self._factor(Kff, cols, loc, where)
            except SolverError:
                return None
            factorizations += fresh
            y_s, work = fac.reduce(b)
            inner = self._inner_solver(ifs, cands, cols, n, x0, free)
            if outer.converged:
                inner.warm_start(len(cols), [(it.active & c, it.stick & c, it.slip & c) for it, c in zip(ifs, cands)])
                for it_in, it in zip(inner.interfaces(len(cols)), ifs):
                    it_in.sign, it_in.dir, it_in.kappa = it.sign.copy(), it.dir.copy(), it.kappa.copy()
            else:
                inner.cold_start()
            try:
                u_s, info_in = inner.solve(fac.S, y_s, np.ones(len(cols), dtype=bool), np.zeros(len(cols)), where)
            except SolverError:
                return None
            u = np.array(x0, dtype=float)
            u[fi] = fac.expand(work, u_s)
            info = info_in if info is None else _merged(info, info_in)
            # every node: a non-candidate penetrating means the window missed it
            missed = False
            for it, cand in zip(ifs, cands):
                gap = (it.op.g0 + it.Bn[:, :n] @ u) / it.w
                if np.any(it.keep & ~cand & (gap < -PENETRATION_TOL * self._extent(it.op))):
                    missed = True
            if not missed:
                break
        else:
            return None
        # the safety net: the residual of the whole system (a K_ii that a rounding error kept from looking
        # singular, a bad candidate set) sends the problem to the sparse path instead of returning a wrong u
        if _residual(matrix, u, f, free, ifs, inner.multipliers, n, float(np.linalg.norm(b))) > RESIDUAL_TOL:
            return None
        return self._adopt(inner, ifs, cols, u, info, factorizations, passes, tic)

    def _adopt(self, inner, ifs, cols: np.ndarray, u: np.ndarray, info, factorizations: int, passes: int,
               tic: float):
        """The outer solver's state from the condensed solution: the sets of the solution, its multipliers, the
        history (the inner solver's record stays as it was); returns (u, info)."""
        outer = self.outer
        n = len(u)
        for it, it_in in zip(ifs, inner.interfaces(len(cols))):
            for key in ("active", "stick", "slip", "sign", "dir", "kappa"):
                setattr(it, key, np.array(getattr(it_in, key)))
        outer.multipliers = [(np.array(a), np.array(t)) for a, t in inner.multipliers]
        outer.converged = True
        pen = 0.0
        for it in ifs:
            gap = (it.op.g0 + it.Bn[:, :n] @ u) / it.w
            pen = max(pen, float(np.max(-gap[it.keep], initial=0.0)))
        info = dataclasses.replace(info)
        info.max_penetration = pen
        info.factorizations += factorizations
        info.condensed_dofs = len(cols)
        info.candidate_passes = passes
        info.wall_s = time.perf_counter() - tic
        outer.infos.append(info)
        return u, info

    def _factor(self, Kff: sp.csr_matrix, cols: np.ndarray, loc: np.ndarray, where: str):
        """PARDISO's factorization of K_ff (``Kff``: its upper triangle) with the Schur set ``cols`` (numbers in
        X): reused when the pattern and the set are the last solve's (only the numeric phase when the values
        changed, nothing when they did not). Returns (the factorization, 1 when factored now else 0)."""
        key = cols.tobytes()
        what = f"condensed contact solve{' at ' + where if where else ''}"
        if self._schur is not None and self._schur[0] == key:
            fac = self._schur[1]
            state = fac.compare(Kff, upper=True)
            if state == "same":
                return fac, 0
            if state == "values":
                fac.factor(Kff, upper=True)
                return fac, 1
        if self._schur is not None:
            self._schur[1].close()
            self._schur = None
        fac = pardiso.SchurFactorization(Kff, loc[cols], what=what, upper=True)
        self._schur = (key, fac)
        return fac, 1

    def _inner_solver(self, ifs, cands, cols: np.ndarray, n: int, x0: np.ndarray, free: np.ndarray):
        """The dense contact solver of the condensed problem for this candidate set (kept for the next solves):
        the interfaces' operators restricted to the candidate rows and the Schur dofs (the prescribed
        displacements moved into the gaps), the floating bodies' motions restricted to the Schur dofs."""
        key = (cols.tobytes(), tuple(c.tobytes() for c in cands))
        outer = self.outer
        fixed = np.nonzero(~free)[0]
        if self._inner is not None and self._inner_key == key:
            # the gaps may have changed since (a time step's gaps at its start; other prescribed displacements)
            for (op, _), (op_in, _) in zip(outer.items, self._inner.items):
                op_in.g0 = op.g0 + _padded(op.Bn, n)[:, fixed] @ x0[fixed]
            return self._inner
        items = []
        for (op, law), it, cand in zip(outer.items, ifs, cands):
            mask = sp.diags(cand.astype(float))

            def cut(B):
                return None if B is None else (mask @ _padded(B, n)[:, cols]).tocsr()
            g0 = op.g0 + _padded(op.Bn, n)[:, fixed] @ x0[fixed]
            items.append((dataclasses.replace(op, Bn=cut(op.Bn), Bt=cut(op.Bt), Bt2=cut(op.Bt2), g0=g0,
                                              coverage=np.where(cand & it.keep, op.coverage, 0.0)), law))
        floating = [dataclasses.replace(b, modes=b.modes[:n][cols]) for b in outer.floating]
        # its dense bulk selects the dense steps; the solvability of the load was checked on all nodes (the outer
        # solver), the candidate nodes alone could wrongly refuse it
        inner = outer.inner_solver(items, floating)
        self._inner, self._inner_key = inner, key
        return inner


RESIDUAL_TOL = 1e-8
"""The largest relative residual of K u - f - B^T lam (free dofs) a condensed solution may leave."""


def _residual(matrix, u: np.ndarray, f: np.ndarray, free: np.ndarray, ifs, multipliers, n: int,
              load: float) -> float:
    """|K u - f - Bn^T lam_n - Bt^T lam_t| on the free dofs, relative to the forces involved: |f|, |K u|, the
    contact forces and ``load`` (|f - K_fd x0_d|: a problem driven by prescribed displacements has f = 0 and, at
    the solution, K u = 0 on the free dofs)."""
    x = matrix.CreateColVector()
    y = matrix.CreateColVector()
    x.FV().NumPy()[:] = u
    y.data = matrix * x
    ku = np.array(y.FV().NumPy())
    contact = np.zeros(n)
    for it, (lam_n, lam_t) in zip(ifs, multipliers):
        contact += it.Bn[:, :n].T @ lam_n
        if it.dim3:
            contact += it.Bt[:, :n].T @ lam_t[:, 0] + it.Bt2[:, :n].T @ lam_t[:, 1]
        else:
            contact += it.Bt[:, :n].T @ lam_t
    r = ku - f - contact
    scale = (float(np.linalg.norm(f[free])) + float(np.linalg.norm(ku[free])) + float(np.linalg.norm(contact[free]))
             + load)
    return float(np.linalg.norm(r[free])) / max(scale, 1e-300)


def _padded(B: sp.csr_matrix, n: int) -> sp.csr_matrix:
    """``B`` with n columns (an operator of V inside a larger X has fewer)."""
    if B.shape[1] == n:
        return B.tocsr()
    return sp.hstack([B, sp.csr_matrix((B.shape[0], n - B.shape[1]))]).tocsr()


def _merged(first, second):
    """The history of two passes as one (iterations and factorizations added, the lists joined)."""
    out = dataclasses.replace(second)
    out.iterations = first.iterations + second.iterations
    out.factorizations = first.factorizations + second.factorizations
    for key in ("active", "stick", "slip", "changes", "newton_residual"):
        setattr(out, key, list(getattr(first, key)) + list(getattr(second, key)))
    return out
