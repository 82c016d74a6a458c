"""Contact on distributed meshes against serial, the cost of a distributed Newton step against dofs, memory per
rank, and the distributed elasticity solve against the serial one.

1. Agreement (every level): the stacked boxes of :mod:`ngs_geomech.verification.distributed_contact` (3D; the
   upper box held by the contact alone; frictionless, Tresca and Coulomb, pushed sideways within the friction
   capacity) solved serially and by ``mpiexec -n 3`` and ``-n 5`` (2 and 4 workers; netgen keeps no elements on
   rank 0): ``max_rel_difference_vs_serial`` is the largest relative difference of the displacement probes, the
   nodal contact pressures and tractions (matched by coordinates) and the contact forces over all runs;
   ``newton_iterations_<ranks>`` the Newton (active-set) iterations summed over the laws, per rank count (1:
   serial), and ``newton_iterations_equal`` 1 when every run took the serial run's iterations.
2. Cost against dofs (every level): the Coulomb case on 2 workers at several mesh sizes: wall time per Newton
   step, its parts (PETSc set-up and GMRES: distributed work; reductions and gathers of replicated arrays), the
   values communicated per step, and ``newton_step_time_exponent``, the slope of log(time per step) against
   log(dofs). ``peak_rss_gib_per_rank_*``: the largest run's peak memory per rank.
3. Elasticity (level 1: the scaling box at maxh 0.04, 171k heat + 513k elastic dofs, the issue's "685k"; level 0:
   maxh 0.15): ``studies/scaling/worker.py`` serially (the two-level AMG, one thread) against
   ``studies/scaling/mpi_box.py`` on 3 ranks (PETSc's GAMG): ``elastic_speedup_2_workers`` = serial elastic time /
   distributed elastic time (assembly, set-up and solve), with both runs' CG iterations.

The machine has 2 cores: 3 ranks are 2 workers and a sleeping rank 0; 5 ranks oversubscribe the cores (their
agreement counts, their times do not). Without petsc4py or mpiexec the study records ``petsc_available`` = 0 and
the serial figures only.

Command: ``python studies/distributed_contact/run.py --level 1 --out docs/results/distributed_contact``.
Cost: level 0 about 60 s; level 1 about 10 minutes.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ngs_geomech.linalg.petsc import available as petsc_available
from ngs_geomech.parallel import launch_environment
from ngs_geomech.verification.distributed_contact import LAWS, case_result, differences, stack_scene
from ngs_geomech.verification.study import study_cli, study_main

HERE = Path(__file__).resolve().parent
SCALING = HERE.parent / "scaling"
LEVELS = {0: {"ranks": (3, 5), "orders": (1,), "maxh": 0.3, "cost_maxh": (0.3, 0.15), "elastic_maxh": 0.15},
          1: {"ranks": (3, 5), "orders": (1, 2), "maxh": 0.2, "cost_maxh": (0.3, 0.2, 0.14, 0.1, 0.07),
              "elastic_maxh": 0.04}}
"""Per level: rank counts, element orders, the agreement runs' mesh size (m; P2 at 1.4 x), the cost runs' sizes
and the elasticity box's maxh."""


def _mpiexec() -> str | None:
    found = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or shutil.which("mpiexec")
    return found if found and petsc_available() else None


def _distributed(law: str, maxh: float, order: int, ranks: int, tmp: Path) -> dict:
    out = tmp / f"{law}_{maxh}_{order}_{ranks}.json"
    cmd = [_mpiexec(), "-n", str(ranks), sys.executable, "-m", "ngs_geomech.verification.distributed_contact", law,
           str(maxh), str(order), str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=3600, env=launch_environment())
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return json.loads(out.read_text())


def agreement(p: dict, tmp: Path) -> tuple[dict, list]:
    """Part 1: the serial and distributed runs of every law, order and rank count."""
    rows, metrics = [], {"max_rel_difference_vs_serial": 0.0, "newton_iterations_equal": 1}
    iterations: dict[int, int] = {}
    for order in p["orders"]:
        maxh = p["maxh"] * (1.4 if order == 2 else 1.0)
        for law in LAWS:
            want = case_result(stack_scene(law, maxh, order))
            iterations[1] = iterations.get(1, 0) + sum(want["contact"]["iterations_per_solve"])
            for ranks in p["ranks"] if _mpiexec() else ():
                got = _distributed(law, maxh, order, ranks, tmp)
                d = differences(got, want)
                iterations[ranks] = iterations.get(ranks, 0) + sum(got["contact"]["iterations_per_solve"])
                metrics["max_rel_difference_vs_serial"] = max(metrics["max_rel_difference_vs_serial"], d["max"])
                metrics["newton_iterations_equal"] &= int(d["same_iterations"] and d["same_states"])
                rows.append({"law": law, "order": order, "ranks": ranks, "dofs": got["dofs"], **d,
                             "newton_iterations": got["contact"]["iterations_per_solve"],
                             "serial_newton_iterations": want["contact"]["iterations_per_solve"],
                             "peak_rss_gib_per_rank": got["peak_rss_gib_per_rank"]})
    metrics.update({f"newton_iterations_{r}": v for r, v in iterations.items()})
    return metrics, rows


def cost(p: dict, tmp: Path) -> tuple[dict, list]:
    """Part 2: the Coulomb case on 2 workers at the cost sizes: time per Newton step and its parts."""
    rows = []
    for maxh in p["cost_maxh"]:
        r = _distributed("coulomb", maxh, 1, 3, tmp)
        c = r["contact"]
        steps = max(sum(c["iterations_per_solve"]), 1)
        comm = (c["communication_per_solve"] or [{}])[-1]
        rows.append({"maxh": maxh, "dofs": r["dofs"], "newton_steps": steps,
                     "step_s": sum(c["wall_s_per_solve"]) / steps,
                     "petsc_setup_s_per_step": comm.get("setup_s", 0.0) / steps,
                     "gmres_s_per_step": comm.get("gmres_s", 0.0) / steps,
                     "replicated_comm_s_per_step": (comm.get("reduce_s", 0.0) + comm.get("gather_s", 0.0)) / steps,
                     "values_per_step": (comm.get("reduced_values", 0) + comm.get("gathered_values", 0)) / steps,
                     "peak_rss_gib_per_rank": r["peak_rss_gib_per_rank"], "wall_s": r["wall_s"]})
    metrics = {}
    if len(rows) >= 2:
        x = np.log([r["dofs"] for r in rows])
        y = np.log([r["step_s"] for r in rows])
        metrics["newton_step_time_exponent"] = float(np.polyfit(x, y, 1)[0])
        last = rows[-1]
        metrics.update({"cost_dofs_largest": last["dofs"], "newton_step_s_largest": last["step_s"],
                        "distributed_share_largest": (last["petsc_setup_s_per_step"] + last["gmres_s_per_step"])
                        / last["step_s"],
                        "replicated_comm_share_largest": last["replicated_comm_s_per_step"] / last["step_s"],
                        "values_per_step_per_dof": last["values_per_step"] / last["dofs"],
                        "peak_rss_gib_per_rank_worker_max": max(last["peak_rss_gib_per_rank"][1:]),
                        "peak_rss_gib_rank0": last["peak_rss_gib_per_rank"][0]})
        # the projection (docs/parallel.md): distributed share f at p = 2 -> c_d / c_r = 2 f / (1 - f)
        f = min(metrics["distributed_share_largest"], 0.999)
        metrics["projected_speedup_limit"] = 1.0 + 2.0 * f / (1.0 - f)
        metrics["projected_half_limit_workers"] = 2.0 * f / (1.0 - f)
        worker_rss = [max(r["peak_rss_gib_per_rank"][1:]) for r in rows]
        metrics["worker_rss_gib_per_million_dofs"] = float(np.polyfit([r["dofs"] / 1e6 for r in rows], worker_rss,
                                                                      1)[0])
    return metrics, rows


def elasticity(p: dict, tmp: Path) -> dict:
    """Part 3: the scaling box's elastic solve, serial two-level AMG (one thread) against GAMG on 2 workers."""
    h = p["elastic_maxh"]
    serial, dist = tmp / "serial.json", tmp / "mpi.json"
    subprocess.run([sys.executable, str(SCALING / "worker.py"), str(h), "2", "iterative", "1", str(serial)],
                   check=True, capture_output=True, timeout=3600)
    subprocess.run([_mpiexec(), "-n", "3", sys.executable, str(SCALING / "mpi_box.py"), str(h), "2", str(dist)],
                   check=True, capture_output=True, timeout=3600, env=launch_environment())
    s, d = json.loads(serial.read_text()), json.loads(dist.read_text())
    return {"elastic_dofs": s["dofs_elastic"], "heat_dofs": s["dofs_heat"],
            "elastic_serial_s": s["elastic_s"], "elastic_2_workers_s": d["elastic_s"],
            "elastic_speedup_2_workers": s["elastic_s"] / d["elastic_s"],
            "cg_elastic_serial": s["cg_elastic"][0], "cg_elastic_2_workers": d["cg_elastic"][0],
            "heat_speedup_2_workers": s["heat_s"] / d["heat_s"],
            "cg_heat_serial": s["cg_heat"][0], "cg_heat_2_workers": d["cg_heat"][0]}


def run(level: int) -> tuple[dict, dict]:
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        metrics, rows = agreement(p, tmp)
        metrics["petsc_available"] = int(_mpiexec() is not None)
        cost_rows = []
        if _mpiexec():
            m, cost_rows = cost(p, tmp)
            metrics.update(m)
            metrics.update(elasticity(p, tmp))
    metrics = {k: v for k, v in metrics.items() if isinstance(v, (int, float)) and math.isfinite(v)}
    result = {"study": "distributed_contact", "level": level, "metrics": metrics, "convergence": [],
              "timing_s": {}, "agreement": rows, "cost": cost_rows,
              "machine": "2 cores: 3 ranks = 2 workers and a sleeping rank 0; 5 ranks oversubscribe the cores"}
    return result, None


def report(result: dict) -> str:
    lines = [f"distributed_contact level {result['level']}"]
    lines += [f"  {k}: {v:.4g}" if isinstance(v, float) else f"  {k}: {v}" for k, v in result["metrics"].items()]
    for r in result["agreement"]:
        lines.append(f"  {r['law']} P{r['order']} {r['ranks']} ranks {r['dofs']} dofs: max diff {r['max']:.1e}, "
                     f"Newton {r['newton_iterations']} (serial {r['serial_newton_iterations']})")
    for r in result["cost"]:
        lines.append(f"  cost {r['dofs']} dofs: {r['step_s']:.3f} s per Newton step ({r['newton_steps']} steps), "
                     f"GMRES {r['gmres_s_per_step']:.3f} s, set-up {r['petsc_setup_s_per_step']:.3f} s, "
                     f"replicated communication {r['replicated_comm_s_per_step']:.4f} s")
    return "\n".join(lines)


def main(level: int = 0, out=None) -> dict:
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
