"""Shared fixtures."""

from __future__ import annotations

import ngsolve as ngs
import pytest


@pytest.fixture(scope="module")
def one_thread():
    """One NGSolve/netgen thread for a module of small problems: idle worker threads spin, which makes small
    runs many times slower on a busy machine. Use with ``pytestmark = pytest.mark.usefixtures("one_thread")``."""
    before = ngs.GetNumThreads()
    ngs.SetNumThreads(1)
    yield
    ngs.SetNumThreads(before)
