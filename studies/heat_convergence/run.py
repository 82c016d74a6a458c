"""Convergence of heat conduction: seed (2.17), (2.19)-(2.22) steady, (2.43) transient, Kirchhoff k(T).

Physics. (1) Manufactured steady solution on the unit square (m) split at x = 0.5 into two regions with full
anisotropic conductivity tensors [[2, .5], [.5, 1]] and [[1, -.3], [-.3, 3]] W/(m K), T and the normal flux
continuous across x = 0.5 (2.22), exact Dirichlet data (2.19): P1 and P2, with a glued interface (one
conforming mesh) and a contact interface (independent, non-matching meshes, mortar coupling); the right
region is meshed with 0.7 h in both cases. (2) Patch tests: piecewise polynomial solutions that P1/P2 must
reproduce exactly. (3) Transient manufactured solution (2.43) with time-dependent Dirichlet data, quadratic
in space so that P2 has no spatial error: backward Euler and Crank-Nicolson orders in dt. (4) Kirchhoff slab:
k(T) = k0 (1 + b T), b = 0.01 1/K, T from 0 to 100 K, closed form through Theta = T + b T^2 / 2 linear in x,
solved by Newton. (5) Decaying point source in an infinite medium (closed form, axisymmetric run through
run_scene), from :mod:`ngs_geomech.verification.point_source`. (6) Material data that vary
(:mod:`ngs_geomech.verification.varying_heat`): steady manufactured solutions on the unit square with kappa(x, y)
(erfc of x) and kappa(x, y, T) (Newton), P1 and P2; a transient one with kappa(x, y, T) and rho c(x, T), backward
Euler and Crank-Nicolson (P2), with the observed order of Newton's convergence per step (2: the tangent holds
d kappa/dT and d(rho c)/dT).

Command: ``python studies/heat_convergence/run.py --level 0 --out out/heat_convergence``
(writes ``results.json``; prints the tables).

Cost on one NGSolve thread: level 0 about 30 s, most of it the point source run; level 1 (one more
refinement in h and dt) about 80 s; level 2 (h down to 1/80, P2 up to ~60k dofs; point source 43k dofs, 552
steps) about 4 min.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ngs_geomech.verification import manufactured as mms
from ngs_geomech.verification import varying_heat
from ngs_geomech.verification.point_source import point_source_errors
from ngs_geomech.verification.study import (
    convergence_entry,
    report,
    study_cli,
    study_main,
)

STUDY = "heat_convergence"
LEVELS = {
    0: {"hs": (0.2, 0.1, 0.05), "dts": (0.2, 0.1, 0.05, 0.025), "slab_hs": (0.1, 0.05, 0.025)},
    1: {"hs": (0.2, 0.1, 0.05, 0.025), "dts": (0.2, 0.1, 0.05, 0.025, 0.0125),
        "slab_hs": (0.1, 0.05, 0.025, 0.0125)},
    2: {"hs": (0.1, 0.05, 0.025, 0.0125), "dts": (0.1, 0.05, 0.025, 0.0125, 0.00625),
        "slab_hs": (0.05, 0.025, 0.0125, 0.00625)},
}
"""Mesh sizes (m) of the steady runs, time steps (s) of the transient runs, slab mesh sizes (m) per level."""
EXPECTED = {(1, "l2"): 2, (1, "h1"): 1, (2, "l2"): 3, (2, "h1"): 2}
"""Expected orders of smooth problems: h^(p+1) in L2, h^p in H1."""


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw dicts of the verification functions (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {"point_source": None}

    # steady manufactured solution, glued and contact
    tic = time.perf_counter()
    steady = {(o, it): mms.steady_convergence(o, p["hs"], it) for o in (1, 2) for it in ("glued", "contact")}
    timing["steady_s"] = time.perf_counter() - tic
    for (o, it), res in steady.items():
        suffix = "" if it == "glued" else "_contact"
        for norm in ("l2", "h1"):
            convergence.append(convergence_entry(f"temperature_{norm.upper()}_error_P{o}_{it}", res["h"], res["ndofs"],
                                      res[norm], EXPECTED[(o, norm)]))
            metrics[f"order_{norm}_p{o}{suffix}"] = res[f"order_{norm}"]
    ratios = {o: max(c / g for norm in ("l2", "h1")
                     for c, g in zip(steady[(o, "contact")][norm], steady[(o, "glued")][norm])) for o in (1, 2)}
    metrics["contact_over_glued_error_ratio_max"] = max(ratios.values())
    metrics["contact_over_glued_error_ratio_max_p1"] = ratios[1]
    metrics["contact_over_glued_error_ratio_max_p2"] = ratios[2]
    tables["steady"] = steady

    # patch tests (exact reproduction of piecewise polynomials)
    tic = time.perf_counter()
    patches = [mms.patch_test(o, it) for o in (1, 2) for it in ("glued", "contact")]
    timing["patch_s"] = time.perf_counter() - tic
    for r in patches:
        metrics[f"patch_test_h1_error_p{r['order']}_{r['interface']}"] = r["h1"]
    tables["patch"] = patches

    # transient: orders in time (P2 represents the solution exactly in space)
    tic = time.perf_counter()
    transient = {(s, it): mms.transient_convergence(s, p["dts"], interface=it)
                 for s in ("backward_euler", "crank_nicolson") for it in ("glued", "contact")}
    timing["transient_s"] = time.perf_counter() - tic
    for (s, it), res in transient.items():
        convergence.append(convergence_entry(f"temperature_L2_error_at_t_end_vs_dt_{s}_{it}", res["dt"], res["ndofs"],
                                  res["l2"], 1 if s == "backward_euler" else 2))
        metrics[f"order_time_{s}" + ("" if it == "glued" else "_contact")] = res["order"]
    tables["transient"] = transient

    # Kirchhoff slab, k(T) = k0 (1 + b T)
    tic = time.perf_counter()
    slabs = {o: mms.kirchhoff_slab(o, p["slab_hs"]) for o in (1, 2)}
    timing["kirchhoff_s"] = time.perf_counter() - tic
    for o, res in slabs.items():
        convergence.append(convergence_entry(f"kirchhoff_slab_L2_error_P{o}", res["h"], res["ndofs"], res["l2"], o + 1))
        convergence.append(convergence_entry(f"kirchhoff_slab_max_error_on_mid_line_P{o}", res["h"], res["ndofs"],
                                  res["max_sampled"], o + 1))
        convergence.append(convergence_entry(f"kirchhoff_slab_max_nodal_error_P{o}", res["h"], res["ndofs"],
                                  res["max_nodal"], o + 1))
        metrics[f"kirchhoff_order_l2_p{o}"] = res["order_l2"]
        metrics[f"kirchhoff_max_nodal_error_p{o}"] = res["max_nodal"][-1]
    metrics["kirchhoff_newton_iterations_max"] = max(max(r["newton_iterations"]) for r in slabs.values())
    metrics["kirchhoff_nonlinear_effect_K"] = slabs[1]["nonlinear_effect"]
    tables["kirchhoff"] = slabs

    # decaying point source (closed form)
    tic = time.perf_counter()
    ps = point_source_errors(level)
    timing["point_source_s"] = time.perf_counter() - tic
    metrics["point_source_max_rel_error"] = float(ps["max_rel_error"])
    for key, value in ps.items():
        if key not in ("max_rel_error", "level") and isinstance(value, (int, float)) \
                and not isinstance(value, bool) and math.isfinite(value):
            metrics[f"point_source_{key}"] = float(value)
    tables["point_source"] = ps

    tables["varying"] = varying(p, metrics, convergence, timing)
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing}
    return result, tables


def varying(p: dict, metrics: dict, convergence: list, timing: dict) -> dict:
    """Part (6): material data that vary in space and with T; fills ``metrics``, ``convergence``, ``timing``."""
    tic = time.perf_counter()
    steady = {(o, law): varying_heat.steady_convergence(o, p["hs"], law) for o in (1, 2) for law in ("x", "xT")}
    for (o, law), res in steady.items():
        for norm in ("l2", "h1"):
            convergence.append(convergence_entry(f"temperature_{norm.upper()}_error_P{o}_kappa_{law}", res["h"],
                                                 res["ndofs"], res[norm], EXPECTED[(o, norm)]))
            metrics[f"varying_order_{norm}_p{o}_kappa_{law}"] = res[f"order_{norm}"]
    metrics["varying_newton_iterations_max_steady"] = max(max(r["newton_iterations"]) for r in steady.values())
    transient = {s: varying_heat.transient_convergence(s, p["dts"]) for s in ("backward_euler", "crank_nicolson")}
    for s, res in transient.items():
        convergence.append(convergence_entry(f"temperature_L2_error_at_t_end_vs_dt_{s}_kappa_T_rho_c_T", res["dt"],
                                             res["ndofs"], res["l2"], 1 if s == "backward_euler" else 2))
        metrics[f"varying_order_time_{s}"] = res["order"]
        metrics[f"varying_newton_order_min_{s}"] = res["newton_order_min"]
        metrics[f"varying_newton_iterations_max_{s}"] = res["iterations_max"]
    timing["varying_s"] = time.perf_counter() - tic
    return {"steady": steady, "transient": transient}


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1, 2 finer); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
