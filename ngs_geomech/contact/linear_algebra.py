"""Linear algebra shared by the contact solvers (:mod:`.solver` and the condensed path :mod:`.condensed`): which
interface nodes carry no unknown multiplier, and whether a bulk matrix is symmetric."""

from __future__ import annotations

import numpy as np


def drop_prescribed_nodes(ifs: list, free: np.ndarray, n: int) -> None:
    """Take out of ``keep`` the nodes whose normal constraint involves only prescribed displacements (a
    foundation's end node on a boundary with u_n given): its multiplier would be undetermined (1e21 Pa was
    reported, balanced by an equal support reaction); the support carries that load."""
    freef = np.asarray(free, dtype=float)
    for it in ifs:
        absB = abs(it.Bn[:, :n])
        it.keep = it.keep & ((absB @ freef) > 1e-10 * (absB @ np.ones(n)))


def is_symmetric(matrix) -> bool:
    """Whether the bulk matrix K is symmetric (K x = K^T x for a random x, to 1e-12 relative)."""
    x = matrix.CreateColVector()
    x.FV().NumPy()[:] = np.random.default_rng(0).standard_normal(len(x))
    y1, y2 = matrix.CreateColVector(), matrix.CreateColVector()
    y1.data = matrix * x
    y2.data = matrix.T * x
    a, d = y1.FV().NumPy(), y1.FV().NumPy() - y2.FV().NumPy()
    return bool(np.linalg.norm(d) <= 1e-12 * max(float(np.linalg.norm(a)), 1e-300))
