"""The threads of a run (ngs_geomech.linalg.threads): NGSolve's by the problem's size, every BLAS at one thread;
what the summary says about them and about the process's start."""

from __future__ import annotations

import ctypes
import os

import pytest

from ngs_geomech.linalg import threads as th
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict


def _block(maxh: float = 0.25, dimension: str = "plane") -> dict:
    shape = {"shape": "rectangle", "origin": [0, 0], "size": [1, 1]} if dimension == "plane" else \
        {"shape": "box", "origin": [0, 0, 0], "size": [1, 1, 1]}
    return {"scene": {"name": "block", "dimension": dimension}, "physics": {"thermal": "steady"},
            "mesh": {"maxh": maxh},
            "blocks": [{"name": "rock", **shape, "boundaries": {"hot": "xmin", "cold": "xmax"}}],
            "materials": {"rock": {"conductivity": 2.0}},
            "boundary_conditions": {"hot": {"temperature": 1.0}, "cold": {"temperature": 0.0}},
            "output": {"vtk": False, "figures": False}}


def test_default_threads_follow_the_size_and_the_load():
    n = th.cores()
    for dim, limit in th.MULTI_THREAD_SIZE.items():
        assert th.default_threads(limit - 1, dim, load=0.0) == 1
        assert th.default_threads(limit, dim, load=0.0) == n
        assert th.default_threads(limit, dim, load=float(n)) == 1          # every core busy: one thread
        assert th.default_threads(limit, dim, load=1.0) == max(1, n - 1)
    assert 1 <= n <= (os.cpu_count() or 1)
    assert 1 <= th.idle_cores() <= n


def test_blas_threads_set_and_restore():
    import numpy  # noqa: F401  (its OpenBLAS is loaded)

    setters = th.openblas_libraries()
    if not setters:
        pytest.skip("no OpenBLAS found in this process (not Linux, or another BLAS)")
    before = [int(get()) for _, get in setters]
    env = os.environ.get("OPENBLAS_NUM_THREADS")
    with th.blas_threads(1) as n:
        assert n == len(setters)
        assert all(int(get()) == 1 for _, get in setters)
        assert os.environ.get("OPENBLAS_NUM_THREADS") == (env if env is not None else "1")
    assert [int(get()) for _, get in setters] == before
    assert os.environ.get("OPENBLAS_NUM_THREADS") == env
    assert all(isinstance(s, ctypes._CFuncPtr) for s, _ in setters)


def test_a_small_run_takes_one_thread_and_says_so():
    res = run_scene(scene_from_dict(_block()), None, progress=False)
    assert res.summary["threads"] == {"ngsolve": 1, "blas": th.BLAS_THREADS}
    w = res.summary["wall_time_s"]
    if os.path.exists("/proc/self/stat"):
        assert 0.0 <= w["process_start_s"]                 # the process started before the run
    assert w["total_s"] > 0


def test_a_large_estimate_takes_the_idle_cores(monkeypatch):
    monkeypatch.setitem(th.MULTI_THREAD_SIZE, 2, 1)        # every mesh is "large"
    monkeypatch.setattr(th.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    res = run_scene(scene_from_dict(_block()), None, progress=False)
    assert res.summary["threads"]["ngsolve"] == th.cores()
    res = run_scene(scene_from_dict(_block()), None, progress=False, threads=1)   # asked: as asked
    assert res.summary["threads"]["ngsolve"] == 1
