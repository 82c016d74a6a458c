"""Time integration of the global evolutionary model (seed (2.6)-(2.16)) on the forms of
:mod:`ngs_geomech.dynamics.forms`, with contact (2.12)-(2.15) through
:class:`~ngs_geomech.contact.solver.ContactSolver`.

Dynamic problem (:class:`DynamicSolver`): the generalized-alpha method (Chung & Hulbert, J. Appl. Mech. 60 (1993))

    M a_{n+1-am} + C^v v_{n+1-af} + K u_{n+1-af} + sum_k K_k w_k,{n+1-af} = f_{n+1-af} + G,
    x_{n+1-a} = (1-a) x_{n+1} + a x_n,
    u_{n+1} = u_n + dt v_n + dt^2 ((1/2 - beta) a_n + beta a_{n+1}),
    v_{n+1} = v_n + dt ((1 - gamma) a_n + gamma a_{n+1}),
    am = (2 rho_inf - 1)/(rho_inf + 1), af = rho_inf/(rho_inf + 1), gamma = 1/2 - am + af, beta = (1 - am + af)^2 / 4,

rho_inf in [0, 1] the spectral radius at dt omega -> infinity (1: no numerical dissipation, the average-acceleration
Newmark rule (trapezoidal, beta = 1/4, gamma = 1/2) written at the mid-step, am = af = 1/2; 0: the highest modes
annihilated in one step); second order for every rho_inf. ``scheme="newmark"`` is rho_inf = 1.

Contact: G = Bn^T lam_n + Bt^T lam_t is the contact force of the step, acting at the generalized mid-step, with the
Signorini conditions on the end-of-step displacement u_{n+1} (implicit, one static contact problem per step solved by
the semi-smooth Newton method of ContactSolver on the increment du = u_{n+1} - u_n: gap g0 + Bn u_n + Bn du, and the
friction laws on the slip increment Bt du, so stick means no slip during the step). For rho_inf = 1 the step
satisfies M (v_{n+1} - v_n) = dt (f - K u_{n+1/2} + G) and u_{n+1} - u_n = dt v_{n+1/2}, hence

    E_{n+1} - E_n = du . (f_{n+1/2} + R_{n+1/2} - (viscous, branch forces)) + lam_n . (g_{n+1} - g_n)
                    + lam_t . Bt du,

with R the reactions on the dofs with prescribed displacements (the residual M a + C^v v + K u + sum_k K_k w_k - f
of those rows at the generalized mid-step; R_{n+1/2} = (R_n + R_{n+1})/2 for rho_inf = 1, the trapezoidal rule of
the scheme) doing the work du_D . R on time-dependent prescribed displacements, and
lam_n . (g_{n+1} - g_n) = -lam_n . g_n <= 0 by lam_n g_{n+1} = 0: contact never adds energy; it removes
lam_n g_n (a node closing a gap within a step: the impact loss) and nothing while a node stays closed (g_n = 0) or
opens (lam_n = 0); friction removes -lam_t . Bt du >= 0. With the contact force taken at both ends of the step
(lam_n + lam_{n+1})/2, the classical Newmark form, the release term +lam_n g_{n+1}/2 gains energy. The
consistent mass makes the contact nodes of a P1 bar oscillate in and out of contact (chattering) and the contact
pressure oscillate; ``mass="lumped", redistribute_contact_mass=True`` removes the mass of the contact side's nodes
(moved to their neighbours, total mass kept): the mass redistribution of Khenous, Laborde & Renard (Eur. J. Mech.
A 27, 2008), after which the contact nodes are quasi-static and do not chatter.

Quasi-static viscous problem (:class:`ViscousSolver`): backward Euler in u,

    C^v (u_{n+1} - u_n)/dt + K u_{n+1} + sum_k K_k w_k,{n+1} = f_{n+1} + G,

first order (the Prony branches by their own rule, exponential by default); :meth:`ViscousSolver.jump` is the
instantaneous response to a load change (dt = 0: the branches unrelaxed; refused with Kelvin-Voigt viscosity, whose
dashpot does not move instantly).

Energies are reported per step (:class:`EnergyRecord`, J for plane models per metre of thickness, axisymmetric per
radian): kinetic v M v / 2, elastic u K u / 2, stored in the branches sum w K_k w / 2, and the cumulated external
work, work of the prescribed displacements (the reactions R against du_D), viscous and branch dissipation, contact
work (<= 0) and the remainder (numerical dissipation of rho_inf < 1).
Units: s, m, m/s, Pa.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..contact.factory import build_contact_solver
from ..contact.forms import ContactOperator
from ..contact.laws import ContactLaw, ContactOptions
from ..contact.solver import nodal_modulus
from ..errors import SolverError
from ..mechanics.solver import ElasticSolver
from .forms import ViscoelasticForms, branch_coefficients

SCHEMES = ("newmark", "generalized_alpha")


def generalized_alpha_parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """(alpha_m, alpha_f, beta, gamma) of Chung & Hulbert for the spectral radius ``rho_inf`` in [0, 1]."""
    if not 0.0 <= rho_inf <= 1.0:
        raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf}")
    am = (2 * rho_inf - 1) / (rho_inf + 1)
    af = rho_inf / (rho_inf + 1)
    gamma = 0.5 - am + af
    beta = 0.25 * (1 - am + af) ** 2
    return am, af, beta, gamma


@dataclass
class EnergyRecord:
    """Energies after a step (J per unit thickness in plane models): ``kinetic``, ``elastic``, ``branches``
    (stored in the Prony branches), ``total`` (their sum), and cumulated since the start: ``external_work``
    (loads), ``dirichlet_work`` (the reactions on the prescribed displacements against their increments),
    ``viscous_dissipation``, ``branch_dissipation``, ``contact_work`` (<= 0 without driven contacts),
    ``numerical_dissipation`` (external + Dirichlet + contact work - change of total - the dissipations: 0 for
    rho_inf = 1 up to round-off)."""

    t: float
    kinetic: float
    elastic: float
    branches: float
    total: float
    external_work: float = 0.0
    viscous_dissipation: float = 0.0
    branch_dissipation: float = 0.0
    contact_work: float = 0.0
    numerical_dissipation: float = 0.0
    dirichlet_work: float = 0.0


@dataclass
class StepInfo:
    """One step: time ``t`` (end of step), ``dt``, whether a contact problem was solved (``contact_solved``),
    ``active`` (per interface the bool array of nodes in contact at the end of the step), contact iterations,
    wall time."""

    t: float
    dt: float
    contact_solved: bool = False
    active: list = field(default_factory=list)
    contact_iterations: int = 0
    wall_s: float = 0.0


def _ngs_matrix(A: sp.csr_matrix):
    coo = A.tocoo()
    return ngs.la.SparseMatrixd.CreateFromCOO(coo.row.astype(np.int64), coo.col.astype(np.int64),
                                              coo.data.astype(float), A.shape[0], A.shape[1])


class _Stepper:
    """What both integrators share: Dirichlet values, factorizations per dt, the contact step on increments,
    the branch recursion."""

    def __init__(self, forms: ViscoelasticForms, *, contact=(), contact_options: ContactOptions | None = None,
                 branch_rule: str = "exponential"):
        self.f = forms
        self.n = forms.elastic.X.ndof
        self.free = forms.free
        self.branch_rule = branch_rule
        branch_coefficients(1.0, 1.0, branch_rule)   # checks the rule's name
        self.t = 0.0
        self.u = np.zeros(self.n)
        self.w = [np.zeros(self.n) for _ in forms.branches]
        self._elastic_solver = ElasticSolver(forms.elastic)
        self._lu: dict = {}
        self._dirichlet_cache = None
        # contact: copies of the operators whose g0 is set to the gap at the start of each step
        self.contact_items = [(dataclasses.replace(op, g0=np.array(op.g0, dtype=float)), law)
                              for op, law in contact]
        self._g0_ref = [np.array(op.g0, dtype=float) for op, _ in contact]
        self.contact_solver = None
        self.dissipated = 0.0               # J per m of depth: viscous dissipation so far (viscous problem)
        self.energy_history: list[EnergyRecord] = []       # the energy balance per step (dynamic problem)
        self.started = False                # set_initial called
        if self.contact_items:
            props = forms.elastic.setup.props
            self.contact_solver = build_contact_solver(self.contact_items, contact_options or ContactOptions(),
                                                       modulus=nodal_modulus(props))
        self.active = [np.zeros(op.size, dtype=bool) for op, _ in self.contact_items]
        self.multipliers = [(np.zeros(op.size), np.zeros(op.size)) for op, _ in self.contact_items]
        self.steps: list[StepInfo] = []

    # -- data at a time ----------------------------------------------------------------------------------------
    def dirichlet(self, t: float) -> np.ndarray:
        """X vector with the prescribed displacements at time t on the fixed dofs (0 elsewhere)."""
        if self.f.steady_data and self._dirichlet_cache is not None:
            return self._dirichlet_cache.copy()
        ef = self.f.elastic
        ef.t.Set(t)
        ef.gf.vec[:] = 0.0
        self._elastic_solver.set_dirichlet()
        out = np.where(self.free, 0.0, np.array(ef.gf.vec.FV().NumPy()))
        self._dirichlet_cache = out.copy()
        return out

    def gaps(self, u: np.ndarray) -> list[np.ndarray]:
        """Nodal gaps (m) per interface for the displacement u (the reference g0, not the step's)."""
        out = []
        for (op, _), g0 in zip(self.contact_items, self._g0_ref):
            out.append((g0 + op.Bn @ u[:op.Bn.shape[1]]) / np.maximum(op.weight, 1e-300))
        return out

    def _branch_coeffs(self, dt: float):
        return [branch_coefficients(dt, b.tau, self.branch_rule) for b in self.f.branches]

    # -- one linear step with contact --------------------------------------------------------------------------
    def _solve(self, key, A: sp.csr_matrix, r: np.ndarray, u_start: np.ndarray, xD: np.ndarray,
               info: StepInfo) -> tuple[np.ndarray, np.ndarray]:
        """The u solving A u = r + G with the Dirichlet values xD and the contact conditions on u (the step's start
        u_start for the increments); returns (u, G) with G = A u - r on the free dofs (the contact force)."""
        fr = self.free
        if key not in self._lu:
            Aff = A[fr][:, fr].tocsc()
            try:
                lu = spla.splu(Aff)
            except RuntimeError as exc:
                raise SolverError(f"dynamic/viscous step: the step matrix is singular ({exc}); a body without mass "
                                  "and support, or a zero time step with Kelvin-Voigt viscosity") from None
            self._lu[key] = (lu, A, _ngs_matrix(A) if self.contact_items else None)
        lu, _, Angs = self._lu[key]
        u = xD.copy()
        u[fr] = lu.solve(r[fr] - A[fr] @ xD)
        if not np.all(np.isfinite(u)):
            raise SolverError("dynamic/viscous step: the solution is not finite")
        if self.contact_items:
            gaps = self.gaps(u)
            keep = [op.coverage > 1 - 1e-6 for op, _ in self.contact_items]
            penetrates = any(np.any(g[k] < 0) for g, k in zip(gaps, keep))
            if penetrates or any(a.any() for a in self.active):
                for (op, _), g0 in zip(self.contact_items, self._g0_ref):
                    op.g0[:] = g0 + op.Bn @ u_start[:op.Bn.shape[1]]
                rhs = r - A @ u_start
                du, cinfo = self.contact_solver.solve(Angs, rhs, fr, np.where(fr, 0.0, xD - u_start),
                                                     f"t = {info.t:.6g} s")
                u = u_start + du
                info.contact_solved = True
                info.contact_iterations = cinfo.iterations
                self.multipliers = [(np.array(ln), np.array(lt)) for ln, lt in self.contact_solver.multipliers]
                self.active = [ln > 0 for ln, _ in self.multipliers]
            else:
                self.multipliers = [(np.zeros(op.size), np.zeros(op.size)) for op, _ in self.contact_items]
                self.active = [np.zeros(op.size, dtype=bool) for op, _ in self.contact_items]
            info.active = [a.copy() for a in self.active]
        G = np.where(fr, A @ u - r, 0.0)
        return u, G

    def _update_branches(self, u_new: np.ndarray, coeffs) -> list[np.ndarray]:
        return [a * w + c * (u_new - self.u) for w, (a, c) in zip(self.w, coeffs)]

    def sync_fields(self):
        nv = self.f.nv
        ef = self.f.elastic
        ef.gf.vec.FV().NumPy()[:] = self.u
        for b, w in zip(self.f.branches, self.w):
            b.w.vec.FV().NumPy()[:] = w[:nv]

    @property
    def factorizations(self) -> int:
        """Matrices factored so far (one per time-step size)."""
        return len(self._lu)


class DynamicSolver(_Stepper):
    """The dynamic problem rho u_tt = div tau + F with the viscoelastic law of :class:`ViscoelasticForms` and
    contact (module docstring). ``contact``: [(ContactOperator, ContactLaw)] (foundation or body pairs, built on
    the forms' space V). ``mass``: "consistent" or "lumped" (row sums; P1 only);
    ``redistribute_contact_mass``: zero mass on the contact sides' nodes (lumped mass only)."""

    def __init__(self, forms: ViscoelasticForms, *, scheme: str = "generalized_alpha", rho_inf: float = 1.0,
                 contact: list[tuple[ContactOperator, ContactLaw]] = (), contact_options: ContactOptions | None = None,
                 branch_rule: str = "exponential", mass: str = "consistent", redistribute_contact_mass: bool = False):
        if scheme not in SCHEMES:
            raise ValueError(f"unknown scheme {scheme!r}; choose one of {', '.join(SCHEMES)}")
        if scheme == "newmark" and rho_inf != 1.0:
            raise ValueError("scheme 'newmark' is the average-acceleration rule (rho_inf = 1); use "
                             "'generalized_alpha' for numerical damping")
        super().__init__(forms, contact=contact, contact_options=contact_options, branch_rule=branch_rule)
        self.rho_inf = float(rho_inf)
        self.am, self.af, self.beta, self.gamma = generalized_alpha_parameters(self.rho_inf)
        self.M = self._mass(mass, redistribute_contact_mass)
        self.v = np.zeros(self.n)
        self.a = np.zeros(self.n)
        self.f_n = None
        self.energy_history: list[EnergyRecord] = []

    def _mass(self, mass: str, redistribute: bool) -> sp.csr_matrix:
        Mc = self.f.M
        if mass == "consistent":
            if redistribute:
                raise ValueError("redistribute_contact_mass needs mass='lumped'")
            return Mc
        if mass != "lumped":
            raise ValueError(f"unknown mass {mass!r}; choose 'consistent' or 'lumped'")
        if self.f.elastic.setup.order != 1:
            raise ValueError("the lumped (row-sum) mass needs P1 elements (mesh order 1)")
        m = np.asarray(Mc.sum(axis=1)).ravel()
        if redistribute and self.contact_items:
            ns = self.f.nv // self.f.elastic.dim
            nodes = np.unique(np.concatenate([op.nodes for op, _ in self.contact_items]))
            dofs = np.concatenate([c * ns + nodes for c in range(self.f.elastic.dim)])
            is_c = np.zeros(self.n, dtype=bool)
            is_c[dofs] = True
            Mcsr = Mc.tocsr()
            for j in dofs:
                row = Mcsr.getrow(j)
                cols, vals = row.indices, row.data
                sel = ~is_c[cols] & (vals > 0)
                if not sel.any():
                    raise ValueError("mass redistribution: a contact node has no neighbour off the contact side")
                m[cols[sel]] += m[j] * vals[sel] / vals[sel].sum()
                m[j] = 0.0
        return sp.diags(m).tocsr()

    # -- state ---------------------------------------------------------------------------------------------
    def set_initial(self, u0: np.ndarray | None = None, v0: np.ndarray | None = None, t0: float = 0.0) -> None:
        """Initial displacement and velocity (X vectors; default 0) at t0; the acceleration from the balance
        without contact force (dofs without mass: 0). The branches start unstrained (w = 0)."""
        self.t = float(t0)
        self.u = np.zeros(self.n) if u0 is None else np.array(u0, dtype=float)
        self.v = np.zeros(self.n) if v0 is None else np.array(v0, dtype=float)
        self.w = [np.zeros(self.n) for _ in self.f.branches]
        self.f_n = self.f.load_vector(self.t)
        r = self.f_n - self.f.K @ self.u - self.f.C @ self.v
        diag = self.M.diagonal()
        dofs = np.where(self.free & (diag > 0))[0]
        self.a = np.zeros(self.n)
        if len(dofs):
            self.a[dofs] = spla.spsolve(self.M[dofs][:, dofs].tocsc(), r[dofs])
        self.energy_history = [self._energies(EnergyRecord(self.t, 0, 0, 0, 0))]
        self.sync_fields()

    def _energies(self, rec: EnergyRecord) -> EnergyRecord:
        kin = 0.5 * float(self.v @ (self.M @ self.v))
        el = 0.5 * float(self.u @ (self.f.K @ self.u))
        br = sum(0.5 * float(w @ (b.K @ w)) for b, w in zip(self.f.branches, self.w))
        rec.kinetic, rec.elastic, rec.branches, rec.total = kin, el, br, kin + el + br
        return rec

    def energy(self) -> EnergyRecord:
        """The last :class:`EnergyRecord`."""
        return self.energy_history[-1]

    # -- stepping ------------------------------------------------------------------------------------------
    def step(self, dt: float) -> StepInfo:
        """Advance by dt (s); returns the step's :class:`StepInfo` (also appended to ``steps``)."""
        if self.f_n is None:
            self.set_initial()
        if not dt > 0:
            raise ValueError(f"the time step must be positive, got {dt}")
        tic = time.perf_counter()
        am, af, beta, gamma = self.am, self.af, self.beta, self.gamma
        F = self.f
        t1 = self.t + dt
        info = StepInfo(t1, dt)
        c0, d0 = 1.0 / (beta * dt * dt), gamma / (beta * dt)
        un, vn, an = self.u, self.v, self.a
        a_hat = -c0 * un - vn / (beta * dt) - (0.5 / beta - 1.0) * an
        v_hat = -d0 * un + (1 - gamma / beta) * vn + dt * (1 - gamma / (2 * beta)) * an
        coeffs = self._branch_coeffs(dt)
        key = ("dyn", round(dt, 15))
        if key not in self._lu:
            A = (1 - am) * c0 * self.M + (1 - af) * d0 * F.C + (1 - af) * F.K
            for b, (_, c) in zip(F.branches, coeffs):
                A = A + (1 - af) * c * b.K
            A = A.tocsr()
        else:
            A = self._lu[key][1]
        f1 = F.load_vector(t1)
        f_alpha = (1 - af) * f1 + af * self.f_n
        r = (f_alpha - self.M @ ((1 - am) * a_hat + am * an) - F.C @ ((1 - af) * v_hat + af * vn)
             - af * (F.K @ un))
        for b, w, (a, c) in zip(F.branches, self.w, coeffs):
            r -= b.K @ ((1 - af) * (a * w - c * un) + af * w)
        xD = self.dirichlet(t1)
        u1, G = self._solve(key, A, r, un, xD, info)
        a1 = c0 * u1 + a_hat
        v1 = d0 * u1 + v_hat
        w1 = self._update_branches(u1, coeffs)
        # energy bookkeeping (the forces at the generalized mid-step against the increment)
        du = u1 - un
        rec = EnergyRecord(t1, 0, 0, 0, 0)
        prev = self.energy_history[-1]
        v_al = (1 - af) * v1 + af * vn
        rec.external_work = prev.external_work + float(du @ f_alpha)
        fixed = ~self.free
        rec.dirichlet_work = prev.dirichlet_work + float(du[fixed] @ (A[fixed] @ u1 - r[fixed]))
        rec.viscous_dissipation = prev.viscous_dissipation + float(du @ (F.C @ v_al))
        stored0 = sum(0.5 * float(w @ (b.K @ w)) for b, w in zip(F.branches, self.w))
        work_b = sum(float(du @ (b.K @ ((1 - af) * w_new + af * w))) for b, w, w_new in zip(F.branches, self.w, w1))
        self.u, self.v, self.a, self.w, self.t, self.f_n = u1, v1, a1, w1, t1, f1
        self._energies(rec)
        rec.branch_dissipation = prev.branch_dissipation + work_b - (rec.branches - stored0)
        rec.contact_work = prev.contact_work + float(du @ G)
        e0 = self.energy_history[0].total
        rec.numerical_dissipation = (rec.external_work + rec.dirichlet_work + rec.contact_work - (rec.total - e0)
                                     - rec.viscous_dissipation - rec.branch_dissipation)
        self.energy_history.append(rec)
        self.sync_fields()
        info.wall_s = time.perf_counter() - tic
        self.steps.append(info)
        return info

    def sync_fields(self):
        super().sync_fields()
        self.f.velocity.vec.FV().NumPy()[:] = self.v[:self.f.nv]


class ViscousSolver(_Stepper):
    """The quasi-static viscoelastic problem -div tau = F (no inertia), backward Euler (module docstring), with
    contact as in :class:`DynamicSolver`. Start from rest (u = 0, unstrained branches) at t0 with
    :meth:`set_initial`, apply a load step with :meth:`jump`, advance with :meth:`step`."""

    def set_initial(self, u0: np.ndarray | None = None, t0: float = 0.0) -> None:
        self.t = float(t0)
        self.u = np.zeros(self.n) if u0 is None else np.array(u0, dtype=float)
        self.w = [np.zeros(self.n) for _ in self.f.branches]
        self.dissipated = 0.0
        self.started = True
        self.sync_fields()

    def jump(self) -> StepInfo:
        """The instantaneous response at the current time (loads and prescribed displacements at t, the branches
        unrelaxed: K + sum_k K_k); refused with Kelvin-Voigt viscosity."""
        if self.f.C.nnz and np.max(np.abs(self.f.C.data)) > 0:
            raise ValueError("a Kelvin-Voigt body has no instantaneous response: step with dt > 0 instead")
        return self._advance(0.0)

    def step(self, dt: float) -> StepInfo:
        """Advance by dt > 0 (s)."""
        if not dt > 0:
            raise ValueError(f"the time step must be positive, got {dt}")
        return self._advance(dt)

    def _advance(self, dt: float) -> StepInfo:
        if not self.started:
            self.set_initial()
        tic = time.perf_counter()
        F = self.f
        t1 = self.t + dt
        info = StepInfo(t1, dt)
        coeffs = self._branch_coeffs(dt)
        key = ("qs", round(dt, 15))
        if key not in self._lu:
            A = F.K + (F.C / dt if dt > 0 else 0 * F.C)
            for b, (_, c) in zip(F.branches, coeffs):
                A = A + c * b.K
            A = A.tocsr()
        else:
            A = self._lu[key][1]
        r = F.load_vector(t1) + (F.C @ self.u / dt if dt > 0 else 0.0)
        for b, w, (a, c) in zip(F.branches, self.w, coeffs):
            r = r - b.K @ (a * w - c * self.u)
        xD = self.dirichlet(t1)
        u1, _ = self._solve(key, A, r, self.u, xD, info)
        w1 = self._update_branches(u1, coeffs)
        du = u1 - self.u
        if dt > 0:
            self.dissipated += float(du @ (F.C @ du)) / dt
        F.velocity.vec.FV().NumPy()[:] = (du / dt)[:F.nv] if dt > 0 else 0.0
        self.u, self.w, self.t = u1, w1, t1
        self.sync_fields()
        info.wall_s = time.perf_counter() - tic
        self.steps.append(info)
        return info


def contact_switches(steps: list[StepInfo]) -> dict:
    """Chattering measures from a step history: ``node_switches`` (the number of open <-> closed changes summed
    over the nodes), ``node_switches_max`` (the most changes of one node), ``status_switches`` (changes of 'any
    node in contact'), ``contact_periods`` (maximal runs of steps with some node in contact)."""
    if not steps or not steps[0].active:
        return {"node_switches": 0, "node_switches_max": 0, "status_switches": 0, "contact_periods": 0}
    st = np.array([np.concatenate(s.active) for s in steps], dtype=int)
    st = np.vstack([np.zeros((1, st.shape[1]), dtype=int), st])
    per_node = np.abs(np.diff(st, axis=0)).sum(axis=0)
    anyc = st.any(axis=1).astype(int)
    sw = int(np.abs(np.diff(anyc)).sum())
    return {"node_switches": int(per_node.sum()), "node_switches_max": int(per_node.max(initial=0)),
            "status_switches": sw, "contact_periods": int(math.ceil(sw / 2))}
