"""Validation of the frictional-heating keys of contact interfaces and foundations (``frictional_heating``,
``heat_partition``; :mod:`ngs_geomech.coupling.frictional`): a coupled scene, a frictional law on a contact,
a partition that applies to the contact's kind, and no remeshing that would drop the heat owed to the bodies.
The materials an effusivity partition reads are checked when the run is built (they are found from the mesh:
the regions along each side)."""

from __future__ import annotations

from ..errors import Problem
from ..scene.model import ContactMechanics, Scene


def _contacts(scene: Scene) -> list[tuple[str, ContactMechanics, str]]:
    """(key prefix, keys, kind) of every interface and foundation: kind 'glued', 'contact' or 'foundation'."""
    out = [(f"interfaces[{i}] ({itf.name})", itf, itf.type) for i, itf in enumerate(scene.interfaces)]
    out += [(f"boundary_conditions.{n}.foundation", bc.foundation, "foundation")
            for n, bc in scene.boundary_conditions.items() if bc.foundation is not None]
    return out


def check_frictional_heating(scene: Scene, problems: list[Problem]) -> None:
    """``frictional_heating`` only on a contact (interface of type 'contact' or foundation) with a frictional law
    (Coulomb with a coefficient that is not 0 everywhere, or Tresca) in a scene with physics.coupling 'staggered'
    or 'iterated' and meshes that are not remade during the run; ``heat_partition`` only with it, and not
    'effusivity' on a foundation (the rigid foundation has no material)."""
    ph = scene.physics
    zone = scene.adaptivity is not None and "contact_zone" in scene.adaptivity.indicators
    for p, c, kind in _contacts(scene):
        if not c.frictional_heating:
            if c.heat_partition is not None:
                problems.append(Problem(f"{p}.heat_partition", "applies with frictional_heating = true"))
            continue
        key = f"{p}.frictional_heating"
        if kind == "glued":
            problems.append(Problem(key, "applies to type = 'contact' interfaces and foundations: a glued "
                                    "interface does not slide"))
            continue
        if ph.coupling not in ("staggered", "iterated"):
            problems.append(Problem(key, "the frictional heat enters the heat (or Stefan) step of a coupled run: it "
                                    f"needs physics.coupling = 'staggered' or 'iterated', got {ph.coupling!r}"))
        if c.law == "frictionless" or (c.law == "coulomb" and isinstance(c.friction, (int, float))
                                       and c.friction == 0):
            problems.append(Problem(key, "needs a frictional law (law = 'coulomb' with a coefficient > 0, or "
                                    "'tresca'): frictionless sliding dissipates nothing"))
        if zone:
            problems.append(Problem(key, "is not available on meshes that follow the contact zones ([adaptivity] "
                                    "indicators 'contact_zone'): the slip state and the heat still owed to the "
                                    "bodies are not carried across the remeshes"))
        if kind == "foundation" and c.heat_partition == "effusivity":
            problems.append(Problem(f"{p}.heat_partition", "'effusivity' needs the materials of both sides; the "
                                    "rigid foundation is not modelled: give the share entering the body as a "
                                    "number (default 1)"))
