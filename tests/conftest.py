"""Shared fixtures."""

from __future__ import annotations

import os

import ngsolve as ngs
import pytest

from ngs_geomech.parallel import LAUNCH_ENVIRONMENT

# the tests' mpiexec runs (Open MPI): as root in containers, more ranks than cores
for _key, _value in LAUNCH_ENVIRONMENT.items():
    os.environ.setdefault(_key, _value)


@pytest.fixture(scope="module")
def one_thread():
    """One NGSolve/netgen thread for a module of small problems: idle worker threads spin, which makes small
    runs many times slower on a busy machine. Use with ``pytestmark = pytest.mark.usefixtures("one_thread")``."""
    before = ngs.GetNumThreads()
    ngs.SetNumThreads(1)
    yield
    ngs.SetNumThreads(before)
