"""What a distributed run (``mpiexec -n N ngs-geomech run``, N >= 2) cannot do, each refusal naming its scene key."""

from __future__ import annotations

from ..errors import Problem
from ..scene.model import RATE_MECHANICS, Scene


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
    if scene.mesh.structured:
        problems.append(Problem("mesh.structured", f"a structured mesh {why} (it is built serially; the "
                                "distributed path sends netgen's mesh of the OCC geometry)"))
    if scene.adaptivity is not None:
        problems.append(Problem("adaptivity", f"adaptive refinement {why} (mesh refinement of a distributed mesh "
                                "is not available)"))
    if scene.physics.mechanics in RATE_MECHANICS:
        problems.append(Problem("physics.mechanics", f"mechanics = {scene.physics.mechanics!r} {why}; 'static' is "
                                "supported"))
    if scene.mechanics.nested_levels > 0:
        problems.append(Problem("mechanics.nested_levels", f"nested iteration {why}; set it to 0"))
    if scene.solver.linear == "direct":
        problems.append(Problem("solver.linear", "'direct' is not available in distributed runs (the systems are "
                                "solved by CG with GAMG or BDDC); use 'auto' or 'iterative'"))
    if resume:
        problems.append(Problem("--resume", "distributed runs write no checkpoints, so they cannot be resumed"))
    return problems
