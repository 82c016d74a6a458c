"""Validation of ``[adaptivity]``: what each kind of adapted mesh supports (:mod:`ngs_geomech.adapt`): the
SOLVE -> ESTIMATE -> MARK -> REFINE loop of stationary scenes, the mesh adapted once to the start of a transient
heat scene, and meshes that follow the phase boundary or the contact zones over time."""

from __future__ import annotations

import math

from ..errors import Problem
from ..scene.model import Scene
from .check_materials import stefan_scene


def check_adaptivity(scene: Scene, problems: list[Problem]) -> None:
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
