"""Stability at the extremes (issue 8 section 2, ``studies/extremes``): the classification of a representative,
cheap subset of the study's cases (each run in the study's worker process with its wall-time limit), and
regression tests of the defects the study found and that were fixed."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from ngs_geomech.errors import SceneError
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.verification.nonlinear_law import bar_scene

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_extremes")]

_spec = importlib.util.spec_from_file_location(
    "study_extremes", Path(__file__).resolve().parents[1] / "studies" / "extremes" / "run.py")
extremes = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(extremes)

EXPECTED = {
    "poisson_0.3": "accurate",
    "poisson_0.4999": "accurate",
    "poisson_0.4999_u_deviatoric": "accurate",
    "poisson_0.5": "clear_error",
    "contrast_contact_1e+06": "accurate",
    "contrast_contact_1e-06": "accurate",
    "contrast_glued_1e6": "accurate",
    "gap_closes": "accurate",
    "gap_stays_open": "accurate",
    "overlap_foundation_heated": "accurate",
    "anisotropy_glued_10000": "accurate",
    "anisotropy_contact_1e4": "accurate",
    "lam_0.3_newton": "accurate",
    "lam_3_secant": "accurate",
    "lam_0": "clear_error",
    "stefan_0.01": "accurate",
    "stefan_100": "accurate",
    "stefan_dt_1e-3_tau": "accurate",
    "stefan_dt_1e3_tau": "accurate",
    "heat_dt_1e3_tau_cn": "accurate",
    "gc_0_sliding": "accurate",
    "gc_0_pushed": "clear_error",
    "gc_1e15_pushed": "accurate",
    "fc_0_pushed": "clear_error",
    "fc_0_sliding": "accurate",
    "fc_0.001_pushed": "accurate",
    "fc_0.01_pushed": "accurate",
    "gc_5e4_pushed": "accurate",
    "overlap_foundation_cold": "accurate",
    "fc_1_pushed_0.99": "accurate",
    "floating_push_over_capacity": "clear_error",
    "floating_pulled_off": "clear_error",
    "floating_no_contact": "clear_error",
    "aspect_bar_H1e-4": "accurate",
    "aspect_bar_H1e-5": "clear_error",
    "coarse_bar": "accurate",
    "scales_gravity": "accurate",
    "scales_contact": "accurate",
}
"""A cheap subset of the cases (about 5 s in all) and the outcome each must have."""

@pytest.fixture(scope="module")
def rows():
    return {r["case"]: r for r in extremes.run_cases(list(EXPECTED), level=0)}


@pytest.mark.parametrize("name", list(EXPECTED))
def test_case_outcome(rows, name):
    r = rows[name]
    print(f"\n{name}: {r['outcome']}, error {r['error']}, tol {r['tol']}, {r['wall_s']:.2f} s: {r['message'][:160]}")
    assert r["outcome"] == EXPECTED[name], r["message"]
    assert r["wall_s"] < 20.0


def test_every_case_is_classified_once():
    names = [c.name for c in extremes.CASES]
    assert len(names) == len(set(names))
    assert set(EXPECTED) <= set(names)


def test_classify_vague_and_timeout():
    """The classification rules: a stop without the expected words is vague, a timeout and a NaN are
    'nan_or_hang', an expected stop that does not come is too."""
    c = extremes.Case("x", "g", "p", lambda level: {}, expect=("body",))
    assert extremes.classify(c, {"kind": "exception", "type": "SolverError", "clear_type": True,
                                 "message": "no convergence", "wall_s": 1.0})["outcome"] == "nan_or_hang"
    assert extremes.classify(c, {"kind": "exception", "type": "SolverError", "clear_type": True,
                                 "message": "body b is not held", "wall_s": 1.0})["outcome"] == "clear_error"
    assert extremes.classify(c, {"kind": "exception", "type": "KeyError", "clear_type": False,
                                 "message": "body", "wall_s": 1.0})["outcome"] == "nan_or_hang"
    assert extremes.classify(c, {"kind": "timeout", "wall_s": 60.0})["outcome"] == "nan_or_hang"
    assert extremes.classify(c, {"kind": "result", "error": 0.0, "tol": 1.0, "wall_s": 1.0})["outcome"] \
        == "nan_or_hang"
    d = extremes.Case("y", "g", "p", lambda level: {})
    assert extremes.classify(d, {"kind": "result", "error": float("nan"), "tol": 1.0,
                                 "wall_s": 1.0})["outcome"] == "nan_or_hang"
    assert extremes.classify(d, {"kind": "result", "error": 0.5, "tol": 1.0, "checks": {"k": [2.0, 1.0]},
                                 "wall_s": 1.0})["outcome"] == "nan_or_hang"
    assert extremes.classify(d, {"kind": "result", "error": 0.5, "tol": 1.0, "wall_s": 1.0})["outcome"] \
        == "accurate"


def test_worker_time_limit():
    """A case over the wall-time limit is killed and reported as a hang; the next case runs in a new worker."""
    rows = extremes.run_cases(["coarse_bar"], level=0, limit=1e-3)
    assert rows[0]["outcome"] == "nan_or_hang" and "time limit" in rows[0]["message"]


# -- regression tests of the defects the study found ------------------------------------------------------

def test_unmeshed_thin_block_is_refused_by_name():
    """A 1 m x 10 um block with maxh = 1 m: netgen meshed 26 % of it and said so on stdout only; the elastic
    solve then failed with 'the matrix is singular: a body without enough displacement conditions' (wrong).
    Now the mesh step stops naming the block."""
    with pytest.raises(SceneError, match=r"blocks\.rock: netgen could not mesh this block \(the mesh covers"):
        run_scene(scene_from_dict(bar_scene(1.0, end_displacement=1e-3, H=1e-5, maxh=1.0)), None, progress=False)


def test_unsupported_second_body_is_refused_by_name():
    """Two blocks that do not touch, no contact: 'held' fixed at its base, 'loose' under gravity with no
    support. The rigid motions were checked for the whole mesh (held as soon as one body is), so the singular
    system was solved without a word; now each body is checked and the loose one is named."""
    data = {"scene": {"name": "loose"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.25},
            "blocks": [{"name": "held", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 0.5],
                        "boundaries": {"base": "ymin"}},
                       {"name": "loose", "shape": "rectangle", "origin": [0, 1.0], "size": [1.0, 0.5]}],
            "materials": {n: {"youngs_modulus": 10e9, "poisson_ratio": 0.25, "density": 2700.0}
                          for n in ("held", "loose")},
            "mechanics": {"gravity": [0.0, -9.81]},
            "boundary_conditions": {"base": {"displacement": [0.0, 0.0]}}}
    with pytest.raises(SceneError, match=r"not held against translation along x of body loose, translation "
                                         r"along y of body loose, rotation"):
        run_scene(scene_from_dict(data), None, progress=False)
    data["boundary_conditions"]["base"] = {"displacement": [0.0, 0.0]}
    data["blocks"][1]["boundaries"] = {"loose_base": "ymin"}
    data["boundary_conditions"]["loose_base"] = {"displacement": [0.0, 0.0]}
    r = run_scene(scene_from_dict(data), None, progress=False)     # both held: runs
    assert r.mechanics is not None
