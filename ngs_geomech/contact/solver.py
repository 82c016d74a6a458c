"""Frictional contact solves of problem (P): (2.17)-(2.27) with the discrete operators of
:mod:`ngs_geomech.contact.forms`.

Default method: a primal-dual active set method, i.e. a semi-smooth Newton method on the nodal
complementarity functions of the augmented Lagrangian (Alart-Curnier type; Hueber, Stadler and Wohlmuth,
SIAM J. Sci. Comput. 30 (2008) for the friction part)

    C_n = lam_n - max(0, lam_n - c g~),                      g~ = g_j / weight_j (nodal gap, m),
    C_t = max(b, |z|) lam_t - b z,    z = lam_t - c s~,      b = g_c (Tresca) or F_c max(0, lam_n - c g~),

c the augmentation (Pa/m; default E_max / h_j). Each step takes the sets A = {lam_n - c g~ > 0} (in contact),
of the active nodes the stick set {|z| < b} and the slip set, and solves the saddle-point system

    K u - Bn^T lam_n - Bt^T lam_t = f,
    g_j = 0 (A),  lam_n,j = 0 (not A),  s_j = 0 (stick),  lam_t,j = b_j sign(z_j) (slip),  lam_t,j = 0 (not A)

(Coulomb slip: lam_t,j - F_c sign(z_j) lam_n,j = 0); it stops when the sets repeat, which for these
piecewise linear conditions means the step solved them exactly. Measured on the Hertz test
(verification/contact_problems.py, P1, h = a/5 ... a/40): 6, 8, 9, 9 iterations. Friction acts on nodes in
contact only (an open node carries no traction).

3D (the operator has ``Bt2``): lam_t,j, s~_j and z_j are vectors of R^2 (components along t1, t2 = n x t1),
the cone is |lam_t,j| <= b_j, and the slip condition lam_t = b z / |z| is nonlinear. The slip rows are the
Newton linearization at the current iterate (z_k, b_k) of the projection form of C_t,
lam_t - b z / max(b, |z|) (C_t above divided by max(b, |z|): the same zeros), with e = z_k / |z_k|,
T = I - e e^T (the projection onto the plane normal to the slip direction) and kappa = b_k / max(|z_k|, b_k)
(b_k = g_c, or F_c lam_n,k as in the 2D rows):

    lam_t,j - kappa T (lam_t,j - c_t s~_j) = g_c e (Tresca),     ... = F_c lam_n,j e (Coulomb)

(d(b z/|z|)/dz = b/|z| T). In 2D T = 0 and these are the rows above, so the 2D iteration is unchanged. Why this
form rather than the full Newton rows of HSW's max(b, |z|) lam_t - b z, whose derivative
|z| dlam + lam_k e^T dz - b dz - z db carries lam_k: the two coincide when lam_k = b e (at the solution), but
for lam_k off the cone (just after stick -> slip) those rows need lam_k damped back into the cone
(HSW's modified algorithm) to keep the 2 x 2 block regular, while here I - kappa T has the eigenvalues 1 (along e) and
1 - kappa in [0, 1) across, and the across direction always keeps the penalty-like coupling kappa c_t T s~ (a
stick row in the limit kappa -> 1): the block is regular for any iterate, and nothing of lam_k enters. A node
forced to slip with |z_k| < b (the twice-switched nodes below) gets kappa = 1: lam_t . e = b with no slip
across e. The sets no longer settle the solution: the iteration stops when they repeat and the slip rows'
residual max |lam_t - b z / |z|| over the nodes slipping in both of the last two iterates is below
NEWTON_TOL (1e-11) of the largest bound (superlinear, e.g. 9e-3, 1e-4, 3e-11, 4e-16 in the last steps; 5 to 10
iterations on the block tests, tests/test_contact_friction_3d.py). The slip rows change at every iteration, so
a 3D solve with more than a few slipping nodes factors at every iteration (no Woodbury reuse). The multipliers
of a 3D interface are (lam_n (m,), lam_t (m, 2)).

Linear algebra: one saddle-point matrix per solve with a fixed sparsity pattern (:class:`_Pattern`; in 3D a
third multiplier block per interface, the rows of t1 and t2 on the union of the patterns of Bt and Bt2, and
the 2 x 2 multiplier blocks); a fixed multiplier (open node, 2D Tresca slip) keeps its row as an identity row
scaled like the penalty rows, so the
matrices of consecutive iterations differ only in the rows of the nodes whose state changed. A matrix is
factored (UMFPACK) when more than ``reuse_rows`` (12) rows changed since the last factorization without a
cached solve; otherwise the old factorization is reused through the Sherman-Morrison-Woodbury formula
(:class:`_Reuse`: one extra solve per changed row). The active sets of the Hertz test (P2, 41k dofs) shrink
geometrically, 186, 143, 115, 99, 90, 85, 83, 82, 81 nodes: 6 factorizations and 18 extra solves instead of
11 factorizations.

Which factorization: a matrix whose bulk K is symmetric and whose multiplier rows are the transposes of their
columns or fix their multiplier alone (frictionless, Tresca, Coulomb while no node slips; 2D, or 3D frictionless)
is factored through its symmetric quasi-definite companion (:meth:`_Pattern.symmetric`: the columns of fixed
multipliers left out, the exact rows' zero diagonal -w / (c x QUASI_DEFINITE)) by NGSolve's sparse Cholesky
(LDL^T without pivoting, which every symmetric quasi-definite matrix admits), and the solve is refined with the
exact residual (the companion's solve is the matrix's to ~1e-8; one more step to round-off); other matrices by
UMFPACK. Measured at 140k dofs (P2 Hertz, one thread): 1.17 - 1.26 s per factorization and 0.08 - 0.09 s per
solve, against 1.9 s and 0.18 s with UMFPACK. A Woodbury update of a companion's factorization also adds the
columns of the nodes that entered the contact or started sticking since (the companion left them out:
:class:`_Reuse`), one more solve per such node. The saddle-point pattern is the sum of K embedded and the
multiplier entries (CreateSparseMatrix, 0.08 s at 140k dofs; CreateFromCOO of the whole took 1.2 - 1.4 s).

Iterative Newton steps (``linear="iterative"``, the scene's ``solver.linear``; issue 10): each Newton-step matrix
is solved by GMRES with the augmented-Lagrangian AMG preconditioner of :mod:`.contact_krylov` instead of the
factorizations above (no Woodbury reuse, no companion; the floating bodies' refinement criteria as above; the
rigid motions that nothing holds are kept out of the iterates, :func:`_free_motions`). The iterations per Newton
step grow slowly under refinement (3D Coulomb punch: P1 41 -> 90 from 663 to 121k dofs, P2 54 -> 99 from 3.8k to
130k), and the 130k-dof P2 solve takes 68 s against 399 s directly (the tables of :mod:`.contact_krylov` and
``studies/scaling``). The slip rows of 3D friction then converge to 100 x the GMRES tolerance instead of
NEWTON_TOL.

Condensed solves (``linear="condensed"``, the default "auto" in 2D when PARDISO is installed): the problem is
condensed onto the dofs of the contact nodes by one PARDISO factorization of K with their Schur complement S
(:mod:`.contact_condensed`), and this solver then runs on the dense S (a numpy bulk): the same iteration, the
pattern holding only the multiplier entries, each Newton step eliminating u against one Cholesky factorization of
S (:class:`_DenseStep`: (D - R S^-1 C) lam = r_m - R S^-1 r_u over the rows coupled to u, the others through their
own block). S is shifted by DENSE_SHIFT = 1e-7 of its mean diagonal on the floating bodies' dofs (on all dofs
when none is declared: a time step's body on a foundation), not 1e-10: the elimination through S^-1 loses about
the shift's inverse in relative accuracy (with 1e-10 the refinement of a floating Coulomb block stalled at a
relative step error of 5e-7), and the refinement with the exact residual removes the shift as before.

Units: u m, multipliers Pa (nodal values of the contact pressure and tangential traction).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..linalg.direct import check_finite, inverse
from .condensed import CondensedContact, applicable
from .forms import ContactOperator
from .linear_algebra import drop_prescribed_nodes, is_symmetric

LAWS = ("frictionless", "tresca", "coulomb")
COULOMB_FIXED_POINT_TOL = 1e-8    # Coulomb fallback: relative change of the slip bounds F_c p that ends it
COULOMB_FIXED_POINT_MAXIT = 60
NEWTON_TOL = 1e-11     # 3D slip rows: converged when max |lam_t - b z / |z|| <= NEWTON_TOL x the largest bound
POLYGON = 16           # 3D solvability check: the friction disc |lam_t| <= b inside a regular 16-gon
QUASI_DEFINITE = 1e8   # symmetric systems: the exact rows' zero diagonal -w / c becomes -w / (c x 1e8) when factored
DENSE_SHIFT = 1e-7       # a dense bulk's relative shift (the sparse path's is 1e-10; module docstring of _DenseStep)
INEXACT_REFINEMENTS = 6  # refinement steps with the quasi-definite factorization before factoring exactly


@dataclass
class ContactLaw:
    """The law of one interface: ``kind`` in :data:`LAWS`; ``slip_bound`` g_c per node (Pa, Tresca);
    ``friction`` F_c (Coulomb); ``augmentation`` c (Pa/m, None: E_max / nodal size); ``penalty``: this
    interface keeps the penalty rows (lam_n = c x penetration, lam_t = c_t x stick slip) to the end instead of
    switching to exact constraints (the whole solve is penalty with ContactSolver(method="penalty"))."""

    kind: str = "frictionless"
    slip_bound: np.ndarray | float | None = None
    friction: float = 0.0
    augmentation: float | None = None
    penalty: bool = False

    def __post_init__(self):
        if self.kind not in LAWS:
            raise ValueError(f"unknown contact law {self.kind!r}; choose one of {', '.join(LAWS)}")
        if self.kind == "tresca" and self.slip_bound is None:
            raise ValueError("Tresca friction needs a slip bound g_c (Pa)")
        if self.kind == "coulomb" and not (self.friction > 0 and np.isfinite(self.friction)):
            raise ValueError(f"Coulomb friction needs a positive coefficient, got {self.friction}")
        if self.kind == "tresca":
            g = np.asarray(self.slip_bound, dtype=float)
            if not np.all(np.isfinite(g)) or np.any(g < 0):
                raise ValueError(f"the Tresca slip bound g_c must be finite and >= 0 (Pa), got {self.slip_bound}")
        if self.augmentation is not None and not (self.augmentation > 0 and np.isfinite(self.augmentation)):
            raise ValueError(f"the augmentation c must be positive (Pa/m), got {self.augmentation}")


class _Cycling(SolverError):
    """The active sets of the semi-smooth Newton iteration cycle (ContactSolver falls back for Coulomb)."""


@dataclass
class ContactInfo:
    """History of one contact solve: per iteration the numbers of nodes in contact, sticking and slipping
    and of set changes; the final complementarity residuals; wall time and factorizations."""

    iterations: int = 0
    active: list = field(default_factory=list)
    stick: list = field(default_factory=list)
    slip: list = field(default_factory=list)
    changes: list = field(default_factory=list)
    max_penetration: float = 0.0
    min_pressure: float = 0.0
    wall_s: float = 0.0
    factorizations: int = 0
    coulomb_fixed_point_passes: int = 0
    """>0: Coulomb was solved by the fixed point of Tresca problems after the active sets cycled (passes)."""
    penalty_iterations: int = 0
    unheld_sets: int = 0
    reused_solves: int = 0
    exact_start_failed: bool = False
    """A cold solve whose exact start failed and that was solved again from the penalty start."""
    cholesky_factorizations: int = 0
    """Of ``factorizations``: the symmetric quasi-definite companions factored by sparse Cholesky."""
    woodbury_columns: int = 0
    newton_residual: list = field(default_factory=list)
    gmres_iterations: list = field(default_factory=list)
    """linear="iterative": the GMRES iterations of every Newton-step solve (:mod:`.contact_krylov`)."""
    amg_setups: int = 0
    """linear="iterative": the AMG hierarchies built (one per solve; later Newton steps refresh its operators)."""
    condensed_dofs: int = 0
    """linear="condensed": the surface dofs of the condensed problem (:mod:`.contact_condensed`)."""
    candidate_passes: int = 0
    """linear="condensed": the candidate sets tried (1 when the first held every node in contact)."""
    condensed_fallback: bool = False
    """linear="condensed": the condensed path could not take the problem and the sparse direct path solved it."""


class _Interface:
    """One interface's operator, law and current sets inside the solver."""

    def __init__(self, op: ContactOperator, law: ContactLaw, c_scale: float, offset: int, ndof: int):
        self.op, self.law = op, law
        keep = op.coverage > 1.0 - 1e-6     # dual multipliers need the whole support projected
        self.keep = keep
        m = op.size
        # first multiplier index: the normal block, then the tangential block(s) at offset + m (3D: t1) and
        # offset + 2 m (3D: t2 = n x t1)
        self.offset = offset
        self.dim3 = op.Bt2 is not None
        self.blocks = 3 if self.dim3 else 2
        pad = sp.csr_matrix((m, ndof - op.Bn.shape[1]))
        self.Bn = sp.hstack([op.Bn, pad]).tocsr()
        self.Bt = sp.hstack([op.Bt, pad]).tocsr()
        self.Bt2 = sp.hstack([op.Bt2, pad]).tocsr() if self.dim3 else None
        # the equilibrium rows' entries -Bn^T lam_n - Bt^T lam_t (- Bt2^T lam_t2) (constant): COO rows, cols, values
        cs = [B.tocoo() for B in (self.Bn, self.Bt, self.Bt2) if B is not None]
        self.transposed = (np.concatenate([c.col for c in cs]).astype(np.int64),
                           np.concatenate([c.row + offset + k * m for k, c in enumerate(cs)]).astype(np.int64),
                           -np.concatenate([c.data for c in cs]))
        w = np.maximum(op.weight, 1e-300)
        if law.augmentation is not None:
            self.c = np.full(m, float(law.augmentation))
        else:
            self.c = c_scale / np.maximum(op.length, 1e-300)
        # tangential augmentation: the modulus over the extent of the side (E/h cycled between stick and
        # slip in the Tresca block test; E/L converged in 5-6 iterations)
        extent = float(np.max(np.ptp(op.coords, axis=0))) if m > 1 else 1.0
        self.ct = (np.full(m, float(law.augmentation)) if law.augmentation is not None
                   else np.full(m, c_scale / max(extent, 1e-300)))
        self.w = w                         # nodal weights: g_j / w_j is the nodal gap (m)
        if law.kind == "tresca":
            self.bound0 = np.broadcast_to(np.asarray(law.slip_bound, dtype=float), (m,)).copy()
        else:
            self.bound0 = np.zeros(m)
        gap = op.g0 / w
        # start: the nodes touching first (smallest nodal gap, or in initial overlap)
        gmin = float(np.min(gap[keep])) if keep.any() else 0.0
        self.active = keep & (gap <= max(gmin, 0.0) + 1e-3 * op.length)
        self.stick = self.active & (law.kind != "frictionless")
        self.slip = np.zeros(m, dtype=bool)
        self.sign = np.zeros(m)
        # 3D slip rows: the unit direction e = z / |z| and kappa = b / max(|z|, b) of the current iterate
        self.dir = np.zeros((m, 2))
        self.kappa = np.zeros(m)
        self.flips = np.zeros(m, dtype=int)     # contact <-> separation switches of each node in this solve

    @property
    def m(self) -> int:
        return self.op.size


def _balance_slip(it, lam_t: np.ndarray, rigid: np.ndarray, n: int, imbalance: np.ndarray) -> np.ndarray:
    """2D, every active node of ``it`` slipping and the free rigid motions ``rigid`` unbalanced by ``imbalance``
    (rigid^T times the residual of the equilibrium rows): choose a node to stick and the slip directions of the
    others so that the friction can balance the load. The slip along an interface varies monotonically between
    points where it turns (a translation plus a smooth deformation), so the candidates move a turning point node
    by node (from an end when the direction does not turn): at each node, if sticking there balances the load
    with a traction within the node's bound, that is the choice; else the node flips its direction when that
    reduces the imbalance. The candidate with the fewest flips among the feasible ones is taken (else the least
    infeasible); returns the imbalance left for the stick node. Changing lam_t of node i by delta changes the
    residual by Bt[i]^T delta, so the imbalance by G[:, i] delta with G = rigid^T Bt^T."""
    slip = np.nonzero(it.slip & it.active)[0]
    xy = np.asarray(it.op.coords, dtype=float)[slip, :2]
    d = xy - xy.mean(axis=0)
    axis = np.linalg.svd(d, full_matrices=False)[2][0] if len(slip) > 1 else np.array([1.0, 0.0])
    order = slip[np.argsort(d @ axis)]
    G = rigid.T @ it.Bt[:, :n].T.toarray()
    s = it.sign[order]
    turns = np.nonzero(s[1:] != s[:-1])[0]
    starts = [(p, -1) for p in turns] + [(p + 1, 1) for p in turns] if len(turns) else [(0, 1), (len(order) - 1, -1)]
    best = None                                    # (violation, flips, stick node, imbalance)
    for start, step in starts:
        r = imbalance.copy()
        flipped: list = []
        k = start
        while 0 <= k < len(order):
            i = order[k]
            g = G[:, i]
            gg = float(g @ g)
            free_r = r - g * lam_t[i]              # node i's traction taken out
            t = -float(g @ free_r) / gg if gg > 0 else math.inf
            violation = max(abs(t) - abs(lam_t[i]), 0.0) / max(abs(lam_t[i]), 1e-300)
            cand = (violation, len(flipped), list(flipped), i, free_r + g * t)
            if best is None or (cand[0], cand[1]) < (best[0], best[1]):
                best = cand
            if violation == 0.0:
                break
            r_new = r + g * (-2.0 * lam_t[i])
            if np.linalg.norm(r_new) >= np.linalg.norm(r):
                break
            flipped.append(i)
            r = r_new
            k += step
    if best is None:                               # no slipping node: stick all (the old fallback)
        it.stick, it.slip = it.active.copy(), np.zeros(it.m, dtype=bool)
        return imbalance
    _, _, flipped, stick_node, r = best
    it.sign = it.sign.copy()
    it.sign[flipped] *= -1.0
    it.stick = np.zeros(it.m, dtype=bool)
    it.stick[stick_node] = True
    it.slip = it.active & ~it.stick
    return r


class ContactSolver:
    """Solves K u = f + B^T lam with the complementarity conditions of the interfaces for the current
    elastic data. ``matrix`` and ``rhs`` are the assembled bulk operator (X x X) and load (X), ``free`` the
    free dofs of X (numpy bool), ``x0`` a vector of X holding the prescribed (Dirichlet) values."""

    def __init__(self, interfaces: list[tuple[ContactOperator, ContactLaw]], *, modulus: float,
                 maxit: int = 50, method: str = "ssn", floating=(), reuse_rows: int = 12,
                 quasi_definite: bool = True, linear: str = "auto", forms=None, linear_tol: float | None = None,
                 linear_maxit: int = 3000, check_solvable: bool = True):
        """``floating``: the semi-coercive bodies (:meth:`ElasticForms.floating_bodies`): their load is
        checked for solvability before any factorization, and their free dofs get a tiny diagonal shift in the
        factorization (the residual is always that of the exact system, so the converged solution is exact;
        a motion no contact holds, e.g. the sliding of a frictionless body under a balanced load, is fixed
        at the shift's minimum-norm value). ``reuse_rows``: the most changed rows needing new solves for which
        an old factorization is reused (Woodbury) instead of factoring anew; -1: always factor.
        ``quasi_definite``: factor the symmetric quasi-definite companion of a symmetric saddle-point matrix by
        sparse Cholesky (:meth:`_Pattern.symmetric`) instead of the matrix by UMFPACK (False: always UMFPACK).
        ``linear``: "direct" (the factorizations above), "condensed" (the problem condensed onto the contact
        surface by one PARDISO factorization of K, :mod:`.contact_condensed`; 2D), "auto" (condensed in 2D when
        PARDISO is installed, else direct) or "iterative": every Newton step by GMRES with the
        augmented-Lagrangian AMG preconditioner of :mod:`.contact_krylov` (needs ``forms``, the
        :class:`ElasticForms` of the matrix, for the displacement space and the rigid motions of the AMG;
        ``linear_tol`` its relative tolerance, ``linear_maxit`` its iteration limit per Newton step).
        ``check_solvable``: False skips the check of the floating bodies' load (the condensed solver's inner
        problem, whose caller checked it on all nodes)."""
        if linear not in ("auto", "direct", "iterative", "condensed"):
            raise ValueError(f"the contact solver's linear solver must be 'auto', 'direct', 'iterative' or "
                             f"'condensed', got {linear!r}")
        if linear == "condensed":
            from ..linalg import pardiso
            if not pardiso.available():
                raise ValueError("the condensed contact solver needs oneMKL PARDISO: install the 'mkl' package")
        if linear == "iterative" and forms is None:
            raise ValueError("the iterative contact solver needs the elastic forms (forms=): the displacement space "
                             "and its rigid motions")
        if linear == "auto":
            dim = 3 if any(op.Bt2 is not None for op, _ in interfaces) else 2
            linear = "condensed" if applicable(dim) else "direct"
        self.linear = linear
        self.forms = forms
        self.linear_tol = linear_tol
        self.linear_maxit = linear_maxit
        self._modes = None                 # contact_krylov.near_null_space(forms), for the iterative solver's AMG
        self._condensed = None             # contact_condensed.CondensedContact (linear="condensed")
        self.check_solvable = check_solvable
        self.items = interfaces
        self.modulus = float(modulus)
        self.maxit = maxit
        self.floating = list(floating)
        if method not in ("ssn", "penalty"):
            raise ValueError(f"unknown contact method {method!r}")
        self.method = method
        self.reuse_rows = reuse_rows
        self.quasi_definite = quasi_definite
        self.infos: list[ContactInfo] = []
        self._state: list[_Interface] | None = None
        self._pattern: _Pattern | None = None
        self.converged = False
        self._penalty_start = False      # a cold solve from the penalty start (after a failed exact start)
        self._exact_cold = False         # the last solve started cold with the exact constraints
        self.multipliers: list[tuple[np.ndarray, np.ndarray]] = []

    def interfaces(self, ndof: int) -> list[_Interface]:
        if self._state is None:
            out, off = [], ndof
            for op, law in self.items:
                out.append(_Interface(op, law, self.modulus, off, ndof))
                off += out[-1].blocks * op.size
            self._state = out
        return self._state

    def inner_solver(self, items: list[tuple[ContactOperator, ContactLaw]], floating: list) -> ContactSolver:
        """A solver with this one's settings for other interfaces and floating bodies, on the sparse or dense
        steps (the condensed problem's: its dense bulk selects the dense steps), without the solvability check
        of the load (the caller checked it on all nodes: the candidate nodes alone could wrongly refuse it)."""
        return ContactSolver(items, modulus=self.modulus, maxit=self.maxit, method=self.method, floating=floating,
                             reuse_rows=self.reuse_rows, quasi_definite=self.quasi_definite, linear="direct",
                             check_solvable=False)

    def cold_start(self) -> None:
        """Forget the sets of the last solve (or of :meth:`warm_start`): the next solve begins as the first one
        does, from the nodes touching first (with the exact constraints; the penalty phase for 3D friction or
        when the exact start fails)."""
        self._state, self._pattern, self.converged = None, None, False

    def warm_start(self, ndof: int, sets: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> None:
        """Start the next solve from given nodal sets, one (active, stick, slip) triple of bool arrays per
        interface (e.g. transferred from the solution on a coarser mesh): the solve then begins with the exact
        constraints of these sets, as after a converged solve, instead of the nodes touching first. ``ndof``: the size
        of the displacement vector X."""
        ifs = self.interfaces(ndof)
        if len(sets) != len(ifs):
            raise ValueError(f"warm_start needs one set triple per interface ({len(ifs)}), got {len(sets)}")
        for it, (active, stick, slip) in zip(ifs, sets):
            it.active = np.asarray(active, dtype=bool) & it.keep
            it.stick = np.asarray(stick, dtype=bool) & it.active
            it.slip = np.asarray(slip, dtype=bool) & it.active & ~it.stick
        self.converged = True

    def capture(self) -> dict:
        """The warm start of the next solve as plain arrays (a checkpoint's): per interface ``"i/name"`` its node
        arrays (the active, stick and slip sets, slip signs and directions, the nodes kept, ...) and
        ``"converged"``; {} before the first solve. The factorizations are not kept: the next solve factors
        the same matrices again, which gives the same values."""
        out = {}
        for i, it in enumerate(self._state or []):
            out.update({f"{i}/{key}": val.copy() for key, val in vars(it).items() if isinstance(val, np.ndarray)})
        if self._state is not None:
            out["converged"] = np.array(self.converged)
        return out

    def restore(self, ndof: int, state: dict) -> None:
        """Start the next solve from a state of :meth:`capture` (``ndof``: the size of the displacement vector X),
        as the solve after the captured one would in an uninterrupted run."""
        items = [(key.split("/", 1), val) for key, val in state.items() if key.split("/", 1)[0].isdigit()]
        if items:
            ifs = self.interfaces(ndof)
            for (i, key), val in items:
                cur = getattr(ifs[int(i)], key, None) if int(i) < len(ifs) else None
                if isinstance(cur, np.ndarray) and cur.shape == np.shape(val):
                    setattr(ifs[int(i)], key, np.array(val, dtype=cur.dtype))
        if "converged" in state:
            self.converged = bool(np.ravel(state["converged"])[0])

    def solve(self, matrix, rhs, free: np.ndarray, x0: np.ndarray, where: str = "") -> tuple[np.ndarray, ContactInfo]:
        """The displacement vector (X) and the history; the multipliers per interface in
        ``self.multipliers`` [(lam_n, lam_t)] (Pa).

        When the active-set iteration cycles on a problem with Coulomb interfaces, Coulomb friction is solved
        again as a fixed point of Tresca problems (:meth:`_coulomb_by_tresca`).

        ``linear="condensed"``: the problem condensed onto the contact surface (:mod:`.contact_condensed`); what it
        cannot take goes to the sparse direct path below (``ContactInfo.condensed_fallback``)."""
        rest = self._at_rest(rhs, free, x0)
        if rest is not None:
            return rest
        if self.linear == "condensed" and not isinstance(matrix, np.ndarray):
            if self._condensed is None:
                self._condensed = CondensedContact(self)
            out = self._condensed.solve(matrix, rhs, free, x0, where)
            if out is not None:
                return out
            u, info = self._solve_any(matrix, rhs, free, x0, where)
            info.condensed_fallback = True
            return u, info
        return self._solve_any(matrix, rhs, free, x0, where)

    def _at_rest(self, rhs, free: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, ContactInfo] | None:
        """The solution u = 0, lam = 0 when the data of (P) vanish: no load on the free dofs, zero prescribed
        displacements and no initial overlap (a load ramping from zero, "P*t", at t = 0). That pair satisfies
        every condition (K u = f + B^T lam, g = g0 >= 0, lam = 0) and fixes each unloaded rigid motion of a
        floating body at zero; the active-set iteration would instead close the first-touching nodes and
        find no load to measure their hold against. None when the data do not vanish. The sets are left as
        they were: the next solve starts from them."""
        n = len(x0)
        f = np.asarray(rhs, dtype=float)[:n]
        if np.any(f[free]) or np.any(np.asarray(x0)[~free]):
            return None
        ifs = self.interfaces(n)
        if any(np.any(it.op.g0[it.keep] < 0) for it in ifs):
            return None
        info = ContactInfo(active=[0], stick=[0], slip=[0], changes=[0], newton_residual=[0.0])
        self.multipliers = [(np.zeros(it.m), np.zeros((it.m, 2) if it.dim3 else it.m)) for it in ifs]
        self.infos.append(info)
        return np.zeros(n), info

    def _solve_any(self, matrix, rhs, free, x0, where: str) -> tuple[np.ndarray, ContactInfo]:
        try:
            return self._solve_cold(matrix, rhs, free, x0, where)
        except _Cycling as exc:
            if not any(law.kind == "coulomb" for _, law in self.items):
                raise SolverError(str(exc)) from None
            return self._coulomb_by_tresca(matrix, rhs, free, x0, where, str(exc))

    def _solve_cold(self, matrix, rhs, free, x0, where: str) -> tuple[np.ndarray, ContactInfo]:
        """:meth:`_solve`; a cold solve that started with the exact constraints (2D) and failed (a singular first
        matrix, sets that do not hold a body, cycling) is solved again from the penalty start."""
        try:
            return self._solve(matrix, rhs, free, x0, where)
        except SolverError:
            if not self._exact_cold:
                raise
            self._state, self.converged, self._penalty_start = None, False, True
            try:
                out = self._solve(matrix, rhs, free, x0, where)
            finally:
                self._penalty_start = False
            out[1].exact_start_failed = True
            return out

    def _coulomb_by_tresca(self, matrix, rhs, free, x0, where: str, why: str) -> tuple[np.ndarray, ContactInfo]:
        """Coulomb friction as the fixed point of Tresca problems with the slip bound g = F_c p from the last
        normal pressure p (the successive approximation of Panagiotopoulos; each Tresca problem is solved by the
        active-set iteration, which does not cycle on it), starting from the frictionless pressure, until the
        bounds change by less than COULOMB_FIXED_POINT_TOL of the largest. Contracts for moderate F_c; when it
        does not within COULOMB_FIXED_POINT_MAXIT passes, the run stops and says so."""
        items = self.items
        coulomb = [k for k, (_, law) in enumerate(items) if law.kind == "coulomb"]
        total = ContactInfo()
        tic = time.perf_counter()
        change = math.inf
        n_infos = len(self.infos)

        def use(laws):
            self.items = [(op, laws.get(k, law)) for k, (op, law) in enumerate(items)]
            self._state, self._pattern, self.converged = None, None, False

        try:
            use({k: ContactLaw("frictionless", augmentation=items[k][1].augmentation, penalty=items[k][1].penalty)
                 for k in coulomb})
            u, info = self._solve(matrix, rhs, free, x0, where)
            bounds = {k: items[k][1].friction * np.maximum(self.multipliers[k][0], 0.0) for k in coulomb}
            for npass in range(1, COULOMB_FIXED_POINT_MAXIT + 1):
                use({k: ContactLaw("tresca", slip_bound=bounds[k], augmentation=items[k][1].augmentation,
                                   penalty=items[k][1].penalty) for k in coulomb})
                u, info = self._solve(matrix, rhs, free, u, where)
                total.coulomb_fixed_point_passes = npass
                total.iterations += info.iterations
                total.factorizations += info.factorizations
                new = {k: items[k][1].friction * np.maximum(self.multipliers[k][0], 0.0) for k in coulomb}
                scale = max(max(float(np.max(b, initial=0.0)) for b in new.values()), 1e-300)
                change = max(float(np.max(np.abs(new[k] - bounds[k]), initial=0.0)) for k in coulomb) / scale
                bounds = new
                if change <= COULOMB_FIXED_POINT_TOL:
                    break
            else:
                raise SolverError(f"{why}; the fallback (Coulomb as a fixed point of Tresca problems) did not "
                                  f"converge in {COULOMB_FIXED_POINT_MAXIT} passes (last relative change of the slip "
                                  f"bounds {change:.1e}): reduce the load or time step, refine the mesh, or lower "
                                  "the friction coefficient")
        finally:
            self.items = items
            state = self._state
            self._state, self._pattern = None, None
        # the last Tresca state is the Coulomb state: keep its sets (with the Coulomb laws) as the next warm start
        for st, (_, law) in zip(state or [], items):
            st.law = law
        self._state = state
        info.iterations = total.iterations
        info.factorizations = total.factorizations
        info.coulomb_fixed_point_passes = total.coulomb_fixed_point_passes
        info.wall_s = time.perf_counter() - tic
        del self.infos[n_infos:]
        self.infos.append(info)
        return u, info

    def _solve(self, matrix, rhs, free: np.ndarray, x0: np.ndarray, where: str = "") -> tuple[np.ndarray, ContactInfo]:
        tic = time.perf_counter()
        self._exact_cold = False
        n = len(x0)
        ifs = self.interfaces(n)
        drop_prescribed_nodes(ifs, free, n)
        N = n + sum(it.blocks * it.m for it in ifs)
        # a dense bulk (numpy, the condensed problem of .contact_condensed): the pattern holds the multiplier
        # entries only, the steps eliminate the multipliers against one Cholesky factorization of the bulk
        dense = isinstance(matrix, np.ndarray)
        if dense:
            kr = kc = np.zeros(0, dtype=np.int64)
            kv = np.zeros(0)
        else:
            kr, kc, kv = (np.asarray(a) for a in matrix.COO())
            kr, kc = kr.astype(np.int64), kc.astype(np.int64)
        f = np.where(free, np.asarray(rhs, dtype=float), 0.0)   # (fixed dofs: their load is the support's)
        if not np.all(np.isfinite(f)):
            bad = int(np.count_nonzero(~np.isfinite(f)))
            raise SolverError(f"contact solve{' at ' + where if where else ''}: the load vector has {bad} NaN or "
                              "infinite entries on free dofs; check the loads, temperatures and material data")
        info = ContactInfo()
        for it in ifs:
            it.flips[:] = 0
        if self.floating and self.check_solvable:
            self.check_load(ifs, f, where)
        reg_dofs = np.zeros(0, dtype=np.int64)
        eps = 0.0
        if self.floating:
            mask = np.zeros(n, dtype=bool)
            for body in self.floating:
                mask |= np.any(np.abs(body.modes) > 0, axis=1)
            reg_dofs = np.where(mask & free)[0].astype(np.int64)
        if dense and not len(reg_dofs):
            # a dense bulk is eliminated by itself (_DenseStep): a rigid motion held only by the contact rows and
            # not declared floating (a time step's matrix of a body on a foundation) would make S singular, so S
            # gets the shift everywhere, and the refinement with the exact residual removes it as for the
            # floating bodies
            reg_dofs = np.where(free)[0].astype(np.int64)
        if len(reg_dofs):
            if dense:
                diag = np.diag(matrix)
            else:
                diag = np.zeros(n)
                np.add.at(diag, kr[kr == kc], kv[kr == kc])
            eps = (DENSE_SHIFT if dense else 1e-10) * float(np.mean(np.abs(diag[reg_dofs])))
        rigid = np.hstack([bd.modes[:n] for bd in self.floating]) if self.floating else np.zeros((n, 0))
        x = np.zeros(N)
        x[:n] = x0
        lam_n = [np.zeros(it.m) for it in ifs]
        lam_t = [np.zeros((it.m, 2) if it.dim3 else it.m) for it in ifs]
        # the first phase (and the whole solve of method 'penalty'); a solve that starts from the sets of a
        # converged one (the next secant iteration, the next time) starts with the exact constraints: the
        # penalty phase moved those good sets away and back (measured: 7 instead of 3 factorizations per
        # secant iteration on a wedge on a Coulomb fault). In 2D a cold solve starts with the exact constraints
        # too: the penalty phase let the floating Hertz cylinder sink onto ~2x its contact zone and then the
        # switch to the exact rows changed every active row (k = 4, 41k dofs: 11 iterations and 6
        # factorizations with the penalty start, 9 and 5 without; Coulomb blocks at h = 0.02: 7 / 3 and 5 / 2).
        # A 3D frictional interface keeps the penalty start: from the first-touch nodes with exact stick rows
        # the block tests' first matrix was singular
        penalty = self.method == "penalty" or (not self.converged and (
            self._penalty_start or any(it.dim3 and it.law.kind != "frictionless" for it in ifs)))
        self._exact_cold = not penalty and not self.converged
        # one pattern for all solves with the same K sparsity (a time series, the secant loop): building it
        # (CreateFromCOO) cost as much as a factorization (0.22 s at 41k dofs)
        pattern = self._pattern
        if pattern is not None and pattern.matches(N, kr, kc):
            pattern.set_bulk(n, kv, reg_dofs, eps)
        else:
            pattern = self._pattern = _Pattern(n, N, kr, kc, kv, reg_dofs, eps, ifs, bulk=None if dense else matrix)
        mat = pattern.matrix
        bulk = None
        if dense:
            shifted = np.array(matrix, dtype=float)
            shifted[reg_dofs, reg_dofs] += eps
            bulk = _DenseBulk(shifted, f"contact solve{' at ' + where if where else ''}")
            mat = _DenseOperator(pattern.matrix, shifted)
        # the free unknowns are the same at every iteration: a fixed multiplier (open node, Tresca slip) has
        # an identity row, so consecutive matrices differ only in the rows of the nodes whose state changed
        freemask = np.zeros(N, dtype=bool)
        freemask[:n] = free
        for it in ifs:
            freemask[it.offset:it.offset + (it.blocks * it.m if it.law.kind != "frictionless" else it.m)] = True
        freedofs = ngs.BitArray(freemask.tolist())
        factored = None      # (the inverse, the COO values it was computed from, cached solves, zero columns)
        hint_unheld = "a body is not held by its supports and the nodes in contact now"
        bulk_symmetric = not dense and self.linear != "iterative" and self.quasi_definite and is_symmetric(matrix)
        what = f"contact solve{' at ' + where if where else ''}"
        it_nr = 0
        krylov = self._krylov(n, N, ifs, freemask) if self.linear == "iterative" else None
        # 3D slip rows: the residual the Newton steps can reach is that of their linear solves (GMRES: 100 x its
        # tolerance; measured 1e-11 ... 2e-11 with 1e-10 on the 3D punch, where the direct solves reach 1e-16)
        newton_tol = NEWTON_TOL if krylov is None else max(NEWTON_TOL, 100.0 * krylov.tol)

        def factor(exact: bool = False):
            """Factor the current matrix: its symmetric quasi-definite companion by sparse Cholesky when it
            has one (:meth:`_Pattern.symmetric`; the refinement below makes the solve exact), else (or
            with ``exact``) the matrix itself by UMFPACK."""
            sym = None if (exact or not bulk_symmetric) else pattern.symmetric(ifs)
            if sym is not None:
                pattern.update(sym)
                try:
                    inv = inverse(mat, freedofs, True, f"{what}, iteration {it_nr}", hint_unheld)
                finally:
                    pattern.update()
                info.cholesky_factorizations += 1
            else:
                inv = inverse(mat, freedofs, False, f"{what}, iteration {it_nr}", hint_unheld)
            info.factorizations += 1
            zeroed = pattern.zero_columns(sym) if sym is not None else None
            return (inv, pattern.values.copy(), {}, zeroed), _Fresh(inv, exact=sym is None)

        for it_nr in range(1, self.maxit + 1):
            b = np.zeros(N)
            b[:n] = f
            vals = pattern.values
            for it, seg in zip(ifs, pattern.segments):
                on, ot = it.offset, it.offset + it.m
                A = it.active & it.keep
                b[on:on + it.m] = np.where(A, it.op.g0, 0.0)     # -Bn u = g0 (g = 0) or lam_n = 0
                x[on:on + it.m] = np.where(A, x[on:on + it.m], 0.0)
                pen_i = penalty or it.law.penalty
                vals[seg["rows_n"]] = seg["rows_n_values"] * A[seg["rows_n_node"]]
                # -Bn u - (weight / c) lam_n = g0 in the penalty phase (lam_n = -c g~)
                # (the identity rows of fixed multipliers scaled like the penalty rows: -weight / c)
                vals[seg["diag_n"]] = np.where(A & (not pen_i), 0.0, -it.w / it.c)
                if it.law.kind == "frictionless":
                    x[ot:it.offset + it.blocks * it.m] = 0.0
                    continue
                if it.dim3:
                    _rows_3d(it, seg, vals, b, x, A, pen_i)
                    continue
                stick = A & it.stick
                slip = A & it.slip
                # stick rows -Bt u (- weight / ct lam_t) = 0; Coulomb slip rows lam_t - F sign lam_n = 0; Tresca
                # slip rows lam_t = g_c sign; open nodes lam_t = 0
                vals[seg["rows_t"]] = seg["rows_t_values"] * stick[seg["rows_t_node"]]
                vals[seg["diag_t"]] = np.where(stick & (not pen_i), 0.0, -it.w / it.ct)
                coulomb_slip = slip if it.law.kind == "coulomb" else np.zeros(it.m, dtype=bool)
                vals[seg["couple"]] = np.where(coulomb_slip, it.w / it.ct * it.law.friction * it.sign, 0.0)
                fixed_t = np.where(slip & (it.law.kind == "tresca"), it.bound0 * it.sign, 0.0)
                b[ot:ot + it.m] = -it.w / it.ct * fixed_t
                x[ot:ot + it.m] = np.where(stick | coulomb_slip, x[ot:ot + it.m], fixed_t)
            pattern.update()


            step = None
            if krylov is not None:
                step = _KrylovStep(krylov, pattern, b, info, f"{what}, iteration {it_nr}", rigid, n)
            elif bulk is not None:
                step = _DenseStep(bulk, pattern, n, freemask)
            elif factored is not None:
                rows = pattern.changed_rows(factored[1])
                if not len(rows):                    # the factored matrix itself
                    step = _Fresh(factored[0], exact=factored[3] is None)
                else:
                    # a companion's factorization: the columns it left out of the nodes now in contact or sticking
                    cols = [] if factored[3] is None else [int(j) for j in pattern.entering(rows, factored[3])]
                    new = (len([j for j in rows if int(j) not in factored[2]])
                           + len([j for j in cols if ("col", j) not in factored[2]]))
                    if new <= self.reuse_rows:
                        step = _Reuse(mat, factored[0], rows, factored[2], info, exact=factored[3] is None,
                                      columns={j: pattern.column(j) for j in cols})
            if step is None:
                factored, step = factor()
            xv = mat.CreateColVector()
            xv.FV().NumPy()[:] = x
            r = mat.CreateColVector()
            held = True
            dx = mat.CreateColVector()
            mode_size = float(np.max(np.linalg.norm(rigid, axis=0), initial=0.0))

            def balance_scale() -> float:
                """Forces the rigid-motion balance is measured against: the load, or the contact forces of the
                iterate when there is none (a problem driven by its gaps alone: an overlap pressing a body)."""
                xs = xv.FV().NumPy()
                forces = float(np.linalg.norm(b[:n] * free))
                for it in ifs:
                    forces = max(forces, float(np.linalg.norm(it.Bn[:, :n].T @ xs[it.offset:it.offset + it.m])))
                return max(forces * mode_size, 1e-300)
            last_balance = math.inf
            last_change = math.inf      # the last correction of an inexact (companion) step, relative
            slow = False
            for k_ref in range(20):   # refinement with the residual of the exact system (without the shift eps)
                if not step.exact and (slow or k_ref == INEXACT_REFINEMENTS):
                    # the quasi-definite companion does not converge fast to the exact system here: factor the matrix
                    # itself
                    factored, step = factor(exact=True)
                r.data = mat * xv
                ra = r.FV().NumPy()
                ra[reg_dofs] -= eps * xv.FV().NumPy()[reg_dofs]
                ra[:] = b - ra
                ra[~freemask] = 0.0
                if not step.apply(r, dx):        # the reused factorization did not converge: factor now
                    factored, step = factor()
                    step.apply(r, dx)
                if not step.exact and not np.all(np.isfinite(dx.FV().NumPy())):
                    # a companion's Cholesky without pivoting met a zero pivot (K singular beyond the known
                    # floating bodies): UMFPACK factors the matrix itself, or names the singularity
                    factored, step = factor(exact=True)
                    step.apply(r, dx)
                xv.data += dx
                if krylov is not None and step.free_motions is not None:
                    q = step.free_motions
                    xs = xv.FV().NumPy()
                    xs[:n] -= q @ (q.T @ xs[:n])
                if not len(reg_dofs) and not step.exact:
                    # no floating body: converged when the corrections of u and of the multipliers contract so that
                    # the error left (about change q / (1 - q), q the last contraction) is below 1e-12 of the
                    # solution: with the exact rows' regularization q ~ 1e-8 and two solves do; a contraction above
                    # 1/4 goes to the exact factorization (leaving a Coulomb coupling out of the companion and
                    # refining was tried: at the blocks' h = 0.01 the contraction was above 1/4, a third
                    # factorization followed)
                    change = _relative_change(dx.FV().NumPy(), xv.FV().NumPy(), n, freemask)
                    q = change / last_change if math.isfinite(last_change) and last_change > 0 else math.inf
                    last_change = change
                    if not (q < 1.0 and change * q / (1.0 - q) <= 1e-12):
                        slow = k_ref >= 2 and q > 0.25
                        continue
                if not len(reg_dofs):
                    break
                # floating bodies: the criteria below (designed for the shift eps, which the companion's
                # regularization contracts alike) decide, a companion step included
                # the correction relative to the solution (the residual mixes forces and lengths), without its
                # rigid-motion part: a free motion without load (a frictionless body sliding sideways) is
                # left at the small value the shift gives it. The corrections contract by about the relative
                # shift (1e-10) when the sets hold the bodies: one of 1e-6 leaves an error of ~1e-16 (a third
                # solve, needed with the threshold 1e-10, cost 10 % of a warm solve)
                d = dx.FV().NumPy()[:n]
                d = d - rigid @ np.linalg.lstsq(rigid, d, rcond=None)[0]
                if float(np.linalg.norm(d)) <= 1e-6 * max(float(np.linalg.norm(xv.FV().NumPy()[:n])), 1e-300):
                    if not rigid.shape[1]:
                        break
                    # the shift leaves a residual eps u along the rigid motions (eps x translation x dofs: 0.5 N
                    # of a 2.5 kN load on a weak Coulomb interface); refine while that falls
                    r.data = mat * xv
                    ra = r.FV().NumPy()
                    ra[reg_dofs] -= eps * xv.FV().NumPy()[reg_dofs]
                    balance = float(np.max(np.abs(rigid.T @ ((b - ra)[:n] * free))))
                    if balance <= 1e-10 * balance_scale() or balance > 0.5 * last_balance:
                        break
                    last_balance = balance
            else:
                held = False
            if held and rigid.shape[1]:   # the loaded rigid motions must be balanced by the contact forces
                r.data = mat * xv
                ra = r.FV().NumPy()
                ra[reg_dofs] -= eps * xv.FV().NumPy()[reg_dofs]
                ru = (b - ra)[:n] * free
                held = float(np.max(np.abs(rigid.T @ ru))) <= 1e-8 * balance_scale()
            check_finite(xv, f"contact solve{' at ' + where if where else ''}, iteration {it_nr}")
            x = np.array(xv.FV().NumPy())
            for it in ifs:      # the fixed multipliers exactly (their identity rows hold them to round-off)
                on, ot = it.offset, it.offset + it.m
                A = it.active & it.keep
                x[on:on + it.m] = np.where(A, x[on:on + it.m], 0.0)
                if it.law.kind == "frictionless":
                    x[ot:it.offset + it.blocks * it.m] = 0.0
                elif it.dim3:
                    x[ot:ot + it.m] = np.where(A, x[ot:ot + it.m], 0.0)
                    x[ot + it.m:ot + 2 * it.m] = np.where(A, x[ot + it.m:ot + 2 * it.m], 0.0)
                else:
                    x[ot:ot + it.m] = np.where(~A, 0.0, np.where(A & it.slip & (it.law.kind == "tresca"),
                                                                 it.bound0 * it.sign, x[ot:ot + it.m]))
            if not held:
                # these sets leave a floating body free along a loaded rigid motion: every node slipping while
                # the friction cannot balance the load (retry with the active nodes sticking), or too few nodes
                # in contact (e.g. the single first node of a curved side: add the nearest open nodes)
                info.unheld_sets += 1
                grow = all(not (it.slip & it.active).any() for it in ifs)
                if info.unheld_sets > 3 or (grow and not any((it.keep & ~it.active).any() for it in ifs)):
                    r.data = mat * xv
                    ra = r.FV().NumPy()
                    ra[reg_dofs] -= eps * xv.FV().NumPy()[reg_dofs]
                    raise SolverError(f"{what}, iteration {it_nr}: "
                                      + self._unheld(ifs, rigid, (b - ra)[:n] * free, f, n))
                walked = False
                if not grow and rigid.shape[1] and not any(it.dim3 for it in ifs):
                    # every active node slips and their friction does not balance the load: move the points where
                    # the slip direction turns until it does (sticking all nodes instead threw the sets back to
                    # the start: they cycled, e.g. a block spreading under its load on a weak interface)
                    r.data = mat * xv
                    ra = r.FV().NumPy()
                    ra[reg_dofs] -= eps * xv.FV().NumPy()[reg_dofs]
                    # only the rigid motions the active normal rows leave free (the others are balanced by the
                    # normal pressures whatever the friction does)
                    held_rows = [(it.Bn[:, :n][it.active & it.keep] @ rigid) for it in ifs]
                    A_held = np.vstack(held_rows) if held_rows else np.zeros((0, rigid.shape[1]))
                    _, sv, vt = np.linalg.svd(A_held, full_matrices=True) if A_held.size else (None, np.zeros(0),
                                                                                              np.eye(rigid.shape[1]))
                    rank = int(np.sum(sv > 1e-10 * max(float(sv.max(initial=0.0)), 1e-300)))
                    free_modes = rigid @ vt[rank:].T
                    imbalance = free_modes.T @ ((b - ra)[:n] * free)
                    for it in ifs:
                        if it.law.kind != "frictionless" and (it.slip & it.active).any() and free_modes.shape[1]:
                            imbalance = _balance_slip(it, x[it.offset + it.m:it.offset + 2 * it.m], free_modes, n,
                                                      imbalance)
                            walked = True
                    if walked and self.method == "ssn":
                        # the penalty rows let a sticking node slip by lam_t / c_t, which turns its neighbours'
                        # slip directions back (the sets cycled): the exact rows from here on
                        penalty = False
                    if walked:
                        # the factorization of the unheld matrix (singular but for the shift) is no basis for the
                        # next one: reused, the refinement left the rigid-motion part unconverged (imbalance 2e-4)
                        factored = None
                for it in ifs:
                    if grow:
                        cand = np.where(it.keep & ~it.active)[0]
                        near = cand[np.argsort(it.op.g0[cand] / it.w[cand])[:max(2, int(it.active.sum()))]]
                        it.active = it.active.copy()
                        it.active[near] = True
                    if it.law.kind != "frictionless" and not walked:
                        it.stick, it.slip = it.active.copy(), np.zeros(it.m, dtype=bool)
                info.iterations = it_nr
                info.changes.append(-1)
                info.newton_residual.append(float("nan"))
                info.active.append(int(sum(it.active.sum() for it in ifs)))
                info.stick.append(int(sum(it.stick.sum() for it in ifs)))
                info.slip.append(0)
                continue
            # new sets
            changes = 0
            n_act = n_stick = n_slip = 0
            u = x[:n]
            newton = 0.0      # 3D: the largest residual |lam_t - b z / |z|| of the slip rows / the largest bound
            for k, it in enumerate(ifs):
                on, ot = it.offset, it.offset + it.m
                lam_n[k] = x[on:on + it.m].copy()
                if it.dim3:
                    lam_t[k] = np.column_stack([x[ot:ot + it.m], x[ot + it.m:ot + 2 * it.m]])
                    ch, res = _sets_3d(it, lam_n[k], lam_t[k], u, penalty or it.law.penalty)
                    changes += ch
                    newton = max(newton, res)
                    n_act += int(it.active.sum())
                    n_stick += int(it.stick.sum())
                    n_slip += int(it.slip.sum())
                    continue
                lam_t[k] = x[ot:ot + it.m].copy()
                gap = (it.op.g0 + it.Bn @ u) / it.w
                pen_i = penalty or it.law.penalty
                # penalty rows: the trial tractions -c g~, -c_t s~ (lam - c g~ would double them, and a Tresca
                # node would start slipping at half its bound)
                zn = (0.0 if pen_i else lam_n[k]) - it.c * gap
                act = (zn > 0) & it.keep
                stick = np.zeros(it.m, dtype=bool)
                slip = np.zeros(it.m, dtype=bool)
                sign = it.sign.copy()
                if it.law.kind != "frictionless":
                    sl = (it.Bt @ u) / it.w
                    z = (0.0 if pen_i else lam_t[k]) - it.ct * sl
                    bound = it.bound0 if it.law.kind == "tresca" else it.law.friction * np.maximum(zn, 0.0)
                    stick = act & (np.abs(z) < bound)
                    slip = act & ~stick
                    # nodes that have switched between contact and separation twice (e.g. the tip of a wedge
                    # on a Coulomb fault: sticking, the node goes into tension; released, it penetrates) go
                    # through the slip state: a sticking node in tension slips instead of opening, and such a
                    # node comes back into contact slipping
                    prone = it.flips >= 2
                    to_slip = prone & ((~act & it.active & it.stick & it.keep) | (act & ~it.active & stick))
                    act = act | to_slip
                    stick = stick & ~to_slip
                    slip = slip | to_slip
                    sign = np.where(slip, np.sign(z), 0.0)
                    sign[slip & (sign == 0)] = 1.0
                changes += int(np.sum(act != (it.active & it.keep)) + np.sum(stick != (it.stick & it.active))
                               + np.sum(slip & (sign != it.sign)) + np.sum(slip != (it.slip & it.active)))
                it.flips += act != (it.active & it.keep)
                it.active, it.stick, it.slip, it.sign = act, stick, slip, sign
                n_act += int(act.sum())
                n_stick += int(stick.sum())
                n_slip += int(slip.sum())
            info.iterations = it_nr
            info.active.append(n_act)
            info.stick.append(n_stick)
            info.slip.append(n_slip)
            info.changes.append(changes)
            info.newton_residual.append(newton)
            if changes == 0:
                if penalty and self.method == "ssn":
                    penalty = False
                    info.penalty_iterations = it_nr
                    continue
                if newton <= newton_tol:
                    break
        else:
            if info.changes[-1] == 0:
                raise SolverError(f"contact solve{' at ' + where if where else ''}: the slip directions have not "
                                  f"converged after {self.maxit} iterations (residual of the slip rows "
                                  f"{info.newton_residual[-1]:.1e} of the slip bound); refine the mesh or change "
                                  "the augmentation")
            raise _Cycling(f"contact solve{' at ' + where if where else ''}: the active sets still change after "
                              f"{self.maxit} iterations ({info.changes[-1]} changes in the last one): the contact "
                              "state cycles; refine the mesh or change the augmentation")
        u = x[:n]
        pen, minp = 0.0, 0.0
        for k, it in enumerate(ifs):
            gap = (it.op.g0 + it.Bn @ u) / it.w
            pen = max(pen, float(np.max(-gap[it.keep], initial=0.0)))
            minp = min(minp, float(np.min(lam_n[k], initial=0.0)))
        info.max_penetration, info.min_pressure = pen, minp
        info.wall_s = time.perf_counter() - tic
        self.multipliers = list(zip(lam_n, lam_t))
        self.infos.append(info)
        self.converged = True
        return u, info

    def _krylov(self, n: int, N: int, ifs: list[_Interface], freemask: np.ndarray):
        """The GMRES solver of the Newton steps of this solve (:class:`.contact_krylov.SaddleKrylov`): row
        scales c, the augmented diagonals -w / c and the node blocks of the multipliers."""
        from .krylov import DEFAULT_TOL, SaddleKrylov, near_null_space
        if self._modes is None:
            self._modes = near_null_space(self.forms)
        modes, vertex, dim = self._modes
        if modes.shape[0] != n:
            raise ValueError(f"the iterative contact solver's displacement space has {modes.shape[0]} dofs, the matrix "
                             f"{n} (the mixed formulation is solved directly)")
        scale = np.ones(N - n)
        aug = np.ones(N - n)
        blocks = []
        for it in ifs:
            o = it.offset - n
            m = it.m
            # the rows scaled to forces by their own augmentation; the exact rows' zero diagonal replaced by
            # -w / c with the normal augmentation c = E / h for the tangential rows too (their c_t = E / L is the
            # active-set test's; with it the GMRES iterations of the 3D punch's slip steps grew 86, 130, 212
            # from h = 0.2 to 0.05)
            cs = [it.c] + [it.ct] * (it.blocks - 1)
            for k, c in enumerate(cs):
                scale[o + k * m:o + (k + 1) * m] = c
                aug[o + k * m:o + (k + 1) * m] = -it.w / it.c
            blocks.append(np.column_stack([o + k * m + np.arange(m) for k in range(it.blocks)]))
        return SaddleKrylov(n, freemask, scale, aug, blocks, modes, vertex, dim,
                            tol=self.linear_tol or DEFAULT_TOL, maxit=self.linear_maxit)

    def _unheld(self, ifs: list[_Interface], rigid: np.ndarray, ru: np.ndarray, f: np.ndarray, n: int) -> str:
        """Why the active sets leave a floating body free along a loaded rigid motion: the body, the motion with
        the largest unbalanced force or moment rigid^T ru (``ru`` the residual of the equilibrium rows; N/m for a
        translation in plane scenes, N m/m for a rotation), the load's component rigid^T f along it, and what
        the body's contact nodes do (none closed, all slipping, frictionless against a tangential load, or
        closed but not holding this motion)."""
        labels = [(b, nm) for b in self.floating for nm in b.names]
        norms = np.maximum(np.linalg.norm(rigid, axis=0), 1e-300)
        j = int(np.argmax(np.abs(rigid.T @ ru) / norms))
        body, name = labels[j]
        kind = "moment" if "rotation" in name else "force"
        mode = rigid[:, j]
        closed = slipping = 0
        frictionless, normal = True, False
        for it in ifs:
            Bn = it.Bn[:, :n]
            on = (np.abs(Bn @ np.abs(body.modes[:n])).sum(axis=1) > 0) & it.active & it.keep
            closed += int(on.sum())
            slipping += int((on & it.slip).sum())
            frictionless = frictionless and (it.law.kind == "frictionless" or not on.any())
            # the closed nodes' normal rows see this motion: holding it would take tension
            size = np.asarray(abs(Bn[on]).sum(axis=1)).ravel() * float(np.max(np.abs(mode)))
            normal = normal or bool(np.any(np.abs(Bn[on] @ mode) > 1e-8 * size))
        nodes = f"{closed} closed node{'s' if closed != 1 else ''}"
        if not closed:
            why = "no contact node of the body is closed (the load pulls it off its supports)"
        elif normal:
            why = (f"its {nodes} would have to pull (contact carries compression only): the load "
                   "pulls the body off its supports")
        elif frictionless:
            why = f"its {nodes} (frictionless) carry no tangential force"
        elif slipping == closed:
            why = f"its {nodes} all slip: the load exceeds what friction can carry"
        else:
            why = f"its {nodes} ({slipping} slipping) do not hold this motion"
        return (f"body {'+'.join(body.regions)}: {name} is not held by the contact set (load component "
                f"{float(mode @ f):.3g}, unbalanced {kind} {float(mode @ ru):.3g}): {why}; add a support "
                "(displacement or symmetry condition) or change the load")

    def check_load(self, ifs: list[_Interface], f: np.ndarray, where: str) -> None:
        """Stop with a SolverError naming the body and the rigid motion when no admissible contact forces
        balance the load on the free rigid motions of the floating bodies: an LP for lam_n >= 0,
        |lam_t| <= g_c (Tresca) or F_c lam_n (Coulomb), lam_t = 0 (frictionless) with
        R^T (f + Bn^T lam_n + Bt^T lam_t) = 0 (a necessary condition of (P)). In 3D the disc |lam_t| <= b is
        not linear: it is replaced by the circumscribed regular POLYGON-gon (16: d_k . lam_t <= b for the unit
        vectors d_k at the angles 2 pi k / 16), which contains the disc, so the LP is a relaxation and the
        refusal only fires for loads that no admissible traction balances. A load between the two (at most
        1/cos(pi/16) - 1 = 2 % above the capacity, in the worst direction) passes the check, and the solve
        itself then fails (the sets leave the body unheld, or they cycle)."""
        from scipy.optimize import linprog
        R = np.hstack([b.modes for b in self.floating])
        labels = [(b, nm) for b in self.floating for nm in b.names]
        cols_eq, bounds, ub_rows, ub_poly = [], [], [], []
        nvar = 0
        for it in ifs:
            kidx = np.where(it.keep)[0]
            cols_eq.append((it.Bn[kidx] @ R).T)
            bounds += [(0, None)] * len(kidx)
            jn = np.arange(nvar, nvar + len(kidx))
            nvar += len(kidx)
            if it.dim3 and it.law.kind != "frictionless":
                # |lam_t| <= b replaced by the circumscribed regular polygon d_k . lam_t <= b (k < POLYGON):
                # an outer approximation, so a load it cannot balance no admissible traction balances
                cols_eq += [(it.Bt[kidx] @ R).T, (it.Bt2[kidx] @ R).T]
                bounds += [(None, None)] * (2 * len(kidx))
                j1 = np.arange(nvar, nvar + len(kidx))
                j2 = j1 + len(kidx)
                nvar += 2 * len(kidx)
                ang = 2 * np.pi * np.arange(POLYGON) / POLYGON
                for ca, sa in zip(np.cos(ang), np.sin(ang)):
                    if it.law.kind == "tresca":
                        ub_poly.append((j1, j2, ca, sa, None, 0.0, it.bound0[kidx]))
                    else:
                        ub_poly.append((j1, j2, ca, sa, jn, it.law.friction, np.zeros(len(kidx))))
            elif it.law.kind == "tresca":
                cols_eq.append((it.Bt[kidx] @ R).T)
                bounds += [(-float(g), float(g)) for g in it.bound0[kidx]]
                nvar += len(kidx)
            elif it.law.kind == "coulomb":
                cols_eq.append((it.Bt[kidx] @ R).T)
                bounds += [(None, None)] * len(kidx)
                jt = np.arange(nvar, nvar + len(kidx))
                nvar += len(kidx)
                ub_rows += [(a, b_, it.law.friction) for a, b_ in zip(jt, jn)]
        Aeq = np.hstack(cols_eq) if cols_eq else np.zeros((R.shape[1], 0))
        beq = -(R.T @ f)
        # scaled unknowns lam = sigma mu so that the LP's coefficients are O(1): the entries of Aeq are
        # lengths (m, e.g. 1e-4 on fine meshes) and the loads forces (e.g. 1e7 N/m); unscaled, HiGHS drops
        # the tiny coefficients and reports a false imbalance
        a_s = max(float(np.max(np.abs(Aeq), initial=0.0)), 1e-300)
        b_s = max(float(np.max(np.abs(beq))), 1e-300)
        sigma = b_s / a_s
        bounds = [(None if lo is None else lo / sigma, None if hi is None else hi / sigma) for lo, hi in bounds]
        Aub = None
        bub = None
        k = R.shape[1]
        if ub_rows or ub_poly:
            rr, cc, vv, bb = [], [], [], []
            for q, (jt_, jn_, F) in enumerate(ub_rows):      # lam_t - F lam_n <= 0, -lam_t - F lam_n <= 0
                rr += [2 * q, 2 * q, 2 * q + 1, 2 * q + 1]
                cc += [jt_, jn_, jt_, jn_]
                vv += [1.0, -F, -1.0, -F]
            nrow = 2 * len(ub_rows)
            bb.append(np.zeros(nrow))
            for j1, j2, ca, sa, jn_, F, rhs in ub_poly:       # cos lam_t1 + sin lam_t2 (- F lam_n) <= g_c / sigma
                rows = nrow + np.arange(len(j1))
                rr += [rows, rows] + ([rows] if jn_ is not None else [])
                cc += [j1, j2] + ([jn_] if jn_ is not None else [])
                vv += [np.full(len(j1), ca), np.full(len(j1), sa)] + ([np.full(len(j1), -F)] if jn_ is not None
                                                                      else [])
                bb.append(rhs / sigma)
                nrow += len(j1)
            rr = np.concatenate([np.atleast_1d(np.asarray(a)) for a in rr])
            cc = np.concatenate([np.atleast_1d(np.asarray(a)) for a in cc])
            vv = np.concatenate([np.atleast_1d(np.asarray(a, dtype=float)) for a in vv])
            Aub = sp.csr_matrix((vv, (rr, cc)), shape=(nrow, nvar + 2 * k))
            bub = np.concatenate(bb)
        # the smallest unbalanced load: minimise sum |residual| with slacks s+ - s- on the equations
        A2 = np.hstack([Aeq / a_s, np.eye(k), -np.eye(k)])
        c = np.concatenate([np.zeros(nvar), np.ones(2 * k)])
        res = linprog(c, A_ub=Aub, b_ub=bub, A_eq=A2, b_eq=beq / b_s, bounds=bounds + [(0, None)] * (2 * k),
                      method="highs")
        if res.status != 0:
            return   # undecided: let the solve itself report
        resid = (res.x[nvar:nvar + k] - res.x[nvar + k:]) * b_s
        load = np.abs(R.T @ f)
        tol = 1e-8 * max(float(np.max(load)), 1e-300)
        bad = [j for j in range(k) if abs(resid[j]) > tol]
        if bad:
            parts = []
            for j in bad:
                body, name = labels[j]
                kind = "moment" if "rotation" in name else "force"
                parts.append(f"body {'+'.join(body.regions)}: {name} is not held (load component "
                             f"{float(R[:, j] @ f):.3g}, unbalanced {kind} {-resid[j]:.3g})")
            raise SolverError(f"contact solve{' at ' + where if where else ''}: the contacts cannot hold the load: "
                              + "; ".join(parts) + ". The load pulls the body off its supports, or a tangential "
                              "load exceeds what friction can carry (frictionless contact carries none); add a "
                              "support (displacement or symmetry condition) or change the load")


def _rows_3d(it: _Interface, seg: dict, vals: np.ndarray, b: np.ndarray, x: np.ndarray, A: np.ndarray,
             pen: bool) -> None:
    """The tangential rows of a 3D frictional interface for the current sets (module docstring): per node the
    2 x 2 blocks R (on the rows -Bt u, -Bt2 u), L (on lam_t) and the Coulomb column on lam_n, right-hand side
    and start values. Stick: R = I, L = 0 (-weight / ct I in the penalty phase); slip: R = kappa T,
    L = -weight / ct (I - kappa T), T = I - e e^T; open: R = 0, L = -weight / ct I (lam_t = 0)."""
    m = it.m
    ot = it.offset + m
    stick = A & it.stick
    slip = A & it.slip
    s = it.w / it.ct
    e = it.dir
    T = np.eye(2)[None] - e[:, :, None] * e[:, None, :]                 # (m, 2, 2)
    kT = it.kappa[:, None, None] * T
    R = np.where(stick[:, None, None], np.eye(2)[None], np.where(slip[:, None, None], kT, 0.0))
    # (penalty rows: the slip law lam_t = b z / |z| with z = -c_t s, so no kappa T on lam_t)
    L = -s[:, None, None] * np.where((slip & (not pen))[:, None, None], np.eye(2)[None] - kT, np.eye(2)[None])
    L = np.where((stick & (not pen))[:, None, None], 0.0, L)
    node = seg["rows_t_node"]
    a1, a2 = seg["rows_t_a"], seg["rows_t_b"]
    vals[seg["rows_t"]] = R[node, 0, 0] * a1 + R[node, 0, 1] * a2
    vals[seg["rows_t2"]] = R[node, 1, 0] * a1 + R[node, 1, 1] * a2
    vals[seg["diag_t"]] = L[:, 0, 0]
    vals[seg["off_t"]] = L[:, 0, 1]
    vals[seg["off_t2"]] = L[:, 1, 0]
    vals[seg["diag_t2"]] = L[:, 1, 1]
    coulomb_slip = slip if it.law.kind == "coulomb" else np.zeros(m, dtype=bool)
    vals[seg["couple"]] = np.where(coulomb_slip, s * it.law.friction * e[:, 0], 0.0)
    vals[seg["couple2"]] = np.where(coulomb_slip, s * it.law.friction * e[:, 1], 0.0)
    tresca_slip = slip if it.law.kind == "tresca" else np.zeros(m, dtype=bool)
    b[ot:ot + m] = np.where(tresca_slip, -s * it.bound0 * e[:, 0], 0.0)
    b[ot + m:ot + 2 * m] = np.where(tresca_slip, -s * it.bound0 * e[:, 1], 0.0)
    x[ot:ot + m] = np.where(A, x[ot:ot + m], 0.0)
    x[ot + m:ot + 2 * m] = np.where(A, x[ot + m:ot + 2 * m], 0.0)


def _sets_3d(it: _Interface, lam_n: np.ndarray, lam_t: np.ndarray, u: np.ndarray, pen: bool) -> tuple[int, float]:
    """The new sets and slip linearization of a 3D interface from the iterate (lam_n, lam_t (m, 2), u): the
    number of set changes and the residual max |lam_t - b z / |z|| of the nodes slipping before and now,
    relative to the largest bound (0 for a frictionless interface). ``pen``: penalty rows, whose sets use the
    trial tractions z = -c_t s~, zn = -c g~ (as in 2D)."""
    m = it.m
    gap = (it.op.g0 + it.Bn @ u) / it.w
    zn = (0.0 if pen else lam_n) - it.c * gap
    act = (zn > 0) & it.keep
    stick = np.zeros(m, dtype=bool)
    slip = np.zeros(m, dtype=bool)
    res = 0.0
    if it.law.kind != "frictionless":
        sl = np.column_stack([it.Bt @ u, it.Bt2 @ u]) / it.w[:, None]
        z = (0.0 if pen else lam_t) - it.ct[:, None] * sl
        nz = np.linalg.norm(z, axis=1)
        bound = it.bound0 if it.law.kind == "tresca" else it.law.friction * np.maximum(zn, 0.0)
        stick = act & (nz < bound)
        slip = act & ~stick
        prone = it.flips >= 2          # as in 2D: twice switched nodes go through the slip state
        to_slip = prone & ((~act & it.active & it.stick & it.keep) | (act & ~it.active & stick))
        act = act | to_slip
        stick = stick & ~to_slip
        slip = slip | to_slip
        e = np.zeros((m, 2))
        pos = nz > 0
        e[pos] = z[pos] / nz[pos, None]
        e[~pos, 0] = 1.0
        # the bound of the slip rows: g_c, or F_c lam_n (as the 2D rows; = F_c zn at an iterate of the exact
        # phase, where the nodes in contact have g~ = 0, and of the penalty rows, where zn = -c g~ = lam_n)
        brow = it.bound0 if it.law.kind == "tresca" else it.law.friction * np.maximum(lam_n, 0.0)
        it.dir = np.where(slip[:, None], e, 0.0)
        it.kappa = np.where(slip, np.divide(brow, np.maximum(nz, brow), out=np.zeros(m),
                                            where=np.maximum(nz, brow) > 0), 0.0)
        both = slip & it.slip & it.active
        if both.any():
            r = np.linalg.norm(lam_t[both] - brow[both, None] * e[both], axis=1)
            scale = max(float(np.max(brow[act], initial=0.0)), float(np.max(bound[act], initial=0.0)), 1e-300)
            res = float(np.max(r)) / scale
    changes = int(np.sum(act != (it.active & it.keep)) + np.sum(stick != (it.stick & it.active))
                  + np.sum(slip != (it.slip & it.active)))
    it.flips += act != (it.active & it.keep)
    it.active, it.stick, it.slip = act, stick, slip
    return changes, res


class _Pattern:
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
                seg["mirror"] = _span(seg["rows_n"])
            elif not it.dim3:
                seg["mirror"] = np.concatenate([_span(seg["rows_n"]), _span(seg["rows_t"])])
            else:
                seg["mirror"] = None
            self.segments.append(seg)
        R, C = np.concatenate(rows), np.concatenate(cols)
        self.values = np.concatenate(vals)
        nk = len(kr)
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
            self._csr_order = np.rint(A.data).astype(np.int64) - 1
            self._csr = A
        self._csr.data = self.values[self._csr_order]
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
                    sel = seg[key] if key == "mirror" else _span(seg[key])
                    np.logical_or.at(out, self.rows[sel], values[sel] != 0.0)
        return out

    def column(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """The entries of the matrix's column of multiplier ``j`` in the equilibrium rows: (row indices, values)."""
        if self._columns is None:
            sel = np.concatenate([_span(seg["cols"]) for seg in self.segments] or [np.zeros(0, dtype=np.int64)])
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


def _free_motions(rigid: np.ndarray, M: sp.csr_matrix, n: int) -> np.ndarray | None:
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


def _relative_change(dx: np.ndarray, x: np.ndarray, n: int, freemask: np.ndarray) -> float:
    """The larger of the relative corrections of u and of the free multipliers."""
    du = float(np.linalg.norm(dx[:n])) / max(float(np.linalg.norm(x[:n])), 1e-300)
    lam = freemask[n:]
    dl = float(np.linalg.norm(dx[n:][lam])) / max(float(np.linalg.norm(x[n:][lam])), 1e-300)
    return max(du, dl)


def _span(sl: slice) -> np.ndarray:
    return np.arange(sl.start, sl.stop)


class _KrylovStep:
    """A step solved by GMRES (:class:`.contact_krylov.SaddleKrylov`) with the preconditioner of the current
    matrix; the tolerance is relative to the Newton step's right-hand side ``b`` (or the first residual when
    larger: a problem driven by prescribed displacements)."""

    usable = True
    exact = True

    def __init__(self, krylov, pattern, b: np.ndarray, info, what: str, rigid: np.ndarray, n: int):
        self.krylov, self.what, self.info = krylov, what, info
        M = pattern.csr()
        self.free_motions = _free_motions(rigid, M, n)
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


class _DenseBulk:
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
        order = pattern._csr_order
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


class _DenseOperator(ngs.BaseMatrix):
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


class _DenseStep:
    """A Newton step of a dense bulk (:class:`_DenseBulk`): M = [[S, C], [R, D]] solved by eliminating u,

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

    def __init__(self, bulk: _DenseBulk, pattern, n: int, freemask: np.ndarray):
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
        CP.data = data[blocks["CT_pos"]][_rows_entries(blocks["CT"], P)]
        keys_r = [_row_key(idx[p], RP, k) for k, p in enumerate(P)]
        keys_c = [_row_key(idx[p], CP, k) for k, p in enumerate(P)]
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


def _rows_entries(A: sp.csr_matrix, rows: np.ndarray) -> np.ndarray:
    """The positions in ``A.data`` of the entries of ``rows`` (in order), i.e. of A[rows].data."""
    starts, ends = A.indptr[rows], A.indptr[np.asarray(rows) + 1]
    if not len(starts):
        return np.zeros(0, dtype=np.int64)
    return np.concatenate([np.arange(a, b) for a, b in zip(starts, ends)]).astype(np.int64)


def _row_key(j: int, A: sp.csr_matrix, k: int) -> tuple:
    """A cache key of row ``k`` of ``A`` (the multiplier ``j``'s row or column): its index and its entries."""
    lo, hi = A.indptr[k], A.indptr[k + 1]
    return int(j), A.indices[lo:hi].tobytes(), A.data[lo:hi].tobytes()


class _Fresh:
    """A step with the factorization of the current matrix (``exact``) or of its quasi-definite companion."""

    usable = True

    def __init__(self, inv, exact: bool = True):
        self.inv = inv
        self.exact = exact

    def apply(self, r, dx) -> bool:
        dx.data = self.inv * r
        return True


class _Reuse:
    """A step with the factorization of an earlier matrix M0 of the same solve, which differs from the current
    matrix M in the rows ``rows`` (the multiplier rows of the nodes whose contact state changed since):
    M = M0 + E (N - O) with E the unit columns of those rows, N and O their new and old values. With
    y = M0^-1 b and Z = M0^-1 E (one solve per changed row, cached until the next factorization), and
    O y = E^T b, O Z = I, the Sherman-Morrison-Woodbury formula gives

        x = y - Z t,    (N Z) t = N y - E^T b,

    a dense system of the size of ``rows``. A solve costs about a tenth of a factorization at 100k dofs in 2D,
    so this pays for a few changed rows.

    When M0 is a quasi-definite companion (:meth:`_Pattern.symmetric`), the nodes that entered the contact or
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


def nodal_modulus(props) -> float:
    """A modulus scale (Pa) for the default augmentation: the largest diagonal entry of the stiffnesses."""
    return max(float(np.max(np.diag(p.C))) for p in props.values())

