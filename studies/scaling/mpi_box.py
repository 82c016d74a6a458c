"""The scaling box under MPI (run by ``studies/scaling/run.py``, or by hand):

    mpiexec -n N python studies/scaling/mpi_box.py MAXH ORDER OUT.json

Rank 0 meshes the box of :mod:`ngs_geomech.verification.scaling` and distributes it with netgen
(``ngmesh.Distribute(comm)`` / ``Mesh.Receive(comm)``; netgen keeps **no elements on rank 0**, so N ranks have N - 1
workers); every rank runs the heat and thermal-stress solves with preconditioned CG (BDDC), one NGSolve thread
each. Rank 0 writes OUT.json: dofs, wall times (rank 0, which waits for the workers), CG iterations and the
temperature and displacement at :data:`POINTS` gathered from the ranks whose part holds them.

Trap: keep no reference to the serial ``ngsolve.Mesh`` on rank 0 while distributing its ``ngmesh`` (``m =
make_box_mesh(...); Mesh(m.ngmesh.Distribute(comm))`` aborted in an MPI_Allreduce with a truncated message).
"""

from __future__ import annotations

import json
import sys
import time

import ngs_geomech  # noqa: F401,I001  (first: it sets rank 0's MPI waits to sleep before MPI starts)

try:                       # before ngsolve, as in NGSolve's MPI tutorials
    from mpi4py import MPI
except ImportError:        # the serial worker imports sample() only
    MPI = None
import netgen.meshing as ngm  # noqa: E402
import ngsolve as ngs  # noqa: E402
import numpy as np  # noqa: E402

from ngs_geomech.verification.scaling import make_box_mesh, thermoelastic_box  # noqa: E402

POINTS = np.array([(x, y, z) for x in np.linspace(0.1, 1.9, 7) for y in (0.2, 0.5, 0.8) for z in (0.2, 0.5, 0.8)])
POINTS += np.array([0.01234, 0.00711, -0.00937])   # off the planes where netgen may put vertices and faces
"""Sample points (m) inside the 2 x 1 x 1 box."""


def sample(mesh, T, u) -> dict:
    """{point index: (T, ux, uy, uz)} for the points of POINTS in this rank's part of the mesh."""
    if mesh.ne == 0:
        return {}
    mp = mesh(POINTS[:, 0], POINTS[:, 1], POINTS[:, 2])
    idx = np.nonzero(np.asarray(mp["nr"]) >= 0)[0]
    if idx.size == 0:
        return {}
    P = POINTS[idx]
    mp = mesh(P[:, 0], P[:, 1], P[:, 2])
    tv = np.asarray(T(mp)).ravel()
    uv = np.asarray(u(mp)).reshape(-1, 3)
    return {int(k): [float(tv[i]), *map(float, uv[i])] for i, k in enumerate(idx)}


def main() -> None:
    maxh, order, out = float(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    comm = MPI.COMM_WORLD
    ngs.SetNumThreads(1)
    tic = time.perf_counter()
    if comm.rank == 0:
        mesh = ngs.Mesh(make_box_mesh(maxh, order).ngmesh.Distribute(comm))
    else:
        mesh = ngs.Mesh(ngm.Mesh.Receive(comm))
    mesh_s = time.perf_counter() - tic
    comm.Barrier()
    tic = time.perf_counter()
    r = thermoelastic_box(maxh, order, "iterative", mesh=mesh, keep=True)
    comm.Barrier()
    solve_s = time.perf_counter() - tic
    vals = sample(mesh, r["heat"].temperature(), r["elastic"].displacement())
    gathered = comm.gather(vals, root=0)
    elements = comm.gather(mesh.ne, root=0)
    if comm.rank == 0:
        merged: dict = {}
        for d in gathered:
            merged.update(d)
        data = {"ranks": comm.size, "elements_per_rank": elements, "maxh": maxh, "order": order,
                "dofs_heat": int(r["heat"].V.ndofglobal), "dofs_elastic": int(r["elastic"].V.ndofglobal),
                "mesh_s": mesh_s, "solve_s": solve_s, "heat_s": r["heat_s"], "elastic_s": r["elastic_s"],
                "cg_heat": r["cg_heat"], "cg_elastic": r["cg_elastic"],
                "points": {str(k): v for k, v in sorted(merged.items())}}
        with open(out, "w") as fh:
            json.dump(data, fh)


if __name__ == "__main__":
    main()
