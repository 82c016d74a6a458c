"""Heat crossing contact interfaces on a netgen distributed mesh or serially (run by
tests/test_mpi_heat_contact.py), through the run path (:func:`ngs_geomech.api.run`):

    mpiexec -n N python tests/mpi_cases/heat_contact_case.py CASE OUT.json     (N >= 3: distributed)

Cases (:data:`CASES`): a box on a box in 3D (non-matching meshes, Crank-Nicolson) with perfect contact (the mortar
coupling, P1 and P2) and a constant conductance; the same boxes pressed together by the mechanics with the power law
h = C p^m of the contact pressure (staggered coupling); side-by-side blocks in 2D whose interface ends on Dirichlet
boundaries (the cross points of the modified mortar space, P1 and P2), with a conductance plus linearized and exact
radiation (degC); k(T) (Newton's method) with perfect contact (2D) and a conductance (3D). Rank 0 writes the
temperatures at fixed points of both bodies, the interface heat flows of every step and the dofs
(:func:`case_result`)."""

from __future__ import annotations

import json
import sys

import numpy as np

MATERIAL = {"conductivity": 2.0, "rho_c": 2e6}
ELASTIC = {"youngs_modulus": 2e10, "poisson_ratio": 0.25, "density": 2500.0, "thermal_expansion": 1e-5,
           "stress_free_temperature": 0.0}


def stack_3d(order: int, interface: dict, mechanics: bool = False, maxh: float | None = None) -> dict:
    """Box 'upper' on box 'lower' (3D, non-matching meshes), 100 on top of the upper box, 0 under the lower one,
    Crank-Nicolson steps from 0; ``mechanics``: pressed by 2e5 Pa on top (frictionless contact, the upper box held
    by the contact alone) with thermal stresses, coupled by staggered steps. ``maxh``: the lower box's mesh size (m;
    the upper box's 0.75 of it; default 0.15 for P1, 0.25 for P2)."""
    maxh = maxh or (0.15 if order == 1 else 0.25)
    mats = {b: {**MATERIAL, **(ELASTIC if mechanics else {})} for b in ("lower", "upper")}
    mats["upper"]["conductivity"] = 3.0
    d = {"scene": {"name": "stack_heat", "dimension": "3d"},
         "physics": {"thermal": "transient"},
         "mesh": {"maxh": maxh, "order": order},
         "blocks": [{"name": "lower", "shape": "box", "origin": [0, 0, 0], "size": [1.0, 0.8, 0.5],
                     "boundaries": {"base": "zmin"}},
                    {"name": "upper", "shape": "box", "origin": [0.1, 0.1, 0.5], "size": [0.7, 0.6, 0.4],
                     "maxh": 0.75 * maxh, "boundaries": {"top": "zmax"}}],
         "materials": mats,
         "interfaces": [{"name": "joint", "blocks": ["upper", "lower"], "type": "contact", **interface}],
         "boundary_conditions": {"base": {"temperature": 0.0}, "top": {"temperature": 100.0}},
         "initial": {"temperature": 0.0},
         "time": {"end": 2e5, "dt": 5e4, "scheme": "crank_nicolson"},
         "solver": {"linear": "iterative", "tolerance": 1e-12},
         "output": {"vtk": False, "figures": False}}
    if mechanics:
        d["physics"].update(mechanics="static", coupling="staggered")
        d["interfaces"][0]["law"] = "frictionless"
        d["boundary_conditions"]["base"]["displacement"] = [0.0, 0.0, 0.0]
        d["boundary_conditions"]["top"]["pressure"] = 2e5
    return d


def blocks_2d(order: int, interface: dict, celsius: bool = False) -> dict:
    """Blocks [0, 1]^2 and [1, 2] x [0, 1] (non-matching meshes) touching along x = 1, whose ends lie on the
    Dirichlet bottoms (0); 100 on the left side; Crank-Nicolson steps from 0."""
    return {"scene": {"name": "blocks_heat", "dimension": "plane", "temperature_unit": "C" if celsius else "K"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": 0.15, "order": order},
            "blocks": [{"name": "left", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 1.0],
                        "boundaries": {"hot": "xmin", "left_bottom": "ymin"}},
                       {"name": "right", "shape": "rectangle", "origin": [1.0, 0], "size": [1.0, 1.0], "maxh": 0.1,
                        "boundaries": {"right_bottom": "ymin"}}],
            "materials": {"left": dict(MATERIAL), "right": {"conductivity": 1.0, "rho_c": 1e6}},
            "interfaces": [{"name": "joint", "blocks": ["left", "right"], "type": "contact", **interface}],
            "boundary_conditions": {"hot": {"temperature": 100.0}, "left_bottom": {"temperature": 0.0},
                                    "right_bottom": {"temperature": 0.0}},
            "initial": {"temperature": 0.0},
            "time": {"end": 4e5, "dt": 1e5, "scheme": "crank_nicolson"},
            "output": {"vtk": False, "figures": False}}


def with_kt(data: dict) -> dict:
    """``data`` with k(T) = k (1 + 0.004 (T - 0)) in its first material (Newton's method)."""
    first = next(iter(data["materials"].values()))
    first.update(conductivity_temperature_coefficient=0.004, reference_temperature=0.0)
    return data


CASES = {
    "3d_perfect_p1": lambda: stack_3d(1, {}),
    "3d_perfect_p2": lambda: stack_3d(2, {}),
    "3d_conductance": lambda: stack_3d(1, {"conductance": 200.0}),
    "3d_pressure_law": lambda: stack_3d(1, {"conductance_coefficient": 1e-3, "conductance_exponent": 1.0},
                                        mechanics=True, maxh=0.3),
    "2d_perfect_p1": lambda: blocks_2d(1, {}),
    "2d_perfect_p2": lambda: blocks_2d(2, {}),
    "2d_radiation": lambda: blocks_2d(2, {"conductance": 5.0, "emissivities": [0.8, 0.6],
                                          "radiation": "linearized"}, celsius=True),
    "2d_exact_radiation": lambda: blocks_2d(1, {"conductance": 5.0, "emissivities": [0.8, 0.6]}, celsius=True),
    "2d_kT_perfect": lambda: with_kt(blocks_2d(2, {})),
    "3d_kT_conductance": lambda: with_kt(stack_3d(1, {"conductance": 200.0})),
}
"""name: the scene dict."""


def points(dim: int) -> np.ndarray:
    """Points in both bodies off the meshes' planes (m)."""
    if dim == 3:
        return np.array([(x, y, z) for x in (0.23, 0.52, 0.71) for y in (0.31, 0.52) for z in (0.13, 0.37, 0.63,
                                                                                                   0.81)])
    return np.array([(x, y) for x in (0.13, 0.47, 0.91, 1.09, 1.53, 1.87) for y in (0.07, 0.41, 0.77)])


def case_result(name: str, comm=None) -> dict:
    """Run case ``name`` (on the ranks of ``comm``, or serially): the temperatures at :func:`points`, the interface
    heat flows per step (W), the dofs and the ranks."""
    from ngs_geomech import parallel
    from ngs_geomech.api import run
    from ngs_geomech.scene.parse import scene_from_dict

    data = CASES[name]()
    res = run(scene_from_dict(data, source=name), None, progress=False, comm=comm)
    mesh = res.forms.mesh
    T = parallel.point_values(mesh, res.forms.temperature(), points(mesh.dim))[:, 0]
    s = res.summary
    return {"T": T.tolist(), "flows": s["interface_heat_flow_W"], "dofs": s["mesh"]["dofs"],
            "ranks": s["mesh"].get("ranks", 1), "elements_per_rank": s["mesh"].get("elements_per_rank"),
            "conductance": s.get("interface_conductance")}


def main() -> None:
    from ngs_geomech.parallel import world

    comm = world()
    result = case_result(sys.argv[1], comm)
    if comm is None or comm.rank == 0:
        with open(sys.argv[2], "w") as fh:
            json.dump(result, fh)


if __name__ == "__main__":
    main()
