"""The floating (semi-coercive) bodies of a contact solve (:mod:`.solver`): the balance of their rigid motions
at an iterate, the slip directions that let friction hold them (:func:`walk_slip`), the check that admissible
contact forces can balance their load (:func:`check_load`) and the diagnosis of a contact set that does not
hold them (:func:`unheld_reason`).

Units: forces N (N/m in plane scenes), moments N m (N m/m), multipliers Pa.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .state import InterfaceState
from .steps import NewtonSystem, exact_residual

POLYGON = 16           # 3D solvability check: the friction disc |lam_t| <= b inside a regular 16-gon


def rigid_balance(s: NewtonSystem, b: np.ndarray, xv, r) -> float:
    """The largest unbalanced force or moment along the floating bodies' rigid motions at the iterate ``xv``."""
    ra = exact_residual(s, xv, r)
    return float(np.max(np.abs(s.rigid.T @ ((b - ra)[:s.n] * s.free))))


def balance_scale(s: NewtonSystem, b: np.ndarray, xv) -> float:
    """Forces the rigid-motion balance is measured against: the load, or the contact forces of the iterate when
    there is none (a problem driven by its gaps alone: an overlap pressing a body)."""
    xs = xv.FV().NumPy()
    forces = float(np.linalg.norm(b[:s.n] * s.free))
    for it in s.ifs:
        forces = max(forces, float(np.linalg.norm(it.Bn[:, :s.n].T @ xs[it.offset:it.offset + it.m])))
    return max(forces * s.mode_size, 1e-300)


def walk_slip(s: NewtonSystem, b: np.ndarray, x: np.ndarray, xv, r) -> bool:
    """2D, every active node slipping and a floating body unheld: :func:`_balance_slip` on each frictional
    interface, for the rigid motions the active normal rows leave free (the others are balanced by the normal
    pressures whatever the friction does). Whether any interface's sets were walked."""
    n, rigid = s.n, s.rigid
    ra = exact_residual(s, xv, r)
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


def unheld_reason(floating: list, ifs: list[InterfaceState], rigid: np.ndarray, ru: np.ndarray, f: np.ndarray,
                  n: int) -> str:
    """Why the active sets leave a floating body (of ``floating``) free along a loaded rigid motion: the body,
    the motion with the largest unbalanced force or moment rigid^T ru (``ru`` the residual of the equilibrium
    rows; N/m for a translation in plane scenes, N m/m for a rotation), the load's component rigid^T f along it,
    and what the body's contact nodes do (none closed, all slipping, frictionless against a tangential load, or
    closed but not holding this motion)."""
    labels = [(b, nm) for b in floating for nm in b.names]
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


def check_load(floating: list, ifs: list[InterfaceState], f: np.ndarray, where: str) -> None:
    """Stop with a SolverError naming the body and the rigid motion when no admissible contact forces
    balance the load on the free rigid motions of the floating bodies ``floating``: an LP for lam_n >= 0,
    |lam_t| <= g_c (Tresca) or F_c lam_n (Coulomb), lam_t = 0 (frictionless) with
    R^T (f + Bn^T lam_n + Bt^T lam_t) = 0 (a necessary condition of (P)). In 3D the disc |lam_t| <= b is
    not linear: it is replaced by the circumscribed regular POLYGON-gon (16: d_k . lam_t <= b for the unit
    vectors d_k at the angles 2 pi k / 16), which contains the disc, so the LP is a relaxation and the
    refusal only fires for loads that no admissible traction balances. A load between the two (at most
    1/cos(pi/16) - 1 = 2 % above the capacity, in the worst direction) passes the check, and the solve
    itself then fails (the sets leave the body unheld, or they cycle)."""
    from scipy.optimize import linprog
    R = np.hstack([b.modes for b in floating])
    labels = [(b, nm) for b in floating for nm in b.names]
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


def _load_lp(ifs: list[InterfaceState], R: np.ndarray) -> tuple[list, list, list, list, int]:
    """The unknowns of :func:`check_load`'s LP per interface (lam_n >= 0 of the kept nodes, then
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
                    ub_poly.append((j1, j2, ca, sa, jn, _node_friction(it)[kidx], np.zeros(len(kidx))))
        elif it.law.kind == "tresca":
            cols_eq.append((it.Bt[kidx] @ R).T)
            bounds += [(-float(g), float(g)) for g in it.bound0[kidx]]
            nvar += len(kidx)
        elif it.law.kind == "coulomb":
            cols_eq.append((it.Bt[kidx] @ R).T)
            bounds += [(None, None)] * len(kidx)
            jt = np.arange(nvar, nvar + len(kidx))
            nvar += len(kidx)
            ub_rows += [(a, b_, float(f)) for a, b_, f in zip(jt, jn, _node_friction(it)[kidx])]
    return cols_eq, bounds, ub_rows, ub_poly, nvar


def _node_friction(it: InterfaceState) -> np.ndarray:
    """The Coulomb friction coefficient of each node of an interface (a number or one per node)."""
    return np.broadcast_to(np.asarray(it.law.friction, dtype=float), (it.m,))


def _friction_inequalities(ub_rows: list, ub_poly: list, nvar: int, k: int, sigma: float):
    """The inequality rows of the friction bounds of :func:`check_load`'s LP (in the unknowns scaled
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
        vv += [np.full(len(j1), ca), np.full(len(j1), sa)] + ([-np.broadcast_to(F, len(j1))] if jn_ is not None
                                                              else [])
        bb.append(rhs / sigma)
        nrow += len(j1)
    rr = np.concatenate([np.atleast_1d(np.asarray(a)) for a in rr])
    cc = np.concatenate([np.atleast_1d(np.asarray(a)) for a in cc])
    vv = np.concatenate([np.atleast_1d(np.asarray(a, dtype=float)) for a in vv])
    Aub = sp.csr_matrix((vv, (rr, cc)), shape=(nrow, nvar + 2 * k))
    bub = np.concatenate(bb)
    return Aub, bub
