"""Running a scene: validate, mesh, build only the physics it declares, solve, write the output.

Output (into ``out``, written completely or not at all): ``<scene>.pvd`` + ``<scene>_stepNNNNN.vtu``
(VTK series with every computed field and the region id), ``figures/*.png``, ``summary.json`` and the marker
``ngs-geomech-output.json`` listing these files. ``out`` is checked before any meshing (:mod:`.io.outdir`: an
existing file, ``/``, a mount point, a directory not writable or of other files without ``overwrite`` are
refused); the files of an earlier output in ``out`` are replaced, no other file there is touched.
Scenes with phase change (a material with ``phase_change_temperature``, physics.thermal = 'transient') are
solved by the Stefan solver (:mod:`ngs_geomech.stefan.problem`) instead of the heat solver; they also write
the phase boundary (liquid fraction 1/2) per output time as ``<scene>_phase_boundary.pvd`` + ``.vtp`` (2D),
``figures/phase_boundary.png`` and ``figures/melted_fraction.png``, and a ``stefan`` block in the summary.

Time-dependent runs write checkpoints (:mod:`ngs_geomech.checkpoint`) into ``checkpoint/`` of their staging
directory ``.<out>.partial-*``: every ``output.checkpoint_every`` steps (default every tenth of the steps
and after any step ending 5 minutes of wall time after the last checkpoint), and the last good state when a
step fails or the run is interrupted (Ctrl-C). A killed, failed or interrupted run that holds a checkpoint
leaves its staging directory behind (``out`` itself is untouched; a disk that fills up stops the run with
:class:`~.errors.OutputError` naming the kept checkpoint); ``run_scene(..., resume=True)`` (the
command line's ``--resume``) continues it from its last checkpoint and commits ``out`` at the end as usual.

Distributed runs (``mpiexec -n N``, N >= 2; :mod:`ngs_geomech.parallel`): every rank runs this module on its part
of the mesh (rank 0 meshes and distributes, keeping no elements); what a distributed run cannot do is refused first
(:func:`~ngs_geomech.scene.validate.distributed_problems`). Rank 0 creates, commits or removes the staging
directory, prints the progress and writes summary.json, figures and line series; every rank with elements writes
its VTK parts; values that need the whole mesh (probes, mesh counts, figure data) are gathered collectively, so
every rank takes every output branch. No checkpoints are written.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import ngsolve as ngs
import numpy as np

from . import parallel
from .adapt.contact_following import ContactFollowing, contact_statuses
from .adapt.front_following import FrontFollowing
from .adapt.loop import adaptive_solve, refine_mesh
from .adapt.marking import StopRule
from .checkpoint import CHECKPOINT_WALL_S, Plan, RunState, Snapshot, check_scene, plan_steps
from .checkpoint import where as checkpoint_where
from .contact.elastic import ElasticContactSolver
from .contact.factory import build_contact_solver
from .contact.output import ContactOutput
from .contact.problem import check_supported, contact_options, contact_specs, contact_warnings
from .contact.solver import nodal_modulus
from .coupling.problem import KELVIN, DeformationHeating, relative_change
from .dynamics.problem import DynamicsRun
from .errors import OutputError, Problem, ResumeError, SceneError, SolverError
from .geometry.assemble import GeometryModel
from .geometry.mesh import make_mesh
from .heat.forms import HeatForms
from .heat.problem import heat_setup, set_initial_temperature
from .heat.solver import HeatSolver
from .io import figures, stress_figures
from .io.atomic import OutputDir, is_locked, staging_dirs, write_json_atomic
from .io.checkpoint import Checkpoint, find_resumable, has_checkpoint, scene_hash
from .io.lines_vtk import LineSeries
from .io.meshdata import mesh_arrays, vertex_values
from .io.outdir import disk_full
from .io.progress import Progress
from .io.summary import finite, probe_statistics, versions
from .io.vtk import VtkSeries
from .mechanics.forms import ElasticForms, stress_measures
from .mechanics.nested import NestedStart
from .mechanics.problem import elastic_setup, mechanics_warnings, probe_fields, watch_small_strain
from .mechanics.solver import ElasticSolver, NonlinearInfo
from .probes import THERMAL, ProbeSet
from .scene.model import Scene
from .scene.names import plain_file_name
from .scene.schema import to_dict
from .scene.units import YEAR, format_time
from .scene.validate import distributed_problems, stefan_scene, validate
from .stefan.forms import vertex_rules
from .stefan.problem import StefanRun

log = logging.getLogger(__name__)


@dataclass
class RunResult:
    """What a run produced: the state at the end and the figures of the summary."""

    mesh: object
    forms: HeatForms
    summary: dict
    out: Path | None
    timings: dict = field(default_factory=dict)
    mechanics: object = None
    stefan: StefanRun | None = None


def run_scene(scene: Scene, out: str | Path | None, *, progress: bool = True, threads: int | None = None,
              geometry: GeometryModel | None = None, resume: bool = False, overwrite: bool = False,
              comm=None) -> RunResult:
    """Run a scene. ``out=None`` writes nothing (for tests and studies). ``overwrite=True`` allows an ``out``
    that holds files other than an earlier output (they are kept; same-named ones replaced). ``resume=True``
    continues the interrupted run into ``out`` from its last checkpoint (:class:`ResumeError` when there is
    none, or when the scene or the mesh differs from the checkpointed run's). ``comm`` (an mpi4py communicator
    of several ranks, every rank calling this): a distributed run (module docstring); None: serial, also inside
    an MPI job whose ranks run separate scenes (``mpi4py.futures`` samples)."""
    timings: dict[str, float] = {}
    t0 = _time.perf_counter()
    if comm is not None and comm.size < 2:
        comm = None
    geo = geometry or validate(scene)
    if comm is not None:
        problems = distributed_problems(scene, resume)
        if problems:
            raise SceneError(problems, source=f"scene {scene.scene.name!r} (distributed run, {comm.size} ranks)")
    timings["validate_s"] = _time.perf_counter() - t0
    cp = None
    if resume:
        cp = _checkpoint_to_resume(scene, out)
    if threads:
        ngs.SetNumThreads(threads)
    elif comm is not None:
        ngs.SetNumThreads(1)                    # one thread per rank unless asked (ranks x threads <= cores)
    root = comm is None or comm.rank == 0
    staging = None
    if out is not None:
        if cp is None and root:
            _note_resumable(Path(out))
        try:
            staging = _staging(Path(out), cp, comm, overwrite, scene.scene.name)
        except BlockingIOError as exc:
            raise ResumeError(f"cannot resume: {exc}") from None
    try:
        with ngs.TaskManager():
            result = _run(scene, geo, staging, progress and root, timings, cp, comm)
        timings["total_s"] = _time.perf_counter() - t0
        result.summary["wall_time_s"] = finite(timings)
        if comm is not None:
            comm.Barrier()                      # every rank's VTK part is written
        if staging is not None and root:
            write_json_atomic(staging.path / "summary.json", result.summary)
            result.out = staging.commit()
        elif staging is not None:
            result.out = Path(out)
        return result
    except BaseException as exc:
        if staging is not None and root:
            # a staging directory with a checkpoint stays for --resume (out itself is untouched)
            kept = has_checkpoint(staging.path)
            staging.abort(keep=kept)
            if disk_full(exc):
                raise OutputError(f"disk full: checkpoint kept in {staging.scratch}, --resume after freeing space"
                                  if kept else f"disk full: {out} was not written and its staging directory was "
                                  "removed; free space and run again") from None
        raise


@dataclass
class _RankStaging:
    """The staging directory of a distributed run as the ranks other than 0 see it: they write their VTK parts
    into it; rank 0 owns it (creates, commits or removes it)."""

    path: Path


def _staging(out: Path, cp: Checkpoint | None, comm, overwrite: bool, name: str):
    """The run's staging directory (rank 0 checks ``out``, creates it and tells the others its path)."""
    if comm is None:
        return OutputDir(out, resume=cp.staging if cp is not None else None, overwrite=overwrite, scene=name)
    if comm.rank == 0:
        try:
            staging = OutputDir(out, overwrite=overwrite, scene=name)
        except BaseException:
            comm.bcast(None, root=0)
            raise
        comm.bcast(str(staging.path), root=0)
        return staging
    path = comm.bcast(None, root=0)
    if path is None:
        raise SolverError(f"rank {comm.rank}: rank 0 could not create the staging directory of {out}")
    return _RankStaging(Path(path))


def _checkpoint_to_resume(scene: Scene, out) -> Checkpoint:
    if out is None:
        raise ResumeError("resume needs the output directory of the interrupted run")
    transient = scene.physics.thermal == "transient" or (not scene.physics.thermal and scene.time is not None)
    if not transient:
        raise ResumeError(f"scene {scene.scene.name!r} is not time-dependent: only time-dependent runs write "
                          "checkpoints; run without --resume")
    if scene.adaptivity is not None:
        raise ResumeError(f"scene {scene.scene.name!r} runs on meshes that follow its phase boundary or contact "
                          "zones ([adaptivity]): such runs "
                          "write no checkpoints and cannot be resumed; run again without --resume")
    found = find_resumable(Path(out))
    d = to_dict(scene)
    cp = next((c for c in found if c.meta.get("scene_hash") == scene_hash(d)), found[0])   # else: say why not
    check_scene(cp, d)
    return cp


def _note_resumable(out: Path) -> None:
    """Warn about checkpoints of interrupted runs into ``out`` that this run will supersede (and remove)."""
    for d in staging_dirs(out):
        if has_checkpoint(d) and not is_locked(d):
            log.warning("%s holds a checkpoint of an interrupted run into %s; it is removed when this run "
                        "finishes (stop it and add --resume to continue that run instead)", d, out)


def _run(scene: Scene, geo: GeometryModel, staging: OutputDir | None, show: bool, timings: dict,
         cp: Checkpoint | None = None, comm=None) -> RunResult:
    tic = _time.perf_counter()
    mesh = make_mesh(geo, scene.mesh, comm=comm)
    timings["mesh_s"] = _time.perf_counter() - tic
    axi = scene.scene.dimension == "axisymmetric"
    name = scene.scene.name
    tic = _time.perf_counter()
    phys = _Physics(scene, geo, mesh)
    adaptive = front = zone = pre = None
    ad = scene.adaptivity
    if ad is not None and scene.time is not None and "contact_zone" in ad.indicators:
        # validated: static mechanics with contact, plane or axisymmetric (the mesh changes at mechanics solves)
        zone = ContactFollowing(scene, geo, phys, lambda m: _Physics(scene, geo, m))
    elif ad is not None and scene.time is not None and "phase_front" in ad.indicators:   # validated: plane Stefan
        front = FrontFollowing(scene, geo, phys, lambda m: _Physics(scene, geo, m))
        phys = front.start(scene.time.start)
        mesh = phys.mesh
        timings["adaptivity_s"] = _time.perf_counter() - tic
    elif ad is not None and scene.time is not None:
        # validated: transient heat without a followed feature: the mesh adapted once to the steady heat problem
        # with the data at the start time, the run on it
        pre = _SceneAdaptive(scene, geo, phys, steady_at=scene.time.start)
        pre.result = adaptive_solve(pre, **pre.settings())
        phys, mesh = pre.phys, pre.mesh
        timings["adaptivity_s"] = _time.perf_counter() - tic
    elif ad is not None:                      # validated: a stationary scene
        adaptive = _SceneAdaptive(scene, geo, phys)
        run_ = adaptive_solve(adaptive, **adaptive.settings())
        adaptive.result = run_
        phys, mesh = adaptive.phys, adaptive.mesh
        timings["adaptivity_s"] = _time.perf_counter() - tic
    fields, heat, solver, T, stefan, mech, coupling = (phys.fields, phys.heat, phys.solver, phys.T, phys.stefan,
                                                       phys.mech, phys.coupling)
    root = comm is None or comm.rank == 0
    if comm is None:
        log.info("%s: %d elements, %d vertices; mesh %.2f s, setup %.2f s", name, mesh.ne, mesh.nv,
                 timings["mesh_s"], _time.perf_counter() - tic)
    shown = list(mech.warnings) if mech is not None else []
    if root:                                  # a distributed run says them once
        for w in shown:
            log.warning("%s", w)
    probes = ProbeSet(mesh, scene.output.probes, axi)
    timings["setup_s"] = _time.perf_counter() - tic
    vtk = None
    lines = {}
    boundary_series = None
    if staging is not None and scene.output.contact_vtp and mech is not None and mech.contact_output is not None:
        lines = {c.name: LineSeries(staging.path, f"{name}_contact_{c.name}") for c in mech.contacts}
    if staging is not None and scene.output.vtk:
        vtk = VtkSeries(mesh, fields, staging.path, name, scene.output.subdivision)
        if stefan is not None and mesh.dim == 2:
            boundary_series = LineSeries(staging.path, f"{name}_phase_boundary")
    thermal_fields = {"temperature": T}
    if stefan is not None:
        phi = stefan.fields["liquid_fraction"]
        thermal_fields.update(liquid_fraction=phi, front=phi)
    every_step = mech is not None and mech.every_step
    history = {"newton_iterations": [], "interface_heat_flow_W": {},
               "coupling": {"passes": [], "deformation_heat": [], "change_T": [], "change_u": [],
                            "conductivity_factor": []}}
    solve_s = 0.0
    write_s = 0.0        # writing the VTK and .vtp series inside output(): counted in output_s, not in solve_s

    def switch(new: _Physics) -> None:
        """Go on with the physics ``new`` on a new mesh (following meshes): the run's objects, probes and VTK."""
        nonlocal phys, mesh, heat, solver, T, stefan, mech, coupling, thermal_fields, probes
        phys, mesh, heat, solver, T, stefan, mech, coupling = (new, new.mesh, new.heat, new.solver, new.T,
                                                               new.stefan, new.mech, new.coupling)
        if T is not None:
            thermal_fields = {"temperature": T}
        if stefan is not None:
            phi = stefan.fields["liquid_fraction"]
            thermal_fields.update(liquid_fraction=phi, front=phi)
        probes = _moved_probes(probes, scene, mesh, axi)
        if vtk:
            vtk.mesh, vtk.coefs = mesh, [phys.fields[n] for n in vtk.names]

    def follow(t: float, where: str, dt: float | None = None) -> None:
        """Contact-zone following: the mechanics solve at t (``dt`` given: it was solved by the coupled step of
        length dt and recorded), the run switched to the new mesh when it remeshed."""
        new = zone.solve(t, where) if dt is None else zone.check(t, where)
        if new is phys:
            return
        switch(new)
        if coupling is not None:
            _update_pressure(heat, stefan, mech, where)
            if dt is not None:                   # the step's rate and record from the solve on the new mesh
                coupling.set_rate(dt)
                mech.record(t, replace=True)

    def output(t: float, k: int | None, last: bool, where: str) -> None:
        """Mechanics (when on) and VTK at the output steps; thermal probes at every step."""
        nonlocal write_s
        if T is not None:
            probes.record(t, thermal_fields)
        if k is not None and not ((k + 1) % scene.output.every == 0 or last):
            return
        if stefan is not None:
            stefan.record(t)
        if mech is not None:
            if adaptive is not None or (zone is not None and (coupling is None or k is None)):
                mech.record(t)                   # solved by the adaptive loop / the zone follower
            elif k is None or (coupling is None and not every_step):
                mech.solve(t, where)
            elif coupling is None:                   # dynamics: advanced in every step, recorded here
                mech.record(t)
            probes.record(t, mech.probe_fields)
        tic_write = _time.perf_counter()
        if vtk:
            vtk.write(t)
        if boundary_series is not None:
            iso = stefan.phase_boundary()            # collective on a distributed mesh (so is vertex_values)
            temperature = iso.interpolate(vertex_values(T))
            if comm is None or comm.rank == 0:
                boundary_series.write(t, iso.points, iso.segments, {"temperature": temperature})
        for spec, res in zip(mech.contacts if lines else [], mech.contact_output.latest if lines else []):
            lines[spec.name].write(t, np.column_stack([res[c] for c in "xyz" if c in res]), spec.cells,
                                   {k: res[k] for k in ("pressure", "traction", "traction_t1", "traction_t2", "gap",
                                                        "slip", "status", "bound") if k in res})
        write_s += _time.perf_counter() - tic_write

    ts = scene.time
    transient = scene.physics.thermal == "transient" or (heat is None and ts is not None)
    all_lines = dict(lines, **({"phase_boundary__": boundary_series} if boundary_series is not None else {}))
    state = RunState(to_dict(scene), mesh, heat, solver, mech, probes, vtk, all_lines, history, stefan, coupling)
    if not transient:
        tic = _time.perf_counter()
        if heat is not None:
            if adaptive is None:
                heat.t_new.Set(0.0)
                info = solver.solve("steady state")
            else:
                info = adaptive.heat_info
            history["newton_iterations"].append(info.iterations)
            _interface_flows(heat, history, axi)
        written = write_s
        output(0.0, None, True, "steady state")
        solve_s += _time.perf_counter() - tic - (write_s - written)
        nsteps = 0
    else:
        plan = plan_steps(ts, cp)
        nsteps = plan.total
        if cp is None:
            if heat is not None:
                heat.t_new.Set(ts.start)
                set_initial_temperature(T, scene, mesh, heat.t_new)
                solver.set_dirichlet()
            tic0 = _time.perf_counter()
            written = write_s
            if stefan is not None:
                stefan.set_initial(ts.start)
            if zone is not None:
                follow(ts.start, f"t = {format_time(ts.start)}")
            output(ts.start, None, True, f"t = {format_time(ts.start)}")
            if coupling is not None:
                _update_pressure(heat, stefan, mech, f"t = {format_time(ts.start)}")
            # the initial state (with mechanics, the t = 0 solve) without writing its output
            timings["initial_s"] = _time.perf_counter() - tic0 - (write_s - written)
            t_done = ts.start
        else:
            state.check_mesh(cp)
            state.restore(cp)
            if coupling is not None:
                _update_pressure(heat, stefan, mech, "resume")
            solve_s = float(cp.meta["solve_s"])
            t_done = float(cp.meta["time_s"])
            log.info("resuming from the checkpoint at %s of %d", checkpoint_where(cp), nsteps)
        every = scene.output.checkpoint_every
        if every is None:
            every, wall = max(1, math.ceil(nsteps / 10)), CHECKPOINT_WALL_S
        else:
            wall = math.inf
        last_saved = _time.perf_counter()
        # none on following meshes, nor in distributed runs
        snapshots = staging is not None and front is None and zone is None and comm is None
        snap = state.capture(plan.k0, t_done, solve_s) if snapshots else None
        bar = Progress(ts.end - ts.start, f"{name}", enabled=show)
        try:
            for j, (a, b) in enumerate(plan.steps):
                k = plan.k0 + j
                tic = _time.perf_counter()
                written, newton = write_s, len(history["newton_iterations"])
                where = f"step {k + 1} (t = {format_time(b)})"
                if coupling is not None:
                    _coupled_step(scene, a, b, where, heat, solver, stefan, mech, coupling, history)
                    if heat is not None:
                        _interface_flows(heat, history, axi)
                    if zone is not None:         # mechanics solved in every coupled step
                        follow(b, where, dt=b - a)
                else:
                    if heat is not None:
                        _heat_step(heat, solver, a, b)
                        info = solver.solve(where)
                        history["newton_iterations"].append(info.iterations)
                        _interface_flows(heat, history, axi)
                    if front is not None:
                        info = front.step(a, b, where)
                        history["newton_iterations"].append(info.iterations)
                        if front.phys is not phys:         # remeshed: the run goes on on the new mesh
                            switch(front.phys)
                    elif stefan is not None:
                        info = stefan.step(a, b, where)
                        history["newton_iterations"].append(info.iterations)
                    if every_step:
                        mech.solve(b, where, record=False)
                if zone is not None and coupling is None and ((k + 1) % scene.output.every == 0 or k == nsteps - 1):
                    follow(b, where)
                output(b, k, k == nsteps - 1, where)
                solve_s += _time.perf_counter() - tic - (write_s - written)
                if log.isEnabledFor(logging.DEBUG):
                    its = history["newton_iterations"][newton:]
                    log.debug("%s: %.3f s%s", where, _time.perf_counter() - tic,
                              f", Newton iterations {its}" if its else "")
                if snapshots:       # (a run writing nothing has no checkpoints, nor one on front- or
                    # contact-zone-following meshes or a distributed one)
                    snap = state.capture(k + 1, b, solve_s)
                    if every and k + 1 < nsteps and \
                            ((k + 1) % every == 0 or _time.perf_counter() - last_saved >= wall):
                        state.save(snap, staging.scratch, plan)
                        last_saved = _time.perf_counter()
                bar.update(b - ts.start, f"t = {format_time(b)}  dt = {format_time(b - a)}")
        except BaseException as exc:
            bar.close()
            _stop(exc, staging, state, snap, plan, nsteps)
            raise
        bar.close()
    state_factorizations = (front.factorizations if front is not None else zone.factorizations if zone is not None
                            else state.factorizations())
    timings["solve_s"] = solve_s
    if comm is None:
        dofs = (heat.X.ndof if heat else 0) + (stefan.forms.n if stefan else 0) + (mech.forms.X.ndof if mech else 0)
        counts = {"vertices": mesh.nv, "elements": mesh.ne}
    else:
        dofs = ((heat.X.ndofglobal if heat else 0) + (stefan.forms.V.ndofglobal if stefan else 0)
                + (mech.forms.X.ndofglobal if mech else 0))
        counts = {"vertices": ngs.H1(mesh, order=1).ndofglobal, "elements": parallel.allsum(mesh, mesh.ne),
                  "ranks": comm.size, "elements_per_rank": parallel.allgather(mesh, mesh.ne)}
    thermal_times = next((probes.times[p.name] for p in scene.output.probes if p.quantity in THERMAL), [])
    if root and mech is not None:             # the warnings of the solves (small-strain range)
        for w in mech.warnings:
            if w not in shown:
                log.warning("%s", w)
    summary = {
        "scene": to_dict(scene),
        "versions": versions(),
        "mesh": {**counts, "dofs": dofs, "order": scene.mesh.order,
                 "regions": list(mesh.GetMaterials())},
        "steps": nsteps,
        "factorizations": state_factorizations,
        "newton_iterations_max": max(history["newton_iterations"] or [0]),
        "probes": {n: finite(probe_statistics(probes.times[n], v)) for n, v in probes.series.items()},
        "probe_series": {"time_s": thermal_times,
                         **{n: finite(v) for n, v in probes.series.items()},
                         "times_s": {n: probes.times[n] for n in probes.series}},
        "interface_heat_flow_W": {k: finite(v) for k, v in history["interface_heat_flow_W"].items()},
        "warnings": mech.warnings if mech else [],
    }
    if state.resumed:
        summary["resumed"] = state.resumed
    if mech is not None:
        summary["mechanics"] = mech.summary()
    if stefan is not None:
        summary["stefan"] = stefan.summary()
    if coupling is not None:
        summary["coupling"] = _coupling_summary(scene, history["coupling"])
    if adaptive is not None:
        summary["adaptivity"] = adaptive.summary()
    if front is not None:
        summary["adaptivity"] = front.summary()
    if pre is not None:
        summary["adaptivity"] = {"mode": "pre_adapted", "adapted_at_s": scene.time.start, **pre.summary()}
    if zone is not None:
        summary["adaptivity"] = zone.summary()
    if staging is not None:
        tic = _time.perf_counter()
        _figures(scene, mesh, T, probes, staging.path / "figures", mech, stefan, coupling, adaptive,
                 draw=comm is None or comm.rank == 0)
        timings["output_s"] = write_s + _time.perf_counter() - tic      # the series above and the figures
    return RunResult(mesh=mesh, forms=heat, summary=summary, out=None, timings=timings, mechanics=mech,
                     stefan=stefan)


def _moved_probes(probes: ProbeSet, scene: Scene, mesh, axi: bool) -> ProbeSet:
    """The probes on a new mesh (front-following), their series so far kept."""
    new = ProbeSet(mesh, scene.output.probes, axi)
    new.times, new.series = probes.times, probes.series
    return new


def _heat_step(heat: HeatForms, solver: HeatSolver, a: float, b: float) -> None:
    """Set a heat step from a to b (s) up: the old state and the times."""
    heat.gf_old.vec.data = heat.gf.vec
    heat.t_old.Set(a)
    heat.t_new.Set(b)
    heat.inv_dt.Set(1.0 / (b - a))


def _deformation_heating(scene: Scene, mesh, mech, heat: HeatForms | None, stefan: StefanRun | None):
    """The deformation-heating source of problem (P_c) against the heat problem's test functions."""
    offset = KELVIN if scene.scene.temperature_unit == "C" else 0.0
    extra = mech.dissipation_source()          # viscous heat (2.6); None for static mechanics
    if stefan is not None:
        V = stefan.forms.V
        return DeformationHeating(mech.forms, V, V.TestFunction(), ngs.dx(intrules=vertex_rules(mesh.dim)), 1.0,
                                  offset, extra)
    tests = heat.X.TestFunction()
    v = tests[0] if heat.setup.contacts else tests
    return DeformationHeating(mech.forms, heat.X, v, heat.volume_measure(), heat.weight, offset, extra)


def _coupled_step(scene: Scene, a: float, b: float, where: str, heat, solver, stefan, mech, coupling,
                  history: dict) -> None:
    """One step of problem (P_c) (:mod:`ngs_geomech.coupling.problem`): the heat step with the deformation
    heating of the last displacement rate, then the mechanics at b; 'iterated' repeats the pair with the new
    rate until T and u change by less than physics.coupling_tolerance between passes."""
    ph = scene.physics
    dt = b - a
    coupling.start_step()
    mark = stefan.mark() if stefan is not None else None
    if heat is not None:
        _heat_step(heat, solver, a, b)
    passes = ph.coupling_max_iterations if ph.coupling == "iterated" else 1
    prev = None
    dT = du = 0.0
    for p in range(passes):
        if p and stefan is not None:
            stefan.rewind(mark)
        load = coupling.load()
        if stefan is not None:
            info = stefan.step(a, b, where, load)
            T_now = stefan.forms.gf_temperature.vec.FV().NumPy().copy()
        else:
            heat.extra_load = coupling.vector()
            info = solver.solve(where)
            T_now = heat.temperature().vec.FV().NumPy().copy()
        mech.solve(b, f"{where}, coupling pass {p + 1}", record=False)
        factors = _update_pressure(heat, stefan, mech, where)
        coupling.set_rate(dt)
        u_now = mech.forms.gf.vec.FV().NumPy().copy()
        if prev is not None:
            m = mech.forms.mesh
            dT, du = relative_change(T_now, prev[0], m), relative_change(u_now, prev[1], m)
        if ph.coupling == "staggered" or (prev is not None and dT <= ph.coupling_tolerance
                                          and du <= ph.coupling_tolerance):
            break
        prev = (T_now, u_now)
    else:
        raise SolverError(f"coupled heat-mechanics step at {where}: the heat and mechanics steps still differ after "
                          f"{passes} passes (relative changes between the last two: T {dT:.2e}, u {du:.2e}; "
                          f"physics.coupling_tolerance {ph.coupling_tolerance:g}). Reduce the time step, raise "
                          "physics.coupling_max_iterations, or use coupling = 'staggered'.")
    history["newton_iterations"].append(info.iterations)
    c = history["coupling"]
    c["passes"].append(p + 1)
    c["deformation_heat"].append(dt * coupling.power())
    c["change_T"].append(dT)
    c["change_u"].append(du)
    c["conductivity_factor"].append(factors)
    mech.record(b)


def _update_pressure(heat, stefan, mech, where: str):
    """Give the heat (Stefan) forms the mean pressure of the last mechanics solve (kappa(T, p)); returns the
    (min, max) conductivity factors, or None without pressure-dependent conductivities."""
    forms = stefan.forms if stefan is not None else heat
    if forms.gf_pressure is None:
        return None
    try:
        return forms.set_pressure(-mech.fields["mean_stress"])
    except ValueError as exc:
        raise SolverError(f"coupled step at {where}: {exc}; reduce the load or the pressure coefficient") from None


def _coupling_summary(scene: Scene, c: dict) -> dict:
    passes = c["passes"]
    return {"mode": scene.physics.coupling,
            "deformation_heating": "-Theta_0 beta : e(u_t) (2.49), W/m^3 (field deformation_heating)",
            "passes_per_step": {"mean": float(np.mean(passes)) if passes else 0.0, "max": int(max(passes, default=0))},
            "deformation_heat_total": float(np.sum(c["deformation_heat"])),
            "deformation_heat_per_step": c["deformation_heat"],
            "units": {"deformation_heat": "J per m of depth" if scene.scene.dimension != "3d" else "J"},
            "conductivity_pressure_factor": ({"min": min(f[0] for f in c["conductivity_factor"] if f),
                                              "max": max(f[1] for f in c["conductivity_factor"] if f)}
                                             if any(c["conductivity_factor"]) else None),
            "last_change_T_max": float(max(c["change_T"], default=0.0)),
            "last_change_u_max": float(max(c["change_u"], default=0.0))}


def _stop(exc: BaseException, staging: OutputDir | None, state: RunState, snap: Snapshot | None, plan: Plan,
          nsteps: int) -> None:
    """A step failed or the run was interrupted: save the last good state (the last completed step) as a
    checkpoint, and raise SolverError and KeyboardInterrupt again with how to continue in their message
    (other exceptions: the caller re-raises them as they are)."""
    if staging is None or snap is None:
        return
    if snap.step > plan.k0 and state.saved_step != snap.step:     # new steps since the start or the checkpoint
        try:
            state.save(snap, staging.scratch, plan)
        except Exception as err:   # noqa: BLE001 - report the original failure, not this one
            log.warning("could not write the checkpoint of step %d: %s", snap.step, err)
    if not has_checkpoint(staging.path):
        return
    hint = (f"The last good state (step {state.saved_step} of {nsteps}, t = {format_time(state.saved_time)}) is "
            f"saved in {staging.scratch}: after a fix (e.g. a smaller time step, --set time.dt=...), the same "
            "command with --resume continues from it.")
    if isinstance(exc, SolverError):
        raise SolverError(f"{exc}\n{hint}") from exc
    if isinstance(exc, KeyboardInterrupt):
        raise KeyboardInterrupt(hint) from exc


class _Physics:
    """What a scene solves on one mesh: heat (or Stefan) forms and solver, mechanics, the coupling, and the
    output fields; built only as the scene declares."""

    def __init__(self, scene: Scene, geo: GeometryModel, mesh):
        self.mesh = mesh
        self.fields = {"region": mesh.MaterialCF({n: i for i, n in enumerate(mesh.GetMaterials())}, default=-1)}
        self.heat = self.solver = self.T = self.stefan = None
        if stefan_scene(scene):           # phase change: the enthalpy (Stefan) solver replaces the heat solver
            self.stefan = StefanRun(scene, mesh, geo)
            self.T = self.stefan.fields["temperature"]
            self.fields.update(self.stefan.fields)
        elif scene.physics.thermal:
            setup = heat_setup(scene, geo, mesh)
            self.heat = HeatForms(mesh, setup)
            sv = scene.solver
            self.solver = HeatSolver(self.heat, solver=sv.linear, tol=sv.tolerance, maxit=sv.max_iterations,
                                     preconditioner=sv.preconditioner)
            self.T = self.heat.temperature()
            self.fields["temperature"] = self.T
            self.fields["heat_flux"] = self.heat.heat_flux(self.T)
            if setup.nonlinear:
                self.fields["kirchhoff_theta"] = self.heat.kirchhoff(self.T)
        self.mech = None
        if scene.physics.mechanics in ("dynamic", "viscous"):
            self.mech = DynamicsRun(scene, geo, mesh, self.T)
            self.fields.update(self.mech.fields)
        elif scene.physics.mechanics:
            self.mech = _Mechanics(scene, geo, mesh, self.T)
            self.fields.update(self.mech.fields)
        self.coupling = None
        if scene.physics.coupling != "none" and self.mech is not None and self.T is not None:
            self.coupling = _deformation_heating(scene, mesh, self.mech, self.heat, self.stefan)
            self.fields["deformation_heating"] = self.coupling.source

    @property
    def ndof(self) -> int:
        return ((self.heat.X.ndof if self.heat is not None else 0)
                + (self.mech.forms.X.ndof if self.mech is not None else 0))


class _SceneAdaptive:
    """A stationary scene as an :class:`ngs_geomech.adapt.loop.AdaptiveProblem`: each step solves the steady heat
    problem and then the mechanics on the current mesh; the scene's estimator measures the target problem's
    error; refining bisects the marked elements (curved again to the mesh order) and builds the physics anew on
    the refined mesh (contact pairs and mortar couplings included)."""

    def __init__(self, scene: Scene, geo: GeometryModel, phys: _Physics, steady_at: float | None = None):
        a = scene.adaptivity
        self.scene, self.geo, self.phys, self.mesh = scene, geo, phys, phys.mesh
        self.steady_at = steady_at
        """A transient scene's start time (s): each step solves the steady heat problem with the data at that time
        (the step operator with 1/dt = 0 and theta = 1), the mechanics not at all (a pre-adapted mesh)."""
        self.target = a.target or ("mechanics" if scene.physics.mechanics and steady_at is None else "heat")
        self.estimator = a.estimator
        self.heat_info = None
        self.result = None
        self.refinements = 0

    def settings(self) -> dict:
        a = self.scene.adaptivity
        return {"estimator": a.estimator, "indicators": tuple(a.indicators), "marker": a.marker,
                "theta": a.theta, "stop": StopRule(tolerance=a.tolerance, max_dofs=a.max_dofs,
                                                   max_refinements=a.max_refinements)}

    @property
    def ndof(self) -> int:
        return self.phys.ndof

    def solve(self) -> dict:
        p = self.phys
        where = f"adaptive step {self.refinements} (steady state)"
        if self.steady_at is not None:
            h = p.heat
            h.t_new.Set(self.steady_at)
            h.t_old.Set(self.steady_at)
            h.inv_dt.Set(0.0)
            h.theta.Set(1.0)
            h.gf_old.vec[:] = 0.0
            self.heat_info = p.solver.solve_steady(where)
        elif p.heat is not None:
            p.heat.t_new.Set(0.0)
            self.heat_info = p.solver.solve(where)
        if p.mech is not None and self.steady_at is None:
            p.mech.solve(0.0, where, record=False)
        log.info("adaptivity: step %d: %d dofs, %d elements", self.refinements, p.ndof, self.mesh.ne)
        return {}

    def estimator_input(self, needs: str):
        p = self.phys
        if needs == "forms":
            return p.mech.forms if self.target == "mechanics" else p.heat
        if needs == "contact":
            return self.mesh, contact_statuses(p.mech)
        raise ValueError(f"a scene has no {needs!r} input for an estimator")

    def refine(self, marks) -> None:
        order = self.scene.mesh.order
        refine_mesh(self.mesh, marks, order if order >= 2 else 0)
        self.refinements += 1
        self.phys = _Physics(self.scene, self.geo, self.mesh)

    def summary(self) -> dict:
        r = self.result
        return {"estimator": self.estimator, "target": self.target, "marker": self.scene.adaptivity.marker,
                "theta": self.scene.adaptivity.theta, "stop_reason": r.stop,
                "steps": [{"refinement": s.refinement, "ndof": s.ndof, "elements": s.elements,
                           "estimate": s.estimate, "marked": s.marked, "flagged": s.flagged,
                           "solve_s": s.solve_s, "estimate_s": s.estimate_s} for s in r.steps]}


class _Mechanics:
    """The elastic part of a run: forms, solver, output fields, solve history."""

    def __init__(self, scene: Scene, geo: GeometryModel, mesh, temperature):
        ms = scene.mechanics
        self.setup = elastic_setup(scene, geo, mesh, temperature)
        self.forms = ElasticForms(mesh, self.setup)
        self.contacts = contact_specs(scene, geo, mesh, self.forms.V)
        self.nested = None                     # NestedStart (mechanics.nested_levels, validated: no contact)
        if self.contacts:
            floating = self.forms.floating_bodies()
            check_supported(self.contacts, floating, scene.scene.name)
            csolver = build_contact_solver([(c.op, c.law) for c in self.contacts],
                                           contact_options(scene, self.contacts, self.forms),
                                           modulus=nodal_modulus(self.setup.props), floating=floating, forms=self.forms)
            relax = ms.secant_relaxation if ms.secant_relaxation is not None and ms.secant_relaxation <= 1 else None
            self.solver = ElasticContactSolver(self.forms, csolver, tol=ms.tolerance, maxit=ms.max_iterations,
                                               relaxation=relax)
            self.contact_output = ContactOutput(self.forms, self.contacts)
        else:
            sv = scene.solver
            if parallel.distributed(mesh):
                _check_distributed_mechanics(scene, self.forms)
            self.nested = (NestedStart(scene, geo, temperature) if ms.nested_levels > 0 and self.setup.nonlinear
                           else None)
            self.solver = ElasticSolver(self.forms, method=ms.nonlinear_solver, tol=ms.tolerance,
                                        maxit=ms.max_iterations, relaxation=ms.secant_relaxation, solver=sv.linear,
                                        linear_tol=sv.tolerance, linear_maxit=sv.max_iterations,
                                        start="linear" if self.nested is None else "current",
                                        preconditioner=sv.preconditioner)
            self.contact_output = None
            free = self.forms.unheld_rigid_motions()
            if free:
                raise SceneError([Problem("boundary_conditions", f"the bodies are not held against "
                                          f"{', '.join(free)}: add displacement or symmetry conditions that stop "
                                          "it, or a foundation")], source=f"scene {scene.scene.name!r}")
        self.warnings = mechanics_warnings(scene, self.setup) + contact_warnings(self.contacts, geo)
        u = self.forms.displacement()
        sigma = self.forms.stress_tensor(u)
        measures = stress_measures(sigma)
        self.sigma = sigma
        self.fields = {"displacement": u, "stress": sigma, **measures,
                       "strain_energy_density": self.forms.strain_energy_density(u)}
        self.probe_fields = probe_fields(u, measures, mesh.dim)
        self.times: list[float] = []
        self.nested_solves: list[list] = []      # per solve: the coarse solves (ndof, iterations, wall s)
        self._copy: tuple[int, dict] | None = None     # the arrays of the last capture

    def solve(self, t: float, where: str, record: bool = True) -> None:
        self.forms.t.Set(t)
        if self.nested is not None:
            self.nested_solves.append(self.nested(self.forms, t, where))
        self.solver.solve(where)
        watch_small_strain(self, where)
        if record:
            self.record(t)

    def adopt(self, old: _Mechanics) -> None:
        """Continue the histories of ``old`` (the same scene on the previous mesh: contact-zone following): the
        times, the solves, the warnings and the contact records (the factorizations are counted by the
        follower)."""
        self.times = old.times
        self.warnings[:] = old.warnings + [w for w in self.warnings if w not in old.warnings]
        self.solver.history[:0] = old.solver.history
        if self.contact_output is not None:
            self.contact_output.history[:0] = old.contact_output.history

    def record(self, t: float, replace: bool = False) -> None:
        """Keep the solution of the last solve as the one at time t (s); ``replace``: instead of the last record
        (the same time solved again on a new mesh)."""
        if replace and self.times:
            self.times.pop()
            if self.contact_output is not None and self.contact_output.history:
                self.contact_output.history.pop()
        self.times.append(t)
        if self.contact_output is not None:
            self.contact_output.record(t, self.solver)

    every_step = False
    """Static mechanics is solved at the output times (or every step of a coupled run), not advanced in time."""

    def dissipation_source(self):
        """No viscous dissipation in static mechanics (the heat source of (2.6) is DynamicsRun's)."""
        return None

    # -- checkpoints: the same interface as DynamicsRun ------------------------------------------------------
    checkpoint_key = "mechanics"

    @property
    def factorizations(self) -> int:
        return self.solver.factorizations

    def capture(self) -> tuple[dict, dict]:
        """The state after the last solve: the displacement, the contact solver's warm start and the last contact
        results as arrays (copied once per solve, reused while no solve happens), and the series lengths."""
        if self._copy is None or self._copy[0] != len(self.times):      # solved since the last capture
            arrays = {"mechanics": np.array(self.forms.gf.vec.FV().NumPy())}
            if self.contact_output is not None:
                arrays.update({f"warm/{k}": v for k, v in self.solver.contact.capture().items()})
            self._copy = (len(self.times), arrays)
        arrays = dict(self._copy[1])
        out = self.contact_output
        for i, res in enumerate(out.latest if out is not None else []):   # replaced (not changed) by each solve
            arrays.update({f"latest/{i}/{k}": np.asarray(v) for k, v in res.items()})
        lengths = {"times": len(self.times), "history": len(self.solver.history),
                   "contact_history": len(out.history) if out is not None else 0,
                   "contact_latest": len(out.latest) if out is not None else 0}
        return arrays, lengths

    def meta(self, lengths: dict) -> dict:
        out = self.contact_output
        return {"times": self.times[:lengths["times"]],
                "history": [dataclasses.asdict(i) for i in self.solver.history[:lengths["history"]]],
                "contact_history": out.history[:lengths["contact_history"]] if out is not None else [],
                "contact_latest": lengths["contact_latest"]}

    def restore(self, arrays: dict, meta: dict) -> None:
        self.forms.gf.vec.FV().NumPy()[:] = arrays["mechanics"]
        self.times[:] = meta["times"]
        self.solver.history[:] = [NonlinearInfo(**d) for d in meta["history"]]
        out = self.contact_output
        if out is not None:
            out.history[:] = meta["contact_history"]
            out.latest = [{k.split("/", 2)[2]: v for k, v in arrays.items() if k.startswith(f"latest/{i}/")}
                          for i in range(meta["contact_latest"])]
            self.solver.contact.restore(self.forms.X.ndof, {k.split("/", 1)[1]: v for k, v in arrays.items()
                                                            if k.startswith("warm/")})

    def summary(self) -> dict:
        h = self.solver.history
        out = {"model": self.setup.model, "solver": self.solver.method if self.setup.nonlinear else "linear",
               "solves": len(h), "times_s": self.times,
               "iterations": [i.iterations for i in h], "wall_s": [i.wall_s for i in h],
               "last_changes": h[-1].changes if h else []}
        if self.nested_solves:
            out["nested_iteration"] = [[{"ndof": n, "iterations": i, "wall_s": w} for n, i, w in solves]
                                       for solves in self.nested_solves]
        if self.contact_output is not None:
            out.update(self.contact_output.summary())
        return out


def _check_distributed_mechanics(scene: Scene, forms: ElasticForms) -> None:
    """What the elastic solver cannot do on a distributed mesh, as a SceneError naming the keys (before any solve:
    the mixed formulation and the primal-dual Newton tangent of softening regions are solved directly)."""
    problems = []
    if forms.mixed:
        problems.append(Problem("mechanics.formulation", f"the mixed displacement-pressure formulation (regions "
                                f"{', '.join(forms.mixed)}) is not supported in distributed runs; set "
                                "formulation = 'displacement'"))
    soft = [r for r, p in forms.setup.props.items() if p.lam < 1.0]
    if soft and scene.mechanics.nonlinear_solver == "newton":
        problems.append(Problem("mechanics.nonlinear_solver", f"Newton with softening regions ({', '.join(soft)}: "
                                "rheology_lambda < 1) uses a tangent solved directly, not available in distributed "
                                "runs; use 'secant'"))
    if problems:
        raise SceneError(problems, source=f"scene {scene.scene.name!r} (distributed run)")


def _interface_flows(forms: HeatForms, history: dict, axi: bool) -> None:
    """Heat flow through each contact interface (W; W per m of depth in plane scenes), master -> minion."""
    w = 2 * math.pi * ngs.x if axi else 1.0
    for (master, _), lam in zip(forms.setup.contacts, forms.multipliers()):
        q = float(ngs.Integrate(w * lam * ngs.ds(definedon=forms.mesh.Boundaries(master)), forms.mesh))
        history["interface_heat_flow_W"].setdefault(master, []).append(q)


def _figures(scene: Scene, mesh, T, probes: ProbeSet, directory: Path, mech=None, stefan=None,
             coupling=None, adaptive=None, draw: bool = True) -> None:
    """The run's figures. A distributed run calls this on every rank (the mesh data are gathered collectively);
    only the rank with ``draw`` draws and writes."""
    if not scene.output.figures:
        return
    figures = _Drawing(draw)
    if adaptive is not None:
        steps = adaptive.result.steps
        if draw:
            directory.mkdir(parents=True, exist_ok=True)
        figures.convergence_figure([s.ndof for s in steps], {f"estimate ({adaptive.estimator})":
                                                            [s.estimate for s in steps]},
                                   directory / "adaptivity.png",
                                   title=f"{scene.scene.name}: adaptive refinement ({adaptive.target})",
                                   ylabel="estimated error (energy norm)")
    t_unit = "degC" if scene.scene.temperature_unit == "C" else "K"
    units = {"temperature": t_unit, "von_mises": "Pa", "mean_stress": "Pa", "sigma_1": "Pa", "sigma_3": "Pa",
             "displacement_x": "m", "displacement_y": "m", "displacement_z": "m", "liquid_fraction": "-",
             "front": "m from the line's first point"}
    groups: dict[str, list] = {}
    for p in probes.probes:
        if len(probes.times[p.name]) > 1:
            groups.setdefault(p.quantity, []).append(p.name)
    if mesh.dim != 2 and not groups:
        return
    if draw:
        directory.mkdir(parents=True, exist_ok=True)
    labels = ("r (m)", "z (m)") if scene.scene.dimension == "axisymmetric" else ("x (m)", "y (m)")
    arrays = mesh_arrays(mesh) if mesh.dim == 2 else None
    t_end = scene.time.end if scene.time else None
    if arrays is not None and T is not None:
        vals = vertex_values(T)
        figures.field_figure(arrays, vals, directory / "temperature.png",
                             title=f"{scene.scene.name}: temperature, {_when(t_end)}",
                             label=f"T ({t_unit})", axis_labels=labels)
        if scene.output.figure_window:
            figures.field_figure(arrays, vals, directory / "temperature_zoom.png",
                                 title=f"{scene.scene.name}: temperature, {_when(t_end)} (near field)",
                                 label=f"T ({t_unit})", axis_labels=labels, window=scene.output.figure_window)
    if arrays is not None and stefan is not None:
        _stefan_figures(scene, arrays, T, stefan, directory, labels, t_end, t_unit, figures)
    if arrays is not None and coupling is not None:
        figures.field_figure(arrays, _vertex_average(mesh, coupling.source), directory / "deformation_heating.png",
                             title=f"{scene.scene.name}: deformation heating, {_when(t_end)}",
                             label="-Theta_0 beta : e(u_t) (W/m^3)", axis_labels=labels, cmap="coolwarm")
    if arrays is not None and mech is not None:
        _mechanics_figures(scene, mesh, arrays, mech, directory, labels, t_end, figures)
        if mech.contact_output is not None:
            _contact_figures(scene, mech, directory, t_end, figures)
    for quantity, names in groups.items():
        times = probes.times[names[0]]
        span = times[-1] - times[0]
        unit, label = (YEAR, "t (years)") if span >= 2 * YEAR else (1.0, "t (s)")
        fname = "probes.png" if quantity == "temperature" else f"probes_{quantity}.png"
        curves = {n: np.array([np.nan if v is None else v for v in probes.series[n]], dtype=float) for n in names}
        limits = {f"{p.name}: limit {p.limit:g}": p.limit for p in scene.output.probes
                  if p.name in names and p.limit is not None}
        figures.time_curves(times, curves, directory / fname,
                            title=f"{scene.scene.name}: probes", ylabel=f"{quantity} ({units[quantity]})",
                            time_unit=unit, time_label=label, hlines=limits)


def _stefan_figures(scene: Scene, arrays, T, stefan: StefanRun, directory: Path, labels, t_end: float,
                    t_unit: str, figures) -> None:
    """The temperature with the phase boundary (liquid_fraction = 1/2) at the last time, and the melted volume
    fraction of each phase-change region over the output times."""
    iso = stefan.phase_boundary()
    figures.field_figure(arrays, vertex_values(T), directory / "phase_boundary.png",
                         title=f"{scene.scene.name}: temperature and phase boundary, {_when(t_end)}",
                         label=f"T ({t_unit})", axis_labels=labels, lines=iso.as_segments(),
                         lines_label="phase boundary (liquid fraction 1/2)")
    rec = stefan.records
    if len(rec["time_s"]) > 1:
        times = np.array(rec["time_s"])
        span = times[-1] - times[0]
        unit, label = (YEAR, "t (years)") if span >= 2 * YEAR else (1.0, "t (s)")
        figures.time_curves(times, {r: np.array(v) / stefan.volume[r] for r, v in rec["melted_volume"].items()},
                            directory / "melted_fraction.png", title=f"{scene.scene.name}: melted volume fraction",
                            ylabel="liquid volume / region volume (-)", time_unit=unit, time_label=label)


def _when(t: float | None) -> str:
    return "steady state" if t is None else f"t = {format_time(t)}"


def _mechanics_figures(scene: Scene, mesh, arrays, mech, directory: Path, labels, t_end: float,
                       figures) -> None:
    """Von Mises stress and principal stress crosses (the seed's Fig. 1) at the last mechanics time."""
    vm = _vertex_average(mesh, mech.fields["von_mises"])
    figures.field_figure(arrays, vm / 1e6, directory / "von_mises.png",
                         title=f"{scene.scene.name}: von Mises stress, {_when(t_end)}",
                         label="von Mises stress (MPa)", axis_labels=labels, cmap="viridis")
    windows = [(None, "principal_stress.png")]
    if scene.output.figure_window:
        windows.append((scene.output.figure_window, "principal_stress_zoom.png"))
    sig = mech.sigma
    for window, fname in windows:
        lo, hi = arrays.points.min(axis=0), arrays.points.max(axis=0)
        if window is not None:
            lo, hi = np.maximum(lo, [window[0], window[2]]), np.minimum(hi, [window[1], window[3]])
        samples = stress_figures.grid_samples(arrays, float(np.max(hi - lo)) / 22, window)
        pts = samples.xy
        if len(pts) == 0:
            continue
        sxx, syy, sxy = parallel.point_values(mesh, ngs.CoefficientFunction((sig[0, 0], sig[1, 1], sig[0, 1])),
                                              pts).T
        s1, s2, th = stress_figures.principal_2d(sxx, syy, sxy)
        figures.principal_stress_crosses(
            arrays, pts, s1, s2, th, directory / fname, axis_labels=labels, window=window,
            title=f"{scene.scene.name}: principal stresses, {_when(t_end)}",
            background=vm / 1e6, background_label="von Mises stress (MPa)")


def _contact_figures(scene: Scene, mech, directory: Path, t_end: float, figures) -> None:
    """Pressure, traction (with the slip bound), gap and slip along each contact, at the last mechanics time
    (2D scenes; 3D contacts are in the boundary VTK only)."""
    for spec, res in zip(mech.contacts, mech.contact_output.latest):
        o = res["order"]
        xy = np.column_stack([res["x"], res["y"]])[o]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
        forces = {"pressure p": res["pressure"][o] / 1e6, "traction q": res["traction"][o] / 1e6}
        if spec.law.kind != "frictionless":
            forces["slip bound"] = res["bound"][o] / 1e6
        figures.interface_profiles(
            s, [forces, {"gap": res["gap"][o] * 1e3, "slip": res["slip"][o] * 1e3}],
            directory / f"contact_{plain_file_name(spec.name)}.png", ylabels=["traction (MPa)", "gap, slip (mm)"],
            title=f"{scene.scene.name}: contact {spec.name} ({spec.law.kind}), {_when(t_end)}",
            xlabel=f"arc length along {spec.op.side} from ({xy[0, 0]:.3g}, {xy[0, 1]:.3g}) (m)",
            status=res["status"][o].astype(int))


def _vertex_average(mesh, cf) -> np.ndarray:
    """Vertex values of a (possibly discontinuous) scalar CF: its L2 projection onto P1, vertex dofs."""
    g = ngs.GridFunction(ngs.H1(mesh, order=1))
    g.Set(cf)
    return vertex_values(g)


class _Drawing:
    """The drawing functions of a run (:mod:`~ngs_geomech.io.figures` and the principal-stress crosses), or, on the
    ranks of a distributed run that do not draw, functions that do nothing."""

    def __init__(self, draw: bool):
        self.draw = draw

    def __getattr__(self, name):
        if not self.draw:
            return lambda *args, **kwargs: None
        return stress_figures.principal_stress_crosses if name == "principal_stress_crosses" else \
            getattr(figures, name)
