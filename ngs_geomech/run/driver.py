"""Running a scene: validate, mesh, build only the physics it declares, solve, write the output.

Output (into ``out``, written completely or not at all): ``<scene>.pvd`` + ``<scene>_stepNNNNN.vtu``
(VTK series with every computed field and the region id), ``figures/*.png``, ``summary.json`` and the marker
``ngs-geomech-output.json`` listing these files. ``out`` is checked before any meshing (:mod:`ngs_geomech.io.outdir`: an
existing file, ``/``, a mount point, a directory not writable or of other files without ``overwrite`` are
refused); the files of an earlier output in ``out`` are replaced, no other file there is touched.
Scenes with phase change (a material with ``phase_change_temperature``, physics.thermal = 'transient') are
solved by the Stefan solver (:mod:`ngs_geomech.stefan.problem`) instead of the heat solver; they also write
the phase boundary (liquid fraction 1/2) per output time as ``<scene>_phase_boundary.pvd`` + ``.vtp`` (2D),
``figures/phase_boundary.png`` and ``figures/melted_fraction.png``, and a ``stefan`` block in the summary.

Time-dependent runs write checkpoints (:mod:`ngs_geomech.run.checkpoint`) into ``checkpoint/`` of their staging
directory ``.<out>.partial-*``: every ``output.checkpoint_every`` steps (default every tenth of the steps
and after any step ending 5 minutes of wall time after the last checkpoint), and the last good state when a
step fails or the run is interrupted (Ctrl-C). A killed, failed or interrupted run that holds a checkpoint
leaves its staging directory behind (``out`` itself is untouched; a disk that fills up stops the run with
:class:`~.errors.OutputError` naming the kept checkpoint); ``run_scene(..., resume=True)`` (the
command line's ``--resume``) continues it from its last checkpoint and commits ``out`` at the end as usual.

Distributed runs (``mpiexec -n N``, N >= 2; :mod:`ngs_geomech.parallel`): every rank runs this module on its part
of the mesh (rank 0 meshes and distributes, keeping no elements); what a distributed run cannot do is refused first
(:func:`~ngs_geomech.validation.validate.distributed_problems`). Rank 0 creates, commits or removes the staging
directory, prints the progress and writes summary.json, figures and line series; every rank with elements writes
its VTK parts; values that need the whole mesh (probes, mesh counts, figure data) are gathered collectively, so
every rank takes every output branch. Checkpoints: rank 0 keeps the whole mesh's element table and coordinates
(:class:`~ngs_geomech.run.numbering.WholeMesh`), every step's state is gathered to rank 0 in a numbering that does
not depend on the partition, and rank 0 writes the checkpoints (:mod:`ngs_geomech.run.checkpoint`); ``--resume``
reads the checkpoint on rank 0 and sends it to the others, so that a distributed run resumes on any number of
ranks, or serially, and a serial run's checkpoint of an order-1 scene resumes distributed.
"""

from __future__ import annotations

import functools
import logging
import os
import pickle
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import ngsolve as ngs

from .. import parallel
from ..adapt.policy import MeshPolicy
from ..errors import OutputError, ResumeError, SceneError, SolverError
from ..geometry.assemble import GeometryModel
from ..geometry.mesh import SerialCopy, element_estimate, make_mesh
from ..io.atomic import OutputDir, is_locked, staging_dirs, write_json_atomic
from ..io.checkpoint import Checkpoint, find_resumable, has_checkpoint, scene_hash
from ..io.outdir import disk_full
from ..io.progress import Progress
from ..io.summary import finite, probe_statistics, versions
from ..linalg.threads import BLAS_THREADS, blas_threads, default_threads
from ..parts import Step
from ..probes import THERMAL
from ..scene.model import Scene
from ..scene.schema import to_dict
from ..scene.units import format_time
from ..validation.validate import distributed_problems, validate
from .checkpoint import Checkpointer, Plan, RunState, check_scene, plan_steps
from .checkpoint import where as checkpoint_where
from .model import Model, mesh_policy
from .numbering import WholeMesh
from .output import RunOutput

log = logging.getLogger(__package__)


@dataclass
class RunResult:
    """What a run produced: the model at the end (its parts, on the last mesh), the summary, the output
    directory and the wall times (s)."""

    mesh: object
    summary: dict
    out: Path | None
    timings: dict = field(default_factory=dict)
    model: Model | None = None

    @property
    def forms(self):
        """The heat forms (:class:`~ngs_geomech.heat.forms.HeatForms`), None without a heat part."""
        t = self.model.thermal if self.model is not None else None
        return t.forms if t is not None and t.key == "heat" else None

    @property
    def mechanics(self):
        """The mechanics part (static, dynamic or viscous), or None."""
        return self.model.mechanics if self.model is not None else None

    @property
    def stefan(self):
        """The Stefan part (:class:`~ngs_geomech.stefan.problem.StefanRun`), or None."""
        t = self.model.thermal if self.model is not None else None
        return t if t is not None and t.key == "stefan" else None


def run_scene(scene: Scene, out: str | Path | None, *, progress: bool = True, threads: int | None = None,
              geometry: GeometryModel | None = None, resume: bool = False, overwrite: bool = False,
              comm=None) -> RunResult:
    """Run a scene. ``out=None`` writes nothing (for tests and studies). ``overwrite=True`` allows an ``out``
    that holds files other than an earlier output (they are kept; same-named ones replaced). ``resume=True``
    continues the interrupted run into ``out`` from its last checkpoint (:class:`ResumeError` when there is
    none, or when the scene or the mesh differs from the checkpointed run's). ``comm`` (an mpi4py communicator
    of several ranks, every rank calling this): a distributed run (module docstring); None: serial, also inside
    an MPI job whose ranks run separate scenes (``mpi4py.futures`` samples). ``threads``: NGSolve's threads
    (default: one, or the idle cores for large problems: :func:`~ngs_geomech.linalg.threads.default_threads`); every
    BLAS runs one thread (:mod:`ngs_geomech.linalg.threads`). The summary's ``threads`` says what ran."""
    timings: dict[str, float] = {}
    t0 = _time.perf_counter()
    started = _since_process_start()
    if started is not None:
        timings["process_start_s"] = started
    if comm is not None and comm.size < 2:
        comm = None
    geo = geometry or validate(scene)
    if comm is not None:
        problems = distributed_problems(scene)
        if problems:
            raise SceneError(problems, source=f"scene {scene.scene.name!r} (distributed run, {comm.size} ranks)")
    timings["validate_s"] = _time.perf_counter() - t0
    cp = None
    if resume:
        cp = _checkpoint_to_resume(scene, out) if comm is None else _on_rank_zero(
            comm, functools.partial(_checkpoint_to_resume, scene, out))
    # one thread per rank unless asked (ranks x threads <= cores); serially by the problem's size
    threads = threads or (1 if comm is not None else default_threads(
        sum(element_estimate(geo, scene.mesh).values()) * scene.mesh.order ** geo.dim, geo.dim))
    ngs.SetNumThreads(threads)
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
        with ngs.TaskManager(), blas_threads(BLAS_THREADS):
            result = _run(scene, geo, staging, progress and root, timings, cp, comm)
        timings["total_s"] = _time.perf_counter() - t0
        result.summary["wall_time_s"] = finite(timings)
        result.summary["threads"] = {"ngsolve": threads, "blas": BLAS_THREADS}
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


def _since_process_start() -> float | None:
    """Seconds since this process started (the interpreter, the imports, the scene file: what a user waits for
    before the run proper), from Linux's /proc at its 10 ms resolution; None where /proc is not there."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(0.0, uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return None


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
            staging = OutputDir(out, resume=cp.staging if cp is not None else None, overwrite=overwrite, scene=name)
        except BaseException:
            comm.bcast(None, root=0)
            raise
        comm.bcast(str(staging.path), root=0)
        return staging
    path = comm.bcast(None, root=0)
    if path is None:
        raise SolverError(f"rank {comm.rank}: rank 0 could not create the staging directory of {out}")
    return _RankStaging(Path(path))


def _on_rank_zero(comm, fn):
    """``fn()`` computed on rank 0 and sent to every rank; an exception it raises is raised on every rank."""
    if comm.rank == 0:
        try:
            value = fn()
        except Exception as exc:
            try:
                pickle.dumps(exc)
                sent = exc
            except Exception:                 # noqa: BLE001 - an exception that does not pickle: its message
                sent = ResumeError(str(exc))
            comm.bcast((False, sent), root=0)
            raise
        comm.bcast((True, value), root=0)
        return value
    ok, value = comm.bcast(None, root=0)
    if not ok:
        raise value
    return value


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


def _transient(scene: Scene) -> bool:
    """Whether the scene is solved over time (else: its stationary state)."""
    ph = scene.physics
    return ph.thermal == "transient" or (not ph.thermal and scene.time is not None)


def _run(scene: Scene, geo: GeometryModel, staging: OutputDir | None, show: bool, timings: dict,
         cp: Checkpoint | None = None, comm=None) -> RunResult:
    """Mesh, build the model on the mesh its policy chooses, solve (stationary, or step by step), write."""
    tic = _time.perf_counter()
    build = functools.partial(Model, scene, geo)
    policy = mesh_policy(scene, geo, build)
    # a distributed run's checkpoints name the dofs by the whole mesh's vertices: rank 0 keeps its tables
    checkpoints = staging is not None and _transient(scene) and policy.checkpoints and \
        (comm is None or scene.adaptivity is None)
    copy = policy.serial_copy or (SerialCopy() if checkpoints and comm is not None else None)
    mesh = make_mesh(geo, scene.mesh, comm=comm, serial_copy=copy)
    whole = WholeMesh(copy.ngmesh) if checkpoints and comm is not None and comm.rank == 0 else None
    if copy is not policy.serial_copy:
        copy.ngmesh = None
    timings["mesh_s"] = _time.perf_counter() - tic
    tic = _time.perf_counter()
    model = policy.prepare(build(mesh), scene.time.start if scene.time is not None else None)
    if policy.adapts_first:
        timings["adaptivity_s"] = _time.perf_counter() - tic
    root = comm is None or comm.rank == 0
    if comm is None:
        log.info("%s: %d elements, %d vertices; mesh %.2f s, setup %.2f s", scene.scene.name, model.mesh.ne,
                 model.mesh.nv, timings["mesh_s"], _time.perf_counter() - tic)
    shown = list(model.warnings)
    if root:                                  # a distributed run says them once
        for w in shown:
            log.warning("%s", w)
    out = RunOutput(scene, model, staging.path if staging is not None else None, root)
    timings["setup_s"] = _time.perf_counter() - tic
    state = RunState(to_dict(scene), model, out, comm, whole)
    if _transient(scene):
        model, nsteps = _march(scene, policy, state, staging if checkpoints else None, show, timings, cp)
    else:
        model, nsteps = _steady(policy, model, out, timings), 0
    if root:                                  # the warnings of the solves (small-strain range)
        for w in model.warnings:
            if w not in shown:
                log.warning("%s", w)
    summary = _summary(scene, model, policy, state, nsteps, comm)
    if staging is not None:
        tic = _time.perf_counter()
        out.figures(model, policy, staging.path / "figures", draw=root)
        timings["output_s"] = out.write_s + _time.perf_counter() - tic      # the series above and the figures
        timings["series_s"] = out.write_s
    return RunResult(mesh=model.mesh, summary=summary, out=None, timings=timings, model=model)


def _steady(policy: MeshPolicy, model: Model, out: RunOutput, timings: dict) -> Model:
    """The stationary state: solved, recorded and written."""
    tic, written = _time.perf_counter(), out.write_s
    model = policy.steady(model, "steady state")
    model.record(0.0, True)
    out.write(model, 0.0, True)
    timings["solve_s"] = _time.perf_counter() - tic - (out.write_s - written)
    return model


def _march(scene: Scene, policy: MeshPolicy, state: RunState, staging, show: bool,
           timings: dict, cp: Checkpoint | None) -> tuple[Model, int]:
    """The time steps of the scene (from the checkpoint ``cp`` when resuming): each advances the model (its mesh
    as the policy decides), records and writes; checkpoints into ``staging`` (None: none; in a distributed run
    every rank captures, rank 0 writes)."""
    ts, model, out = scene.time, state.model, state.output
    plan = plan_steps(ts, cp)
    root = state.comm is None or state.comm.rank == 0
    scratch_dir = staging if root else None
    if staging is not None or cp is not None:
        state.prepare()
    if cp is None:
        model, timings["initial_s"] = _initial(scene, policy, model, out)
        solve_s = 0.0
    else:
        state.check_mesh(cp)
        state.restore(cp)
        solve_s = float(cp.meta["solve_s"])
        log.info("resuming from the checkpoint at %s of %d", checkpoint_where(cp), plan.total)
    saver = Checkpointer(state, scratch_dir.scratch if scratch_dir is not None else None, plan,
                         scene.output.checkpoint_every, capturing=staging is not None)
    saver.capture(plan.k0, ts.start if cp is None else float(cp.meta["time_s"]), solve_s)
    bar = Progress(ts.end - ts.start, scene.scene.name, enabled=show)
    try:
        for j, (a, b) in enumerate(plan.steps):
            k = plan.k0 + j
            step = Step(a, b, k, (k + 1) % scene.output.every == 0 or k == plan.total - 1,
                        f"step {k + 1} (t = {format_time(b)})")
            tic, written = _time.perf_counter(), out.write_s
            model = _advance(policy, model, out, step)
            solve_s += _time.perf_counter() - tic - (out.write_s - written)
            saver.after_step(k, b, solve_s)
            bar.update(b - ts.start, f"t = {format_time(b)}  dt = {format_time(b - a)}")
    except BaseException as exc:
        bar.close()
        _stop(exc, scratch_dir, state, saver.snap, plan)
        raise
    bar.close()
    timings["solve_s"] = solve_s
    return model, plan.total


def _initial(scene: Scene, policy: MeshPolicy, model: Model, out: RunOutput) -> tuple[Model, float]:
    """The initial state at the start time (with mechanics, the t0 solve): set, recorded and written; returns the
    model and the time it took without the writing (s)."""
    t0 = scene.time.start
    where = f"t = {format_time(t0)}"
    tic, written = _time.perf_counter(), out.write_s
    model.start(t0, where)
    new = policy.started(model, t0, where)
    if new is not model:
        out.switch(new)
    new.record(t0, True)
    out.write(new, t0, True)
    return new, _time.perf_counter() - tic - (out.write_s - written)


def _advance(policy: MeshPolicy, model: Model, out: RunOutput, step: Step) -> Model:
    """One time step: the model advanced (on the mesh the policy chooses), recorded and written."""
    tic, newton = _time.perf_counter(), len(model.newton_iterations)
    new = policy.advance(model, step)
    if new is not model:                      # remeshed: the run goes on on the new mesh
        out.switch(new)
    new.record(step.b, step.output)
    out.write(new, step.b, step.output)
    if log.isEnabledFor(logging.DEBUG):
        its = new.newton_iterations[newton:]
        log.debug("%s: %.3f s%s", step.where, _time.perf_counter() - tic, f", Newton iterations {its}" if its else "")
    return new


def _summary(scene: Scene, model: Model, policy: MeshPolicy, state: RunState, nsteps: int, comm) -> dict:
    """summary.json without the wall times: the scene, the mesh, the steps, the probes, each part's block and
    the mesh policy's."""
    mesh, probes = model.mesh, state.output.probes
    if comm is None:
        dofs, counts = model.ndof, {"vertices": mesh.nv, "elements": mesh.ne}
        by_part = {p.key: p.ndof for p in model.parts}
    else:
        by_part = {p.key: p.ndof_global for p in model.parts}
        dofs = sum(by_part.values())
        counts = {"vertices": ngs.H1(mesh, order=1).ndofglobal, "elements": parallel.allsum(mesh, mesh.ne),
                  "ranks": comm.size, "elements_per_rank": parallel.allgather(mesh, mesh.ne),
                  "peak_rss_gib_per_rank": parallel.allgather(mesh, parallel.peak_rss_gib())}
    thermal_times = next((probes.times[p.name] for p in scene.output.probes if p.quantity in THERMAL), [])
    summary = {
        "scene": to_dict(scene),
        "versions": versions(),
        "mesh": {**counts, "dofs": dofs, "dofs_by_part": by_part, "order": scene.mesh.order,
                 "regions": list(mesh.GetMaterials())},
        "steps": nsteps,
        "factorizations": state.factorizations_before + policy.factorizations(model),
        "newton_iterations_max": max(model.newton_iterations or [0]),
        "probes": {n: finite(probe_statistics(probes.times[n], v)) for n, v in probes.series.items()},
        "probe_series": {"time_s": thermal_times,
                         **{n: finite(v) for n, v in probes.series.items()},
                         "times_s": {n: probes.times[n] for n in probes.series}},
        "interface_heat_flow_W": {},
        "warnings": model.warnings,
    }
    if state.resumed:
        summary["resumed"] = state.resumed
    for p in model.parts:
        summary.update(p.summary())
    adaptivity = policy.summary()
    if adaptivity is not None:
        summary["adaptivity"] = adaptivity
    return summary


def _stop(exc: BaseException, staging: OutputDir | None, state: RunState, snap, plan: Plan) -> None:
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
    hint = (f"The last good state (step {state.saved_step} of {plan.total}, t = {format_time(state.saved_time)}) is "
            f"saved in {staging.scratch}: after a fix (e.g. a smaller time step, --set time.dt=...), the same "
            "command with --resume continues from it.")
    if isinstance(exc, SolverError):
        raise SolverError(f"{exc}\n{hint}") from exc
    if isinstance(exc, KeyboardInterrupt):
        raise KeyboardInterrupt(hint) from exc


