"""One size of the scaling box in its own process (run by ``studies/scaling/run.py``), so that the process's peak
resident memory (max RSS, which counts NGSolve's C++ allocations; tracemalloc does not) belongs to that size:

    python studies/scaling/worker.py MAXH ORDER SOLVER THREADS OUT.json      (SOLVER: direct, iterative, bddc)

Writes OUT.json: the dict of :func:`ngs_geomech.verification.scaling.thermoelastic_box` without the solution
vectors, ``peak_rss_gib`` and, for the MPI comparison, ``points`` (:func:`mpi_box.sample`).
"""

from __future__ import annotations

import json
import resource
import sys
import time
from pathlib import Path

import ngsolve as ngs

from ngs_geomech.verification.scaling import thermoelastic_box

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main() -> None:
    maxh, order, solver, threads, out = (float(sys.argv[1]), int(sys.argv[2]), sys.argv[3], int(sys.argv[4]),
                                         sys.argv[5])
    ngs.SetNumThreads(threads)
    tic = time.perf_counter()
    # "bddc": CG with BDDC and its directly factored vertex problem (the comparison of the preconditioners)
    solver, pre = ("iterative", "bddc") if solver == "bddc" else (solver, "auto")
    with ngs.TaskManager():
        r = thermoelastic_box(maxh, order, solver, keep=True, preconditioner=pre)
    total = time.perf_counter() - tic
    from mpi_box import sample  # the same sample points as the MPI runs (mpi_box imports mpi4py lazily)

    points = sample(r["mesh"], r["heat"].temperature(), r["elastic"].displacement())
    data = {k: v for k, v in r.items() if k not in ("T", "u", "mesh", "heat", "elastic")}
    data.update(threads=threads, total_s=total, solve_s=r["heat_s"] + r["elastic_s"],
                peak_rss_gib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
                points={str(k): v for k, v in sorted(points.items())})
    with open(out, "w") as fh:
        json.dump(data, fh)


if __name__ == "__main__":
    main()
