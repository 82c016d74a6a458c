"""Uncertain data (issue 11): the worst-scenario search, Monte Carlo and quasi-Monte Carlo against the closed
forms of tests/scenes/uncertainty/slab.toml (steady slab with a uniform source: peak q L^2 / (8 k), exact for
P2), parallel executors equal to serial, a killed study resumed, and bad input named before any run."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.errors import ResumeError, SceneError
from ngs_geomech.uncertainty import samples as samples_module
from ngs_geomech.uncertainty.study import run_uncertainty

pytestmark = pytest.mark.usefixtures("one_thread")

ROOT = Path(__file__).resolve().parents[1]
SLAB = ROOT / "tests" / "scenes" / "uncertainty" / "slab.toml"
L, Q, K = 2.0, (80.0, 120.0), (1.5, 3.0)


def peak(q, k):
    return q * L * L / (8 * k)


EXACT_MEAN = L * L / 8 * np.mean(Q) * math.log(K[1] / K[0]) / (K[1] - K[0])


def _criterion(res, mode=None):
    return res[mode or res["mode"]]["criteria"]["peak_temperature"]


def test_worst_scenario_with_corners_matches_closed_form(tmp_path):
    res = run_uncertainty(SLAB, tmp_path / "w", executor="serial", progress=False)
    e = _criterion(res)
    print("range", e["range"], "exact", [peak(Q[0], K[1]), peak(Q[1], K[0])])
    assert e["range"][0] == pytest.approx(peak(Q[0], K[1]), rel=1e-10)
    assert e["range"][1] == pytest.approx(peak(Q[1], K[0]), rel=1e-10)
    assert e["max"]["parameters"] == {"source": Q[1], "conductivity": K[0]}
    assert e["min"]["parameters"] == {"source": Q[0], "conductivity": K[1]}
    assert e["max"]["stop"] == e["min"]["stop"] == "kkt"
    assert e["margin_to_limit"] == pytest.approx(60.0 - peak(Q[1], K[0]))
    assert e["nominal"] == pytest.approx(peak(100.0, 2.0), rel=1e-10)
    # derivative at the worst point (backward difference at conductivity's lower end: first order)
    assert e["max"]["gradient"]["source"] == pytest.approx(L * L / (8 * K[0]), rel=1e-8)
    assert e["max"]["gradient"]["conductivity"] == pytest.approx(-Q[1] * L * L / (8 * K[0] ** 2), rel=0.03)
    for f in ("results.json", "table.md", "table.csv", "samples.jsonl", "figures/worst_scenario.png",
              "figures/samples_peak_temperature.png"):
        assert (tmp_path / "w" / f).is_file(), f
    assert "source=120; conductivity=1.5" in (tmp_path / "w" / "table.md").read_text()


def test_local_search_reaches_the_worst_corners_from_the_design(tmp_path):
    """Without the corners in the design the projected-gradient search must find them."""
    res = run_uncertainty(SLAB, tmp_path / "w", overrides=["uncertainty.vertices=no"], executor="serial",
                          progress=False)
    e = _criterion(res)
    for sense, exact, bounds in (("max", peak(Q[1], K[0]), {"source": "upper", "conductivity": "lower"}),
                                 ("min", peak(Q[0], K[1]), {"source": "lower", "conductivity": "upper"})):
        s = e[sense]
        print(sense, "start", s["start_value"], "path", s["path"], "stop", s["stop"], "iterations", s["iterations"])
        assert s["start_found_by"] == "design"
        assert abs(s["start_value"] - exact) > 0.05 * exact          # the design alone is far off
        assert s["value"] == pytest.approx(exact, rel=1e-10)
        assert s["at_bounds"] == bounds and s["stop"] == "kkt"
        assert s["iterations"] <= 3


def test_derivative_check_measures_finite_difference_error(tmp_path):
    res = run_uncertainty(SLAB, tmp_path / "w", overrides=["uncertainty.derivative_check=true",
                                                           "uncertainty.local_search=false"],
                          executor="serial", progress=False, figures=False)
    dc = _criterion(res)  # noqa: F841 -- the search entries exist too
    check = res["worst_scenario"]["derivative_check"]["peak_temperature"]["steps"]
    exact_k = -100.0 * L * L / (8 * 2.0 ** 2)
    errs = {}
    for name, row in check.items():
        g = row["gradient"]
        assert g["source"] == pytest.approx(L * L / 16, rel=1e-8)      # linear in q: exact for every step
        errs[name] = abs(g["conductivity"] - exact_k) / abs(exact_k)
    print("relative error of dT/dk:", errs)
    assert errs["central_0.01"] < 1e-4
    # forward differences: first order in the step
    order = math.log(errs["forward_0.1"] / errs["forward_0.001"]) / math.log(100.0)
    assert 0.9 < order < 1.1
    lin = res["worst_scenario"]["derivative_check"]["peak_temperature"]["linearized_range"]
    assert lin[0] < peak(Q[0], K[1]) and lin[1] < peak(Q[1], K[0])    # the linearization misses the convex max


def test_monte_carlo_and_qmc_confidence_intervals_hold_the_exact_mean(tmp_path):
    mc = run_uncertainty(SLAB, tmp_path / "mc", overrides=["uncertainty.mode=monte_carlo", "uncertainty.samples=64"],
                         executor="serial", progress=False)
    qmc = run_uncertainty(SLAB, tmp_path / "qmc", overrides=["uncertainty.mode=quasi_monte_carlo",
                                                             "uncertainty.samples=64"],
                          executor="serial", progress=False)
    a, b = _criterion(mc), _criterion(qmc)
    print("exact", EXACT_MEAN, "MC", a["mean"], a["mean_ci"], "QMC", b["mean"], b["mean_ci"])
    assert a["n"] == b["n"] == 64
    assert a["mean_ci"][0] <= EXACT_MEAN <= a["mean_ci"][1]
    assert b["mean_ci"][0] <= EXACT_MEAN <= b["mean_ci"][1]
    assert (b["mean_ci"][1] - b["mean_ci"][0]) < 0.25 * (a["mean_ci"][1] - a["mean_ci"][0])
    assert abs(b["mean"] - EXACT_MEAN) < 0.01 * EXACT_MEAN
    assert a["p_exceed"] == 0.0 and a["p_exceed_ci"][0] == 0.0 and 0 < a["p_exceed_ci"][1] < 0.07
    lo, hi = peak(Q[0], K[1]), peak(Q[1], K[0])
    assert lo <= a["min"] and a["max"] <= hi
    assert (tmp_path / "qmc" / "figures" / "distribution_peak_temperature.png").is_file()


def test_distributions_are_truncated_to_the_interval(tmp_path):
    over = ["uncertainty.mode=monte_carlo", "uncertainty.samples=40",
            "uncertainty.parameters.source.distribution=normal", "uncertainty.parameters.source.std=30.0",
            "uncertainty.parameters.conductivity.distribution=lognormal",
            "uncertainty.parameters.conductivity.sigma=0.5"]
    run_uncertainty(SLAB, tmp_path / "d", overrides=over, executor="serial", progress=False, figures=False)
    recs = [json.loads(x) for x in (tmp_path / "d" / "samples.jsonl").read_text().splitlines()[1:]]
    q = np.array([r["params"]["source"] for r in recs])
    k = np.array([r["params"]["conductivity"] for r in recs])
    assert np.all((Q[0] <= q) & (q <= Q[1])) and np.all((K[0] <= k) & (k <= K[1]))
    for r in recs:
        assert r["values"]["peak_temperature"] == pytest.approx(peak(r["params"]["source"],
                                                                     r["params"]["conductivity"]), rel=1e-9)


def test_process_pool_equals_serial(tmp_path):
    over = ["uncertainty.vertices=no"]
    a = run_uncertainty(SLAB, tmp_path / "s", overrides=over, executor="serial", progress=False, figures=False)
    b = run_uncertainty(SLAB, tmp_path / "p", overrides=over, executor="process", workers=2, progress=False,
                        figures=False)
    assert b["executor"] == {"kind": "process", "workers": 2}
    assert _criterion(a)["range"] == _criterion(b)["range"]
    assert a["samples"]["total"] == b["samples"]["total"]


@needs_mpi
@one_mpi_job
def test_mpi_executor_equals_serial(tmp_path):
    cmd = [mpiexec(), "-n", "3", sys.executable, "-m", "mpi4py.futures", "-m", "ngs_geomech.cli", "uncertain",
           str(SLAB), "--out", str(tmp_path / "m"), "--executor", "mpi", "--quiet", "--no-figures"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stderr
    res = json.loads((tmp_path / "m" / "results.json").read_text())
    assert res["executor"] == {"kind": "mpi", "workers": 2}
    ser = run_uncertainty(SLAB, tmp_path / "s", executor="serial", progress=False, figures=False)
    assert _criterion(res)["range"] == _criterion(ser)["range"]


def test_killed_study_resumes_without_rerunning_finished_samples(tmp_path):
    out = tmp_path / "k"
    over = ["--set", "uncertainty.samples=40", "--set", "uncertainty.vertices=no", "--set",
            "uncertainty.local_search=false"]
    cmd = [sys.executable, "-m", "ngs_geomech.cli", "uncertain", str(SLAB), "--out", str(out), "--executor",
           "serial", "--threads", "1", "--quiet", "--no-figures", *over]
    env = dict(os.environ)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    log = out / "samples.jsonl"
    t0 = time.time()
    while time.time() - t0 < 120:
        if log.is_file() and len(log.read_text().splitlines()) >= 8:
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    kept = len(log.read_text().splitlines()) - 1
    assert 7 <= kept < 41 and not (out / "results.json").exists()
    # without --resume the study refuses to overwrite the samples
    fresh = subprocess.run(cmd, capture_output=True, text=True, env=env)
    assert fresh.returncode == 2 and "--resume" in fresh.stderr
    res = subprocess.run(cmd + ["--resume"], capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr
    r = json.loads((out / "results.json").read_text())
    print("kept", kept, r["samples"])
    assert r["samples"]["total"] == 41
    assert r["samples"]["reused_from_log"] == kept
    assert r["samples"]["run_in_this_session"] == 41 - kept
    ref = run_uncertainty(SLAB, tmp_path / "ref", overrides=[o for o in over if o != "--set"], executor="serial",
                          progress=False, figures=False)
    assert _criterion(r)["range"] == pytest.approx(_criterion(ref)["range"], rel=1e-12)
    # other data: refused, naming the item
    bad = subprocess.run(cmd + ["--resume", "--set", "materials.slab.conductivity=2.5"], capture_output=True,
                         text=True, env=env)
    assert bad.returncode == 2 and "materials.slab.conductivity" in bad.stderr
    bad = subprocess.run(cmd + ["--resume", "--set", "uncertainty.criteria.peak_temperature.summary=probes.peak.min"],
                         capture_output=True, text=True, env=env)
    assert bad.returncode == 2 and "criteria.peak_temperature" in bad.stderr


def test_failed_samples_are_reported_not_dropped(tmp_path, monkeypatch):
    real = samples_module.evaluate

    def flaky(task):
        if task["params"]["conductivity"] > 2.9 and task["tag"] == "design":
            return {**{k: task[k] for k in ("key", "z", "tag", "params")}, "status": "failed", "values": {},
                    "wall_s": 0.0, "message": "SolverError: made to fail"}
        return real(task)

    monkeypatch.setattr(samples_module, "evaluate", flaky)
    res = run_uncertainty(SLAB, tmp_path / "f", executor="serial", progress=False, figures=False)
    assert res["samples"]["failed"] >= 2
    assert all("made to fail" in f["message"] for f in res["failed_samples"])
    assert "failed at" in (tmp_path / "f" / "table.md").read_text()


BAD = [
    (["uncertainty.parameters.source.keys=['sources.0.densty']"], "densty: unknown key"),
    (["uncertainty.parameters.source.keys=['materials.nowhere.conductivity']"], "materials.nowhere"),
    (["uncertainty.parameters.source.interval=[120.0, 80.0]"], "uncertainty.parameters.source.interval"),
    (["uncertainty.parameters.source.interval=[110.0, 120.0]"], "nominal value 100"),
    (["uncertainty.parameters.conductivity.interval=[-1.0, 3.0]"], "lower ends"),
    (["uncertainty.parameters.source.scale=factor", "uncertainty.parameters.source.keys=['mesh.nothing']"],
     "mesh.nothing"),
    (["uncertainty.criteria.peak_temperature.summary=probes.peek.max"], "peek"),
    (["uncertainty.mode=quasi_monte_carlo", "uncertainty.samples=60"], "uncertainty.samples"),
    (["uncertainty.parameters.source.distribution=normal"], "uncertainty.parameters.source.std"),
    (["uncertainty.fd_step=0.9"], "uncertainty.fd_step"),
    (["uncertainty.parameters.conductivity.keys=['sources.0.density']"], "set by parameter"),
    (["uncertainty.samplez=3"], "uncertainty.samplez"),
]


@pytest.mark.parametrize("over,needle", BAD, ids=[b[1] for b in BAD])
def test_bad_uncertainty_input_is_named_before_any_run(tmp_path, monkeypatch, over, needle):
    def boom(task):
        raise AssertionError("a sample ran")

    monkeypatch.setattr(samples_module, "evaluate", boom)
    with pytest.raises(SceneError) as exc:
        run_uncertainty(SLAB, tmp_path / "b", overrides=over, executor="serial", progress=False)
    print(exc.value)
    assert needle in str(exc.value)
    assert not (tmp_path / "b").exists()


def test_missing_summary_item_is_named_after_the_nominal_run(tmp_path):
    with pytest.raises(SceneError) as exc:
        run_uncertainty(SLAB, tmp_path / "b", overrides=["uncertainty.criteria.peak_temperature.summary="
                                                         "mechanics.contact.interfaces.fault.max_slip_m"],
                        executor="serial", progress=False)
    assert "peak_temperature" in str(exc.value) and "has no 'mechanics'" in str(exc.value)
    assert not (tmp_path / "b" / "results.json").exists()


def test_scene_without_uncertainty_table_and_resume_without_log(tmp_path):
    with pytest.raises(SceneError, match="no \\[uncertainty\\] table"):
        run_uncertainty("heated_rock", tmp_path / "x", executor="serial", progress=False)
    with pytest.raises(ResumeError, match="no sample log"):
        run_uncertainty(SLAB, tmp_path / "y", executor="serial", progress=False, resume=True)


def test_factor_scales_numbers_and_expressions(tmp_path):
    """scale = 'factor': a number item becomes value x factor, an expression item (e)*factor."""
    over = ['sources.0.density="100.0 + 0*x"', "uncertainty.parameters.source.scale=factor",
            "uncertainty.parameters.source.interval=[0.8, 1.2]",
            "uncertainty.parameters.conductivity.scale=factor",
            "uncertainty.parameters.conductivity.interval=[0.75, 1.5]", "uncertainty.local_search=false"]
    res = run_uncertainty(SLAB, tmp_path / "f", overrides=over, executor="serial", progress=False, figures=False)
    e = _criterion(res)
    assert e["nominal"] == pytest.approx(peak(100.0, 2.0), rel=1e-10)
    assert e["range"] == pytest.approx([peak(Q[0], K[1]), peak(Q[1], K[0])], rel=1e-10)
    assert res["parameters"]["source"]["nominal"] == 1.0


def test_a_dying_worker_stops_the_study_with_a_clear_error():
    """A worker process that dies (out of memory, a crash in a library) ends the batch with a SolverError that
    says the finished samples are kept and how to resume, not with a bare BrokenProcessPool."""
    from ngs_geomech.errors import SolverError
    from ngs_geomech.uncertainty.executors import Runner

    with Runner("process", 1) as runner, pytest.raises(SolverError, match="--resume"):
        list(runner.as_completed(os._exit, [3]))


def _two_criteria_slab() -> dict:
    """The slab with a second probe (x = L/4: q x (L - x) / (2 k), largest where the peak is) and two criteria
    searched in opposite senses: the quarter's max search passes points where the peak exceeds everything the
    peak's own (min) search saw."""
    from ngs_geomech.scene.parse import read_toml

    raw = read_toml(SLAB)
    raw["output"]["probes"].append({"name": "quarter", "point": [0.5, 0.125]})
    raw["uncertainty"]["criteria"] = [
        {"name": "peak_temperature", "summary": "probes.peak.max", "unit": "C", "sense": "min", "limit": 30.0},
        {"name": "quarter_temperature", "summary": "probes.quarter.max", "unit": "C", "sense": "max",
         "limit": 45.0}]
    return raw


@pytest.mark.parametrize("mode", ["worst_scenario", "monte_carlo"])
def test_reported_range_covers_every_sample_and_gives_the_margin(tmp_path, mode):
    """Each criterion's range covers its value at every finished sample (nominal, design, every criterion's
    search), the margin to the limit is limit - max of that range, and results.json, table.md and the CLI
    report say the same."""
    from ngs_geomech.cli import _uncertainty_report

    over = [f"uncertainty.mode={mode}", "uncertainty.samples=3", "uncertainty.vertices=no",
            "uncertainty.max_local_iterations=1"]
    res = run_uncertainty(_two_criteria_slab(), tmp_path / "r", overrides=over, executor="serial", progress=False,
                          figures=False)
    recs = [json.loads(x) for x in (tmp_path / "r" / "samples.jsonl").read_text().splitlines()[1:]]
    table = (tmp_path / "r" / "table.md").read_text()
    report = _uncertainty_report(res, str(tmp_path / "r"))
    for name, limit in (("peak_temperature", 30.0), ("quarter_temperature", 45.0)):
        v = [r["values"][name] for r in recs if r["status"] == "ok"]
        e = res[mode]["criteria"][name]
        print(mode, name, "range", e["range"], "samples", [min(v), max(v)], "margin", e["margin_to_limit"])
        assert e["range"] == [min(v), max(v)] and e["range_samples"] == len(v) == len(recs)
        assert e["margin_to_limit"] == limit - max(v)
        assert f"{min(v):.6g} | {max(v):.6g} | {limit:.6g} | {limit - max(v):.6g}" in table
        assert (f"range [{min(v):.6g}, {max(v):.6g}] C, margin to the limit {limit - max(v):.4g} C"
                in report)
    if mode == "worst_scenario":      # the case that hid the peak's largest value before
        peak_max = res[mode]["criteria"]["peak_temperature"]["max_over_all_samples"]
        assert peak_max["found_by"].startswith("quarter_temperature:max")
