"""Validation of the settings of a scene and of how they go together: the physics switched on and the keys each of
them uses (mechanics, coupling, dynamics, nested iteration, the mixed formulation), time, sources, boundary
conditions, and the contact laws and methods of interfaces and foundations."""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..contact.choices import contact_methods
from ..errors import Problem
from ..fem.timesteps import schedule
from ..geometry.assemble import scene_dim
from ..scene import expressions
from ..scene.model import RATE_MECHANICS, BoundaryCondition, ContactMechanics, Scene
from ..scene.units import KELVIN
from .check_adaptivity import check_adaptivity

MAX_STEPS = 1_000_000
"""The most time steps a scene may take: far beyond any scene's need (each step solves at least one system), and
an end time of 1e9 years with a step of one second (3e16 steps) is refused before any work."""


def check_settings(scene: Scene, problems: list[Problem]) -> None:
    """Every setting against the physics switched on, in the order of the scene's tables."""
    _check_physics(scene, problems)
    check_adaptivity(scene, problems)
    _check_nested(scene, problems)
    _check_dynamics(scene, problems)
    _check_formulation(scene, problems)
    _check_coupling(scene, problems)
    check_time(scene, problems)
    _check_sources(scene, problems)
    for name, bc in scene.boundary_conditions.items():
        _check_boundary_condition(scene, name, bc, problems)
    if scene.physics.mechanics is not None and not any(
            bc.displacement is not None or bc.symmetry or bc.foundation is not None
            for bc in scene.boundary_conditions.values()):
        problems.append(Problem("boundary_conditions", "the bodies are not held: mechanics needs a displacement, "
                                "symmetry or foundation condition somewhere, or rigid motions are free"))
    _check_interfaces(scene, problems)


def _check_physics(scene: Scene, problems: list[Problem]) -> None:
    """Some physics is on; the mechanics' loads fit the dimension; a pressure-dependent conductivity has the
    pressure."""
    ph = scene.physics
    if ph.thermal is None and ph.mechanics is None:
        problems.append(Problem("physics", "no physics is switched on (set physics.thermal = 'steady' or "
                                           "'transient', and/or physics.mechanics = 'static')"))
    dim = scene_dim(scene)
    ms = scene.mechanics
    if ph.mechanics is not None:
        if ms.gravity is not None and len(ms.gravity) != dim:
            problems.append(Problem("mechanics.gravity", f"needs {dim} components, got {len(ms.gravity)}"))
        _check_initial_stress(scene, dim, problems)
        softening = [n for n, m in scene.materials.items() if m.rheology_lambda < 1]
        if softening and ms.regularization <= 0:
            problems.append(Problem("mechanics.regularization", f"must be positive: rheology_lambda < 1 in "
                                    f"{softening} is singular at zero strain"))
    for name, mat in scene.materials.items():
        if mat.conductivity_pressure_coefficient != 0.0 and ph.coupling == "none":
            problems.append(Problem(f"materials.{name}.conductivity_pressure_coefficient", "a pressure-dependent "
                                    "conductivity needs the pressure of the mechanics in every heat step: set "
                                    "physics.coupling = 'staggered' or 'iterated' (with physics.thermal = "
                                    "'transient' and physics.mechanics = 'static')"))


def _check_initial_stress(scene: Scene, dim: int, problems: list[Problem]) -> None:
    """mechanics.initial_stress is a dim x dim table; plane strain also takes a 3x3 table whose zz entry is the
    out-of-plane prestress (sigma_zz = zz entry + the plane-strain elastic and thermal part) and whose xz, yz
    entries are 0 (an out-of-plane shear prestress is not in equilibrium with a plane section's loads)."""
    s0 = scene.mechanics.initial_stress
    if s0 is None:
        return
    sizes = (dim, 3) if scene.scene.dimension == "plane" and scene.physics.plane_model == "plane_strain" else (dim,)
    n = len(s0)
    if n not in sizes or any(len(r) != n for r in s0):
        shapes = " or ".join(f"{k}x{k}" for k in sizes)
        problems.append(Problem("mechanics.initial_stress", f"must be a {shapes} table of expressions"))
        return
    if n == 3 and dim == 2:
        bad = [f"[{i}][{j}]" for i, j in ((0, 2), (1, 2), (2, 0), (2, 1)) if not _zero_expression(s0[i][j])]
        if bad:
            problems.append(Problem("mechanics.initial_stress", f"entries {', '.join(bad)} (the xz, yz "
                                    "shears) must be 0 in plane strain: only the zz entry of the third row and "
                                    "column is taken (the out-of-plane normal prestress)"))


def _zero_expression(v) -> bool:
    """True for the number 0 or an expression without variables whose value is 0."""
    if isinstance(v, (int, float)):
        return v == 0
    return not expressions.uses(v) and expressions.evaluate(v) == 0.0


def _check_coupling(scene: Scene, problems: list[Problem]) -> None:
    """physics.coupling: a transient heat problem with mechanics, and absolute reference temperatures above 0 K."""
    ph = scene.physics
    if ph.coupling == "none":
        return
    if ph.thermal != "transient" or ph.mechanics is None:
        problems.append(Problem("physics.coupling", f"{ph.coupling!r} couples a transient heat problem with "
                                "mechanics (deformation heating, problem (P_c)): it needs physics.thermal = "
                                "'transient' and physics.mechanics = 'static'; use 'none' otherwise"))
    offset = KELVIN if scene.scene.temperature_unit == "C" else 0.0
    for name, mat in scene.materials.items():
        if mat.thermal_expansion is not None and not isinstance(mat.stress_free_temperature, str) \
                and not mat.stress_free_temperature + offset > 0:      # an expression: validation.material_values
            problems.append(Problem(f"materials.{name}.stress_free_temperature", f"the deformation heating of "
                                    f"physics.coupling = {ph.coupling!r} is proportional to the absolute "
                                    f"reference temperature, here {mat.stress_free_temperature + offset:g} K: "
                                    "it must be > 0 K (give it in the scene's temperature_unit)"))


def _check_sources(scene: Scene, problems: list[Problem]) -> None:
    """One of power or density per source; decay goes with power, its time constants are positive."""
    for i, s in enumerate(scene.sources):
        p = f"sources[{i}]"
        if (s.power is None) == (s.density is None):
            problems.append(Problem(p, "give exactly one of 'power' (W) or 'density' (W/m^3)"))
        if s.decay and s.density is not None:
            problems.append(Problem(f"{p}.decay", "'decay' applies to 'power'; write the time dependence into "
                                                  "'density' instead"))
        for j, pair in enumerate(s.decay):
            if pair and pair[1] is not None and pair[1] <= 0:
                problems.append(Problem(f"{p}.decay[{j}]", f"time constant must be positive, got {pair[1]}"))


def _check_boundary_condition(scene: Scene, name: str, bc: BoundaryCondition, problems: list[Problem]) -> None:
    """One thermal and one mechanical condition at most, each with its physics on and its components."""
    ph, dim = scene.physics, scene_dim(scene)
    p = f"boundary_conditions.{name}"
    kinds = [k for k, v in (("temperature", bc.temperature), ("flux", bc.flux),
                            ("heat_transfer_coefficient", bc.heat_transfer_coefficient)) if v is not None]
    if bc.insulated:
        kinds.append("insulated")
    mkinds = [k for k, v in (("displacement", bc.displacement), ("traction", bc.traction),
                             ("pressure", bc.pressure)) if v is not None]
    if bc.symmetry:
        mkinds.append("symmetry")
    if bc.foundation is not None:
        mkinds.append("foundation")
        _check_foundation(bc.foundation, f"{p}.foundation", dim, problems)
    if len(kinds) > 1:
        problems.append(Problem(p, f"contradictory conditions {kinds}: give one of temperature, flux, "
                                   "insulated, or heat_transfer_coefficient with ambient_temperature"))
    if len(mkinds) > 1:
        problems.append(Problem(p, f"contradictory conditions {mkinds}: give one of displacement, traction, "
                                   "pressure, symmetry, foundation"))
    if not kinds and not mkinds:
        problems.append(Problem(p, "no condition given (temperature, flux, insulated, heat_transfer_coefficient"
                                   " with ambient_temperature; displacement, traction, pressure, symmetry, "
                                   "foundation)"))
    if kinds and ph.thermal is None:
        problems.append(Problem(p, f"thermal condition {kinds[0]!r} but physics.thermal is off"))
    if mkinds and ph.mechanics is None:
        problems.append(Problem(p, f"mechanical condition {mkinds[0]!r} but physics.mechanics is off"))
    for key in ("displacement", "traction"):
        v = getattr(bc, key)
        if v is not None and len(v) != dim:
            problems.append(Problem(f"{p}.{key}", f"needs {dim} components, got {len(v)}"))
    if (bc.heat_transfer_coefficient is None) != (bc.ambient_temperature is None):
        problems.append(Problem(p, "heat_transfer_coefficient and ambient_temperature go together"))


def _check_foundation(fd, p: str, dim: int, problems: list[Problem]) -> None:
    """A foundation's contact law, a point and a nonzero normal of ``dim`` components."""
    _check_contact_law(fd, p, problems)
    for key in ("point", "normal"):
        v = getattr(fd, key)
        if v is not None and len(v) != dim:
            problems.append(Problem(f"{p}.{key}", f"needs {dim} components, got {len(v)}"))
    if fd.normal is not None and not float(np.linalg.norm(np.asarray(fd.normal, dtype=float))) > 0:
        problems.append(Problem(f"{p}.normal", "must not be the zero vector"))


def _check_interfaces(scene: Scene, problems: list[Problem]) -> None:
    """Contact keys only on contact interfaces; each contact's law; the contacts' methods
    (:func:`~ngs_geomech.contact.choices.contact_methods`, the one reading of the ``method`` keys)."""
    ph = scene.physics
    for i, itf in enumerate(scene.interfaces):
        p = f"interfaces[{i}] ({itf.name})"
        if itf.type == "glued":
            set_keys = [k for k in ("slip_bound", "friction", "augmentation", "search_distance", "uzawa_step")
                        if getattr(itf, k) is not None] + [k for k, d in (("law", "frictionless"), ("method", "ssn"))
                                                           if getattr(itf, k) != d]
            if set_keys:
                problems.append(Problem(f"{p}.{set_keys[0]}", "contact keys apply to type = 'contact' only"))
        elif ph.mechanics is not None:
            _check_contact_law(itf, p, problems)
    if ph.mechanics is None:
        return
    contacts = ([(f"interfaces[{i}] ({itf.name})", itf) for i, itf in enumerate(scene.interfaces)
                 if itf.type == "contact"]
                + [(f"boundary_conditions.{n}.foundation", bc.foundation)
                   for n, bc in scene.boundary_conditions.items() if bc.foundation is not None])
    choice = contact_methods([c.method for _, c in contacts], [p for p, _ in contacts], dim=scene_dim(scene),
                             mechanics=ph.mechanics)
    problems += [Problem(f"{p}.method", why) for p, why in choice.problems]


def _check_contact_law(c: ContactMechanics, p: str, problems: list[Problem]) -> None:
    """The contact-law keys of an interface or foundation (:class:`ContactMechanics`)."""
    if c.law == "tresca" and c.slip_bound is None:
        problems.append(Problem(f"{p}.slip_bound", "Tresca friction needs a slip bound g_c (Pa)"))
    if c.law != "tresca" and c.slip_bound is not None:
        problems.append(Problem(f"{p}.slip_bound", f"applies to law = 'tresca', not {c.law!r}"))
    if c.law == "coulomb" and c.friction is None:
        problems.append(Problem(f"{p}.friction", "Coulomb friction needs a coefficient F_c"))
    if c.law != "coulomb" and c.friction is not None:
        problems.append(Problem(f"{p}.friction", f"applies to law = 'coulomb', not {c.law!r}"))
    if isinstance(c.slip_bound, (int, float)) and not (c.slip_bound >= 0 and math.isfinite(c.slip_bound)):
        problems.append(Problem(f"{p}.slip_bound", f"must be >= 0 (Pa), got {c.slip_bound}"))
    if isinstance(c.slip_bound, str) and "t" in expressions.uses(c.slip_bound):
        problems.append(Problem(f"{p}.slip_bound", "must not depend on time t (an expression of x, y, z)"))
    if c.uzawa_step is not None and c.method != "uzawa":
        problems.append(Problem(f"{p}.uzawa_step", f"applies to method = 'uzawa', not {c.method!r}"))


def check_time(scene: Scene, problems: list[Problem]) -> None:
    """``[time]``, whenever it is given (transient heat, dynamic or viscous mechanics, time-dependent loads): a
    positive step, an end after the start, and at most :data:`MAX_STEPS` steps of :func:`schedule`."""
    t = scene.time
    if t is None:
        if scene.physics.thermal == "transient":
            problems.append(Problem("time", "a transient scene needs [time] with end and dt"))
        return
    if t.end <= t.start:
        problems.append(Problem("time.end", f"end {t.end:g} s must be after start {t.start:g} s"))
    if t.dt_max is not None and t.dt_max < t.dt:
        problems.append(Problem("time.dt_max", f"{t.dt_max:g} s is smaller than dt {t.dt:g} s"))
    elif t.dt > 0 and t.end > t.start and t.dt_growth >= 1:
        steps = schedule(t.start, t.end, t.dt, t.dt_growth, t.dt_max)
        if sum(1 for _ in itertools.islice(steps, MAX_STEPS + 1)) > MAX_STEPS:
            growth = f", dt_growth = {t.dt_growth:g}" + (f", dt_max = {t.dt_max:g} s" if t.dt_max else "")
            problems.append(Problem("time.dt", f"more than {MAX_STEPS} steps from time.start = {t.start:g} s to "
                                    f"time.end = {t.end:g} s with dt = {t.dt:g} s{growth}: use a larger dt (or "
                                    "dt_growth), or an earlier time.end"))


def _check_nested(scene: Scene, problems: list[Problem]) -> None:
    """``mechanics.nested_levels``: Newton on a nonlinear law without contact."""
    ms = scene.mechanics
    if ms.nested_levels == 0:
        return
    if scene.physics.mechanics != "static":
        problems.append(Problem("mechanics.nested_levels", "needs physics.mechanics = 'static'"))
    if ms.nonlinear_solver != "newton":
        problems.append(Problem("mechanics.nested_levels", "is a start for Newton: needs "
                                "mechanics.nonlinear_solver = 'newton'"))
    if all(m.rheology_lambda == 1.0 for m in scene.materials.values()):
        problems.append(Problem("mechanics.nested_levels", "the law is linear (rheology_lambda = 1 everywhere): "
                                "there is no Newton iteration to start; remove it"))
    if any(itf.type == "contact" for itf in scene.interfaces) or any(
            bc.foundation is not None for bc in scene.boundary_conditions.values()):
        problems.append(Problem("mechanics.nested_levels", "is not available with contact (the contact solve "
                                "has its own start)"))


def _check_dynamics(scene: Scene, problems: list[Problem]) -> None:
    """physics.mechanics = 'dynamic' | 'viscous' and the rate keys of the materials."""
    ph = scene.physics
    rate = ph.mechanics in RATE_MECHANICS
    for name, m in scene.materials.items():
        p = f"materials.{name}"
        if (m.viscosity_time is not None or m.prony) and not rate:
            problems.append(Problem(f"{p}.{'viscosity_time' if m.viscosity_time is not None else 'prony'}",
                                    "applies to physics.mechanics = 'dynamic' or 'viscous'"))
        if rate and m.rheology_lambda != 1.0:
            problems.append(Problem(f"{p}.rheology_lambda", f"physics.mechanics = {ph.mechanics!r} needs the linear "
                                    f"law (1), got {m.rheology_lambda}"))
        if ph.mechanics == "dynamic" and m.density is None:
            problems.append(Problem(f"{p}.density", "dynamic mechanics needs the density (kg/m^3) of every material"))
    if scene.initial.velocity is not None:
        dim = scene_dim(scene)
        if ph.mechanics != "dynamic":
            problems.append(Problem("initial.velocity", "applies to physics.mechanics = 'dynamic'"))
        elif len(scene.initial.velocity) != dim:
            problems.append(Problem("initial.velocity", f"needs {dim} components, got {len(scene.initial.velocity)}"))
    if not rate:
        return
    if scene.time is None:
        problems.append(Problem("time", f"physics.mechanics = {ph.mechanics!r} is time-dependent: it needs [time]"))
    if ph.thermal == "steady":
        problems.append(Problem("physics.thermal", f"physics.mechanics = {ph.mechanics!r} runs in time: the heat "
                                "problem must be 'transient' (or off)"))
    if ph.mechanics == "viscous" and not any(m.viscosity_time is not None or m.prony
                                             for m in scene.materials.values()):
        problems.append(Problem("physics.mechanics", "'viscous' needs a material with viscosity_time or prony"))
    if ph.coupling == "iterated":
        problems.append(Problem("physics.coupling", f"'iterated' is not available with physics.mechanics = "
                                f"{ph.mechanics!r} (its state cannot be stepped twice); use 'staggered'"))
    d = scene.dynamics
    if not 0.0 <= d.rho_inf <= 1.0:
        problems.append(Problem("dynamics.rho_inf", f"must lie in [0, 1], got {d.rho_inf}"))
    if d.mass == "lumped" and scene.mesh.order != 1:
        problems.append(Problem("dynamics.mass", "'lumped' needs mesh.order = 1"))


def _check_formulation(scene: Scene, problems: list[Problem]) -> None:
    ph, ms = scene.physics, scene.mechanics
    if ms.formulation == "mixed" and ph.mechanics is not None:
        if ph.mechanics in RATE_MECHANICS:
            problems.append(Problem("mechanics.formulation", f"'mixed' is not available with physics.mechanics = "
                                    f"{ph.mechanics!r}: use 'displacement' or 'auto'"))
        if scene.scene.dimension == "plane" and ph.plane_model == "plane_stress":
            problems.append(Problem("mechanics.formulation", "'mixed' is for plane strain, axisymmetric and 3D "
                                    "(plane stress does not lock)"))
        bad = sorted(n for n, m in scene.materials.items() if m.rheology_lambda != 1.0)
        if bad:
            problems.append(Problem("mechanics.formulation", f"'mixed' needs the linear law (rheology_lambda = 1); "
                                    f"{bad} are not"))
    s = scene.solver
    if s.preconditioner == "bddc" and scene.mesh.order < 2:
        problems.append(Problem("solver.preconditioner", "'bddc' needs mesh.order >= 2 (P1 elements have no "
                                "interface dofs); use 'auto'"))
    if s.preconditioner == "gamg":
        from ..linalg.iterative import petsc_available

        if not petsc_available():
            problems.append(Problem("solver.preconditioner", "'gamg' needs petsc4py, which is not installed: "
                                    "pip install -e '.[petsc]' (docs/install.md), or use 'auto'"))
