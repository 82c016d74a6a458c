"""Validation of the contact-conductance keys of an interface (``conductance``, ``conductance_coefficient``,
``conductance_exponent``, ``gap_conductivity``, ``minimum_gap``, ``emissivities``, ``radiation``;
:mod:`ngs_geomech.heat.conductance`): they apply to contact interfaces of scenes with heat; one law for the closed
parts; a power law in the contact pressure needs the mechanics' pressure at every coupled step; a table of
increasing pressures and non-negative conductances; 'perfect' contact between touching blocks and alone;
exact radiation only where Newton's method solves the heat step (not in Stefan scenes)."""

from __future__ import annotations

from ..errors import Problem
from ..geometry.assemble import GeometryModel
from ..scene.model import Interface, Scene
from .check_materials import stefan_scene

KEYS = ("conductance", "conductance_coefficient", "conductance_exponent", "gap_conductivity", "emissivities")


def check_conductance(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """The contact-conductance keys of every interface (module docstring)."""
    for i, itf in enumerate(scene.interfaces):
        given = [k for k in KEYS if getattr(itf, k) is not None]
        if itf.radiation is not None and itf.emissivities is None:
            problems.append(Problem(f"interfaces[{i}] ({itf.name}).radiation", "applies with emissivities only"))
        if itf.minimum_gap is not None and itf.gap_conductivity is None:
            problems.append(Problem(f"interfaces[{i}] ({itf.name}).minimum_gap", "applies with gap_conductivity "
                                    "only (the floor of k_gap / g)"))
        if not given:
            continue
        p = f"interfaces[{i}] ({itf.name})"
        cs = geo.contacts.get(itf.name)
        if cs is None:
            problems.append(Problem(f"{p}.{given[0]}", "applies to contact interfaces (type = 'contact'); a glued "
                                    "interface shares its nodes (the temperature is continuous)"))
            continue
        if not scene.physics.thermal:
            problems.append(Problem(f"{p}.{given[0]}", "the scene solves no heat problem (physics.thermal is off)"))
            continue
        _check_law(scene, itf, p, cs.initial_gap, problems)
        if itf.radiation == "linearized" and scene.physics.thermal == "steady":
            problems.append(Problem(f"{p}.radiation", "'linearized' radiation takes h_rad from the previous step, "
                                    "which a steady solve does not have: use 'exact' (Newton's method)"))
        if itf.radiation == "exact" and stefan_scene(scene):
            problems.append(Problem(f"{p}.radiation", "'exact' radiation needs Newton's method on T^4, which the "
                                    "phase-change (Stefan) solver does not take: set radiation = 'linearized'"))
        if itf.thermal_penalty is not None and itf.conductance != "perfect":
            problems.append(Problem(f"{p}.thermal_penalty", "applies to perfect contact only (no conductance keys): "
                                    "the interface passes heat by its conductance"))


def _check_law(scene: Scene, itf: Interface, p: str, initial_gap: bool, problems: list[Problem]) -> None:
    """One law for the closed parts; a power law with its two keys and the mechanics' pressure; a valid table;
    'perfect' alone and between touching blocks."""
    c = itf.conductance
    if c is not None and itf.conductance_coefficient is not None:
        problems.append(Problem(f"{p}.conductance", "give either conductance or the power law "
                                "conductance_coefficient / conductance_exponent, not both"))
    if (itf.conductance_coefficient is None) != (itf.conductance_exponent is None):
        missing = "conductance_exponent" if itf.conductance_exponent is None else "conductance_coefficient"
        problems.append(Problem(f"{p}.{missing}", "the power law h = C p^m needs both conductance_coefficient (C) "
                                "and conductance_exponent (m)"))
    if itf.conductance_coefficient is not None and not _follows_mechanics(scene):
        problems.append(Problem(f"{p}.conductance_coefficient", "the power law h = C p^m needs the contact pressure of "
                                "the mechanics at every step: physics.mechanics with physics.coupling = "
                                "'staggered' or 'iterated' (a transient heat problem); without mechanics give a "
                                "number (conductance)"))
    if isinstance(c, list):
        _check_table(c, f"{p}.conductance", problems)
    if (initial_gap and c not in (None, "perfect") and itf.gap_conductivity is None and itf.emissivities is None
            and not _follows_mechanics(scene)):
        problems.append(Problem(f"{p}.conductance", "the interface has an initial gap and nothing closes it (no "
                                "mechanics coupled to the heat problem): the contact conductance would never act; "
                                "add gap_conductivity or emissivities for the open gap, or couple the mechanics"))
    if c == "perfect":
        others = [k for k in ("conductance_coefficient", "gap_conductivity", "emissivities")
                  if getattr(itf, k) is not None]
        if initial_gap:
            problems.append(Problem(f"{p}.conductance", "'perfect' contact needs touching blocks: across an initial "
                                    "gap give a number, a table or a power law (with gap_conductivity for the open "
                                    "gap)"))
        elif others:
            problems.append(Problem(f"{p}.{others[0]}", "perfect contact (conductance = 'perfect') is the limit of "
                                    "an infinite conductance: nothing adds to it"))


def _check_table(rows: list, p: str, problems: list[Problem]) -> None:
    """[[p, h], ...]: at least one row, pressures >= 0 and increasing, conductances >= 0."""
    if not rows:
        problems.append(Problem(p, "the table [[p (Pa), h (W/(m^2 K))], ...] has no rows"))
        return
    pressures = [r[0] for r in rows]
    if any(x < 0 for x in pressures):
        problems.append(Problem(p, f"the pressures of the table must be >= 0 Pa, got {min(pressures):g}"))
    if any(b <= a for a, b in zip(pressures, pressures[1:])):
        problems.append(Problem(p, "the pressures of the table must increase from row to row"))
    if any(r[1] < 0 for r in rows):
        problems.append(Problem(p, f"the conductances of the table must be >= 0 W/(m^2 K), got "
                                   f"{min(r[1] for r in rows):g}"))


def _follows_mechanics(scene: Scene) -> bool:
    """Whether the heat problem receives the mechanics' contact state at every step."""
    ph = scene.physics
    return bool(ph.mechanics) and ph.thermal == "transient" and ph.coupling != "none"
