"""Distributed meshes (MPI): the few collective operations the package needs (builds no mesh, writes no file).

A run under ``mpiexec -n N`` (N >= 2) works on a netgen distributed mesh: rank 0 meshes and sends the parts
(``ngmesh.Distribute(comm)``), the other ranks receive them (``Mesh.Receive(comm)``); netgen keeps **no
elements on rank 0**, so N ranks have N - 1 workers. Every rank then runs the same Python code on its part.
The rules that keep the ranks in step (all checked on this machine with NGSolve 6.2 and the Open MPI wheel;
with the mpich wheel, meshes split into more than 2 parts corrupted the heap or gave wrong solutions, even in a plain
NGSolve Poisson solve):

* Element loops (``mesh.Elements``, ``mesh.Boundaries(...).Elements()``) see this rank's part only: a fact
  about the whole mesh is gathered (:func:`allgather`) or reduced (:func:`allsum`, :func:`allmax`).
* ``Integrate(cf, mesh, VOL|BND, definedon=...)`` returns the global value on every rank, but
  ``Integrate(cf * dx, mesh)`` only this rank's part (silently); ``InnerProduct`` and ``Norm`` of NGSolve vectors
  are global; ``vec.FV().NumPy()`` is the local part. An assembled linear form is *distributed* (a dof shared by
  several ranks holds a part of its value on each); a GridFunction's vector is *cumulated* (every copy holds the
  value). A sum over dofs takes the distributed vector's local entries (:func:`allsum`), or the cumulated one's
  entries of the dofs this rank owns (:func:`owned`).
* Point evaluation raises on a rank whose part does not hold the point (``mesh(p).nr == -1``):
  :func:`point_values` evaluates where the part holds it and combines.
* Every rank must take the same branch around a collective call (assembly, a solve, ``Integrate``): a decision
  made from local data is reduced first.

On a serial mesh every function here is the plain serial operation (no mpi4py needed).
"""

from __future__ import annotations

import os

import numpy as np


def launched_by_mpiexec() -> bool:
    """True in a process started by ``mpiexec`` with more than one rank, read from what the launcher (mpich's
    hydra, Open MPI, PMIx) puts into the environment: no MPI is initialized."""
    for key in ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE"):
        if key in os.environ:
            return int(os.environ[key]) > 1
    return "MPI_LOCALNRANKS" in os.environ or "PMIX_RANK" in os.environ


LAUNCH_ENVIRONMENT = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
                      "PRTE_MCA_rmaps_default_mapping_policy": ":oversubscribe"}
"""What the package's own ``mpiexec`` launches (tests, studies) add to the environment: Open MPI may run as root
(containers) and more ranks than cores (correctness runs on small machines; timings then mean little)."""


def launch_environment() -> dict:
    """``os.environ`` with :data:`LAUNCH_ENVIRONMENT` added where not set (for ``subprocess`` calls of mpiexec)."""
    return {**LAUNCH_ENVIRONMENT, **os.environ}


RANK_VARIABLES = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK")
"""Where the launchers (mpich's hydra, Open MPI, PMIx) put a process's rank."""


def sleep_while_waiting_on_rank_zero() -> None:
    """In a process started by ``mpiexec`` as rank 0, before MPI starts: ask the MPI to sleep or yield in its waits.

    Rank 0 holds no elements and waits in MPI while the workers compute; MPICH's waits busy-poll and, with as many
    processes as cores, take a core from the workers (measured on 2 cores, 2 busy workers: rank 0 used 1.6 s of CPU
    in a 2 s barrier, 0.5 s with the sleeping wait). The workers keep the fast polling their own collectives need.
    MPICH sleeps (nanosleep), Open MPI yields the processor. A value set in the environment is kept; each MPI
    ignores the other's variable."""
    if not launched_by_mpiexec():
        return
    rank = next((os.environ[k] for k in RANK_VARIABLES if k in os.environ), None)
    if rank == "0":
        os.environ.setdefault("MPIR_CVAR_ENABLE_HEAVY_YIELD", "1")     # MPICH
        os.environ.setdefault("OMPI_MCA_mpi_yield_when_idle", "1")     # Open MPI


def world():
    """mpi4py's COMM_WORLD when this process is one of several MPI ranks, else None.

    Raises RuntimeError when started by mpiexec with several ranks but mpi4py is missing (the ranks would
    otherwise each run the whole job serially)."""
    if not launched_by_mpiexec():
        return None
    try:
        from mpi4py import MPI
    except ImportError as exc:
        raise RuntimeError("this process was started by mpiexec with several ranks, but mpi4py is not installed: "
                           "pip install -e '.[mpi]'") from exc
    comm = MPI.COMM_WORLD
    return comm if comm.size > 1 else None


def world_rank() -> int:
    """This process's rank in a distributed run (0 otherwise): only rank 0 prints and writes shared files."""
    comm = world()
    return 0 if comm is None else comm.rank


def peak_rss_gib() -> float:
    """This process's peak resident memory so far, GiB (Linux: ru_maxrss in KiB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def distributed(mesh) -> bool:
    """Whether ``mesh`` is a part of a distributed mesh."""
    return mesh.comm.size > 1


def comm(mesh):
    """The mesh's communicator as an mpi4py communicator (None on a serial mesh)."""
    return mesh.comm.mpi4py if distributed(mesh) else None


def allsum(mesh, value):
    """The sum over the ranks of a number or array (the value itself on a serial mesh), the same to the last bit on
    every rank: summed on rank 0 and broadcast (an all-reduce may round differently on different ranks, and a
    decision taken from such sums would part the ranks)."""
    if not distributed(mesh):
        return value
    from mpi4py import MPI

    c = comm(mesh)
    if np.ndim(value) == 0:
        return c.bcast(c.reduce(value.item() if isinstance(value, np.generic) else value, op=MPI.SUM, root=0), root=0)
    arr = np.ascontiguousarray(value, dtype=float)
    out = np.empty_like(arr)
    c.Reduce(arr, out, op=MPI.SUM, root=0)
    c.Bcast(out, root=0)
    return out


def allmax(mesh, value: float) -> float:
    """The largest of a number over the ranks (ranks without data pass -inf)."""
    if not distributed(mesh):
        return value
    from mpi4py import MPI

    return comm(mesh).allreduce(value, op=MPI.MAX)


def allmin(mesh, value: float) -> float:
    """The smallest of a number over the ranks (ranks without data pass +inf)."""
    if not distributed(mesh):
        return value
    from mpi4py import MPI

    return comm(mesh).allreduce(value, op=MPI.MIN)


def anyof(mesh, flag: bool) -> bool:
    """True on every rank when ``flag`` is True on some rank."""
    return bool(allmax(mesh, int(bool(flag))))


def allgather(mesh, obj) -> list:
    """``[obj of rank 0, obj of rank 1, ...]`` on every rank (``[obj]`` on a serial mesh)."""
    return comm(mesh).allgather(obj) if distributed(mesh) else [obj]


def concat(mesh, arr: np.ndarray, axis: int = 0) -> np.ndarray:
    """The local arrays of all ranks joined along ``axis``, on every rank (the array on a serial mesh)."""
    if not distributed(mesh):
        return arr
    parts = [np.asarray(a) for a in allgather(mesh, np.asarray(arr)) if np.asarray(a).size]
    return np.concatenate(parts, axis=axis) if parts else np.asarray(arr)


def owned(space) -> np.ndarray:
    """Boolean mask of the local dofs this rank owns (each global dof owned by exactly one rank; all True on a
    serial mesh): sums of cumulated vectors over ``owned`` entries count every dof once."""
    if not distributed(space.mesh):
        return np.ones(space.ndof, dtype=bool)
    return np.array(list(space.ParallelDofs().MasterDofs()), dtype=bool).reshape(space.ndof)


def point_values(mesh, cf, points: np.ndarray) -> np.ndarray:
    """Values of ``cf`` at ``points`` (n x dim, m): array (n, components), NaN where no part holds the point.

    Serial meshes evaluate directly (points outside the mesh give NaN); on a distributed mesh every rank
    evaluates the points its part holds and the values are combined on every rank (a point on a part boundary
    takes the value of the lowest rank holding it)."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    ncomp = cf.dim
    vals = np.full((len(points), ncomp), np.nan)
    if mesh.ne and len(points):
        coords = [points[:, k] for k in range(mesh.dim)]
        mips = mesh(*coords)
        inside = np.asarray(mips["nr"]) >= 0
        if inside.any():
            sub = mesh(*[c[inside] for c in coords])
            vals[inside] = np.asarray(cf(sub), dtype=float).reshape(int(inside.sum()), ncomp)
    return first_valid(mesh, vals)


def first_valid(mesh, vals: np.ndarray) -> np.ndarray:
    """Combine per-rank arrays of point values with NaN where a rank's part does not hold the point: every
    rank gets, per entry, the value of the lowest rank that has one (NaN when none has). Serial: ``vals``."""
    if not distributed(mesh):
        return vals
    vals = np.asarray(vals, dtype=float)
    out = np.full_like(vals, np.nan)
    for other in allgather(mesh, vals):
        fill = np.isnan(out) & ~np.isnan(other)
        out[fill] = other[fill]
    return out


class GlobalDofs:
    """A global numbering of the dofs of an H1 or VectorH1 ``space``, the same on every rank: scalar dof i of this
    rank's part is global scalar dof ``scalar[i]`` (NGSolve's ``EnumerateGlobally``: each rank's master dofs one
    contiguous range), vector dof (component c, scalar i) is global dof ``c * n_scalar + scalar[i]`` (component
    major, as NGSolve orders a serial VectorH1 space). On a serial mesh the numbering is the space's own.
    Creating it is collective over the mesh's ranks."""

    def __init__(self, space):
        self.space = space
        import ngsolve as ngs

        self.components = len(space.components) if isinstance(space, ngs.comp.ProductSpace) else 1
        comp = space.components[0] if self.components > 1 else space
        nc = comp.ndof
        if space.ndof != self.components * nc:
            raise AssertionError("GlobalDofs: the vector space's components differ in size")
        self.mesh = space.mesh
        if distributed(space.mesh):
            pardofs = comp.ParallelDofs()
            glob, count = pardofs.EnumerateGlobally(None)
            self.scalar = np.asarray(glob, dtype=np.int64)
            self.n_scalar = int(count)
            self.master = np.array(list(pardofs.MasterDofs()), dtype=bool) if nc else np.zeros(0, dtype=bool)
        else:
            self.scalar, self.n_scalar = np.arange(nc, dtype=np.int64), nc
            self.master = np.ones(nc, dtype=bool)
        c = np.repeat(np.arange(self.components), nc)
        self.vector = c * self.n_scalar + np.tile(self.scalar, self.components)
        """(space.ndof,) the global number of each local dof."""
        self.size = self.components * self.n_scalar
        """The number of global dofs."""

    @property
    def owned(self) -> np.ndarray:
        """Bool per local dof: this rank owns it (each global dof owned by exactly one rank)."""
        return np.tile(self.master, self.components)

    def gather(self, local: np.ndarray, cumulated: bool = True) -> np.ndarray:
        """The global array (size) of a local one, on every rank: a cumulated array (every copy of a shared dof
        holds the value: a GridFunction, Dirichlet values, a mask as 0/1) by its owned entries, a distributed one
        (an assembled load: the copies sum to the value) by the sum of all."""
        local = np.asarray(local, dtype=float)
        out = np.zeros(self.size)
        if cumulated:
            own = self.owned
            out[self.vector[own]] = local[own]
        else:
            np.add.at(out, self.vector, local)
        return allsum(self.mesh, out) if distributed(self.mesh) else out

    def local(self, glob: np.ndarray) -> np.ndarray:
        """This rank's (cumulated) entries of a global array (size, or size x k)."""
        return np.asarray(glob)[self.vector]
