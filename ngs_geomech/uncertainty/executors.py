"""Where the samples run: in this process, in a pool of worker processes on this machine, or on the ranks of
an MPI job (``mpi4py.futures``: one machine or a cluster, started with ``mpiexec -n N python -m mpi4py.futures
-m ngs_geomech.cli uncertain ...``). Each yields the results of a batch of tasks as they finish."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from ..errors import SolverError

EXECUTORS = ("serial", "process", "mpi")


class Runner:
    """``as_completed(fn, tasks)`` yields ``fn(task)`` for each task as it finishes; ``close()`` ends the pool."""

    def __init__(self, kind: str = "serial", workers: int | None = None, threads: int | None = None):
        self.threads = threads
        if kind not in EXECUTORS:
            raise ValueError(f"executor {kind!r} is not one of {', '.join(EXECUTORS)}")
        self.kind = kind
        self.workers = workers
        self._pool: Executor | None = None
        if kind == "process":
            n = workers or max(1, multiprocessing.cpu_count())
            # spawn: a forked child would inherit NGSolve's task manager threads in an undefined state
            self._pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"))
            self.workers = n
        elif kind == "mpi":
            try:
                from mpi4py.futures import MPIPoolExecutor
            except ImportError as exc:   # pragma: no cover - depends on the install
                raise RuntimeError("executor 'mpi' needs mpi4py (pip install -e '.[mpi]')") from exc
            self._pool = MPIPoolExecutor(max_workers=workers)
            self.workers = workers or getattr(self._pool, "num_workers", None)
        else:
            self.workers = 1

    @property
    def threads_per_task(self) -> int | None:
        """NGSolve threads a task may use: one in a pool (the pool is the parallelism); serially ``threads``
        (None: by the problem's size, :func:`ngs_geomech.linalg.threads.default_threads`)."""
        return self.threads if self.kind == "serial" else 1

    def as_completed(self, fn: Callable[[dict], dict], tasks: Iterable[dict]) -> Iterator[dict]:
        tasks = list(tasks)
        if self._pool is None:
            for t in tasks:
                yield fn(t)
            return
        pending = {self._pool.submit(fn, t) for t in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in done:
                    try:
                        result = f.result()
                    except BrokenProcessPool as exc:
                        raise SolverError(f"a worker process of the {self.kind} pool died ({exc}); the samples "
                                          "finished so far are kept in samples.jsonl: rerun with --resume (with "
                                          "fewer --workers if memory ran out)") from exc
                    yield result
        finally:
            for f in pending:
                f.cancel()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
