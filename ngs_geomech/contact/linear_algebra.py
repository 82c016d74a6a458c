"""Linear algebra shared by the contact solvers (:mod:`.solver` and the condensed path :mod:`.condensed`): which
interface nodes carry no unknown multiplier, and whether a bulk matrix is symmetric."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def drop_prescribed_nodes(ifs: list, free: np.ndarray, n: int) -> None:
    """Take out of ``keep`` the nodes whose normal constraint involves only prescribed displacements (a
    foundation's end node on a boundary with u_n given): its multiplier would be undetermined (1e21 Pa was
    reported, balanced by an equal support reaction); the support carries that load. In 3D mark the nodes whose
    rows are dependent on the free dofs (``dropped``, :func:`dependent_rows`)."""
    freef = np.asarray(free, dtype=float)
    for it in ifs:
        absB = abs(it.Bn[:, :n])
        it.keep = it.keep & ((absB @ freef) > 1e-10 * (absB @ np.ones(n)))
        if it.law.kind != "frictionless":
            it.dropped = dependent_rows(it, freef, n)
            it.keep = it.keep & ~it.dropped[0]


def dependent_rows(it, freef: np.ndarray, n: int) -> np.ndarray:
    """Rows (normal, t1 (, t2) per node: a (blocks, m) bool array) to leave out so that the remaining rows are
    linearly independent on the free dofs. Where the interface meets rollers the supports hold some relative
    motions already (a node's motion along the roller's normal, or a combination over the nodes on it): those rows
    are dependent, and exact stick rows there make the matrix singular. Only the rows of nodes that touch a
    prescribed dof can take part (the others' rows are independent: the mortar's D block). Their left null space
    W on the free dofs is taken densely, and k rows with a regular k x k block of W are left out (QR with column
    pivoting, tangential rows first): the rest spans the same forces on the free dofs."""
    m, nb = it.m, it.blocks
    out = np.zeros((nb, m), dtype=bool)
    B = sp.vstack([M[:, :n] for M in (it.Bn, it.Bt, it.Bt2) if M is not None]).tocsr()
    touches = (abs(B) @ (1.0 - freef) > 0).reshape(nb, m).any(axis=0) & it.keep
    if not touches.any():
        return out
    nodes = np.nonzero(touches)[0]
    rows = np.concatenate([nodes + k * m for k in range(nb)])
    sub = B[rows][:, freef > 0]
    sub = sub[:, np.unique(sub.nonzero()[1])].toarray()
    u, sv, _ = np.linalg.svd(sub, full_matrices=True)
    rank = int(np.sum(sv > 1e-10 * max(float(sv.max(initial=0.0)), 1e-300)))
    if rank == len(rows):
        return out
    W = u[:, rank:] * np.repeat([1e-3] + [1.0] * (nb - 1), len(nodes))[:, None]    # tangential rows first
    # loaded when rows are dependent (start-up)
    import scipy.linalg

    pivots = scipy.linalg.qr(W.T, pivoting=True, mode="r")[1][:W.shape[1]]
    out.reshape(-1)[rows[pivots]] = True
    return out


def is_symmetric(matrix) -> bool:
    """Whether the bulk matrix K is symmetric (K x = K^T x for a random x, to 1e-12 relative)."""
    x = matrix.CreateColVector()
    x.FV().NumPy()[:] = np.random.default_rng(0).standard_normal(len(x))
    y1, y2 = matrix.CreateColVector(), matrix.CreateColVector()
    y1.data = matrix * x
    y2.data = matrix.T * x
    a, d = y1.FV().NumPy(), y1.FV().NumPy() - y2.FV().NumPy()
    return bool(np.linalg.norm(d) <= 1e-12 * max(float(np.linalg.norm(a)), 1e-300))
