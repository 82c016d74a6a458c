"""The contact part of studies/scaling: the Newton steps of the frictional contact solver by GMRES
with the augmented-Lagrangian AMG preconditioner (:mod:`ngs_geomech.contact.krylov`) against the direct
factorizations, on the 3D punch of :func:`ngs_geomech.verification.contact_problems.punch_3d` (Coulomb F_c = 0.3,
pushed at 0.7 of the capacity: stick and slip zones; the punch held by the contact alone), P1 and P2, h halved.

Per size: dofs, Newton (active-set) steps, the GMRES iterations of every Newton-step solve (max and mean over the
solves that do work; a floating body adds one short refinement solve per step), the contact solve's wall time
iterative and direct (one NGSolve thread), and the largest relative difference of u, lam_n, lam_t between the two.
Run from run.py; also ``python studies/scaling/contact.py LEVEL``."""

from __future__ import annotations

import sys
import time

import numpy as np

from ngs_geomech.verification.contact_problems import punch_3d
from ngs_geomech.verification.study import one_ngsolve_thread

CONTACT_LEVELS = {
    0: ((1, 0.2, True),),
    1: ((1, 0.2, True), (1, 0.1, True), (1, 0.05, True), (2, 0.2, True), (2, 0.1, True)),
    2: ((1, 0.2, True), (1, 0.1, True), (1, 0.05, True), (1, 0.025, False), (2, 0.2, True), (2, 0.1, True),
        (2, 0.05, False)),
}
"""(order, h, also solved directly) per level."""


def _rel(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b))) / max(float(np.linalg.norm(b)), 1e-300)


def run_contact(level: int) -> dict:
    rows = []
    with one_ngsolve_thread():
        for order, h, with_direct in CONTACT_LEVELS[level]:
            tic = time.perf_counter()
            it = punch_3d(h, order, law="coulomb", linear="iterative")
            work = [g for g in it["gmres"] if g > 0]
            row = {"order": order, "h": h, "dofs": it["ndof"], "nodes": it["nodes"], "newton": it["iterations"],
                   "gmres": it["gmres"], "gmres_max": max(work), "gmres_mean": float(np.mean(work)),
                   "iterative_s": it["wall_s"], "stick": it["stick"], "slip": it["slip"],
                   "force_balance": max(it["force_balance_n"], it["force_balance_t"]),
                   "direct_s": None, "newton_direct": None, "max_rel_difference": None}
            if with_direct:
                d = punch_3d(h, order, law="coulomb")
                row.update(direct_s=d["wall_s"], newton_direct=d["iterations"],
                           max_rel_difference=max(_rel(it[k], d[k]) for k in ("u", "lam_n", "lam_t")),
                           same_sets=(d["stick"], d["slip"]) == (it["stick"], it["slip"]))
            row["case_s"] = time.perf_counter() - tic
            rows.append(row)
    metrics = {}
    for order in sorted({r["order"] for r in rows}):
        rs = [r for r in rows if r["order"] == order]
        metrics[f"contact_gmres_max_p{order}"] = float(max(r["gmres_max"] for r in rs))
        if len(rs) >= 2:
            metrics[f"contact_gmres_max_ratio_finest_coarsest_p{order}"] = rs[-1]["gmres_max"] / rs[0]["gmres_max"]
        both = [r for r in rs if r["direct_s"]]
        if both:
            metrics[f"contact_direct_over_iterative_time_p{order}"] = both[-1]["direct_s"] / both[-1]["iterative_s"]
    diffs = [r["max_rel_difference"] for r in rows if r["max_rel_difference"] is not None]
    if diffs:
        metrics["contact_max_rel_difference"] = max(diffs)
    metrics["contact_largest_dofs"] = float(max(r["dofs"] for r in rows))
    return {"rows": rows, "metrics": metrics}


def contact_table(contact: dict) -> list[str]:
    lines = ["", "Contact Newton steps (3D punch, Coulomb): GMRES (augmented-Lagrangian AMG) vs direct, 1 thread",
             f"{'P':>2} {'h':>6} {'dofs':>8} {'nodes':>6} {'stick/slip':>10} {'Newton':>6} {'gmres max':>9} "
             f"{'mean':>6} {'iter s':>8} {'direct s':>9} {'Newton d':>8} {'max rel diff':>12}"]
    for r in contact["rows"]:
        d = f"{r['direct_s']:9.2f}" if r["direct_s"] is not None else f"{'-':>9}"
        nd = f"{r['newton_direct']:8d}" if r["newton_direct"] is not None else f"{'-':>8}"
        diff = f"{r['max_rel_difference']:12.1e}" if r["max_rel_difference"] is not None else f"{'-':>12}"
        lines.append(f"{r['order']:2d} {r['h']:6.3f} {r['dofs']:8d} {r['nodes']:6d} "
                     f"{str(r['stick']) + '/' + str(r['slip']):>10} {r['newton']:6d} {r['gmres_max']:9d} "
                     f"{r['gmres_mean']:6.1f} {r['iterative_s']:8.2f} {d} {nd} {diff}")
    return lines


if __name__ == "__main__":
    res = run_contact(int(sys.argv[1]) if len(sys.argv) > 1 else 0)
    print("\n".join(contact_table(res)))
    for k, v in res["metrics"].items():
        print(f"{k} = {v:.4g}")
