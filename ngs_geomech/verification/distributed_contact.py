"""Distributed contact against serial: a box resting on a box in 3D, the upper box held by the contact alone (a
floating body), pressed from above and, for the friction laws, pushed sideways within the friction capacity (a
stick zone and a slip zone), solved on a netgen distributed mesh and serially through the same path
(:func:`ngs_geomech.api.run`).

:func:`stack_scene` builds the scene; :func:`case_result` runs it (on the ranks of ``comm``, or serially) and
returns what a comparison needs: the summary's probes and contact figures, the nodal contact arrays with their
node coordinates, the Newton iterations and the per-rank memory; :func:`differences` compares two results node by
node (matched by coordinates). Nothing here writes files (the callers write their JSON)."""

from __future__ import annotations

import numpy as np

LAWS = {"frictionless": ({"law": "frictionless"}, None),
        "tresca": ({"law": "tresca", "slip_bound": 3e4}, [4e4, 0.0, 0.0]),
        "coulomb": ({"law": "coulomb", "friction": 0.4}, [1.2e5, 0.0, 0.0])}
"""Per law: the interface keys and the sideways traction on the upper box (Pa; None: no push). The pushes are
about 0.6 of the capacity (Tresca: g_c times the contact area 0.42 m^2; Coulomb: F_c times the normal force)."""

PROBES = {"ux_corner": ("displacement_x", [0.75, 0.65, 0.85]), "uz_corner": ("displacement_z", [0.75, 0.65, 0.85]),
          "uy_middle": ("displacement_y", [0.41, 0.37, 0.6]), "uz_lower": ("displacement_z", [0.52, 0.43, 0.3])}
"""Displacement probes (m) in both boxes, off the mesh's planes."""


def stack_scene(law: str, maxh: float = 0.3, order: int = 1, tolerance: float = 1e-12) -> dict:
    """The scene dict (module docstring) with the contact ``law``, mesh size ``maxh`` (m; the upper box 0.75 maxh:
    non-matching meshes), element ``order`` and the linear solver ``tolerance``. The Newton steps are iterative
    serially too (``solver.linear``), as they are on a distributed mesh: frictionless, nothing holds the upper box's
    sliding, which the iterative steps fix by projection and the direct ones by a shift (the two solutions differ
    by about 2e-7 of the displacement along that free motion)."""
    interface, push = LAWS[law]
    data = {"scene": {"name": f"stack_{law}", "dimension": "3d"},
            "physics": {"mechanics": "static"},
            "mesh": {"maxh": maxh, "order": order},
            "blocks": [{"name": "lower", "shape": "box", "origin": [0, 0, 0], "size": [1.0, 0.8, 0.5],
                        "boundaries": {"base": "zmin"}},
                       {"name": "upper", "shape": "box", "origin": [0.1, 0.1, 0.5], "size": [0.7, 0.6, 0.4],
                        "maxh": 0.75 * maxh, "boundaries": {"push": "xmin", "top": "zmax"}}],
            "materials": {"lower": {"youngs_modulus": 2e10, "poisson_ratio": 0.25, "density": 2500.0},
                          "upper": {"youngs_modulus": 3e10, "poisson_ratio": 0.3, "density": 2500.0}},
            "interfaces": [{"name": "joint", "blocks": ["upper", "lower"], "type": "contact", **interface}],
            "mechanics": {"gravity": [0.0, 0.0, -9.81]},
            "boundary_conditions": {"base": {"displacement": [0.0, 0.0, 0.0]}, "top": {"pressure": 2e5}},
            "solver": {"linear": "iterative", "tolerance": tolerance},
            "output": {"vtk": False, "figures": False,
                       "probes": [{"name": k, "quantity": q, "point": p} for k, (q, p) in PROBES.items()]}}
    if push is not None:
        data["boundary_conditions"]["push"] = {"traction": push}
    return data


def case_result(data: dict, comm=None) -> dict:
    """Run the scene ``data`` (on the ranks of the mpi4py communicator ``comm``, or serially) and return (on every
    rank) the probes, the contact summary, the nodal contact arrays of the last solve with their coordinates,
    the dofs and the per-rank peak memory (GiB)."""
    from ..api import run
    from ..parallel import peak_rss_gib
    from ..scene.parse import scene_from_dict

    res = run(scene_from_dict(data, source="distributed_contact"), None, progress=False, comm=comm)
    s = res.summary
    spec, latest = res.mechanics.contacts[0], res.mechanics.contact_output.latest[0]
    nodal = {k: np.asarray(latest[k], dtype=float).tolist() for k in ("pressure", "traction", "gap", "slip")}
    memory = comm.allgather(peak_rss_gib()) if comm is not None else [peak_rss_gib()]
    return {"dofs": s["mesh"]["dofs"], "ranks": s["mesh"].get("ranks", 1),
            "probes": {k: v[-1] for k, v in s["probe_series"].items() if k in PROBES},
            "contact": s["mechanics"]["contact"], "coords": np.asarray(spec.op.coords).tolist(), "nodal": nodal,
            "peak_rss_gib_per_rank": memory, "wall_s": s["wall_time_s"]["total_s"]}


def _by_coordinates(result: dict) -> np.ndarray:
    """The permutation sorting a result's nodes by their coordinates (rounded to 1e-9 m)."""
    xyz = np.round(np.asarray(result["coords"], dtype=float), 9)
    return np.lexsort(xyz.T[::-1])


def differences(got: dict, want: dict) -> dict:
    """Relative differences of ``got`` to ``want`` (each relative to the largest value of its kind): the probes
    (displacements), the nodal contact pressures and tractions (node by node, matched by coordinates), the
    normal and tangential forces, and whether the Newton iterations per solve and the node states agree."""
    def rel(a, b, scale=None) -> float:
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        s = scale if scale is not None else float(np.max(np.abs(b), initial=0.0))
        return float(np.max(np.abs(a - b), initial=0.0)) / max(s, 1e-300)

    pg, pw = _by_coordinates(got), _by_coordinates(want)
    if not np.allclose(np.asarray(got["coords"])[pg], np.asarray(want["coords"])[pw], atol=1e-9):
        raise AssertionError("distributed contact: the multiplier nodes differ from the serial run's")
    u_scale = max(abs(v) for v in want["probes"].values())
    p_scale = float(np.max(np.abs(want["nodal"]["pressure"]), initial=0.0))
    jg, jw = got["contact"]["interfaces"]["joint"], want["contact"]["interfaces"]["joint"]
    out = {"displacement": rel([got["probes"][k] for k in want["probes"]], list(want["probes"].values()), u_scale),
           "pressure": rel(np.asarray(got["nodal"]["pressure"])[pg], np.asarray(want["nodal"]["pressure"])[pw]),
           "traction": rel(np.asarray(got["nodal"]["traction"])[pg], np.asarray(want["nodal"]["traction"])[pw],
                           p_scale),
           "forces": max(rel(jg[k], jw[k], abs(jw["normal_force"])) for k in ("normal_force", "tangential_force"))}
    out["max"] = max(out.values())
    out["same_iterations"] = got["contact"]["iterations_per_solve"] == want["contact"]["iterations_per_solve"]
    out["same_states"] = jg["nodes"] == jw["nodes"]
    return out


def main(argv: list[str]) -> None:
    """``[mpiexec -n N] python -m ngs_geomech.verification.distributed_contact LAW MAXH ORDER OUT.json``: rank 0
    writes :func:`case_result` of :func:`stack_scene` to OUT.json."""
    import json

    from ..parallel import world

    law, maxh, order, out = argv[0], float(argv[1]), int(argv[2]), argv[3]
    comm = world()
    result = case_result(stack_scene(law, maxh, order), comm)
    if comm is None or comm.rank == 0:
        with open(out, "w") as fh:
            json.dump(result, fh)


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
