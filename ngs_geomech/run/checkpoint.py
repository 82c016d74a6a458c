"""Checkpoints of time-dependent runs: which objects make up the state of a run, capturing it after each
step, writing it, and restoring a run from it (the file format is :mod:`ngs_geomech.io.checkpoint`).

The state after step k (time t_k): what each part of the run captures (:meth:`ngs_geomech.parts.Part.capture`):
the heat GridFunction vector (temperature and the mortar multipliers; the old state is a copy of it at the start
of the next step) with the Newton iteration and interface heat flow histories or, in a scene with phase change,
the Stefan solver's state (:meth:`StefanSolver.capture`: the nodal enthalpy, its predictor rate and what its
Newton matrix was factored from, with the correction rows solved since, so that the resumed Newton steps reuse
the same factorization; with the melted volume, latent heat, energy and Newton histories), the mechanics
GridFunction vector (at the last output step) with its solve histories and the contact solvers' warm start
(:meth:`ContactSolver.capture`: the active/stick/slip sets, slip signs and directions; the next solve starts from
them as in an uninterrupted run), the coupling's displacement rate and history; and the output's probe series
and the VTK and line series entries written so far, the time step schedule (where it started and with which dt,
so the remaining steps are the same ones) and the scene and mesh sizes the checkpoint belongs to.
:meth:`RunState.capture` after every completed step copies the vectors and notes the lengths of the
(append-only) series, so that a failing step can still save the last good state.
Everything a next step depends on is restored, so a resumed run repeats the uninterrupted one to the last bit
(with one NGSolve thread), the Stefan step control's state (:mod:`ngs_geomech.stefan.stepping`) included.

Distributed runs (``comm``): the capture after every step is collective: the vectors of the parts' spaces
(:meth:`~ngs_geomech.parts.Part.checkpoint_spaces`) are gathered to rank 0 in the canonical numbering of
:mod:`.numbering` (independent of the partition; meta ``numbering`` = ``"canonical"``), the other arrays are
rank 0's own (the same on every rank). Only rank 0 writes, decides when (the wall-time trigger is its own: a write
needs no other rank) and, when a step fails, saves the last good state without communicating. The mesh data
(``mesh_info``) are the whole mesh's, equal to a serial run's on the same mesh. On resume every rank takes its
entries from the canonical arrays, so a distributed checkpoint resumes on any number of ranks or serially; a
serial run's checkpoint (serial numbering) resumes distributed when every checkpointed space has one dof per
vertex (order 1: the serial numbering is the canonical one). Arrays whose order follows the partition
(:meth:`~ngs_geomech.parts.Part.partition_bound`; the contact solver's warm start is not one: its node arrays are
stored with the nodes' coordinates) resume on the same number of ranks only
(:class:`~ngs_geomech.errors.ResumeError` naming both counts).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time

import numpy as np

from ..errors import ResumeError
from ..fem.timesteps import nominal_step, schedule
from ..io.checkpoint import Checkpoint, checkpoint_meta_base, scene_differences, write_checkpoint
from ..io.summary import versions
from ..scene.units import format_time
from .numbering import RunNumbering

CHECKPOINT_WALL_S = 300.0     # with the default checkpoint_every: also after any step ending 5 min after the last


@dataclasses.dataclass
class Snapshot:
    """The state after ``step`` completed steps (time ``time``): vector copies and series lengths."""

    step: int
    time: float
    arrays: dict
    lengths: dict
    solve_s: float
    factorizations: int


def check_scene(cp: Checkpoint, scene_dict: dict) -> None:
    """Refuse to resume when the scene differs from the checkpoint's (outside the resumable keys)."""
    diff = scene_differences(cp.meta["scene"], scene_dict)
    if diff:
        raise ResumeError(f"cannot resume from {cp.path} ({where(cp)}): the scene differs from the checkpointed "
                          "run's:\n" + "\n".join(f"  - {d}" for d in diff) +
                          "\nOnly the time steps (time.end, time.dt, time.dt_growth, time.dt_max, time.scheme), the "
                          "mechanics solver settings and the output frequency may change on resume; run without "
                          "--resume to start anew.")


def where(cp: Checkpoint) -> str:
    return f"step {cp.meta['step']}, t = {format_time(cp.meta['time_s'])}"


@dataclasses.dataclass
class Plan:
    """The time steps of a run: ``steps`` still to take (global numbers from ``k0``), from one schedule() call
    ``segment`` (from_step, from_time, dt) with the scene's ``settings`` (end, dt, dt_growth, dt_max)."""

    segment: dict
    settings: dict
    k0: int
    steps: list

    @property
    def total(self) -> int:
        return self.k0 + len(self.steps)


def plan_steps(ts, cp: Checkpoint | None) -> Plan:
    """The steps of a run, or of a run resumed from ``cp``. Resuming with the same time settings continues the
    same schedule (the same steps as without the interruption); with changed ones a new schedule starts at the
    checkpoint's time with the new time.dt (if that changed) or the step the old schedule would have taken
    next."""
    settings = {"end": ts.end, "dt": ts.dt, "dt_growth": ts.dt_growth, "dt_max": ts.dt_max}
    if cp is None:
        return Plan({"from_step": 0, "from_time": ts.start, "dt": ts.dt}, settings, 0,
                    list(schedule(ts.start, ts.end, ts.dt, ts.dt_growth, ts.dt_max)))
    k, t = int(cp.meta["step"]), float(cp.meta["time_s"])
    seg, old = cp.meta["segment"], cp.meta["time_settings"]
    if old == settings:
        steps = list(schedule(seg["from_time"], ts.end, seg["dt"], ts.dt_growth, ts.dt_max))[k - seg["from_step"]:]
        if steps and steps[0][0] == t:
            return Plan(seg, settings, k, steps)
    if not t < ts.end - 1e-9 * max(abs(ts.end), ts.dt):
        raise ResumeError(f"time.end = {format_time(ts.end)} is not after the time of the checkpoint ({where(cp)})")
    if ts.dt != old["dt"]:
        first = ts.dt
    else:
        first = nominal_step(k - seg["from_step"], seg["dt"], old["dt_growth"], old["dt_max"])
    if ts.dt_max is not None:
        first = min(first, ts.dt_max)
    return Plan({"from_step": k, "from_time": t, "dt": first}, settings, k,
                list(schedule(t, ts.end, first, ts.dt_growth, ts.dt_max)))


class RunState:
    """The objects of a run whose state a checkpoint holds: the model's parts (each captures and restores its
    own state, :class:`~ngs_geomech.parts.Part`) and the output's probes and series (``output``, a
    :class:`~ngs_geomech.run.output.RunOutput`)."""

    def __init__(self, scene_dict: dict, model, output, comm=None, whole=None):
        self.scene_dict = scene_dict
        self.model = model
        self.output = output
        self.comm, self.whole = comm, whole     # a distributed run: its communicator, rank 0's WholeMesh
        self.numbering: RunNumbering | None = None
        self._mesh_info: dict | None = None
        self.factorizations_before = 0      # in the runs before a resume
        self.resumed: list[dict] = []
        self.saved_step: int | None = None      # the step and time of the newest checkpoint on disk
        self.saved_time: float | None = None

    # -- what identifies the problem ------------------------------------------------------------------
    def prepare(self) -> None:
        """Collective in a distributed run, before the first capture or restore: the canonical numbering and the
        whole mesh's data (:meth:`mesh_info`)."""
        if self.comm is None or self.numbering is not None:
            return
        from .. import parallel

        mesh = self.model.mesh
        self.numbering = RunNumbering(mesh, self.whole)
        sha = self.comm.bcast(self.whole.coordinates_sha256 if self.comm.rank == 0 else None, root=0)
        self._mesh_info = {"vertices": self.numbering.nv, "elements": int(parallel.allsum(mesh, mesh.ne)),
                           "dofs": {p.key: p.ndof_global for p in self.model.parts}, "vertex_coordinates_sha256": sha}

    def mesh_info(self) -> dict:
        if self._mesh_info is not None:
            return self._mesh_info
        mesh = self.model.mesh
        coords = np.round(np.asarray(mesh.ngmesh.Coordinates(), dtype=float), 9)
        return {"vertices": mesh.nv, "elements": mesh.ne, "dofs": {p.key: p.ndof for p in self.model.parts},
                "vertex_coordinates_sha256": hashlib.sha256(coords.tobytes()).hexdigest()}

    def check_mesh(self, cp: Checkpoint) -> None:
        old, new = cp.meta["mesh"], self.mesh_info()
        diff = [f"{k}: {old.get(k)} in the checkpoint, {new[k]} now" for k in new if old.get(k) != new[k]]
        if diff:
            raise ResumeError(f"cannot resume from {cp.path} ({where(cp)}): the mesh differs from the checkpointed "
                              "run's (" + "; ".join(diff) + "); the same scene meshed differently (another netgen "
                              "version or thread count?). Run without --resume to start anew.")

    def factorizations(self) -> int:
        return self.factorizations_before + self.model.factorizations

    # -- capture and save -----------------------------------------------------------------------------
    def capture(self, step: int, t: float, solve_s: float) -> Snapshot:
        """The state after ``step`` completed steps (cheap: vector copies and list lengths; in a distributed run
        collective, the arrays gathered on rank 0 and none kept on the others)."""
        arrays, lengths = {}, {}
        for p in self.model.parts:
            part_arrays, lengths[p.key] = p.capture()
            if self.comm is not None:
                part_arrays = self._gathered(p, part_arrays)
            arrays.update(part_arrays)
        return Snapshot(step, float(t), arrays, {"parts": lengths, "output": self.output.lengths()}, solve_s,
                        self.factorizations())

    def _gathered(self, part, arrays: dict) -> dict:
        """A part's captured arrays in a distributed run: its spaces' vectors in canonical numbering on rank 0
        (collective, in the part's order of :meth:`~ngs_geomech.parts.Part.checkpoint_spaces`), the others rank
        0's; {} on the other ranks."""
        out = dict(arrays) if self.comm.rank == 0 else {}
        for name, space in part.checkpoint_spaces().items():
            if name in arrays:
                canonical = self.numbering.of(space).gather(arrays[name])
                if canonical is not None:
                    out[name] = canonical
        return out

    def layout(self) -> dict:
        """What a checkpoint's meta says of the numbering of its arrays."""
        if self.comm is None:
            return {"numbering": "serial", "ranks": 1}
        return {"numbering": "canonical", "ranks": self.comm.size,
                "vertex_order_kept": self.numbering.vertex_order_kept}

    def save(self, snap: Snapshot, directory, plan: Plan) -> None:
        """Write the checkpoint of ``snap`` into ``directory`` (atomically; in a distributed run rank 0 alone)."""
        L = snap.lengths
        meta = {**checkpoint_meta_base(self.scene_dict), "versions": versions(), "mesh": self.mesh_info(),
                **self.layout(),
                "step": snap.step, "time_s": snap.time, "segment": plan.segment,
                "time_settings": plan.settings, "solve_s": snap.solve_s, "factorizations": snap.factorizations,
                "resumed": self.resumed, "output": self.output.meta(L["output"]),
                "parts": {p.key: p.meta(L["parts"][p.key]) for p in self.model.parts}}
        write_checkpoint(directory, json.loads(json.dumps(meta, default=_plain)), snap.arrays)
        self.saved_step, self.saved_time = snap.step, snap.time

    # -- restore --------------------------------------------------------------------------------------
    def restore(self, cp: Checkpoint) -> None:
        """Put the checkpoint's state into the run's objects (after :meth:`check_mesh`)."""
        meta = cp.meta
        for p in self.model.parts:
            p.restore(self._local(cp, p), meta["parts"][p.key])
        self.output.restore(meta["output"])
        self.factorizations_before = int(meta["factorizations"])
        self.resumed = list(meta.get("resumed", [])) + [{"step": meta["step"], "time_s": meta["time_s"],
                                                          "at": time.strftime("%Y-%m-%dT%H:%M:%S")}]
        self.saved_step, self.saved_time = int(meta["step"]), float(meta["time_s"])

    def _local(self, cp: Checkpoint, part) -> dict:
        """The checkpoint's arrays as ``part`` restores them here: its spaces' vectors in this run's numbering
        (collective in a distributed run); ResumeError when they cannot be (module docstring)."""
        meta, arrays = cp.meta, dict(cp.arrays)
        written, ranks = meta.get("numbering", "serial"), int(meta.get("ranks", 1))
        here = self.comm.size if self.comm is not None else 1
        bound = [n for n in arrays if n.startswith(part.partition_bound())] if part.partition_bound() else []
        if bound and ranks != here:
            raise ResumeError(f"cannot resume from {cp.path} ({where(cp)}): it was written by a run on "
                              f"{_ranks(ranks)} and this run is on {_ranks(here)}; its {part.key} state "
                              f"({bound[0]}...) follows how the mesh is split: resume on {_ranks(ranks)}")
        if written == "serial" and self.comm is None:
            return arrays
        numbering = self._run_numbering()
        for name, space in part.checkpoint_spaces().items():
            if name not in arrays:
                continue
            nb = numbering.of(space)
            if written == "serial" and not nb.vertex_only:
                raise ResumeError(f"cannot resume from {cp.path} ({where(cp)}) on {_ranks(here)}: it was written by a "
                                  f"serial run, whose {part.key} vector ({name}) is in the serial numbering of a space "
                                  "with dofs on edges or faces (mesh.order > 1); resume it serially")
            portable = not nb.oriented or (meta.get("vertex_order_kept", True) and numbering.vertex_order_kept)
            if not portable and ranks != here:
                raise ResumeError(f"cannot resume from {cp.path} ({where(cp)}): its {part.key} vector ({name}) has "
                                  "dofs on oriented edges or faces and the parts did not keep the mesh's vertex order: "
                                  f"resume on {_ranks(ranks)}")
            arrays[name] = nb.local(arrays[name])
        return arrays

    def _run_numbering(self) -> RunNumbering:
        if self.numbering is None:                # serial: built when first needed
            self.numbering = RunNumbering(self.model.mesh)
        return self.numbering


def _ranks(n: int) -> str:
    return "1 process (serial)" if n == 1 else f"{n} ranks"


def _plain(obj):
    """JSON form of numpy scalars and arrays in the meta data."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


class Checkpointer:
    """When a run captures and writes its state: a capture after every step (cheap), a checkpoint into
    ``scratch`` every ``output.checkpoint_every`` steps (default: every tenth of the steps, and after any step
    ending :data:`CHECKPOINT_WALL_S` after the last checkpoint). ``scratch`` None: no checkpoints (a run writing
    nothing, on followed meshes), or, with ``capturing`` (the ranks other than 0 of a distributed run), no
    writes: they take part in the collective captures only."""

    def __init__(self, state: RunState, scratch, plan: Plan, every: int | None, capturing: bool | None = None):
        self.state, self.scratch, self.plan = state, scratch, plan
        self.capturing = scratch is not None if capturing is None else capturing
        if every is None:
            self.every, self.wall = max(1, math.ceil(plan.total / 10)), CHECKPOINT_WALL_S
        else:
            self.every, self.wall = every, math.inf
        self.last_saved = time.perf_counter()
        self.snap: Snapshot | None = None

    def capture(self, step: int, t: float, solve_s: float) -> None:
        """The state after ``step`` completed steps (time t, s)."""
        if self.capturing:
            self.snap = self.state.capture(step, t, solve_s)

    def after_step(self, k: int, t: float, solve_s: float) -> None:
        """Step k (from 0) ended at time t (s): capture, and write when due."""
        self.capture(k + 1, t, solve_s)
        if self.scratch is None:
            return
        if self.every and k + 1 < self.plan.total and \
                ((k + 1) % self.every == 0 or time.perf_counter() - self.last_saved >= self.wall):
            self.state.save(self.snap, self.scratch, self.plan)
            self.last_saved = time.perf_counter()
