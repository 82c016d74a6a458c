"""Worst scenario of the KBS-3 repository section over the data intervals of its sources.

Physics: the built-in scene ``repository_section`` (plane-strain section through a row of five deposition holes
with decaying canister power, the rest of the panel as a smeared source, granite with a geotherm, in-situ stress and
a Coulomb fault; transient heat, quasi-static thermal stresses with the fault contact at the output times) with the
data its ``[uncertainty]`` table gives in intervals: the modelled canisters' power (factor 0.9-1.1), the rest of the
panel's power (0.9-1.1) and the granite conductivity (2.7-3.5 W/(m K)). Criteria: the
peak canister/buffer temperature (against the 100 C design limit), the fault's largest slip of a closed node and
largest relative tangential motion (opened nodes included) over the run, and the most compressive principal stress
at the middle hole's wall. The worst-scenario search (:mod:`ngs_geomech.uncertainty.worst`): a Latin hypercube and
the box's corners, then projected-gradient steps with finite differences per criterion and sense.

Levels (coarse meshes: a run of the scene as shipped takes about a minute and a half): level 0 (the contract test)
runs to 30 years on the test mesh with two parameters (canister power, conductivity) at two Latin hypercube points
(3 runs); level 1 runs to 1000 years with all three parameters (8 Latin hypercube points, 8 corners, the local
searches, the finite-difference check at the nominal point); level 2 is level 1 on the scene's own mesh (about 40
runs).

Command: ``python studies/worst_scenario/run.py --level 1 --out out/worst_scenario`` (writes ``results.json`` and
``repository/`` with the study's table, figures and sample log; ``--level`` and the same ``--out`` resume a killed
study). Equivalent: ``ngs-geomech uncertain repository_section --out DIR --set mesh.maxh=150 ...``.

Cost on 2 cores (process pool of 2 workers, one thread each): level 0 about 13 s; level 1 (about 50 runs) about
13 minutes; level 2 over an hour.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from ngs_geomech.io.atomic import write_json_atomic
from ngs_geomech.scene.parse import read_toml, resolve
from ngs_geomech.uncertainty.study import Study
from ngs_geomech.verification.study import json_safe

COARSE = ["mesh.maxh=150", "mesh.boundary_maxh.fault__rock_west=40", "mesh.boundary_maxh.fault__rock_east=40",
          "time.dt=1 year", "output.vtk=false", "output.figures=false"]
LEVELS = {
    0: COARSE + ["time.end=30 year", "time.dt_max=10 year", "output.every=4", "uncertainty.samples=2",
                 "uncertainty.vertices=no", "uncertainty.local_search=false"],
    1: COARSE + ["time.dt_max=50 year", "output.every=4", "uncertainty.derivative_check=true"],
    2: ["output.vtk=false", "output.figures=false"],
}


def run(level: int = 0, out: str | Path | None = None, workers: int = 2, resume: bool = False) -> dict:
    raw = read_toml(resolve("repository_section"))
    if level == 0:      # two parameters: the panel's power stays at its value
        raw["uncertainty"]["parameters"] = [p for p in raw["uncertainty"]["parameters"] if p["name"] != "panel_power"]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(out) / "repository" if out is not None else Path(tmp) / "repository"
        resume = resume and (where / "samples.jsonl").is_file()
        res = Study(raw, where, LEVELS[level], resume=resume).run(executor="process", workers=workers,
                                                                   progress=out is not None)
    wall = time.perf_counter() - t0
    body = res["worst_scenario"]["criteria"]
    metrics = {}
    for name, e in body.items():
        metrics[f"{name}_nominal"] = e["nominal"]
        metrics[f"{name}_min"] = e["range"][0]
        metrics[f"{name}_max"] = e["range"][1]
    metrics["peak_buffer_temperature_margin_to_limit"] = body["peak_buffer_temperature"]["margin_to_limit"]
    s = res["samples"]
    metrics.update({"samples_total": s["total"], "samples_failed": s["failed"], "mean_run_s": s["mean_run_wall_s"],
                    "wall_s": wall})
    return json_safe({"study": "worst_scenario", "level": level, "metrics": metrics, "convergence": [],
                      "timing_s": {"total": wall, "runs_summed": s["run_wall_s_sum"]}, "uncertainty": res})


def report(result: dict) -> str:
    lines = [f"study worst_scenario, level {result['level']}"]
    res = result["uncertainty"]
    for name, e in res["worst_scenario"]["criteria"].items():
        lines.append(f"  {name:26s} nominal {e['nominal']:11.5g}  range [{e['range'][0]:11.5g}, "
                     f"{e['range'][1]:11.5g}] {e['unit']}")
        for sense in ("max", "min"):
            if sense in e:
                x = e[sense]
                lines.append(f"      {sense}: {x['value']:.6g} at " + ", ".join(f"{k}={v:.4g}" for k, v in
                                                                                x["parameters"].items())
                             + f" ({x['found_by']}, {x['iterations']} steps, stop {x['stop']})")
    lines += ["", "metrics:"] + [f"  {k:45s} {v:.5g}" for k, v in result["metrics"].items()]
    return "\n".join(lines)


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level``; write ``out/results.json`` if ``out`` is given."""
    result = run(level, out)
    if out is not None:
        write_json_atomic(Path(out) / "results.json", result)
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, default=0)
    parser.add_argument("--out", default=None)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    result = run(args.level, args.out, args.workers, resume=True)
    if args.out is not None:
        write_json_atomic(Path(args.out) / "results.json", result)
    print(report(result))
