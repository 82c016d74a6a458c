"""What a run writes (:class:`RunOutput`): the probe series (thermal quantities at every step, the others at the
output times), the VTK series of the model's fields and the parts' line series at the output times, the figures
at the end (with a thin column's temperature profile along its axis at a few output times); on followed meshes it
moves with the model. Files go into the run's staging directory only.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..io.canvas import Canvas, Drawing
from ..io.lines_vtk import LineSeries
from ..io.meshdata import bounding_box, mesh_arrays
from ..io.profiles import AxisProfile
from ..io.scales import SCALES, figure_time
from ..io.sections import SectionPlane
from ..io.vtk import VtkSeries
from ..probes import ProbeSet
from ..scene.model import Scene
from ..scene.units import YEAR

UNITS = {"von_mises": "Pa", "mean_stress": "Pa", "sigma_1": "Pa", "sigma_3": "Pa", "displacement_x": "m",
         "displacement_y": "m", "displacement_z": "m", "liquid_fraction": "-",
         "front": "m from the line's first point"}
"""The units of the probe quantities in the probe figures (temperature: the scene's unit)."""


class RunOutput:
    """The run's output into ``directory`` (None: only the probes, nothing written); ``root``: this rank writes
    the files every rank contributes to (a distributed run's rank 0). ``write_s`` is the time spent writing the
    series (s)."""

    def __init__(self, scene: Scene, model, directory: Path | None, root: bool = True):
        self.scene, self.root = scene, root
        self.axisymmetric = scene.scene.dimension == "axisymmetric"
        self.probes = ProbeSet(model.mesh, scene.output.probes, self.axisymmetric)
        self.bounds = bounding_box(model.mesh)
        t0, t1 = (scene.time.start, scene.time.end) if scene.time else (0.0, 0.0)
        self.profile = AxisProfile.of(*self.bounds, t0, t1) if directory is not None and scene.output.figures \
            else None
        self.vtk = None
        self.lines: dict[str, LineSeries] = {}
        name = scene.scene.name
        if directory is not None:
            self.lines = {n: LineSeries(directory, f"{name}_{n}") for p in model.parts for n in p.line_names(scene)}
            if scene.output.vtk:
                self.vtk = VtkSeries(model.mesh, model.fields, directory, name, scene.output.subdivision,
                                     derived=model.derived)
        self.write_s = 0.0

    def switch(self, model) -> None:
        """Go on with ``model`` on a new mesh (followed meshes): the probes located anew (their series kept), the
        VTK of its fields."""
        moved = ProbeSet(model.mesh, self.scene.output.probes, self.axisymmetric)
        moved.times, moved.series = self.probes.times, self.probes.series
        self.probes = moved
        if self.vtk is not None:
            self.vtk.mesh, self.vtk.coefs = model.mesh, [model.fields[n] for n in self.vtk.names]

    def write(self, model, t: float, output: bool) -> None:
        """The probes of the parts recorded every step at t (s); at an output time the others, the VTK and the
        line series too."""
        for p in model.parts:
            if p.probes_every_step:
                self.probes.record(t, p.probe_fields)
        if not output:
            return
        for p in model.parts:
            if not p.probes_every_step and p.probe_fields:
                self.probes.record(t, p.probe_fields)
            if self.profile is not None and "temperature" in p.probe_fields:
                self.profile.record(model.mesh, t, p.probe_fields["temperature"])
        tic = time.perf_counter()
        if self.vtk is not None:
            self.vtk.write(t)
        for p in model.parts:
            data = p.lines() if any(n in self.lines for n in p.line_names(self.scene)) else {}
            for n, (points, cells, values) in data.items():
                if self.root:
                    self.lines[n].write(t, points, cells, values)
        self.write_s += time.perf_counter() - tic

    # -- checkpoints ----------------------------------------------------------------------------------------
    def lengths(self) -> dict:
        p = self.probes
        return {"probes": {n: len(v) for n, v in p.times.items()},
                "vtk": len(self.vtk.entries) if self.vtk is not None else 0,
                "lines": {n: len(s.entries) for n, s in self.lines.items()},
                "profile": len(self.profile.times) if self.profile is not None else 0}

    def meta(self, lengths: dict) -> dict:
        p = self.probes
        n = lengths["probes"]
        return {"probes": {"times": {k: p.times[k][:n[k]] for k in p.times},
                           "series": {k: p.series[k][:n[k]] for k in p.series}},
                "vtk": self.vtk.entries[:lengths["vtk"]] if self.vtk is not None else [],
                "lines": {k: s.entries[:lengths["lines"][k]] for k, s in self.lines.items()},
                "profile": self.profile.meta(lengths.get("profile", 0)) if self.profile is not None else {}}

    def restore(self, meta: dict) -> None:
        p = self.probes
        for n in p.times:
            p.times[n][:] = meta["probes"]["times"].get(n, [])
            p.series[n][:] = meta["probes"]["series"].get(n, [])
        if self.vtk is not None:
            self.vtk.restore(meta["vtk"], files=self.root)
        for n, s in self.lines.items():
            if self.root:                         # rank 0 alone writes the line series
                s.restore(meta["lines"].get(n, []))
        if self.profile is not None:
            self.profile.restore(meta.get("profile", {}))

    # -- figures --------------------------------------------------------------------------------------------
    def figures(self, model, policy, directory: Path, draw: bool = True) -> None:
        """The figures of the parts, the mesh policy, the probes and a thin column's profile (``figures/``). A
        distributed run calls this on every rank (the mesh data are gathered collectively); only the rank with
        ``draw`` draws and writes."""
        scene = self.scene
        if not scene.output.figures:
            return
        probes = self.probes
        groups: dict[str, list] = {}
        for p in probes.probes:
            if len(probes.times[p.name]) > 1:
                groups.setdefault(p.quantity, []).append(p.name)
        canvas = self.canvas(model, directory, draw)
        policy.figures(canvas)
        for part in model.parts:
            part.figures(canvas)
        for quantity, names in groups.items():
            self._probe_figure(canvas, quantity, names)
        if self.profile is not None and self.profile.times:
            self._profile_figure(canvas)

    def canvas(self, model, directory: Path, draw: bool) -> Canvas:
        """The canvas the figures are drawn on: the 2D mesh, or the plane sections of a 3D one (the scene's, else
        the mid-planes)."""
        scene = self.scene
        t_end = scene.time.end if scene.time else None
        lo, hi = self.bounds = bounding_box(model.mesh)
        sections = []
        if model.mesh.dim == 3:
            sections = SectionPlane.mid_planes(lo, hi) if scene.output.sections is None else \
                [SectionPlane.through(s.name, s.point, s.normal, s.window) for s in scene.output.sections]
        return Canvas(directory, scene.scene.name, mesh_arrays(model.mesh) if model.mesh.dim == 2 else None,
                      ("r (m)", "z (m)") if self.axisymmetric else ("x (m)", "y (m)"),
                      "degC" if scene.scene.temperature_unit == "C" else "K",
                      "steady state" if t_end is None else f"t = {figure_time(t_end)}",
                      scene.output.figure_window, Drawing(draw), bounds=(lo, hi), sections=sections)

    def _probe_figure(self, canvas: Canvas, quantity: str, names: list[str]) -> None:
        """The probes of one quantity over time; stresses in MPa or GPa, displacements in mm or m."""
        probes = self.probes
        times = probes.times[names[0]]
        unit, label = (YEAR, "t (years)") if times[-1] - times[0] >= 2 * YEAR else (1.0, "t (s)")
        fname = "probes.png" if quantity == "temperature" else f"probes_{quantity}.png"
        curves = {n: np.array([np.nan if v is None else v for v in probes.series[n]], dtype=float) for n in names}
        limits = {f"{p.name}: limit {p.limit:g}": p.limit for p in self.scene.output.probes
                  if p.name in names and p.limit is not None}
        y_unit = UNITS.get(quantity, canvas.t_unit)
        if y_unit in SCALES:
            scale = SCALES[y_unit](np.concatenate([*curves.values(), list(limits.values())]))
            curves = {n: scale(v) for n, v in curves.items()}
            limits = {n: float(scale(v)) for n, v in limits.items()}
            y_unit = scale.unit
        canvas.draw.time_curves(times, curves, canvas.path(fname), title=f"{canvas.title}: probes",
                                ylabel=f"{quantity} ({y_unit})", time_unit=unit, time_label=label, hlines=limits)

    def _profile_figure(self, canvas: Canvas) -> None:
        """The temperature along the thin column's axis at the kept output times (``temperature_profile.png``)."""
        pr = self.profile
        names = canvas.labels[0][0] + canvas.labels[1][0] + "z"
        vertical = pr.axis == (2 if len(self.bounds[0]) == 3 else 1)
        where = ", ".join(f"{names[k]} = {pr.points[0, k]:.4g}" for k in range(len(self.bounds[0])) if k != pr.axis)
        curves = {("steady state" if self.scene.time is None else f"t = {figure_time(t)}"): np.array(v)
                  for t, v in zip(pr.times, pr.values)}
        canvas.draw.profile_figure(pr.coord, curves, canvas.path("temperature_profile.png"),
                                   title=f"{canvas.title}: temperature along the column's axis ({where} m)",
                                   value_label=f"T ({canvas.t_unit})", coord_label=f"{names[pr.axis]} (m)",
                                   vertical=vertical)
