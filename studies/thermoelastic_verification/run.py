"""Verification of thermo-elasticity: seed problem (P) (2.17)-(2.22) without contact, law (2.18)/(2.37), (2.38).

Physics. (1) Thick-walled cylinder a = 1 < r < b = 2 m with free surfaces, steady temperature from the thermal
solve (100 K at r = a, 0 at r = b, stress free at 0), E = 70 GPa, nu = 0.25, alpha = 8e-6 1/K, P2, against the
closed forms (:mod:`ngs_geomech.verification.thermoelastic`): a plane strain quarter ring with symmetry conditions
on its straight edges, an axisymmetric section 0 < z < 0.5 m with u_z = 0 on both ends (plane strain), and an
axisymmetric free-ended cylinder 0 < z < 12 m (symmetry at z = 0) compared at z <= 1 m with the generalized plane
strain closed form. Error: max over sample radii of |sigma_h - sigma| per component (r, theta, z), divided by max
|sigma_theta| = 45.7 MPa. (2) Manufactured plane strain thermo-elasticity on the unit square split at x = 0.5 into
an orthotropic (rotated) and a fully anisotropic region with anisotropic thermal expansion tensors, displacement
and traction continuous across x = 0.5, temperature from the thermal solve of a manufactured T (same elements),
exact body force (ElasticSetup.body_force) and Dirichlet data: L2/H1 orders of P1 and P2. (3) Near
incompressibility: plane strain manufactured u = curl psi + (mu/lambda) grad phi at nu = 0.3 and 0.4999, P1 and P2:
relative errors of u (L2, H1) and of the stress; with the displacement formulation P1 locks (and P2's stress is
poor), with the mixed displacement-pressure formulation (Taylor-Hood P2-P1, stabilized P1-P1; ``formulation =
"mixed"``, what "auto" picks at nu > 0.45) the errors at nu = 0.4999 are close to the compressible ones, with
optimal orders. (4) Varying data (:mod:`ngs_geomech.verification.varying_elastic`): manufactured thermo-elasticity with
E(x, y, T), nu(x, y), alpha(x, y), T0(x) and rho(x, y) under gravity, given as expressions in the scene, plane strain
on the unit square and axisymmetric on [0.5, 1.5] x [0, 1]: L2/H1/stress orders of P1 and P2.

Command: ``python studies/thermoelastic_verification/run.py --level 0 --out out/thermoelastic_verification``
(writes ``results.json``; prints the tables).

Cost on one NGSolve thread: level 0 (manufactured, varying-data and near-incompressibility runs to h = 0.05) about
40 s;
level 1 (cylinders down to h = 0.025, manufactured and near incompressibility to h = 0.0125) about a minute;
level 2 (cylinders to h = 0.0125, free ends 1.07M dofs; manufactured and near incompressibility to
h = 0.00625, 240k dofs) about 5 min.
"""

from __future__ import annotations

import time
from pathlib import Path

from ngs_geomech.verification import thermoelastic as te
from ngs_geomech.verification import varying_elastic as ve
from ngs_geomech.verification.study import (
    convergence_entry,
    report,
    study_cli,
    study_main,
)

STUDY = "thermoelastic_verification"
LEVELS = {
    0: {"cylinder": 0, "hs": (0.2, 0.1, 0.05), "ni_hs": (0.2, 0.1, 0.05)},
    1: {"cylinder": 1, "hs": (0.2, 0.1, 0.05, 0.025, 0.0125), "ni_hs": (0.2, 0.1, 0.05, 0.025, 0.0125)},
    2: {"cylinder": 2, "hs": (0.1, 0.05, 0.025, 0.0125, 0.00625), "ni_hs": (0.1, 0.05, 0.025, 0.0125, 0.00625)},
}
"""Per level: the cylinder level (mesh sizes in te.CYLINDER_LEVELS), mesh sizes (m) of the manufactured and
near-incompressibility runs."""
EXPECTED = {(1, "l2"): 2, (1, "h1"): 1, (1, "stress"): 1, (2, "l2"): 3, (2, "h1"): 2, (2, "stress"): 2}
"""Expected orders of smooth, compressible problems: h^(p+1) in L2, h^p in H1 and in the stress."""
NUS = (0.3, 0.4999)
VARYING_MODELS = ("plane_strain", "axisymmetric")


def _nu_tag(nu: float) -> str:
    return f"nu{nu:g}".replace(".", "")


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw dicts of the verification functions."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {}

    # (1) thick-walled cylinder against the closed forms
    tic = time.perf_counter()
    cyl = {case: te.cylinder(case, p["cylinder"]) for case in te.CYLINDER_CASES}
    timing["cylinder_s"] = time.perf_counter() - tic
    for case, res in cyl.items():
        metrics[f"cylinder_max_rel_error_{case}"] = res["max_rel_error"]
        for comp, v in res["errors"].items():
            metrics[f"cylinder_{comp}_rel_error_{case}"] = v
        metrics[f"cylinder_order_max_error_{case}"] = res["order_max_error"]
        convergence.append(convergence_entry(f"cylinder_{case}_max_stress_error_over_max_sigma_theta_P2", res["h"],
                                  res["dofs"], res["max_rel_errors"], 2))
    tables["cylinder"] = cyl

    # (2) manufactured thermo-elasticity, two anisotropic regions
    tic = time.perf_counter()
    mms = {o: te.manufactured(o, p["hs"]) for o in (1, 2)}
    timing["manufactured_s"] = time.perf_counter() - tic
    for o, res in mms.items():
        for norm, name in (("l2", "displacement_L2"), ("h1", "displacement_H1"), ("stress", "stress_L2")):
            convergence.append(convergence_entry(f"manufactured_{name}_error_P{o}", res["h"], res["dofs"], res[norm],
                                      EXPECTED[(o, norm)]))
            metrics[f"order_{norm}_p{o}"] = res[f"order_{norm}"]
        convergence.append(convergence_entry(f"manufactured_temperature_L2_error_P{o}", res["h"], res["dofs"],
                                  res["thermal_l2"], o + 1))
    jumps = mms[2]["interface_jumps"]
    metrics["manufactured_traction_jump_rel"] = jumps["traction_jump"] / jumps["traction_max"]
    tables["manufactured"] = mms

    # (3) near incompressibility
    tic = time.perf_counter()
    ni = {(nu, o): te.near_incompressible(nu, o, p["ni_hs"], "displacement") for nu in NUS for o in (1, 2)}
    mixed = {o: te.near_incompressible(0.4999, o, p["ni_hs"], "mixed") for o in (1, 2)}
    timing["near_incompressible_s"] = time.perf_counter() - tic
    for (nu, o), res in ni.items():
        tag = _nu_tag(nu)
        for norm, name in (("l2", "displacement_L2"), ("h1", "displacement_H1"), ("stress", "stress_L2")):
            convergence.append(convergence_entry(f"near_incompressible_{tag}_{name}_rel_error_P{o}", res["h"],
                                                 res["dofs"],
                                      res[f"{norm}_rel"], EXPECTED[(o, norm)]))
            metrics[f"near_incompressible_{tag}_{norm}_rel_error_p{o}"] = res[f"{norm}_rel"][-1]
            metrics[f"near_incompressible_{tag}_order_{norm}_p{o}"] = res[f"order_{norm}"]
    for o in (1, 2):
        metrics[f"near_incompressible_h1_error_ratio_p{o}"] = (ni[(0.4999, o)]["h1_rel"][-1]
                                                               / ni[(0.3, o)]["h1_rel"][-1])
    metrics["near_incompressible_h1_error_p2_over_p1_nu04999"] = (ni[(0.4999, 2)]["h1_rel"][-1]
                                                                  / ni[(0.4999, 1)]["h1_rel"][-1])
    for o, res in mixed.items():
        for norm, name in (("l2", "displacement_L2"), ("h1", "displacement_H1"), ("stress", "stress_L2")):
            convergence.append(convergence_entry(f"near_incompressible_mixed_nu04999_{name}_rel_error_P{o}", res["h"],
                                                 res["dofs"], res[f"{norm}_rel"], EXPECTED[(o, norm)]))
            metrics[f"near_incompressible_mixed_nu04999_{norm}_rel_error_p{o}"] = res[f"{norm}_rel"][-1]
            metrics[f"near_incompressible_mixed_nu04999_order_{norm}_p{o}"] = res[f"order_{norm}"]
        metrics[f"near_incompressible_mixed_h1_error_ratio_p{o}"] = res["h1_rel"][-1] / ni[(0.3, o)]["h1_rel"][-1]
    tables["near_incompressible"] = ni
    tables["near_incompressible_mixed"] = mixed

    # (4) manufactured thermo-elasticity with varying data (expressions of x, y and T)
    tic = time.perf_counter()
    tables["varying"] = varying_data(p["hs"], metrics, convergence)
    timing["varying_s"] = time.perf_counter() - tic

    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing}
    return result, tables


def varying_data(hs, metrics: dict, convergence: list) -> dict:
    """Part (4): the manufactured solution with varying data per model and order; appends its convergence entries
    and metrics (orders, relative errors at the finest h) and returns the raw results."""
    out = {}
    for model in VARYING_MODELS:
        for o in (1, 2):
            res = out[f"{model}_p{o}"] = ve.convergence(model, o, hs)
            for norm, name in (("l2", "displacement_L2"), ("h1", "displacement_H1"), ("stress", "stress_L2")):
                convergence.append(convergence_entry(f"varying_{model}_{name}_error_P{o}", res["h"], res["dofs"],
                                                     res[norm], EXPECTED[(o, norm)]))
                metrics[f"varying_{model}_order_{norm}_p{o}"] = res[f"order_{norm}"]
                metrics[f"varying_{model}_{norm}_rel_error_p{o}"] = res[f"{norm}_rel"][-1]
    return out


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1, 2 finer); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
