"""Starting MPI jobs from the tests: the ``mpiexec`` of this Python's environment (the Open MPI wheel) or of the
PATH, and the marks of a test that starts one."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest


def mpiexec() -> str | None:
    """The mpiexec to use, or None when it or mpi4py is not installed."""
    found = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or shutil.which("mpiexec")
    if found is None:
        return None
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        return None
    return found


needs_mpi = pytest.mark.skipif(mpiexec() is None, reason="mpiexec or mpi4py not installed")
one_mpi_job = pytest.mark.xdist_group("mpi")
"""One MPI job at a time (--dist loadgroup): 3 ranks already fill the 2 cores, and two jobs at once made each
several times slower (MPI ranks poll while they wait)."""
