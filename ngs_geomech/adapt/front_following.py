"""Front-following meshes for a scene's Stefan problem (``[adaptivity]`` with ``indicators = ['phase_front']`` in a
transient plane scene with a phase change, time-dependent).

The mesh is the scene's geometry meshed anew by :func:`ngs_geomech.geometry.mesh.make_mesh` (so the regions and
boundaries keep their names; sources, boundary conditions, probes and the Stefan setup are rebuilt on each mesh by
the run's ``build`` callable) with the local size restricted to h_front = h_base / 2^levels (h_base: the median
longest edge of the scene's own mesh in the phase-change regions) at the vertices of the elements the
liquid-fraction 1/2 iso-line crosses and ``layers`` rings around them
(:func:`ngs_geomech.adapt.estimators.phase_front`). Resolution is added ahead of the front and given back behind it
by remeshing from the geometry with the flags recomputed (not by coarsening): bisection of the strip's marked
triangles produced obtuse angles, the lumped P1 stiffness lost its M-matrix property (nodes undershot the coldest
boundary temperature, -0.548 against -0.5) and the Stefan Newton iteration cycled; netgen's Delaunay meshes of a
restricted size keep it.

When: ``remesh_every = k > 0``: after every k steps, at the front of the step's end. ``remesh_every = 0``
(default): after a step whose front reached elements 1.25 times coarser than the band's own (the largest element
the front crossed right after the last remesh; 1.5 h_front while there was no front): that step is discarded, the
mesh is refined at the front before and after it, the state before it is carried over and the step repeated on the
new mesh, so the front never moves through coarse elements (the first appearance of a front included). A mesh is
made in two passes when the elements the front crossed were coarser than 3 h_front (the first pass refines the
wide band of coarse elements, the second the band of ``layers`` fine rings), else one. When the front has vanished the
mesh goes back to the scene's own mesh.

Transfer: the nodal enthalpy by the lumped L2 projection e_i = int e_old phi_i dx / m_i (the old P1 field integrated
on the new mesh, :meth:`StefanForms.project_enthalpy`), which keeps the heat content up to the quadrature of a
piecewise-linear field of another mesh; each transfer's heat-content change is recorded (``remeshes``) and counted
in the Stefan energy balance (:meth:`StefanRun.adopt`), the only term besides the boundary and source heat.

No checkpoints: a front-following run is not resumable (the run refuses ``--resume`` for it).
Units: m, s, J per m of depth (plane scenes).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ..geometry.assemble import GeometryModel
from ..geometry.mesh import make_mesh
from ..scene.model import Scene
from .estimators import element_sizes, element_vertices, phase_front, vertex_coords
from .policy import MeshPolicy

log = logging.getLogger(__name__)

BAND_FACTOR = 1.25
"""remesh_every = 0: remesh when the front crosses elements this much larger than the band's."""

SECOND_PASS = 3.0
"""A second meshing narrows the band when the elements the front crossed were this much larger than h_front (a
front appearing in, or running into, coarse elements; a band of ``layers`` rings of such elements would be wide)."""


@dataclass
class RemeshRecord:
    """One remeshing: time (s), unknowns before/after, the heat content before/after the transfer (J per metre
    of depth in 2D) and its relative change, wall time (s)."""

    t: float
    ndof_before: int
    ndof_after: int
    heat_before: float
    heat_after: float
    wall_s: float

    @property
    def transfer_error(self) -> float:
        return abs(self.heat_after - self.heat_before) / max(abs(self.heat_before), 1e-300)


@dataclass
class Remesh(RemeshRecord):
    """One remeshing of a scene run: :class:`RemeshRecord` (time, unknowns, heat content before/after the transfer,
    wall time) plus the elements after it, whether the step was repeated, and the number of meshings."""

    elements_after: int = 0
    repeated_step: bool = False
    passes: int = 1

    def as_dict(self) -> dict:
        return {"t_s": self.t, "ndof_before": self.ndof_before, "ndof_after": self.ndof_after,
                "elements_after": self.elements_after, "heat_before": self.heat_before,
                "heat_after": self.heat_after, "heat_change_rel": self.transfer_error,
                "repeated_step": self.repeated_step, "meshings": self.passes, "wall_s": self.wall_s}


def phase_change_size(mesh, regions) -> float:
    """The median longest edge (m) of the elements of ``mesh`` in the phase-change ``regions`` (of all elements
    when there are none): the base size that front-following meshes halve ``levels`` times."""
    regions = set(regions)
    in_pc = np.array([el.mat in regions for el in mesh.Elements(ngs.VOL)])
    sizes = element_sizes(mesh)
    return float(np.median(sizes[in_pc] if in_pc.any() else sizes))


def _copy(gf):
    g = ngs.GridFunction(gf.space)
    g.vec.data = gf.vec
    return g


class FrontFollowing(MeshPolicy):
    """A Stefan problem on front-following meshes (module docstring), a :class:`~.policy.MeshPolicy`.
    ``build(mesh)`` returns the run's model on a mesh (its ``thermal`` part a :class:`StefanRun`); ``phys`` is
    the current one, replaced at each remesh."""

    checkpoints = False
    adapts_first = True

    def __init__(self, scene: Scene, geo: GeometryModel, build: Callable):
        super().__init__()
        a = scene.adaptivity
        self.scene, self.geo, self.build = scene, geo, build
        self.levels, self.layers, self.remesh_every = a.levels, a.layers, a.remesh_every
        self.phys = None
        self.h_base = self.h_front = 0.0
        self.remeshes: list[Remesh] = []
        self.ndofs: list[int] = []               # unknowns of each step's (final) mesh
        self.discarded_steps = 0
        self._since = 0
        self._on_base = True
        self._band_h = 0.0

    @property
    def mesh(self):
        return self.phys.mesh

    @property
    def stefan(self):
        return self.phys.thermal

    # -- meshes -------------------------------------------------------------------------------------------
    def _flags(self, liquids: list) -> np.ndarray:
        """Elements of the liquid fractions' mesh the iso-line 1/2 of any of ``liquids`` (P1 GridFunctions of one
        mesh) crosses, with ``layers`` rings."""
        return phase_front(liquids[0], layers=self.layers,
                           predicted=liquids[1] if len(liquids) > 1 else None).eta > 0

    def _restrictions(self, mesh, flags: np.ndarray) -> list:
        xy = vertex_coords(mesh)
        verts = np.unique(element_vertices(mesh)[flags])
        z = xy[verts, 2] if xy.shape[1] > 2 else np.zeros(len(verts))
        return [(float(xy[v, 0]), float(xy[v, 1]), float(zz), self.h_front) for v, zz in zip(verts, z)]

    def _mesh_at(self, liquids: list) -> tuple:
        """A mesh of the geometry refined at the fronts of ``liquids`` (GridFunctions on the current mesh; none: the
        scene's own mesh); returns (mesh, meshings, refined)."""
        flags = self._flags(liquids) if liquids else np.zeros(0, dtype=bool)
        if not flags.any():
            return make_mesh(self.geo, self.scene.mesh), 1, False
        old = liquids[0].space.mesh
        crossed = phase_front(liquids[0], layers=0,
                              predicted=liquids[1] if len(liquids) > 1 else None).eta > 0
        coarse = float(element_sizes(old)[crossed].max()) > SECOND_PASS * self.h_front
        mesh = make_mesh(self.geo, self.scene.mesh, self._restrictions(old, flags))
        if not coarse:
            return mesh, 1, True
        moved = []                              # second pass: the band of fine rings on the first pass's mesh
        for g in liquids:
            h = ngs.GridFunction(ngs.H1(mesh, order=1))
            h.Set(g)
            moved.append(h)
        flags = self._flags(moved)
        if not flags.any():
            return mesh, 1, True
        return make_mesh(self.geo, self.scene.mesh, self._restrictions(mesh, flags)), 2, True

    def _front_size(self) -> float:
        """The largest element the iso-line 1/2 (with one ring) crosses on the current mesh (0 without front)."""
        f = self.stefan.forms
        f.store(self.stefan.solver.e)
        flags = phase_front(f.gf_liquid_fraction, layers=1).eta > 0
        return float(element_sizes(f.mesh)[flags].max()) if flags.any() else 0.0

    # -- the run ------------------------------------------------------------------------------------------
    def prepare(self, model, t0: float | None):
        """The first mesh: refined ``levels`` times at the front of the initial state (the scene's own mesh when
        the initial state has no front); the initial state is set on it from the scene. Returns the model."""
        self.phys = model
        self.h_base = phase_change_size(model.mesh, model.thermal.regions)
        self.h_front = self.h_base * 0.5 ** self.levels
        self.stefan.set_initial(t0)
        for _ in range(self.levels):
            st = self.stefan
            st.forms.store(st.solver.e)
            flags = self._flags([st.forms.gf_liquid_fraction])
            if not flags.any():
                break
            if float(element_sizes(self.mesh)[flags].max()) <= 1.5 * self.h_front:
                break
            mesh = make_mesh(self.geo, self.scene.mesh, self._restrictions(self.mesh, flags))
            self.phys = self.build(mesh)
            self.stefan.set_initial(t0)
            self._on_base = False
        self._band_h = self._front_size()
        return self.phys

    def advance(self, model, step):
        """One step of the Stefan part (:meth:`step`); returns the model to go on with."""
        self.stefan.finish_step(self.step(step.a, step.b, step.where))
        return self.phys

    def step(self, a: float, b: float, where: str):
        """One Stefan step from a to b (s) on the current mesh, remeshing as the module docstring says (``phys``
        may be a new object afterwards). Returns the step's info."""
        st = self.stefan
        mark = st.mark()
        info = st.step(a, b, where)
        self._since += 1
        if self.remesh_every > 0:
            if self._since >= self.remesh_every:
                self._since = 0
                st.forms.store(st.solver.e)
                self._remesh(b, [_copy(st.forms.gf_liquid_fraction)], repeated=False)
        else:
            size = self._front_size()
            ref = BAND_FACTOR * self._band_h if self._band_h > 0 else 1.5 * self.h_front
            if size > ref:
                after = _copy(st.forms.gf_liquid_fraction)
                st.rewind(mark)
                self.discarded_steps += 1
                before = _copy(st.forms.gf_liquid_fraction)
                self._remesh(a, [after, before], repeated=True)
                info = self.stefan.step(a, b, where)
                self._band_h = self._front_size()
            elif size == 0.0 and not self._on_base:        # the front has gone: back to the scene's own mesh
                self._remesh(b, [], repeated=False)
        self.ndofs.append(self.stefan.forms.n)
        return info

    def _remesh(self, t: float, liquids: list, repeated: bool) -> None:
        """A new mesh at the fronts of ``liquids`` (none: the scene's own mesh), the current state carried over."""
        tic = time.perf_counter()
        old = self.stefan
        mesh, passes, refined = self._mesh_at(liquids)
        self._on_base = not refined
        self.factorizations_before += old.factorizations
        phys = self.build(mesh)
        new = phys.thermal
        heat_before, heat_after, commit = new.take_state(old, None)
        commit()
        self.phys = phys
        if not repeated:
            self._band_h = self._front_size()
        rec = Remesh(t, old.forms.n, new.forms.n, heat_before, heat_after, time.perf_counter() - tic,
                     elements_after=mesh.ne, repeated_step=repeated, passes=passes)
        self.remeshes.append(rec)
        log.info("front-following: remesh at t = %.6g s: %d -> %d dofs, heat content change %.1e", t,
                 rec.ndof_before, rec.ndof_after, rec.transfer_error)

    def summary(self) -> dict:
        n = np.array(self.ndofs, dtype=float)
        errs = [r.transfer_error for r in self.remeshes]
        return {"mode": "front_following", "indicators": ["phase_front"], "levels": self.levels,
                "layers": self.layers, "remesh_every": self.remesh_every, "h_base_m": self.h_base,
                "h_front_m": self.h_front, "remesh_count": len(self.remeshes),
                "repeated_steps": self.discarded_steps,
                "transfer_error_max": max(errs, default=0.0),
                "transfer_error_sum": float(sum(errs)),
                "dofs": {"mean": float(n.mean()) if len(n) else float(self.stefan.forms.n),
                         "max": int(n.max()) if len(n) else self.stefan.forms.n,
                         "min": int(n.min()) if len(n) else self.stefan.forms.n,
                         "final": self.stefan.forms.n},
                "remesh_wall_s": float(sum(r.wall_s for r in self.remeshes)),
                "remeshes": [r.as_dict() for r in self.remeshes]}
