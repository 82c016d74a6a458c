"""Convergence of the nonlinear elastic solvers of seed problem (P): the secant modules method (2.32)-(2.34)
with the quantity (2.35), and Newton on the energy of the lambda law (2.1)-(2.5).

Physics. Plane strain, E = 10 GPa, nu = 0.25, reference strain 1e-3, regularization delta = 1e-6, P1.
(1) A quarter of a plate with a hole (1 m x 1 m quarter, hole radius 0.3 m, symmetry on x = 0 and y = 0)
stretched by u_x = 3 mm on x = 1 m, lam = 0.5, 0.75, 1.5, 2, on a sequence of meshes: Newton (primal-dual
tangent for lam < 1, energy line search) and the secant modules method (energy line search along
u~_{n+1} - u_n), both from the linear elastic solution with tolerance 1e-8 on
||u_{n+1} - u_n||_1 / ||u_{n+1}||_1 (2.35): iteration counts and wall times side by side, the (2.35)
sequence per iteration at each h, the observed contraction rate against the theory |1 - lam|/lam, the H1
difference of the two solutions; also the plain secant iteration (relaxation 1, rate bound 2|1 - lam|: it
diverges for lam >= 1.5) and Newton with the exact Hessian. The secant method at lam = 0.5 contracts slowly
and is run on the coarse meshes only. (1b) Nested iteration at lam = 0.5 (``mechanics.nested_levels``): scene
runs of the plate at each h with Newton started from the solutions on the meshes 2, 4, ... times coarser down
to h = 0.2 m, against the same scene from the linear solution; ``newton_iterations_max_with_nested_at_lam0p5``
is the most Newton steps for lam in [0.5, 2] with nested iteration at lam = 0.5. (2) Uniaxial strain bar
(displacement- and traction-driven) against the closed forms, lam = 0.5, 1, 2, both methods. (3) The
regularization delta = 1e-2 ... 1e-10 for lam = 0.5 and 0.3 on one mesh: change of the solution (H1, reaction
force, local stress) and iterations.

Headline metrics ``secant_iterations`` and ``newton_iterations`` (and their wall times, the contraction
rate): lam = 0.75 on the finest mesh, tolerance 1e-8; per-lam metrics carry a ``_lam<value>`` suffix.

Command: ``python studies/secant_convergence/run.py --level 0 --out out/secant_convergence``
(writes ``results.json``; prints the tables). Levels: 0 h = 0.1, 0.05 (secant at lam = 0.5 and the delta study
on h = 0.1); 1 down to h = 0.0125 (13k dofs; secant at lam = 0.5 on h = 0.1, 0.05; delta study on h = 0.025);
2 h = 0.05 ... 0.00625 (53k dofs).

Cost on one NGSolve thread: level 0 about 12 s, level 1 about 3-4 minutes, level 2 well over 10 minutes.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ngs_geomech import api
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.verification import nonlinear_law as nl
from ngs_geomech.verification.study import convergence_entry, metrics_lines, one_ngsolve_thread, study_cli, study_main

STUDY = "secant_convergence"
LEVELS = {
    0: {"hs": (0.1, 0.05), "half_secant_hs": (0.1,), "reg_h": 0.1},
    1: {"hs": (0.1, 0.05, 0.025, 0.0125), "half_secant_hs": (0.1, 0.05), "reg_h": 0.025},
    2: {"hs": (0.05, 0.025, 0.0125, 0.00625), "half_secant_hs": (0.05, 0.025), "reg_h": 0.0125},
}
"""Per level: mesh sizes (m) of the plate, those of the (slow) secant runs at lam = 0.5, and the mesh size
of the regularization study."""
LAMS = (0.5, 0.75, 1.5, 2.0)
LAM = 0.75
"""The exponents of the plate runs, and the one of the headline metrics."""
TOL = 1e-8
NESTED_COARSEST = 0.2
"""The coarsest mesh size (m) of the nested iteration at lam = 1/2 (section 1b)."""
PLAIN_MAXIT = 60
"""Iteration limit of the plain secant iteration (enough to see it converge at lam = 0.75, in 24)."""
UNIAXIAL_LAMS = (0.5, 1.0, 2.0)
REG_LAMS = (0.5, 0.3)
DEFAULT_DELTA = 1e-6


def _tag(lam: float) -> str:
    return f"lam{lam:g}".replace(".", "p")


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw dicts of the verification functions (for the report), on one
    NGSolve thread (restored afterwards): the wall times compare the solvers, and idle worker threads spin,
    which makes these small problems several times slower on a shared machine."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    with one_ngsolve_thread():
        return _run(level)


def _run(level: int) -> tuple[dict, dict]:
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {"plate": {}, "uniaxial": {}, "regularization": {}}

    # (1) plate with a hole: secant versus Newton on a sequence of meshes
    for lam in LAMS:
        tag = _tag(lam)
        tic = time.perf_counter()
        if lam == 0.5:
            r = nl.secant_vs_newton(lam, p["hs"], TOL, methods=("newton", "newton_exact_hessian"))
            half = nl.secant_vs_newton(lam, p["half_secant_hs"], TOL, methods=("newton", "secant"), maxit=5000)
            tables["plate"][(lam, "secant")] = half
        else:
            methods = ("newton", "secant", "secant_plain") + (("newton_exact_hessian",) if lam < 1 else ())
            r = nl.secant_vs_newton(lam, p["hs"], TOL, methods=methods, variant_maxit=PLAIN_MAXIT)
            half = r
        tables["plate"][lam] = r
        timing[f"plate_{tag}_s"] = time.perf_counter() - tic
        hs, dofs = r["h"], r["ndof"]
        n = r["newton"]
        convergence.append(convergence_entry(f"newton_iterations_vs_h_{tag}", hs, dofs, n["iterations"], 0,
                                  wall_s=n["wall_s"], changes=n["changes"], residuals=n["residuals"],
                                  steps=n["steps"], tolerance=TOL))
        metrics[f"newton_iterations_{tag}"] = n["iterations"][-1]
        metrics[f"newton_wall_s_{tag}"] = n["wall_s"][-1]
        if "newton_exact_hessian" in r:
            ex = r["newton_exact_hessian"]
            convergence.append(convergence_entry(f"newton_exact_hessian_iterations_vs_h_{tag}", hs, dofs,
                                                 ex["iterations"], 0,
                                      converged=ex["converged"], wall_s=ex["wall_s"], changes=ex["changes"]))
            metrics[f"newton_exact_hessian_iterations_{tag}"] = ex["iterations"][-1]
        s = half["secant"]
        sh, sd = half["h"], half["ndof"]
        if len(sh) >= 2:
            convergence.append(convergence_entry(f"secant_iterations_vs_h_{tag}", sh, sd, s["iterations"], 0,
                                      converged=s["converged"], wall_s=s["wall_s"], rate=s["rate"],
                                      rate_theory=half["rate_optimal_relaxation"], changes=s["changes"],
                                      steps=s["steps"], tolerance=TOL))
            convergence.append(convergence_entry(f"secant_newton_difference_h1_{tag}", sh, sd, half["difference_h1"], 0,
                                      note="||u_newton - u_secant||_1 / ||u_newton||_1: tolerance level, no order "
                                           "in h", reaction_newton=half["reaction_newton"],
                                      reaction_secant=half["reaction_secant"]))
        else:
            tables["plate"][(lam, "secant_changes")] = s["changes"]
        suffix = "" if len(sh) == len(hs) else f"_h{sh[-1]:g}".replace(".", "p")
        if all(s["converged"]):
            metrics[f"secant_iterations_{tag}{suffix}"] = s["iterations"][-1]
            metrics[f"secant_wall_s_{tag}{suffix}"] = s["wall_s"][-1]
            metrics[f"secant_newton_difference_h1_{tag}{suffix}"] = half["difference_h1"][-1]
            if math.isfinite(s["rate"][-1]):
                metrics[f"secant_contraction_rate_{tag}{suffix}"] = s["rate"][-1]
        metrics[f"secant_converged_{tag}{suffix}"] = float(all(s["converged"]))
        metrics[f"secant_contraction_rate_theory_{tag}"] = r["rate_optimal_relaxation"]
        if "secant_plain" in r:
            pl = r["secant_plain"]
            convergence.append(convergence_entry(f"secant_plain_iterations_vs_h_{tag}", hs, dofs, pl["iterations"], 0,
                                      converged=pl["converged"], rate=pl["rate"],
                                      rate_bound=r["rate_bound_plain"], changes=pl["changes"],
                                      iteration_limit=PLAIN_MAXIT))
            metrics[f"secant_plain_converged_{tag}"] = float(all(pl["converged"]))
            if all(pl["converged"]):
                metrics[f"secant_plain_iterations_{tag}"] = pl["iterations"][-1]
                if math.isfinite(pl["rate"][-1]):
                    metrics[f"secant_plain_contraction_rate_{tag}"] = pl["rate"][-1]
    # (1b) nested iteration (mechanics.nested_levels) at lam = 1/2: Newton on each mesh h started from the solutions
    # on the meshes 2, 4, ... times coarser down to h = 0.2 m; scene runs (mesh, forms, solves), cold vs nested
    tic = time.perf_counter()
    nested = {"h": [], "ndof": [], "iterations": [], "coarse_iterations": [], "wall_s": [], "cold_iterations": [],
              "cold_wall_s": [], "difference_h1": []}
    for h in p["hs"]:
        levels = round(math.log2(NESTED_COARSEST / h))
        res = {}
        for lv in (0, levels):
            d = nl.plate_scene(0.5, h, tol=TOL)
            d["mechanics"]["nested_levels"] = lv
            t0 = time.perf_counter()
            res[lv] = (api.run(scene_from_dict(d), None, progress=False), time.perf_counter() - t0)
        (cold, cold_s), (nest, nest_s) = res[0], res[levels]
        m = nest.summary["mechanics"]
        nested["h"].append(h)
        nested["ndof"].append(nest.summary["mesh"]["dofs"])
        nested["iterations"].append(m["iterations"][0])
        nested["coarse_iterations"].append([c["iterations"] for c in m["nested_iteration"][0]])
        nested["wall_s"].append(nest_s)
        nested["cold_iterations"].append(cold.summary["mechanics"]["iterations"][0])
        nested["cold_wall_s"].append(cold_s)
        nested["difference_h1"].append(nl._rel_diff(cold.mechanics.forms.displacement(),
                                                    nest.mechanics.forms.displacement(), cold.mechanics.forms.mesh))
    tables["nested"] = nested
    timing["nested_s"] = time.perf_counter() - tic
    metrics["newton_nested_iterations_lam0p5"] = nested["iterations"][-1]
    metrics["newton_nested_iterations_max_lam0p5"] = max(max(nested["iterations"]),
                                                        max(max(c) for c in nested["coarse_iterations"]))
    metrics["newton_nested_wall_ratio_lam0p5"] = nested["wall_s"][-1] / nested["cold_wall_s"][-1]
    metrics["newton_nested_difference_h1_lam0p5"] = max(nested["difference_h1"])
    convergence.append(convergence_entry("newton_nested_iterations_vs_h_lam0p5", nested["h"], nested["ndof"],
                                         nested["iterations"], 0, coarse_iterations=nested["coarse_iterations"],
                                         wall_s=nested["wall_s"], cold_iterations=nested["cold_iterations"],
                                         cold_wall_s=nested["cold_wall_s"]))

    main_r = tables["plate"][LAM]
    metrics["secant_iterations"] = main_r["secant"]["iterations"][-1]
    metrics["newton_iterations"] = main_r["newton"]["iterations"][-1]
    metrics["secant_wall_s"] = main_r["secant"]["wall_s"][-1]
    metrics["newton_wall_s"] = main_r["newton"]["wall_s"][-1]
    metrics["secant_contraction_rate"] = main_r["secant"]["rate"][-1]
    metrics["secant_contraction_rate_theory"] = main_r["rate_optimal_relaxation"]
    metrics["secant_newton_difference_h1"] = main_r["difference_h1"][-1]
    metrics["secant_plain_iterations"] = main_r["secant_plain"]["iterations"][-1]
    metrics["secant_plain_contraction_rate"] = main_r["secant_plain"]["rate"][-1]
    metrics["newton_iterations_max"] = max(max(tables["plate"][lam]["newton"]["iterations"]) for lam in LAMS)
    metrics["newton_iterations_max_lam0p75_to_2"] = max(max(tables["plate"][lam]["newton"]["iterations"])
                                                        for lam in LAMS if lam >= 0.75)
    metrics["newton_iterations_max_with_nested_at_lam0p5"] = max(metrics["newton_iterations_max_lam0p75_to_2"],
                                                                 metrics["newton_nested_iterations_max_lam0p5"])
    metrics["plate_ndof_finest"] = main_r["ndof"][-1]

    # (2) uniaxial strain against the closed forms
    tic = time.perf_counter()
    worst = 0.0
    for lam in UNIAXIAL_LAMS:
        for method in ("newton", "secant"):
            u = nl.uniaxial_strain_test(lam, method)
            tables["uniaxial"][(lam, method)] = u
            worst = max(worst, u["max_rel_error"])
            metrics[f"uniaxial_max_rel_error_{_tag(lam)}_{method}"] = u["max_rel_error"]
            metrics[f"uniaxial_iterations_max_{_tag(lam)}_{method}"] = u["iterations_max"]
    metrics["uniaxial_max_rel_error"] = worst
    timing["uniaxial_s"] = time.perf_counter() - tic

    # (3) the regularization delta
    for lam in REG_LAMS:
        tic = time.perf_counter()
        g = nl.regularization_effect(lam, h=p["reg_h"], secant=lam < 0.5, exact_hessian=lam >= 0.5)
        tables["regularization"][lam] = g
        timing[f"regularization_{_tag(lam)}_s"] = time.perf_counter() - tic
        tag = _tag(lam)
        rows = g["rows"]
        default = next(row for row in rows if row["delta"] == DEFAULT_DELTA)
        metrics[f"regularization_rel_h1_at_default_delta_{tag}"] = default["rel_h1_to_smallest"]
        metrics[f"regularization_reaction_rel_change_at_default_delta_{tag}"] = default["reaction_rel_change"]
        metrics[f"regularization_newton_iterations_default_delta_{tag}"] = default["newton_iterations"]
        metrics[f"regularization_newton_iterations_smallest_delta_{tag}"] = rows[-1]["newton_iterations"]
        if "newton_exact_hessian_iterations" in default:
            metrics[f"regularization_newton_exact_hessian_iterations_default_delta_{tag}"] = \
                default["newton_exact_hessian_iterations"]
            metrics[f"regularization_newton_exact_hessian_iterations_smallest_delta_{tag}"] = \
                rows[-1]["newton_exact_hessian_iterations"]
        deltas = [row["delta"] for row in rows[:-1]]
        dofs = [g["ndof"]] * len(deltas)
        convergence.append(convergence_entry(f"regularization_rel_h1_to_smallest_delta_{tag}", deltas, dofs,
                                  [row["rel_h1_to_smallest"] for row in rows[:-1]], 0.5 if lam == 0.5 else None,
                                  note="'h' holds delta; the smallest delta is the reference", rows=rows,
                                  mesh_h=p["reg_h"]))

    metrics = {k: float(v) for k, v in metrics.items() if isinstance(v, (int, float)) and math.isfinite(v)}
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing}
    return result, tables


def report(result: dict) -> str:
    """A plain-text report of a result dict: iterations and times side by side, the (2.35) sequences, the
    regularization tables and the metrics."""
    conv = {c["quantity"]: c for c in result["convergence"]}
    m = result["metrics"]
    lines = [f"study {result['study']}, level {result['level']}", "",
             f"plate with a hole, tolerance {TOL:g} on ||u_(n+1) - u_n||_1 / ||u_(n+1)||_1 (2.35)",
             f"{'lam':>5} {'h':>7} {'dofs':>6} {'Newton':>6} {'t (s)':>6} {'secant':>6} {'t (s)':>6} "
             f"{'rate':>6} {'theory':>6} {'plain':>6} {'||uN-uS||_1':>11}"]
    for lam in LAMS:
        tag = _tag(lam)
        n = conv[f"newton_iterations_vs_h_{tag}"]
        s = conv.get(f"secant_iterations_vs_h_{tag}")
        d = conv.get(f"secant_newton_difference_h1_{tag}")
        pl = conv.get(f"secant_plain_iterations_vs_h_{tag}")
        for k, h in enumerate(n["h"]):
            sec = f"{'-':>6} {'-':>6} {'-':>6}"
            dif = f"{'-':>11}"
            if s is not None and k < len(s["h"]):
                rate = s["rate"][k]
                sec = (f"{int(s['errors'][k]):6d} {s['wall_s'][k]:6.2f} "
                       + (f"{rate:6.3f}" if rate is not None else f"{'-':>6}"))
                dif = f"{d['errors'][k]:11.2e}"
            plain = "-"
            if pl is not None:
                plain = str(int(pl["errors"][k])) if pl["converged"][k] else "no"
            lines.append(f"{lam:5.2f} {h:7.4f} {n['dofs'][k]:6d} {int(n['errors'][k]):6d} {n['wall_s'][k]:6.2f} "
                         f"{sec} {abs(1 - lam) / lam:6.3f} {plain:>6} {dif}")
        ex = conv.get(f"newton_exact_hessian_iterations_vs_h_{tag}")
        if ex is not None:
            lines.append(f"      Newton with the exact Hessian: {[int(v) for v in ex['errors']]} iterations")
        if s is None:
            key = f"secant_iterations_{tag}_h"
            hits = {k: v for k, v in m.items() if k.startswith(key)}
            for k, v in hits.items():
                lines.append(f"      secant at {k[len('secant_iterations_' + tag) + 1:]}: {int(v)} iterations, rate "
                             f"{m.get(k.replace('iterations', 'contraction_rate'), math.nan):.4f}, "
                             f"||uN-uS||_1 = {m.get(k.replace('iterations', 'newton_difference_h1'), math.nan):.2e}")
    for lam in LAMS:
        s = conv.get(f"secant_iterations_vs_h_{_tag(lam)}")
        if s is None:
            continue
        lines.append("")
        lines.append(f"(2.35) per secant iteration, lam = {lam:g}:")
        for h, ch in zip(s["h"], s["changes"]):
            lines.append(f"  h = {h:<7g} " + " ".join(f"{c:.1e}" for c in ch))
    for lam in REG_LAMS:
        c = conv[f"regularization_rel_h1_to_smallest_delta_{_tag(lam)}"]
        lines.append("")
        lines.append(f"regularization delta, lam = {lam:g} (h = {c['mesh_h']:g}, {c['dofs'][0]} dofs)")
        lines.append(f"{'delta':>7} {'Newton':>6} {'exact H':>7} {'secant':>6} {'dH1':>9} {'reaction N/m':>13} "
                     f"{'d react':>8} {'rigid':>6}")
        for row in c["rows"]:
            lines.append(f"{row['delta']:7.0e} {row['newton_iterations']:6d} "
                         f"{row.get('newton_exact_hessian_iterations', '-')!s:>7} "
                         f"{row.get('secant_iterations', '-')!s:>6} {row['rel_h1_to_smallest']:9.2e} "
                         f"{row['reaction']:13.6e} {row['reaction_rel_change']:8.1e} {row['rigid_fraction']:6.3f}")
    return "\n".join(lines + metrics_lines(result, width=60))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1, 2 finer); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
