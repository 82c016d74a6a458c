"""What a distributed run (``mpiexec -n N ngs-geomech run``, N >= 2) cannot do, each refusal naming its scene key."""

from __future__ import annotations

from ..errors import Problem
from ..heat.materials import has_phase_change
from ..scene.model import RATE_MECHANICS, Scene


def distributed_problems(scene: Scene) -> list[Problem]:
    """What a distributed run (``mpiexec -n N ngs-geomech run``, N >= 2) cannot do, each naming its scene key.

    Supported: thermal (steady, transient, k(T)), thermo-elastic (static mechanics, the lambda law) and Stefan
    scenes with glued interfaces; static contact (every law, interfaces and foundations, floating bodies) with
    PETSc; heat crossing contact interfaces (perfect contact by the mortar coupling; contact conductance: constant,
    power law in the contact pressure, tables, gap conductivity, radiation; k(T)) in heat and thermo-elastic scenes.
    Not supported, and why:

    * contact without PETSc or with Uzawa's method (:func:`_contact_problems`); heat crossing a contact interface
      in Stefan scenes and frictional heating (:func:`_contact_heat_problems`);
    * meshes that follow a phase boundary or contact zones over time (:func:`_adaptivity_problems`); adaptive
      refinement of stationary scenes by the estimators and the contact-zone indicator (and the mesh adapted once
      for a transient heat scene) is supported;
    * dynamic and viscous mechanics and nested iteration: their matrices are scipy (local) or coarse meshes are
      re-made serially.

    Checkpoints and ``--resume`` work as in serial runs (:mod:`ngs_geomech.run.checkpoint`: the vectors are kept
    in a numbering of the whole mesh and the contact solver's node arrays with their coordinates, so a checkpoint
    resumes on any rank count or serially); a serial run's checkpoint of fields of mesh.order > 1 is refused on a
    distributed resume, naming the field.
    """
    problems: list[Problem] = []
    why = "is not supported in distributed runs (mpiexec -n N, N >= 2): run serially"
    problems += _contact_problems(scene, why)
    if scene.mesh.structured:
        problems.append(Problem("mesh.structured", f"a structured mesh {why} (it is built serially; the "
                                "distributed path sends netgen's mesh of the OCC geometry)"))
    problems += _adaptivity_problems(scene, why)
    if scene.physics.mechanics in RATE_MECHANICS:
        problems.append(Problem("physics.mechanics", f"mechanics = {scene.physics.mechanics!r} {why}; 'static' is "
                                "supported"))
    if scene.mechanics.nested_levels > 0:
        problems.append(Problem("mechanics.nested_levels", f"nested iteration {why}; set it to 0"))
    if scene.solver.linear == "direct":
        problems.append(Problem("solver.linear", "'direct' is not available in distributed runs (the systems are "
                                "solved by CG with GAMG or BDDC); use 'auto' or 'iterative'"))
    return problems


def _adaptivity_problems(scene: Scene, why: str) -> list[Problem]:
    """What a distributed run cannot do with ``[adaptivity]``: rank 0 refines its copy of the whole mesh and sends
    it out again (:mod:`ngs_geomech.adapt.distributed`), which serves the stationary adaptive loop (the estimators,
    and the contact-zone indicator, evaluated on rank 0's whole mesh) and the mesh adapted once; the meshes that
    follow a phase boundary or contact zones over time remesh the geometry on one process
    (:mod:`ngs_geomech.adapt.front_following`, :mod:`ngs_geomech.adapt.contact_following`)."""
    a = scene.adaptivity
    if a is None or scene.time is None:
        return []
    followed = [name for name in ("contact_zone", "phase_front") if name in a.indicators]
    if not followed:
        return []
    return [Problem("adaptivity.indicators", f"meshes that follow the {' and '.join(followed)} over time {why} "
                    "(they remesh the geometry on one process); stationary scenes refine adaptively")]


def _contact_problems(scene: Scene, why: str) -> list[Problem]:
    """What a distributed run cannot do with contact: contact needs PETSc (its Newton steps are solved by PETSc's
    GMRES, :mod:`ngs_geomech.contact.distributed`), static mechanics and the semi-smooth Newton method (Uzawa's
    method factors K); heat crossing them: :func:`_contact_heat_problems`."""
    contacts = [(f"interfaces[{i}] ({itf.name})", itf) for i, itf in enumerate(scene.interfaces)
                if itf.type == "contact"]
    contacts += [(f"boundary_conditions.{name}.foundation", bc.foundation)
                  for name, bc in scene.boundary_conditions.items() if bc.foundation is not None]
    if not contacts:
        return []
    from ..linalg.iterative import petsc_available

    problems = []
    if scene.physics.mechanics is not None and not petsc_available():     # heat alone needs no PETSc
        key = contacts[0][0] + (".type" if contacts[0][0].startswith("interfaces") else "")
        problems.append(Problem(key, "contact in distributed runs needs petsc4py (its Newton steps are solved by "
                                "PETSc): pip install -e '.[petsc]' (docs/parallel.md), or run serially"))
    for key, c in contacts:
        if c.method == "uzawa":
            problems.append(Problem(f"{key}.method", f"'uzawa' {why}; use 'ssn' or 'penalty'"))
    return problems + _contact_heat_problems(scene, contacts, why)


def _contact_heat_problems(scene: Scene, contacts: list, why: str) -> list[Problem]:
    """What a distributed run cannot do with heat crossing a contact interface: the couplings of heat scenes
    (mortar, contact conductance) are built in a global numbering and the step systems solved on one rank
    (:mod:`ngs_geomech.heat.distributed`); the jump penalty of Stefan scenes and frictional heating stay serial."""
    if scene.physics.thermal is None:
        return []
    problems = [Problem(f"{key}.frictional_heating", f"frictional heating {why} (its sources are transferred "
                        "between the contact's sides on one process)")
                for key, c in contacts if getattr(c, "frictional_heating", None)]
    heated = [(key, c) for key, c in contacts if key.startswith("interfaces") and (c.sides is None or any(
        getattr(c, k) is not None for k in ("conductance", "conductance_coefficient", "gap_conductivity",
                                            "emissivities", "thermal_penalty")))]
    if not heated:
        return problems
    stefan = [n for n, m in scene.materials.items() if has_phase_change(m)]
    if stefan:
        return problems + [Problem(heated[0][0], f"heat crossing a contact interface in a Stefan scene (phase change "
                                   f"in materials.{stefan[0]}) {why} (the jump penalty of the enthalpy forms is "
                                   "serial); heat and thermo-elastic scenes are supported")]
    return problems
