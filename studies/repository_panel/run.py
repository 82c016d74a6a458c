"""The 3D repository panel ``repository_panel_3d`` at its quick level and the size of its large level.

Physics. A KBS-3 panel (geometries/repository_panel_3d.toml): four deposition holes along one tunnel, each a
12-sided copper canister with decaying power in a bentonite buffer, in frictionless contact with it (the gaps
gap_1 ... gap_4), and a steep Coulomb fracture zone crossing the tunnels beyond their deposition section;
transient heat (Crank-Nicolson) to 1000 years, static thermo-elasticity with contact at the output times. The
study records what the scene computes (the canisters' peak temperatures and the inner holes' excess over the outer
ones, the gaps' states and normal forces, the fracture's states, slip and normal force) and what it costs
(elements, dofs per part, run time), and the size of the large level meant for distributed runs (P2, finer near
the holes: :data:`LARGE`).

Why the canisters are prisms: level 0 also measures the initial gaps the 3D contact operator
(:func:`ngs_geomech.contact.forms3d.contact_operator_3d`, flat boundary triangles) finds between a canister and its
buffer, touching, when the canister is the 0.525 m cylinder instead of the 12-sided prism: the chords of the two
independently meshed copies of the curved face disagree by millimetres to centimetres (``cylinder_gap_*``), where
the prism's flat facets give zero to rounding (``prism_gap_abs_max_m``).

Command (what docs/scenarios.md quotes)::

    python studies/repository_panel/run.py --level 1 --out docs/results/repository_panel && python studies/quote.py

Level 0 (the contract test, under a minute): the quick level's mesh (elements, dofs) and the initial gaps of the
prism and cylinder canisters. Level 1 (a few minutes on one thread): level 0, the quick level as shipped (VTK and
figures into a temporary directory), the large level's mesh (elements, dofs, mesh time; no solve) and, with
mpiexec and petsc4py, the quick level for 30 years on 3 ranks (2 workers) against serial (:data:`DISTRIBUTED`;
``distributed_*``; without them ``distributed_available`` = 0). Level 2
(long: an hour on a shared machine): level 1 and the large level's first mechanics solve (t = 0, contact included).
Dofs: ``dofs_*_heat`` is the temperature space; the run's summary also counts the heat's mortar multiplier
spaces (one per contact interface) at their full size, ``summary_dofs_*``.
"""

from __future__ import annotations

import json
import logging
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import ngsolve as ngs
import numpy as np

from ngs_geomech import api
from ngs_geomech.contact.forms3d import contact_operator_3d
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.linalg.petsc import available as petsc_available
from ngs_geomech.parallel import launch_environment
from ngs_geomech.scene.parse import load_scene, read_toml, resolve, scene_from_dict
from ngs_geomech.scene.units import YEAR
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification.study import metrics_lines, one_ngsolve_thread, study_cli, study_main

log = logging.getLogger(__name__)

STUDY = "repository_panel"
SCENE = "repository_panel_3d"
HOLES = (1, 2, 3, 4)
LARGE = ["mesh.order=2", "mesh.maxh=25", "blocks.tunnel.maxh=1.0", "solver.linear=auto", "solver.tolerance=1e-9",
         *[f"blocks.{b}_{i}.maxh=0.2" for i in HOLES for b in ("buffer", "canister")]]
"""The large level's overrides (P2; 0.2 m in the holes, 1 m in the tunnel, 25 m far field; the iterative solvers,
GMRES of the contact Newton steps to 1e-9, above the default 1e-10, which it does not reach at this size)."""
FIRST_SOLVE = ["time.end=1 day", "output.every=1", "output.vtk=false", "output.figures=false"]
"""With :data:`LARGE`: one time step, mechanics at t = 0 and after it (level 2)."""
DISTRIBUTED = ["time.end=30 year", "time.dt_max=5 year", "output.every=100", "output.vtk=false",
               "output.figures=false", "solver.linear=iterative", "solver.tolerance=1e-9"]
"""The distributed comparison (level 1): the quick mesh for 30 years, mechanics at t = 0 and 30 years, the Newton
steps by GMRES to 1e-9 (at 1e-12 it stopped at 9e-10 after 2000 iterations) in both runs."""
PICTURES = ("temperature_section_along_tunnel.png", "von_mises_section_across_tunnel.png")
"""The quick run's figures the documentation shows (level 1)."""
CYLINDER_RADIUS = 0.525       # m, the canister of repository_3d
GAP_SEARCH = 0.05             # m: the search distance of the gap measurement (the sides touch)


def _mesh(sc):
    """The scene's geometry model, its mesh and the meshing's wall and CPU time (s)."""
    geo = validate(sc)
    tic, cpu = time.perf_counter(), time.process_time()
    mesh = make_mesh(geo, sc.mesh)
    return geo, mesh, time.perf_counter() - tic, time.process_time() - cpu


def _size(mesh, order: int, prefix: str) -> dict:
    """Elements, vertices and the dofs of the heat (H1) and mechanics (VectorH1) spaces of ``order``."""
    heat = ngs.H1(mesh, order=order).ndof
    return {f"{prefix}_elements": mesh.ne, f"{prefix}_vertices": mesh.nv, f"dofs_{prefix}_heat": heat,
            f"dofs_{prefix}_mechanics": 3 * heat, f"dofs_{prefix}": 4 * heat}


def _gap_range(sc, geo, mesh) -> np.ndarray:
    """The nodal initial gaps g0 / weight (m) of the canister gaps of scene ``sc`` (its geometry model ``geo`` and
    mesh), all four together."""
    V = ngs.VectorH1(mesh, order=sc.mesh.order)
    gaps = []
    for i in HOLES:
        cs = geo.contacts[f"gap_{i}"]
        op = contact_operator_3d(mesh, V, cs.name, cs.master, cs.minion, search_distance=GAP_SEARCH)
        gaps.append(op.g0 / op.weight)
    return np.concatenate(gaps)


def cylinder_scene():
    """The quick level with the canisters as cylinders of radius :data:`CYLINDER_RADIUS` (repository_3d's)."""
    data = read_toml(resolve(SCENE))
    for b in data["blocks"]:
        if b["name"].startswith("canister_"):
            x, y, z = b.pop("origin")
            for k in ("points", "length"):
                b.pop(k)
            b.update(shape="cylinder", center=[x, y, z], axis=[0.0, 0.0, 1.0], radius=CYLINDER_RADIUS, height=4.8)
    return scene_from_dict(data)


def level0() -> tuple[dict, dict]:
    """The quick mesh's size and the initial gaps of the prism and cylinder canisters."""
    sc = load_scene(SCENE)
    geo, mesh, wall, cpu = _mesh(sc)
    out = {**_size(mesh, sc.mesh.order, "quick"), "quick_mesh_s": wall, "quick_mesh_cpu_s": cpu}
    prism = _gap_range(sc, geo, mesh)
    cyl_scene = cylinder_scene()
    cyl = _gap_range(cyl_scene, *_mesh(cyl_scene)[:2])
    out.update(prism_gap_abs_max_m=float(np.max(np.abs(prism))), cylinder_gap_min_mm=1e3 * float(cyl.min()),
               cylinder_gap_max_mm=1e3 * float(cyl.max()), cylinder_gap_abs_mean_mm=1e3 * float(np.abs(cyl).mean()),
               cylinder_gap_nodes_over_1mm=int(np.sum(np.abs(cyl) > 1e-3)), cylinder_gap_nodes=len(cyl))
    return out, {}


def _gap_metrics(c: dict) -> dict:
    """The gaps' states and normal forces over the output times (the contact summary ``c``)."""
    hist = c["history"]
    forces = [[h[f"gap_{i}"]["normal_force"] for h in hist] for i in HOLES]
    return {"gap_nodes": sum(c["interfaces"][f"gap_{i}"]["nodes"][k] for i in HOLES
                             for k in ("open", "stick", "slip", "prescribed")) // len(HOLES),
            "gap_open_nodes_max": max(h[f"gap_{i}"]["nodes"]["open"] for h in hist for i in HOLES),
            "gap_normal_force_t0_MN": float(np.mean([f[0] for f in forces])) / 1e6,
            "gap_normal_force_max_MN": float(np.max(forces)) / 1e6,
            "gap_max_pressure_MPa": max(c["interfaces"][f"gap_{i}"]["max_pressure_Pa"] for i in HOLES) / 1e6}


def _fracture_metrics(c: dict) -> dict:
    """The fracture's states, normal force and slip over the output times (the contact summary ``c``)."""
    hist = [h["fracture"] for h in c["history"]]
    f = c["interfaces"]["fracture"]
    force = [h["normal_force"] for h in hist]
    return {"fracture_nodes": sum(f["nodes"].values()),
            "fracture_normal_force_rise_percent": 100 * (max(force) / force[0] - 1),
            "fracture_open_nodes_max": max(h["nodes"]["open"] for h in hist),
            "fracture_slip_nodes_t0": hist[0]["nodes"]["slip"],
            "fracture_slip_nodes_max": max(h["nodes"]["slip"] for h in hist),
            "fracture_max_slip_mm": 1e3 * f["max_slip_over_time_m"]}


def quick_run() -> tuple[dict, dict]:
    """The quick level as shipped (one thread, VTK and figures into a temporary directory): its metrics and the
    bytes of its :data:`PICTURES`."""
    with tempfile.TemporaryDirectory(prefix="ngs_geomech_panel_") as tmp:
        tic, cpu = time.perf_counter(), time.process_time()
        res = api.run(SCENE, Path(tmp) / "out", progress=False, threads=1)
        wall, cpu = time.perf_counter() - tic, time.process_time() - cpu
        pictures = {name: (res.out / "figures" / name).read_bytes() for name in PICTURES}
    s = res.summary
    peaks = [s["probes"][f"canister_{i}_surface_max"] for i in HOLES]
    top = [p["max"] for p in peaks]
    c = s["mechanics"]["contact"]
    return {"quick_wall_s": wall, "quick_cpu_s": cpu, "quick_steps": int(s["steps"]),
            "quick_mechanics_solves": len(c["history"]), "summary_dofs_quick": int(s["mesh"]["dofs"]),
            **{f"canister_{i}_peak_C": p for i, p in zip(HOLES, top)},
            "canister_peak_time_years": float(np.mean([p["time_of_max"] for p in peaks])) / YEAR,
            "inner_minus_outer_peak_K": 0.5 * (top[1] + top[2] - top[0] - top[3]),
            "mirror_peak_difference_K": max(abs(top[0] - top[3]), abs(top[1] - top[2])),
            "contact_iterations": int(sum(c["iterations_per_solve"])),
            "force_imbalance_rel": c["force_balance"]["imbalance_rel"],
            "surface_uplift_max_mm": 1e3 * s["probes"]["surface_uplift"]["max"],
            **_gap_metrics(c), **_fracture_metrics(c)}, pictures


def large_mesh() -> tuple[dict, dict]:
    """The large level's mesh: elements, dofs per part and meshing wall and CPU time (no solve)."""
    sc = load_scene(SCENE, LARGE)
    _, mesh, wall, cpu = _mesh(sc)
    return {**_size(mesh, sc.mesh.order, "large"), "large_mesh_s": wall, "large_mesh_cpu_s": cpu}, {}


def large_first_solve() -> tuple[dict, dict]:
    """The large level's first mechanics solve (t = 0) and the run's set-up, from one time step."""
    tic = time.perf_counter()
    res = api.run(SCENE, None, overrides=LARGE + FIRST_SOLVE, progress=False, threads=1)
    s = res.summary
    c = s["mechanics"]["contact"]
    t = s["wall_time_s"]
    return {"large_run_s": time.perf_counter() - tic, "summary_dofs_large": int(s["mesh"]["dofs"]),
            "large_first_contact_iterations": int(c["iterations_per_solve"][0]),
            "large_setup_s": t["setup_s"], "large_initial_state_s": t["initial_s"]}, {}


def _mpiexec() -> str | None:
    """The MPI launcher next to this Python (or on the PATH) when petsc4py is installed, else None."""
    found = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or shutil.which("mpiexec")
    return found if found and petsc_available() else None


def _probe_difference(got: dict, want: dict, names: list[str]) -> float:
    """The largest difference of the probe series ``names`` of two summaries, relative to each series' largest
    value."""
    worst = 0.0
    for name in names:
        a, b = np.asarray(got["probe_series"][name], float), np.asarray(want["probe_series"][name], float)
        worst = max(worst, float(np.max(np.abs(a - b))) / max(float(np.max(np.abs(b))), 1e-300))
    return worst


def distributed_run() -> tuple[dict, dict]:
    """The quick level for 30 years (:data:`DISTRIBUTED`) on 3 ranks (2 workers) against the same serially: the
    temperatures, contact forces and node states, the iterations and the wall times (2 cores: the ranks share
    them with nothing else, the serial run has one)."""
    launcher = _mpiexec()
    if launcher is None:
        return {"distributed_available": 0}, {}
    with tempfile.TemporaryDirectory(prefix="ngs_geomech_panel_mpi_") as tmp:
        cmd = [launcher, "-n", "3", sys.executable, "-m", "ngs_geomech.cli", "run", SCENE, "--out",
               str(Path(tmp) / "out"), "--quiet", "--threads", "1"]
        for o in DISTRIBUTED:
            cmd += ["--set", o]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=3600, env=launch_environment())
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
        got = json.loads((Path(tmp) / "out" / "summary.json").read_text())
    want = api.run(SCENE, None, overrides=DISTRIBUTED, progress=False, threads=1).summary
    temps = [f"canister_{i}_surface_max" for i in HOLES] + ["mid_between_holes", "fracture"]
    cg, cw = got["mechanics"]["contact"], want["mechanics"]["contact"]
    forces = max(abs(hg[k]["normal_force"] - hw[k]["normal_force"]) / abs(hw[k]["normal_force"])
                 for hg, hw in zip(cg["history"], cw["history"]) for k in hw if isinstance(hw[k], dict))
    states = all(cg["interfaces"][k]["nodes"] == cw["interfaces"][k]["nodes"] for k in cw["interfaces"])
    return {"distributed_available": 1, "distributed_dofs": int(got["mesh"]["dofs"]),
            "distributed_temperature_rel_difference": _probe_difference(got, want, temps),
            "distributed_displacement_rel_difference": _probe_difference(got, want, ["surface_uplift"]),
            "distributed_normal_force_rel_difference": forces, "distributed_node_states_equal": int(states),
            "distributed_newton_iterations": int(sum(cg["iterations_per_solve"])),
            "serial_newton_iterations": int(sum(cw["iterations_per_solve"])),
            "distributed_gmres_max": int(max(cg["gmres_max_per_solve"])),
            "serial_gmres_max": int(max(cw["gmres_max_per_solve"])),
            "distributed_wall_s": got["wall_time_s"]["total_s"],
            "serial_iterative_wall_s": want["wall_time_s"]["total_s"],
            "distributed_peak_rss_gib_per_rank_max": max(got["mesh"]["peak_rss_gib_per_rank"])}, {}


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the pictures (file name -> PNG bytes)."""
    if level not in (0, 1, 2):
        raise ValueError("level must be 0, 1 or 2")
    metrics, timing, pictures = {}, {}, {}
    with one_ngsolve_thread():
        for name, part, lowest in (("level0", level0, 0), ("quick", quick_run, 1), ("large_mesh", large_mesh, 1),
                                   ("distributed", distributed_run, 1), ("large_first_solve", large_first_solve, 2)):
            if level < lowest:
                continue
            tic = time.perf_counter()
            values, drawn = part()
            metrics.update(values)
            pictures.update(drawn)
            timing[name] = time.perf_counter() - tic
            log.info("%s: %.1f s", name, timing[name])
    return {"study": STUDY, "level": level, "metrics": metrics, "convergence": [], "timing_s": timing,
            "large_overrides": LARGE}, pictures


def report(result: dict) -> str:
    """The printed summary: the study, its level and its metrics."""
    return "\n".join([f"study {result['study']}, level {result['level']}", *metrics_lines(result)])


def write_pictures(pictures: dict, out: Path) -> None:
    """Each picture as ``out/<scene>_<file name>``."""
    out.mkdir(parents=True, exist_ok=True)
    for name, data in pictures.items():
        (out / f"{SCENE}_{name}").write_bytes(data)


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run ``level``, write results.json and the pictures into ``out`` (when given), return the results."""
    return study_main(run, level, out, write_pictures)


if __name__ == "__main__":
    study_cli(__doc__, run, report, write_pictures)
