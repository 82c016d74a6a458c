"""The interface every contact solver implements (:class:`ContactSolverBase`): the semi-smooth Newton solver
(:class:`.solver.ContactSolver`), its penalty variant (:class:`.solver.PenaltyContactSolver`) and Uzawa's algorithm
(:class:`.uzawa.UzawaSolver`); :func:`.factory.build_contact_solver` picks one by the options' method."""

from __future__ import annotations

import abc

import numpy as np


class ContactSolverBase(abc.ABC):
    """A contact solver of the interfaces ``items`` [(ContactOperator, ContactLaw)]: :meth:`solve` for the current
    elastic data; after it ``multipliers`` holds per interface (lam_n, lam_t) (Pa) and ``infos`` the history of
    every solve; :meth:`capture` and :meth:`restore` carry the warm start of the next solve as plain arrays (a
    checkpoint's)."""

    items: list
    multipliers: list
    infos: list
    warm_starts = False
    """Whether the solver can start from given nodal sets (``warm_start(ndof, sets)``, ``cold_start()``)."""

    @classmethod
    @abc.abstractmethod
    def from_options(cls, items: list, options, *, modulus: float, floating=(), forms=None) -> ContactSolverBase:
        """The solver of ``items`` with :class:`.laws.ContactOptions` ``options`` (``modulus`` Pa, ``floating``
        the semi-coercive bodies, ``forms`` the elastic forms of the matrix)."""

    @abc.abstractmethod
    def solve(self, matrix, rhs, free: np.ndarray, x0: np.ndarray, where: str = "") -> tuple[np.ndarray, object]:
        """The displacement vector (X) solving K u = f + B^T lam with the contact conditions (``matrix`` K and
        ``rhs`` f on X, ``free`` the free dofs, ``x0`` the prescribed values), and the solve's history."""

    @abc.abstractmethod
    def capture(self) -> dict:
        """The warm start of the next solve as plain arrays."""

    @abc.abstractmethod
    def restore(self, ndof: int, state: dict) -> None:
        """Start the next solve from a state of :meth:`capture` (``ndof``: the size of X)."""
