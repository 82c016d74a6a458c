"""The stacked boxes of :mod:`ngs_geomech.verification.distributed_contact` (3D, the upper box held by the contact
alone, pressed and pushed sideways: stick and slip zones) with an ``[adaptivity]`` table, on a netgen distributed
mesh or serially (run by tests/test_mpi_adaptive_contact.py):

    mpiexec -n N python tests/mpi_cases/adaptive_contact_case.py LAW MAXH ADAPTIVITY_JSON OUT.json   (N >= 3)

Rank 0 writes :func:`adaptive_result` of the scene to OUT.json; the test calls it serially in its own process."""

from __future__ import annotations

import json
import sys

import numpy as np

from ngs_geomech.verification.distributed_contact import PROBES, stack_scene


def adaptive_scene(law: str, maxh: float, adaptivity: dict) -> dict:
    """The stack with the contact ``law`` and mesh size ``maxh`` (m), refined by ``adaptivity`` (the table)."""
    return {**stack_scene(law, maxh, 1), "adaptivity": dict(adaptivity)}


def adaptive_result(data: dict, comm=None) -> dict:
    """Run ``data`` (on the ranks of ``comm``, or serially) and return the adaptive steps, the mesh, the probes, the
    contact summary and the nodal contact arrays of the last solve with their coordinates (as
    :func:`ngs_geomech.verification.distributed_contact.case_result`, for its ``differences``)."""
    from ngs_geomech.api import run
    from ngs_geomech.scene.parse import scene_from_dict

    res = run(scene_from_dict(data, source="adaptive_contact"), None, progress=False, comm=comm)
    s = res.summary
    nodal = [{k: np.asarray(latest[k], dtype=float).tolist() for k in ("pressure", "traction", "gap", "slip")}
             for latest in res.mechanics.contact_output.latest]
    return {"adaptivity": s["adaptivity"], "mesh": {k: s["mesh"].get(k) for k in ("dofs", "elements", "vertices",
                                                                                "ranks", "elements_per_rank")},
            "dofs": s["mesh"]["dofs"],
            "probes": {k: v[-1] for k, v in s["probe_series"].items() if k in PROBES},
            "contact": s["mechanics"]["contact"], "nodal": nodal,
            "coords": [np.asarray(spec.op.coords).tolist() for spec in res.mechanics.contacts]}


def main(argv: list[str]) -> None:
    from ngs_geomech.parallel import world

    law, maxh, adaptivity, out = argv[0], float(argv[1]), json.loads(argv[2]), argv[3]
    comm = world()
    result = adaptive_result(adaptive_scene(law, maxh, adaptivity), comm)
    if comm is None or comm.rank == 0:
        with open(out, "w") as fh:
            json.dump(result, fh)


if __name__ == "__main__":
    main(sys.argv[1:])
