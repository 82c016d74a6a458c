"""Verification of the general geometry: faults made by cuts, STEP import, arcs and prisms (closed forms).

Physics and geometry (:mod:`ngs_geomech.verification.geometry`). (1) The inclined contact patch test: the unit cube
cut through its centre by a fault of dip 50 and strike 30 degrees into a hanging wall and a footwall, frictionless
contact on non-matching meshes, symmetry on x = 0, y = 0, z = 0 and a pressure p on the other faces: the exact
state is hydrostatic (sigma = -p I, u = -p x / (3 K)), every nodal contact pressure is p (P1 and P2); the same with
the parts glued, and with the part below a cut through the origin removed and u_n = 0 on the inclined face; in 2D
(plane strain) a line dipping 40 degrees. (2) A STEP round trip: two boxes with named solids and faces written by
netgen.occ, read back by an ``import`` block: volumes (geometry and mesh), names, the series heat flux through the
glued layers. (3) A tunnel section with a semicircular arc roof (``profile`` with an ``arc``): area and roof length
of meshes of order 1 and 2 against the closed forms (orders 2 and 4: the deviation of a quadratic interpolant of the
arc has zero mean over each element). (4) The section extruded (``prism``) along y and obliquely: volume = area x
length x (a . n), of the OCC solid and of the order-2 mesh.

Command: ``python studies/geometry_verification/run.py --level 0 --out out/geometry_verification``
(writes ``results.json``; prints the tables).

Cost on one NGSolve thread: level 0 about 10 s, level 1 about 20 s (the order-2 prism meshes dominate).

Limits: the patch tests check the exact (affine) states only; the geometry of a curved contact side enters the 3D
contact operators through flat triangles. Import reads the solids and the names STEP keeps (BREP keeps none).
"""

from __future__ import annotations

import time
from pathlib import Path

from ngs_geomech.verification import geometry as vg
from ngs_geomech.verification.study import (
    convergence_entry,
    one_ngsolve_thread,
    report,
    study_cli,
    study_main,
)

STUDY = "geometry_verification"
LEVELS = {
    0: {"patch": {"maxh": 0.3, "fine": 0.17}, "arc_h": (0.4, 0.2, 0.1), "prism_h": (0.6, 0.3, 0.15)},
    1: {"patch": {"maxh": 0.2, "fine": 0.11}, "arc_h": (0.4, 0.2, 0.1, 0.05, 0.025), "prism_h": (0.4, 0.2, 0.1)},
}
"""Mesh sizes (m) per level: the patch test's cube and the hanging wall's contact side, the arc profile, the prism."""


def _patches(p: dict, metrics: dict, tables: dict) -> None:
    """The inclined fault patch tests (3D contact P1/P2, glued, symmetry; 2D contact, glued, symmetry)."""
    for order in (1, 2):
        r = vg.inclined_fault_patch(order=order, **p)
        tables[f"patch_3d_p{order}"] = r
        metrics[f"patch_3d_contact_pressure_dev_p{order}"] = r["max_deviation"]
        metrics[f"patch_3d_contact_u_error_p{order}"] = r["u_error"]
        metrics[f"patch_3d_contact_nodes_p{order}"] = r["nodes"]
        metrics[f"patch_3d_imbalance_p{order}"] = r["imbalance_rel"]
    for mode in ("glued", "symmetry"):
        r = vg.inclined_fault_patch(mode=mode, **p)
        metrics[f"patch_3d_{mode}_u_error"] = r["u_error"]
    for mode in ("contact", "glued", "symmetry"):
        r = vg.inclined_fault_patch(dim=2, mode=mode, dip=40.0, strike=180.0, maxh=p["maxh"] * 0.8,
                                    fine=p["fine"] * 0.8)
        tables[f"patch_2d_{mode}"] = r
        metrics[f"patch_2d_{mode}_u_error"] = r["u_error"]
        if mode == "contact":
            metrics["patch_2d_contact_pressure_dev"] = r["max_deviation"]


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw dicts of the verification functions (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {}
    with one_ngsolve_thread():
        tic = time.perf_counter()
        _patches(p["patch"], metrics, tables)
        timing["patch_s"] = time.perf_counter() - tic

        tic = time.perf_counter()
        r = vg.step_round_trip()
        tables["step"] = r
        metrics["step_volume_error"] = r["volume_error"]
        metrics["step_mesh_volume_error"] = r["mesh_volume_error"]
        metrics["step_flux_error"] = r["flux_error"]
        timing["step_s"] = time.perf_counter() - tic

        tic = time.perf_counter()
        for order, expected in ((1, 2), (2, 4)):
            r = vg.arc_profile(order=order, sizes=p["arc_h"])
            tables[f"arc_p{order}"] = r
            convergence.append(convergence_entry(f"arc_area_rel_error_p{order}", r["h"], r["dofs"], r["area_error"],
                                                 expected))
            convergence.append(convergence_entry(f"arc_roof_length_rel_error_p{order}", r["h"], r["dofs"],
                                                 r["length_error"], expected))
            metrics[f"arc_area_rel_error_p{order}"] = r["area_error"][-1]
        metrics["arc_occ_area_error"] = r["occ_area_error"]
        timing["arc_s"] = time.perf_counter() - tic

        tic = time.perf_counter()
        for name, axis in (("prism", None), ("oblique_prism", [0.3, 1.0, 0.2])):
            r = vg.arc_prism(axis=axis, sizes=p["prism_h"])
            tables[name] = r
            convergence.append(convergence_entry(f"{name}_volume_rel_error_p2", r["h"], r["dofs"], r["mesh_error"], 4))
            metrics[f"{name}_occ_volume_error"] = r["occ_error"]
            metrics[f"{name}_mesh_volume_error_p2"] = r["mesh_error"][-1]
        timing["prism_s"] = time.perf_counter() - tic
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing}
    return result, tables


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1 finer); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
