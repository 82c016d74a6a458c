"""Meshes that follow a moving phase boundary (issue 6 section 2, time-dependent): the Stefan problem of
:mod:`ngs_geomech.stefan.forms` solved on meshes generated anew every ``remesh_every`` steps by netgen from the
geometry (a ``mesher`` callable: restrictions [(x, y, z, h)] -> Mesh; ``remesh_every = 0``: only when the front
is about to leave the refined band), with the local size restricted to the
fine size on the elements the liquid-fraction iso-line 1/2 crosses plus ``layers`` rings around them
(:func:`ngs_geomech.adapt.estimators.phase_front`): resolution is added ahead of the front and given back
behind it (remeshing from the geometry with the flags recomputed, rather than coarsening). The first mesh halves
the size at the front ``levels`` times, one meshing per level; a remesh restricts the size at the old mesh's
flagged elements to the finest size ``h_fine`` (one meshing).

Why remeshing and not netgen's marked bisection: bisection of the strip's triangles produced obtuse angles, the
lumped P1 stiffness lost its M-matrix property (nodes undershot the coldest boundary temperature, -0.548 against
-0.5) and the Stefan Newton iteration cycled; netgen's Delaunay meshes of a restricted size keep it.

State transfer: the nodal enthalpy is carried to the new mesh by the lumped L2 projection
e_i = int e_old phi_i dx / m_i (the old field integrated on the new mesh), which keeps the heat content
sum_i m_i e_i = int e_old up to the quadrature of the old (piecewise linear, on another mesh) field; the relative
change of the heat content at each transfer is recorded (``transfer_errors``) and reported. The solver (and its
factorization) is built anew on each mesh; the predictor rate starts at zero.

Writes nothing; units as in the Stefan forms (K, J/m^3, W, m, s).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np

from ..stefan.forms import StefanForms, StefanSetup
from ..stefan.solver import StefanSolver
from .estimators import element_sizes, element_vertices, phase_front, vertex_coords


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
class FrontAdaptiveStefan:
    """The Stefan problem on front-following meshes (module docstring). ``mesher(restrictions)`` generates a
    mesh of the geometry with netgen, the local size restricted at the points (x, y, z, h) (m); ``setup`` the
    :class:`StefanSetup` (its regions and boundary names must be the mesher's)."""

    mesher: object
    setup: StefanSetup
    levels: int = 4
    layers: int = 2
    remesh_every: int = 5
    transfer_order: int = 4
    transfer: str = "interpolation"
    solver_options: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.transfer not in ("interpolation", "projection"):
            raise ValueError(f"transfer must be 'interpolation' or 'projection', got {self.transfer!r}")
        if self.levels < 0 or self.layers < 0 or self.remesh_every < 0:
            raise ValueError(f"levels, layers, remesh_every >= 0 needed, got {self.levels}, {self.layers}, "
                             f"{self.remesh_every}")
        self.forms: StefanForms | None = None
        self.solver: StefanSolver | None = None
        self.remeshes: list[RemeshRecord] = []
        self.ndofs: list[int] = []          # unknowns of each step's mesh
        self.iterations: list[int] = []
        self.boundary_heat = 0.0
        self.source_heat = 0.0
        self._steps = 0

    # -- meshes -----------------------------------------------------------------------------------------------
    def _restrictions(self, mesh, liquid, h_target: float) -> list:
        """(x, y, z, h_target) at the vertices of the elements of ``mesh`` the iso-line 1/2 of ``liquid`` (a CF or
        a GridFunction on another mesh) crosses, plus ``layers`` rings."""
        g = ngs.GridFunction(ngs.H1(mesh, order=1))
        g.Set(liquid)
        flags = phase_front(g, layers=self.layers).eta > 0
        if not flags.any():
            return []
        xy = vertex_coords(mesh)
        verts = np.unique(element_vertices(mesh)[flags])
        z = xy[verts, 2] if xy.shape[1] > 2 else np.zeros(len(verts))
        return [(float(xy[v, 0]), float(xy[v, 1]), float(zz), float(h_target)) for v, zz in zip(verts, z)]

    def _mesh_for(self, liquid) -> ngs.Mesh:
        """The first mesh: the size halved ``levels`` times at the iso-line 1/2 of the CF ``liquid`` (the size of
        the base mesh is the median element size of ``mesher([])``); sets ``h_fine``."""
        mesh = self.mesher([])
        h = float(np.median(element_sizes(mesh)))
        self.h_fine = h * 0.5 ** self.levels
        restrictions: list = []
        for _ in range(self.levels):
            h *= 0.5
            new = self._restrictions(mesh, liquid, h)
            if not new:
                break
            restrictions += new
            mesh = self.mesher(restrictions)
        return mesh

    def _build(self, mesh) -> None:
        self._sizes = element_sizes(mesh)
        self.forms = StefanForms(mesh, self.setup)
        self.solver = StefanSolver(self.forms, **self.solver_options)

    # -- state ------------------------------------------------------------------------------------------------
    def start(self, enthalpy_cf, liquid_cf) -> None:
        """The first mesh from the initial liquid fraction ``liquid_cf`` (CF, 0..1) and the initial enthalpy
        ``enthalpy_cf`` (CF, J/m^3) projected onto it."""
        self._build(self._mesh_for(liquid_cf))
        self.solver.set_initial_enthalpy(self.forms.project_enthalpy(enthalpy_cf, order=self.transfer_order))
        self._band_h = self._front_size()

    def remesh(self, t: float) -> RemeshRecord:
        """Rebuild the mesh at the current front and transfer the enthalpy (module docstring)."""
        tic = time.perf_counter()
        old_forms, old_e = self.forms, self.solver.e
        heat_before = old_forms.heat_content(old_e)
        n_before = old_forms.n
        old_forms.store(old_e)
        restrictions = self._restrictions(old_forms.mesh, old_forms.gf_liquid_fraction, self.h_fine)
        self._build(self.mesher(restrictions))
        if self.transfer == "projection":
            e = self.forms.project_enthalpy(old_forms.gf_enthalpy, order=self.transfer_order)
        else:                                   # the old P1 enthalpy at the new vertices
            xy = vertex_coords(self.forms.mesh)
            pts = old_forms.mesh(*xy.T) if xy.shape[1] == 3 else old_forms.mesh(xy[:, 0], xy[:, 1])
            e = np.asarray(old_forms.gf_enthalpy(pts), dtype=float).ravel()
        self.solver.set_initial_enthalpy(e)
        self._band_h = self._front_size()
        rec = RemeshRecord(t, n_before, self.forms.n, heat_before, self.forms.heat_content(e),
                           time.perf_counter() - tic)
        self.remeshes.append(rec)
        return rec

    def step(self, t_old: float, t_new: float):
        """One step of the Stefan solver on the current mesh; remeshes after every ``remesh_every`` steps."""
        info = self.solver.step(t_old, t_new)
        self.ndofs.append(self.forms.n)
        self.iterations.append(info.iterations)
        self.boundary_heat += info.boundary_heat
        self.source_heat += info.source_heat
        self._steps += 1
        if self.remesh_every == 0:
            if self._front_leaves_band():
                self.remesh(t_new)
        elif self._steps % self.remesh_every == 0:
            self.remesh(t_new)
        return info

    def _front_size(self) -> float:
        """The largest element the iso-line 1/2 (with one ring) crosses on the current mesh (0 without front)."""
        f = self.forms
        f.store(self.solver.e)
        flags = phase_front(f.gf_liquid_fraction, layers=1).eta > 0
        return float(np.max(self._sizes[flags])) if flags.any() else 0.0

    def _front_leaves_band(self) -> bool:
        """Whether the front reaches elements 1.25 times coarser than the ones it crossed right after the last
        (re)meshing: it is about to leave the refined band (``remesh_every = 0``: remesh only then). Netgen does
        not reach a restricted size exactly, so the band's own size is the reference, not h_fine."""
        return self._front_size() > 1.25 * self._band_h

    @property
    def transfer_errors(self) -> list[float]:
        return [r.transfer_error for r in self.remeshes]

    def mean_ndof(self) -> float:
        return float(np.mean(self.ndofs)) if self.ndofs else float(self.forms.n)
