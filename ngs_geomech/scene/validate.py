"""Semantic validation of a scene, before any meshing or solving.

Every problem found is reported, each naming its item: unknown region or boundary names, regions without a
material, unphysical values, inconsistent settings. The geometry is built (cheap: OCC shapes, no mesh) to
learn the region and boundary names.
"""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
from netgen import occ

from ..errors import Problem, SceneError
from ..fem.timesteps import schedule
from ..geometry.assemble import GeometryModel, build_geometry, scene_dim
from ..geometry.shapes import cells, sides
from ..heat.materials import (
    conductivity_tensor,
    has_phase_change,
    isotropic_conductivity,
    phase_change_problems,
    volumetric_heat_capacity,
)
from ..mechanics.materials import MaterialError, axisymmetric, elastic_properties
from . import expressions
from .expression_values import check_expression_values, value_range
from .model import Scene
from .names import name_problem
from .schema import recheck
from .units import KELVIN

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def validate(scene: Scene) -> GeometryModel:
    """Check a scene; return its geometry model, or raise SceneError listing every problem."""
    problems: list[Problem] = []
    recheck(scene, "", problems)        # the declared types and ranges (also of a scene built in Python)
    _check_names(scene, problems)
    _check_settings(scene, problems)
    _check_materials(scene, problems)
    _check_phase_change(scene, problems)
    _check_temperatures(scene, problems)
    geo = None
    if not any(p.item.startswith("blocks") for p in problems):
        try:
            geo = build_geometry(scene)
        except SceneError as exc:
            problems += exc.problems
    if geo is not None:
        _check_references(scene, geo, problems)
        _check_mesh_size(scene, geo, problems)
        check_expression_values(scene, geo, problems)
        if not problems:
            _check_conductivity_range(scene, geo, problems)
    if problems:
        # a declared range is checked both by recheck and by the physics' reading of the material (the same
        # problem from the same declaration): each once
        raise SceneError(list(dict.fromkeys(problems)), source=f"scene {scene.scene.name!r}")
    return geo


def _check_names(scene: Scene, problems: list[Problem]) -> None:
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


def _check_temperatures(scene: Scene, problems: list[Problem]) -> None:
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


def _check_mesh_size(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """The mesh is not larger than ``mesh.max_elements``, from the geometry's estimate before meshing (meshing
    runs until memory is exhausted otherwise)."""
    m = scene.mesh
    if not m.maxh > 0 or any(not h > 0 for h in m.boundary_maxh.values()) or any(
            b.maxh is not None and not b.maxh > 0 for b in scene.blocks):
        return                              # reported by _check_settings, _check_names
    counts = geo.element_estimate(m.maxh)
    n = sum(counts.values())
    if n <= m.max_elements:
        return
    (kind, name), most = max(counts.items(), key=lambda kv: kv[1])
    item, h = "mesh.maxh", m.maxh
    i = next((i for i, b in enumerate(scene.blocks) if b.name == name), None)
    if kind == "boundary":
        item, h = f"mesh.boundary_maxh.{name}", m.boundary_maxh.get(name, m.maxh)
    elif i is not None and scene.blocks[i].maxh is not None and scene.blocks[i].maxh < m.maxh:
        item, h = f"blocks[{i}].maxh", scene.blocks[i].maxh
    where = f"{'region' if kind == 'region' else 'boundary'} {name!r}"
    problems.append(Problem(item, f"{h:g} m: the mesh would have at least {n:.3g} elements ({most:.3g} in {where}; "
                            f"estimated from the {'areas' if geo.dim == 2 else 'volumes'} and the element sizes "
                            f"before meshing), more than mesh.max_elements = {m.max_elements}: use larger elements, "
                            "or raise mesh.max_elements if the machine can take it"))


def _check_formulation(scene: Scene, problems: list[Problem]) -> None:
    ph, ms = scene.physics, scene.mechanics
    if ms.formulation == "mixed" and ph.mechanics is not None:
        if ph.mechanics in ("dynamic", "viscous"):
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


def _check_dynamics(scene: Scene, problems: list[Problem]) -> None:
    """physics.mechanics = 'dynamic' | 'viscous' and the rate keys of the materials."""
    ph = scene.physics
    rate = ph.mechanics in ("dynamic", "viscous")
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
    for i, itf in enumerate(scene.interfaces):
        if itf.type == "contact" and itf.method == "uzawa":
            problems.append(Problem(f"interfaces[{i}] ({itf.name}).method", "'uzawa' is not available with "
                                    f"physics.mechanics = {ph.mechanics!r}: use 'ssn' or 'penalty'"))


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


def _check_adaptivity(scene: Scene, problems: list[Problem]) -> None:
    a = scene.adaptivity
    if a is None:
        return
    if not 1 <= a.levels <= 8:                # ranges checked whether or not the scene uses the key
        problems.append(Problem("adaptivity.levels", f"must be between 1 and 8, got {a.levels}"))
    if not 0 <= a.layers <= 20:
        problems.append(Problem("adaptivity.layers", f"must be between 0 and 20, got {a.layers}"))
    ph = scene.physics
    if ph.thermal == "transient" or (ph.thermal is None and scene.time is not None):
        if "contact_zone" in a.indicators:
            _check_zone_following(scene, problems)
        elif "phase_front" in a.indicators or stefan_scene(scene):
            _check_front_following(scene, problems)
        else:
            _check_pre_adapted(scene, problems)
        return
    if "phase_front" in a.indicators:
        problems.append(Problem("adaptivity.indicators", "'phase_front' (front-following meshes) needs a transient "
                                "scene with a phase change (physics.thermal = 'transient', a material with "
                                "phase_change_temperature)"))
    target = a.target or ("mechanics" if ph.mechanics else "heat")
    if target == "mechanics" and ph.mechanics is None:
        problems.append(Problem("adaptivity.target", "'mechanics' needs physics.mechanics = 'static'"))
    if target == "heat" and ph.thermal is None:
        problems.append(Problem("adaptivity.target", "'heat' needs physics.thermal"))
    if a.estimator == "residual" and target == "mechanics":
        if scene.scene.dimension == "axisymmetric":
            problems.append(Problem("adaptivity.estimator", "the residual estimator of elasticity is not available "
                                    "for axisymmetric scenes: use 'zz'"))
        bad = sorted(n for n, m in scene.materials.items() if m.rheology_lambda != 1.0)
        if bad:
            problems.append(Problem("adaptivity.estimator", f"the residual estimator of elasticity needs the linear "
                                    f"law (rheology_lambda = 1; {bad} are not): use 'zz'"))
    if "contact_zone" in a.indicators and (ph.mechanics is None or not any(
            itf.type == "contact" for itf in scene.interfaces) and not any(
            bc.foundation is not None for bc in scene.boundary_conditions.values())):
        problems.append(Problem("adaptivity.indicators", "'contact_zone' needs mechanics with a contact interface or "
                                "a foundation"))
    _check_loop_settings(a, problems)


def _check_front_following(scene: Scene, problems: list[Problem]) -> None:
    """``[adaptivity]`` of a time-dependent scene: front-following meshes for the Stefan problem, plane scenes
    without mechanics or contact interfaces (what :mod:`ngs_geomech.adapt.front_following` supports)."""
    a = scene.adaptivity
    ph = scene.physics
    if not stefan_scene(scene):
        problems.append(Problem("adaptivity", "estimator-driven refinement is available for stationary scenes "
                                "(no [time]); time-dependent scenes are adapted only with a phase change (meshes "
                                "that follow the phase boundary: physics.thermal = 'transient' and a material with "
                                "phase_change_temperature); without one, remove [adaptivity]"))
    if "phase_front" not in a.indicators:
        problems.append(Problem("adaptivity.indicators", "a time-dependent scene needs indicators = "
                                "['phase_front'] (meshes that follow the phase boundary) or ['contact_zone'] "
                                "(meshes that follow the contact zones of static mechanics)"))
    if ph.mechanics is not None:
        problems.append(Problem("physics.mechanics", "front-following meshes ([adaptivity] with 'phase_front') "
                                "are not available with mechanics: remove [adaptivity] or the mechanics"))
    if scene.scene.dimension != "plane":
        problems.append(Problem("scene.dimension", f"front-following meshes ([adaptivity] with 'phase_front') are "
                                f"available for plane scenes only, not {scene.scene.dimension!r}"))
    for itf in scene.interfaces:
        if itf.type == "contact":
            problems.append(Problem(f"interfaces.{itf.name}", "front-following meshes ([adaptivity] with "
                                    "'phase_front') need conforming meshes: contact interfaces are not "
                                    "supported (use type = 'glued', or remove [adaptivity])"))
    _check_following_settings(a, problems, "front-following meshes", "the front leaves")


def _check_following_settings(a, problems: list[Problem], what: str, leaves: str) -> None:
    """levels, layers, remesh_every of meshes that follow a feature over time, and the loop keys they do not use
    (``what``: the meshes' name; ``leaves``: when they are remeshed with remesh_every = 0)."""
    for key in ("target", "tolerance", "max_dofs"):
        if getattr(a, key) is not None:
            problems.append(Problem(f"adaptivity.{key}", f"not used by {what} (time-dependent scenes): remove it"))
    if a.remesh_every < 0:
        problems.append(Problem("adaptivity.remesh_every", f"must be >= 0 (0: when {leaves} the refined band), got "
                                f"{a.remesh_every}"))


def _check_loop_settings(a, problems: list[Problem]) -> None:
    """The marker's theta and the stop rule of the SOLVE -> ESTIMATE -> MARK -> REFINE loop."""
    if not (0 < a.theta <= 1):
        problems.append(Problem("adaptivity.theta", f"must be in (0, 1], got {a.theta}"))
    if a.tolerance is not None and not (a.tolerance > 0 and math.isfinite(a.tolerance)):
        problems.append(Problem("adaptivity.tolerance", f"must be > 0, got {a.tolerance}"))
    if a.max_dofs is not None and a.max_dofs < 1:
        problems.append(Problem("adaptivity.max_dofs", f"must be >= 1, got {a.max_dofs}"))
    if a.max_refinements < 0:
        problems.append(Problem("adaptivity.max_refinements", f"must be >= 0, got {a.max_refinements}"))


def _check_pre_adapted(scene: Scene, problems: list[Problem]) -> None:
    """``[adaptivity]`` without a followed feature in a time-dependent scene: the mesh adapted once to the steady
    heat problem with the data at the start time (transient heat scenes)."""
    a = scene.adaptivity
    if scene.physics.thermal != "transient":
        problems.append(Problem("adaptivity", "a time-dependent scene without physics.thermal = 'transient' has "
                                "nothing to adapt the mesh to: use indicators = ['contact_zone'] (meshes that "
                                "follow the contact zones) or remove [adaptivity]"))
    if a.target == "mechanics":
        problems.append(Problem("adaptivity.target", "a transient scene's mesh is adapted to the steady heat problem "
                                "at the start time: target must be 'heat' (or indicators = ['contact_zone'])"))
    _check_loop_settings(a, problems)


def _check_zone_following(scene: Scene, problems: list[Problem]) -> None:
    """``[adaptivity]`` with ``'contact_zone'`` in a time-dependent scene: meshes that follow the contact zones
    (what :mod:`ngs_geomech.adapt.contact_following` supports: static mechanics with a contact, plane or
    axisymmetric)."""
    a = scene.adaptivity
    ph = scene.physics
    if "phase_front" in a.indicators and not stefan_scene(scene):
        problems.append(Problem("adaptivity.indicators", "'phase_front' needs a phase change (a material with "
                                "phase_change_temperature)"))
    if ph.mechanics != "static":
        problems.append(Problem("physics.mechanics", "meshes that follow the contact zones ([adaptivity] with "
                                f"'contact_zone') need physics.mechanics = 'static', got {ph.mechanics!r}"))
    elif not any(itf.type == "contact" for itf in scene.interfaces) and not any(
            bc.foundation is not None for bc in scene.boundary_conditions.values()):
        problems.append(Problem("adaptivity.indicators", "'contact_zone' needs mechanics with a contact interface or "
                                "a foundation"))
    if scene.scene.dimension == "3d":
        problems.append(Problem("scene.dimension", "meshes that follow the contact zones are available for plane "
                                "and axisymmetric scenes only, not '3d'"))
    _check_following_settings(a, problems, "meshes that follow the contact zones", "a transition leaves")


def _check_settings(scene: Scene, problems: list[Problem]) -> None:
    ph = scene.physics
    if ph.thermal is None and ph.mechanics is None:
        problems.append(Problem("physics", "no physics is switched on (set physics.thermal = 'steady' or "
                                           "'transient', and/or physics.mechanics = 'static')"))
    dim = scene_dim(scene)
    ms = scene.mechanics
    if ph.mechanics is not None:
        if ms.gravity is not None and len(ms.gravity) != dim:
            problems.append(Problem("mechanics.gravity", f"needs {dim} components, got {len(ms.gravity)}"))
        if ms.initial_stress is not None and (len(ms.initial_stress) != dim
                                              or any(len(r) != dim for r in ms.initial_stress)):
            problems.append(Problem("mechanics.initial_stress", f"must be a {dim}x{dim} table of expressions"))
        softening = [n for n, m in scene.materials.items() if m.rheology_lambda < 1]
        if softening and ms.regularization <= 0:
            problems.append(Problem("mechanics.regularization", f"must be positive: rheology_lambda < 1 in "
                                    f"{softening} is singular at zero strain"))
    for name, mat in scene.materials.items():
        c_p = mat.conductivity_pressure_coefficient
        item = f"materials.{name}.conductivity_pressure_coefficient"
        if c_p != 0.0 and ph.coupling == "none":
            problems.append(Problem(item, "a pressure-dependent conductivity needs the pressure of the mechanics "
                                    "in every heat step: set physics.coupling = 'staggered' or 'iterated' (with "
                                    "physics.thermal = 'transient' and physics.mechanics = 'static')"))
    _check_adaptivity(scene, problems)
    _check_nested(scene, problems)
    _check_dynamics(scene, problems)
    _check_formulation(scene, problems)
    if ph.coupling != "none":
        if ph.thermal != "transient" or ph.mechanics is None:
            problems.append(Problem("physics.coupling", f"{ph.coupling!r} couples a transient heat problem with "
                                    "mechanics (deformation heating, problem (P_c)): it needs physics.thermal = "
                                    "'transient' and physics.mechanics = 'static'; use 'none' otherwise"))
        offset = KELVIN if scene.scene.temperature_unit == "C" else 0.0
        for name, mat in scene.materials.items():
            if mat.thermal_expansion is not None and not mat.stress_free_temperature + offset > 0:
                problems.append(Problem(f"materials.{name}.stress_free_temperature", f"the deformation heating of "
                                        f"physics.coupling = {ph.coupling!r} is proportional to the absolute "
                                        f"reference temperature, here {mat.stress_free_temperature + offset:g} K: "
                                        "it must be > 0 K (give it in the scene's temperature_unit)"))
    _check_time(scene, problems)
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
    for name, bc in scene.boundary_conditions.items():
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
            _check_contact_law(bc.foundation, f"{p}.foundation", problems)
            for key in ("point", "normal"):
                v = getattr(bc.foundation, key)
                if v is not None and len(v) != dim:
                    problems.append(Problem(f"{p}.foundation.{key}", f"needs {dim} components, got {len(v)}"))
            nv = bc.foundation.normal
            if nv is not None and not float(np.linalg.norm(np.asarray(nv, dtype=float))) > 0:
                problems.append(Problem(f"{p}.foundation.normal", "must not be the zero vector"))
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
    if ph.mechanics is not None and not any(bc.displacement is not None or bc.symmetry or bc.foundation is not None
                                            for bc in scene.boundary_conditions.values()):
        problems.append(Problem("boundary_conditions", "the bodies are not held: mechanics needs a displacement, "
                                "symmetry or foundation condition somewhere, or rigid motions are free"))
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
    contacts = ([(f"interfaces[{i}] ({itf.name})", itf) for i, itf in enumerate(scene.interfaces)
                 if itf.type == "contact"]
                + [(f"boundary_conditions.{n}.foundation", bc.foundation)
                   for n, bc in scene.boundary_conditions.items() if bc.foundation is not None])
    uzawa = [p for p, c in contacts if c.method == "uzawa"]
    if ph.mechanics is not None and uzawa and len(uzawa) != len(contacts):
        other = next(p for p, c in contacts if c.method != "uzawa")
        problems.append(Problem(f"{other}.method", f"the Uzawa reference method ({uzawa[0]}) solves all contacts "
                                "of a scene at once: use method = 'uzawa' on every contact or on none"))
    if ph.mechanics is not None and dim == 3:     # 3D contact mechanics: all laws, methods ssn and penalty
        for p, c in contacts:
            if c.method == "uzawa":
                problems.append(Problem(f"{p}.method", "the Uzawa reference method is implemented in 2D only: use "
                                        "'ssn' or 'penalty' in 3D"))


def _check_contact_law(c, p: str, problems: list[Problem]) -> None:
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


MAX_STEPS = 1_000_000
"""The most time steps a scene may take: far beyond any scene's need (each step solves at least one system), and
an end time of 1e9 years with a step of one second (3e16 steps) is refused before any work."""


def _check_time(scene: Scene, problems: list[Problem]) -> None:
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


def _check_materials(scene: Scene, problems: list[Problem]) -> None:
    dim = scene_dim(scene)
    for name, mat in scene.materials.items():
        if scene.physics.thermal is not None:
            # conductivity and heat capacity are checked separately so that both are reported, each under
            # the key at fault (e.g. materials.granite.rho_c)
            key = "conductivity_principal" if mat.conductivity_principal is not None else "conductivity"
            if mat.conductivity is None and mat.conductivity_principal is None:
                key = ""
            try:
                conductivity_tensor(mat, dim)
            except MaterialError as exc:
                problems.append(Problem(f"materials.{name}.{exc.key}", exc.detail))
            except ValueError as exc:
                problems.append(Problem(f"materials.{name}" + (f".{key}" if key else ""), str(exc)))
        key = "rho_c" if mat.rho_c is not None else "density" if mat.density is not None else "specific_heat"
        try:
            rho_c = volumetric_heat_capacity(mat)
        except MaterialError as exc:
            problems.append(Problem(f"materials.{name}.{exc.key}", exc.detail))
            rho_c = 0.0
        except ValueError as exc:
            problems.append(Problem(f"materials.{name}.{key}", str(exc)))
            rho_c = 0.0
        if scene.physics.thermal == "transient" and rho_c is None:
            problems.append(Problem(f"materials.{name}", "a transient thermal scene needs rho_c "
                                                         "(or density and specific_heat)"))
        if scene.physics.mechanics is not None:
            try:
                props = elastic_properties(mat, dim)
                if scene.scene.dimension == "axisymmetric":
                    axisymmetric(props.C, props.beta)
            except MaterialError as exc:
                problems.append(Problem(f"materials.{name}.{exc.key}" if exc.key else f"materials.{name}",
                                        exc.detail if exc.key else str(exc)))
            except ValueError as exc:
                problems.append(Problem(f"materials.{name}", str(exc)))
            if scene.mechanics.gravity is not None and mat.density is None:
                problems.append(Problem(f"materials.{name}.density", "gravity is on: every region needs a density"))


def stefan_scene(scene: Scene) -> bool:
    """Whether the scene is solved as a Stefan problem: some material has a phase change and the thermal
    problem is transient (the enthalpy solver replaces the heat solver)."""
    return scene.physics.thermal == "transient" and any(has_phase_change(m) for m in scene.materials.values())


def _check_phase_change(scene: Scene, problems: list[Problem]) -> None:
    """Phase-change keys of each material, and what the Stefan solver supports (seed (2.46)-(2.51), (2.55): P1,
    lumped, backward Euler, isotropic conductivity per phase (constant or k (1 + b (T - T_ref))), no Robin
    condition, plane or 3D)."""
    pcm = [n for n, m in scene.materials.items() if has_phase_change(m)]
    for name, mat in scene.materials.items():
        for key, msg in phase_change_problems(mat):
            problems.append(Problem(f"materials.{name}.{key}", msg))
    if not pcm:
        return
    ph = scene.physics
    if ph.thermal is None:
        problems.append(Problem(f"materials.{pcm[0]}.phase_change_temperature", "a phase change needs "
                                "physics.thermal = 'transient' (the Stefan problem), but physics.thermal is off"))
        return
    if ph.thermal == "steady":
        problems.append(Problem("physics.thermal", f"'steady' with a phase change in {pcm}: the Stefan problem is "
                                "time-dependent (the phase boundary moves); use thermal = 'transient' with [time], "
                                "or remove phase_change_temperature"))
        return
    why = f"the Stefan (phase change) solver, used because of the phase change in {pcm},"
    if scene.scene.dimension == "axisymmetric":
        problems.append(Problem("scene.dimension", f"'axisymmetric': {why} has no axisymmetric (r-weighted) form; "
                                "use a plane or 3d scene"))
    if scene.mesh.order != 1:
        problems.append(Problem("mesh.order", f"{scene.mesh.order}: {why} uses lumped P1 elements; set "
                                "mesh.order = 1 (refine with mesh.maxh instead)"))
    if scene.time is not None and scene.time.scheme != "backward_euler":
        problems.append(Problem("time.scheme", f"{scene.time.scheme!r}: {why} steps with backward Euler (seed "
                                "(2.55)); set time.scheme = 'backward_euler'"))
    for name, bc in scene.boundary_conditions.items():
        if bc.heat_transfer_coefficient is not None:
            problems.append(Problem(f"boundary_conditions.{name}.heat_transfer_coefficient", f"{why} does not "
                                    "take a heat transfer (Robin) condition; give a temperature or a flux"))
    dim = scene_dim(scene)
    for name, mat in scene.materials.items():
        # conductivity_temperature_coefficient: k(T) = k (1 + b (T - T_ref)) in both phases (the Kirchhoff
        # variable is then piecewise quadratic); that k stays positive is checked at the temperatures reached
        try:
            conductivity_tensor(mat, dim)
        except ValueError:
            continue                    # reported by _check_materials
        try:
            isotropic_conductivity(mat, dim)
        except ValueError as exc:
            key = "conductivity_principal" if mat.conductivity_principal is not None else "conductivity"
            problems.append(Problem(f"materials.{name}.{key}", str(exc)))


def _check_conductivity_range(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """k(T) = k (1 + b (T - T_ref)) must be positive at the temperatures a region surely takes: its initial
    temperature and the prescribed temperatures on its block's boundaries."""
    if scene.physics.thermal is None:
        return
    for name, mat in scene.materials.items():
        b, t_ref = mat.conductivity_temperature_coefficient, mat.reference_temperature
        if b == 0.0 or name not in geo.regions:
            continue
        data = [(f"initial.regions.{name}" if name in scene.initial.regions else "initial.temperature",
                 scene.initial.regions.get(name, scene.initial.temperature), ("region", (name,)))]
        if scene.physics.thermal == "steady":
            data = []
        data += [(f"boundary_conditions.{n}.temperature", bc.temperature, ("boundary", (n,)))
                 for n, bc in scene.boundary_conditions.items()
                 if bc.temperature is not None and n in geo.block_boundaries.get(name, ())]
        for key, value, target in data:
            r = value_range(geo, value, target)
            bad = [T for T in (r or ()) if not 1 + b * (T - t_ref) > 0]
            if bad:
                problems.append(Problem(f"materials.{name}.conductivity_temperature_coefficient", f"k(T) = k (1 + b "
                                        f"(T - T_ref)) with b = {b:g} 1/K, T_ref = {t_ref:g} is not positive at "
                                        f"T = {bad[0]:g} given by {key} (positive only for T "
                                        f"{'>' if b > 0 else '<'} {t_ref - 1 / b:.6g})"))
                break


def _mechanical_kinds(bc) -> list[str]:
    kinds = [k for k, v in (("displacement", bc.displacement), ("traction", bc.traction), ("pressure", bc.pressure),
                            ("foundation", bc.foundation)) if v is not None]
    return kinds + (["symmetry"] if bc.symmetry else [])


def _check_references(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    regions = set(geo.regions)
    interface_sides = set(geo.glued)
    gap_sides: dict[str, str] = {}       # sides of contacts with an initial gap -> interface
    for cs in geo.contacts.values():
        if cs.initial_gap:
            gap_sides.update({cs.master: cs.name, cs.minion: cs.name})
        else:
            interface_sides |= {cs.master, cs.minion}
    outer = geo.boundaries - interface_sides
    for r in geo.regions:
        if r not in scene.materials:
            problems.append(Problem(f"materials.{r}", f"region {r!r} has no material"))
    for name in scene.materials:
        if name not in regions:
            problems.append(Problem(f"materials.{name}", f"no region {name!r} in the geometry "
                                                         f"(regions: {', '.join(geo.regions)})"))
    for name, bc in scene.boundary_conditions.items():
        if name in gap_sides and _mechanical_kinds(bc):
            problems.append(Problem(f"boundary_conditions.{name}", f"{name!r} is a side of contact interface "
                                    f"{gap_sides[name]!r}: mechanical conditions ({_mechanical_kinds(bc)[0]}) are "
                                    "not allowed there (thermal ones are: the gap carries no heat)"))
    for name in scene.boundary_conditions:
        if name in interface_sides:
            problems.append(Problem(f"boundary_conditions.{name}", f"{name!r} is an interface, not an outer "
                                                                   "boundary"))
        elif name in geo.contacts:
            cs = geo.contacts[name]
            problems.append(Problem(f"boundary_conditions.{name}", f"{name!r} is a contact interface (sides "
                                    f"{cs.master!r}, {cs.minion!r}), not an outer boundary"))
        elif name not in outer:
            problems.append(Problem(f"boundary_conditions.{name}", f"no boundary {name!r} in the geometry "
                                    f"(boundaries: {', '.join(sorted(outer))})"))
    for name, bc in scene.boundary_conditions.items():
        if bc.symmetry and name in outer and not _flat(geo, name):
            problems.append(Problem(f"boundary_conditions.{name}.symmetry", f"boundary {name!r} is not "
                                    f"{'straight' if geo.dim == 2 else 'planar'}: the symmetry condition u_n = 0 "
                                    "(2.16) needs one normal direction"))
    for name in scene.mesh.boundary_maxh:
        if name not in geo.boundaries:
            problems.append(Problem(f"mesh.boundary_maxh.{name}", f"no boundary {name!r} in the geometry"))
    for i, s in enumerate(scene.sources):
        if s.region not in regions:
            problems.append(Problem(f"sources[{i}].region", f"no region {s.region!r} in the geometry"))
    for name in scene.initial.regions:
        if name not in regions:
            problems.append(Problem(f"initial.regions.{name}", f"no region {name!r} in the geometry"))
    if scene.physics.thermal == "steady":
        fixes = [n for n, bc in scene.boundary_conditions.items()
                 if bc.temperature is not None or bc.heat_transfer_coefficient is not None]
        if not fixes:
            problems.append(Problem("boundary_conditions", "a steady heat problem needs a temperature or a "
                                    "heat_transfer_coefficient condition somewhere, or its solution is not unique"))
        else:
            for members in _thermal_bodies(geo):
                if not any(n in fixes for b in members for n in geo.block_boundaries.get(b, ())):
                    gaps = sorted(cs.name for cs in geo.contacts.values() if cs.initial_gap
                                  and {cs.master_block, cs.minion_block} & set(members))
                    why = (f" (interface(s) {gaps} have an initial gap and carry no heat)" if gaps else "")
                    problems.append(Problem("boundary_conditions", f"a steady heat problem needs a temperature or "
                                            f"heat_transfer_coefficient condition on every body heat cannot leave "
                                            f"otherwise: block(s) {members} have none{why}"))
    for i, itf in enumerate(scene.interfaces):
        if itf.thermal_penalty is None:
            continue
        p = f"interfaces[{i}] ({itf.name}).thermal_penalty"
        cs = geo.contacts.get(itf.name)
        if not stefan_scene(scene):
            problems.append(Problem(p, "applies to phase-change (Stefan) scenes only: other scenes couple the "
                                    "temperature across contact interfaces exactly (mortar)"))
        elif cs is None or cs.initial_gap:
            problems.append(Problem(p, "applies to contact interfaces between touching blocks (heat passes there); "
                                    + ("a glued interface shares its nodes" if cs is None
                                       else "an interface with an initial gap carries no heat")))
        elif not (math.isfinite(itf.thermal_penalty) and itf.thermal_penalty > 0):
            problems.append(Problem(p, f"must be > 0, got {itf.thermal_penalty}"))
    if scene.physics.mechanics is not None:
        for i, itf in enumerate(scene.interfaces):
            cs = geo.contacts.get(itf.name)
            sd = itf.search_distance
            if cs is not None and cs.initial_gap and sd is not None and sd < cs.gap:
                problems.append(Problem(f"interfaces[{i}] ({itf.name}).search_distance", f"{sd:g} m is smaller than "
                                        f"the initial gap {cs.gap:.6g} m between {cs.master!r} and {cs.minion!r}: "
                                        "the sides could never come into contact"))
    for i, pr in enumerate(scene.output.probes):
        p = f"output.probes[{i}] ({pr.name})"
        targets = [k for k in ("point", "region", "boundary", "line") if getattr(pr, k) is not None]
        if len(targets) != 1:
            problems.append(Problem(p, "give exactly one of point, region, boundary, line"))
            continue
        if pr.quantity in ("liquid_fraction", "front") and not stefan_scene(scene):
            if not any(has_phase_change(m) for m in scene.materials.values()):   # else: reported there
                problems.append(Problem(f"{p}.quantity", f"{pr.quantity!r} needs a phase change (a material with "
                                        "phase_change_temperature and physics.thermal = 'transient')"))
            continue
        if (pr.quantity == "front") != (pr.line is not None):
            problems.append(Problem(f"{p}.line" if pr.line is not None else f"{p}.quantity",
                                    "a line goes with quantity = 'front' (and a front probe needs a line)"))
            continue
        if pr.line is not None:
            a, b = (np.asarray(q, dtype=float) for q in pr.line)
            if pr.statistic != "value":
                problems.append(Problem(f"{p}.statistic", "a front probe has statistic 'value'"))
            if len(a) != geo.dim or len(b) != geo.dim:
                problems.append(Problem(f"{p}.line", f"needs two points of {geo.dim} coordinates"))
            elif not float(np.linalg.norm(b - a)) > 0:
                problems.append(Problem(f"{p}.line", "the two points must differ"))
            elif not _inside(geo, pr.line[0]):
                problems.append(Problem(f"{p}.line", f"the first point {pr.line[0]} lies outside the geometry"))
            continue
        needs = "thermal" if pr.quantity in ("temperature", "liquid_fraction") else "mechanics"
        if getattr(scene.physics, needs) is None:
            problems.append(Problem(f"{p}.quantity", f"{pr.quantity!r} needs physics.{needs}"))
        if pr.quantity == "displacement_z" and geo.dim != 3:
            problems.append(Problem(f"{p}.quantity", "displacement_z needs a 3d scene"))
        if pr.point is not None:
            if pr.statistic != "value":
                problems.append(Problem(f"{p}.statistic", "a point probe has statistic 'value'"))
            if len(pr.point) != geo.dim:
                problems.append(Problem(f"{p}.point", f"needs {geo.dim} coordinates"))
            elif not _inside(geo, pr.point):
                problems.append(Problem(f"{p}.point", f"{pr.point} lies outside the geometry"))
        else:
            if pr.statistic == "value":
                problems.append(Problem(f"{p}.statistic", "use max, min or mean over a region or boundary"))
            if pr.region is not None and pr.region not in regions:
                problems.append(Problem(f"{p}.region", f"no region {pr.region!r}"))
            if pr.boundary is not None and pr.boundary not in geo.boundaries:
                problems.append(Problem(f"{p}.boundary", f"no boundary {pr.boundary!r}"))
    names = [pr.name for pr in scene.output.probes]
    for n in set(names):
        if names.count(n) > 1:
            problems.append(Problem("output.probes", f"probe name {n!r} is used twice"))


def _thermal_bodies(geo: GeometryModel) -> list[list[str]]:
    """The blocks heat can pass between (joined by glued interfaces or contact interfaces without a gap), as
    sorted lists of block names."""
    parent = {b: b for b in geo.regions}

    def find(b):
        while parent[b] != b:
            b = parent[b]
        return b
    pairs = list(geo.glued.values()) + [(cs.master_block, cs.minion_block) for cs in geo.contacts.values()
                                        if not cs.initial_gap]
    for a, b in pairs:
        parent[find(a)] = find(b)
    groups: dict[str, list[str]] = {}
    for b in geo.regions:
        groups.setdefault(find(b), []).append(b)
    return [sorted(g) for g in groups.values()]


def _flat(geo: GeometryModel, name: str) -> bool:
    """Whether all sides called ``name`` are straight (2D) or planar (3D) with one normal direction (parallel
    sides, e.g. both ends of a column, are fine: u_n = 0 is then one component)."""
    normals = []
    for side in sides(geo.shape, geo.dim):
        if side.name != name:
            continue
        if geo.dim == 2:
            a, b = np.array([side.start.x, side.start.y]), np.array([side.end.x, side.end.y])
            if abs(np.linalg.norm(b - a) - side.mass) > 1e-9 * side.mass:
                return False
            t = (b - a) / np.linalg.norm(b - a)
            normals.append(np.array([t[1], -t[0]]))
        else:
            inertia = np.array([[side.inertia[i, j] for j in range(3)] for i in range(3)])
            ev, vec = np.linalg.eigh(0.5 * (inertia + inertia.T))
            if abs(ev[2] - ev[0] - ev[1]) > 1e-9 * ev[2]:
                return False
            normals.append(vec[:, 2])
    return all(abs(abs(float(np.dot(n, normals[0]))) - 1) < 1e-9 for n in normals)


def _inside(geo: GeometryModel, point: list) -> bool:
    """Whether a point lies in (or on the boundary of) one of the geometry's cells, up to a relative
    tolerance. The bounding box alone is not enough (concave blocks, holes)."""
    lo, hi = geo.bounding_box
    tol = 1e-9 * max(float(np.max(hi - lo)), 1e-30)
    pt = np.zeros(3)
    pt[:geo.dim] = point
    if np.any(pt < lo - tol) or np.any(pt > hi + tol):
        return False
    vertex = occ.Vertex(occ.Pnt(*pt))
    return any(vertex.Distance(c) <= tol for c in cells(geo.shape, geo.dim))


def distributed_problems(scene: Scene, resume: bool = False) -> list[Problem]:
    """What a distributed run (``mpiexec -n N ngs-geomech run``, N >= 2) cannot do, each naming its scene key.

    Supported: thermal (steady, transient, k(T)), thermo-elastic (static mechanics, the lambda law) and Stefan
    scenes with glued interfaces. Not supported, and why:

    * contact interfaces and foundations: the contact and mortar operators pair the two sides of an interface by
      searching the other side's elements (``ContactBoundary``, segment mortar integrals), and the Newton steps
      factor saddle-point systems directly; a distributed mesh splits both sides over ranks that do not see each
      other's elements;
    * adaptivity: ``mesh.Refine()`` on a distributed mesh hung (NGSolve 6.2), and front-following remeshes on
      rank 0 only;
    * dynamic and viscous mechanics and nested iteration: their matrices are scipy (local) or coarse meshes are
      re-made serially;
    * checkpoints and --resume: a checkpoint holds one process's vectors.
    """
    problems: list[Problem] = []
    why = "is not supported in distributed runs (mpiexec -n N, N >= 2): run serially"
    for i, itf in enumerate(scene.interfaces):
        if itf.type == "contact":
            problems.append(Problem(f"interfaces[{i}] ({itf.name}).type", f"a contact interface {why} (the contact "
                                    "and mortar operators pair the sides of an interface by searching the other "
                                    "side's elements, which a distributed mesh splits over ranks)"))
    for name, bc in scene.boundary_conditions.items():
        if bc.foundation is not None:
            problems.append(Problem(f"boundary_conditions.{name}.foundation", f"contact with a foundation {why}"))
    if scene.adaptivity is not None:
        problems.append(Problem("adaptivity", f"adaptive refinement {why} (mesh refinement of a distributed mesh "
                                "is not available)"))
    if scene.physics.mechanics in ("dynamic", "viscous"):
        problems.append(Problem("physics.mechanics", f"mechanics = {scene.physics.mechanics!r} {why}; 'static' is "
                                "supported"))
    if scene.mechanics.nested_levels > 0:
        problems.append(Problem("mechanics.nested_levels", f"nested iteration {why}; set it to 0"))
    if scene.solver.linear == "direct":
        problems.append(Problem("solver.linear", "'direct' is not available in distributed runs (the systems are "
                                "solved by CG with BDDC); use 'auto' or 'iterative'"))
    if resume:
        problems.append(Problem("--resume", "distributed runs write no checkpoints, so they cannot be resumed"))
    return problems
