"""The one place a contact solver is built: :func:`build_contact_solver` picks the solver class for the options'
method (:class:`.uzawa.UzawaSolver` for "uzawa", :class:`.solver.ContactSolver` otherwise); the scene's keys become
those options in :func:`.problem.contact_options`."""

from __future__ import annotations

from .forms import ContactOperator
from .laws import ContactLaw, ContactOptions
from .solver import ContactSolver
from .uzawa import UzawaSolver


def build_contact_solver(items: list[tuple[ContactOperator, ContactLaw]], options: ContactOptions, *,
                         modulus: float, floating=(), forms=None):
    """The contact solver of the interfaces ``items`` [(operator, law)] with ``options``: ``modulus`` (Pa) the
    scale of the default augmentations and Uzawa steps, ``floating`` the semi-coercive bodies, ``forms`` the
    elastic forms of the matrix (the iterative Newton steps' AMG)."""
    if options.method == "uzawa":
        return UzawaSolver(items, modulus=modulus, floating=floating, maxit=options.uzawa_max_steps,
                           rho=options.uzawa_step, settings=options.uzawa_settings)
    return ContactSolver(items, modulus=modulus, floating=floating, forms=forms, options=options)
