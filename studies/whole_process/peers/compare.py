"""Time ngs-geomech and Kratos Multiphysics as processes on twins of two small scenes of studies/whole_process.

Problems (both codes on the same triangles: the Kratos meshes are written from ngs-geomech's meshes by
:file:`make_meshes.py`):

- ``two_blocks``: :file:`../two_blocks.toml` (two elastic blocks, frictionless contact, plane strain, P1,
  328 displacement dofs) against :file:`kratos_two_blocks/` (StructuralMechanicsApplication with the mortar
  augmented-Lagrangian frictionless contact of ContactStructuralMechanicsApplication);
- ``heat_block``: :file:`../heat_block.toml` (steady conduction, P1, 305 dofs) against
  :file:`kratos_heat_block/` (ConvectionDiffusionApplication, stationary, LaplacianElement2D3N).

Each process is timed from launch to exit (reading the input, meshing for ngs-geomech, solving, writing the
VTK files and the summary), with one thread on both sides (``--threads 1`` and OMP_NUM_THREADS=1); the two
codes alternate within each of ``--repeats`` rounds and the best wall time of each is kept (and the best
CPU time, user + system, the steadier figure on a shared machine). Imports are timed the
same way (``python -c "import ngsolve"`` against ``python -c "import KratosMultiphysics"``). Each process runs
in a fresh temporary folder (the Kratos twin is copied there), so nothing is written beside this file except
``results.json`` when asked.

Command (from the repository root)::

    .venv/bin/python studies/whole_process/peers/compare.py \\
        --peers-python ~/peers-venv/bin/python [--repeats 5]

It prints the figures (``--out FILE``: also writes them as JSON). ``studies/whole_process/run.py --peers
PYTHON`` calls :func:`measure` and keeps the figures in the study's results (what the documentation quotes).
The agreement figures read our run's summary.json and VTK files (meshio, from the ngs-geomech environment) and
the twins' kratos_summary.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
PROBLEMS = {"two_blocks": HERE / "kratos_two_blocks", "heat_block": HERE / "kratos_heat_block"}
ONE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _cpu_children() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(cmd: list[str], cwd: Path, log: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system; s) of one process, launch to exit; its output goes to ``log``;
    a failure raises. The CPU time is the steadier figure on a machine shared with other work."""
    env = {**os.environ, **ONE_THREAD}
    with open(log, "w") as out:
        cpu, start = _cpu_children(), time.perf_counter()
        proc = subprocess.run(cmd, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT)
        wall, cpu = time.perf_counter() - start, _cpu_children() - cpu
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}); see {log}")
    return wall, cpu


def _ours_cmd(problem: str, out: Path) -> list[str]:
    scene = ROOT / "studies" / "whole_process" / f"{problem}.toml"
    return [sys.executable, "-m", "ngs_geomech", "run", str(scene), "--out", str(out), "--overwrite",
            "--threads", "1"]


def time_problem(problem: str, peers_python: str, repeats: int, work: Path) -> dict:
    """Best-of-``repeats`` process times of both codes on ``problem``, alternated; the last run's outputs are
    kept in ``work`` for the agreement figures."""
    ours, theirs = [], []
    for i in range(repeats):
        out = work / f"{problem}_ours"
        shutil.rmtree(out, ignore_errors=True)
        ours.append(_timed(_ours_cmd(problem, out), ROOT, work / f"{problem}_ours_{i}.log"))
        twin = work / f"{problem}_kratos"
        shutil.rmtree(twin, ignore_errors=True)
        shutil.copytree(PROBLEMS[problem], twin, ignore=shutil.ignore_patterns("vtk_output", "kratos_summary.json"))
        theirs.append(_timed([peers_python, "run_kratos.py"], twin, work / f"{problem}_kratos_{i}.log"))
    best = {"ours_process_s": min(w for w, _ in ours), "kratos_process_s": min(w for w, _ in theirs),
            "ours_process_cpu_s": min(c for _, c in ours), "kratos_process_cpu_s": min(c for _, c in theirs)}
    best["process_ratio_ours_over_kratos"] = best["ours_process_s"] / best["kratos_process_s"]
    phases = json.loads((work / f"{problem}_ours" / "summary.json").read_text())["wall_time_s"]
    return {**best, "ours_all_s": [w for w, _ in ours], "kratos_all_s": [w for w, _ in theirs],
            "ours_last_run_phases_s": phases}


def time_imports(peers_python: str, repeats: int, work: Path) -> dict:
    pairs = {"python_startup_s": [sys.executable, "-c", "pass"],
             "ngsolve_import_s": [sys.executable, "-c", "import ngsolve"],
             "kratos_import_s": [peers_python, "-c", "import KratosMultiphysics"],
             "kratos_contact_import_s": [peers_python, "-c",
                                         "import KratosMultiphysics.ContactStructuralMechanicsApplication"]}
    times = {key: [] for key in pairs}
    for i in range(repeats):
        for key, cmd in pairs.items():
            times[key].append(_timed(cmd, work, work / f"{key}_{i}.log"))
    best = {key: min(w for w, _ in t) for key, t in times.items()}
    best.update({key[:-2] + "_cpu_s": min(c for _, c in t) for key, t in times.items()})
    return best


def _joint_pressures(vtp: Path) -> dict:
    """x (m, rounded) -> contact pressure (Pa) from our joint's ASCII PolyData file."""
    arrays = {a.get("Name"): [float(v) for v in a.text.split()] for a in ET.parse(vtp).iter("DataArray")}
    return dict(zip((round(x, 9) for x in arrays["Points"][0::3]), arrays["pressure"]))


def contact_agreement(work: Path) -> dict:
    """Mean and nodal contact pressures, contact force and the largest vertical displacement of both runs."""
    import meshio

    ours_dir, twin = work / "two_blocks_ours", json.loads((work / "two_blocks_kratos" / "kratos_summary.json")
                                                           .read_text())
    joint = json.loads((ours_dir / "summary.json").read_text())["mechanics"]["contact"]["interfaces"]["joint"]
    uy = meshio.read(ours_dir / "two_blocks.vtu").point_data["displacement"][:, 1]
    ours_p = _joint_pressures(ours_dir / "two_blocks_contact_joint_step00000.vtp")
    nodal = [abs(ours_p[round(x, 9)] - p) / twin["mean_pressure_Pa"]
             for x, p in zip(twin["slave_nodes_x_m"], twin["slave_pressures_Pa"])]
    ours_mean = joint["normal_force"] / joint["closed_length_m"]
    ours_uy = float(abs(uy).max())
    return {"ours_mean_pressure_Pa": ours_mean, "kratos_mean_pressure_Pa": twin["mean_pressure_Pa"],
            "closed_form_mean_pressure_Pa": 5e6 * 0.6 / 0.6,
            "ours_max_pressure_Pa": joint["max_pressure_Pa"], "kratos_max_pressure_Pa": twin["max_pressure_Pa"],
            "ours_contact_force_N_per_m": joint["normal_force"],
            "kratos_contact_force_N_per_m": twin["contact_force_N_per_m"],
            "nodal_pressure_max_diff_rel": max(nodal), "contact_nodes": len(nodal),
            "ours_max_abs_uy_m": ours_uy, "kratos_max_abs_uy_m": twin["max_abs_displacement_y_m"],
            "max_abs_uy_diff_rel": abs(ours_uy - twin["max_abs_displacement_y_m"]) / ours_uy,
            "note": "our displacements are read from the VTU (float32): relative agreement below 1e-7 is "
                    "output precision"}


def heat_agreement(work: Path) -> dict:
    import meshio

    vtu = meshio.read(work / "heat_block_ours" / "heat_block.vtu")
    temp, x = vtu.point_data["temperature"], vtu.points[:, 0]
    twin = json.loads((work / "heat_block_kratos" / "kratos_summary.json").read_text())
    return {"ours_max_nodal_error_K": float(abs(temp - (80.0 - 70.0 * x)).max()),
            "kratos_max_nodal_error_K": twin["max_nodal_error_K"],
            "kratos_hot_side_heat_flow_W_per_m": twin["hot_side_heat_flow_W_per_m"],
            "closed_form_heat_flow_W_per_m": 3.0 * 70.0,
            "note": "closed form T = 80 - 70 x (in the P1 space: both codes exact up to round-off; ours read "
                    "from the VTU in float32)"}


def sizes(work: Path) -> dict:
    ours = {p: json.loads((work / f"{p}_ours" / "summary.json").read_text())["mesh"] for p in PROBLEMS}
    twin = {p: json.loads((work / f"{p}_kratos" / "kratos_summary.json").read_text()) for p in PROBLEMS}
    return {"two_blocks": {"nodes": ours["two_blocks"]["vertices"], "triangles": ours["two_blocks"]["elements"],
                           "displacement_dofs": ours["two_blocks"]["dofs"],
                           "kratos_nodes": twin["two_blocks"]["nodes"],
                           "kratos_lagrange_multiplier_dofs": len(twin["two_blocks"]["slave_nodes_x_m"])},
            "heat_block": {"nodes": ours["heat_block"]["vertices"], "triangles": ours["heat_block"]["elements"],
                           "dofs": ours["heat_block"]["dofs"], "kratos_nodes": twin["heat_block"]["nodes"]}}


def versions(peers_python: str) -> dict:
    import ngsolve

    code = ("import importlib.metadata as m, json; print(json.dumps({p: m.version(p) for p in ['KratosMultiphysics',"
            "'KratosStructuralMechanicsApplication','KratosContactStructuralMechanicsApplication',"
            "'KratosConvectionDiffusionApplication','KratosLinearSolversApplication']}))")
    kratos = json.loads(subprocess.run([peers_python, "-c", code], capture_output=True, text=True,
                                       check=True).stdout)
    return {"ngsolve": ngsolve.__version__, **kratos, "python": platform.python_version(),
            "cores": os.cpu_count()}


def measure(peers_python: str, repeats: int = 5) -> dict:
    """Every figure of results.json: imports, both problems' process times and agreement, sizes, versions."""
    with tempfile.TemporaryDirectory(prefix="peers_") as tmp:
        work = Path(tmp)
        result = {"imports": time_imports(peers_python, repeats, work)}
        for problem in PROBLEMS:
            result[problem] = time_problem(problem, peers_python, repeats, work)
        result["two_blocks"]["agreement"] = contact_agreement(work)
        result["heat_block"]["agreement"] = heat_agreement(work)
        result["sizes"] = sizes(work)
    result["versions"] = versions(peers_python)
    result["protocol"] = (f"best of {repeats} processes each, ngs-geomech and Kratos alternated in every round, "
                          "one thread on both sides (--threads 1, OMP_NUM_THREADS=1), on a 2-core machine shared "
                          "with other work")
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--peers-python", required=True, help="python of the environment with Kratos")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", default=None, help="also write the figures to this JSON file")
    args = parser.parse_args()
    result = measure(args.peers_python, args.repeats)
    if args.out is not None:
        Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
