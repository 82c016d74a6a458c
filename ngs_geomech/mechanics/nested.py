"""Nested iteration for Newton on the lambda law (2.1)-(2.5): the solution on coarser meshes of the same geometry
as Newton's start on the scene's mesh (``mechanics.nested_levels``).

Why: at lam = 1/2 the law tends to a rigid-perfectly plastic one, and Newton from the linear elastic solution needs
more steps as h falls (measured on the plate with a hole, P1, tol 1e-8: 12, 14, 16 at h = 0.1, 0.05, 0.025), the
early steps shortened by the line search where the strain crosses the rigid range. Started from the solution of
the mesh twice as coarse (itself started from the one before, from h = 0.2), it needs 9, 10, 9, and the whole
sequence took 2.2 s against 3.5 s for the cold solve at h = 0.025 (the solutions agree to 6e-15 in H1).

The coarse meshes are the scene's geometry meshed by :func:`ngs_geomech.geometry.mesh.make_mesh` with
``mesh.maxh`` and ``mesh.boundary_maxh`` times 2^k (blocks' own maxh stay: their regions coarsen less); the
temperature of the thermal stress is the scene mesh's field evaluated on them. Builds meshes and forms, writes
nothing; units as the elastic forms.
"""

from __future__ import annotations

import dataclasses

from ..geometry.assemble import GeometryModel
from ..geometry.mesh import make_mesh
from ..scene.model import Scene
from .forms import ElasticForms
from .problem import elastic_setup
from .solver import ElasticSolver


def coarse_settings(scene: Scene, k: int):
    """The scene's mesh settings with maxh and boundary_maxh times 2^k."""
    m = scene.mesh
    f = 2.0 ** k
    return dataclasses.replace(m, maxh=m.maxh * f, boundary_maxh={b: h * f for b, h in m.boundary_maxh.items()})


class NestedStart:
    """Newton's start on a scene's mesh by nested iteration (module docstring): the coarse meshes and forms are
    built at the first solve and kept (the temperature CF they hold is the scene mesh's field, so later solves
    see its new values)."""

    def __init__(self, scene: Scene, geo: GeometryModel, temperature):
        self.scene, self.geo, self.temperature = scene, geo, temperature
        self.levels: list[ElasticForms] = []

    def _build(self) -> None:
        for k in range(self.scene.mechanics.nested_levels, 0, -1):
            mesh = make_mesh(self.geo, coarse_settings(self.scene, k))
            self.levels.append(ElasticForms(mesh, elastic_setup(self.scene, self.geo, mesh, self.temperature)))

    def __call__(self, forms: ElasticForms, t: float, where: str) -> list:
        """Set ``forms``' displacement to the start at time t (s): the Newton solutions on the meshes 2^k coarser,
        k = nested_levels ... 1, each started from the previous one. Returns the coarse solves' (ndof,
        iterations, wall time s)."""
        if not self.levels:
            self._build()
        ms = self.scene.mechanics
        prev = None
        out = []
        for k, f in zip(range(ms.nested_levels, 0, -1), self.levels):
            f.t.Set(t)
            if prev is not None:
                f.displacement().Set(prev)
            solver = ElasticSolver(f, method="newton", tol=ms.tolerance, maxit=ms.max_iterations,
                                   start="linear" if prev is None else "current")
            info = solver.solve(f"{where}, nested iteration on the mesh {2 ** k} times coarser")
            out.append((int(f.X.ndof), info.iterations, info.wall_s))
            prev = f.displacement()
        if prev is not None:
            forms.displacement().Set(prev)
        return out
