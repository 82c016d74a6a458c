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

Linear algebra (one strategy of :mod:`.steps` per solve: sparse direct, dense condensed or Krylov steps): one
saddle-point matrix per solve with a fixed sparsity pattern (:class:`.saddle.SaddlePattern`; in 3D a third
multiplier block per interface, the rows of t1 and t2 on the union of the patterns of Bt and Bt2, and the 2 x 2
multiplier blocks); a fixed multiplier (open node, 2D Tresca slip) keeps its row as an identity row scaled like
the penalty rows, so the matrices of consecutive iterations differ only in the rows of the nodes whose state
changed. A matrix is factored (UMFPACK) when more than ``reuse_rows`` (12) rows changed since the last
factorization without a
cached solve; otherwise the old factorization is reused through the Sherman-Morrison-Woodbury formula
(:class:`.steps.WoodburyStep`: one extra solve per changed row). The active sets of the Hertz test (P2, 41k dofs) shrink
geometrically, 186, 143, 115, 99, 90, 85, 83, 82, 81 nodes: 6 factorizations and 18 extra solves instead of
11 factorizations.

Which factorization: a matrix whose bulk K is symmetric and whose multiplier rows are the transposes of their
columns or fix their multiplier alone (frictionless, Tresca, Coulomb while no node slips; 2D, or 3D frictionless)
is factored through its symmetric quasi-definite companion (:meth:`.saddle.SaddlePattern.symmetric`: the columns
of fixed multipliers left out, the exact rows' zero diagonal -w / (c x QUASI_DEFINITE)) by NGSolve's sparse Cholesky
(LDL^T without pivoting, which every symmetric quasi-definite matrix admits), and the solve is refined with the
exact residual (the companion's solve is the matrix's to ~1e-8; one more step to round-off); other matrices by
UMFPACK. Measured at 140k dofs (P2 Hertz, one thread): 1.17 - 1.26 s per factorization and 0.08 - 0.09 s per
solve, against 1.9 s and 0.18 s with UMFPACK. A Woodbury update of a companion's factorization also adds the
columns of the nodes that entered the contact or started sticking since (the companion left them out:
:class:`.steps.WoodburyStep`), one more solve per such node. The saddle-point pattern is the sum of K embedded and the
multiplier entries (CreateSparseMatrix, 0.08 s at 140k dofs; CreateFromCOO of the whole took 1.2 - 1.4 s).

Iterative Newton steps (``linear="iterative"``, the scene's ``solver.linear``): each Newton-step matrix
is solved by GMRES with the augmented-Lagrangian AMG preconditioner of :mod:`.krylov` instead of the
factorizations above (no Woodbury reuse, no companion; the floating bodies' refinement criteria as above; the
rigid motions that nothing holds are kept out of the iterates, :func:`.steps.free_motions`). The iterations per Newton
step grow slowly under refinement (3D Coulomb punch: P1 41 -> 90 from 663 to 121k dofs, P2 54 -> 99 from 3.8k to
130k), and the 130k-dof P2 solve takes 68 s against 399 s directly (the tables of :mod:`.krylov` and
``studies/scaling``). The slip rows of 3D friction then converge to 100 x the GMRES tolerance instead of
NEWTON_TOL.

Condensed solves (``linear="condensed"``, the default "auto" in 2D when PARDISO is installed): the problem is
condensed onto the dofs of the contact nodes by one PARDISO factorization of K with their Schur complement S
(:mod:`.condensed`), and this solver then runs on the dense S (a numpy bulk): the same iteration, the
pattern holding only the multiplier entries, each Newton step eliminating u against one Cholesky factorization of
S (:class:`.steps.DenseStep`: (D - R S^-1 C) lam = r_m - R S^-1 r_u over the rows coupled to u, the others through their
own block). S is shifted by steps.DENSE_SHIFT = 1e-7 of its mean diagonal on the floating bodies' dofs (on all dofs
when none is declared: a time step's body on a foundation), not 1e-10: the elimination through S^-1 loses about
the shift's inverse in relative accuracy (with 1e-10 the refinement of a floating Coulomb block stalled at a
relative step error of 5e-7), and the refinement with the exact residual removes the shift as before.

Units: u m, multipliers Pa (nodal values of the contact pressure and tangential traction).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..linalg import pardiso
from ..linalg.direct import check_finite
from .base import ContactSolverBase
from .condensed import CondensedContact, applicable
from .forms import ContactOperator
from .krylov import near_null_space
from .laws import ContactLaw, ContactOptions, slip_bound
from .linear_algebra import drop_prescribed_nodes
from .saddle import SaddlePattern
from .steps import NewtonSystem, newton_steps, relative_change

COULOMB_FIXED_POINT_TOL = 1e-8    # Coulomb fallback: relative change of the slip bounds F_c p that ends it
COULOMB_FIXED_POINT_MAXIT = 60
NEWTON_TOL = 1e-11     # 3D slip rows: converged when max |lam_t - b z / |z|| <= NEWTON_TOL x the largest bound
POLYGON = 16           # 3D solvability check: the friction disc |lam_t| <= b inside a regular 16-gon
INEXACT_REFINEMENTS = 6  # refinement steps with the quasi-definite factorization before factoring exactly


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
    """linear="iterative": the GMRES iterations of every Newton-step solve (:mod:`.krylov`)."""
    amg_setups: int = 0
    """linear="iterative": the AMG hierarchies built (one per solve; later Newton steps refresh its operators)."""
    condensed_dofs: int = 0
    """linear="condensed": the surface dofs of the condensed problem (:mod:`.condensed`)."""
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


class ContactSolver(ContactSolverBase):
    """Solves K u = f + B^T lam with the complementarity conditions of the interfaces for the current
    elastic data. ``matrix`` and ``rhs`` are the assembled bulk operator (X x X) and load (X), ``free`` the
    free dofs of X (numpy bool), ``x0`` a vector of X holding the prescribed (Dirichlet) values."""

    warm_starts = True

    def __init__(self, interfaces: list[tuple[ContactOperator, ContactLaw]], *, modulus: float, floating=(),
                 forms=None, options: ContactOptions | None = None, **settings):
        """``modulus``: the scale (Pa) of the default augmentations (:func:`nodal_modulus`). ``floating``: the
        semi-coercive bodies (:meth:`ElasticForms.floating_bodies`): their load is checked for solvability before
        any factorization, and their free dofs get a tiny diagonal shift in the factorization (the residual is
        always that of the exact system, so the converged solution is exact; a motion no contact holds, e.g. the
        sliding of a frictionless body under a balanced load, is fixed at the shift's minimum-norm value).
        ``forms``: the :class:`ElasticForms` of the matrix (``linear="iterative"``: the displacement space and the
        rigid motions of the AMG). ``options``: :class:`.laws.ContactOptions`; keywords of its field names
        (``maxit``, ``method``, ``linear``, ...) replace its values. ``linear``: "direct" (the factorizations
        above), "condensed" (the problem condensed onto the contact surface by one PARDISO factorization of K,
        :mod:`.condensed`; 2D), "auto" (condensed in 2D when PARDISO is installed, else direct) or "iterative":
        every Newton step by GMRES with the augmented-Lagrangian AMG preconditioner of :mod:`.krylov`.
        ``check_solvable`` False skips the check of the floating bodies' load (the condensed solver's inner
        problem, whose caller checked it on all nodes)."""
        opts = dataclasses.replace(options or ContactOptions(), **settings)
        if opts.method not in ("ssn", "penalty"):
            raise ValueError(f"unknown contact method {opts.method!r} for ContactSolver: 'ssn' or 'penalty' (Uzawa: "
                             "UzawaSolver)")
        linear = opts.linear
        if linear == "condensed" and not pardiso.available():
            raise ValueError("the condensed contact solver needs oneMKL PARDISO: install the 'mkl' package")
        if linear == "iterative" and forms is None:
            raise ValueError("the iterative contact solver needs the elastic forms (forms=): the displacement space "
                             "and its rigid motions")
        if linear == "auto":
            dim = 3 if any(op.Bt2 is not None for op, _ in interfaces) else 2
            linear = "condensed" if applicable(dim) else "direct"
        self.options = opts
        self.linear = linear
        self.forms = forms
        self.linear_tol = opts.linear_tol
        self.linear_maxit = opts.linear_maxit
        self._modes = None                 # krylov.near_null_space(forms), for the iterative solver's AMG
        self._condensed = None             # condensed.CondensedContact (linear="condensed")
        self.check_solvable = opts.check_solvable
        self.items = interfaces
        self.modulus = float(modulus)
        self.maxit = opts.maxit
        self.floating = list(floating)
        self.method = opts.method
        self.reuse_rows = opts.reuse_rows
        self.quasi_definite = opts.quasi_definite
        self.infos: list[ContactInfo] = []
        self._state: list[_Interface] | None = None
        self._pattern: SaddlePattern | None = None
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

    @classmethod
    def from_options(cls, items, options: ContactOptions, *, modulus: float, floating=(), forms=None) -> ContactSolver:
        return cls(items, modulus=modulus, floating=floating, forms=forms, options=options)

    def inner_solver(self, items: list[tuple[ContactOperator, ContactLaw]], floating: list) -> ContactSolver:
        """A solver with this one's settings for other interfaces and floating bodies, on the sparse or dense
        steps (the condensed problem's: its dense bulk selects the dense steps), without the solvability check
        of the load (the caller checked it on all nodes: the candidate nodes alone could wrongly refuse it)."""
        return ContactSolver(items, modulus=self.modulus, floating=floating, options=self.options, linear="direct",
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

        ``linear="condensed"``: the problem condensed onto the contact surface (:mod:`.condensed`); what it
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
            bounds = {k: slip_bound(items[k][1].friction, self.multipliers[k][0]) for k in coulomb}
            for npass in range(1, COULOMB_FIXED_POINT_MAXIT + 1):
                use({k: ContactLaw("tresca", slip_bound=bounds[k], augmentation=items[k][1].augmentation,
                                   penalty=items[k][1].penalty) for k in coulomb})
                u, info = self._solve(matrix, rhs, free, u, where)
                total.coulomb_fixed_point_passes = npass
                total.iterations += info.iterations
                total.factorizations += info.factorizations
                new = {k: slip_bound(items[k][1].friction, self.multipliers[k][0]) for k in coulomb}
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
        """One active-set (semi-smooth Newton) iteration from the current sets (module docstring): each iteration
        sets the rows of the current sets, solves the Newton step to the exact residual and takes the new sets;
        the linear algebra of the steps is the strategy :func:`.steps.newton_steps` chooses for this solve."""
        tic = time.perf_counter()
        self._exact_cold = False
        n = len(x0)
        ifs = self.interfaces(n)
        drop_prescribed_nodes(ifs, free, n)
        steps = newton_steps(matrix, self.linear, reuse_rows=self.reuse_rows, quasi_definite=self.quasi_definite,
                             modes=self._krylov_modes, tol=self.linear_tol, maxit=self.linear_maxit)
        s = self._system(matrix, rhs, free, n, ifs, steps, where)
        x = np.zeros(s.N)
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
        newton_tol = max(NEWTON_TOL, steps.tol_floor)
        info = s.info
        for it_nr in range(1, self.maxit + 1):
            b = _assemble_rows(s, x, penalty)
            step = steps.step(s, b, it_nr)
            x, held, xv, r = self._newton_step(s, steps, step, b, x, it_nr)
            if not held:
                penalty = self._unheld_sets(s, steps, b, x, xv, r, it_nr, penalty)
                continue
            changes, newton = _new_sets(s, x, lam_n, lam_t, penalty, it_nr)
            if changes == 0:
                if penalty and self.method == "ssn":
                    penalty = False
                    info.penalty_iterations = it_nr
                    continue
                if newton <= newton_tol:
                    break
        else:
            if info.changes[-1] == 0:
                raise SolverError(f"{s.what}: the slip directions have not converged after {self.maxit} iterations "
                                  f"(residual of the slip rows {info.newton_residual[-1]:.1e} of the slip bound); "
                                  "refine the mesh or change the augmentation")
            raise _Cycling(f"{s.what}: the active sets still change after {self.maxit} iterations "
                           f"({info.changes[-1]} changes in the last one): the contact state cycles; refine the mesh "
                           "or change the augmentation")
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

    def _krylov_modes(self):
        """The near null space of the displacement space for the iterative steps' AMG (computed once)."""
        if self._modes is None:
            self._modes = near_null_space(self.forms)
        return self._modes

    def _system(self, matrix, rhs, free: np.ndarray, n: int, ifs: list[_Interface], steps, where: str) -> NewtonSystem:
        """The data the Newton steps of a solve share (:class:`.steps.NewtonSystem`): the load on the free dofs, the
        shift of the floating bodies' free dofs (``steps.shift`` of their mean diagonal; the residual is always
        that of the exact system), their rigid motions, the saddle-point pattern (kept for the next solve with the
        same sparsity of K) and the operator the strategy ``steps`` solves with."""
        what = f"contact solve{' at ' + where if where else ''}"
        N = n + sum(it.blocks * it.m for it in ifs)
        kr, kc, kv = steps.bulk_coo(matrix)
        f = np.where(free, np.asarray(rhs, dtype=float), 0.0)   # (fixed dofs: their load is the support's)
        if not np.all(np.isfinite(f)):
            bad = int(np.count_nonzero(~np.isfinite(f)))
            raise SolverError(f"{what}: the load vector has {bad} NaN or infinite entries on free dofs; check the "
                              "loads, temperatures and material data")
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
        reg_dofs = steps.shift_dofs(reg_dofs, free)
        if len(reg_dofs):
            eps = steps.shift * float(np.mean(np.abs(steps.diagonal(matrix, n, kr, kc, kv)[reg_dofs])))
        rigid = np.hstack([bd.modes[:n] for bd in self.floating]) if self.floating else np.zeros((n, 0))
        # one pattern for all solves with the same K sparsity (a time series, the secant loop): building it
        # (CreateFromCOO) cost as much as a factorization (0.22 s at 41k dofs)
        pattern = self._pattern
        if pattern is not None and pattern.matches(N, kr, kc):
            pattern.set_bulk(n, kv, reg_dofs, eps)
        else:
            pattern = self._pattern = SaddlePattern(n, N, kr, kc, kv, reg_dofs, eps, ifs,
                                                    bulk=steps.pattern_bulk(matrix))
        # the free unknowns are the same at every iteration: a fixed multiplier (open node, Tresca slip) has
        # an identity row, so consecutive matrices differ only in the rows of the nodes whose state changed
        freemask = np.zeros(N, dtype=bool)
        freemask[:n] = free
        for it in ifs:
            freemask[it.offset:it.offset + (it.blocks * it.m if it.law.kind != "frictionless" else it.m)] = True
        s = NewtonSystem(n, N, ifs, info, what, f, free, freemask, ngs.BitArray(freemask.tolist()), reg_dofs, eps,
                         rigid, float(np.max(np.linalg.norm(rigid, axis=0), initial=0.0)), pattern)
        s.mat = steps.operator(s, matrix)
        return s

    def _newton_step(self, s: NewtonSystem, steps, step, b: np.ndarray, x: np.ndarray, it_nr: int):
        """Solve the Newton step from ``x`` by refinement with the residual of the exact system (without the shift
        eps) with the strategy's ``step``: (the new iterate with its fixed multipliers set exactly, whether the sets
        hold the floating bodies, the iterate and the residual as vectors of the matrix)."""
        n, mat, reg_dofs = s.n, s.mat, s.reg_dofs
        xv = mat.CreateColVector()
        xv.FV().NumPy()[:] = x
        r = mat.CreateColVector()
        held = True
        dx = mat.CreateColVector()
        last_balance = math.inf
        last_change = math.inf      # the last correction of an inexact (companion) step, relative
        slow = False
        for k_ref in range(20):   # refinement with the residual of the exact system (without the shift eps)
            if not step.exact and (slow or k_ref == INEXACT_REFINEMENTS):
                # the quasi-definite companion does not converge fast to the exact system here: factor the matrix
                # itself
                step = steps.refactor(exact=True)
            ra = _residual(s, xv, r)
            ra[:] = b - ra
            ra[~s.freemask] = 0.0
            if not step.apply(r, dx):        # the reused factorization did not converge: factor now
                step = steps.refactor()
                step.apply(r, dx)
            if not step.exact and not np.all(np.isfinite(dx.FV().NumPy())):
                # a companion's Cholesky without pivoting met a zero pivot (K singular beyond the known
                # floating bodies): UMFPACK factors the matrix itself, or names the singularity
                step = steps.refactor(exact=True)
                step.apply(r, dx)
            xv.data += dx
            steps.project(step, xv, n)
            if not len(reg_dofs) and not step.exact:
                # no floating body: converged when the corrections of u and of the multipliers contract so that
                # the error left (about change q / (1 - q), q the last contraction) is below 1e-12 of the
                # solution: with the exact rows' regularization q ~ 1e-8 and two solves do; a contraction above
                # 1/4 goes to the exact factorization (leaving a Coulomb coupling out of the companion and
                # refining was tried: at the blocks' h = 0.01 the contraction was above 1/4, a third
                # factorization followed)
                change = relative_change(dx.FV().NumPy(), xv.FV().NumPy(), n, s.freemask)
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
            d = d - s.rigid @ np.linalg.lstsq(s.rigid, d, rcond=None)[0]
            if float(np.linalg.norm(d)) <= 1e-6 * max(float(np.linalg.norm(xv.FV().NumPy()[:n])), 1e-300):
                if not s.rigid.shape[1]:
                    break
                # the shift leaves a residual eps u along the rigid motions (eps x translation x dofs: 0.5 N
                # of a 2.5 kN load on a weak Coulomb interface); refine while that falls
                balance = _rigid_balance(s, b, xv, r)
                if balance <= 1e-10 * _balance_scale(s, b, xv) or balance > 0.5 * last_balance:
                    break
                last_balance = balance
        else:
            held = False
        if held and s.rigid.shape[1]:   # the loaded rigid motions must be balanced by the contact forces
            held = _rigid_balance(s, b, xv, r) <= 1e-8 * _balance_scale(s, b, xv)
        check_finite(xv, f"{s.what}, iteration {it_nr}")
        return _fixed_multipliers(s, np.array(xv.FV().NumPy())), held, xv, r

    def _unheld_sets(self, s: NewtonSystem, steps, b: np.ndarray, x: np.ndarray, xv, r, it_nr: int,
                     penalty: bool) -> bool:
        """New sets when the current ones leave a floating body free along a loaded rigid motion: every node
        slipping while the friction cannot balance the load (retry with the active nodes sticking, or walk the
        slip directions, :func:`_balance_slip`), or too few nodes in contact (e.g. the single first node of a
        curved side: add the nearest open nodes). Returns whether the penalty phase goes on."""
        ifs, info, n = s.ifs, s.info, s.n
        info.unheld_sets += 1
        grow = all(not (it.slip & it.active).any() for it in ifs)
        if info.unheld_sets > 3 or (grow and not any((it.keep & ~it.active).any() for it in ifs)):
            ra = _residual(s, xv, r)
            raise SolverError(f"{s.what}, iteration {it_nr}: "
                              + self._unheld(ifs, s.rigid, (b - ra)[:n] * s.free, s.f, n))
        walked = False
        if not grow and s.rigid.shape[1] and not any(it.dim3 for it in ifs):
            # every active node slips and their friction does not balance the load: move the points where
            # the slip direction turns until it does (sticking all nodes instead threw the sets back to
            # the start: they cycled, e.g. a block spreading under its load on a weak interface)
            walked = _walk_slip(s, b, x, xv, r)
            if walked and self.method == "ssn":
                # the penalty rows let a sticking node slip by lam_t / c_t, which turns its neighbours'
                # slip directions back (the sets cycled): the exact rows from here on
                penalty = False
            if walked:
                # the factorization of the unheld matrix (singular but for the shift) is no basis for the
                # next one: reused, the refinement left the rigid-motion part unconverged (imbalance 2e-4)
                steps.forget()
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
        return penalty

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
        cols_eq, bounds, ub_rows, ub_poly, nvar = _load_lp(ifs, R)
        Aeq = np.hstack(cols_eq) if cols_eq else np.zeros((R.shape[1], 0))
        beq = -(R.T @ f)
        # scaled unknowns lam = sigma mu so that the LP's coefficients are O(1): the entries of Aeq are
        # lengths (m, e.g. 1e-4 on fine meshes) and the loads forces (e.g. 1e7 N/m); unscaled, HiGHS drops
        # the tiny coefficients and reports a false imbalance
        a_s = max(float(np.max(np.abs(Aeq), initial=0.0)), 1e-300)
        b_s = max(float(np.max(np.abs(beq))), 1e-300)
        sigma = b_s / a_s
        bounds = [(None if lo is None else lo / sigma, None if hi is None else hi / sigma) for lo, hi in bounds]
        k = R.shape[1]
        Aub, bub = _friction_inequalities(ub_rows, ub_poly, nvar, k, sigma)
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


class PenaltyContactSolver(ContactSolver):
    """The penalty method: the iteration of :class:`ContactSolver` with the penalty rows (lam_n = c x penetration,
    lam_t = c_t x stick slip) kept to the end on every interface (``method="penalty"``)."""

    def __init__(self, interfaces: list[tuple[ContactOperator, ContactLaw]], *, modulus: float, floating=(),
                 forms=None, options: ContactOptions | None = None, **settings):
        super().__init__(interfaces, modulus=modulus, floating=floating, forms=forms, options=options,
                         **{**settings, "method": "penalty"})


def _load_lp(ifs: list[_Interface], R: np.ndarray) -> tuple[list, list, list, list, int]:
    """The unknowns of :meth:`ContactSolver.check_load`'s LP per interface (lam_n >= 0 of the kept nodes, then
    lam_t: bounded by g_c (2D Tresca), free with |lam_t| <= F_c lam_n rows (2D Coulomb) or polygon rows (3D
    friction)): the equation columns R^T B^T, the bounds, the Coulomb rows (lam_t, lam_n, F_c), the polygon rows
    (t1, t2, cos, sin, lam_n or None, F_c, right-hand side) and the number of unknowns."""
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
    return cols_eq, bounds, ub_rows, ub_poly, nvar


def _friction_inequalities(ub_rows: list, ub_poly: list, nvar: int, k: int, sigma: float):
    """The inequality rows of the friction bounds of :meth:`ContactSolver.check_load`'s LP (in the unknowns scaled
    by ``sigma``; ``k`` slack pairs follow the ``nvar`` unknowns): (A_ub, b_ub), or (None, None) without friction."""
    if not (ub_rows or ub_poly):
        return None, None
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
    return Aub, bub


def _residual(s: NewtonSystem, xv, r) -> np.ndarray:
    """The residual's matrix part M x of the exact system (without the shift eps) into ``r``; returns its array."""
    r.data = s.mat * xv
    ra = r.FV().NumPy()
    ra[s.reg_dofs] -= s.eps * xv.FV().NumPy()[s.reg_dofs]
    return ra


def _rigid_balance(s: NewtonSystem, b: np.ndarray, xv, r) -> float:
    """The largest unbalanced force or moment along the floating bodies' rigid motions at the iterate ``xv``."""
    ra = _residual(s, xv, r)
    return float(np.max(np.abs(s.rigid.T @ ((b - ra)[:s.n] * s.free))))


def _balance_scale(s: NewtonSystem, b: np.ndarray, xv) -> float:
    """Forces the rigid-motion balance is measured against: the load, or the contact forces of the iterate when
    there is none (a problem driven by its gaps alone: an overlap pressing a body)."""
    xs = xv.FV().NumPy()
    forces = float(np.linalg.norm(b[:s.n] * s.free))
    for it in s.ifs:
        forces = max(forces, float(np.linalg.norm(it.Bn[:, :s.n].T @ xs[it.offset:it.offset + it.m])))
    return max(forces * s.mode_size, 1e-300)


def _fixed_multipliers(s: NewtonSystem, x: np.ndarray) -> np.ndarray:
    """``x`` with the fixed multipliers set exactly (their identity rows hold them to round-off)."""
    for it in s.ifs:
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
    return x


def _walk_slip(s: NewtonSystem, b: np.ndarray, x: np.ndarray, xv, r) -> bool:
    """2D, every active node slipping and a floating body unheld: :func:`_balance_slip` on each frictional
    interface, for the rigid motions the active normal rows leave free (the others are balanced by the normal
    pressures whatever the friction does). Whether any interface's sets were walked."""
    n, rigid = s.n, s.rigid
    ra = _residual(s, xv, r)
    held_rows = [(it.Bn[:, :n][it.active & it.keep] @ rigid) for it in s.ifs]
    A_held = np.vstack(held_rows) if held_rows else np.zeros((0, rigid.shape[1]))
    _, sv, vt = np.linalg.svd(A_held, full_matrices=True) if A_held.size else (None, np.zeros(0),
                                                                              np.eye(rigid.shape[1]))
    rank = int(np.sum(sv > 1e-10 * max(float(sv.max(initial=0.0)), 1e-300)))
    free_modes = rigid @ vt[rank:].T
    imbalance = free_modes.T @ ((b - ra)[:n] * s.free)
    walked = False
    for it in s.ifs:
        if it.law.kind != "frictionless" and (it.slip & it.active).any() and free_modes.shape[1]:
            imbalance = _balance_slip(it, x[it.offset + it.m:it.offset + 2 * it.m], free_modes, n, imbalance)
            walked = True
    return walked


def _assemble_rows(s: NewtonSystem, x: np.ndarray, penalty: bool) -> np.ndarray:
    """Set the multiplier rows of the current sets in the pattern's values (and the matrix), the start values of
    the fixed multipliers in ``x``; returns the right-hand side b (N)."""
    n = s.n
    b = np.zeros(s.N)
    b[:n] = s.f
    vals = s.pattern.values
    for it, seg in zip(s.ifs, s.pattern.segments):
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
        elif it.dim3:
            _rows_3d(it, seg, vals, b, x, A, pen_i)
        else:
            _rows_2d(it, seg, vals, b, x, A, pen_i)
    s.pattern.update()
    return b


def _rows_2d(it: _Interface, seg: dict, vals: np.ndarray, b: np.ndarray, x: np.ndarray, A: np.ndarray,
             pen: bool) -> None:
    """The tangential rows of a 2D frictional interface for the current sets: stick rows -Bt u (- weight / ct
    lam_t) = 0; Coulomb slip rows lam_t - F sign lam_n = 0; Tresca slip rows lam_t = g_c sign; open nodes
    lam_t = 0."""
    ot = it.offset + it.m
    stick = A & it.stick
    slip = A & it.slip
    vals[seg["rows_t"]] = seg["rows_t_values"] * stick[seg["rows_t_node"]]
    vals[seg["diag_t"]] = np.where(stick & (not pen), 0.0, -it.w / it.ct)
    coulomb_slip = slip if it.law.kind == "coulomb" else np.zeros(it.m, dtype=bool)
    vals[seg["couple"]] = np.where(coulomb_slip, it.w / it.ct * it.law.friction * it.sign, 0.0)
    fixed_t = np.where(slip & (it.law.kind == "tresca"), it.bound0 * it.sign, 0.0)
    b[ot:ot + it.m] = -it.w / it.ct * fixed_t
    x[ot:ot + it.m] = np.where(stick | coulomb_slip, x[ot:ot + it.m], fixed_t)


def _new_sets(s: NewtonSystem, x: np.ndarray, lam_n: list, lam_t: list, penalty: bool, it_nr: int) -> tuple[int, float]:
    """The multipliers of the iterate ``x`` into ``lam_n``, ``lam_t`` and the new sets of every interface, recorded
    in the history: (the number of set changes, the largest relative residual of the 3D slip rows)."""
    changes = 0
    n_act = n_stick = n_slip = 0
    u = x[:s.n]
    newton = 0.0      # 3D: the largest residual |lam_t - b z / |z|| of the slip rows / the largest bound
    for k, it in enumerate(s.ifs):
        on, ot = it.offset, it.offset + it.m
        lam_n[k] = x[on:on + it.m].copy()
        if it.dim3:
            lam_t[k] = np.column_stack([x[ot:ot + it.m], x[ot + it.m:ot + 2 * it.m]])
            ch, res = _sets_3d(it, lam_n[k], lam_t[k], u, penalty or it.law.penalty)
            newton = max(newton, res)
        else:
            lam_t[k] = x[ot:ot + it.m].copy()
            ch = _sets_2d(it, lam_n[k], lam_t[k], u, penalty or it.law.penalty)
        changes += ch
        n_act += int(it.active.sum())
        n_stick += int(it.stick.sum())
        n_slip += int(it.slip.sum())
    info = s.info
    info.iterations = it_nr
    info.active.append(n_act)
    info.stick.append(n_stick)
    info.slip.append(n_slip)
    info.changes.append(changes)
    info.newton_residual.append(newton)
    return changes, newton


def _sets_2d(it: _Interface, lam_n: np.ndarray, lam_t: np.ndarray, u: np.ndarray, pen: bool) -> int:
    """The new sets and slip signs of a 2D interface from the iterate (lam_n, lam_t, u): the number of set changes.
    ``pen``: penalty rows, whose sets use the trial tractions -c g~, -c_t s~ (lam - c g~ would double them, and a
    Tresca node would start slipping at half its bound)."""
    gap = (it.op.g0 + it.Bn @ u) / it.w
    zn = (0.0 if pen else lam_n) - it.c * gap
    act = (zn > 0) & it.keep
    stick = np.zeros(it.m, dtype=bool)
    slip = np.zeros(it.m, dtype=bool)
    sign = it.sign.copy()
    if it.law.kind != "frictionless":
        sl = (it.Bt @ u) / it.w
        z = (0.0 if pen else lam_t) - it.ct * sl
        bound = it.bound0 if it.law.kind == "tresca" else slip_bound(it.law.friction, zn)
        stick = act & (np.abs(z) < bound)
        slip = act & ~stick
        # nodes that have switched between contact and separation twice (e.g. the tip of a wedge on a Coulomb
        # fault: sticking, the node goes into tension; released, it penetrates) go through the slip state: a
        # sticking node in tension slips instead of opening, and such a node comes back into contact slipping
        prone = it.flips >= 2
        to_slip = prone & ((~act & it.active & it.stick & it.keep) | (act & ~it.active & stick))
        act = act | to_slip
        stick = stick & ~to_slip
        slip = slip | to_slip
        sign = np.where(slip, np.sign(z), 0.0)
        sign[slip & (sign == 0)] = 1.0
    changes = int(np.sum(act != (it.active & it.keep)) + np.sum(stick != (it.stick & it.active))
                  + np.sum(slip & (sign != it.sign)) + np.sum(slip != (it.slip & it.active)))
    it.flips += act != (it.active & it.keep)
    it.active, it.stick, it.slip, it.sign = act, stick, slip, sign
    return changes


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
        bound = it.bound0 if it.law.kind == "tresca" else slip_bound(it.law.friction, zn)
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
        brow = it.bound0 if it.law.kind == "tresca" else slip_bound(it.law.friction, lam_n)
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


def nodal_modulus(props) -> float:
    """A modulus scale (Pa) for the default augmentation: the largest diagonal entry of the stiffnesses."""
    return max(float(np.max(np.diag(p.C))) for p in props.values())

