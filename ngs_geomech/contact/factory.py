"""The one place a contact solver is built: :data:`SOLVERS` maps each contact method of :data:`.choices.METHODS`
to its solver class (all implement :class:`.base.ContactSolverBase`), :func:`build_contact_solver` builds it from
:class:`.laws.ContactOptions`; the scene's keys become those options in :func:`.problem.contact_options`."""

from __future__ import annotations

from .base import ContactSolverBase
from .forms import ContactOperator
from .laws import ContactLaw, ContactOptions
from .solver import ContactSolver, PenaltyContactSolver
from .uzawa import UzawaSolver

SOLVERS: dict[str, type[ContactSolverBase]] = {"ssn": ContactSolver, "penalty": PenaltyContactSolver,
                                               "uzawa": UzawaSolver}
"""The solver class of each contact method (the keys are :data:`.choices.METHODS`)."""


def build_contact_solver(items: list[tuple[ContactOperator, ContactLaw]], options: ContactOptions, *,
                         modulus: float, floating=(), forms=None) -> ContactSolverBase:
    """The contact solver of the interfaces ``items`` [(operator, law)] for ``options.method``: ``modulus`` (Pa) the
    scale of the default augmentations and Uzawa steps, ``floating`` the semi-coercive bodies, ``forms`` the
    elastic forms of the matrix (the iterative Newton steps' AMG)."""
    return SOLVERS[options.method].from_options(items, options, modulus=modulus, floating=floating, forms=forms)
