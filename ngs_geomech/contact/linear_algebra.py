"""Linear algebra shared by the contact solvers (:mod:`.solver` and the condensed path :mod:`.condensed`): which
interface nodes carry no unknown multiplier, and whether a bulk matrix is symmetric."""

from __future__ import annotations

import numpy as np


def drop_prescribed_nodes(ifs: list, free: np.ndarray, n: int) -> None:
    """Take out of ``keep`` the nodes whose normal constraint involves only prescribed displacements (a
    foundation's end node on a boundary with u_n given): its multiplier would be undetermined (1e21 Pa was
    reported, balanced by an equal support reaction); the support carries that load. In 3D mark the nodes whose
    rows are dependent on the free dofs (``t_supported``, :func:`supported_tangents`)."""
    freef = np.asarray(free, dtype=float)
    for it in ifs:
        absB = abs(it.Bn[:, :n])
        it.keep = it.keep & ((absB @ freef) > 1e-10 * (absB @ np.ones(n)))
        if it.dim3 and it.law.kind != "frictionless":
            it.t_supported = supported_tangents(it, freef, n)


def supported_tangents(it, freef: np.ndarray, n: int) -> np.ndarray:
    """3D: the nodes whose three rows (normal, t1, t2) are linearly dependent on the free dofs (bool per node): a
    node on a roller whose direction is a combination of n, t1, t2 (the supports hold that relative motion
    already), whose exact stick rows would make the matrix singular."""
    rows = [B[:, :n].multiply(freef[None, :]).tocsr() for B in (it.Bn, it.Bt, it.Bt2)]
    G = np.empty((it.m, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            G[:, a, b] = G[:, b, a] = np.asarray(rows[a].multiply(rows[b]).sum(axis=1)).ravel()
    ev = np.linalg.eigvalsh(G)
    return ev[:, 0] <= 1e-12 * np.maximum(ev[:, 2], 1e-300)


def is_symmetric(matrix) -> bool:
    """Whether the bulk matrix K is symmetric (K x = K^T x for a random x, to 1e-12 relative)."""
    x = matrix.CreateColVector()
    x.FV().NumPy()[:] = np.random.default_rng(0).standard_normal(len(x))
    y1, y2 = matrix.CreateColVector(), matrix.CreateColVector()
    y1.data = matrix * x
    y2.data = matrix.T * x
    a, d = y1.FV().NumPy(), y1.FV().NumPy() - y2.FV().NumPy()
    return bool(np.linalg.norm(d) <= 1e-12 * max(float(np.linalg.norm(a)), 1e-300))
