"""Verification of the global evolutionary model, seed (2.6)-(2.16): inertia, Kelvin-Voigt and Prony viscosity, contact.

Physics (:mod:`ngs_geomech.verification.dynamics`). (1) Free axial vibration of a bar (E = 1 GPa, rho = 2500 kg/m^3,
L = 1 m, nu = 0, fixed at one end), started from the first discrete mode, average-acceleration generalized-alpha
(rho_inf = 1): the frequency measured from the tip against omega_1 = pi c / (2 L) while h is refined (dt = T/1000),
and the time error against the semi-discrete frequency while dt is refined (h = L/16). (2) Homogeneous uniaxial
tests under constant load (backward Euler; plane stress, C^v and the branch proportional to C): Kelvin-Voigt creep
and recovery, standard linear solid (one Prony branch, stiffness 1.5 E, tau = 1 s) creep and relaxation, against
their closed forms. (3) An elastic column (nu = 0, L = 1 m) touching a rigid foundation with v0 = 1 m/s, frictionless
Signorini contact on the end-of-step displacement with the contact force acting over the step, lumped mass with the
contact nodes' mass redistributed: the energy history (max gain), the contact duration against 2 L / c, the status
switches per node (chattering), the rebound velocity; the consistent mass (no redistribution) for comparison.

Command: ``python studies/dynamics_verification/run.py --level 0 --out out/dynamics_verification``
(writes ``results.json``; prints the tables).

Cost on one NGSolve thread: level 0 about 2 s, level 1 about 3 s, level 2 about 4 s.

Limits: the rebound velocity of the column and its mean contact pressure approach the closed form (a perfect
rebound) slowly, at about half order, because the dispersion of the P1 / Newmark wave leaves part of the energy
as vibration of the released column; the contact duration converges with order 1 (the release is detected at
step ends). The energy statement holds for rho_inf = 1; generalized-alpha with rho_inf < 1 dissipates but gains
nothing. Friction in the dynamic solver acts on the slip increment of the step.
"""

from __future__ import annotations

import time
from pathlib import Path

from ngs_geomech.verification import dynamics as vd
from ngs_geomech.verification.study import (
    convergence_entry,
    one_ngsolve_thread,
    report,
    study_cli,
    study_main,
)

STUDY = "dynamics_verification"
LEVELS = {
    0: {"bar_n": (4, 8, 16), "bar_steps": (10, 20, 40), "creep_dt": (0.1, 0.05, 0.025), "impact_n": (8, 16, 32)},
    1: {"bar_n": (4, 8, 16, 32), "bar_steps": (10, 20, 40, 80), "creep_dt": (0.1, 0.05, 0.025, 0.0125),
        "impact_n": (8, 16, 32, 64)},
    2: {"bar_n": (4, 8, 16, 32, 64), "bar_steps": (10, 20, 40, 80, 160),
        "creep_dt": (0.1, 0.05, 0.025, 0.0125, 0.00625), "impact_n": (8, 16, 32, 64, 128)},
}
"""Bar elements along L, steps per period, creep time steps (units of tau), impact elements along L, per level."""


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw dicts of the verification functions (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {}
    with one_ngsolve_thread():
        tic = time.perf_counter()
        bars_h = [vd.bar_vibration(n, 1000) for n in p["bar_n"]]
        bars_dt = [vd.bar_vibration(p["bar_n"][-1], s) for s in p["bar_steps"]]
        timing["bar_s"] = time.perf_counter() - tic
        c = convergence_entry("bar_frequency_rel_error_vs_h", [r["h"] for r in bars_h], [r["ndof"] for r in bars_h],
                              [r["rel_error"] for r in bars_h], 2)
        convergence.append(c)
        metrics["frequency_rel_error"] = bars_h[-1]["rel_error"]
        metrics["frequency_order_h"] = c["observed_order"]
        c = convergence_entry("bar_frequency_time_rel_error_vs_dt", [r["dt"] for r in bars_dt],
                              [r["ndof"] for r in bars_dt], [r["time_rel_error"] for r in bars_dt], 2)
        convergence.append(c)
        metrics["frequency_order_dt"] = c["observed_order"]
        metrics["frequency_time_error_vs_rule_closed_form_max"] = max(
            abs(r["time_rel_error"] / r["time_rel_error_theory"] - 1) for r in bars_dt)
        metrics["bar_energy_drift_rel_max"] = max(r["energy_drift_rel"] for r in bars_h + bars_dt)
        tables["bar_h"], tables["bar_dt"] = bars_h, bars_dt

        tic = time.perf_counter()
        cases = {"kelvin_voigt_creep": ("kelvin_voigt", "creep", 1), "sls_creep": ("sls", "creep", 2),
                 "sls_relaxation": ("sls", "relaxation", None)}
        for name, (model, test, order) in cases.items():
            res = [vd.creep(model, test, dt) for dt in p["creep_dt"]]
            tables[name] = [{k: v for k, v in r.items() if k not in ("t", "num", "exact")} for r in res]
            metrics[f"{name}_rel_error"] = res[-1]["max_rel_error"]
            if order is not None:
                c = convergence_entry(f"{name}_max_rel_error_vs_dt", p["creep_dt"], [0] * len(res),
                                      [r["max_rel_error"] for r in res], order)
                convergence.append(c)
                metrics[f"{name}_order_dt"] = c["observed_order"]
        metrics["creep_rel_error"] = max(metrics["kelvin_voigt_creep_rel_error"], metrics["sls_creep_rel_error"],
                                         metrics["sls_relaxation_rel_error"])
        timing["creep_s"] = time.perf_counter() - tic

        tic = time.perf_counter()
        impacts = [vd.block_impact(n) for n in p["impact_n"]]
        consistent = vd.block_impact(16, mass="consistent", redistribute=False)
        timing["impact_s"] = time.perf_counter() - tic
        c = convergence_entry("impact_contact_duration_rel_error_vs_h", [r["h"] for r in impacts],
                              [r["ndof"] for r in impacts], [r["duration_rel_error"] for r in impacts], 1)
        convergence.append(c)
        metrics["impact_energy_gain_rel"] = max(r["energy_gain_rel"] for r in impacts)
        metrics["impact_energy_loss_rel_max"] = max(abs(r["energy_loss_rel"]) for r in impacts)
        metrics["impact_duration_rel_error"] = impacts[-1]["duration_rel_error"]
        metrics["impact_node_switches_max"] = max(r["node_switches_max"] for r in impacts)
        metrics["impact_status_switches_max"] = max(r["status_switches"] for r in impacts)
        metrics["impact_rebound_velocity_rel"] = impacts[-1]["rebound_velocity_rel"]
        metrics["impact_pressure_mean_rel"] = impacts[-1]["pressure_mean"] / impacts[-1]["pressure_exact"]
        metrics["impact_max_penetration_m"] = max(r["max_penetration"] for r in impacts)
        metrics["impact_consistent_mass_node_switches_max"] = consistent["node_switches_max"]
        metrics["impact_consistent_mass_energy_loss_rel"] = consistent["energy_loss_rel"]
        tables["impact"] = [{k: v for k, v in r.items() if k not in ("energy", "t")} for r in impacts]
        tables["impact_consistent"] = {k: v for k, v in consistent.items() if k not in ("energy", "t")}
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing}
    return result, tables


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1, 2 finer); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
