"""Validation of the names and numbers of a scene that hold whatever the physics: names usable as file names and
as region, boundary and interface names, and temperatures at or above absolute zero."""

from __future__ import annotations

import re

from ..errors import Problem
from ..scene.model import Scene
from ..scene.names import name_problem
from ..scene.units import KELVIN

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
"""An identifier: a letter first, then letters, digits and underscores."""


def check_names(scene: Scene, problems: list[Problem]) -> None:
    """Every name that becomes part of a file name follows :data:`ngs_geomech.scene.names.RULE`; block, boundary and
    interface names are also identifiers (region and boundary names of the mesh; ``__`` joins an interface and
    a block name in a contact side's name)."""
    _check_name("scene.name", scene.scene.name, problems)
    if not scene.blocks:
        problems.append(Problem("blocks", "a scene needs at least one block"))
    seen = set()
    for i, b in enumerate(scene.blocks):
        _check_name(f"blocks[{i}].name", b.name, problems, identifier=True)
        if b.name in seen:
            problems.append(Problem(f"blocks[{i}].name", f"block name {b.name!r} is used twice"))
        seen.add(b.name)
        for bname in b.boundaries:
            _check_name(f"blocks[{i}].boundaries.{bname}", bname, problems, identifier=True)
        for j, ename in enumerate(b.edges or []):
            if ename:                   # an unnamed side
                _check_name(f"blocks[{i}].edges[{j}]", ename, problems, identifier=True)
        for j, seg in enumerate(b.segments or []):
            if seg is not None and seg.name:
                _check_name(f"blocks[{i}].segments[{j}].name", seg.name, problems, identifier=True)
        for key in ("solids", "faces"):
            for fname, name in getattr(b, key).items():
                _check_name(f"blocks[{i}].{key}.{fname}", name, problems, identifier=True)
    for i, cut in enumerate(scene.cuts):
        _check_name(f"cuts[{i}].name", cut.name, problems, identifier=True)
        for j, pair in enumerate(cut.parts):
            for name in pair:
                if name:                # '' removes the part
                    _check_name(f"cuts[{i}].parts[{j}]", name, problems, identifier=True)
    inames = set()
    for i, itf in enumerate(scene.interfaces):
        _check_name(f"interfaces[{i}].name", itf.name, problems, identifier=True)
        if itf.name in inames or itf.name in seen:
            problems.append(Problem(f"interfaces[{i}].name", f"name {itf.name!r} is used twice"))
        inames.add(itf.name)
    for i, pr in enumerate(scene.output.probes):
        _check_name(f"output.probes[{i}].name", pr.name, problems)


def _check_name(item: str, name, problems: list[Problem], identifier: bool = False) -> None:
    """One name: the file-name rule, and with ``identifier`` a letter first, then letters, digits and single
    underscores."""
    why = name_problem(name)
    if why is None and identifier and (not NAME.fullmatch(name) or "__" in name):
        why = f"{name!r} must start with a letter and hold letters, digits and single underscores"
    if why is not None:
        problems.append(Problem(item, why))


def check_temperatures(scene: Scene, problems: list[Problem]) -> None:
    """Every temperature given as a number lies at or above absolute zero in the scene's temperature_unit
    (0 K = -273.15 degC). Expressions are evaluated at the mesh points and are not checked here."""
    unit = scene.scene.temperature_unit
    zero = -KELVIN if unit == "C" else 0.0
    given: list[tuple[str, object]] = [("initial.temperature", scene.initial.temperature)]
    given += [(f"initial.regions.{n}", v) for n, v in scene.initial.regions.items()]
    for name, bc in scene.boundary_conditions.items():
        given += [(f"boundary_conditions.{name}.{k}", getattr(bc, k)) for k in ("temperature", "ambient_temperature")]
    for name, mat in scene.materials.items():
        given += [(f"materials.{name}.{k}", getattr(mat, k))
                  for k in ("reference_temperature", "stress_free_temperature", "phase_change_temperature")]
    for item, v in given:
        if isinstance(v, (int, float)) and not isinstance(v, bool) and v < zero:
            problems.append(Problem(item, f"{v:g} {'degC' if unit == 'C' else 'K'} is below absolute zero "
                                    f"({zero:g} {'degC' if unit == 'C' else 'K'}; the scene's temperatures are in "
                                    f"scene.temperature_unit = {unit!r})"))
