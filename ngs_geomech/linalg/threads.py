"""The threads of a run: NGSolve's (its TaskManager: assembly, its sparse factorizations, MKL's PARDISO) chosen by
the problem's size, and every BLAS the process loads at one thread.

Measured on the shared 2-core machine (the ``threads`` table of ``studies/whole_process``): BLAS threads spin while
the other core is busy. contact_melting (897 dofs) took 2.1 s with one NGSolve and one BLAS thread, 24.5 s with the
defaults (two of each), 2.2 s with two NGSolve threads and one BLAS thread and 5.0 s with one NGSolve thread and
two BLAS threads. The dense work of the solvers (SuperLU's multi-column solves, the contact surface's small
systems) is too small to gain from BLAS threads, so a run keeps every BLAS at one thread. NGSolve's threads pay
only on large problems: below :data:`MULTI_THREAD_ELEMENTS` a run takes one.
"""

from __future__ import annotations

import contextlib
import ctypes
import os

MULTI_THREAD_ELEMENTS = {2: 2_000_000, 3: 150_000}
"""Estimated elements (:meth:`~ngs_geomech.geometry.assemble.GeometryModel.element_estimate`, per mesh dimension)
from which a run without ``threads`` uses every core of the process; one thread below. Chosen from the ``threads``
table of ``studies/whole_process`` (module docstring)."""

BLAS_THREADS = 1
"""Threads of every BLAS (OpenBLAS) of the process during a run (module docstring)."""


def cores() -> int:
    """The cores this process may run on (its CPU affinity; the machine's count where that is not known)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_threads(estimated_elements: float, dim: int) -> int:
    """NGSolve threads of a run of about ``estimated_elements`` elements in ``dim`` dimensions
    (:data:`MULTI_THREAD_ELEMENTS`)."""
    return cores() if estimated_elements >= MULTI_THREAD_ELEMENTS[dim] else 1


def _openblas_setters() -> list[tuple]:
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
    for setter, getter in _openblas_setters():
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
