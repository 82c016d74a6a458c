"""Run time, size and one picture of every built-in scene at its quick level, run as shipped.

What. Every built-in scene (the TOML files in ``geometries/``, listed by :func:`ngs_geomech.api.list_builtin`, so
a new scene joins by itself) runs with its own settings: its quick-level mesh and time steps, its VTK and figures
as the scene has them, one NGSolve thread, no progress display, into a temporary output directory. Per scene the
study records the wall time of the whole run (s: loading and validating the scene, meshing, every solve, the VTK,
the figures and ``summary.json``), the dofs in total and per part of the run (``mesh.dofs_by_part`` of the
summary: ``heat`` or ``stefan``, ``mechanics`` or ``dynamics``), the mesh's elements and vertices, the dimension
(plane, axisymmetric, 3d), the time steps (0: a stationary scene), the VTK files written (``.vtu`` per output
time, contact ``.vtp`` series, ``.pvd``) and their size (MB), and the figures; it copies ONE picture per scene,
the one :data:`PICTURES` declares as the scene's most telling, to ``OUT/<scene>.png`` for the documentation. A
scene without a declared picture, or whose picture the run did not draw, stops the study with an error naming it.

Command (what ``docs/scenarios.md`` quotes; a few minutes on one thread)::

    python studies/scenes/run.py --level 1 --out docs/results/scenes && python studies/quote.py

Level 0 (the contract test of the suite, a few seconds): the same machinery on three small scenes (:data:`LEVEL0`:
a 2D transient heat scene and a 3D one as shipped, the Stefan-contact-coupling one coarse and 60 days long),
asserting every figure of a scene is positive (steps where the scene has time, VTK files where it writes VTK).
Level 1: every scene as shipped.
"""

from __future__ import annotations

import logging
import tempfile
import time
from pathlib import Path

from ngs_geomech import api
from ngs_geomech.scene.parse import load_scene
from ngs_geomech.verification.study import metrics_lines, study_cli, study_main

log = logging.getLogger(__name__)

STUDY = "scenes"
PICTURES = {
    "block3d": "temperature_section_y.png",
    "canister": "probes.png",
    "canister_gap": "probes_displacement_x.png",
    "contact_melting": "phase_boundary.png",
    "fault2d": "temperature.png",
    "fault_3d": "von_mises_section_across_fault.png",
    "fault_heating": "temperature.png",
    "fault_wedge": "contact_fault.png",
    "heated_rock": "principal_stress.png",
    "melting_block": "phase_boundary.png",
    "permafrost": "temperature_profile.png",
    "plate_collision": "principal_stress_change.png",
    "repository_3d": "probes.png",
    "repository_fracture_3d": "von_mises_section_across_tunnel.png",
    "repository_panel_3d": "temperature_section_along_tunnel.png",
    "repository_section": "temperature_zoom.png",
}
"""The picture of each scene in the documentation: a file of the run's ``figures/``."""

EXCLUDED: dict[str, str] = {}
"""Built-in scenes the study does not run (name -> the reason)."""

LEVEL0 = {
    "fault2d": [],
    "block3d": [],
    "contact_melting": ["time.end=60 day", "time.dt=10 day", "mesh.maxh=0.25"],
}
"""The scenes of level 0 and their coarsening overrides."""

VTK_SUFFIXES = (".vtu", ".vtp", ".pvd")


def scenes(level: int) -> dict[str, list[str]]:
    """The scenes of ``level`` and their overrides (level 1: every built-in scene but :data:`EXCLUDED`, as
    shipped)."""
    if level == 0:
        return LEVEL0
    if level == 1:
        return {name: [] for name in api.list_builtin() if name not in EXCLUDED}
    raise ValueError("level must be 0 or 1")


def _files(out: Path) -> dict:
    vtk = [p for p in out.rglob("*") if p.suffix in VTK_SUFFIXES]
    figures = sorted(p.name for p in (out / "figures").glob("*.png"))
    return {"vtk_outputs": sum(p.suffix == ".vtu" for p in vtk), "vtk_files": len(vtk),
            "vtk_MB": sum(p.stat().st_size for p in vtk) / 1e6, "figures": figures}


def run_scene(name: str, overrides: list[str], tmp: Path) -> tuple[dict, bytes]:
    """One scene run into ``tmp/name``: its row (module docstring) and the bytes of its picture."""
    if name not in PICTURES:
        raise KeyError(f"scene {name!r} has no picture in studies/scenes PICTURES (declare one, or exclude it "
                       "in EXCLUDED with the reason)")
    tic = time.perf_counter()
    sc = load_scene(name, overrides)
    res = api.run(sc, tmp / name, progress=False, threads=1)
    wall = time.perf_counter() - tic
    mesh, files = res.summary["mesh"], _files(res.out)
    if PICTURES[name] not in files["figures"]:
        raise FileNotFoundError(f"scene {name!r} drew no figures/{PICTURES[name]} (its figures: "
                                f"{files['figures']}): fix PICTURES in studies/scenes/run.py")
    parts = {k: int(v) for k, v in mesh["dofs_by_part"].items() if v}
    row = {"dimension": sc.scene.dimension, "dofs": int(mesh["dofs"]),
           "parts": ", ".join(f"{k} {v}" for k, v in parts.items()), "dofs_by_part": parts,
           "elements": int(mesh["elements"]), "vertices": int(mesh["vertices"]), "order": int(mesh["order"]),
           "steps": int(res.summary["steps"]), "wall_s": wall, **files, "picture": PICTURES[name],
           "transient": sc.time is not None, "vtk": bool(sc.output.vtk), "overrides": overrides}
    _check(name, row)
    log.info("%s: %.1f s, %d dofs", name, wall, row["dofs"])
    return row, (res.out / "figures" / PICTURES[name]).read_bytes()


def _check(name: str, row: dict) -> None:
    """Every figure of a run is positive: steps where the scene has time, VTK where it writes VTK."""
    wanted = ["wall_s", "dofs", "elements", "vertices"] + ["steps"] * row["transient"] + ["vtk_files"] * row["vtk"]
    bad = [k for k in wanted if not row[k] > 0] + [k for k, v in row["dofs_by_part"].items() if not v > 0]
    if not row["figures"]:
        bad.append("figures")
    if bad:
        raise RuntimeError(f"scene {name!r}: not positive: {bad} in {row}")


def metrics(rows: dict) -> dict:
    """The numeric figures of every scene as flat metrics ``<scene>_<figure>``, and the totals."""
    out = {}
    for name, row in rows.items():
        out.update({f"{name}_{k}": row[k] for k in ("dofs", "elements", "vertices", "steps", "wall_s",
                                                    "vtk_outputs", "vtk_files", "vtk_MB")})
        out.update({f"{name}_dofs_{k}": v for k, v in row["dofs_by_part"].items()})
        out[f"{name}_dimension"] = 3 if row["dimension"] == "3d" else 2
        out[f"{name}_figures"] = len(row["figures"])
    out["scenes"] = len(rows)
    out["total_wall_s"] = sum(row["wall_s"] for row in rows.values())
    return out


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` (``rows``: per scene its figures, module docstring) and the pictures
    (scene -> PNG bytes)."""
    todo = scenes(level)
    rows, pictures = {}, {}
    with tempfile.TemporaryDirectory(prefix="ngs_geomech_scenes_") as tmp:
        for name, overrides in todo.items():
            rows[name], pictures[name] = run_scene(name, overrides, Path(tmp))
    result = {"study": STUDY, "level": level, "metrics": metrics(rows), "convergence": [],
              "timing_s": {name: row["wall_s"] for name, row in rows.items()},
              "row_name": "scene", "rows": rows, "excluded": EXCLUDED}
    return result, pictures


def write_pictures(pictures: dict, out: Path) -> None:
    """Each scene's picture as ``out/<scene>.png``."""
    out.mkdir(parents=True, exist_ok=True)
    for name, data in pictures.items():
        (out / f"{name}.png").write_bytes(data)


def report(result: dict) -> str:
    """A table of the scenes (dimension, dofs per part, elements, steps, wall time, VTK) and the metrics."""
    lines = [f"study {result['study']}, level {result['level']}", "",
             f"{'scene':24} {'dim':12} {'dofs':>7} {'elements':>8} {'steps':>5} {'wall s':>7} {'VTK MB':>7}  parts"]
    for name, r in result["rows"].items():
        lines.append(f"{name:24} {r['dimension']:12} {r['dofs']:7d} {r['elements']:8d} {r['steps']:5d} "
                     f"{r['wall_s']:7.1f} {r['vtk_MB']:7.2f}  {r['parts']}")
    lines.append(f"total {result['metrics']['total_wall_s']:.1f} s")
    return "\n".join(lines + metrics_lines(result))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1 every scene as shipped); write ``out/results.json`` and the
    pictures ``out/<scene>.png`` if ``out`` is given."""
    return study_main(run, level, out, write_pictures)


if __name__ == "__main__":
    study_cli(__doc__, run, report, write_pictures)
