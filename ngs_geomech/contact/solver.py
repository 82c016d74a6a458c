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
the cone is |lam_t,j| <= b_j, and the slip rows are the Newton linearization of the slip condition
lam_t = b z / |z| at the current iterate (:mod:`.active_set`). The sets no longer settle the solution: the
iteration stops when they repeat and the slip rows' residual max |lam_t - b z / |z|| over the nodes slipping in
both of the last two iterates is below NEWTON_TOL (1e-11) of the largest bound (superlinear, e.g. 9e-3, 1e-4,
3e-11, 4e-16 in the last steps; 5 to 10 iterations on the block tests, tests/test_contact_friction_3d.py). The
slip rows change at every iteration, so a 3D solve with more than a few slipping nodes factors at every
iteration (no Woodbury reuse). The multipliers of a 3D interface are (lam_n (m,), lam_t (m, 2)).

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

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..linalg import pardiso
from ..linalg.direct import check_finite
from .active_set import assemble_rows, fixed_multipliers, new_sets
from .base import ContactSolverBase
from .condensed import CondensedContact, applicable
from .floating import balance_scale, check_load, rigid_balance, unheld_reason, walk_slip
from .forms import ContactOperator
from .laws import ContactLaw, ContactOptions, slip_bound
from .linear_algebra import drop_prescribed_nodes
from .saddle import SaddlePattern
from .state import ContactInfo, InterfaceState
from .steps import NewtonSystem, exact_residual, newton_steps, relative_change

COULOMB_FIXED_POINT_TOL = 1e-8    # Coulomb fallback: relative change of the slip bounds F_c p that ends it
COULOMB_FIXED_POINT_MAXIT = 60
NEWTON_TOL = 1e-11     # 3D slip rows: converged when max |lam_t - b z / |z|| <= NEWTON_TOL x the largest bound
ROUNDOFF_TOL = 1e-9    # ... or below ROUNDOFF_TOL and no longer halving (the round-off floor of the rows)
U_FLOOR = 1e-8         # floating bodies' refinement: displacements below U_FLOOR |f| / mean diag K (m) count as zero
INEXACT_REFINEMENTS = 6  # refinement steps with the quasi-definite factorization before factoring exactly


class _Cycling(SolverError):
    """The active sets of the semi-smooth Newton iteration cycle (ContactSolver falls back for Coulomb)."""


def node_permutation(saved, current) -> np.ndarray | None:
    """The rows of ``saved`` (node coordinates, m x dim) in the order of ``current``: None when they are already in
    it (or the node counts differ), else the index array p with saved[p] = current (each node matched once, to
    1e-9 of the interface's extent; a contact's nodes are in the order of the mesh's numbering, which follows how
    a distributed mesh is split). Raises ValueError when the nodes are not the same."""
    saved, current = np.asarray(saved, dtype=float), np.asarray(current, dtype=float)
    if saved.shape != current.shape or np.array_equal(saved, current):
        return None
    from scipy.spatial import cKDTree

    size = float(np.max(np.ptp(current, axis=0), initial=0.0)) or 1.0
    dist, perm = cKDTree(saved).query(current)
    if np.max(dist, initial=0.0) > 1e-9 * size or len(np.unique(perm)) != len(perm):
        raise ValueError("the contact nodes of the checkpoint are not this mesh's")
    return perm


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
        self._state: list[InterfaceState] | None = None
        self._pattern: SaddlePattern | None = None
        self.converged = False
        self._penalty_start = False      # a cold solve from the penalty start (after a failed exact start)
        self._exact_cold = False         # the last solve started cold with the exact constraints
        self.multipliers: list[tuple[np.ndarray, np.ndarray]] = []

    def interfaces(self, ndof: int) -> list[InterfaceState]:
        if self._state is None:
            out, off = [], ndof
            for op, law in self.items:
                out.append(InterfaceState(op, law, self.modulus, off, ndof))
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
            out[f"{i}/coords"] = np.array(it.op.coords, dtype=float)       # names the nodes (any partition)
        if self._state is not None:
            out["converged"] = np.array(self.converged)
        return out

    def restore(self, ndof: int, state: dict) -> None:
        """Start the next solve from a state of :meth:`capture` (``ndof``: the size of the displacement vector X),
        as the solve after the captured one would in an uninterrupted run."""
        items = [(key.split("/", 1), val) for key, val in state.items() if key.split("/", 1)[0].isdigit()]
        if items:
            ifs = self.interfaces(ndof)
            order = {i: node_permutation(state[f"{i}/coords"], it.op.coords) for i, it in enumerate(ifs)
                     if f"{i}/coords" in state}
            for (i, key), val in items:
                cur = getattr(ifs[int(i)], key, None) if int(i) < len(ifs) else None
                perm = order.get(int(i))
                if perm is not None and key != "coords":      # written on another partition: its node order
                    val = np.take(np.asarray(val), perm, axis=1 if key == "dropped" else 0)
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
        last_newton = math.inf
        for it_nr in range(1, self.maxit + 1):
            b = assemble_rows(s, x, penalty)
            step = steps.step(s, b, it_nr)
            x, held, xv, r = self._newton_step(s, steps, step, b, x, it_nr)
            if not held:
                penalty = self._unheld_sets(s, steps, b, x, xv, r, it_nr, penalty)
                continue
            changes, newton = new_sets(s, x, lam_n, lam_t, penalty, it_nr)
            if changes == 0:
                if penalty and self.method == "ssn":
                    penalty = False
                    info.penalty_iterations = it_nr
                    continue
                if newton <= newton_tol or (newton <= ROUNDOFF_TOL and newton > 0.5 * last_newton):
                    break           # converged, or at the round-off floor of the slip rows (no longer falling)
                last_newton = newton
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
            # the Krylov path and its scipy.sparse.linalg load when it runs (start-up of the direct path)
            from .krylov import near_null_space

            self._modes = near_null_space(self.forms)
        return self._modes

    def _system(self, matrix, rhs, free: np.ndarray, n: int, ifs: list[InterfaceState], steps,
                where: str) -> NewtonSystem:
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
        u_floor = 0.0
        if len(reg_dofs):
            k_mean = float(np.mean(np.abs(steps.diagonal(matrix, n, kr, kc, kv)[reg_dofs])))
            eps = steps.shift * k_mean
            u_floor = U_FLOOR * float(np.linalg.norm(f)) / max(k_mean, 1e-300)
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
        s.u_floor = u_floor
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
            ra = exact_residual(s, xv, r)
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
            if float(np.linalg.norm(d)) <= 1e-6 * max(float(np.linalg.norm(xv.FV().NumPy()[:n])), s.u_floor, 1e-300):
                if not s.rigid.shape[1]:
                    break
                # the shift leaves a residual eps u along the rigid motions (eps x translation x dofs: 0.5 N
                # of a 2.5 kN load on a weak Coulomb interface); refine while that falls
                balance = rigid_balance(s, b, xv, r)
                if balance <= 1e-10 * balance_scale(s, b, xv) or balance > 0.5 * last_balance:
                    break
                last_balance = balance
        else:
            held = False
        if held and s.rigid.shape[1]:   # the loaded rigid motions must be balanced by the contact forces
            held = rigid_balance(s, b, xv, r) <= 1e-8 * balance_scale(s, b, xv)
        check_finite(xv, f"{s.what}, iteration {it_nr}")
        return fixed_multipliers(s, np.array(xv.FV().NumPy())), held, xv, r

    def _unheld_sets(self, s: NewtonSystem, steps, b: np.ndarray, x: np.ndarray, xv, r, it_nr: int,
                     penalty: bool) -> bool:
        """New sets when the current ones leave a floating body free along a loaded rigid motion: every node
        slipping while the friction cannot balance the load (retry with the active nodes sticking, or walk the
        slip directions, :func:`.floating.walk_slip`), or too few nodes in contact (e.g. the single first node of a
        curved side: add the nearest open nodes). Returns whether the penalty phase goes on."""
        ifs, info, n = s.ifs, s.info, s.n
        if not s.rigid.shape[1]:
            raise SolverError(f"{s.what}, iteration {it_nr}: the refinement of the Newton step did not converge: the "
                              "saddle-point matrix is singular or badly conditioned (no floating body); check the "
                              "supports next to the contacts")
        info.unheld_sets += 1
        grow = all(not (it.slip & it.active).any() for it in ifs)
        if info.unheld_sets > 3 or (grow and not any((it.keep & ~it.active).any() for it in ifs)):
            ra = exact_residual(s, xv, r)
            raise SolverError(f"{s.what}, iteration {it_nr}: "
                              + unheld_reason(self.floating, ifs, s.rigid, (b - ra)[:n] * s.free, s.f, n))
        walked = False
        if not grow and s.rigid.shape[1] and not any(it.dim3 for it in ifs):
            # every active node slips and their friction does not balance the load: move the points where
            # the slip direction turns until it does (sticking all nodes instead threw the sets back to
            # the start: they cycled, e.g. a block spreading under its load on a weak interface)
            walked = walk_slip(s, b, x, xv, r)
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

    def check_load(self, ifs: list[InterfaceState], f: np.ndarray, where: str) -> None:
        """Stop with a SolverError naming the body and the rigid motion when no admissible contact forces
        balance the load on the free rigid motions of the floating bodies (:func:`.floating.check_load`)."""
        check_load(self.floating, ifs, f, where)


class PenaltyContactSolver(ContactSolver):
    """The penalty method: the iteration of :class:`ContactSolver` with the penalty rows (lam_n = c x penetration,
    lam_t = c_t x stick slip) kept to the end on every interface (``method="penalty"``)."""

    def __init__(self, interfaces: list[tuple[ContactOperator, ContactLaw]], *, modulus: float, floating=(),
                 forms=None, options: ContactOptions | None = None, **settings):
        super().__init__(interfaces, modulus=modulus, floating=floating, forms=forms, options=options,
                         **{**settings, "method": "penalty"})


def nodal_modulus(props) -> float:
    """A modulus scale (Pa) for the default augmentation: the largest diagonal entry of the stiffnesses. Varying
    elastic data enter with their representative stiffness, that of the stiffest of the region's sample points
    (:func:`~ngs_geomech.mechanics.materials.varying_elastic_properties`): the largest over the region."""
    return max(float(np.max(np.diag(p.C))) for p in props.values())

