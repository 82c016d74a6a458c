"""The seed's reference algorithm for friction: Uzawa's algorithm on the saddle point (2.64)/(2.66).

The seed (section 2.2, (2.55)-(2.66)) writes the non-differentiable friction functional j(v) = int g_c |v_t| ds
by multipliers mu with |mu| <= 1 (the set Lambda), L(v, mu) = L_0(v) + int mu g_c (v_t^k - v_t^l) ds, and
solves (2.66) by Uzawa's algorithm: given mu^i, minimize L(., mu^i) over K_h (a contact problem without
friction, the friction traction g_c mu^i being a given load), then mu^(i+1) = P(mu^i + rho_i g_c slip(u_i)) with
P the projection onto Lambda and 0 < rho_1 <= rho_i <= rho_2 small enough (Ekeland-Temam).

In the notation of :mod:`ngs_geomech.contact.forms` (K u = f + Bn^T lam_n + Bt^T lam_t, nodal slip
s~_j = (Bt u)_j / weight_j in m with s = (u_O - u_S).t, and lam_t s <= 0) the friction traction is
lam_t = g mu (Pa), so mu_j = lam_t,j / g_j, the seed's mu up to its sign (the seed's Lagrangian adds
+mu g_c (v_t^k - v_t^l), ours -lam_t^T Bt v, with the slip oriented O minus S). The dual function
D(lam_t) = min_{v in K_h} {1/2 v^T K v - f^T v - lam_t^T Bt v} has the gradient -s~ in the L2(Gamma_c) inner
product sum_j weight_j a_j b_j of the nodal values, so one step is

    u_i   = the frictionless contact solution for the load f + Bt^T lam_t^i      (ContactSolver, "frictionless"),
    lam_t^(i+1) = P(lam_t^i - rho s~(u_i)),   P: nodewise clip to [-b_j, b_j],

i.e. mu^(i+1) = P(mu^i - (rho / g) s~): the seed's step is rho_seed = rho / g_c^2. ``rho`` (Pa/m) is of the
order of a stiffness per length: the default is ``RHO_FACTOR`` x modulus / L (L the extent of the contact side,
the tangential augmentation c_t of ContactSolver). The largest eigenvalue of the step operator s~(lam_t) is the
compliance of the smoothest traction mode, about L / E, so rho < 2 E / L (up to a geometric factor) converges;
the smallest is about h / E, so the contraction factor is about 1 - rho h / E and the number of steps grows like
L / h at a fixed rho (measured below).

Bounds b_j: Tresca g_c(x_j) (Pa); Coulomb F_c lam_n,j with lam_n from the previous normal subproblem, i.e. the
classic successive-Tresca fixed point, here with one Uzawa step per Tresca problem (a single loop: the bound is
updated at every step). As in :class:`ContactSolver`, friction acts on nodes in contact only: b_j = 0 where the
previous normal subproblem has lam_n,j = 0 (so Tresca is also a fixed point over the contact set). Stop when
||lam_t^(i+1) - lam_t^i|| < tol max(||lam_t^(i+1)||, ||b||) (weighted L2 norms on Gamma_c); the returned pair is
(u_i, lam_t^i) of the last subproblem, which satisfies the equilibrium exactly.

Floating (semi-coercive) bodies: the seed assumes Gamma_u is not empty (V_h has v = 0 on Gamma_u), so every
subproblem is coercive. Without it, a frictionless subproblem with a given tangential traction is solvable only
when that traction balances the load on the rigid motions the normal contact does not see (e.g. the sliding of a
block on a flat foundation); the dual function is -infinity elsewhere. So P projects onto Lambda intersected
with that balance condition, R_N^T (f + Bt^T lam_t) = 0, in the same weighted inner product (clip(y - nu a / w)
with the scalar nu solving the balance exactly, found on the breakpoints of the piecewise linear balance). The
update is then independent of the free rigid motion the subproblem picks, and the displacement is fixed by
moving the body along it so that the stick nodes (|lam_t| < b) do not slip (least squares). The start is the
projection of lam_t = 0 (for Coulomb without the bound, which is unknown before the first normal solve). One
free sliding motion is handled (one floating body on one or more interfaces); more raise a SolverError, as does a
tangential load the friction cannot carry.

Measured on the block of :func:`ngs_geomech.verification.contact_problems.friction_block` (L = 1 m, H = 0.5 m,
P1, E = 10 GPa, nu = 0.25, modulus 12 GPa, p_top = 5 MPa, g_c = 1 MPa, F_c = 0.3; tol = 1e-10;
tests/test_contact_reference_methods.py), default rho = 2 x 12 GPa / 1 m = 2.4e10 Pa/m (Tresca: the seed's
rho_seed = rho / g_c^2 = 0.024 / (Pa m)); multipliers within 1e-9 p_top and displacements within 1e-10 of the
ContactSolver (ssn) solution:

* pushed at half the capacity, floating (sticks in the middle, slips at the ends): Tresca 180 steps, Coulomb
  173 steps at h = 0.1 m (ssn: 5 and 3 iterations); Tresca 75 / 180 / 353 steps at h = 0.2 / 0.1 / 0.05 m (the
  L / h growth); at h = 0.1 m, rho = (1, 2, 3, 4) x modulus / L: 353, 180, 120, 90 steps, 5 x does not converge
  (the stability limit, also at h = 0.05 m); Coulomb: 2.5 x converges, 3.5 x (h = 0.1 m) and 3 x (h = 0.05 m)
  do not (the bound moving with lam_n lowers the limit); hence the default factor 2;
* pushed by a displacement (slides everywhere): Tresca 2 steps (all nodes at the bound after one projection),
  Coulomb 11 steps.

The inner (frictionless active set) iterations: 181 for 180 steps, i.e. one factorization per step once the
contact set has settled, since the one ContactSolver instance starts from its previous sets (it skips its
penalty phase when warm; two factorizations per step without that). A steady step costs about 5 ms here, the
ssn solve of the whole problem about 30 ms: this is a reference method, not a production one.

Units: u m, multipliers Pa, rho Pa/m.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .base import ContactSolverBase
from .forms import ContactOperator
from .laws import ContactLaw, ContactOptions, slip_bound
from .solver import ContactSolver

RHO_FACTOR = 2.0
"""Default step: rho = RHO_FACTOR x modulus / (extent of the contact side) (Pa/m); see the module docstring
for the measured stability limits."""


@dataclass
class UzawaInfo:
    """History of one Uzawa solve: per outer step the relative change of lam_t and the numbers of nodes in
    contact, sticking (|lam_t| < b) and slipping (|lam_t| = b); the inner (active set) iterations in total;
    the step rho per interface (Pa/m, the last one used) and ``rho_halvings`` (the safeguard's); final
    penetration and pressure as :class:`ContactInfo`; wall time."""

    iterations: int = 0
    inner_iterations: int = 0
    factorizations: int = 0
    changes: list = field(default_factory=list)
    active: list = field(default_factory=list)
    stick: list = field(default_factory=list)
    slip: list = field(default_factory=list)
    rho: list = field(default_factory=list)
    rho_halvings: int = 0
    max_penetration: float = 0.0
    min_pressure: float = 0.0
    wall_s: float = 0.0


class _Side:
    """One interface's padded operators, law, bounds and step inside the Uzawa solver."""

    def __init__(self, op: ContactOperator, law: ContactLaw, ndof: int, modulus: float, rho: float | None):
        self.op, self.law = op, law
        m = op.size
        pad = sp.csr_matrix((m, ndof - op.Bn.shape[1]))
        self.Bn = sp.hstack([op.Bn, pad]).tocsr()
        self.Bt = sp.hstack([op.Bt, pad]).tocsr()
        self.keep = op.constrained
        self.w = np.maximum(op.weight, 1e-300)
        self.frictional = law.kind != "frictionless"
        extent = float(np.max(np.ptp(op.coords, axis=0))) if m > 1 else 1.0
        self.rho = float(rho) if rho is not None else RHO_FACTOR * modulus / max(extent, 1e-300)
        if law.kind == "tresca":
            self.g = np.broadcast_to(np.asarray(law.slip_bound, dtype=float), (m,)).copy()
        else:
            self.g = np.zeros(m)

    def bound(self, lam_n: np.ndarray | None) -> np.ndarray:
        """b_j (Pa): g_c or F_c lam_n on the nodes in contact, 0 elsewhere; lam_n None (before the first normal
        solve): g_c on every kept node (Tresca), unbounded (Coulomb)."""
        if not self.frictional:
            return np.zeros(self.op.size)
        if lam_n is None:
            b = self.g.copy() if self.law.kind == "tresca" else np.full(self.op.size, np.inf)
            return np.where(self.keep, b, 0.0)
        on = self.keep & (lam_n > 0)
        b = self.g if self.law.kind == "tresca" else slip_bound(self.law.friction, lam_n)
        return np.where(on, b, 0.0)


def _project_balanced(y: np.ndarray, b: np.ndarray, w: np.ndarray, a: np.ndarray, c: float,
                      c_tol: float = 0.0) -> np.ndarray | None:
    """The minimizer of sum_j w_j (lam_j - y_j)^2 over |lam_j| <= b_j with a . lam = c, i.e.
    lam = clip(y - nu a / w, -b, b) with the scalar nu solving the piecewise linear, non-increasing equation
    h(nu) = a . lam(nu) - c = 0 exactly (on its breakpoints); None when no admissible lam balances
    (|c| > sum |a_j| b_j + c_tol; an excess up to c_tol, rounding of the load, is dropped)."""
    d = a / w

    def lam(nu):
        return np.clip(y - nu * d, -b, b)

    cap = float(np.sum(np.abs(a) * b))
    if abs(c) > cap * (1 + 1e-12) + c_tol:
        return None
    c = float(np.clip(c, -cap, cap))
    nz = (d != 0) & (b > 0)
    if not nz.any():
        return np.clip(y, -b, b)
    # breakpoints where a node reaches a bound
    with np.errstate(invalid="ignore"):
        bp = np.concatenate([(y[nz] - b[nz]) / d[nz], (y[nz] + b[nz]) / d[nz]])
    bp = np.unique(bp[np.isfinite(bp)])

    def h(nu):
        return float(a @ lam(nu)) - c

    if len(bp) == 0:             # no finite bound: linear
        lo, hi = -1.0, 1.0
    else:
        # h is non-increasing: the last breakpoint with h >= 0 and the next one bracket the root
        lo_i, hi_i = 0, len(bp) - 1
        if h(bp[0]) < 0:
            lo, hi = bp[0] - max(1.0, abs(bp[0])), bp[0]
        elif h(bp[-1]) > 0:
            lo, hi = bp[-1], bp[-1] + max(1.0, abs(bp[-1]))
        else:
            while hi_i - lo_i > 1:
                mid = (lo_i + hi_i) // 2
                if h(bp[mid]) >= 0:
                    lo_i = mid
                else:
                    hi_i = mid
            lo, hi = bp[lo_i], bp[hi_i]
    # h is linear on [lo, hi] (no breakpoint inside; outside the breakpoints the nodes stay clipped or free)
    h_lo, h_hi = h(lo), h(hi)
    if h_lo == h_hi:
        return lam(lo)
    nu = lo + (hi - lo) * h_lo / (h_lo - h_hi)
    return lam(nu)


class _Tangential:
    """The tangential multipliers of all interfaces as one vector: the nodal weights ``W``, the split per interface,
    the projection P onto the friction bounds and, with a floating body's sliding motion ``r`` (an X vector, or
    None), the balance a . lam_t = c of its tangential load (a = the parts Bt r of the interfaces, c = -r . f).
    ``at``: the solve's name in errors."""

    def __init__(self, sides: list[_Side], r: np.ndarray | None, f: np.ndarray, floating: list, n: int, at: str):
        self.r, self.at = r, at
        self.names = ", ".join(s.op.name for s in sides)
        self.cuts = np.cumsum([0] + [s.op.size for s in sides])
        self.W = np.concatenate([s.w for s in sides]) if sides else np.zeros(0)
        if r is not None:
            self.a = np.concatenate([s.Bt @ r for s in sides])
            self.c = -float(r @ f)
            # rounding of the load: the scale of ContactSolver's solvability check (all free rigid motions)
            self.c_tol = 1e-10 * float(np.max(np.abs(np.hstack([bd.modes[:n] for bd in floating]).T @ f)))

    def split(self, v: np.ndarray) -> list[np.ndarray]:
        """The parts of ``v`` per interface."""
        return [v[self.cuts[k]:self.cuts[k + 1]] for k in range(len(self.cuts) - 1)]

    def project(self, y: np.ndarray, b: np.ndarray) -> np.ndarray:
        """P(y): y clipped to [-b, b], balanced on the sliding motion (:func:`_project_balanced`) when there is
        one; SolverError when the friction cannot balance it."""
        if self.r is None:
            return np.clip(y, -b, b)
        lam = _project_balanced(y, b, self.W, self.a, self.c, self.c_tol)
        if lam is None:
            raise SolverError(f"{self.at}: the friction on {self.names} cannot hold the tangential load of the "
                              f"floating body (unbalanced {abs(self.c):.3g} against a capacity "
                              f"{float(np.sum(np.abs(self.a) * np.where(np.isfinite(b), b, 0))):.3g}): add a "
                              "support or change the load")
        return lam

    def hold_stick(self, u: np.ndarray, slip: np.ndarray, stick: np.ndarray) -> np.ndarray:
        """``u`` moved along the sliding motion so that the stick nodes do not slip (least squares; ``u``
        itself without a sliding motion)."""
        if self.r is None:
            return u
        sig = self.a / self.W
        den = float(np.sum(self.W[stick] * sig[stick] ** 2))
        if den > 0:
            shift = -float(np.sum(self.W[stick] * sig[stick] * slip[stick])) / den
            u = u + shift * self.r
        return u


class UzawaSolver(ContactSolverBase):
    """Uzawa's algorithm (2.66) for Tresca and Coulomb friction (module docstring), with the interface of
    :class:`ContactSolver`: ``solve(matrix, rhs, free, x0, where) -> (u, info)`` and the multipliers per
    interface in ``self.multipliers`` [(lam_n, lam_t)] (Pa).

    ``rho``: the step (Pa/m), one for every interface or a list with one per interface (None entries: the
    default ``RHO_FACTOR`` x modulus / extent of the side); ``tol``: the relative change of lam_t that stops;
    ``maxit``: outer steps; ``inner_maxit``: active set iterations of each frictionless subproblem;
    ``floating``: as ContactSolver; ``settings``: the names of the step and step-limit settings the
    non-convergence error advises to change (a scene's keys; default the arguments ``rho`` and ``maxit``). rho
    is halved after ``STALL`` steps without a new smallest change of lam_t (a step above the stability limit
    oscillates)."""

    STALL = 30

    def __init__(self, interfaces: list[tuple[ContactOperator, ContactLaw]], *, modulus: float,
                 maxit: int = 1000, rho=None, tol: float = 1e-10, inner_maxit: int = 50,
                 floating=(), settings: tuple[str, str] = ("rho", "maxit")):
        self.items = interfaces
        self.modulus = float(modulus)
        self.maxit = maxit
        self.rho = list(rho) if isinstance(rho, (list, tuple)) else [rho] * len(interfaces)
        self.tol = float(tol)
        self.settings = settings
        if len(self.rho) != len(interfaces):
            raise ValueError(f"the Uzawa steps rho: one per interface ({len(interfaces)}), got {len(self.rho)}")
        for r in self.rho:
            if r is not None and not (r > 0 and np.isfinite(r)):
                raise ValueError(f"the Uzawa step rho must be positive (Pa/m), got {r}")
        self.floating = list(floating)
        # the normal subproblems: one solver, so that its active sets carry over from step to step
        self.inner = ContactSolver([(op, ContactLaw("frictionless", augmentation=law.augmentation))
                                    for op, law in interfaces], modulus=modulus, maxit=inner_maxit,
                                   floating=floating)
        self.infos: list[UzawaInfo] = []
        self.multipliers: list[tuple[np.ndarray, np.ndarray]] = []
        self._last: np.ndarray | None = None      # lam_t of the previous solve: the start of the next one

    @classmethod
    def from_options(cls, items, options: ContactOptions, *, modulus: float, floating=(), forms=None) -> UzawaSolver:
        """Uzawa's solver with the options' ``uzawa_step``, ``uzawa_max_steps`` and ``uzawa_settings`` (``forms`` is
        not needed: the subproblems are solved directly)."""
        return cls(items, modulus=modulus, floating=floating, maxit=options.uzawa_max_steps, rho=options.uzawa_step,
                   settings=options.uzawa_settings)

    def _sliding_motion(self, sides: list[_Side], n: int, where: str):
        """The rigid motion (X vector) of the floating bodies the normal contact does not see (Bn r = 0 on
        every interface), or None."""
        if not self.floating:
            return None
        R = np.hstack([bd.modes[:n] for bd in self.floating])
        R = R / np.maximum(np.linalg.norm(R, axis=0), 1e-300)
        BR = np.vstack([s.Bn[np.where(s.keep)[0]] @ R for s in sides] + [np.zeros((0, R.shape[1]))])
        if BR.shape[0]:
            _, sv, vt = np.linalg.svd(BR, full_matrices=True)
            sv = np.concatenate([sv, np.zeros(vt.shape[0] - len(sv))])
            null = vt[sv <= 1e-10 * max(float(sv[0]) if len(sv) else 0.0, 1e-300)]
        else:
            null = np.eye(R.shape[1])
        if len(null) == 0:
            return None
        if len(null) > 1:
            raise SolverError(f"Uzawa contact solve{' at ' + where if where else ''}: {len(null)} rigid motions of "
                              "the floating bodies are not held by the normal contact; the Uzawa solver handles "
                              "one (one body sliding along its contacts): add supports or use ContactSolver")
        return R @ null[0]

    def capture(self) -> dict:
        """The warm start of the next solve as plain arrays: the last tangential multipliers (``"last"``) and the
        inner solver's sets (``"inner/..."``, :meth:`ContactSolver.capture`)."""
        out = {f"inner/{k}": v for k, v in self.inner.capture().items()}
        if self._last is not None:
            out["last"] = self._last.copy()
        return out

    def restore(self, ndof: int, state: dict) -> None:
        """Start the next solve from a state of :meth:`capture`."""
        if "last" in state:
            self._last = np.array(state["last"], dtype=float)
        self.inner.restore(ndof, {k.split("/", 1)[1]: v for k, v in state.items() if k.startswith("inner/")})

    def _safeguard(self, sides: list[_Side], info: UzawaInfo, change: float, best: float,
                   since_best: int) -> tuple[float, int]:
        """Halve rho after STALL steps without a new smallest change of lam_t; returns (best, since_best)."""
        if change < best:
            return change, 0
        since_best += 1
        if since_best >= self.STALL:
            for side in sides:
                side.rho *= 0.5
            info.rho = [side.rho for side in sides]
            info.rho_halvings += 1
            return change, 0
        return best, since_best

    def _finish(self, sides: list[_Side], u: np.ndarray, lam: np.ndarray, lam_n: np.ndarray, lam_t: list,
                info: UzawaInfo, tic: float) -> None:
        """The history's penetration, pressure and time, the multipliers of the solve and the next start."""
        pen = 0.0
        for s in sides:
            gap = (s.op.g0 + s.Bn @ u) / s.w
            pen = max(pen, float(np.max(-gap[s.keep], initial=0.0)))
        info.max_penetration = pen
        info.min_pressure = min(0.0, float(np.min(lam_n, initial=0.0)))
        info.wall_s = time.perf_counter() - tic
        self.multipliers = [(ln.copy(), np.where(s.frictional, lt, 0.0))
                            for s, (ln, _), lt in zip(sides, self.inner.multipliers, lam_t)]
        self._last = lam.copy()
        self.infos.append(info)

    def solve(self, matrix, rhs, free: np.ndarray, x0: np.ndarray, where: str = "") -> tuple[np.ndarray, UzawaInfo]:
        """The displacement vector (X) and the history; raises SolverError when the change of lam_t does not
        fall below ``tol`` in ``maxit`` steps or a floating body's tangential load exceeds the friction."""
        tic = time.perf_counter()
        n = len(x0)
        f = np.asarray(rhs, dtype=float)
        sides = [_Side(op, law, n, self.modulus, rho) for (op, law), rho in zip(self.items, self.rho)]
        info = UzawaInfo(rho=[s.rho for s in sides])
        tan = _Tangential(sides, self._sliding_motion(sides, n, where), f, self.floating, n,
                          f"Uzawa contact solve{' at ' + where if where else ''}")
        W = tan.W
        b = np.concatenate([s.bound(None) for s in sides]) if sides else np.zeros(0)
        lam = tan.project(self._last if self._last is not None and len(self._last) == len(W) else np.zeros_like(W), b)
        change = float("inf")
        best, since_best = float("inf"), 0
        for it_nr in range(1, self.maxit + 1):
            u, lam_n, b, slip = self._normal_step(matrix, f, free, x0, f"{where}, Uzawa step {it_nr}", sides,
                                                  tan.split(lam), info)
            rho = np.concatenate([np.full(s.op.size, s.rho) for s in sides])
            new = tan.project(lam - rho * slip, b)      # independent of the free motion of a floating body
            stick = (b > 0) & (np.abs(new) < b)
            u = tan.hold_stick(u, slip, stick)
            scale = max(float(np.sqrt(W @ new ** 2)), float(np.sqrt(W @ np.where(np.isfinite(b), b, 0) ** 2)),
                        1e-300)
            change = float(np.sqrt(W @ (new - lam) ** 2)) / scale
            info.iterations = it_nr
            info.changes.append(change)
            info.active.append(int(np.sum(lam_n > 0)))
            info.stick.append(int(np.sum(stick)))
            info.slip.append(int(np.sum((b > 0) & ~stick)))
            if not any(s.frictional for s in sides) or change < self.tol:
                break
            lam = new
            # safeguard: a step above the stability limit makes the change oscillate without decreasing (two
            # elastic bodies on the default rho: still 0.49 after 1000 steps); halve rho after STALL steps
            # without a new smallest change
            best, since_best = self._safeguard(sides, info, change, best, since_best)
        else:
            raise SolverError(f"{tan.at}: the friction multipliers on {tan.names} still change by {change:.2e} "
                              f"(relative) after {self.maxit} Uzawa steps (tol {self.tol:.1e}, rho "
                              f"{', '.join(f'{s.rho:.3g}' for s in sides)} Pa/m): lower {self.settings[0]} (too "
                              f"large a step diverges) or raise {self.settings[1]}")
        self._finish(sides, u, lam, lam_n, tan.split(lam), info, tic)
        return u, info

    def _normal_step(self, matrix, f: np.ndarray, free: np.ndarray, x0: np.ndarray, where: str, sides: list[_Side],
                     lam_t: list, info: UzawaInfo):
        """The frictionless contact solution for the load f + Bt^T lam_t (per interface ``lam_t``): (u, lam_n, the
        bounds b and the nodal slips s~ of all interfaces)."""
        load = f.copy()
        for s, lt in zip(sides, lam_t):
            if s.frictional:
                load += s.Bt.T @ lt
        u, inner = self.inner.solve(matrix, load, free, x0, where)
        info.inner_iterations += inner.iterations
        info.factorizations += inner.factorizations
        lam_n = np.concatenate([ln for ln, _ in self.inner.multipliers]) if sides else np.zeros(0)
        b = np.concatenate([s.bound(ln) for s, (ln, _) in zip(sides, self.inner.multipliers)])
        slip = np.concatenate([(s.Bt @ u) / s.w for s in sides]) if sides else np.zeros(0)
        return u, lam_n, b, slip
