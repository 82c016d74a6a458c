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

from ..contact.solver import ContactSolver
from ..errors import SolverError
from .forms import ElasticForms
from .solver import ElasticSolver, Linearized, NonlinearInfo, h1_norm


class ElasticContactSolver:
    """Drives :class:`ElasticForms` and a :class:`ContactSolver`; same ``solve(where)`` interface, history
    and factorization count as :class:`ElasticSolver`. Contact histories per solve in ``contact_infos``."""

    def __init__(self, forms: ElasticForms, contact: ContactSolver, *, tol: float = 1e-8, maxit: int = 100,
                 relaxation: float | None = None):
        if relaxation is not None and not 0 < relaxation <= 1:
            raise ValueError(f"the secant relaxation with contact must be in (0, 1], got {relaxation}")
        self.f = forms
        self.contact = contact
        self.tol = tol
        self.maxit = maxit
        lam_max = max(p.lam for p in forms.setup.props.values())
        self.relaxation = relaxation if relaxation is not None else min(1.0, 1.0 / lam_max)
        self._dirichlet = ElasticSolver(forms)      # its Dirichlet handling only
        self._free = np.array(list(forms.X.FreeDofs()), dtype=bool)
        self.method = "secant" if forms.setup.nonlinear else "linear"
        self.history: list[NonlinearInfo] = []
        self.contact_infos: list[list] = []

    @property
    def factorizations(self) -> int:
        return sum(i.factorizations for infos in self.contact_infos for i in infos)

    def _contact_solve(self, where: str, infos: list) -> None:
        """U <- the contact solution with the current secant matrix and load (Dirichlet values kept)."""
        f = self.f
        f.secant_form.Assemble()
        f.secant_rhs.Assemble()
        x0 = np.array(f.gf.vec.FV().NumPy())
        u, info = self.contact.solve(f.secant_form.mat, np.array(f.secant_rhs.vec.FV().NumPy()), self._free, x0,
                                     where)
        f.gf.vec.FV().NumPy()[:] = u
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
