"""Preconditioned conjugate gradients for the SPD systems of heat conduction and elasticity, watched: a relative
tolerance, the iteration count reported, and a SolverError naming the solve on divergence, stagnation, an
indefinite matrix or preconditioner, or the iteration limit. The CG iteration is NGSolve's
(``ngsolve.krylovspace.CGSolver``: NGSolve vectors and operators, serial and distributed); :class:`PCG` adds the
watch. The project's other Krylov solves are NGSolve's GMRES on NGSolve vectors (the Stefan Newton steps, the k(T)
heat Newton steps on distributed meshes) and scipy's GMRES on numpy vectors (the contact Newton steps).

Preconditioners (NGSolve's, registered on the bilinear form before it is assembled, so they see the element
matrices):

* order 2, vector (elasticity) in 3D, serial: a **two-level AMG** preconditioner
  (:meth:`Preconditioned._two_level_mat`): Jacobi on the edge dofs plus, on the P1 part (the vertex dofs of
  NGSolve's hierarchical basis), the displacement decomposition of the P1 case (one ``h1amg`` per component).
  Nothing is factored but AMG's coarsest level. Measured (``studies/scaling`` box, 2 threads): 98 / 100 / 105 /
  111 / 114 iterations to 1e-10 at 15k / 58k / 213k / 432k / 1.53M heat + elastic dofs; at 1.15M elastic dofs
  the elastic solve took 51 s against 118 s with BDDC, whose coarse problem (the P1 vertex problem, factored
  directly) grew like dofs^1.7.
* order >= 2 otherwise (scalar heat, 2D, order >= 3, distributed meshes): NGSolve's element-wise BDDC with the
  **vertex** wirebasket. NGSolve's H1 space puts the lowest-order edge dofs into the wirebasket in 3D
  (``wb_withedges``), which for P2 makes the BDDC coarse problem the whole system (2 iterations, the cost of a
  direct solve): the edge dofs are set to interface dofs here, so the coarse problem is the P1 (vertex) problem,
  and the edge and higher dofs are eliminated element by element. The condition number then depends on the order
  only (measured, 3D P2: heat 32 / 36 / 40 iterations to 1e-10 at 8k / 51k / 377k dofs; elasticity 80 / 97 at
  24k / 154k). In 3D on one process the scalar vertex problem is solved by ``h1amg`` (``coarsetype="h1amg"``:
  32 -> 34 iterations at 382k dofs, and no superlinear coarse factorization); elsewhere it is factored.
* order 1, scalar (heat): NGSolve's algebraic multigrid ``h1amg`` (12 / 15 / 18 iterations at 1k / 7k / 50k
  dofs in 3D).
* order 1, vector (elasticity): the displacement-decomposition preconditioner, one ``h1amg`` per displacement
  component on a scalar form mu-weighted like the elastic one (Korn: the constant depends on the Poisson ratio and
  the supports, not on h).

``choose_solver`` resolves ``solver="auto"``: direct below :data:`AUTO_DOFS` (per dimension), iterative above.
Only systems with an SPD matrix and no Lagrange multipliers take the CG path here; the contact Newton steps (saddle
points with the contact multipliers) take GMRES with the augmented-Lagrangian AMG preconditioner of
:mod:`ngs_geomech.contact.krylov` when ``choose_solver`` says iterative; the other saddle-point systems (oblique
symmetry multipliers, mixed pressures, the mortar coupling of heat across contact interfaces) and the unsymmetric
Newton matrices (k(T) heat, the primal-dual elastic tangent) stay direct in serial runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from .choices import PRECONDITIONERS, SOLVERS


def petsc_available() -> bool:
    """Whether PETSc's GAMG (:mod:`.petsc`, petsc4py) can be used; "auto" takes it on distributed meshes."""
    from .petsc import available

    return available()

AUTO_DOFS = {2: 1_000_000, 3: 60_000}
"""Dofs above which ``solver="auto"`` takes preconditioned CG (per mesh dimension, per system). Measured
(``studies/scaling``, 3D P2 thermo-elastic box, 2 threads): CG (two-level AMG for elasticity, BDDC
for heat) was faster than the direct solvers at every size, 0.12 / 0.23 / 0.38 / 1.40 s against 0.18 / 0.44 /
0.68 / 5.85 s at 2.5k / 9.9k / 15k / 58k total dofs (UMFPACK on elasticity 1.1 GiB at 58k). The 3D value is
conservative on purpose: it keeps the small scenes on the exact, bit-for-bit reproducible direct path, where the
difference is a fraction of a second. In 2D sparse Cholesky stays cheap (fill ~ N log N) and the value is a guess,
not a measurement."""

DEFAULT_TOL = 1e-10
"""Relative residual (preconditioned norm) at which CG stops; see :class:`PCG`."""

STALL_ITERATIONS = 100
"""CG stops as stagnated when the residual has not fallen below 0.9 times its best value for this many iterations."""

DIVERGENCE_FACTOR = 1e8
"""CG stops as diverged when the residual exceeds this factor times its reference."""


def choose_solver(solver: str, ndof: int, dim: int, spd: bool = True, distributed: bool = False,
                  auto_dofs: dict | None = None) -> str:
    """'direct' or 'iterative' for ``solver`` in :data:`SOLVERS`: 'auto' is iterative above ``AUTO_DOFS[dim]``
    dofs (or ``auto_dofs[dim]``); a system that is not SPD (or has multipliers) is always direct, except on a
    distributed mesh, where everything is iterative (the caller solves a nonsymmetric system by GMRES)."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if distributed:
        if solver == "direct":
            raise ValueError("solver 'direct' is not available on a distributed mesh (use 'auto' or 'iterative')")
        return "iterative"
    if not spd:
        return "direct"
    if solver == "auto":
        table = auto_dofs or AUTO_DOFS
        return "iterative" if ndof > table.get(dim, table[3]) else "direct"
    return solver


def vertex_dofs(space, what: str) -> np.ndarray:
    """The dof numbers (components x nv) of the vertex dofs of a VectorH1 ``space``: NGSolve numbers each
    component's dofs vertices first, so vertex i of component k is dof offset_k + i (checked on a sample; ``what``
    names the caller in the error). With the hierarchical basis these dofs span P1."""
    nv = space.mesh.nv
    offsets = np.cumsum([0] + [c.ndof for c in space.components])
    for comp in space.components:
        for i in (0, nv // 2, nv - 1):
            if tuple(comp.GetDofNrs(ngs.NodeId(ngs.VERTEX, i))) != (i,):
                raise AssertionError(f"{what}: the vertex dofs are not numbered first")
    return offsets[:-1, None] + np.arange(nv)[None, :]


def vertex_wirebasket(space) -> int:
    """Make the vertex dofs the only wirebasket dofs of an H1 / VectorH1 ``space`` (NGSolve's 3D default adds the
    lowest-order edge dofs): the BDDC coarse problem becomes the vertex (P1) problem. Returns the number of edge
    dofs set to interface dofs. Touches only coupling types (used by BDDC and static condensation), so direct
    solvers are unaffected.

    NGSolve numbers an H1 component's dofs vertices first, then the p - 1 dofs of each edge in edge order, so the
    edge dofs of a component are one range (checked on the first and last edge; otherwise edge by edge): a
    Python loop over the edges took 1.8 s of a 3.6 s heat solve at 108k dofs."""
    wb, iface = ngs.COUPLING_TYPE.WIREBASKET_DOF, ngs.COUPLING_TYPE.INTERFACE_DOF
    mesh = space.mesh
    comps = list(space.components) if isinstance(space, ngs.comp.ProductSpace) else [space]
    offset, moved = 0, 0
    for comp in comps:
        first = comp.GetDofNrs(ngs.NodeId(ngs.EDGE, 0)) if mesh.nedge else ()
        per_edge = len(first)
        last = comp.GetDofNrs(ngs.NodeId(ngs.EDGE, mesh.nedge - 1)) if mesh.nedge else ()
        start = mesh.nv
        ranged = (per_edge > 0 and tuple(first) == tuple(range(start, start + per_edge))
                  and tuple(last) == tuple(range(start + per_edge * (mesh.nedge - 1), start + per_edge * mesh.nedge)))
        if ranged:
            lo, hi = offset + start, offset + start + per_edge * mesh.nedge
            moved += hi - lo
            space.SetCouplingType(ngs.IntRange(lo, hi), iface)
        else:
            for e in mesh.edges:
                for d in comp.GetDofNrs(e):
                    if d >= 0 and space.CouplingType(offset + d) == wb:
                        space.SetCouplingType(offset + d, iface)
                    moved += d >= 0
        offset += comp.ndof
    return moved


@dataclass
class CGInfo:
    """One CG solve: iterations, the final relative residual (preconditioned norm) and its history."""

    iterations: int
    residual: float
    history: list


class Preconditioned:
    """A preconditioner registered on ``form`` (a BilinearForm on ``space``, SPD after assembly), chosen by the
    space's order and value dimension (module docstring). Create it before ``form.Assemble()``; it is rebuilt with
    every assembly (and linearization) of ``form``. ``scale`` (a CF, Pa) weights the displacement-decomposition
    form of P1 elasticity; ``weight`` (the axisymmetric r, or 1) multiplies it."""

    def __init__(self, form, space, order: int, vector: bool, scale=None, weight=None, dirichlet=None,
                 choice: str = "auto"):
        """``dirichlet``: per displacement component the boundary regex of its fixed values (what the space was
        built with); with it a 3D P2 vector space, when not distributed, gets the two-level preconditioner.
        ``choice`` in :data:`PRECONDITIONERS` ("bddc" needs order >= 2)."""
        if choice not in PRECONDITIONERS:
            raise ValueError(f"preconditioner must be one of {PRECONDITIONERS}, got {choice!r}")
        distributed = space.mesh.comm.size > 1
        if choice == "bddc" and order < 2 and not distributed:
            raise ValueError("the BDDC preconditioner needs elements of order >= 2 (P1 has no interface dofs)")
        self.kind = ""
        self.form = form
        self._aux = []
        self._scale = scale if scale is not None else ngs.CoefficientFunction(1.0)
        self._weight = weight if weight is not None else ngs.CoefficientFunction(1.0)
        self._space = space
        self._two_level = None
        self._p1 = None
        # BDDC with its vertex problem factored: asked for, or on a distributed mesh (the two-level injection and
        # h1amg of the vertex problem are serial)
        self._vector = vector
        self._gamg = None
        bddc_only = distributed or choice == "bddc"
        if choice == "gamg" or (choice == "auto" and distributed and petsc_available()):
            self.kind = "gamg"          # PETSc's CG with GAMG (:mod:`.petsc`): nothing registered on the form
            self.pre = None
        elif order == 2 and vector and space.mesh.dim == 3 and dirichlet is not None and not bddc_only:
            self.kind = "two_level_amg"
            self.pre = None
            self._dirichlet = list(dirichlet)
        elif order == 1 and distributed:
            # P1 has no interface dofs: BDDC's coarse problem is the whole (gathered, factored) problem, so CG takes
            # one or two iterations; h1amg is serial
            self.pre = ngs.Preconditioner(form, "bddc")
            self.kind = "bddc_p1"
        elif order >= 2:
            vertex_wirebasket(space)
            if not vector and space.mesh.dim == 3 and not bddc_only:
                # the vertex problem by AMG (scalar: h1amg is made for it): same iterations (32 / 34 at 382k
                # dofs), no superlinear coarse factorization
                self.pre = ngs.Preconditioner(form, "bddc", coarsetype="h1amg")
                self.kind = "bddc_h1amg"
            else:
                self.pre = ngs.Preconditioner(form, "bddc")
                self.kind = "bddc"
        elif not vector:
            self.pre = ngs.Preconditioner(form, "h1amg")
            self.kind = "h1amg"
        else:
            self.kind = "h1amg_per_component"
            self.pre = None

    def cg(self, pcg: PCG, mat, rhs, x, what: str, hint: str = "") -> CGInfo:
        """Solve ``mat`` x = ``rhs`` by CG with this preconditioner: ``pcg`` (its tolerance and iteration limit) with
        :attr:`mat`, or PETSc's CG with GAMG (:class:`.petsc.GamgCG`)."""
        if self.kind != "gamg":
            return pcg.solve(mat, self.mat, rhs, x, what, hint)
        if self._gamg is None:
            from .petsc import GamgCG

            self._gamg = GamgCG(self._space, self._vector, pcg.tol, pcg.maxit)
        return CGInfo(*self._gamg.solve(mat, rhs, x, what, hint))

    @property
    def mat(self):
        if self.pre is not None:
            return self.pre.mat
        if self.kind == "two_level_amg":
            return self._two_level_mat()
        return self._component_mat()

    def update(self) -> None:
        """After an assembly of the form: rebuild the auxiliary component forms (P1 elasticity and the P1 part of
        the two-level preconditioner: the coefficients may have changed) and the Jacobi part of the two-level
        preconditioner (the matrix's diagonal)."""
        if self._gamg is not None:
            self._gamg.update()
        if self.pre is None:
            self._aux = []
            self._two_level = None

    def _two_level_mat(self):
        """3D P2 elasticity: C = D_E^-1 + sum_k E_k A_k^-1 E_k^T. NGSolve's H1 basis is hierarchical (the vertex
        functions of P2 are the P1 hat functions), so the P1 space is the span of the vertex dofs: E_k injects the
        P1 dofs of component k into them, and A_k^-1 is one h1amg cycle on the P1 form scale x weight x grad u .
        grad v with component k's Dirichlet boundaries (the displacement decomposition of the P1 case); D_E is the
        diagonal of the P2 matrix on the free edge dofs (Jacobi). The two-level splitting of P2 into P1 and
        the edge bubbles is stable uniformly in h, so the condition number does not grow under refinement, and
        nothing is factored but AMG's small coarsest level: the cost per iteration is linear in the dofs
        (measured: the module docstring). The P1 spaces, injections and the edge-dof mask are built once; an
        :meth:`update` re-assembles the P1 forms and re-reads the diagonal."""
        if self._two_level is not None:
            return self._two_level
        space, mesh = self._space, self._space.mesh
        if self._p1 is None:          # the P1 spaces, injections and edge-dof mask: fixed for the space
            nv = mesh.nv
            vdofs = vertex_dofs(space, "two-level preconditioner")
            free = np.array(list(space.FreeDofs()), dtype=bool)
            self._p1 = []
            for k in range(len(space.components)):
                p1 = ngs.H1(mesh, order=1, dirichlet=self._dirichlet[k])
                E = ngs.la.SparseMatrixd.CreateFromCOO(vdofs[k], np.arange(nv), np.ones(nv), space.ndof, p1.ndof)
                self._p1.append((p1, E))
                free[vdofs[k]] = False          # the vertex dofs belong to the P1 part
            self._edges = ngs.BitArray(free.tolist())
        if not self._aux:
            self._aux = [self._amg(p1, symmetric=True) for p1, _ in self._p1]
        coarse = None
        for (_, E), (_, pre) in zip(self._p1, self._aux):
            term = E @ pre.mat @ E.T
            coarse = term if coarse is None else coarse + term
        self._two_level = coarse + self.form.mat.CreateSmoother(self._edges)
        return self._two_level

    def _amg(self, space, symmetric: bool = False):
        """The scalar form scale x weight x grad u . grad v on ``space``, assembled, and its h1amg: a component
        operator of the displacement decomposition. Returns (form, preconditioner)."""
        u, v = space.TnT()
        a = ngs.BilinearForm(space, symmetric=symmetric)
        a += self._weight * self._scale * ngs.grad(u) * ngs.grad(v) * ngs.dx
        pre = ngs.Preconditioner(a, "h1amg")
        a.Assemble()
        return a, pre

    def _component_mat(self):
        if not self._aux:
            space = self._space
            total = None
            for k in range(len(space.components)):
                a, pre = self._amg(space.components[k])
                emb = space.Embedding(k)
                term = emb @ pre.mat @ emb.T
                total = term if total is None else total + term
                self._aux.append((a, pre))
            self._mat = total
        return self._mat


class _Checked(ngs.BaseMatrix):
    """``op`` (an NGSolve operator) applied unchanged, with ``check(call, <x, op x>)`` after each application
    (``call`` counts from 0): how :class:`PCG` sees the signs CG needs positive, the matrix on the search
    directions and the preconditioner on the residuals, which NGSolve's CG does not report."""

    def __init__(self, op, check):
        super().__init__()
        self.op = op
        self.check = check
        self.calls = 0

    def IsComplex(self) -> bool:
        return False

    def Height(self) -> int:
        return self.op.height

    def Width(self) -> int:
        return self.op.width

    def CreateRowVector(self):
        return self.op.CreateRowVector()

    def CreateColVector(self):
        return self.op.CreateColVector()

    def Mult(self, x, y) -> None:
        y.data = self.op * x
        self.check(self.calls, float(ngs.InnerProduct(x, y)))
        self.calls += 1


class PCG:
    """Preconditioned conjugate gradients (NGSolve's ``krylovspace.CGSolver``) on ``mat`` with ``pre`` (both
    NGSolve operators, serial or distributed; pre zero on the fixed dofs), watched.

    The solve updates x (its Dirichlet values are kept: the preconditioner does not touch fixed dofs). Convergence:
    sqrt(<r, C r>) <= tol * ref, where ref is the largest of the same norm of the right-hand side, of mat x and of
    the first residual (the forces the residual is measured against, as in :func:`~.linear.solve_watched`).
    SolverError naming ``what`` when <p, A p> <= 0 (the matrix is not positive definite: a rigid motion, a
    negative coefficient), <r, C r> < 0 (the preconditioner is not positive definite), the residual is not finite
    or grows beyond :data:`DIVERGENCE_FACTOR` times ref, it does not fall below 0.9 times its best for
    :data:`STALL_ITERATIONS` iterations (stagnation), or ``maxit`` iterations pass."""

    def __init__(self, tol: float = DEFAULT_TOL, maxit: int = 2000, stall: int = STALL_ITERATIONS):
        if not (tol > 0 and math.isfinite(tol)):
            raise ValueError(f"tol must be positive, got {tol}")
        self.tol = tol
        self.maxit = maxit
        self.stall = stall

    def solve(self, mat, pre, rhs, x, what: str, hint: str = "") -> CGInfo:
        hint = f" {hint}" if hint else ""
        z, ax = rhs.CreateVector(), rhs.CreateVector()

        def pnorm(vec) -> float:
            z.data = pre * vec
            return math.sqrt(max(float(ngs.InnerProduct(vec, z)), 0.0))

        ax.data = mat * x
        ref0 = max(pnorm(rhs), pnorm(ax))

        def check_matrix(call: int, pap: float) -> None:
            if call > 0 and not pap > 0:      # call 0: mat x of the first residual
                raise SolverError(f"{what}: CG found <p, A p> = {pap:.3e} <= 0 in iteration {call}: the matrix is "
                                  f"not positive definite (a rigid motion without supports, a negative or zero "
                                  f"coefficient).{hint}")

        def check_pre(call: int, rz: float) -> None:
            if not math.isfinite(rz):
                raise SolverError(f"{what}: the preconditioned residual is not finite before the first CG iteration "
                                  f"(singular preconditioner: a body without supports?).{hint}" if call == 0 else
                                  f"{what}: CG diverged (the residual is not finite in iteration {call}).{hint}")
            if rz < 0:
                where = f" in iteration {call}" if call else ""
                raise SolverError(f"{what}: the preconditioner is not positive definite (<r, C r> = {rz:.3e}"
                                  f"{where}).{hint}")

        best = [math.inf, 0]                # the best residual and its iteration (stagnation)

        def watch(it: int, err: float) -> None:
            it -= 1                          # NGSolve counts the first residual as an iteration
            ref = max(ref0, cg.residuals[0])
            if err <= self.tol * ref:
                return
            if err > DIVERGENCE_FACTOR * ref:
                raise SolverError(f"{what}: CG diverged: relative residual {err / ref:.3e} after {it} iterations."
                                  f"{hint}")
            if it == 1:
                best[:] = [cg.residuals[0], 0]
            if err < 0.9 * best[0]:
                best[:] = [err, it]
            elif it - best[1] >= self.stall:
                raise SolverError(f"{what}: CG stagnated at relative residual {best[0] / ref:.3e} (tolerance "
                                  f"{self.tol:.1e}; no progress in {self.stall} iterations after iteration "
                                  f"{best[1]}).{hint}")

        # the stopping test max(tol * first residual, atol) = tol * ref
        cg = ngs.krylovspace.CGSolver(_Checked(mat, check_matrix), _Checked(pre, check_pre), tol=self.tol,
                                      atol=self.tol * ref0, maxiter=self.maxit + 1, callback=watch)
        cg.Solve(rhs=rhs, sol=x, initialize=False)
        ref = max(ref0, cg.residuals[0])
        history = [r / ref if ref > 0 else 0.0 for r in cg.residuals]
        iterations = len(history) - 1
        if not cg.residuals[-1] <= self.tol * ref:
            raise SolverError(f"{what}: CG did not converge in {iterations} iterations (relative residual "
                              f"{history[-1]:.3e}, tolerance {self.tol:.1e}).{hint}")
        return CGInfo(iterations, history[-1], history)
