"""The nodal rows and sets of the active-set (semi-smooth Newton) iteration of :mod:`.solver`: the
multiplier rows of the current sets in the saddle-point matrix (:func:`assemble_rows`), the new sets from an
iterate (:func:`new_sets`) and the fixed multipliers of the iterate (:func:`fixed_multipliers`).

The rows of a 3D interface (its operator has ``Bt2``): lam_t,j, s~_j and z_j are vectors of R^2 (components along
t1, t2 = n x t1), the cone is |lam_t,j| <= b_j, and the slip condition lam_t = b z / |z| is nonlinear. The slip
rows are the Newton linearization at the current iterate (z_k, b_k) of the projection form of C_t,
lam_t - b z / max(b, |z|) (C_t of :mod:`.solver` divided by max(b, |z|): the same zeros), with e = z_k / |z_k|,
T = I - e e^T (the projection onto the plane normal to the slip direction) and kappa = b_k / max(|z_k|, b_k)
(b_k = g_c, or F_c lam_n,k as in the 2D rows):

    lam_t,j - kappa T (lam_t,j - c_t s~_j) = g_c e (Tresca),     ... = F_c lam_n,j e (Coulomb)

(d(b z/|z|)/dz = b/|z| T). In 2D T = 0 and these are the 2D rows of :mod:`.solver`, so the 2D iteration is
unchanged. Why this form rather than the full Newton rows of HSW's max(b, |z|) lam_t - b z, whose derivative
|z| dlam + lam_k e^T dz - b dz - z db carries lam_k: the two coincide when lam_k = b e (at the solution), but for
lam_k off the cone (just after stick -> slip) those rows need lam_k damped back into the cone (HSW's modified
algorithm) to keep the 2 x 2 block regular, while here I - kappa T has the eigenvalues 1 (along e) and
1 - kappa in [0, 1) across, and the across direction always keeps the penalty-like coupling kappa c_t T s~ (a
stick row in the limit kappa -> 1): the block is regular for any iterate, and nothing of lam_k enters. A node
forced to slip with |z_k| < b (the twice-switched nodes of :func:`new_sets`) gets kappa = 1: lam_t . e = b with
no slip across e.
"""

from __future__ import annotations

import numpy as np

from .laws import slip_bound
from .state import InterfaceState
from .steps import NewtonSystem


def assemble_rows(s: NewtonSystem, x: np.ndarray, penalty: bool) -> np.ndarray:
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


def _rows_2d(it: InterfaceState, seg: dict, vals: np.ndarray, b: np.ndarray, x: np.ndarray, A: np.ndarray,
             pen: bool) -> None:
    """The tangential rows of a 2D frictional interface for the current sets: stick rows -Bt u (- weight / ct
    lam_t) = 0; Coulomb slip rows lam_t - F sign lam_n = 0; Tresca slip rows lam_t = g_c sign; open nodes
    lam_t = 0."""
    ot = it.offset + it.m
    stick = A & it.stick
    slip = A & it.slip
    # an exact stick row left out (dependent through the supports, :func:`.linear_algebra.dependent_rows`) fixes its
    # multiplier at 0 like an open node's row: the supports carry that traction (slip rows stay: they are regular)
    exact_stick = stick & ~(it.dropped[1] & (not pen))
    vals[seg["rows_t"]] = seg["rows_t_values"] * exact_stick[seg["rows_t_node"]]
    vals[seg["diag_t"]] = np.where(exact_stick & (not pen), 0.0, -it.w / it.ct)
    coulomb_slip = slip if it.law.kind == "coulomb" else np.zeros(it.m, dtype=bool)
    vals[seg["couple"]] = np.where(coulomb_slip, it.w / it.ct * it.law.friction * it.sign, 0.0)
    fixed_t = np.where(slip & (it.law.kind == "tresca"), it.bound0 * it.sign, 0.0)
    b[ot:ot + it.m] = -it.w / it.ct * fixed_t
    x[ot:ot + it.m] = np.where(exact_stick | coulomb_slip, x[ot:ot + it.m], fixed_t)


def _rows_3d(it: InterfaceState, seg: dict, vals: np.ndarray, b: np.ndarray, x: np.ndarray, A: np.ndarray,
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
    # an exact row left out (dependent on the free dofs through the supports, :func:`.linear_algebra.dependent_rows`)
    # fixes its multiplier at 0: the supports carry that part (the penalty rows are regular as they are)
    for k in range(2):
        out = it.dropped[1 + k] & A & (not pen)
        R[:, k, :] = np.where(out[:, None], 0.0, R[:, k, :])
        L[:, k, :] = np.where(out[:, None], 0.0, L[:, k, :])
        L[:, k, k] = np.where(out, -s, L[:, k, k])
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


def new_sets(s: NewtonSystem, x: np.ndarray, lam_n: list, lam_t: list, penalty: bool, it_nr: int) -> tuple[int, float]:
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


def _sets_2d(it: InterfaceState, lam_n: np.ndarray, lam_t: np.ndarray, u: np.ndarray, pen: bool) -> int:
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


def _sets_3d(it: InterfaceState, lam_n: np.ndarray, lam_t: np.ndarray, u: np.ndarray, pen: bool) -> tuple[int, float]:
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


def fixed_multipliers(s: NewtonSystem, x: np.ndarray) -> np.ndarray:
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
