"""From a scene to the elastic problem's plain inputs (:class:`ElasticSetup`)."""

from __future__ import annotations

import numpy as np

from ..elastic_materials import elastic_properties
from ..geometry.assemble import GeometryModel
from ..physics.coefficients import expression_function
from ..physics.elasticity import ElasticSetup, mixed_regions
from ..scene.model import Scene


def mechanics_model(scene: Scene) -> str:
    """'plane_strain' | 'plane_stress' | 'axisymmetric' | '3d' for a scene."""
    if scene.scene.dimension == "3d":
        return "3d"
    if scene.scene.dimension == "axisymmetric":
        return "axisymmetric"
    return scene.physics.plane_model


def axis_boundaries(mesh, names) -> list[str]:
    """Boundary names all of whose vertices lie on the axis x = 0 (axisymmetric scenes: u_r = 0 there)."""
    pts = np.array([v.point for v in mesh.vertices])
    size = float(np.max(pts.max(axis=0) - pts.min(axis=0)))
    out = []
    for name in names:
        els = list(mesh.Boundaries(name).Elements())
        if els and all(abs(mesh[v].point[0]) <= 1e-9 * size for el in els for v in el.vertices):
            out.append(name)
    return out


def elastic_setup(scene: Scene, geo: GeometryModel, mesh, temperature=None) -> ElasticSetup:
    """The ElasticSetup of a validated scene on its mesh; ``temperature`` is the heat solution CF or None."""
    dim = 3 if scene.scene.dimension == "3d" else 2
    props = {name: elastic_properties(m, dim) for name, m in scene.materials.items()}
    ms = scene.mechanics
    setup = ElasticSetup(props=props, model=mechanics_model(scene), order=scene.mesh.order,
                         gravity=tuple(ms.gravity) if ms.gravity else None,
                         temperature=temperature, regularization=ms.regularization, formulation=ms.formulation)
    for name, bc in scene.boundary_conditions.items():
        if bc.displacement is not None:
            setup.dirichlet[name] = [None if c == "free" else expression_function(c) for c in bc.displacement]
        elif bc.traction is not None:
            setup.traction[name] = [expression_function(c) for c in bc.traction]
        elif bc.pressure is not None:
            setup.pressure[name] = expression_function(bc.pressure)
        elif bc.symmetry:
            setup.symmetry.append(name)
    if ms.initial_stress is not None:
        setup.initial_stress = [[expression_function(c) for c in row] for row in ms.initial_stress]
    if setup.model == "axisymmetric":
        taken = set(setup.dirichlet) | set(setup.symmetry)
        setup.axis = [n for n in axis_boundaries(mesh, sorted(set(mesh.GetBoundaries()))) if n not in taken]
    return setup


def mechanics_warnings(scene: Scene, setup: ElasticSetup) -> list[str]:
    """Warnings a user should see before trusting the result (printed on stdout, kept in summary.json)."""
    mixed, notes = mixed_regions(setup)
    out = list(notes)
    if scene.mesh.order == 1:
        for name, p in setup.props.items():
            nu = p.max_poisson
            if nu is not None and nu > 0.49 and name not in mixed:
                out.append(f"materials.{name}: Poisson ratio {nu:.4f} > 0.49 with P1 elements of the displacement "
                           "formulation locks (stresses and displacements far too small); use mechanics.formulation "
                           "= 'mixed' or mesh.order = 2 or higher")
    for name, p in setup.props.items():
        if p.lam < 0.5:
            out.append(f"materials.{name}: rheology_lambda {p.lam:g} < 0.5 makes the stress-strain law non-monotone "
                       "(the energy is not convex): solutions may localize or not be unique")
    return out
