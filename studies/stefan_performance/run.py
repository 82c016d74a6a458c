"""Performance of the Stefan solver (issue 5, section 4): semi-smooth Newton iterations per step and the wall time
of a step against a linear heat step on the same mesh, with the front error, the L2 error and the energy balance.

Physics. The Neumann melting problems of :mod:`ngs_geomech.verification.stefan` on the strip [0, L] x [0, 0.1] m
(2D, P1, vertex-lumped storage, backward Euler; T = T_L on x = 0, T = T_S on x = L, insulated top and bottom;
started at t0 = 0.05 s from the lumped projection of the exact enthalpy, run to t1 = 0.5 s), h and dt refined
together (dt = 0.2 h s/m). Headline: the two-phase case (Theta_R = 0, L = 2 J/m^3, C_s = 3, C_l = 1 J/(m^3 K),
k_s = 1.5, k_l = 1 W/(m K), T_L = 1, T_S = -0.5: the solid is below the melting temperature, the conductivity
jumps at the front, so the Newton matrix is not symmetric). Beside it the one-phase case (St = 1, the solid
at Theta_R: most of it is mushy, dT/de = 0), a degenerate but instructive case for the solver.

Measured per level: Newton iterations per step (mean and max; "iterations" are linear solves with the Newton
matrix), sparse LU factorizations and low-rank correction columns per step (:class:`_ColumnJacobian` of
:mod:`ngs_geomech.stefan.solver`), nodes changing between solid, mushy and liquid per step, the wall time per
step (``StefanSolver.step``, everything included: state, residuals, solves, the GridFunctions) and, in the same
run and on the same mesh, the time of a linear heat step: :class:`HeatSolver` with the liquid's constant
properties and the same Dirichlet data, one backward Euler step (Dirichlet values, right-hand side assembly,
residual, solve). Two definitions of "a linear heat step":

* reused (the headline, ``time_ratio_vs_linear_step``): the factorization kept across the steps, as HeatSolver
  does for constant dt: the honest comparison for a time-stepping run, mean over as many steps as the Stefan run;
* with factorization (``..._with_factorization``): the cache cleared before each step (assembly and sparse
  Cholesky factorization included), mean of three steps.

Both sides run on one NGSolve thread and one BLAS thread, in five alternating blocks of Stefan steps and of as
many linear steps (both timed under the same load of the shared machine). The Stefan solver factors with
SuperLU (scipy), HeatSolver with NGSolve's sparsecholesky; on these meshes a SuperLU solve is 1.5 - 3 x faster
than a sparsecholesky solve (0.35 against 1.0 ms at 10.8k unknowns), which helps the ratio: one linear step
costs about 1.3 sparsecholesky solves.

Errors at t1 against the closed form: the front from the melted volume (lumped liquid fractions / height; the
headline ``front_rel_error_finest``) and from the temperatures (where T_h crosses Theta_R along the bottom
edge: it moves from node to node), the L2 error of T, the energy imbalance |heat gained - heat entered through
the Dirichlet nodes| / heat entered (the scheme's conservation, round-off) and the energy error against the
exact heat input.

Metrics (two-phase unless prefixed ``one_phase_``): ``newton_iterations_mean`` the largest of the per-level means,
``newton_iterations_max`` the most iterations of any step at any level, ``time_ratio_vs_linear_step`` at the
finest level (``..._max`` the largest over the levels), ``front_rel_error_finest`` |s_h - s| / s with s_h from
the melted volume at the finest level, ``energy_imbalance_rel`` the largest over all levels of both cases.

Targets (issue 5, section 4): Newton mean at most 4 at every level (``target_newton_mean_met``) and not growing
with refinement (``target_newton_not_growing_met``: the finest level's mean at most the coarsest level's mean
plus one iteration; the fitted log-log slope of the means against h is reported as ``newton_mean_slope``,
negative when the mean grows as h falls); time ratio at most 3 at the finest level
(``target_time_ratio_met``), also reported at every level.

Command: ``python studies/stefan_performance/run.py --level 1 --out out/stefan_performance`` (writes
``results.json``; prints the tables). Levels: 0 two-phase h = 0.05 ... 0.00625 m (215 ... 10.8k nodes, 45 ... 360
steps), one-phase h = 0.05 ... 0.0125; 1 both down to h = 0.003125 (42k / 16k nodes, 720 steps); 2 both down to
h = 0.0015625 (170k / 66k nodes, 1440 steps).

Measured with the solver's window mode (issue 5, the remaining target: :class:`_ColumnJacobian` of
:mod:`ngs_geomech.stefan.solver` factors M0 outside a window of nodes around the front and the window's Schur
complement per changed Newton matrix, for factored sets of at least 8000 unknowns; the smaller meshes keep the
Woodbury correction, unchanged). Level 2, one run, the other core busy for most of it (load about 2.5: the linear
step at 170k nodes took 146 ms against 64 ms in the level-2 run below; both are timed under the same load),
columns as in the tables below ("corr": solves for the window's interface in window mode: two-phase h <= 0.00625,
one-phase h <= 0.003125 once its factored set, the liquid and a halo, reaches 8000 unknowns):

    two-phase  h    nodes steps Newton fact  corr  chg   step    lin ratio   r f front vol front T  L2 rel  imbal run
         0.05       215    45 1.22/2 .022  0.42  0.8   1.13   0.42  2.70  0.60  1.29e-2  1.92e-2  4.3e-3 5e-16  0.2
         0.025      717    90 1.28/3 .022  0.72  1.4   1.41   0.64  2.22  0.23  6.34e-3  1.18e-2  2.1e-3 1e-14  0.5
         0.0125    2842   180 1.86/5 .022  1.42  2.7   4.41   1.40  3.15  0.18  3.34e-3  4.39e-3  9.0e-4 3e-14  2.2
         0.00625  10806   360 1.44/4 .014  0.26  5.1  15.09   9.16  1.65  0.11  1.37e-3  3.37e-3  4.7e-4 2e-14 14.0
         0.003125 42051   720 1.76/5 .010  0.52  9.8  63.25  29.06  2.18  0.13  6.34e-4  6.43e-4  2.4e-4 2e-14 96.5
         0.0015625 170186 1440 1.71/4 .006 0.62 19.8 257.19 145.74  1.76  0.11  3.32e-4  1.28e-3  1.0e-4 5e-13 683
    one-phase
         0.05        83    45 1.13/3 .067  0.76  0.8   0.99   0.56  1.78  0.58  2.35e-3  3.80e-2  5.8e-3 2e-15  0.1
         0.025      282    90 1.07/2 .056  1.20  1.3   1.31   0.65  2.01  0.71  9.70e-4  9.17e-3  2.7e-3 2e-15  0.3
         0.0125    1099   180 1.51/3 .056  2.58  2.7   2.07   0.64  3.24  0.28  3.60e-4  7.96e-5  1.1e-3 0      0.9
         0.00625   4170   360 1.10/3 .069  4.45  5.1   3.83   1.75  2.18  0.08  1.53e-4  7.96e-5  5.3e-4 2e-14  3.7
         0.003125 16276   720 1.10/3 .060  5.82  9.9  11.39   8.46  1.35  0.07  8.29e-5  1.20e-3  2.7e-4 1e-13 22.0
         0.0015625 65634 1440 1.09/3 .034 2.45 20.0  56.73  44.25  1.28  0.07  4.62e-5  5.86e-4  1.5e-4 1e-13 180

Newton iterations, front errors, L2 errors and imbalances are those of the Woodbury solver below (the same
iterates: at 42k nodes the final enthalpies agree to 1.2e-12 J/m^3, identical iteration counts). The time
ratios before (level 2 with the Woodbury correction at every size, the run of the issue): two-phase 2.10, 2.24,
3.43, 2.78, 3.46, 4.61 (h = 0.05 ... 0.0015625); after: 2.70, 2.22, 3.15, 1.65, 2.18, 1.76 (the three coarse
levels run the same code as before: their ratios move with the load of the machine). Old and new solver in
one process at 170k nodes, the first 500 steps (where the front is fastest), blocks of 100 steps alternating,
the machine busy: 960 against 330 ms per step (2.9 x), 16.5 correction columns and 0.046 factorizations per
step against 0.90 interface solves and 0.008 factorizations (adapted width 37), the same Newton iterations
(mean 2.03, max 4), final enthalpies within 1.5e-13 J/m^3.

Measured at level 1 before the window mode (one NGSolve and one BLAS thread, the 2-core machine shared with other
jobs; CPU time = wall time within 1 %; the ratios of repeated runs differ by up to 15 % at the fine levels, more
on the coarse ones). "Newton": iterations per step, mean / max; "fact", "corr", "chg": factorizations, correction
columns and nodes changing branch, per step; times in ms per step; "lin": the linear heat step with its
factorization reused, "ratio" = step / lin (the headline), "r f": step / (linear step with assembly and
factorization); front: relative error of the front from the melted volume and from the T crossing; "imbal":
relative energy imbalance; "run": seconds for the level (mesh, initial state, both runs, errors).

    two-phase  h    nodes steps Newton fact  corr  chg   step    lin ratio   r f front vol front T  L2 rel  imbal run
         0.05       215    45 1.22/2 .022  0.42  0.8   0.36   0.14  2.55  0.45  1.29e-2  1.92e-2  4.3e-3 9e-16  0.1
         0.025      717    90 1.28/3 .022  0.72  1.4   0.50   0.21  2.39  0.24  6.34e-3  1.18e-2  2.1e-3 1e-14  0.2
         0.0125    2842   180 1.86/5 .022  1.41  2.7   1.35   0.44  3.10  0.16  3.34e-3  4.39e-3  9.0e-4 3e-14  0.9
         0.00625  10806   360 1.44/4 .025  2.63  5.1   4.85   1.56  3.11  0.14  1.37e-3  3.37e-3  4.7e-4 2e-14  4.6
         0.003125 42051   720 1.76/5 .025  5.33  9.8  38.28  11.75  3.26  0.22  6.34e-4  6.43e-4  2.4e-4 2e-14 46.5
    one-phase
         0.05        83    45 1.13/3 .067  0.76  0.8   0.30   0.12  2.58  0.60  2.35e-3  3.80e-2  5.8e-3 2e-15  0.0
         0.025      282    90 1.07/2 .067  1.19  1.3   0.34   0.14  2.42  0.37  9.70e-4  9.17e-3  2.7e-3 4e-15  0.1
         0.0125    1099   180 1.51/3 .067  2.54  2.7   0.67   0.24  2.74  0.19  3.60e-4  7.96e-5  1.1e-3 1e-15  0.4
         0.00625   4170   360 1.10/3 .069  4.45  5.1   1.47   0.62  2.39  0.10  1.53e-4  7.96e-5  5.3e-4 2e-14  1.5
         0.003125 16276   720 1.10/3 .069  8.66  9.9   6.66   1.99  3.35  0.11  8.29e-5  1.20e-3  2.7e-4 1e-13  9.4

Level 2 before the window mode (the next run, same set-up; the rows of the coarser levels agree with the
tables above to 10 - 30 % in time; this run while the other core was busy with tests):

    two-phase  h    nodes steps Newton fact  corr  chg   step    lin ratio   r f front vol front T  L2 rel  imbal run
         0.003125 42051   720 1.76/5 .025  5.33  9.8  33.77   8.46  3.99  0.22  6.34e-4  6.43e-4  2.4e-4 2e-14 40.0
         0.0015625 170186 1440 1.71/4 .029 11.74 19.8 260.83 63.67  4.10  0.28  3.32e-4  1.28e-3  1.0e-4 5e-13 508
    one-phase
         0.003125 16276   720 1.10/3 .069  8.66  9.9   7.23   2.16  3.35  0.12  8.29e-5  1.20e-3  2.7e-4 1e-13 10.1
         0.0015625 65634  1440 1.09/3 .076 17.21 20.0  54.34  22.52  2.41  0.06  4.62e-5  5.86e-4  1.5e-4 9e-14 128

After SuperLU's minimum-degree ordering on A + A^T and the residual-watched linear reference step (one run,
level 1, the other core running a test suite): two-phase ratios 2.75 2.19 3.39 2.88 2.90 (h = 0.05 ... 0.003125;
step 37.6 ms against 12.96 ms at 42k nodes), one-phase 2.05 2.05 2.59 2.17 2.38; Newton and errors unchanged.
Level 2 (170k nodes) not re-run after the ordering change.

Orders (two-phase, fitted over the levels of level 1): front from the melted volume 1.09, L2 1.04; the front
from the T crossing moves from node to node (no clean order). Energy imbalance at round-off at every level
(<= 5e-13).

Targets: Newton mean <= 4: met (largest mean 1.86, max 5 iterations); not growing: met (1.22 at h = 0.05,
1.44 - 1.86 from h = 0.0125 on, up and down between levels; log-log slope -0.10 over the six levels of level 2);
time ratio <= 3 at the finest level: met with the window mode (1.76 at 170k nodes, 2.18 at 42k; before: 4.10 -
4.61 at 170k, 3.1 - 3.5 at 42k); at every level: NOT met, h = 0.0125 (2842 nodes, the Woodbury correction, the
code unchanged) 3.15 in the last run (3.1 - 3.7 in others). Order of the front over all six levels 1.08, L2
1.06. Against a linear step with its factorization the Stefan step costs 0.1 - 0.25 of it.

Where a step's time goes with the window mode (profile, two-phase, 170k nodes, the window's width fixed at 16,
287 ms per step on the busy machine): two SuperLU solves with M0_RR per Newton iteration (about 125 ms per
step: the bulk), the placements (factorization of M0_RR and the solves for the window's interface, about 130
columns: 5.7 s each, 14 in 1440 steps, 56 ms per step; the adapted width halves their number: 8 placements,
0.0056 factorizations per step in the table), the window's Schur complement (a factorization per changed
Newton matrix, 1.07 per step, about 2300 unknowns: about 10 ms per step), the nodal states, residuals and
GridFunctions (about 90 ms). Why a window rather than a better refactoring policy for the Woodbury correction:
its correction columns are the nodes the front sweeps since the factorization, one solve each, and a
refactorization does not remove them (every node that changes after it needs its own column again), so no
policy gets below about one solve per swept node (11.7 per step at 170k, each about the cost of a linear
step); the window's cost is instead per placement (its interface, two lines of nodes across the front) and per
Newton matrix (a sparse LU of the window's size). Avoiding the second solve per iteration would need the
columns M0_RR^-1 e_i on the interface stored in full (130 x 170k, 177 MB): not done.

Before the window mode (profile, two-phase, h = 0.00625, 4.2 - 4.8 ms): 2.8 SuperLU solves (1.1 ms: two per
Newton iteration with a correction), 2.6 correction columns (0.75 ms, batched), 0.025 factorizations of 14 ms
(0.35 ms), the nodal states and GridFunctions (1.15 ms: ``StefanForms.nodal_state`` 3.4 times per step, once
in ``store``), the rest numpy/Python. A linear step costs about one NGSolve sparsecholesky solve plus the
right-hand side assembly. What keeps the ratio near 3 rather than 2: two solves per Newton iteration (the
Woodbury correction needs M0^-1 b before and after), and the correction columns, whose number per step grows
like 1/h (the nodes the front sweeps in a step, dt ~ h): 2.6, 5.3, 11.7 per step at 10.8k, 42k, 170k nodes, so
at fine levels they become the largest part (170k: about 45 % of the step).

The previous solver (one factorization of the Schur-reduced system per Newton iteration whose branches differ
from the last one; sparse Cholesky or UMFPACK) measured in one run with the current one, same meshes and steps,
identical iterations (ms per step, factorizations per step, old -> new):

    two-phase h    0.05  0.80 (0.58) -> 0.32 (0.022)     one-phase h  0.05  0.49 (0.62) -> 0.30 (0.067)
                   0.025 1.07 (0.59) -> 0.43 (0.022)                  0.025 0.60 (0.57) -> 0.35 (0.067)
                  0.0125 8.77 (1.76) -> 1.22 (0.022)                 0.0125 1.98 (1.51) -> 0.71 (0.067)
                 0.00625 20.6 (0.76) -> 4.54 (0.025)                0.00625 3.60 (0.55) -> 2.00 (0.069)
                0.003125  148 (1.18) -> 34.4 (0.025)               0.003125 12.2 (0.57) -> 7.80 (0.069)

so the previous time ratios were about 4.5 - 24 (two-phase, e.g. 23.8 at h = 0.0125).

Cost on the shared 2-core machine: level 0 about 7 s (two-phase 5.6 s, of it 4.3 s at h = 0.00625); level 1
about 65 s (two-phase h = 0.003125 alone 45 s: Stefan run 26 s, linear reference 9 s, mesh and initial state
10 s); level 2 about 17 min with the window mode on the busy machine (two-phase 170k nodes 11.4 min, one-phase
66k nodes 3 min).
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
    return ["", "targets (issue 5, section 4), two-phase case:",
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
