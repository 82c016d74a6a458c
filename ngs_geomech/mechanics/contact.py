"""Problem (P) with contact, (2.17)-(2.27): the elastic forms (thermal stresses, loads, the lambda law) with
the contact conditions of :class:`ngs_geomech.contact.solver.ContactSolver` on every contact interface and
rigid foundation.

Linear materials (lam = 1): one contact solve with the elastic matrix. The lambda law: the secant modules
method (2.32)-(2.34) as the outer loop, each iteration a contact solve with the coefficients c* frozen at
u_n (the contact solver keeps its active and stick sets from the previous iteration, so later iterations
take 2-3 active-set steps), u_{n+1} = u_n + w (u~_{n+1} - u_n) with the relaxation w = min(1, 1/lam_max)
(or mechanics.secant_relaxation when <= 1): a step w <= 1 is a convex combination of two admissible
displacements, so it stays admissible (non-penetrating); the energy line search of the contact-free solver
is not used here because the constrained energy is not smooth along the direction. The plain iteration
contracts at ~2 |1 - lam| (lam < 1), w = 1/lam at |1 - lam| / lam (lam > 1). Stops when the relative H1
change (2.35) < tol.

A time-dependent scene (temperature history) solves a static contact problem at each mechanics time (the
seed's (P) is static): the slip is the total slip from the reference configuration, not an increment.
"""

from __future__ import annotations

import math
import time

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from .. import parallel
from ..contact.solver import ContactSolver
from ..errors import SolverError
from ..fem.normals import outward_normal
from .forms import ElasticForms
from .solver import ElasticSolver, Linearized, NonlinearInfo, h1_norm


class ElasticContactSolver:
    """Drives :class:`ElasticForms` and a :class:`ContactSolver`; same ``solve(where)`` interface, history
    and factorization count as :class:`ElasticSolver`. Contact histories per solve in ``contact_infos``."""

    def __init__(self, forms: ElasticForms, contact: ContactSolver, *, tol: float = 1e-8, maxit: int = 100,
                 relaxation: float | None = None, insitu: InSituTraction | None = None):
        if relaxation is not None and not 0 < relaxation <= 1:
            raise ValueError(f"the secant relaxation with contact must be in (0, 1], got {relaxation}")
        self.f = forms
        self.contact = contact
        self.insitu = insitu
        """The exact transfer of the initial stress's interface traction (added to every contact solve's load)."""
        self._correction = None
        self.tol = tol
        self.maxit = maxit
        lam_max = max(p.lam for p in forms.setup.props.values())
        self.relaxation = relaxation if relaxation is not None else min(1.0, 1.0 / lam_max)
        self._dirichlet = ElasticSolver(forms, method="secant")      # its Dirichlet handling only
        # a distributed mesh: the contact solve runs on global arrays (contact.distributed), numbered by dofs
        self.dofs = parallel.GlobalDofs(forms.X) if parallel.distributed(forms.mesh) else None
        self._free = self.array(np.array(list(forms.X.FreeDofs()), dtype=float)) > 0.5
        self.method = "secant" if forms.setup.nonlinear else "linear"
        self.history: list[NonlinearInfo] = []
        self.contact_infos: list[list] = []

    @property
    def factorizations(self) -> int:
        return sum(i.factorizations for infos in self.contact_infos for i in infos)

    def array(self, local: np.ndarray, cumulated: bool = True) -> np.ndarray:
        """A vector of X as the contact solve sees it: the local array itself, or on a distributed mesh the global
        array (:class:`~ngs_geomech.parallel.GlobalDofs`; ``cumulated`` as there)."""
        return local if self.dofs is None else self.dofs.gather(local, cumulated)

    @property
    def free(self) -> np.ndarray:
        """The free dofs of X (bool; global on a distributed mesh)."""
        return self._free

    def displacement(self) -> np.ndarray:
        """The displacement vector of X (global on a distributed mesh)."""
        return self.array(np.array(self.f.gf.vec.FV().NumPy()))

    def stiffness_times_displacement(self) -> np.ndarray:
        """K u with the matrix of the last contact solve (N; global on a distributed mesh)."""
        ku = self.f.gf.vec.CreateVector()
        ku.data = self.f.secant_form.mat * self.f.gf.vec
        return self.array(np.array(ku.FV().NumPy()), cumulated=False)

    def load(self) -> np.ndarray:
        """The load of the last contact solve (N, a vector of X; global on a distributed mesh): the assembled load
        and the in-situ correction."""
        rhs = self.array(np.array(self.f.secant_rhs.vec.FV().NumPy()), cumulated=False)
        return rhs if self._correction is None else rhs + self._correction

    def _contact_solve(self, where: str, infos: list) -> None:
        """U <- the contact solution with the current secant matrix and load (Dirichlet values kept)."""
        f = self.f
        f.secant_form.Assemble()
        f.secant_rhs.Assemble()
        x0 = self.displacement()
        if self.insitu is not None:
            self._correction = self.insitu.load(len(x0))
        matrix = f.secant_form.mat
        if self.dofs is not None:         # (PETSc and the Krylov path load only for distributed runs)
            from ..contact.distributed import DistributedBulk

            matrix = DistributedBulk(matrix, self.dofs)
        u, info = self.contact.solve(matrix, self.load(), self._free, x0, where)
        f.gf.vec.FV().NumPy()[:] = u if self.dofs is None else self.dofs.local(u)
        infos.append(info)

    def solve(self, where: str) -> NonlinearInfo:
        """Solve at the current time (f.t set; temperature CF up to date)."""
        tic = time.perf_counter()
        f = self.f
        self._dirichlet.set_dirichlet()
        infos: list = []
        self.contact_infos.append(infos)
        if not f.setup.nonlinear:
            f.u_frozen.vec[:] = 0.0
            self._contact_solve(where, infos)
            info = NonlinearInfo("linear", 1)
        else:
            info = self._secant(where, infos)
        info.wall_s = time.perf_counter() - tic
        self.history.append(info)
        return info

    def _secant(self, where: str, infos: list) -> NonlinearInfo:
        f = self.f
        info = NonlinearInfo("secant")
        with Linearized(f):
            self._contact_solve(where, infos)
        x = f.gf.vec
        prev = x.CreateVector()
        du = ngs.GridFunction(f.X)
        w = self.relaxation
        for it in range(1, self.maxit + 1):
            prev.data = x
            f.u_frozen.vec.data = f.displacement().vec
            self._contact_solve(f"{where}, secant iteration {it}", infos)
            if w != 1.0:              # (not x.data = (1 - w) prev + w x: NGSolve assigns term by term, x aliased)
                x.data *= w
                x.data += (1.0 - w) * prev
            du.vec.data = x - prev
            d = f.displacement(du)
            change = h1_norm(d, f.mesh) / max(h1_norm(f.displacement(), f.mesh), 1e-300)
            info.steps.append(w)
            info.changes.append(change)
            info.iterations = it
            if change < self.tol:
                return info
            if not math.isfinite(change) or (it > 5 and change > 1e3 * info.changes[0]):
                break
        raise SolverError(f"secant modules method with contact at {where} did not converge in {info.iterations} "
                          f"iterations (last relative H1 change {info.changes[-1]:.3e}); try a smaller "
                          "mechanics.secant_relaxation, more max_iterations or a larger regularization")


class InSituTraction:
    """The exact transfer of the initial stress's traction across the contact interfaces.

    An initial stress sigma0 in equilibrium with gravity and the boundary loads (div sigma0 + rho g = 0, the
    in-situ state of (2.18)) loads the bodies at u = 0 with their interface tractions only: the load is
    f = -F, F(v) = int_S w sigma0 n_S . v ds + int_O w sigma0 n_O . v ds (N; n outward of each body, w the
    axisymmetric weight). The contact solve K u - B^T lam = f (:class:`ContactSolver`) carries the side S's part
    exactly (the dual multipliers are biorthogonal to S's nodal basis), but transmits to the opposite side O only
    M^T lam, which reproduces a traction constant along the interface and leaves an O(h^2) load where it varies,
    e.g. the lithostatic pressure rho g depth on a dipping fault: the in-situ state would move at t = 0.

    The correction c = F - B^T lam_ref (N), lam_ref the multipliers that fit F on S's dofs (least squares over
    the nodes the solver constrains), is added to the contact solve's load: u = 0, lam = lam_ref then solve the
    contact problem of an equilibrated initial stress exactly, the in-situ traction crosses the interface exactly,
    and the mortar transfers what the loads add to it. At nodes the solver does not constrain (not fully covered
    by the opposite side) c holds S's in-situ traction as a load. Rigid foundations have no side O: their S side
    is exact without a correction."""

    def __init__(self, forms, ops: list):
        """``ops``: the interfaces' :class:`ContactOperator` (each with an opposite side; on a distributed mesh in the
        global numbering of :class:`~ngs_geomech.parallel.GlobalDofs`, and so are the arrays here)."""
        self.forms = forms
        self.ops = ops
        self.dofs = parallel.GlobalDofs(forms.V) if parallel.distributed(forms.mesh) else None
        self.fits = [self._fit(op) for op in ops]
        self.normals: dict = {}
        self._last: tuple | None = None        # (time, c) of the last load
        self.multipliers: list[np.ndarray] = []
        """lam_ref of each interface at the last :meth:`load` (the blocks of B's rows: normal, t1 (, t2))."""

    def _fit(self, op) -> tuple:
        """(B, S's dofs, B on S's dofs, the factorized normal equations) of interface ``op``."""
        k = op.constrained
        B = sp.vstack([M[k] for M in (op.Bn, op.Bt, op.Bt2) if M is not None]).tocsr()
        sdofs = np.array(list(self.forms.V.GetDofs(self.forms.mesh.Boundaries(op.side))), dtype=bool)
        if self.dofs is not None:         # a dof of S on any rank's elements
            sdofs = self.dofs.gather(sdofs.astype(float), cumulated=False) > 0.5
        Bs = B[:, sdofs]
        # loaded with an initial stress only (start-up)
        import scipy.sparse.linalg as spla

        solve = spla.factorized((Bs @ Bs.T).tocsc()) if B.shape[0] else None
        return B, sdofs, Bs, solve

    @classmethod
    def of(cls, forms, specs) -> InSituTraction | None:
        """The correction of a scene's contacts (``specs``: :class:`ngs_geomech.contact.problem.ContactSpec`), None
        without an initial stress or without an interface between two bodies."""
        ops = [s.op for s in specs if s.kind == "interface"]
        if forms.setup.initial_stress is None or not ops:
            return None
        return cls(forms, ops)

    def tractions(self) -> list[np.ndarray]:
        """F of each interface at the current time (N, a vector of V): sigma0 n tested on both sides."""
        f = self.forms
        sigma0 = f.initial_stress_tensor()
        v = f.V.TestFunction()
        out = []
        for op in self.ops:
            lf = ngs.LinearForm(f.V)
            for side in (op.side, op.opposite):
                n = self.normals.setdefault(side, outward_normal(f.mesh, side))
                lf += f.weight * ((sigma0 * n) * v) * ngs.ds(definedon=f.mesh.Boundaries(side),
                                                            intrules=f.bnd_intrules)
            lf.Assemble()
            local = np.array(lf.vec.FV().NumPy())
            out.append(local if self.dofs is None else self.dofs.gather(local, cumulated=False))
        return out

    def load(self, ndof: int) -> np.ndarray:
        """C (N) at the current time as a vector of the solve's space X (``ndof``; V's dofs first); kept for the
        solves at the same time (the secant iterations, the coupling passes)."""
        t = float(self.forms.t.Get())
        if self._last is not None and self._last[0] == t and len(self._last[1]) == ndof:
            return self._last[1]
        c = np.zeros(ndof)
        self.multipliers = []
        for (B, sdofs, Bs, solve), F in zip(self.fits, self.tractions()):
            lam = solve(Bs @ F[sdofs]) if solve is not None else np.zeros(0)
            c[:B.shape[1]] += F - B.T @ lam
            self.multipliers.append(lam)
        self._last = (t, c)
        return c
