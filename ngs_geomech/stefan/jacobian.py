"""The interface of the linear solvers of the Stefan Newton steps (:mod:`ngs_geomech.stefan.solver`).

Every Newton matrix of the Stefan solvers has the form

    M = diag(d) + sum_g (K_g - diag K_g) diag(w_g)        on the free nodes,

d = mc/dt + sum_g diag(K_g) wd_g, with K_g the stiffness matrix of material group g for unit conductivity, mc the
lumped mass times a nodal heat capacity (J/(m^3 K)) and w_g, wd_g nodal column weights (W/(m K): the derivatives
of the Kirchhoff maps): column j belongs to node j alone. A strategy solves M x = b for such
matrices, one after the other, reusing what it can between them. The strategies: :class:`ColumnJacobian`
(:mod:`ngs_geomech.stefan.column_jacobian`; serial, one sparse LU kept over many matrices with low-rank column
updates) and :class:`KrylovJacobian` (:mod:`ngs_geomech.stefan.krylov_jacobian`; distributed meshes or
``linear="iterative"``, preconditioned GMRES).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from .forms import StefanForms


class NewtonJacobian(ABC):
    """A linear solver for the Newton matrices M of the module docstring, on the free nodes of ``forms``.

    ``free`` (indices of the free nodes) and ``nF`` (their number) fix the numbering of the arrays of
    :meth:`solve`; ``factorizations`` counts the expensive set-ups (sparse LU factorizations, preconditioner
    builds), ``corrections`` the extra solves of a low-rank update (0 when the strategy makes none); the Stefan
    solvers report their differences per step.
    """

    def __init__(self, forms: StefanForms):
        self.forms = forms
        self.free = np.nonzero(forms.free)[0]
        self.nF = len(self.free)
        self.factorizations = 0
        self.corrections = 0

    @abstractmethod
    def solve(self, mc: np.ndarray, wd: np.ndarray, w: np.ndarray, b: np.ndarray, dt: float,
              where: str) -> np.ndarray:
        """Solve M x = b on the free nodes, M = diag(d) + sum_g (K_g - diag K_g) diag(w_g) with the diagonal
        d = ``mc`` / dt + sum_g diag(K_g) ``wd``_g (``mc``, ``b``: free nodes; ``wd``, ``w``: free nodes x groups;
        the diagonal weights ``wd`` may differ from ``w``). The unknowns of nodes with w_j = 0 may come out as 0
        (such a column has no off-diagonal part: the other unknowns do not depend on them). ``where`` names the
        step in error messages (SolverError when M cannot be solved)."""

    @abstractmethod
    def capture(self) -> dict:
        """The reuse state between solves as plain arrays ({} when there is nothing to keep)."""

    @abstractmethod
    def restore(self, state: dict) -> None:
        """Continue from a state of :meth:`capture`: the next solves are those of an uninterrupted run."""
