"""The built-in scene ``melting_block`` with its ground surface as a heat transfer (Robin) condition (h = 20
W/(m^2 K) to the scene's surface temperature), plane, axisymmetric and plane with the silt's conductivities varying
with depth (``varying``: read at the vertices of every rank, one k_s on all of them), coarse and six steps of 5
days, on a serial or a netgen distributed mesh (:class:`ngs_geomech.stefan.problem.StefanRun`):

    mpiexec -n 3 python stefan_robin_case.py OUT.json     (netgen keeps no elements on rank 0: 2 workers)

writes, on rank 0, per variant the Newton iterations per step, the heat gain, the heat through the Robin boundary
and the melted volumes at the output times and the largest relative energy imbalance. :func:`solve` runs the same
serially when ``comm`` is None (tests/test_mpi_stefan_extended.py compares).
"""

from __future__ import annotations

import json
import sys

VARIANTS = ("plane", "axisymmetric", "varying")
DT = 5 * 86400.0
STEPS = 6


def scene(variant: str):
    from ngs_geomech.scene.parse import load_scene, scene_from_dict
    from ngs_geomech.scene.schema import to_dict

    data = to_dict(load_scene("melting_block", ["mesh.maxh=0.35"]))
    surface = data["boundary_conditions"]["surface"]["temperature"]
    data["boundary_conditions"]["surface"] = {"heat_transfer_coefficient": 20.0, "ambient_temperature": surface}
    data["scene"]["dimension"] = variant if variant == "axisymmetric" else "plane"
    if variant == "varying":            # the silt's conductivities of depth, the phases sharing the variation
        silt = data["materials"]["silt"]
        silt["conductivity"], silt["conductivity_liquid"] = "2.0*(1 - 0.2*y)", "1.4*(1 - 0.2*y)"
    return scene_from_dict(data)


def solve(comm, variant: str) -> dict:
    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.stefan.problem import StefanRun
    from ngs_geomech.validation.validate import validate

    sc = scene(variant)
    geo = validate(sc)
    mesh = make_mesh(geo, sc.mesh, comm=comm)
    run = StefanRun(sc, mesh, geo)
    run.set_initial(0.0)
    run.record(0.0)
    for k in range(STEPS):
        run.step(k * DT, (k + 1) * DT, f"step {k + 1}")
        run.record((k + 1) * DT)
    energy = run.summary()["stefan"]["energy"]
    return {"newton": run.iterations, "heat_gain": energy["heat_gain"], "robin": energy["heat_supplied_robin"],
            "melted_volume": run.summary()["stefan"]["melted_volume"], "imbalance_rel": energy["imbalance_rel_max"]}


if __name__ == "__main__":
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    data = {v: solve(comm if comm.size > 1 else None, v) for v in VARIANTS}
    if comm.rank == 0:
        with open(sys.argv[1], "w") as fh:
            json.dump(data, fh, indent=1)
