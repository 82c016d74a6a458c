"""Mesh convergence, uniform against adaptive refinement (the (2.35)-(2.36) checks): error against dofs and wall
time for a heat problem with a re-entrant corner, for Hertz contact and for the Stefan front, and the
effectivity indices of the a posteriori estimators.

Physics. (1) Effectivity indices eta / ||e|| (energy norm) of the Zienkiewicz-Zhu recovery estimator ("zz") and
the explicit residual estimator ("residual", :mod:`ngs_geomech.adapt.estimators`) on the manufactured steady
two-region anisotropic heat solution (:mod:`ngs_geomech.verification.manufactured`, glued, kappa
[[2, .5], [.5, 1]] / [[1, -.3], [-.3, 3]] W/(m K)) and the two-region anisotropic plane-strain thermo-elastic
solution (:mod:`ngs_geomech.verification.thermoelastic`), P1 and P2, h = 0.2, 0.1, 0.05 m. For P2 the ZZ estimator
uses the superconvergent patch recovery (the averaging recovery underestimates for P2 on unstructured meshes).
(2) The re-entrant corner: Laplace on the L-shaped domain (-1, 1)^2 minus [0, 1] x [-1, 0] with
T = r^(2/3) sin(2 theta/3) (exact energy error by Galerkin orthogonality), P1 from maxh = 0.5: uniform refinement
(every element bisected) against the adaptive loop (Doerfler theta = 0.5) with each estimator; orders fitted in
dofs over the meshes with at least 4x the start dofs (optimal P1: 1/2; the singularity limits uniform meshes to
1/3). (3) Hertz line contact (:func:`ngs_geomech.verification.contact_problems.hertz`, P1, frictionless, quarter
cylinder R = 1 m on a rigid flat, a = R/50), from a start mesh with h = a/2 on the contact arc: uniform refinement
against the adaptive loop (ZZ stress recovery + the contact-zone indicator, Doerfler 0.5; the forms and contact
operators rebuilt and the mesh curved again after every refinement, the contact solver warm-started from the last
active set). Errors: p0 (nodal pressure on the axis) against a reference p0 from a finer adaptive run (the closed
form is a half space's, from which the finite cylinder differs by a fixed amount that no refinement removes; the
error against the closed form is reported too), and the half width against the closed form (a node-position
quantity that jumps between steps: the headline ratios use p0). (4) The Neumann two-phase Stefan strip
(:mod:`ngs_geomech.verification.stefan`, t = 0.05 -> 0.5 s): uniform meshes (dt = 0.2 h) against front-following
meshes (the strip as a scene with ``[adaptivity] indicators = ['phase_front']``,
:func:`ngs_geomech.verification.stefan_adaptive.neumann_adaptive`: remeshed from a 0.05 m base with the size
0.05 / 2^levels at the front, a step repeated on the new mesh whenever the front reaches coarser elements, the
enthalpy carried over by the lumped projection; started from the nodal values of the exact temperature; dt = 0.2
h_fine); error of the front from the melted volume.

Ratios: the first adaptive step whose error is at most the finest uniform mesh's: its dofs over the finest
uniform mesh's dofs (``*_dof_ratio_adaptive_vs_uniform``), and the adaptive run's cumulative wall time to that
step (every solve on the coarser meshes, estimates, refinements) over ONE solve on the finest uniform mesh
(``*_time_ratio_adaptive_vs_uniform``). Targets, reported: <= 1/5 of the dofs, <= 1/3 of the wall time;
effectivity indices within [0.5, 3]. On small meshes the fixed costs of each adaptive solve (forms, contact
operators built in Python, netgen remeshing) weigh more, so the time ratios improve with the level.

Command: ``python studies/mesh_convergence/run.py --level 0 --out out/mesh_convergence`` (writes
``results.json``; prints the tables). One NGSolve thread. Levels: 0 the corner to ~12k adaptive dofs, Hertz
adaptive to 20k dofs, Stefan h to 0.0125; 1 the corner to ~180k dofs, Hertz uniform to 123k, Stefan h to 0.003125.

Cost on one thread: level 0 about 11 s, level 1 about 2-3 minutes.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ngs_geomech.verification import adaptivity as ad
from ngs_geomech.verification import stefan as sst
from ngs_geomech.verification import stefan_adaptive as sad
from ngs_geomech.verification.study import (
    convergence_entry,
    convergence_tables,
    metrics_lines,
    one_ngsolve_thread,
    study_cli,
    study_main,
)

STUDY = "mesh_convergence"
LEVELS = {
    0: {"hs": (0.2, 0.1, 0.05), "corner_uniform": 5, "corner_dofs": 12000, "hertz_uniform": 5,
        "hertz_dofs": 20000, "hertz_reference": 60000, "stefan_uniform": (0.025, 0.0125), "stefan_levels": (1, 2)},
    1: {"hs": (0.2, 0.1, 0.05, 0.025), "corner_uniform": 7, "corner_dofs": 200000, "hertz_uniform": 6,
        "hertz_dofs": 100000, "hertz_reference": 250000, "stefan_uniform": (0.025, 0.0125, 0.00625, 0.003125),
        "stefan_levels": (2, 3, 4)},
    2: {"hs": (0.2, 0.1, 0.05, 0.025, 0.0125), "corner_uniform": 8, "corner_dofs": 500000, "hertz_uniform": 7,
        "hertz_dofs": 250000, "hertz_reference": 600000,
        "stefan_uniform": (0.025, 0.0125, 0.00625, 0.003125, 0.0015625), "stefan_levels": (2, 3, 4, 5)},
}
STEFAN_BASE_H = 0.05
"""The Stefan front runs: the base mesh size (m) of the front-following meshes; fine size 0.05 / 2^levels;
dt = 0.2 x the finest size (uniform: 0.2 h); remeshed when the front is about to leave the refined band."""
"""Per level: manufactured mesh sizes (m), corner uniform levels and adaptive dof budget, Hertz uniform levels,
adaptive dof budget and the reference run's dof budget. Level 2 has not been run yet (Hertz uniform to ~490k
dofs: expect several minutes)."""
HERTZ_OPTIONS = {"contact_zone": {"active": True}}


def _h(ndofs) -> list[float]:
    """The equivalent mesh size dofs^(-1/2) (2D), so that a convergence entry's order in h is twice that in dofs."""
    return [d ** -0.5 for d in ndofs]


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw series (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {}
    with one_ngsolve_thread():
        # (1) effectivity indices on the manufactured solutions
        tic = time.perf_counter()
        eff = {order: ad.effectivities(order, p["hs"]) for order in (1, 2)}
        timing["effectivity_s"] = time.perf_counter() - tic
        values = {}
        for order, res in eff.items():
            for physics, r in res.items():
                for name in ("zz", "residual"):
                    values[(order, physics, name)] = r[name]
                    metrics[f"effectivity_{physics}_p{order}_{name}_finest"] = r[name][-1]
        allv = [v for vs in values.values() for v in vs]
        p1 = [v for (o, _, _), vs in values.items() if o == 1 for v in vs]
        metrics["effectivity_min"] = min(allv)
        metrics["effectivity_max"] = max(allv)
        metrics["effectivity_min_p1"] = min(p1)
        metrics["effectivity_max_p1"] = max(p1)
        metrics["effectivity_target_met"] = float(all(0.5 <= v <= 3.0 for v in allv))
        tables["effectivity"] = eff

        # (2) re-entrant corner
        tic = time.perf_counter()
        corner = {e: ad.corner_convergence(estimator=e, uniform_levels=p["corner_uniform"], max_dofs=p["corner_dofs"])
                  for e in ("zz", "residual")}
        timing["corner_s"] = time.perf_counter() - tic
        for e, r in corner.items():
            for kind in ("uniform", "adaptive"):
                s = r[kind]
                if kind == "adaptive" or e == "zz":
                    convergence.append(convergence_entry(
                        f"corner_energy_error_P1_{kind}" + (f"_{e}" if kind == "adaptive" else ""),
                        _h(s["ndof"]), s["ndof"], s["error"], 1.0 if kind == "adaptive" else 2 / 3,
                        wall_s=s["wall_s"], estimate=s["estimate"]))
            metrics[f"corner_observed_order_adaptive_{e}"] = r["order_adaptive"]
            effs = r["adaptive"]["effectivity"] + r["uniform"]["effectivity"]
            metrics[f"corner_effectivity_min_{e}"] = min(effs)
            metrics[f"corner_effectivity_max_{e}"] = max(effs)
            hit = ad.reach_ratios(r["uniform"], r["adaptive"], "error")
            metrics[f"corner_dof_ratio_adaptive_vs_uniform_{e}"] = hit["dof_ratio"]
            metrics[f"corner_time_ratio_adaptive_vs_uniform_{e}"] = hit["time_ratio"]
        metrics["corner_observed_order_adaptive"] = corner["zz"]["order_adaptive"]
        metrics["corner_observed_order_uniform"] = corner["zz"]["order_uniform"]
        tables["corner"] = corner

        # (3) Hertz contact
        tic = time.perf_counter()
        hz = ad.hertz_convergence(order=1, h_contact_over_a=0.5, uniform_levels=p["hertz_uniform"],
                                  max_dofs=p["hertz_dofs"], reference_dofs=p["hertz_reference"], options=HERTZ_OPTIONS)
        timing["hertz_s"] = time.perf_counter() - tic
        for kind in ("uniform", "adaptive"):
            s = hz[kind]
            convergence.append(convergence_entry(f"hertz_p0_error_vs_reference_P1_{kind}", _h(s["ndof"]), s["ndof"],
                                                 s["p0_ref_error"], None, wall_s=s["wall_s"], solve_s=s["solve_s"]))
            convergence.append(convergence_entry(f"hertz_half_width_error_P1_{kind}", _h(s["ndof"]), s["ndof"],
                                                 s["a_error"], None))
        hit = ad.reach_ratios(hz["uniform"], hz["adaptive"], "p0_ref_error")
        metrics["hertz_dof_ratio_adaptive_vs_uniform"] = hit["dof_ratio"]
        metrics["hertz_time_ratio_adaptive_vs_uniform"] = hit["time_ratio"]
        half = ad.reach_ratios(hz["uniform"], hz["adaptive"], "a_error")
        metrics["hertz_half_width_dof_ratio_adaptive_vs_uniform"] = half["dof_ratio"]
        metrics["hertz_half_width_time_ratio_adaptive_vs_uniform"] = half["time_ratio"]
        metrics["hertz_p0_error_finest_uniform"] = hz["uniform"]["p0_ref_error"][-1]
        metrics["hertz_p0_error_finest_adaptive"] = hz["adaptive"]["p0_ref_error"][-1]
        metrics["hertz_reference_p0_vs_closed_form"] = hz["p0_ref"] / hz["p0"] - 1
        metrics["hertz_adaptive_contact_iterations_max_warm"] = max(hz["adaptive"]["iterations"][1:])
        tables["hertz"] = hz
        tables["hertz_reach"] = {"p0": hit, "half_width": half}

        # (4) the Neumann Stefan front: uniform meshes against front-following meshes
        tic = time.perf_counter()
        stefan = _stefan(p)
        timing["stefan_s"] = time.perf_counter() - tic
        tables["stefan"] = stefan
        metrics.update(stefan["metrics"])
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": {k: float(v) for k, v in metrics.items()
                                                          if isinstance(v, (int, float)) and math.isfinite(v)},
              "convergence": convergence, "timing_s": timing,
              "stefan": {k: tables["stefan"][k] for k in ("uniform", "adaptive")}}
    return result, tables


def _stefan(p: dict) -> dict:
    """Uniform strips (h, dt = 0.2 h) against front-following meshes (base 0.05 m, ``levels``, dt = 0.2 h_fine):
    front error (melted volume), unknowns (adaptive: mean over the steps), wall time; the first adaptive run whose
    error is at most the finest uniform one gives the dof and time ratios."""
    problem = sst.TWO_PHASE
    t0, t1 = 0.05, 0.5
    uni = [sad.neumann_uniform(problem, h, 0.2 * h, t0, t1) for h in p["stefan_uniform"]]
    ada = []
    for lev in p["stefan_levels"]:
        hf = STEFAN_BASE_H / 2 ** lev
        ada.append(sad.neumann_adaptive(problem, STEFAN_BASE_H, lev, 0.2 * hf, t0, t1, layers=2 * lev + 2,
                                        remesh_every=0))
    fin = uni[-1]
    hit = next((a for a in ada if a["front_rel_error"] <= fin["front_rel_error"]), None)
    m = {"stefan_front_error_finest_uniform": fin["front_rel_error"],
         "stefan_front_error_finest_adaptive": ada[-1]["front_rel_error"],
         "stefan_transfer_error_max": max(a["transfer_error_max"] for a in ada),
         "stefan_energy_imbalance_adaptive_max": max(a["energy_imbalance_rel"] for a in ada)}
    if hit is not None:
        m["stefan_dof_ratio_adaptive_vs_uniform"] = hit["ndof_mean"] / fin["ndof"]
        m["stefan_time_ratio_adaptive_vs_uniform"] = hit["wall_s"] / fin["wall_s"]
    return {"uniform": uni, "adaptive": ada, "metrics": m}


def _stefan_lines(st_tables: dict) -> list[str]:
    lines = ["", "Neumann two-phase front (relative error of the melted-volume front at t = 0.5 s)",
             f"{'mesh':>28} {'dofs':>8} {'front err':>10} {'wall s':>8} {'Newton':>6} {'remeshes':>8}"]
    for u in st_tables["uniform"]:
        lines.append(f"{'uniform h = ' + format(u['h'], 'g'):>28} {u['ndof']:8d} {u['front_rel_error']:10.2e} "
                     f"{u['wall_s']:8.2f} {u['newton_mean']:6.2f} {'':>8}")
    for a in st_tables["adaptive"]:
        lines.append(f"{'front, ' + str(a['levels']) + ' levels, h_min ' + format(a['h_min'], '.2g'):>28} "
                     f"{a['ndof_mean']:8.0f} {a['front_rel_error']:10.2e} {a['wall_s']:8.2f} {a['newton_mean']:6.2f} "
                     f"{a['remeshes']:8d}")
    return lines


def report(result: dict) -> str:
    """The convergence tables (h = dofs^-1/2), the metrics and the timings."""
    return "\n".join([f"study {result['study']}, level {result['level']} (h = dofs^-1/2: orders in h are twice "
                      "those in dofs)"] + convergence_tables(result, "dofs^-1/2")
                     + (_stefan_lines(result["stefan"]) if "stefan" in result else []) + metrics_lines(result, 56))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1, 2 finer); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
