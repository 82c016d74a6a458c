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

Cost on 2 cores (one NGSolve thread, measured with the process start): level 0 1.5 s, level 1 2.3 s, level 2 3.4 s.

Measured (level 0, 2 cores, one thread):

    bar, h = L/4, L/8, L/16 (dt = T/1000): frequency rel. error 5.81e-3, 1.52e-3, 3.88e-4: order 1.95 (P1, 2)
    bar, h = L/16, dt = T/10, T/20, T/40: time rel. error 3.11e-2, 8.11e-3, 2.05e-3: order 1.96 (2), equal to the
        closed form of the rule tan(Omega dt/2) = omega_h dt/2 to 1e-9; energy drift over a period 8e-13
    Kelvin-Voigt creep + recovery, dt = 0.1, 0.05, 0.025 tau: max rel. error 2.27e-2, 1.16e-2, 5.86e-3: order 0.98
        (backward Euler, 1)
    SLS creep, same dt: 5.39e-5, 1.35e-5, 3.37e-6: order 2.00 (exponential branch rule after the jump at t = 0)
    SLS relaxation: 4e-15 (the exponential rule is exact for a constant strain)
    impact, h = L/8, L/16, L/32 (dt = h/c): energy gain 1.5e-14, 1.6e-14, 8.5e-14 (relative, round-off; also no
        loss: the contact starts at g = 0, stays closed, and opens with lam = 0); duration error 1/16, 1/32, 1/64
        (one step late: 2n + 1 steps instead of 2n); 2 status switches per node (closes once, opens once);
        penetration < 1e-20 m
    impact with the consistent mass (h = L/16): 4 switches on one node (chattering), 0.33 % of the energy lost;
        lumped without redistribution: 6 switches on a node, 2.6 % lost.

Level 2 (h down to L/64 for the bar, L/128 for the impact, dt down to tau/160): frequency error 2.17e-5 (order
2.01 in h, 1.98 in dt), Kelvin-Voigt 1.48e-3 (0.99), SLS creep 2.1e-7 (2.00), impact energy gain 9.8e-13 (round-off
growing with the number of steps), duration 2n + 1 or 2n + 2 steps (errors 1/16, 1/32, 1/64, 1/64, 1/128: order
0.70 fitted, one or two steps late), rebound 0.985 v0, mean contact pressure 0.985 rho c v0.

What falls short: the rebound velocity of the column is 0.932, 0.951, 0.966, 0.977 v0 for h = L/8 ... L/64 (order
about 0.5: the dispersion of the P1 / Newmark wave leaves part of the energy as vibration of the released column;
the closed form is a perfect rebound); the mean contact pressure is 0.91 ... 0.97 rho c v0 for the same reason. The
contact duration converges with order 1 (one step, not better: the release is detected at step ends). The energy
statement holds for rho_inf = 1; generalized-alpha with rho_inf < 1 dissipates (3 % at rho_inf = 0.5 in the impact)
but gains nothing here. Friction in the dynamic solver acts on the slip increment of the step.
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
