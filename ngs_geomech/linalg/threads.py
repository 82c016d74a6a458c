"""The threads of a run: NGSolve's (its TaskManager: assembly, its sparse factorizations, MKL's PARDISO) chosen by
the problem's size and the machine's load, and every BLAS the process loads at one thread.

Why (the ``threads`` table of ``studies/whole_process``, a 2-core machine): threads that wait spin, so with
another busy process on the machine a second thread makes a run slower at every size measured, many times slower
for small ones; BLAS threads did the same even on small dense work (SuperLU's multi-column solves, the contact
surface's systems), which never gains from them. On an idle machine a second NGSolve thread pays on large 3D
problems only. So a run takes one thread unless its size reaches :data:`MULTI_THREAD_SIZE` and the machine has
idle cores (its load average), and every BLAS runs one thread.
"""

from __future__ import annotations

import contextlib
import ctypes
import os

MULTI_THREAD_SIZE = {2: 1_000_000, 3: 30_000}
"""Per mesh dimension, the size (estimated elements before meshing times order^dim:
:func:`ngs_geomech.geometry.mesh.element_estimate`) from which a run without ``threads`` uses the idle cores; one
thread below. Chosen from the ``threads`` table of ``studies/whole_process`` (module docstring): on an idle machine
3D scenes above it gained, 2D ones little (so the 2D value lies beyond the sizes measured)."""

BLAS_THREADS = 1
"""Threads of every BLAS (OpenBLAS) of the process during a run (module docstring)."""


def cores() -> int:
    """The cores this process may run on (its CPU affinity; the machine's count where that is not known)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def idle_cores(load: float | None = None) -> int:
    """The cores of this process not busy with other work: :func:`cores` minus the machine's 1-minute load
    average (``load``; read from the system when None), rounded, at least 1."""
    if load is None:
        try:
            load = os.getloadavg()[0]
        except (AttributeError, OSError):
            load = 0.0
    return max(1, min(cores(), cores() - int(load + 0.5)))


def default_threads(size: float, dim: int, load: float | None = None) -> int:
    """NGSolve threads of a run of ``size`` (estimated elements times order^dim) in ``dim`` dimensions: one below
    :data:`MULTI_THREAD_SIZE`, the idle cores (:func:`idle_cores` at the machine's ``load``) from there."""
    return 1 if size < MULTI_THREAD_SIZE[dim] else idle_cores(load)


def openblas_libraries() -> list[tuple]:
    """(set, get) of every OpenBLAS loaded in the process (NGSolve's, numpy's, scipy's: from /proc/self/maps,
    Linux only)."""
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({line.split()[-1] for line in fh if "openblas" in line.lower()
                            and line.split()[-1].startswith("/")})
    except OSError:
        paths = []
    found = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix, suffix in (("openblas", ""), ("scipy_openblas", "64_"), ("scipy_openblas", "")):
            setter = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
            getter = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
            if setter is not None and getter is not None:
                found.append((setter, getter))
                break
    return found


@contextlib.contextmanager
def blas_threads(n: int = BLAS_THREADS):
    """Every OpenBLAS loaded in the process at ``n`` threads, restored on exit; one loaded inside (scipy's, when
    the solvers import it) starts with ``n`` too (OPENBLAS_NUM_THREADS, unless the user set it; it keeps ``n``).
    Yields how many libraries were set."""
    changed = []
    for setter, getter in openblas_libraries():
        changed.append((setter, int(getter())))
        setter(int(n))
    env = os.environ.get("OPENBLAS_NUM_THREADS")
    if env is None:
        os.environ["OPENBLAS_NUM_THREADS"] = str(int(n))
    try:
        yield len(changed)
    finally:
        for setter, old in changed:
            setter(old)
        if env is None:
            os.environ.pop("OPENBLAS_NUM_THREADS", None)
