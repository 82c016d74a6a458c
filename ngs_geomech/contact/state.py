"""The state of a contact solve (:mod:`.solver`): one interface's operator, law and current nodal sets
(:class:`InterfaceState`) and the history of a solve (:class:`ContactInfo`).

Units: multipliers Pa, gaps m, augmentations Pa/m.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .forms import ContactOperator
from .laws import ContactLaw


@dataclass
class ContactInfo:
    """History of one contact solve: per iteration the numbers of nodes in contact, sticking and slipping
    and of set changes; the final complementarity residuals; wall time and factorizations."""

    iterations: int = 0
    active: list = field(default_factory=list)
    stick: list = field(default_factory=list)
    slip: list = field(default_factory=list)
    changes: list = field(default_factory=list)
    max_penetration: float = 0.0
    min_pressure: float = 0.0
    wall_s: float = 0.0
    factorizations: int = 0
    coulomb_fixed_point_passes: int = 0
    """>0: Coulomb was solved by the fixed point of Tresca problems after the active sets cycled (passes)."""
    penalty_iterations: int = 0
    unheld_sets: int = 0
    reused_solves: int = 0
    exact_start_failed: bool = False
    """A cold solve whose exact start failed and that was solved again from the penalty start."""
    cholesky_factorizations: int = 0
    """Of ``factorizations``: the symmetric quasi-definite companions factored by sparse Cholesky."""
    woodbury_columns: int = 0
    newton_residual: list = field(default_factory=list)
    gmres_iterations: list = field(default_factory=list)
    """linear="iterative": the GMRES iterations of every Newton-step solve (:mod:`.krylov`)."""
    amg_setups: int = 0
    """linear="iterative": the AMG hierarchies built (one per solve; later Newton steps refresh its operators)."""
    condensed_dofs: int = 0
    """linear="condensed": the surface dofs of the condensed problem (:mod:`.condensed`)."""
    candidate_passes: int = 0
    """linear="condensed": the candidate sets tried (1 when the first held every node in contact)."""
    condensed_fallback: bool = False
    """linear="condensed": the condensed path could not take the problem and the sparse direct path solved it."""
    communication: dict = field(default_factory=dict)
    """Distributed solves (:mod:`.distributed`): the wall time (s) and the numbers (8-byte values per rank) of the
    reductions and gathers of replicated arrays, and the PETSc set-up and GMRES times (s)."""


class InterfaceState:
    """One interface's operator, law and current sets inside the solver."""

    def __init__(self, op: ContactOperator, law: ContactLaw, c_scale: float, offset: int, ndof: int):
        self.op, self.law = op, law
        keep = op.constrained
        self.keep = keep
        m = op.size
        # first multiplier index: the normal block, then the tangential block(s) at offset + m (3D: t1) and
        # offset + 2 m (3D: t2 = n x t1)
        self.offset = offset
        self.dim3 = op.Bt2 is not None
        self.blocks = 3 if self.dim3 else 2
        pad = sp.csr_matrix((m, ndof - op.Bn.shape[1]))
        self.Bn = sp.hstack([op.Bn, pad]).tocsr()
        self.Bt = sp.hstack([op.Bt, pad]).tocsr()
        self.Bt2 = sp.hstack([op.Bt2, pad]).tocsr() if self.dim3 else None
        # the equilibrium rows' entries -Bn^T lam_n - Bt^T lam_t (- Bt2^T lam_t2) (constant): COO rows, cols, values
        cs = [B.tocoo() for B in (self.Bn, self.Bt, self.Bt2) if B is not None]
        self.transposed = (np.concatenate([c.col for c in cs]).astype(np.int64),
                           np.concatenate([c.row + offset + k * m for k, c in enumerate(cs)]).astype(np.int64),
                           -np.concatenate([c.data for c in cs]))
        w = np.maximum(op.weight, 1e-300)
        if law.augmentation is not None:
            self.c = np.full(m, float(law.augmentation))
        else:
            self.c = c_scale / np.maximum(op.length, 1e-300)
        # tangential augmentation: the modulus over the extent of the side (E/h cycled between stick and
        # slip in the Tresca block test; E/L converged in 5-6 iterations)
        extent = float(np.max(np.ptp(op.coords, axis=0))) if m > 1 else 1.0
        self.ct = (np.full(m, float(law.augmentation)) if law.augmentation is not None
                   else np.full(m, c_scale / max(extent, 1e-300)))
        self.w = w                         # nodal weights: g_j / w_j is the nodal gap (m)
        if law.kind == "tresca":
            self.bound0 = np.broadcast_to(np.asarray(law.slip_bound, dtype=float), (m,)).copy()
        else:
            self.bound0 = np.zeros(m)
        gap = op.g0 / w
        # start: the nodes touching first (smallest nodal gap, or in initial overlap)
        gmin = float(np.min(gap[keep])) if keep.any() else 0.0
        self.active = keep & (gap <= max(gmin, 0.0) + 1e-3 * op.length)
        self.stick = self.active & (law.kind != "frictionless")
        self.slip = np.zeros(m, dtype=bool)
        self.sign = np.zeros(m)
        # 3D slip rows: the unit direction e = z / |z| and kappa = b / max(|z|, b) of the current iterate
        self.dir = np.zeros((m, 2))
        self.kappa = np.zeros(m)
        self.dropped = np.zeros((self.blocks, m), dtype=bool)
        """The rows (normal, t1 (, t2) per node) left out as dependent on the free dofs through the supports
        (:func:`.linear_algebra.dependent_rows`): a left-out exact tangential row's multiplier is 0."""
        self.flips = np.zeros(m, dtype=int)     # contact <-> separation switches of each node in this solve

    @property
    def m(self) -> int:
        return self.op.size
