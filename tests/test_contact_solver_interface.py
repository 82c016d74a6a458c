"""The contact solvers behind one interface: every contact method of the scene's choice list has a solver class
implementing :class:`ngs_geomech.contact.base.ContactSolverBase`, built by the one factory from the options; the
options check their choice lists."""

from __future__ import annotations

import pytest

from ngs_geomech.contact.base import ContactSolverBase
from ngs_geomech.contact.choices import LINEAR_SOLVERS, METHODS
from ngs_geomech.contact.factory import SOLVERS, build_contact_solver
from ngs_geomech.contact.laws import ContactOptions
from ngs_geomech.scene.model import ContactMechanics


def test_every_method_has_a_solver():
    assert tuple(SOLVERS) == METHODS
    assert ContactMechanics.__dataclass_fields__["method"].default == METHODS[0]


@pytest.mark.parametrize("method", METHODS)
def test_factory_builds_the_method_s_solver(method):
    solver = build_contact_solver([], ContactOptions(method=method, linear="direct"), modulus=1e9)
    assert isinstance(solver, SOLVERS[method]) and isinstance(solver, ContactSolverBase)
    if method != "uzawa":
        assert solver.method == method and solver.linear == "direct"


@pytest.mark.parametrize("key, value", [("method", "newton"), ("linear", "multigrid")])
def test_options_check_their_choice_lists(key, value):
    with pytest.raises(ValueError, match=value):
        ContactOptions(**{key: value})
    assert "condensed" in LINEAR_SOLVERS
