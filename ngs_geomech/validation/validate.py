"""Semantic validation of a scene, before any meshing or solving.

Every problem found is reported, each naming its item: unknown region or boundary names, regions without a material,
unphysical values, inconsistent settings. The declared type and range of every key come first
(:func:`~ngs_geomech.scene.schema.recheck`), then the rules that join keys, by subject: names and temperatures
(:mod:`.check_values`), settings (:mod:`.check_settings`, :mod:`.check_adaptivity`, the contacts' frictional heating
:mod:`.check_frictional`), materials (:mod:`.check_materials`) and, on the geometry (built cheaply: OCC shapes, no
mesh), the names it must hold (:mod:`.check_geometry`), the interfaces' contact-conductance keys
(:mod:`.check_conductance`), the values expressions take on it (:mod:`.expression_values`) and the material values
that vary over their regions and the contact laws' values along their sides (:mod:`.material_values`). What
distributed runs cannot do is :mod:`.check_distributed`.
"""

from __future__ import annotations

from ..errors import Problem, SceneError
from ..geometry.assemble import GeometryModel, build_geometry
from ..geometry.structured import structured_problems
from ..scene.model import Scene
from ..scene.schema import recheck
from .check_conductance import check_conductance
from .check_distributed import distributed_problems
from .check_frictional import check_frictional_heating
from .check_geometry import check_mesh_size, check_references
from .check_materials import check_conductivity_range, check_materials, check_phase_change, stefan_scene
from .check_output import check_sections
from .check_settings import check_settings
from .check_values import check_names, check_temperatures
from .expression_values import check_expression_values
from .material_values import check_contact_values, check_material_values, check_phase_conductivity_values

__all__ = ["distributed_problems", "stefan_scene", "validate"]


def validate(scene: Scene) -> GeometryModel:
    """Check a scene; return its geometry model, or raise SceneError listing every problem."""
    problems: list[Problem] = []
    recheck(scene, "", problems)        # the declared types and ranges (also of a scene built in Python)
    check_names(scene, problems)
    check_settings(scene, problems)
    problems += structured_problems(scene)
    check_frictional_heating(scene, problems)
    check_materials(scene, problems)
    check_phase_change(scene, problems)
    check_temperatures(scene, problems)
    geo = None
    if not any(p.item.startswith(("blocks", "cuts")) for p in problems):
        try:
            geo = build_geometry(scene)
        except SceneError as exc:
            problems += exc.problems
    if geo is not None:
        check_references(scene, geo, problems)
        check_conductance(scene, geo, problems)
        check_sections(scene, geo, problems)
        check_mesh_size(scene, geo, problems)
        check_expression_values(scene, geo, problems)
        check_material_values(scene, geo, problems)
        check_phase_conductivity_values(scene, geo, problems)
        check_contact_values(scene, geo, problems)
        if not problems:
            check_conductivity_range(scene, geo, problems)
    if problems:
        # a declared range is checked both by recheck and by the physics' reading of a material (the same
        # problem from the same declaration): each once
        raise SceneError(list(dict.fromkeys(problems)), source=f"scene {scene.scene.name!r}")
    return geo
