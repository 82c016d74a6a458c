"""The thermo-elastic box (:mod:`ngs_geomech.verification.scaling`) on a netgen distributed mesh with PETSc's GAMG
(run by tests/test_petsc_gamg.py):

    mpiexec -n N python tests/mpi_cases/gamg_case.py MAXH ORDER DIM OUT.json

Rank 0 writes OUT.json: the CG iterations of the heat and elastic solves and T, u at :data:`POINTS` (combined from
the ranks whose part holds them)."""

from __future__ import annotations

import json
import sys

import netgen.meshing as ngm
import ngsolve as ngs
import numpy as np

from ngs_geomech.parallel import point_values
from ngs_geomech.verification.scaling import make_box_mesh, thermoelastic_box


def points(dim: int) -> np.ndarray:
    """Sample points (m) inside the box, off the planes where netgen may put vertices and faces."""
    if dim == 3:
        pts = np.array([(x, y, z) for x in np.linspace(0.1, 1.9, 5) for y in (0.2, 0.8) for z in (0.3, 0.7)])
        return pts + np.array([0.01234, 0.00711, -0.00937])
    return np.array([(x, y) for x in np.linspace(0.1, 1.9, 7) for y in (0.2, 0.5, 0.8)]) + np.array([0.0123, 0.0071])


def sample(mesh, r: dict, dim: int) -> np.ndarray:
    """(n, 1 + dim) values of T and u at :func:`points`."""
    pts = points(dim)
    return np.hstack([point_values(mesh, r["heat"].temperature(), pts),
                      point_values(mesh, r["elastic"].displacement(), pts)])


def main() -> None:
    from mpi4py import MPI  # after ngs_geomech: rank 0's MPI waits sleep (ngs_geomech.parallel)

    maxh, order, dim, out = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    comm = MPI.COMM_WORLD
    ngs.SetNumThreads(1)
    if comm.rank == 0:
        mesh = ngs.Mesh(make_box_mesh(maxh, order, dim).ngmesh.Distribute(comm))
    else:
        mesh = ngs.Mesh(ngm.Mesh.Receive(comm))
    r = thermoelastic_box(maxh, order, "iterative", dim=dim, mesh=mesh, keep=True, preconditioner="gamg", tol=1e-12)
    vals = sample(mesh, r, dim)
    if comm.rank == 0:
        with open(out, "w") as fh:
            json.dump({"cg_heat": r["cg_heat"], "cg_elastic": r["cg_elastic"], "values": vals.tolist(),
                       "dofs": int(r["heat"].X.ndofglobal + r["elastic"].X.ndofglobal)}, fh)


if __name__ == "__main__":
    main()
