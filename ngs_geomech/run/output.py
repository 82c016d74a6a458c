"""What a run writes (:class:`RunOutput`): the probe series (thermal quantities at every step, the others at the
output times), the VTK series of the model's fields and the parts' line series at the output times, the figures
at the end; on followed meshes it moves with the model. Files go into the run's staging directory only.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..io.canvas import Canvas, Drawing
from ..io.lines_vtk import LineSeries
from ..io.meshdata import mesh_arrays
from ..io.vtk import VtkSeries
from ..probes import ProbeSet
from ..scene.model import Scene
from ..scene.units import YEAR, format_time

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
        self.vtk = None
        self.lines: dict[str, LineSeries] = {}
        name = scene.scene.name
        if directory is not None:
            self.lines = {n: LineSeries(directory, f"{name}_{n}") for p in model.parts for n in p.line_names(scene)}
            if scene.output.vtk:
                self.vtk = VtkSeries(model.mesh, model.fields, directory, name, scene.output.subdivision)
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
                "lines": {n: len(s.entries) for n, s in self.lines.items()}}

    def meta(self, lengths: dict) -> dict:
        p = self.probes
        n = lengths["probes"]
        return {"probes": {"times": {k: p.times[k][:n[k]] for k in p.times},
                           "series": {k: p.series[k][:n[k]] for k in p.series}},
                "vtk": self.vtk.entries[:lengths["vtk"]] if self.vtk is not None else [],
                "lines": {k: s.entries[:lengths["lines"][k]] for k, s in self.lines.items()}}

    def restore(self, meta: dict) -> None:
        p = self.probes
        for n in p.times:
            p.times[n][:] = meta["probes"]["times"].get(n, [])
            p.series[n][:] = meta["probes"]["series"].get(n, [])
        if self.vtk is not None:
            self.vtk.restore(meta["vtk"])
        for n, s in self.lines.items():
            s.restore(meta["lines"].get(n, []))

    # -- figures --------------------------------------------------------------------------------------------
    def figures(self, model, policy, directory: Path, draw: bool = True) -> None:
        """The figures of the parts, the mesh policy and the probes (``figures/``). A distributed run calls this on
        every rank (the mesh data are gathered collectively); only the rank with ``draw`` draws and writes."""
        scene = self.scene
        if not scene.output.figures:
            return
        probes = self.probes
        groups: dict[str, list] = {}
        for p in probes.probes:
            if len(probes.times[p.name]) > 1:
                groups.setdefault(p.quantity, []).append(p.name)
        t_end = scene.time.end if scene.time else None
        canvas = Canvas(directory, scene.scene.name, mesh_arrays(model.mesh) if model.mesh.dim == 2 else None,
                        ("r (m)", "z (m)") if self.axisymmetric else ("x (m)", "y (m)"),
                        "degC" if scene.scene.temperature_unit == "C" else "K",
                        "steady state" if t_end is None else f"t = {format_time(t_end)}",
                        scene.output.figure_window, Drawing(draw))
        policy.figures(canvas)
        for part in model.parts:
            part.figures(canvas)
        for quantity, names in groups.items():
            self._probe_figure(canvas, quantity, names)

    def _probe_figure(self, canvas: Canvas, quantity: str, names: list[str]) -> None:
        probes = self.probes
        times = probes.times[names[0]]
        unit, label = (YEAR, "t (years)") if times[-1] - times[0] >= 2 * YEAR else (1.0, "t (s)")
        fname = "probes.png" if quantity == "temperature" else f"probes_{quantity}.png"
        curves = {n: np.array([np.nan if v is None else v for v in probes.series[n]], dtype=float) for n in names}
        limits = {f"{p.name}: limit {p.limit:g}": p.limit for p in self.scene.output.probes
                  if p.name in names and p.limit is not None}
        canvas.draw.time_curves(times, curves, canvas.path(fname), title=f"{canvas.title}: probes",
                                ylabel=f"{quantity} ({UNITS.get(quantity, canvas.t_unit)})",
                                time_unit=unit, time_label=label, hlines=limits)
