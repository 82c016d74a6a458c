"""Checkpoints and ``--resume`` (issue 8, section 3): a run killed with SIGKILL, stopped by a solver error or
interrupted, then resumed, gives the uninterrupted run's results (summary, probe series, final temperature
vector, VTK series); a changed scene or mesh is refused by name; a kill while a checkpoint is written leaves
the previous one loadable.

The scene: the built-in canister (axisymmetric, P2, a contact interface with mortar multipliers in the heat
state), one year in 74 constant 5-day steps, a checkpoint every 5 steps, VTK every 5 steps, no figures.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ngs_geomech import cli
from ngs_geomech.api import run
from ngs_geomech.errors import ResumeError, SolverError
from ngs_geomech.fem.timesteps import schedule
from ngs_geomech.heat.solver import HeatSolver
from ngs_geomech.io.checkpoint import load_checkpoint, read_checkpoint_file, write_checkpoint
from ngs_geomech.mechanics.contact import ElasticContactSolver

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_checkpoint")]

SETS = ["--set", "time.end='1 year'", "--set", "time.dt='5 day'", "--set", "time.dt_growth=1.0",
        "--set", "output.checkpoint_every=5", "--set", "output.figures=false"]
OVERRIDES = SETS[1::2]
STEPS = 74
# costs: a resumed run factors once more
IGNORED = {"wall_time_s", "wall_s", "wall_s_per_solve", "communication_per_solve", "factorizations", "resumed"}


def command() -> list[str]:
    script = Path(sys.executable).with_name("ngs-geomech")
    return [str(script)] if script.exists() else [sys.executable, "-m", "ngs_geomech.cli"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run: (result, output directory)."""
    out = tmp_path_factory.mktemp("reference") / "REF"
    return run("canister", out, overrides=OVERRIDES, progress=False), out


def assert_close(a, b, path: str = "summary") -> None:
    """Equal data, floats to 1e-12 relative."""
    if isinstance(a, dict):
        assert set(a) - IGNORED == set(b) - IGNORED, path
        for k in set(a) - IGNORED:
            assert_close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-12), path
    else:
        assert a == b, path


def assert_same_output(ref: Path, out: Path) -> dict:
    """The same summary (to round-off) and the complete VTK series of the reference; returns the summary."""
    a = json.loads((ref / "summary.json").read_text())
    b = json.loads((out / "summary.json").read_text())
    assert_close(a, b)
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in ref.iterdir())
    listed = re.findall(r'file="([^"]+)"', (out / "canister.pvd").read_text())
    assert listed == re.findall(r'file="([^"]+)"', (ref / "canister.pvd").read_text())
    assert sorted(p.name for p in out.glob("*.vtu")) == sorted(listed)
    for f in listed:
        assert (out / f).stat().st_size == (ref / f).stat().st_size > 0, f
    assert not list(out.rglob(".*")) and not (out / "checkpoint").exists()
    assert [p.name for p in out.parent.iterdir() if p.name.startswith(".")] == []   # no staging left
    return b


def staging_of(parent: Path, name: str = "DIR") -> Path:
    (d,) = [p for p in parent.glob(f".{name}.partial-*") if p.is_dir()]
    return d


def fail_heat_solve_at(monkeypatch, n: int, exc: BaseException) -> None:
    original = HeatSolver.solve
    calls = {"n": 0}

    def solve(self, where):
        calls["n"] += 1
        if calls["n"] == n:
            raise exc
        return original(self, where)
    monkeypatch.setattr(HeatSolver, "solve", solve)


def failed_run(tmp_path: Path, monkeypatch, capsys, n: int, exc: BaseException = None) -> tuple[int, str]:
    """A CLI run into tmp_path/DIR whose heat solve raises at the n-th step; (exit status, stderr)."""
    fail_heat_solve_at(monkeypatch, n, exc or SolverError(f"injected divergence at call {n}"))
    rc = cli.main(["run", "canister", "--out", str(tmp_path / "DIR"), *SETS, "--quiet"])
    monkeypatch.undo()
    return rc, capsys.readouterr().err


def test_killed_run_resumes_to_the_uninterrupted_result(tmp_path, reference):
    """SIGKILL after the first checkpoint, then --resume: the same probes and final temperature to 1e-12."""
    ref_result, ref_out = reference
    out = tmp_path / "DIR"
    tic = time.perf_counter()
    proc = subprocess.Popen([*command(), "run", "canister", "--out", str(out), *SETS, "--quiet", "--threads", "1"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    while proc.poll() is None and time.perf_counter() - tic < 120:
        if list(tmp_path.glob(".DIR.partial-*/checkpoint/checkpoint.npz")):
            break
        time.sleep(0.002)
    assert proc.poll() is None, f"the run ended before it was killed: {proc.stderr.read()}"
    proc.kill()                   # SIGKILL: no clean-up of any kind
    proc.wait()
    proc.stderr.close()
    assert not out.exists()
    cp = load_checkpoint(staging_of(tmp_path) / "checkpoint")
    assert 5 <= cp.meta["step"] < STEPS
    result = run("canister", out, overrides=OVERRIDES, progress=False, resume=True)
    assert result.summary["resumed"][0]["step"] >= 5
    summary = assert_same_output(ref_out, out)
    for name, stats in summary["probes"].items():
        assert stats["final"] == pytest.approx(ref_result.summary["probes"][name]["final"], rel=1e-12)
    a, b = ref_result.forms.gf.vec.FV().NumPy(), result.forms.gf.vec.FV().NumPy()
    assert np.linalg.norm(b - a) <= 1e-12 * np.linalg.norm(a)


def test_solver_error_saves_the_last_good_state_and_resume_continues(tmp_path, monkeypatch, capsys, reference):
    rc, err = failed_run(tmp_path, monkeypatch, capsys, 23)
    assert rc == 2
    assert "injected divergence" in err and "Traceback" not in err
    assert f"The last good state (step 22 of {STEPS}" in err and "--resume" in err and "time.dt" in err
    assert not (tmp_path / "DIR").exists()
    cp = load_checkpoint(staging_of(tmp_path) / "checkpoint")
    series = cp.meta["output"]["probes"]["series"]
    assert cp.meta["step"] == 22 and len(series["buffer_max"]) == 23   # t = 0 and 22 steps
    rc = cli.main(["run", "canister", "--out", str(tmp_path / "DIR"), *SETS, "--quiet", "--resume"])
    out, err = capsys.readouterr()
    assert rc == 0 and err == ""
    assert f"resumed at step 22 of {STEPS}" in out
    assert_same_output(reference[1], tmp_path / "DIR")


def test_mechanics_failure_saves_the_last_good_state_and_resume_continues(tmp_path, monkeypatch, capsys):
    """A transient fault_wedge (heat, thermal stress, lambda law, Coulomb fault): the mechanics fails at its
    third solve (step 4); the resumed run gives the uninterrupted run's probes, contact forces and contact
    iteration counts (the contact solver's sets are restored as its warm start)."""
    sets = ["physics.thermal=transient", "time.end='4 year'", "time.dt='1 year'", "output.every=2",
            "materials.footwall.rho_c=2.2e6", "materials.wedge.rho_c=2.2e6", "output.figures=false",
            "output.checkpoint_every=2", "mesh.maxh=100"]
    ref = run("fault_wedge", tmp_path / "REF", overrides=sets, progress=False)
    original = ElasticContactSolver.solve
    calls = {"n": 0}

    def solve(self, where):
        calls["n"] += 1
        if calls["n"] == 3:
            raise SolverError(f"secant modules method with contact at {where} diverged (injected)")
        return original(self, where)
    monkeypatch.setattr(ElasticContactSolver, "solve", solve)
    with pytest.raises(SolverError, match=r"step 4 .*\n.*The last good state \(step 3 of 4.*--resume"):
        run("fault_wedge", tmp_path / "DIR", overrides=sets, progress=False)
    monkeypatch.undo()
    cp = load_checkpoint(staging_of(tmp_path) / "checkpoint")
    assert cp.meta["step"] == 3 and cp.meta["parts"]["mechanics"]["times"] == [0.0, 2 * 365.25 * 86400]
    res = run("fault_wedge", tmp_path / "DIR", overrides=sets, progress=False, resume=True)
    a, b = ref.summary, res.summary
    assert_close(json.loads(json.dumps({k: a[k] for k in ("probes", "probe_series", "mechanics", "steps")})),
                 json.loads(json.dumps({k: b[k] for k in ("probes", "probe_series", "mechanics", "steps")})))
    assert b["mechanics"]["contact"]["iterations_per_solve"] == a["mechanics"]["contact"]["iterations_per_solve"]
    u, v = ref.mechanics.forms.gf.vec.FV().NumPy(), res.mechanics.forms.gf.vec.FV().NumPy()
    assert np.linalg.norm(v - u) <= 1e-10 * np.linalg.norm(u)
    names = {p.name for p in (tmp_path / "DIR").iterdir()}
    assert names == {p.name for p in (tmp_path / "REF").iterdir()}


def test_interrupt_keeps_a_checkpoint_and_resume_may_change_the_time_step(tmp_path, monkeypatch, capsys):
    """Ctrl-C saves the last good state (exit 130); the resumed run may take other time steps (the fix for a
    diverging run): the new dt from the checkpoint's time to the end."""
    rc, err = failed_run(tmp_path, monkeypatch, capsys, 8, KeyboardInterrupt())
    assert rc == 130
    assert "interrupted; The last good state (step 7 of" in err and "--resume" in err
    sets = [s if s != "time.dt='5 day'" else "time.dt='10 day'" for s in SETS]
    rc = cli.main(["run", "canister", "--out", str(tmp_path / "DIR"), *sets, "--quiet", "--resume"])
    assert rc == 0, capsys.readouterr().err
    summary = json.loads((tmp_path / "DIR" / "summary.json").read_text())
    times = np.array(summary["probe_series"]["time_s"])
    day = 86400.0
    assert np.allclose(np.diff(times[:8]), 5 * day) and np.allclose(np.diff(times[8:-2]), 10 * day)
    assert times[-1] == pytest.approx(365.25 * day, rel=1e-12)
    assert summary["steps"] == len(times) - 1 == 7 + len(list(schedule(35 * day, 365.25 * day, 10 * day)))
    assert summary["resumed"][0]["step"] == 7


def test_resume_with_a_changed_scene_or_mesh_is_refused(tmp_path, monkeypatch, capsys):
    rc, _ = failed_run(tmp_path, monkeypatch, capsys, 8)
    assert rc == 2
    staging = staging_of(tmp_path)
    before = (staging / "checkpoint" / "checkpoint.npz").read_bytes()
    base = ["run", "canister", "--out", str(tmp_path / "DIR"), *SETS, "--quiet", "--resume"]
    assert cli.main([*base, "--set", "materials.buffer.conductivity=1.2", "--set", "mesh.maxh=10"]) == 2
    err = capsys.readouterr().err
    assert "the scene differs from the checkpointed run's" in err
    assert "materials.buffer.conductivity: 1.0 in the checkpoint, 1.2 now" in err
    assert "mesh.maxh: 12.0 in the checkpoint, 10.0 now" in err
    # the mesh (same scene, meshed differently): its sizes are compared after meshing
    cp = load_checkpoint(staging / "checkpoint")
    cp.meta["mesh"]["elements"] += 1
    write_checkpoint(staging / "checkpoint", {k: v for k, v in cp.meta.items() if k != "format"}, cp.arrays)
    with pytest.raises(ResumeError, match=r"the mesh differs .*elements: \d+ in the checkpoint, \d+ now"):
        run("canister", tmp_path / "DIR", overrides=OVERRIDES, progress=False, resume=True)
    assert not (tmp_path / "DIR").exists()
    assert (staging / "checkpoint" / "previous.npz").read_bytes() == before    # nothing else touched
    # nothing to resume
    assert cli.main(["run", "canister", "--out", str(tmp_path / "OTHER"), *SETS, "--quiet", "--resume"]) == 2
    assert "nothing to resume" in capsys.readouterr().err
    assert not (tmp_path / "OTHER").exists()


def test_kill_while_writing_a_checkpoint_leaves_the_previous_one(tmp_path, monkeypatch, capsys, reference):
    """A truncated temporary file (a kill while writing) is ignored; a damaged checkpoint.npz, or none (a kill
    between the two renames), falls back to previous.npz; the run resumed from it equals the reference."""
    rc, _ = failed_run(tmp_path, monkeypatch, capsys, 13)     # checkpoints at steps 5, 10, and 12 (last good)
    assert rc == 2
    d = staging_of(tmp_path) / "checkpoint"
    assert load_checkpoint(d).meta["step"] == 12 and read_checkpoint_file(d / "previous.npz").meta["step"] == 10
    data = (d / "checkpoint.npz").read_bytes()
    (d / ".checkpoint.npz.x1y2z3.tmp").write_bytes(data[: len(data) // 2])
    assert load_checkpoint(d).meta["step"] == 12
    (d / "checkpoint.npz").write_bytes(data[: len(data) - 100])            # damaged: the zip is cut short
    assert load_checkpoint(d).meta["step"] == 10
    (d / "checkpoint.npz").unlink()
    assert load_checkpoint(d).meta["step"] == 10
    result = run("canister", tmp_path / "DIR", overrides=OVERRIDES, progress=False, resume=True)
    assert result.summary["resumed"][0]["step"] == 10
    assert_same_output(reference[1], tmp_path / "DIR")
    a, b = reference[0].forms.gf.vec.FV().NumPy(), result.forms.gf.vec.FV().NumPy()
    assert np.linalg.norm(b - a) <= 1e-12 * np.linalg.norm(a)


def test_stefan_run_with_growing_steps_resumes_to_the_last_bit(tmp_path, monkeypatch):
    """Permafrost (phase change, dt growing 1.2x per step up to dt_max) stopped by a solver error after dt
    reached dt_max, where the Newton matrix's factorization is reused over steps (Woodbury corrections): the
    checkpoint keeps that reuse state, so the resumed run repeats the uninterrupted one to the last bit."""
    from ngs_geomech.stefan.solver import StefanSolver

    sets = ["mesh.maxh=10", "time.end='15000 year'", "output.figures=false",
            "output.vtk=false", "output.checkpoint_every=1000"]
    ref = run("permafrost", tmp_path / "REF", overrides=sets, progress=False)
    original = StefanSolver.step
    year = 365.25 * 86400
    stop = [t1 for _, t1 in schedule(0.0, 15000 * year, 20 * year, 1.2, 250 * year)][28]

    def step(self, t_old, t_new, extra_load=None):
        if t_new > stop * (1 + 1e-12):  # every try after the 29th step (the finer substeps too)
            raise SolverError("Stefan Newton step diverged (injected)")
        return original(self, t_old, t_new, extra_load)
    monkeypatch.setattr(StefanSolver, "step", step)
    with pytest.raises(SolverError, match=r"The last good state \(step 29 of"):
        run("permafrost", tmp_path / "DIR", overrides=sets, progress=False)
    monkeypatch.undo()
    cp = load_checkpoint(staging_of(tmp_path) / "checkpoint")
    res = run("permafrost", tmp_path / "DIR", overrides=sets, progress=False, resume=True)
    a, b = ref.summary, res.summary
    dts = [t1 - t0 for t0, t1 in schedule(0.0, 15000 * year, 20 * year, 1.2, 250 * year)]
    assert dts[13] < dts[14] == dts[29] == 250 * year         # the steps around the stop: dt_max
    assert b["resumed"][0]["step"] == 29
    assert np.array_equal(res.stefan.solver.e, ref.stefan.solver.e)
    assert b["probe_series"] == a["probe_series"] and b["stefan"]["energy"] == a["stefan"]["energy"]
    assert b["stefan"]["newton_iterations"] == a["stefan"]["newton_iterations"]
    # what made it so: the factorization's data and the correction rows solved since it
    assert "stefan/jacobian/d0" in cp.arrays and len(cp.arrays["stefan/jacobian/rows_nodes"]) > 0


def test_contact_node_arrays_follow_their_coordinates():
    """A contact warm start written on another partition lists the nodes in another order: node_permutation puts
    the saved rows into the current order, leaves an equal order alone and refuses other nodes."""
    from ngs_geomech.contact.solver import node_permutation

    rng = np.random.default_rng(7)
    saved = rng.random((40, 3))
    order = rng.permutation(40)
    current = saved[order] + 1e-13
    perm = node_permutation(saved, current)
    np.testing.assert_allclose(saved[perm], current, atol=1e-12)
    assert node_permutation(saved, saved.copy()) is None
    with pytest.raises(ValueError, match="not this mesh's"):
        node_permutation(saved, current + 1e-3)
