"""The Stefan step control (:mod:`ngs_geomech.stefan.stepping`) on the two-phase Neumann strip written as a scene
(:func:`~ngs_geomech.verification.stefan_adaptive.strip_scene`, :data:`~ngs_geomech.verification.stefan.TWO_PHASE`):
from the exact state at t0 = 0.05 s to t1 = 0.5 s with the scene step dt, run by :func:`ngs_geomech.run.run_scene`.
Measured: the front from the melted volume against the closed form (relative error), the run's energy balance,
the substeps taken and rejected, the smallest and largest substep, the Newton iterations, and the wall time of
the whole run (the summary's ``wall_time_s.total_s``: meshing included). Returns plain dicts; prints nothing.
"""

from __future__ import annotations

from ..run import run_scene
from ..scene.parse import scene_from_dict
from . import stefan as st
from .stefan_adaptive import exact_temperature_expression, strip_scene

T0, T1 = 0.05, 0.5
"""The strip's start and end times (s)."""

HEIGHT = 0.1
"""The strip's height (m)."""


def strip_step_scene(h: float, dt: float, control: str = "adaptive", t1: float = T1) -> dict:
    """The two-phase strip (mesh size ``h``, m) from the exact state at T0 to ``t1`` with the scene step ``dt`` (s)
    and the step control ``control`` ('adaptive' or 'halving'), one output at the end, no probes."""
    p = st.TWO_PHASE
    return {**strip_scene(p, p.domain_length(T1), HEIGHT, h),
            "initial": {"temperature": exact_temperature_expression(p, T0)},
            "time": {"start": T0, "end": t1, "dt": dt, "stefan_step_control": control},
            "output": {"every": 10 ** 6, "probes": []}}


def strip_figures(summary: dict, t1: float = T1) -> dict:
    """The figures of a strip run's summary: the front (m, melted volume / height) and its relative error against
    the closed form at t1, the energy imbalance, the step control's counts, the Newton iterations, the wall time."""
    s = summary["stefan"]
    front = s["melted_volume"]["pcm"][-1] / HEIGHT
    exact = st.TWO_PHASE.front(t1)
    ctl = s["step_control"]
    return {"front_m": front, "front_exact_m": exact, "front_rel": abs(front - exact) / exact,
            "imbalance_rel": s["energy"]["imbalance_rel_max"], "output_times_s": s["output_times_s"],
            "steps_taken": ctl["steps_taken"], "rejected_steps": ctl["rejected_steps"],
            "dt_min_s": ctl["dt_min_s"], "dt_max_s": ctl["dt_max_s"],
            "newton_iterations": int(round(s["newton_iterations"]["mean"] * s["newton_iterations"]["steps"])),
            "newton_mean": s["newton_iterations"]["mean"], "wall_s": summary["wall_time_s"]["total_s"],
            "solve_s": summary["wall_time_s"]["solve_s"]}


def strip_run(h: float, dt: float, control: str = "adaptive", t1: float = T1) -> dict:
    """One strip run (one NGSolve thread, one BLAS thread): :func:`strip_figures` of its summary."""
    with st.single_threaded_blas():
        res = run_scene(scene_from_dict(strip_step_scene(h, dt, control, t1)), None, progress=False, threads=1)
    return strip_figures(res.summary, t1)


def large_dt_ratio(h: float = 0.00625, dts: tuple = (0.000625, 0.005), repeats: int = 3,
                   controls: tuple = ("adaptive",)) -> dict:
    """``stefan_large_dt_ratio``: the whole-run wall time at the largest dt over that at the smallest, per step
    control. The runs alternate (dt by dt, control by control, ``repeats`` rounds); per (control, dt) the figures of
    :func:`strip_run` with the best wall time of the rounds (the other figures are the same in every round: the
    runs are deterministic). Returns {"h", "dts", "repeats", "runs": {control: {dt: figures}}, "ratio": {control:
    wall(max dt) / wall(min dt)}, "front_rel": {control: {dt: error}}}."""
    runs: dict = {c: {} for c in controls}
    for _ in range(repeats):
        for c in controls:
            for dt in dts:
                r = strip_run(h, dt, c)
                best = runs[c].get(dt)
                if best is None or r["wall_s"] < best["wall_s"]:
                    runs[c][dt] = r
    lo, hi = min(dts), max(dts)
    return {"h": h, "dts": list(dts), "repeats": repeats,
            "runs": {c: {str(dt): r for dt, r in v.items()} for c, v in runs.items()},
            "ratio": {c: runs[c][hi]["wall_s"] / runs[c][lo]["wall_s"] for c in controls},
            "front_rel": {c: {str(dt): runs[c][dt]["front_rel"] for dt in dts} for c in controls}}
