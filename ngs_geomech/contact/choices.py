"""The choice lists of contact: laws, methods and the Newton steps' linear algebra, declared once (the scene's keys
and the solvers' options validate against them), and the one reading of the contacts' ``method`` keys
(:func:`contact_methods`). No package imports: the scene model reads them without loading the solvers."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

LAWS = ("frictionless", "tresca", "coulomb")
"""Contact laws: Signorini without friction, Tresca (given slip bound g_c), Coulomb (slip bound F_c p)."""
METHODS = ("ssn", "penalty", "uzawa")
"""Contact methods: the semi-smooth Newton (active set) iteration, its penalty rows kept to the end, Uzawa's
algorithm (the seed's reference method for friction)."""
LINEAR_SOLVERS = ("auto", "direct", "iterative", "condensed")
"""The Newton steps' linear algebra: "auto" (condensed in 2D with PARDISO, else direct), sparse direct
factorizations, GMRES (Krylov), the problem condensed onto the contact surface."""

AUTO_DOFS = {2: 1_000_000, 3: 20_000}
"""Displacement dofs above which ``solver.linear = "auto"`` solves the contact Newton steps by GMRES (per mesh
dimension). Measured on the 3D Coulomb punch (``studies/scaling``, one thread): direct / GMRES
1.12 / 1.47 s at 3.5k P1 dofs, 8.08 / 6.29 s at 22k P2, 59.8 / 11.2 - 13.9 s at 19k P1, 399 / 67.5 s at 130k P2
(the direct solves factor the 3D saddle point at every Newton step, 6 s at 19k P1 and 50 s at 130k P2). In 2D the
direct solves stay cheap; the value is that of the other systems
(:data:`ngs_geomech.linalg.iterative.AUTO_DOFS`). The GMRES path is :mod:`.krylov`."""


class MethodChoice(NamedTuple):
    """What the ``method`` keys of a scene's contacts ask for: ``solver`` the method of the scene's one contact
    solver (a key of :data:`.factory.SOLVERS`); ``penalty`` per contact whether it keeps its penalty rows to the end
    (:attr:`.laws.ContactLaw.penalty`); ``problems`` (contact name, why) for methods that cannot be solved so."""

    solver: str
    penalty: tuple[bool, ...]
    problems: tuple[tuple[str, str], ...]


def contact_methods(methods: Sequence[str], names: Sequence[str], *, dim: int, mechanics: str) -> MethodChoice:
    """The one reading of the ``method`` keys ``methods`` of a scene's contacts (``names`` name them in messages) in
    a ``dim``-dimensional scene with ``physics.mechanics = mechanics`` ('static', or 'dynamic' and 'viscous', whose
    contacts advance every time step).

    'penalty' marks its own contact: that contact keeps its penalty rows, the others their exact constraints, in one
    semi-smooth Newton solve ('ssn'); in dynamic and viscous mechanics a scene whose contacts all ask for 'penalty'
    is solved by the penalty solver (static mechanics keeps the semi-smooth Newton solver there, with the penalty
    rows of every contact: the same equations). 'uzawa' is the seed's reference algorithm, which solves all
    contacts of a scene at once, in 2D static mechanics: there it must be on every contact or on none."""
    uzawa = [n for n, m in zip(names, methods) if m == "uzawa"]
    problems: list[tuple[str, str]] = []
    if mechanics != "static":
        problems += [(n, f"'uzawa' is not available with physics.mechanics = {mechanics!r}: use 'ssn' or 'penalty'")
                     for n in uzawa]
    if uzawa and len(uzawa) != len(methods):
        other = next(n for n, m in zip(names, methods) if m != "uzawa")
        problems.append((other, f"the Uzawa reference method ({uzawa[0]}) solves all contacts of a scene at once: "
                                "use method = 'uzawa' on every contact or on none"))
    if dim == 3:
        problems += [(n, "the Uzawa reference method is implemented in 2D only: use 'ssn' or 'penalty' in 3D")
                     for n in uzawa]
    penalty = tuple(m == "penalty" for m in methods)
    if uzawa:
        solver = "uzawa"
    elif mechanics != "static" and penalty and all(penalty):
        solver = "penalty"
    else:
        solver = "ssn"
    return MethodChoice(solver, penalty, tuple(problems))
