"""Running a scene: validate, mesh, build only the physics it declares, solve, write the output.

Output (into ``out``, written completely or not at all): ``<scene>.pvd`` + ``<scene>_stepNNNNN.vtu``
(VTK series with every computed field and the region id), ``figures/*.png`` and ``summary.json``.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import ngsolve as ngs

from .errors import SolverError
from .geometry.assemble import GeometryModel
from .geometry.mesh import make_mesh
from .io import figures
from .io.atomic import OutputDir, write_json_atomic
from .io.meshdata import mesh_arrays, vertex_values
from .io.progress import Progress
from .io.summary import finite, probe_statistics, versions
from .io.vtk import VtkSeries
from .physics.thermal import HeatForms
from .probes import ProbeSet
from .problems.heat import heat_setup, initial_temperature
from .scene.model import Scene
from .scene.schema import to_dict
from .scene.validate import validate
from .solvers.heat import HeatSolver
from .solvers.timesteps import schedule
from .units import YEAR, format_time


@dataclass
class RunResult:
    """What a run produced: the state at the end and the figures of the summary."""

    mesh: object
    forms: HeatForms
    summary: dict
    out: Path | None
    timings: dict = field(default_factory=dict)


def run_scene(scene: Scene, out: str | Path | None, *, progress: bool = True, threads: int | None = None,
              geometry: GeometryModel | None = None) -> RunResult:
    """Run a scene. ``out=None`` writes nothing (for tests and studies)."""
    timings: dict[str, float] = {}
    t0 = _time.perf_counter()
    geo = geometry or validate(scene)
    timings["validate_s"] = _time.perf_counter() - t0
    if threads:
        ngs.SetNumThreads(threads)
    staging = OutputDir(Path(out)) if out is not None else None
    try:
        with ngs.TaskManager():
            result = _run(scene, geo, staging, progress, timings)
        timings["total_s"] = _time.perf_counter() - t0
        result.summary["wall_time_s"] = finite(timings)
        if staging is not None:
            write_json_atomic(staging.path / "summary.json", result.summary)
            result.out = staging.commit()
        return result
    except BaseException:
        if staging is not None:
            staging.abort()
        raise


def _run(scene: Scene, geo: GeometryModel, staging: OutputDir | None, show: bool, timings: dict) -> RunResult:
    tic = _time.perf_counter()
    mesh = make_mesh(geo, scene.mesh)
    timings["mesh_s"] = _time.perf_counter() - tic
    axi = scene.scene.dimension == "axisymmetric"
    tic = _time.perf_counter()
    setup = heat_setup(scene, geo, mesh)
    forms = HeatForms(mesh, setup)
    solver = HeatSolver(forms)
    probes = ProbeSet(mesh, scene.output.probes, axi)
    timings["setup_s"] = _time.perf_counter() - tic
    T = forms.temperature()
    fields = {"temperature": T,
              "region": mesh.MaterialCF({n: i for i, n in enumerate(mesh.GetMaterials())}, default=-1),
              "heat_flux": forms.heat_flux(T)}
    if setup.nonlinear:
        fields["kirchhoff_theta"] = forms.kirchhoff(T)
    name = scene.scene.name
    vtk = None
    if staging is not None and scene.output.vtk:
        vtk = VtkSeries(mesh, fields, staging.path, name, scene.output.subdivision)
    history = {"time": [], "newton_iterations": [], "interface_heat_flow_W": {}}
    solve_s = 0.0
    if scene.physics.thermal == "steady":
        tic = _time.perf_counter()
        forms.t_new.Set(0.0)
        info = solver.solve("steady state")
        solve_s += _time.perf_counter() - tic
        probes.record(0.0, T)
        history["time"].append(0.0)
        history["newton_iterations"].append(info.iterations)
        _interface_flows(forms, history, axi)
        if vtk:
            vtk.write(0.0)
        nsteps = 0
    else:
        ts = scene.time
        forms.t_new.Set(ts.start)
        T.Set(initial_temperature(scene, mesh, forms.t_new))
        solver.set_dirichlet()
        probes.record(ts.start, T)
        history["time"].append(ts.start)
        if vtk:
            vtk.write(ts.start)
        steps = list(schedule(ts.start, ts.end, ts.dt, ts.dt_growth, ts.dt_max))
        bar = Progress(ts.end - ts.start, f"{name}", enabled=show)
        for k, (a, b) in enumerate(steps):
            tic = _time.perf_counter()
            forms.gf_old.vec.data = forms.gf.vec
            forms.t_old.Set(a)
            forms.t_new.Set(b)
            forms.inv_dt.Set(1.0 / (b - a))
            try:
                info = solver.solve(f"step {k + 1} (t = {format_time(b)})")
            except SolverError:
                bar.close()
                raise
            solve_s += _time.perf_counter() - tic
            probes.record(b, T)
            history["time"].append(b)
            history["newton_iterations"].append(info.iterations)
            _interface_flows(forms, history, axi)
            last = k == len(steps) - 1
            if vtk and ((k + 1) % scene.output.every == 0 or last):
                vtk.write(b)
            bar.update(b - ts.start, f"t = {format_time(b)}  dt = {format_time(b - a)}")
        bar.close()
        nsteps = len(steps)
    timings["solve_s"] = solve_s
    summary = {
        "scene": to_dict(scene),
        "versions": versions(),
        "mesh": {"vertices": mesh.nv, "elements": mesh.ne, "dofs": forms.X.ndof, "order": scene.mesh.order,
                 "regions": list(mesh.GetMaterials())},
        "steps": nsteps,
        "factorizations": solver.factorizations,
        "newton_iterations_max": max(history["newton_iterations"] or [0]),
        "probes": {n: finite(probe_statistics(probes.times, v)) for n, v in probes.series.items()},
        "probe_series": {"time_s": probes.times, **{n: finite(v) for n, v in probes.series.items()}},
        "interface_heat_flow_W": {k: finite(v) for k, v in history["interface_heat_flow_W"].items()},
    }
    if staging is not None:
        tic = _time.perf_counter()
        _figures(scene, mesh, T, probes, staging.path / "figures")
        timings["output_s"] = _time.perf_counter() - tic
    return RunResult(mesh=mesh, forms=forms, summary=summary, out=None, timings=timings)


def _interface_flows(forms: HeatForms, history: dict, axi: bool) -> None:
    """Heat flow through each contact interface (W; W per m of depth in plane scenes), master -> minion."""
    w = 2 * 3.141592653589793 * ngs.x if axi else 1.0
    for (master, _), lam in zip(forms.setup.contacts, forms.multipliers()):
        q = float(ngs.Integrate(w * lam * ngs.ds(definedon=forms.mesh.Boundaries(master)), forms.mesh))
        history["interface_heat_flow_W"].setdefault(master, []).append(q)


def _figures(scene: Scene, mesh, T, probes: ProbeSet, directory: Path) -> None:
    if not scene.output.figures or (mesh.dim != 2 and not (probes.series and len(probes.times) > 1)):
        return
    directory.mkdir(parents=True, exist_ok=True)
    t_unit = "degC" if scene.scene.temperature_unit == "C" else "K"
    if mesh.dim == 2:
        arrays = mesh_arrays(mesh)
        labels = ("r (m)", "z (m)") if scene.scene.dimension == "axisymmetric" else ("x (m)", "y (m)")
        vals = vertex_values(T)
        t_end = probes.times[-1] if probes.times else 0.0
        figures.field_figure(arrays, vals, directory / "temperature.png",
                             title=f"{scene.scene.name}: temperature at t = {format_time(t_end)}",
                             label=f"T ({t_unit})", axis_labels=labels)
        if scene.output.figure_window:
            figures.field_figure(arrays, vals, directory / "temperature_zoom.png",
                                 title=f"{scene.scene.name}: temperature at t = {format_time(t_end)} (near field)",
                                 label=f"T ({t_unit})", axis_labels=labels, window=scene.output.figure_window)
    if probes.series and len(probes.times) > 1:
        span = probes.times[-1] - probes.times[0]
        unit, label = (YEAR, "t (years)") if span >= 2 * YEAR else (1.0, "t (s)")
        figures.time_curves(probes.times, probes.series, directory / "probes.png",
                            title=f"{scene.scene.name}: probes", ylabel=f"temperature ({t_unit})",
                            time_unit=unit, time_label=label)
