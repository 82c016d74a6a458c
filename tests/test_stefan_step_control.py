"""The Stefan step control (:mod:`ngs_geomech.stefan.stepping`): substeps on a ladder of levels that end exactly at
the scene's output times, the halving control repeating recursive halving, the adaptive control on the two-phase
Neumann strip at a large dt (front against the closed form, energy balance), its determinism (window mode of the
Newton matrix included), a resumed run equal to the uninterrupted one, and the summary's counts."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.errors import SolverError
from ngs_geomech.io.checkpoint import load_checkpoint
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan import stepping
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.verification import stefan as st
from ngs_geomech.verification.stefan_steps import strip_figures, strip_run, strip_step_scene


# -- the ladder -----------------------------------------------------------------------------------------------
def test_substep_times_are_the_midpoints_of_recursive_halving():
    a, b = 0.08, 0.085
    mid = 0.5 * (a + b)
    assert stepping.bisect_time(a, b, 0) == a and stepping.bisect_time(a, b, 64) == b
    assert stepping.bisect_time(a, b, 32) == mid
    assert stepping.bisect_time(a, b, 48) == 0.5 * (mid + b)
    assert stepping.bisect_time(a, b, 40) == 0.5 * (mid + 0.5 * (mid + b))
    assert [stepping.coarsest_level(p) for p in (0, 32, 16, 48, 1, 63)] == [0, 1, 2, 2, 6, 6]


def _walk(control, fails: set) -> list:
    """The (start, end) positions a control takes over one scene step when the substeps in ``fails`` fail once."""
    pos, out, units = 0, [], 1 << stepping.MAX_LEVEL
    while pos < units:
        end = pos + (units >> control.next_level(pos))
        if (pos, end) in fails:
            fails.discard((pos, end))
            assert control.reject()
            continue
        out.append((pos, end))
        control.accept(1, 0.0, 1.0)
        pos = end
    return out


def test_halving_control_repeats_recursive_halving():
    """(0, 64) fails, then (0, 32), then (32, 64): the recursion's order (0, 16), (16, 32), (32, 48), (48, 64)."""
    steps = _walk(stepping.HalvingControl(), {(0, 64), (0, 32), (32, 64)})
    assert steps == [(0, 16), (16, 32), (32, 48), (48, 64)]


def test_adaptive_control_keeps_the_level_and_grows_after_easy_substeps():
    c = stepping.AdaptiveControl()
    assert _walk(c, {(0, 64)}) == [(0, 32), (32, 64)]          # kept at level 1, not back to the full step
    assert c.patience == 2 * stepping.GROW_AFTER
    steps = [s for _ in range(c.patience // 2 + 1) for s in _walk(c, set())]
    assert steps[-1] == (0, 64) and c.level == 0                # easy substeps: back to the scene's step
    assert c.taken == 2 + len(steps) and c.rejected == 1
    c.accept(stepping.SHRINK_ITERATIONS, 0.0, 1.0)             # many iterations: the next substep finer
    assert c.level == 1
    state = c.state()
    d = stepping.AdaptiveControl()
    d.load(state)
    assert np.array_equal(d.state(), state)


# -- the strip ------------------------------------------------------------------------------------------------
H, DT = 0.008, 0.0075
"""The strip of these tests: h = 0.008 m (4.4k nodes: Woodbury mode of the Newton matrix), scene step 0.0075 s
(about one element layer of front travel per step, where the semi-smooth Newton iteration cycles now and then:
14 halvings with the halving control)."""

FRONT_BOUND = 2.5e-3
"""The front error (relative, melted volume) allowed at the large step: measured 1.99e-3 at H, DT (2.44e-3 with
the halving control)."""


def test_large_step_hits_the_output_times_conserves_energy_and_follows_the_front():
    adaptive = strip_run(H, DT)
    halving = strip_run(H, DT, "halving")
    small = strip_run(H, DT / 8)
    print(f"\nstrip h = {H}, dt = {DT}: adaptive front_rel {adaptive['front_rel']:.3e} ({adaptive['steps_taken']} "
          f"substeps, {adaptive['rejected_steps']} rejected, dt {adaptive['dt_min_s']:.4g} .. "
          f"{adaptive['dt_max_s']:.4g} s, Newton {adaptive['newton_iterations']}); halving {halving['front_rel']:.3e} "
          f"({halving['steps_taken']} substeps, {halving['rejected_steps']} rejected, Newton "
          f"{halving['newton_iterations']}); dt / 8: {small['front_rel']:.3e} ({small['steps_taken']} steps, "
          f"Newton {small['newton_iterations']}); imbalance {adaptive['imbalance_rel']:.1e}")
    assert adaptive["output_times_s"] == [0.05, 0.5]
    assert adaptive["imbalance_rel"] <= 1e-8
    assert adaptive["front_rel"] <= FRONT_BOUND
    assert adaptive["front_rel"] <= halving["front_rel"]
    assert adaptive["rejected_steps"] >= 1 and adaptive["dt_min_s"] < DT <= adaptive["dt_max_s"] * (1 + 1e-12)
    assert adaptive["rejected_steps"] < halving["rejected_steps"]
    assert small["rejected_steps"] == 0 and small["steps_taken"] == 480


def test_the_control_is_deterministic_in_window_mode():
    """h = 0.00625 m: 10.8k nodes, the Newton matrix in window mode (its width adapted to counted work): two runs
    give the same substeps and the same enthalpy to the last bit."""
    runs = []
    for _ in range(2):
        with st.single_threaded_blas():
            res = run_scene(scene_from_dict(strip_step_scene(0.00625, 0.005, t1=0.2)), None, progress=False,
                            threads=1)
        runs.append(res)
    a, b = runs
    assert a.stefan.solver.jac.window_size is not None
    assert a.stefan.control.rejected >= 1
    assert np.array_equal(a.stefan.control.state(), b.stefan.control.state())
    assert a.stefan.iterations == b.stefan.iterations
    assert np.array_equal(a.stefan.solver.e, b.stefan.solver.e)


def test_resumed_run_equals_the_uninterrupted_one(tmp_path, monkeypatch):
    """A strip run stopped by a Newton failure that every substep meets after the 20th solve (past the first
    rejections, the control at a finer level): the checkpoint keeps the control's state, and the resumed run takes
    the uninterrupted run's substeps to the same enthalpy, bit for bit."""
    scene = scene_from_dict({**strip_step_scene(H, DT, t1=0.15),
                             "output": {"every": 5, "probes": [], "vtk": False, "figures": False,
                                        "checkpoint_every": 1}})
    ref = run_scene(scene, tmp_path / "REF", progress=False, threads=1)
    original = StefanSolver.step
    calls = {"n": 0}

    def step(self, t_old, t_new, extra_load=None):
        calls["n"] += 1
        if calls["n"] > 20:
            raise SolverError("Stefan Newton step diverged (injected)")
        return original(self, t_old, t_new, extra_load)
    monkeypatch.setattr(StefanSolver, "step", step)
    with pytest.raises(SolverError, match="The last good state"):
        run_scene(scene, tmp_path / "DIR", progress=False, threads=1)
    monkeypatch.undo()
    (staging,) = [p for p in tmp_path.glob(".DIR.partial-*") if p.is_dir()]     # not its .lock file
    cp = load_checkpoint(staging / "checkpoint")
    saved = cp.arrays["stefan/step_control"]
    assert saved[2] >= 1                                        # rejected substeps before the stop
    res = run_scene(scene, tmp_path / "DIR", progress=False, threads=1, resume=True)
    a, b = ref.summary["stefan"], res.summary["stefan"]
    print(f"\nresumed at step {res.summary['resumed'][0]['step']}: control {b['step_control']}")
    assert b["step_control"] == a["step_control"] and b["newton_iterations"] == a["newton_iterations"]
    assert b["energy"] == a["energy"] and b["melted_volume"] == a["melted_volume"]
    assert np.array_equal(res.stefan.solver.e, ref.stefan.solver.e)


def test_summary_reports_the_substeps():
    """The summary's stefan.step_control block: strategy, substeps taken and rejected, smallest and largest
    substep; ``step_halvings`` is the rejected count."""
    res = run_scene(scene_from_dict(strip_step_scene(H, DT, t1=0.15)), None, progress=False, threads=1)
    s = res.summary["stefan"]
    ctl = s["step_control"]
    assert ctl["strategy"] == "adaptive" and ctl["max_level"] == stepping.MAX_LEVEL
    assert ctl["steps_taken"] == s["newton_iterations"]["steps"] == len(res.stefan.iterations)
    assert s["step_halvings"] == ctl["rejected_steps"]
    assert 0 < ctl["dt_min_s"] <= ctl["dt_max_s"] <= DT * (1 + 1e-12)
    assert strip_figures(res.summary, 0.15)["steps_taken"] == ctl["steps_taken"]
