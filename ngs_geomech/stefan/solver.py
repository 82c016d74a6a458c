"""Time steps of the Stefan problem in enthalpy form (:mod:`ngs_geomech.stefan.forms`), seed (2.55):
a semi-smooth Newton method on the nodal enthalpy, and the smeared apparent-heat-capacity method for
comparison.

Semi-smooth Newton (:class:`StefanSolver`). One backward Euler step solves, for the free nodal enthalpies e,

    R(e) = m (e - e_old)/dt + A(beta(e)) - F = 0,

with beta the nodal inverse enthalpy graph (piecewise linear and Lipschitz) and A(T) = sum_g K_g theta_g(T)
(piecewise linear too). The generalized derivative of beta is 1/C_s, 0 (mushy), 1/C_l node by node (the flat
parts are closed: a node at a kink counts as mushy, see :meth:`StefanForms.nodal_state`), and that of theta_g
is k_s or k_l of the node's interval. With D = dT/de, a Newton step J de = -R, J = m/dt + A'(T) D, is computed
on the temperatures of the non-mushy free nodes N (dT = 0 on the mushy ones M, de_N = dT_N / D_N):

    (m C/dt + A'(T))_NN dT_N = -R_N,        de_M = -(dt/m)(R + A'(T) dT)_M.

R is piecewise linear in e: once every node is on its final branch (solid, mushy or liquid) the next Newton
step is exact, so Newton ends after a small number of iterations, about one more than the number of element
layers the phase boundary crosses in the step (each iteration moves it by about one layer). With dt refined
with h that number stays O(1): this is why the unknown is the enthalpy (single valued, Lipschitz inverse graph,
exact per-node semismoothness) rather than the temperature with the multivalued graph. The first iterate is the
old state plus dt times the last step's rate of change (a predictor: fewer nodes change branch during the
iteration). No damping or line search: none was needed in the measurements.

Linear algebra (:class:`_ColumnJacobian`). The system above is solved as the larger, block triangular system
on all free nodes in mixed unknowns (dT_j on a non-mushy node, a multiple of de_j on a mushy one), whose column
j is (m_j C_j/dt) e_j + sum_g K_g[:, j] dtheta_g(T_j), without its off-diagonal part when j is mushy (the mushy
rows do not feed back into N, so dT_N is the same; de_M is then taken from the explicit formula above, which
keeps exact zeros ahead of a one-phase front). In that form a column belongs to one node, so the Newton
matrices of all iterations and steps differ from a factored reference matrix only in the columns of the nodes
whose branch changed since it was factored, a few per step: they are solved exactly (to round-off) with one
sparse LU factorization (SuperLU) kept over many steps and a Sherman-Morrison-Woodbury correction of the size of
the changed set (two solves per iteration and one solve per newly changed node). It is refactored when the
changed set is large, when dt changes, or when a node outside the factored set (mushy nodes far from any
sensible one are left out: a one-phase solid at Theta_R) turns sensible. Keeping the diagonal of a mushy
column equal to the sensible one makes the correction of a node entering or leaving the flat part a change of
off-diagonal entries only: with the bare m_j C_j/dt the corrected solves of the one-phase problem left
residuals of 1e-11 instead of 1e-14 and Newton needed more iterations (mean 1.35 instead of 1.10 at
h = 0.003125).

Measured in one run against the previous solver (one sparse Cholesky or UMFPACK factorization of the reduced
system per Newton iteration whose branches differ from the last one) on the Neumann strips of
:mod:`ngs_geomech.verification.stefan`, P1, dt = 0.2 h s/m, one NGSolve and one BLAS thread: the same Newton
iterations and errors (the states agree to the Newton tolerance, max |de| <= 7e-13 J/m^3), 0.02 - 0.07
factorizations per step (0.5 - 1.8 before), time per step two-phase 0.80 -> 0.32, 8.8 -> 1.2, 20.6 -> 4.5,
148 -> 34 ms (h = 0.05, 0.0125, 0.00625, 0.003125 m; 215 ... 42k nodes), one-phase 0.49 -> 0.30,
2.0 -> 0.7, 12.2 -> 7.8 ms (h = 0.05, 0.0125, 0.003125): 2 - 3.6 linear heat steps (factorization reused)
instead of 4 - 24. Two BLAS threads on a busy 2-core machine made the steps up to 1.8 x slower (SuperLU's
multi-column solves and the small dense systems): run with one. With dt = 4 h (the front crosses several
layers per step) mean 8, max 13 iterations; a step asking the front to cross dozens of layers does not
converge in 25 iterations and raises SolverError. The stopping test is on the nodal residual: the enthalpy
defect max_i |R_i| dt/m_i (J/m^3) of the free nodes below ``tol`` times the enthalpy scale of the step (the
largest latent heat or C times the temperature range, whichever is larger). A step that does not converge
raises SolverError with the residual history and the nodes that still switch branch (never NaN).
``studies/stefan_performance`` measures iterations and the time per step against a linear heat step.

Window mode (factored sets of at least 8000 unknowns, see :class:`_ColumnJacobian`). The correction columns are
the nodes the front sweeps, one solve each, about 1/h per step with dt ~ h (5.3 per step at 42k nodes, 11.7 at
170k): on fine meshes they were the largest part of a step (time ratio 4.1 - 4.6 at 170k nodes), and no
refactoring policy removes them (after a factorization each node that changes needs its column again). The
large meshes therefore factor M0 outside a window around the front and solve the window's Schur complement,
factored per changed Newton matrix (sparse, of the window's size); a placement (the factorization and about two
solves per node across the front, for the window's interface) lasts until the front leaves the window, about
100 - 200 steps. Measured (``studies/stefan_performance`` level 2, one run on the busy shared machine): the same
iterations, states within 1.2e-12 J/m^3 (42k nodes), 0.5 - 0.6 interface solves and 0.006 - 0.014
factorizations per step (5.3 and 11.7 correction columns, 0.025 - 0.029 factorizations before), time ratio
against a linear heat step 1.65, 2.18, 1.76 at 10.8k, 42k, 170k nodes (before 2.78, 3.46, 4.61); old and new
in one process at 170k nodes (first 500 steps): 2.9 x faster per step, final states within 1.5e-13 J/m^3.

Temperature-dependent conductivity (b != 0, :mod:`ngs_geomech.stefan.forms`). theta is then quadratic on each
branch, and the Newton matrix's column j carries k_g(T_j) = k_g (1 + b_g (T_j - T_ref)), which changes at every
node in every iteration: the same :class:`_ColumnJacobian` gives the exact Newton step, but it refactors in
practically every iteration (the changed set is everything), so a step costs Newton iterations x one sparse LU.
Two safeguards, used only when b != 0 (the b = 0 path is unchanged, bit for bit): the update of a non-mushy node
is taken in its Kirchhoff variable (the step's change of theta, k dT, mapped back through the node's quadratic
theta, :meth:`StefanSolver._kirchhoff_update`; taken in T, a node far from the solution came back by halves as on
a parabola), and each node's increment is cut so that its factor 1 + b (T - T_ref) stays above 0.1 of its value
(:meth:`StefanSolver._in_range`; beyond f = 0 lies a spurious root with k < 0, where undamped iterations went).
Measured (``tests/test_stefan_kirchhoff.py``, melting strip, b = 0.01 1/K, dt = 0.4 h): Newton mean 3.3 - 4.0 per
step against 1.4 - 2.4 with b = 0, 3.3 - 4.0 factorizations per step against 0.04 - 0.11, 6.2, 11.5, 28.6 ms
per step against 1.5, 1.2, 5.3 ms (h = 0.05, 0.025, 0.0125 m; 4 - 9 times; one run on the shared machine). On the
steady slab (steps doubling up to 1e12 s) some steps near the diffusion time of the mesh did not converge and were
split (6 and 13 splits at h = 0.05, 0.025 against 0 and 3 with b = 0); the mushy nodes' cycling seen there is
not specific to b != 0.

Distributed meshes (MPI; :mod:`ngs_geomech.parallel`, selected by ``parallel.distributed(mesh)`` only, the serial
path above unchanged). The same iteration on the same unknown: every rank holds the nodal arrays of its vertices
with cumulated values (:class:`StefanForms`: masses, loads and A(T) cumulated over the ranks), so the branches, the
nodal states, the predictor and the mushy update de_M stay pointwise numpy; after each update the enthalpy of a
shared vertex is set to its owner's value (the same bits on every rank, so the ranks take the same branch there).
The stopping test, the round-off floor and the enthalpy scale are maxima over the ranks (``parallel.allmax``), the
heats and counts of :class:`StefanStepInfo` sums over the owned vertices (``parallel.allsum``), so every rank takes
the same branches around the collective calls, raises the same SolverError (the diagnosis gathers the switching
nodes of all ranks) and never sees NaN. The Newton step (m C/dt + A'(T))_NN dT_N = -R_N is solved by
:class:`_KrylovJacobian`: the Newton matrix in the mixed unknowns above, written into the local matrices of an
NGSolve ParallelMatrix (column j of the local stiffness scaled by dtheta_j, the lumped m C/dt on the owner rank's
diagonal), and GMRES (``ngsolve.krylovspace``, relative tolerance 1e-12 on the preconditioned residual; its true
residual is checked) on the non-mushy free nodes, the mushy ones held as fixed dofs (dT_M = 0, left out by the
preconditioner's projection; de_M then from their rows as above). Preconditioners: "bddc" (default), NGSolve's BDDC
on the symmetric form int kappa grad u . grad v + lumped C/dt (kappa the P1 interpolant of the nodal dtheta, the
mushy nodes pinned), built again only when dt changed by more than 25 %, GMRES needed more than 30 iterations, or a
pinned node turned sensible (it would be a near-null direction of the old preconditioner: GMRES then converged in
its norm, not in the residual's, which the true-residual check caught); and "jacobi" (the global diagonal, nothing
to build). Measured on ``melting_block`` (tests/mpi_cases/stefan_case.py, steps of 5 days, 3 ranks = 2 workers on
the busy 2-core machine, one run each): the same Newton iterations as the serial solver in every step, temperatures
within 2e-15 (BDDC) / 2e-13 (Jacobi) relative at 246 vertices; GMRES iterations per Newton solve, mean (max), BDDC
against Jacobi: 10.9 (14) / 54.5 (59) at 246 vertices, 14.8 (17) / 99 (109) at 918, 18.4 (22) / 178 (203) at 3459
(six steps); 16.6 (21) over 24 steps at 918 (52 Newton iterations as serially). BDDC was built once per run there
(at the first solve, with no mushy node; with a rebuild after 12 iterations instead of 30 it was built 24 times in
29 solves at 3459 vertices, 11.5 s against 8.7 s). Time of the whole case at 3459 vertices (meshing and set-up
included, rank 0 idling in the collectives on one of the 2 cores): 10 s with BDDC, 70 s with Jacobi, 2.7 s serially
(SuperLU with the Woodbury updates): on this machine the distributed path is slower than the serial one. Jacobi's
count grows like 1/h, BDDC's slowly; with P1 BDDC's coarse problem is the whole form, factored directly (NGSolve's
coarse inverse), so its builds do not scale like the Krylov part to very large meshes. The Neumann strips of
:mod:`ngs_geomech.verification.stefan` (h = 0.05 m, dt = 0.2 h s/m, 40 steps): the same Newton iterations per step
as serially, temperatures within 5e-15; one-phase (the solid at Theta_R, mushy ahead of the front) GMRES 3 per solve
and BDDC built 20 times in 42 solves (pinned nodes turning sensible), two-phase 13 per solve, built once; 3.4 and
4.8 s against 0.1 s serially (142 and 362 vertices: the per-iteration overheads of the Python GMRES and the
collectives dominate). The whole pipeline (``mpiexec -n 3 ngs-geomech run melting_block``, 60 days, h = 0.3 m, the
probes left out) gave the serial summary's melted volumes and heats to 5e-13 relative. Not available there: contact
interfaces (the mortar penalty: refused by :class:`StefanForms`), the smeared :class:`ApparentHeatCapacitySolver`,
and the SuperLU-specific options (``max_changed``, window mode).

Serial meshes with ``linear="iterative"`` (the scene's ``solver.linear``; "auto" above
:data:`ngs_geomech.stefan.problem.AUTO_NODES`) take the same :class:`_KrylovJacobian` with NGSolve's ``h1amg`` on
the same symmetric form instead of BDDC (whose P1 coarse problem is the whole form, factored). Measured on the
two-phase Neumann strip (tests/test_stefan_iterative.py): the same Newton iterations and temperatures to 4e-14;
GMRES 13 - 14 per solve at 1k nodes, 14 - 16 at 4k; 0.17 s per step against 0.013 s with SuperLU at 12k nodes
(2D, one thread): in 2D the direct path stays faster.

Smeared variant (:class:`ApparentHeatCapacitySolver`): the apparent heat capacity method with the capacity
lagged, m C_app(T_old)(T - T_old)/dt + A(T) = F with C_app = C + L/(2 delta) for |T - Theta_R| < delta, solved by
Newton's method for the Kirchhoff kink of A (one linear solve when k_s = k_l), with the same linear algebra (its
columns change where C_app(T_old) or the Kirchhoff slope changes). The fully implicit form
C_app(T)(T - T_old) was tried first: its residual jumps at Theta_R +- delta and Newton cycled between two
iterates from the first steps of the Neumann problems (delta = h, 4 h and 0.05 K), so it is not offered. The
lagged form is not conservative (C_app(T_old)(T - T_old) is not the change of the smeared enthalpy e_delta) and
misses latent heat when a node jumps over the band in one step; :mod:`ngs_geomech.verification.stefan`
measures both methods on the same problem.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import parallel
from ..errors import SolverError
from .forms import NodalState, PhaseChangeMaterial, StefanForms, time_function


@dataclass
class StefanStepInfo:
    """What one step did: ``iterations`` (linear solves), the final ``residual`` (max nodal enthalpy defect,
    J/m^3), ``boundary_heat`` (heat that entered through the Dirichlet nodes during the step, J per metre of
    depth in 2D, J in 3D), ``source_heat`` (sources and fluxes, same units), ``phase_changes`` (nodes whose
    branch, solid/mushy/liquid, changed in the step), ``factorizations`` (sparse LU factorizations in the step;
    on a distributed mesh the BDDC preconditioners built)
    and ``corrections`` (new low-rank correction columns, one solve each; in window mode the solves for the
    window's interface; see :class:`_ColumnJacobian`)."""

    iterations: int
    residual: float
    boundary_heat: float
    source_heat: float
    phase_changes: int
    factorizations: int = 0
    corrections: int = 0


class _ColumnJacobian:
    """Solves with M = diag(d) + sum_g (K_g - diag K_g) diag(w_g) on the free nodes, reusing one factorization.

    Every Newton matrix of this module has that form: column j belongs to node j alone (its diagonal d_j and the
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
    adapted at each placement to the measured costs of the last cycle (:meth:`_adapt_width`; timing-based, so the
    placements, and the round-off of the iterates, may differ between two runs of the same problem on large
    meshes; the Woodbury path below ``WINDOW_MIN`` is deterministic as before). ``factorizations``
    counts the factorizations of M0_RR, ``corrections`` the solves for Z, ``window_factorizations`` those of S.
    """

    HALO = 8
    BAND = 16
    WINDOW = 16
    WINDOW_RANGE = (4, 64)
    WINDOW_MIN = 8000
    WINDOW_FRACTION = 0.5

    def __init__(self, forms: StefanForms, max_changed: int | None = None):
        f = forms
        self.forms = forms
        self.free = np.nonzero(f.free)[0]
        nF = len(self.free)
        self.nF = nF
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
        self.factorizations = 0
        self.corrections = 0
        """Solves for the rows v_i (one per node and factorization)."""
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
        self._cycle = [0.0, 0.0]                        # seconds of the last placement, of Schur factorizations since
        """Sparse LU factorizations of the window's Schur complement (window mode, one per changed matrix)."""

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
        """The window's width for the next placement, from the measured costs of the last cycle: a placement
        (factorization and interface solves, T_p) against the Schur complement factorizations during the cycle
        (T_s). The cycle lasts about as many steps as the front needs to cross the width w, and the Schur
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
        start = time.perf_counter()
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
            "S": None, "S_key": None, "vic": None}
        self._win["cc_diag_node"] = C[self._win["cc_rows"][self._win["cc_diag"]]]
        self._last = (d.copy(), w.copy())
        self._cycle = [time.perf_counter() - start, 0.0]

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
            start = time.perf_counter()
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
                return None
            W["S_key"] = (dC.copy(), wC.copy())
            W["vic"] = vic
            self.window_factorizations += 1
            self._cycle[1] += time.perf_counter() - start
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
        solves, so that the Newton steps after it are those of an uninterrupted run to the last bit (window
        mode: up to its timing-based width adaptation, see the class docstring)."""
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


class _KrylovJacobian:
    """The distributed-mesh counterpart of :class:`_ColumnJacobian` (same :meth:`solve`, same matrices
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
    other unknowns are those of the full system (block triangular, see the module docstring), and their own
    unknowns come out as 0 (not used, as in :class:`_ColumnJacobian` for unfactored nodes).

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
        f = forms
        self.forms = f
        self.tol = float(tol)
        self.maxiter = int(maxiter)
        self.preconditioner = preconditioner
        self.free = np.nonzero(f.free)[0]
        self.nF = len(self.free)
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
        self.factorizations = 0
        self.corrections = 0
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
            form += indicator * self._kappa[g] * ngs.grad(u) * ngs.grad(v) * ngs.dx
        form += self._c * u * v * ngs.dx(intrules=f.rules)
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
        """Solve M x = b on the free nodes (arguments as :meth:`_ColumnJacobian.solve`, local free nodes, all
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


def _branch(st: NodalState) -> np.ndarray:
    """Per node: the interval index on a sensible branch, -1 - the flat part's index on a mushy one."""
    return np.where(st.mushy, -1 - st.segment, st.segment)


def _conduction_derivative_apply(forms: StefanForms, dtheta: np.ndarray, dT: np.ndarray) -> np.ndarray:
    """A'(T) dT = sum_g K_g (dtheta_g dT) (cumulated on a distributed mesh)."""
    if forms.distributed:
        return forms.cumulate(sum((K @ (dtheta[:, g] * dT) for g, K in enumerate(forms.stiffness)), np.zeros(forms.n)))
    return sum(K @ (dtheta[:, g] * dT) for g, K in enumerate(forms.stiffness))


class StefanSolver:
    """Backward Euler steps of the enthalpy formulation by the semi-smooth Newton method (module docstring).

    ``e`` holds the nodal enthalpy (J/m^3); set it with :meth:`set_initial`. ``tol`` is relative to the
    enthalpy scale, ``maxit`` the largest number of Newton iterations per step, ``max_changed`` the number of
    changed nodes after which the Newton matrix is factored again (default: see :class:`_ColumnJacobian`).
    On a distributed mesh (MPI), and on a serial one with ``linear="iterative"``, the Newton steps are solved by
    GMRES (:class:`_KrylovJacobian`, module docstring) with ``krylov_preconditioner`` "bddc" (the distributed
    default), "h1amg" (the serial default: NGSolve's AMG on the same symmetric form, serial only) or "jacobi";
    ``max_changed`` is not used there. On a distributed mesh every method that steps or sets the state is
    collective (every rank calls it).
    """

    def __init__(self, forms: StefanForms, tol: float = 1e-10, maxit: int = 25, predictor: bool = True,
                 max_changed: int | None = None, krylov_preconditioner: str | None = None, linear: str = "direct"):
        self.f = forms
        self.tol = tol
        self.maxit = maxit
        self.predictor = predictor
        self.e = np.zeros(forms.n)
        self._last_change = None          # (e_new - e_old)/dt of the last step
        self.distributed = forms.distributed
        """Distributed mesh (MPI): the Newton steps are solved by :class:`_KrylovJacobian` (module docstring)."""
        if linear not in ("direct", "iterative"):
            raise ValueError(f"the Stefan solver's linear solver must be 'direct' or 'iterative', got {linear!r}")
        self.linear = "iterative" if self.distributed else linear
        """'iterative': the Newton steps by GMRES (:class:`_KrylovJacobian`; always on a distributed mesh)."""
        if self.linear == "iterative":
            pre = krylov_preconditioner or ("bddc" if self.distributed else "h1amg")
            self.jac = _KrylovJacobian(forms, preconditioner=pre)
        else:
            self.jac = _ColumnJacobian(forms, max_changed)
        self.iterations: list[int] = []
        self._state = None                # (e, NodalState of e) of the last step's end
        self._dirichlet_static = all(getattr(time_function(v), "time_dependent", True) is False
                                     for v in forms.setup.dirichlet.values())
        self._dirichlet_cache = None

    @property
    def factorizations(self) -> int:
        return self.jac.factorizations

    def set_initial(self, temperature, liquid_fraction=None) -> None:
        """Initial state from nodal temperatures (array, K) or a CoefficientFunction interpolated at the nodes;
        ``liquid_fraction`` (array or CF, 0..1) decides nodes exactly at a phase-change temperature
        (default solid)."""
        T = self._nodal(temperature)
        self.f.check_conductivity(T, " at the initial state")
        f = None if liquid_fraction is None else self._nodal(liquid_fraction)
        self.e = self.f.consistent(self.f.enthalpy_of(T, f))
        self._last_change = None
        self.f.store(self.e)

    def set_initial_enthalpy(self, e) -> None:
        """Initial state from nodal enthalpies (array, J/m^3), e.g. :meth:`StefanForms.project_enthalpy`."""
        self.e = self.f.consistent(self._nodal(e))
        self.f.check_conductivity(self.f.nodal_state(self.e).T, " at the initial state")
        self._last_change = None
        self.f.store(self.e)

    def _nodal(self, value) -> np.ndarray:
        if isinstance(value, ngs.CoefficientFunction):
            if self.f.n == 0:                         # a rank without vertices (rank 0 of a distributed mesh)
                return np.zeros(0)
            pts = np.array([v.point for v in self.f.mesh.vertices])
            mp = self.f.mesh(*pts.T) if pts.shape[1] == 3 else self.f.mesh(pts[:, 0], pts[:, 1])
            return np.asarray(value(mp), dtype=float).ravel()
        arr = np.asarray(value, dtype=float)
        if arr.shape != (self.f.n,):
            raise ValueError(f"nodal values must have shape ({self.f.n},), got {arr.shape}")
        return arr

    def mark(self) -> tuple:
        """The solver's state between steps (enthalpy, predictor rate, cached nodal state, step count)."""
        return (self.e.copy(), None if self._last_change is None else self._last_change.copy(), self._state,
                len(self.iterations))

    def rewind(self, mark: tuple) -> None:
        """Back to a state from :meth:`mark`: the next :meth:`step` repeats the step taken since."""
        e, rate, state, n = mark
        self.e = e.copy()
        self._last_change = None if rate is None else rate.copy()
        self._state = state
        del self.iterations[n:]
        self.f.store(self.e)

    def capture(self) -> dict:
        """The state between steps as plain arrays: the enthalpy, the predictor rate and the Newton matrix's
        reuse state (``jacobian/...``, :meth:`_ColumnJacobian.capture`)."""
        out = {"enthalpy": np.array(self.e, dtype=float)}
        if self._last_change is not None:
            out["rate"] = self._last_change.copy()
        out.update({f"jacobian/{k}": v for k, v in self.jac.capture().items()})
        return out

    def restore(self, state: dict) -> None:
        """Continue from a state of :meth:`capture` (a checkpoint's; a missing rate or reuse state starts the
        next step without them)."""
        self.set_initial_enthalpy(np.array(state["enthalpy"], dtype=float))
        if "rate" in state:
            self._last_change = np.array(state["rate"], dtype=float)
        self.jac.restore({k.split("/", 1)[1]: v for k, v in state.items() if k.startswith("jacobian/")})

    def temperature(self) -> np.ndarray:
        """Nodal temperatures of the current state, K."""
        return self.f.nodal_state(self.e).T

    def _scale(self, T: np.ndarray) -> float:
        f = self.f
        lat = max([f.groups[g].latent_heat for g in f.pcm_groups] + [0.0])
        if self.distributed:                          # the same scale on every rank
            span = f.nodal_max(T) + f.nodal_max(-T)  # max T - min T over the ranks
            return max(lat, f.nodal_max(f.capacity, 0.0) * span, 1e-300)
        span = float(np.max(T) - np.min(T)) if T.size else 0.0
        return max(lat, float(np.max(f.capacity)) * span, 1e-300)

    def _old_state(self, e: np.ndarray) -> NodalState:
        """The nodal state of ``e``: the last step's final state when ``e`` is still its result."""
        if self._state is not None and np.array_equal(self._state[0], e):
            return self._state[1]
        return self.f.nodal_state(e)

    def _dirichlet_temperatures(self, t: float) -> np.ndarray:
        """Dirichlet temperatures at t (interpolated once when none depends on t)."""
        if not self._dirichlet_static:
            return self.f.dirichlet_temperatures(t)
        if self._dirichlet_cache is None:
            self._dirichlet_cache = self.f.dirichlet_temperatures(t)
        return self._dirichlet_cache

    def step(self, t_old: float, t_new: float, extra_load: np.ndarray | None = None) -> StefanStepInfo:
        """One backward Euler step from t_old to t_new (s): Dirichlet data, sources and fluxes at t_new.
        ``extra_load`` (nodal, W per metre of depth in 2D, W in 3D; e.g. the deformation heating of (2.49)) is
        added to the loads and counted in ``source_heat``; on a distributed mesh it holds this rank's vertices with
        cumulated values (the full nodal value at a shared vertex, as a GridFunction's vector), and the call is
        collective."""
        f = self.f
        dt = float(t_new) - float(t_old)
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"Stefan step: dt must be positive and finite, got {dt} (t_old {t_old}, t_new {t_new})")
        where = f"t = {t_new:g} s"
        fact0, corr0 = self.jac.factorizations, self.jac.corrections
        e_old = self.e.copy()
        st_old = self._old_state(e_old)
        e = e_old.copy()
        if self.predictor and self._last_change is not None:
            e[f.free] += dt * self._last_change[f.free]
            if f.temperature_dependent:
                e = e_old + self._in_range(e_old, e - e_old, st_old)
        if len(f.dirichlet_dofs):
            T_D = self._dirichlet_temperatures(t_new)
            d = f.dirichlet_dofs
            changed = T_D != st_old.T[d]
            if np.any(changed):
                T = st_old.T.copy()
                T[d] = T_D
                e[d[changed]] = f.enthalpy_of(T)[d[changed]]
        F = f.loads(t_new)
        if extra_load is not None:
            F = F + np.asarray(extra_load, dtype=float)
        free = f.free
        m = f.mass
        jfree = self.jac.free                        # the free nodes (indices)
        dt_m = dt / m
        dt_m_free = dt_m[jfree]
        rows = np.arange(f.n)
        history = []
        prev_st = None
        it = 0
        while True:
            st = f.nodal_state(e)
            if it == 0:
                scale = self._scale(np.concatenate([st_old.T, st.T]))
            R = m * (e - e_old) / dt + f.conduction(st.T) - F
            Rf = R[jfree]
            res = float(np.max(np.abs(Rf) * dt_m_free)) if len(jfree) else 0.0
            if self.distributed:                      # the same on every rank: every rank takes the same branches
                res = f.nodal_max(np.array([res if math.isfinite(res) else math.inf]), 0.0)
            if not math.isfinite(res):
                raise SolverError(f"Stefan Newton step at {where}: the residual is not finite "
                                  f"(history {history}). Check the material data and the time step.")
            history.append(res)
            if res <= self.tol * scale:
                break
            if it >= 2:
                # the defect cannot fall below the round-off of the terms it is made of (steps far longer than
                # the diffusion time of the mesh, large interface penalties): accept it there
                terms = (np.abs(e) + np.abs(e_old) + dt_m * (f.conduction_magnitude(st.T) + np.abs(F)))[jfree]
                floor = 64 * np.finfo(float).eps * (f.nodal_max(terms, 0.0) if self.distributed
                                                    else float(np.max(terms)))
                if res <= floor:
                    break
            if it >= self.maxit:
                f.check_conductivity(st.T, f" at {where}", floor=self.RANGE_FLOOR)
                switching = (np.zeros(0, dtype=int) if prev_st is None
                             else np.nonzero(_branch(st) != _branch(prev_st))[0])
                raise SolverError(self._diagnosis(where, history, switching, st, scale))
            prev_st = st
            dtheta = f.kirchhoff_derivatives(st)
            capacity = f.capacity[rows, st.segment]      # 1/D on the non-mushy nodes
            # the Newton matrix in mixed unknowns (dT on the non-mushy nodes, a multiple of de on the mushy ones):
            # column j is (m_j C_j/dt) e_j + sum_g K_g[:, j] dtheta_gj, without its off-diagonal part when j is
            # mushy (the diagonal kept, so that a node entering or leaving the flat part changes only the
            # off-diagonal entries of its column: a well-conditioned update); the mushy rows decouple
            # (block triangular), so dT on the non-mushy nodes is the Schur-reduced Newton step
            sensible = ~st.mushy[jfree]
            dth = dtheta[jfree]
            x = self.jac.solve((m * capacity)[jfree], dth, dth * sensible[:, None], -Rf * sensible, dt, where)
            dT = np.zeros(f.n)
            dT[jfree] = x * sensible
            y = _conduction_derivative_apply(f, dtheta, dT)
            # de = C dT on the non-mushy nodes; on the mushy ones from their rows: -(dt/m)(R + A'(T) dT)
            if f.temperature_dependent:
                # the update of a non-mushy node taken in its Kirchhoff variable (see _kirchhoff_update)
                de = np.where(st.mushy, -dt_m * (R + y), self._kirchhoff_update(st, dT, dtheta) * capacity)
                de[~free] = 0.0
                de = self._in_range(e, de, st)
            else:
                de = np.where(st.mushy, -dt_m * (R + y), dT * capacity)
                de[~free] = 0.0
            e = e + de
            if self.distributed:
                e = f.consistent(e)                   # a shared vertex: the same bits on every rank
            it += 1
        f.check_conductivity(st.T, f" at {where}")
        if self.distributed:
            return self._finish_distributed(e, e_old, st, st_old, R, F, dt, it, res, fact0)
        boundary_heat = float(dt * np.sum(R[~free]))
        self._last_change = (e - e_old) / dt
        self.e = e
        self._state = (e.copy(), st)
        f.store(e, st)                               # st is the nodal state of the final e
        self.iterations.append(max(it, 1))
        return StefanStepInfo(iterations=max(it, 1), residual=res, boundary_heat=boundary_heat,
                              source_heat=float(dt * np.sum(F)),
                              phase_changes=int(np.count_nonzero(_branch(st) != _branch(st_old))),
                              factorizations=self.jac.factorizations - fact0,
                              corrections=self.jac.corrections - corr0)

    def _finish_distributed(self, e, e_old, st, st_old, R, F, dt, it, res, fact0) -> StefanStepInfo:
        """The end of :meth:`step` on a distributed mesh: the state kept, the heats and counts summed over the
        global vertices (each once), the same on every rank."""
        f = self.f
        self._last_change = (e - e_old) / dt
        self.e = e
        self._state = (e.copy(), st)
        f.store(e, st)
        self.iterations.append(max(it, 1))
        changes = (_branch(st) != _branch(st_old)).astype(float)
        return StefanStepInfo(iterations=max(it, 1), residual=res,
                              boundary_heat=dt * f.nodal_sum(np.where(f.free, 0.0, R)),
                              source_heat=dt * f.nodal_sum(F), phase_changes=int(round(f.nodal_sum(changes))),
                              factorizations=self.jac.factorizations - fact0)

    def _kirchhoff_update(self, st: NodalState, dT: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """The temperature change of each node for the Newton step ``dT`` taken in the node's Kirchhoff variable.

        Per node the m-weighted Kirchhoff map of its materials on its current branch (extended past the branch's
        end) is exactly quadratic: theta(T + d) - theta(T) = a d + c d^2/2 with a = sum_g w_g k_g(T) and
        c = sum_g w_g k_g b_g. The Newton step asks for the change a dT of it (the linearization); this returns
        the d that gives it, d = 2 a dT / (a + sqrt(a^2 + 2 c a dT)) (= dT when c = 0; where the quadratic cannot
        reach a dT the turning point, cut by :meth:`_in_range`). Taking the step in T instead (d = dT) converged
        like the bisection far from the solution: with steps much longer than the diffusion time the step equation
        is nearly K theta = F, linear in theta, and a node overshooting to 1e8 K came back by halves."""
        f = self.f
        b, _ = f.group_law
        G = len(f.groups)
        w = f.weights
        a = np.sum(w * dtheta[:, :G], axis=1)
        k_ref = f.group_conductivity[:G, st.segment].T
        c = np.sum(w * k_ref * b[None, :G], axis=1)
        target = a * dT
        disc = a * a + 2.0 * c * target
        with np.errstate(invalid="ignore", divide="ignore"):
            d = np.where(disc > 0, 2.0 * target / (a + np.sqrt(np.maximum(disc, 0.0))),
                         np.where(c != 0, -a / np.where(c != 0, c, 1.0), dT))
        return np.where(a > 0, d, dT)

    RANGE_FLOOR = 1e-6
    """A step that does not converge with a node's factor 1 + b (T - T_ref) below this was held at the edge of
    the range by :meth:`_in_range` (each iteration keeps RANGE_FRACTION of the factor): its solution needs k <= 0,
    reported as such (ConductivityRangeError naming the key) instead of a non-converging Newton."""

    RANGE_FRACTION = 0.1
    """A Newton update keeps every free node's conductivity factor 1 + b (T - T_ref) at least this fraction of
    its value before the update (:meth:`_in_range`)."""

    def _in_range(self, e: np.ndarray, de: np.ndarray, st: NodalState) -> np.ndarray:
        """``de`` with each free node's increment cut so that its factor f = 1 + b (T - T_ref) (for every
        temperature-dependent material touching it) stays >= RANGE_FRACTION times its value at e (``st``: the
        nodal state of e): a bound on T per node, turned into one on e by the (monotone) nodal enthalpy graph.

        The Kirchhoff map of such a material is quadratic and turns back where f = 0 (T = T_ref - 1/b): beyond,
        a second, unphysical root of the step equation exists (k < 0), and undamped Newton steps from far away
        (steps much longer than the diffusion time of the mesh) went there. A global damping factor did not do:
        a mushy node whose increment overshoots by orders of magnitude (normal in the semi-smooth iteration)
        then stalled every other node, and the iteration cycled. The true solution lies inside the range (T stays
        between the data's extremes without sources), so near it nothing is cut and the convergence is Newton's."""
        f = self.f
        b, tref = f.group_law
        lo = np.full(f.n, -np.inf)
        hi = np.full(f.n, np.inf)
        for g, m in enumerate(f.groups):
            if b[g] == 0.0:
                continue
            on = (f.weights[:, g] > 0) & f.free
            f0 = m.conductivity_factor(st.T[on])
            lim = tref[g] + (self.RANGE_FRACTION * f0 - 1.0) / b[g]
            if b[g] > 0:
                lo[on] = np.maximum(lo[on], lim)
            else:
                hi[on] = np.minimum(hi[on], lim)
        e_new = e + de
        out = de
        for bound, frac, side in ((lo, 0.0, 1.0), (hi, 1.0, -1.0)):
            where = np.isfinite(bound)
            if not np.any(where):
                continue
            e_b = f.enthalpy_of(np.where(where, bound, st.T), frac)
            cut = where & (side * (e_new - e_b) < 0)
            if np.any(cut):
                out = out.copy() if out is de else out
                out[cut] = e_b[cut] - e[cut]
        return out

    def _diagnosis(self, where, history, switching, st: NodalState, scale) -> str:
        """The message of a step that did not converge (collective on a distributed mesh: the switching nodes of
        all ranks, the vertices each rank owns)."""
        f = self.f
        pts = np.array([v.point for v in f.mesh.vertices])
        if self.distributed:
            switching = switching[f.owned[switching]]
            local = [(tuple(round(float(c), 4) for c in pts[i]), float(st.T[i])) for i in switching[:5]]
            count = int(round(f.nodal_sum(np.isin(np.arange(f.n), switching).astype(float))))
            nodes = [item for part in parallel.allgather(f.mesh, local) for item in part][:5]
            at = "; ".join(f"node at {p} T = {T:.4g}" for p, T in nodes)
            switching = np.zeros(count)
        else:
            at = "; ".join(f"node {i} at {tuple(round(float(c), 4) for c in pts[i])} T = {st.T[i]:.4g}"
                           for i in switching[:5])
        hist = ", ".join(f"{h:.3e}" for h in history[-6:])
        return (f"Stefan Newton step at {where} did not converge in {self.maxit} iterations: nodal enthalpy "
                f"defect (J/m^3) history ... {hist}, tolerance {self.tol * scale:.3e}; "
                f"{len(switching)} node(s) still switch between solid, mushy and liquid"
                + (f" ({at})" if at else "") + ". Each Newton iteration moves the phase boundary by about one "
                "element layer, so a step in which it crosses many layers needs as many iterations: reduce the time "
                "step to about h / (front speed), or check that the mesh has no obtuse angles (the stiffness matrix "
                "should be an M-matrix).")


class ApparentHeatCapacitySolver:
    """Backward Euler steps of the smeared apparent-heat-capacity method, capacity lagged (module docstring).

    ``delta`` (K) is the half width of the smeared band; the state is the nodal temperature ``T`` (K).
    """

    def __init__(self, forms: StefanForms, delta: float, tol: float = 1e-10, maxit: int = 25):
        if not (delta > 0 and math.isfinite(delta)):
            raise ValueError(f"delta (half width of the smeared band) must be > 0 K, got {delta}")
        if not any(isinstance(m, PhaseChangeMaterial) for m in forms.groups):
            raise ValueError("the apparent heat capacity method needs a PhaseChangeMaterial")
        if forms.distributed:
            raise ValueError("the apparent heat capacity method is not available on a distributed mesh (MPI): "
                             "use StefanSolver or run serially")
        self.f = forms
        self.delta = float(delta)
        self.tol = tol
        self.maxit = maxit
        self.T = np.zeros(forms.n)
        self.jac = _ColumnJacobian(forms)
        self.iterations: list[int] = []

    @property
    def factorizations(self) -> int:
        return self.jac.factorizations

    def set_initial(self, temperature: np.ndarray) -> None:
        self.T = np.asarray(temperature, dtype=float).copy()

    def enthalpy(self) -> np.ndarray:
        """Nodal smeared enthalpy e_delta(T), J/m^3."""
        return self.f.smeared_enthalpy(self.T, self.delta)

    def step(self, t_old: float, t_new: float) -> StefanStepInfo:
        f = self.f
        dt = float(t_new) - float(t_old)
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"apparent heat capacity step: dt must be positive and finite, got {dt}")
        where = f"t = {t_new:g} s"
        T_old = self.T.copy()
        T = T_old.copy()
        if len(f.dirichlet_dofs):
            T[f.dirichlet_dofs] = f.dirichlet_temperatures(t_new)
        F = f.loads(t_new)
        free, m = f.free, f.mass
        lat = max([f.groups[g].latent_heat for g in f.pcm_groups] + [0.0])
        scale = max(lat, float(np.max(f.capacity)) * float(np.ptp(np.concatenate([T_old, T]))), 1e-300)
        history = []
        it = 0
        K = len(f.breakpoints)
        c = f.apparent_capacity(T_old, self.delta)
        while True:
            R = m * c * (T - T_old) / dt + f.conduction(T) - F
            res = float(np.max(np.abs(R[free]) * dt / m[free])) if free.any() else 0.0
            history.append(res)
            if not math.isfinite(res):
                raise SolverError(f"apparent heat capacity step at {where}: non-finite residual")
            if res <= self.tol * scale:
                break
            if it >= self.maxit:
                hist = ", ".join(f"{h:.3e}" for h in history[-6:])
                raise SolverError(f"apparent heat capacity Newton at {where} did not converge in {self.maxit} "
                                  f"iterations (defect history ... {hist} J/m^3); reduce the time step.")
            seg = np.minimum(np.count_nonzero(T[:, None] > f.breakpoints[None, :], axis=1), K)
            dtheta = f.kirchhoff_slopes(T, seg)
            jf = self.jac.free
            dT = np.zeros(f.n)
            dT[jf] = self.jac.solve((m * c)[jf], dtheta[jf], dtheta[jf], -R[jf], dt, where)
            T = T + dT
            it += 1
        self.T = T
        self.iterations.append(max(it, 1))
        return StefanStepInfo(iterations=max(it, 1), residual=res, boundary_heat=float(dt * np.sum(R[~free])),
                              source_heat=float(dt * np.sum(F)), phase_changes=0)
