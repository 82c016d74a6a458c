"""Speed where users wait, measured on whole runs as a user starts them: start-up, a small contact run as a
process, 3D VTK output against the solve, meshing's share of a fine 2D run, Stefan runs at large time steps, and
the threads a run takes.

Runs and figures (results.json ``metrics``; every time is the best of ``repeats`` runs, the compared variants
alternated within one run of the study, since the 2-core machine is shared and noisy):

1. Start-up. ``ngsolve_import_s``: the process ``python -c "import ngsolve"``. ``startup_s``: from launching
   ``python -m ngs_geomech run SCENE --out DIR -v`` to the moment the run reports its mesh and model built (the
   log line before the first solve), for the 305-dof steady heat block (:file:`heat_block.toml`);
   ``startup_ratio`` = startup_s / ngsolve_import_s. ``startup_contact_s`` and ``startup_contact_ratio`` the same
   for the 328-dof two-block contact scene (:file:`two_blocks.toml`: two elastic blocks pressed together,
   frictionless, the upper one held by the contact alone: the contact solvers and scipy.sparse load too).
   ``small_contact_process_s``: the whole two-block process (VTK and the contact series written, no figures);
   ``small_contact_process_with_figures_s`` the same with its figures.
2. ``vtk_to_solve_ratio_3d``: repository_3d at its quick level (the scene as shipped; level 0: its first
   30 days), figures off: the time spent writing the VTK series (``wall_time_s.output_s``) over the solves
   (``initial_s + solve_s``).
3. ``mesh_share_fine_2d``: the two-phase Neumann strip at h = 0.003125 m (37k dofs; level 0: h = 0.0125 m) as a
   scene on a structured mesh (:func:`ngs_geomech.verification.structured.strip_meshing_share`): mesh_s / total_s
   of the run; ``mesh_share_netgen_2d`` the same strip meshed by netgen (what every scene did before).
4. ``stefan_large_dt_ratio``: the strip at h = 0.00625 m (level 0: 0.0125 m) from t0 = 0.05 s to 0.5 s as a
   process: wall time at dt = 0.005 s over the wall time at dt = 0.000625 s, one NGSolve and one BLAS thread;
   ``stefan_front_rel_error_large_dt`` / ``..._small_dt`` the front (melted volume) against the closed form.
5. Threads (``threads`` table; level 1): built-in scenes of several sizes (repository_3d also at order 3) run with
   one NGSolve thread and with every core (BLAS at one thread in both, :mod:`ngs_geomech.linalg.threads`), on the
   machine as it is and with one other process keeping a core busy: ``threads_speedup_<run>`` = wall(1) /
   wall(cores), above 1 where the threads pay, ``threads_speedup_loaded_<run>`` the same under that load;
   ``default_threads_wall_s_{idle,loaded}_<code>``: contact_melting run with each code's default threads (no
   ``--threads``; before this study's changes: NGSolve's and OpenBLAS's defaults, every core).

Before and after: ``--baseline DIR`` (a source checkout of an earlier commit) runs the process figures of 1, 2 and 4
with that code too (``*_before``): the same scenes, the same machine, alternated with the current code.

An established code: ``--peers PYTHON`` (the interpreter of a separate environment with Kratos Multiphysics, set up
as :file:`peers/README.md` says) times Kratos on twins of the two small scenes on the same triangles
(:mod:`peers.compare`): ``peer_*`` metrics (process times of both codes alternated, their ratio, the agreement of
the contact pressures and the heat solution) and the whole comparison under ``peers``.

Command: ``python studies/whole_process/run.py --level 1 --out docs/results/whole_process [--baseline DIR]
[--peers PYTHON]``.
Cost: level 0 about 40 s; level 1 about 15 minutes (the 37k-dof strip twice, repository_3d, the threads table);
``--baseline`` adds about 3 minutes, ``--peers`` 20 s.
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ngs_geomech.linalg.threads import cores
from ngs_geomech.verification import stefan as st
from ngs_geomech.verification.stefan_steps import HEIGHT, T1, strip_step_scene
from ngs_geomech.verification.structured import strip_meshing_share
from ngs_geomech.verification.study import metrics_lines, study_main

STUDY = "whole_process"
HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

LEVELS = {
    0: {"repeats": 2, "repository_3d": ["time.end=30 day"], "strip_h": 0.0125, "stefan_h": 0.0125,
        "stefan_dts": (0.00125, 0.005), "threads": {},
        "default_threads": None},
    1: {"repeats": 5, "repository_3d": [], "strip_h": 0.003125, "stefan_h": 0.00625,
        "stefan_dts": (0.000625, 0.005),
        "threads": {"contact_melting": ["contact_melting"], "heated_rock": ["heated_rock"],
                    "repository_section": ["repository_section", "time.end=20 year"],
                    "repository_3d": ["repository_3d", "time.end=20 year", "output.every=1000"],
                    "repository_3d_p3": ["repository_3d", "mesh.order=3", "time.end=5 day", "output.every=1000"]},
        "default_threads": "contact_melting"},
}
"""Per level: repeats of the process runs, repository_3d's overrides, the strips' h (m) and steps (s), and the
scenes of the threads table with their overrides."""

LIMITS = {"startup_s": 0.8, "startup_ratio": 2.0, "small_contact_process_s": 1.0, "vtk_to_solve_ratio_3d": 0.5,
          "mesh_share_fine_2d": 0.2, "stefan_large_dt_ratio": 1.0}
"""The targets (recorded with the results, not asserted: benchmarks, not tests)."""

BUILT = re.compile(r"\d+ elements, \d+ vertices; mesh")
"""The run's log line (-v) once the mesh and the model are built: what comes next is the first solve."""


def _env(code: Path) -> dict:
    """The environment of a process running the package at ``code`` (also its working directory: ``python -m``
    and ``-c`` put the working directory first on the path)."""
    return {**os.environ, "PYTHONPATH": str(code)}


def _process(code: Path, args: list[str], out: Path) -> dict:
    """One ``python -m ngs_geomech run ARGS --out OUT -v`` with the package at ``code``: ``startup_s`` (to the
    line :data:`BUILT`), ``process_s`` (to the process's end) and the run's summary."""
    tic = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "ngs_geomech", "run", *args, "--out", str(out), "--overwrite",
                             "-v"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=_env(code),
                            cwd=code)
    built, lines = None, []
    for line in proc.stderr:
        lines.append(line)
        if built is None and BUILT.search(line):
            built = time.perf_counter() - tic
    if proc.wait() != 0 or built is None:
        raise RuntimeError(f"{args} with {code} failed or said no {BUILT.pattern!r}: {''.join(lines[-5:])}")
    wall = time.perf_counter() - tic
    return {"startup_s": built, "process_s": wall, "summary": json.loads((out / "summary.json").read_text())}


def _import_ngsolve() -> float:
    tic = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import ngsolve"], check=True)
    return time.perf_counter() - tic


def startup(codes: dict[str, Path], repeats: int, tmp: Path) -> dict:
    """Section 1 per code ("after", and "before" with a baseline): the best of ``repeats`` alternated runs."""
    best: dict[str, float] = {}

    def keep(key: str, value: float) -> None:
        best[key] = min(best.get(key, float("inf")), value)

    for _ in range(repeats):
        keep("ngsolve_import_s", _import_ngsolve())
        for tag, code in codes.items():
            heat = _process(code, [str(HERE / "heat_block.toml")], tmp / f"heat_{tag}")
            keep(f"startup_s_{tag}", heat["startup_s"])
            contact = _process(code, [str(HERE / "two_blocks.toml")], tmp / f"contact_{tag}")
            keep(f"startup_contact_s_{tag}", contact["startup_s"])
            keep(f"small_contact_process_s_{tag}", contact["process_s"])
            drawn = _process(code, [str(HERE / "two_blocks.toml"), "--set", "output.figures=true"],
                             tmp / f"figures_{tag}")
            keep(f"small_contact_process_with_figures_s_{tag}", drawn["process_s"])
            best[f"small_contact_dofs_{tag}"] = contact["summary"]["mesh"]["dofs"]
            best[f"startup_dofs_{tag}"] = heat["summary"]["mesh"]["dofs"]
    for tag in codes:
        best[f"startup_ratio_{tag}"] = best[f"startup_s_{tag}"] / best["ngsolve_import_s"]
        best[f"startup_contact_ratio_{tag}"] = best[f"startup_contact_s_{tag}"] / best["ngsolve_import_s"]
    return best


def vtk_3d(codes: dict[str, Path], overrides: list[str], tmp: Path) -> dict:
    """Section 2 per code: repository_3d's VTK time over its solve time (figures off)."""
    out = {}
    for tag, code in codes.items():
        sets = [a for o in ["output.figures=false", *overrides] for a in ("--set", o)]
        s = _process(code, ["repository_3d", "--threads", "1", *sets], tmp / f"repository_3d_{tag}")["summary"]
        w = s["wall_time_s"]
        solve = w.get("initial_s", 0.0) + w["solve_s"]
        out[f"vtk_to_solve_ratio_3d_{tag}"] = w["output_s"] / solve
        out[f"vtk_s_3d_{tag}"] = w["output_s"]
        out[f"solve_s_3d_{tag}"] = solve
        out[f"vtk_outputs_3d_{tag}"] = len(list((tmp / f"repository_3d_{tag}").glob("*.vtu")))
        out[f"dofs_3d_{tag}"] = s["mesh"]["dofs"]
    return out


STEFAN_RUN = """
import json, sys
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
run_scene(scene_from_dict(json.load(open(sys.argv[1]))), sys.argv[2], progress=False, threads=1, overwrite=True)
"""
"""A strip scene (JSON) run into a directory as a process with the code on PYTHONPATH (the same call in every
version)."""


def stefan_steps(codes: dict[str, Path], h: float, dts: tuple, repeats: int, tmp: Path) -> dict:
    """Section 4 per code: the strip at ``h`` with the steps ``dts`` (small, large), the best of ``repeats``
    alternated runs (``total_s`` of the run's summary), the front errors, the steps and Newton iterations."""
    exact, height = st.TWO_PHASE.front(T1), HEIGHT
    rows: dict[tuple, dict] = {}
    for _ in range(repeats):
        for tag, code in codes.items():
            for dt in dts:
                data = strip_step_scene(h, dt)
                del data["time"]["stefan_step_control"]     # the default; a key earlier code does not know
                data["output"].update(vtk=False, figures=False)
                path = tmp / f"strip_{tag}_{dt:g}.json"
                path.write_text(json.dumps(data))
                out = tmp / f"strip_{tag}_{dt:g}"
                subprocess.run([sys.executable, "-c", STEFAN_RUN, str(path), str(out)], check=True, cwd=code,
                               env={**_env(code), "OPENBLAS_NUM_THREADS": "1"})
                s = json.loads((out / "summary.json").read_text())
                row = {"total_s": s["wall_time_s"]["total_s"], "dofs": s["mesh"]["dofs"],
                       "front_rel_error": abs(s["stefan"]["melted_volume"]["pcm"][-1] / height - exact) / exact,
                       "steps": s["steps"], "newton_mean": s["stefan"]["newton_iterations"]["mean"],
                       "stefan": {k: v for k, v in s["stefan"].items() if k in ("step_halvings", "step_control")}}
                if (tag, dt) not in rows or row["total_s"] < rows[tag, dt]["total_s"]:
                    rows[tag, dt] = row
    out = {}
    small, large = dts
    for tag in codes:
        out[f"stefan_large_dt_ratio_{tag}"] = rows[tag, large]["total_s"] / rows[tag, small]["total_s"]
        out[f"stefan_front_rel_error_small_dt_{tag}"] = rows[tag, small]["front_rel_error"]
        out[f"stefan_front_rel_error_large_dt_{tag}"] = rows[tag, large]["front_rel_error"]
        out[f"stefan_wall_small_dt_{tag}"] = rows[tag, small]["total_s"]
        out[f"stefan_wall_large_dt_{tag}"] = rows[tag, large]["total_s"]
    return out, {f"{tag}_dt_{dt:g}": row for (tag, dt), row in rows.items()}


BUSY = "while True: pass"
"""The other work of a loaded machine: one process keeping one core busy."""


def _threads_pass(runs: dict[str, list[str]], tmp: Path, n: int) -> dict:
    """Each run (label: [scene, overrides...]) with one NGSolve thread and with ``n``, alternated:
    {label: (dofs, wall(1), wall(n))}."""
    out = {}
    for label, (name, *overrides) in runs.items():
        sets = [a for o in ["output.figures=false", "output.vtk=false", *overrides] for a in ("--set", o)]
        walls = {}
        for threads in (1, n):
            r = _process(ROOT, [name, "--threads", str(threads), *sets], tmp / f"threads_{name}")
            walls[threads] = r["summary"]["wall_time_s"]["total_s"]
        out[label] = (r["summary"]["mesh"]["dofs"], walls[1], walls[n])
    return out


def _defaults(codes: dict[str, Path], scene: str, tmp: Path) -> dict:
    """``scene`` run by each code with its default threads (no --threads): wall time per code."""
    sets = ["--set", "output.figures=false", "--set", "output.vtk=false"]
    return {tag: _process(code, [scene, *sets], tmp / f"default_{tag}")["summary"]["wall_time_s"]["total_s"]
            for tag, code in codes.items()}


def threads_table(scenes: dict[str, list[str]], tmp: Path, codes: dict[str, Path],
                  default_scene: str | None) -> tuple[dict, dict]:
    """Section 5: each scene (a name: [scene, overrides...]) with one NGSolve thread and with every core, on the
    machine as it is ("idle") and with one other busy process ("loaded"); ``default_scene`` run by every code
    with its default threads, idle and loaded."""
    n = cores()
    table, metrics = {}, {"cores": n}
    runs = {label: list(run) for label, run in scenes.items()}
    idle = _threads_pass(runs, tmp, n) if n > 1 else {}
    defaults = {"idle": _defaults(codes, default_scene, tmp)} if default_scene else {}
    busy = subprocess.Popen([sys.executable, "-c", BUSY]) if n > 1 else None
    try:
        loaded = _threads_pass(runs, tmp, n) if n > 1 else {}
        if default_scene:
            defaults["loaded"] = _defaults(codes, default_scene, tmp)
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
    for label in runs:
        if label not in idle:
            continue
        dofs, w1, wn = idle[label]
        _, l1, ln = loaded[label]
        table[label] = {"scene": runs[label][0], "overrides": runs[label][1:], "dofs": dofs,
                        "wall_s_1_thread": w1, f"wall_s_{n}_threads": wn, "wall_s_1_thread_loaded": l1,
                        f"wall_s_{n}_threads_loaded": ln}
        metrics[f"threads_speedup_{label}"] = w1 / wn
        metrics[f"threads_speedup_loaded_{label}"] = l1 / ln
        metrics[f"threads_dofs_{label}"] = dofs
    for load, walls in defaults.items():
        for tag, wall in walls.items():
            metrics[f"default_threads_wall_s_{load}_{tag}"] = wall
    table["defaults"] = {"scene": default_scene, **defaults}
    return metrics, table


def peers(python: str, repeats: int) -> tuple[dict, dict]:
    """The established code's twins (:file:`peers/compare.py`): flat ``peer_*`` metrics and the whole dict."""
    spec = importlib.util.spec_from_file_location("whole_process_peers", HERE / "peers" / "compare.py")
    compare = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(compare)
    r = compare.measure(python, repeats)
    c, h = r["two_blocks"], r["heat_block"]
    metrics = {"peer_contact_process_s_ours": c["ours_process_s"],
               "peer_contact_process_s_kratos": c["kratos_process_s"],
               "peer_contact_process_ratio": c["process_ratio_ours_over_kratos"],
               "peer_heat_process_s_ours": h["ours_process_s"], "peer_heat_process_s_kratos": h["kratos_process_s"],
               "peer_heat_process_ratio": h["process_ratio_ours_over_kratos"],
               "peer_import_s_ngsolve": r["imports"]["ngsolve_import_s"],
               "peer_import_s_kratos": r["imports"]["kratos_contact_import_s"],
               "peer_contact_nodal_pressure_max_diff_rel": c["agreement"]["nodal_pressure_max_diff_rel"],
               "peer_contact_mean_pressure_ours_Pa": c["agreement"]["ours_mean_pressure_Pa"],
               "peer_contact_mean_pressure_kratos_Pa": c["agreement"]["kratos_mean_pressure_Pa"],
               "peer_contact_max_uy_diff_rel": c["agreement"]["max_abs_uy_diff_rel"],
               "peer_heat_max_nodal_error_K_kratos": h["agreement"]["kratos_max_nodal_error_K"],
               "peer_heat_max_nodal_error_K_ours": h["agreement"]["ours_max_nodal_error_K"]}
    return metrics, r


def _commit(code: Path) -> str:
    """The commit a baseline checkout is at (what results.json records of it)."""
    return subprocess.run(["git", "-C", str(code), "rev-parse", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()


def run(level: int, baseline: Path | None = None, peers_python: str | None = None) -> tuple[dict, dict]:
    """The results dict of ``level`` (module docstring) and its tables."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    codes = {"after": ROOT, **({"before": Path(baseline).resolve()} if baseline is not None else {})}
    t_start = time.perf_counter()
    timing, tables, metrics = {}, {}, {}
    with tempfile.TemporaryDirectory(prefix="whole_process_") as d:
        tmp = Path(d)
        tic = time.perf_counter()
        metrics.update(startup(codes, p["repeats"], tmp))
        timing["startup_s"] = time.perf_counter() - tic
        tic = time.perf_counter()
        metrics.update(vtk_3d(codes, p["repository_3d"], tmp))
        timing["vtk_3d_s"] = time.perf_counter() - tic
        tic = time.perf_counter()
        share = strip_meshing_share(p["strip_h"], repeats=1)
        tables["mesh_share"] = share
        metrics["mesh_share_fine_2d"] = share["share_after"]
        metrics["mesh_share_netgen_2d"] = share["share_before"]
        metrics["mesh_share_dofs"] = share["tensor"]["dofs"]
        timing["mesh_share_s"] = time.perf_counter() - tic
        tic = time.perf_counter()
        figures, tables["stefan_steps"] = stefan_steps(codes, p["stefan_h"], p["stefan_dts"], 2, tmp)
        metrics.update(figures)
        timing["stefan_steps_s"] = time.perf_counter() - tic
        tic = time.perf_counter()
        figures, tables["threads"] = threads_table(p["threads"], tmp, codes, p["default_threads"])
        metrics.update(figures)
        timing["threads_s"] = time.perf_counter() - tic
    if peers_python is not None:
        tic = time.perf_counter()
        figures, tables["peers"] = peers(peers_python, p["repeats"])
        metrics.update(figures)
        timing["peers_s"] = time.perf_counter() - tic
    for key in ("startup_s", "startup_ratio", "startup_contact_s", "startup_contact_ratio", "small_contact_process_s",
                "small_contact_process_with_figures_s", "vtk_to_solve_ratio_3d", "stefan_large_dt_ratio"):
        metrics[key] = metrics[f"{key}_after"]
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": [], "timing_s": timing,
              "limits": LIMITS, "tables": tables, "baseline": _commit(baseline) if baseline is not None else None}
    return result, tables


def report(result: dict) -> str:
    lines = [f"study {result['study']}, level {result['level']}", "", "target    measured  metric"]
    for key, limit in result["limits"].items():
        lines.append(f"<= {limit:<6g} {result['metrics'][key]:9.3g}  {key}")
    return "\n".join(lines + metrics_lines(result))


def main(level: int = 0, out: str | Path | None = None, baseline: str | Path | None = None,
         peers_python: str | None = None) -> dict:
    """Run the study at ``level`` (with a ``baseline`` checkout: its figures too; with ``peers_python``: the
    established code's); write ``out/results.json``."""
    return study_main(functools.partial(run, baseline=baseline, peers_python=peers_python), level, out)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, default=0, help="0 quick, 1 the issue's sizes")
    parser.add_argument("--out", default=None, help="directory for results.json")
    parser.add_argument("--baseline", default=None, help="a source checkout of an earlier commit to compare with")
    parser.add_argument("--peers", default=None, help="python of an environment with Kratos (peers/README.md)")
    args = parser.parse_args()
    print(report(main(args.level, args.out, args.baseline, args.peers)))
