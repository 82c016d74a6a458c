"""Performance of the Stefan solver: semi-smooth Newton iterations per step and the wall time of a step against a
linear heat step on the same mesh, with the front error, the L2 error and the energy balance.

Physics. The Neumann melting problems of :mod:`ngs_geomech.verification.stefan` on the strip [0, L] x [0, 0.1] m
(2D, P1, vertex-lumped storage, backward Euler (2.55); T = T_L on x = 0, T = T_S on x = L, insulated top and
bottom; started at t0 = 0.05 s from the lumped projection of the exact enthalpy, run to t1 = 0.5 s), h and dt
refined together (dt = 0.2 h s/m). Headline: the two-phase case (Theta_R = 0, L = 2 J/m^3, C_s = 3, C_l = 1
J/(m^3 K), k_s = 1.5, k_l = 1 W/(m K), T_L = 1, T_S = -0.5: the conductivity jumps at the front, so the Newton
matrix is not symmetric). Beside it the one-phase case (St = 1, the solid at Theta_R: most of it is mushy,
dT/de = 0), a degenerate case for the solver.

Measured per level: Newton iterations per step (mean and max; an iteration is a linear solve with the Newton
matrix), sparse LU factorizations and low-rank correction columns per step (:mod:`ngs_geomech.stefan.solver`
reuses a factorization and corrects it for the nodes that changed phase), nodes changing phase per step, the
wall time per step (``StefanSolver.step``, everything included) and, in the same run and on the same mesh, the
time of a linear heat step: :class:`HeatSolver` with the liquid's constant properties and the same Dirichlet
data, one backward Euler step. Two definitions of "a linear heat step": reused (the headline,
``time_ratio_vs_linear_step``: the factorization kept across the steps, as HeatSolver does for constant dt) and
with factorization (``..._with_factorization``: the cache cleared before each step). Both sides run on one
NGSolve thread and one BLAS thread, in alternating blocks of steps so both see the same machine load.

Errors at t1 against the closed form: the front from the melted volume (``front_rel_error_finest``) and from the
temperatures (where T_h crosses Theta_R along the bottom edge), the L2 error of T, the energy imbalance |heat
gained - heat entered through the Dirichlet nodes| / heat entered (conservation of the scheme, round-off) and
the energy error against the exact heat input.

Metrics (two-phase unless prefixed ``one_phase_``): ``newton_iterations_mean`` the largest of the per-level
means, ``newton_iterations_max`` the most iterations of any step, ``time_ratio_vs_linear_step`` at the finest
level (``..._max`` the largest over the levels), ``energy_imbalance_rel`` the largest over all levels of both
cases. Targets, reported and not gated: Newton mean at most 4 at every level and not growing with refinement
(``newton_mean_slope``: the log-log slope of the means against h, negative when the mean grows as h falls);
time ratio at most 3 at the finest level.

Command: ``python studies/stefan_performance/run.py --level 1 --out out/stefan_performance`` (writes
``results.json``; prints the tables). Levels: 0 two-phase h = 0.05 ... 0.00625 m (215 ... 10.8k nodes),
one-phase h = 0.05 ... 0.0125; 1 both down to h = 0.003125 (42k / 16k nodes, 720 steps); 2 both down to
h = 0.0015625 (170k / 66k nodes, 1440 steps).

Cost on one thread: level 0 about 6 s, level 1 about 50 s, level 2 tens of minutes.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ngs_geomech.verification import stefan as st
from ngs_geomech.verification.study import convergence_entry, metrics_lines, study_cli, study_main

STUDY = "stefan_performance"
LEVELS = {
    0: {"two_phase": (0.05, 0.025, 0.0125, 0.00625), "one_phase": (0.05, 0.025, 0.0125)},
    1: {"two_phase": (0.05, 0.025, 0.0125, 0.00625, 0.003125), "one_phase": (0.05, 0.025, 0.0125, 0.00625, 0.003125)},
    2: {"two_phase": (0.05, 0.025, 0.0125, 0.00625, 0.003125, 0.0015625),
        "one_phase": (0.05, 0.025, 0.0125, 0.00625, 0.003125, 0.0015625)},
}
"""Mesh sizes h (m) per level and case; dt = DT_OVER_H * h."""
DT_OVER_H = 0.2
T0, T1 = 0.05, 0.5
HEIGHT = 0.1
TARGET_NEWTON_MEAN = 4.0
TARGET_TIME_RATIO = 3.0
CASES = {"two_phase": st.TWO_PHASE, "one_phase": st.ONE_PHASE}
KEYS = ("h", "dt", "ndofs", "steps", "newton_mean", "newton_max", "factorizations_per_step", "corrections_per_step",
        "phase_changes_per_step", "time_per_step", "linear_step_time", "linear_step_time_factor", "time_ratio",
        "time_ratio_factor", "cpu_time_per_step", "linear_step_cpu_time", "time_ratio_cpu", "front_exact",
        "front_volume", "front_temperature", "front_error_volume", "front_error_temperature", "l2", "l2_rel",
        "energy_imbalance_rel", "energy_error_rel")


def _level(problem, h: float) -> dict:
    t0 = time.perf_counter()
    r = st.neumann_strip(problem, h, DT_OVER_H * h, T0, T1, height=HEIGHT)
    row = {k: r[k] for k in KEYS}
    row["front_rel_error_volume"] = r["front_error_volume"] / r["front_exact"]
    row["front_rel_error_temperature"] = r["front_error_temperature"] / r["front_exact"]
    row["run_s"] = time.perf_counter() - t0
    return row


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the per-case rows (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    rows: dict[str, list] = {}
    convergence: list[dict] = []
    for case, hs in LEVELS[level].items():
        tic = time.perf_counter()
        rows[case] = []
        for h in hs:
            row = _level(CASES[case], h)
            rows[case].append(row)
            timing[f"{case}_h{h:g}_s"] = row["run_s"]
        timing[f"{case}_s"] = time.perf_counter() - tic
        rs = rows[case]
        hs_, dofs = [r["h"] for r in rs], [r["ndofs"] for r in rs]
        for quantity, key, expected, note in (
                ("front_rel_error_volume", "front_rel_error_volume", 1, "|s_h - s| / s, s_h = melted volume / height"),
                ("front_rel_error_temperature", "front_rel_error_temperature", 1,
                 "|s_h - s| / s, s_h where T_h crosses Theta_R on the bottom edge (node to node)"),
                ("l2_error", "l2", 1, "||T_h - T||_L2 (K m) at t1"),
                ("energy_error_rel", "energy_error_rel", 1, "|heat gained - exact heat input| / exact heat input")):
            convergence.append(convergence_entry(f"{case}_{quantity}", hs_, dofs, [r[key] for r in rs], expected,
                                                 note=note, dt=[r["dt"] for r in rs]))
        convergence.append(convergence_entry(
            f"{case}_newton_iterations_mean", hs_, dofs, [r["newton_mean"] for r in rs], 0,
            note="Newton iterations (linear solves) per step, mean; expected: not growing",
            newton_max=[r["newton_max"] for r in rs],
            factorizations_per_step=[r["factorizations_per_step"] for r in rs],
            corrections_per_step=[r["corrections_per_step"] for r in rs],
            phase_changes_per_step=[r["phase_changes_per_step"] for r in rs]))
        convergence.append(convergence_entry(
            f"{case}_time_ratio_vs_linear_step", hs_, dofs, [r["time_ratio"] for r in rs], None,
            note="Stefan step wall time / linear heat step (factorization reused), same mesh, same run",
            time_per_step=[r["time_per_step"] for r in rs], linear_step_time=[r["linear_step_time"] for r in rs],
            linear_step_time_factor=[r["linear_step_time_factor"] for r in rs],
            time_ratio_factor=[r["time_ratio_factor"] for r in rs]))
    timing["total_s"] = time.perf_counter() - t_start
    metrics = _metrics(rows)
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing,
              "rows": rows, "dt_over_h": DT_OVER_H, "t0": T0, "t1": T1, "height": HEIGHT}
    return result, rows


def _slope(rs: list, key: str) -> float:
    """Least-squares slope of log(key) against log(h) (0 when fewer than two levels)."""
    if len(rs) < 2:
        return 0.0
    return float(np.polyfit(np.log([r["h"] for r in rs]), np.log([r[key] for r in rs]), 1)[0])


def _metrics(rows: dict) -> dict:
    m: dict[str, float] = {}
    two, one = rows["two_phase"], rows["one_phase"]
    fin = two[-1]
    means = [r["newton_mean"] for r in two]
    m["newton_iterations_mean"] = max(means)
    m["newton_iterations_max"] = max(r["newton_max"] for r in two)
    m["newton_iterations_mean_finest"] = fin["newton_mean"]
    m["newton_iterations_mean_coarsest"] = two[0]["newton_mean"]
    m["newton_mean_slope"] = _slope(two, "newton_mean")
    m["time_ratio_vs_linear_step"] = fin["time_ratio"]
    m["time_ratio_vs_linear_step_max"] = max(r["time_ratio"] for r in two)
    m["time_ratio_vs_linear_step_with_factorization"] = fin["time_ratio_factor"]
    m["time_ratio_vs_linear_step_cpu"] = fin["time_ratio_cpu"]
    m["time_ratio_vs_linear_step_cpu_max"] = max(r["time_ratio_cpu"] for r in two)
    m["front_rel_error_finest"] = fin["front_rel_error_volume"]
    m["front_rel_error_temperature_finest"] = fin["front_rel_error_temperature"]
    m["l2_rel_error_finest"] = fin["l2_rel"]
    m["energy_imbalance_rel"] = max(r["energy_imbalance_rel"] for rs in rows.values() for r in rs)
    m["energy_error_rel_finest"] = fin["energy_error_rel"]
    m["order_front_volume"] = _slope(two, "front_error_volume")
    m["order_l2"] = _slope(two, "l2")
    m["factorizations_per_step_finest"] = fin["factorizations_per_step"]
    m["corrections_per_step_finest"] = fin["corrections_per_step"]
    m["time_per_step_finest_s"] = fin["time_per_step"]
    m["linear_step_time_finest_s"] = fin["linear_step_time"]
    m["ndofs_finest"] = fin["ndofs"]
    m["h_finest"] = fin["h"]
    m["target_newton_mean_met"] = float(max(means) <= TARGET_NEWTON_MEAN)
    m["target_newton_not_growing_met"] = float(means[-1] <= means[0] + 1.0)
    m["target_time_ratio_met"] = float(fin["time_ratio"] <= TARGET_TIME_RATIO)
    m["target_time_ratio_every_level_met"] = float(all(r["time_ratio"] <= TARGET_TIME_RATIO for r in two))
    m["one_phase_newton_iterations_mean"] = max(r["newton_mean"] for r in one)
    m["one_phase_newton_iterations_max"] = max(r["newton_max"] for r in one)
    m["one_phase_time_ratio_vs_linear_step"] = one[-1]["time_ratio"]
    m["one_phase_front_rel_error_finest"] = one[-1]["front_rel_error_volume"]
    return {k: float(v) for k, v in m.items() if math.isfinite(float(v))}


def tables_text(rows: dict) -> list[str]:
    """The per-level tables as text lines."""
    lines = []
    for case, rs in rows.items():
        lines += ["", f"{case} (dt = {DT_OVER_H:g} h, t = {T0:g} -> {T1:g} s; times in ms; ratio: Stefan step / linear "
                      "step with its factorization reused, 'r cpu' the same in CPU time, 'r fact': / linear step "
                      "with factorization)",
                  f"{'h':>9} {'dofs':>6} {'steps':>5} {'Newton':>6} {'max':>3} {'fact/st':>7} {'corr/st':>7} "
                  f"{'chg/st':>6} {'step':>7} {'lin':>6} {'ratio':>5} {'r cpu':>5} {'lin+f':>7} {'r fact':>6} "
                  f"{'front vol':>9} "
                  f"{'front T':>9} {'L2 rel':>8} {'imbal':>7} {'run s':>6}"]
        for r in rs:
            lines.append(f"{r['h']:9.6g} {r['ndofs']:6d} {r['steps']:5d} {r['newton_mean']:6.2f} {r['newton_max']:3d} "
                         f"{r['factorizations_per_step']:7.3f} {r['corrections_per_step']:7.2f} "
                         f"{r['phase_changes_per_step']:6.2f} {1e3 * r['time_per_step']:7.2f} "
                         f"{1e3 * r['linear_step_time']:6.2f} {r['time_ratio']:5.2f} {r['time_ratio_cpu']:5.2f} "
                         f"{1e3 * r['linear_step_time_factor']:7.2f} {r['time_ratio_factor']:6.2f} "
                         f"{r['front_rel_error_volume']:9.2e} {r['front_rel_error_temperature']:9.2e} "
                         f"{r['l2_rel']:8.2e} {r['energy_imbalance_rel']:7.1e} {r['run_s']:6.1f}")
    return lines


def _targets(m: dict) -> list[str]:
    def ok(key):
        return "met" if m.get(key) == 1.0 else "NOT met"
    return ["", "targets, two-phase case:",
            f"  Newton mean <= {TARGET_NEWTON_MEAN:g} at every level: largest mean {m['newton_iterations_mean']:.2f} "
            f"(max {m['newton_iterations_max']:.0f}): {ok('target_newton_mean_met')}",
            f"  Newton mean not growing with refinement: coarsest {m['newton_iterations_mean_coarsest']:.2f}, finest "
            f"{m['newton_iterations_mean_finest']:.2f} (slope vs h {m['newton_mean_slope']:.2f}): "
            f"{ok('target_newton_not_growing_met')}",
            f"  time ratio <= {TARGET_TIME_RATIO:g} at the finest level (factorization reused): "
            f"{m['time_ratio_vs_linear_step']:.2f}: {ok('target_time_ratio_met')}; at every level (largest "
            f"{m['time_ratio_vs_linear_step_max']:.2f}): {ok('target_time_ratio_every_level_met')}; in CPU time "
            f"{m['time_ratio_vs_linear_step_cpu']:.2f} (largest {m['time_ratio_vs_linear_step_cpu_max']:.2f}); "
            f"against a linear step with its factorization: {m['time_ratio_vs_linear_step_with_factorization']:.2f}"]


def report(result: dict) -> str:
    """A plain-text report: the per-level tables, the targets next to the measured values, the metrics."""
    lines = [f"study {result['study']}, level {result['level']}"] + tables_text(result["rows"])
    lines += _targets(result["metrics"])
    return "\n".join(lines + metrics_lines(result, width=46))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1 up to 42k nodes, 2 up to 166k nodes); write ``out/results.json``
    if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
