"""Every part of a run speaks the one interface of :class:`ngs_geomech.parts.Part`: the model of a scene holds
the parts it declares (heat or Stefan, static or dynamic mechanics, coupling), each advances over a step and
captures and restores its own state so that a repeated step gives the same numbers; the mesh policy follows
the scene's ``[adaptivity]``."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.adapt.contact_following import ContactFollowing
from ngs_geomech.adapt.front_following import FrontFollowing
from ngs_geomech.adapt.policy import FixedMesh
from ngs_geomech.adapt.stationary import PreAdapted, StationaryAdaptive
from ngs_geomech.coupling.run import CouplingRun
from ngs_geomech.dynamics.problem import DynamicsRun
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.heat.run import HeatRun
from ngs_geomech.mechanics.run import StaticMechanicsRun
from ngs_geomech.parts import Part, Step
from ngs_geomech.run.model import Model, mesh_policy
from ngs_geomech.scene.parse import load_scene
from ngs_geomech.stefan.problem import StefanRun
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

PLATE = ["mesh.maxh=30e3", "blocks.melt_zone.maxh=10e3", "time.dt=25000 year"]
CASES = {
    "canister": (["time.dt='5 day'", "time.dt_growth=1.0"], [HeatRun]),
    "melting_block": (["mesh.maxh=0.3"], [StefanRun]),
    "contact_melting": (["mesh.maxh=0.25", "time.dt=10 day"], [StefanRun, StaticMechanicsRun, CouplingRun]),
    "plate_collision": (PLATE, [StefanRun, StaticMechanicsRun, CouplingRun]),
    "plate_collision viscous": (PLATE + ["physics.mechanics='viscous'",
                                         "materials.mantle_wedge.viscosity_time='5000 year'"],
                                [StefanRun, DynamicsRun, CouplingRun]),
    "plate_collision dynamic": (PLATE + ["physics.mechanics='dynamic'"], [StefanRun, DynamicsRun, CouplingRun]),
}


def model_of(case: str) -> tuple:
    sets, _ = CASES[case]
    scene = load_scene(case.split()[0], sets)
    geo = validate(scene)
    return scene, Model(scene, geo, make_mesh(geo, scene.mesh))


def state(model: Model) -> dict:
    arrays = {}
    for p in model.parts:
        arrays.update({f"{p.key}:{k}": np.array(v) for k, v in p.capture()[0].items()})
    return arrays


@pytest.mark.parametrize("case", list(CASES))
def test_a_repeated_step_from_the_captured_state_gives_the_same_numbers(case):
    """start, one step, capture; a second step; restore; the second step again: the same state to the bit (one
    thread), for every part of the scene."""
    scene, model = model_of(case)
    assert [type(p) for p in model.parts] == CASES[case][1]
    assert all(isinstance(p, Part) and p.key for p in model.parts)
    assert len({p.key for p in model.parts}) == len(model.parts)
    assert set(model.fields) >= {n for p in model.parts for n in p.fields} | {"region"}
    t0, dt = scene.time.start, scene.time.dt
    model.start(t0, "start")
    first = Step(t0, t0 + dt, 0, True, "step 1")
    model.advance(first)
    model.record(first.b, True)
    captured = {p.key: p.capture() for p in model.parts}
    metas = {p.key: p.meta(captured[p.key][1]) for p in model.parts}
    second = Step(first.b, first.b + dt, 1, True, "step 2")
    model.advance(second)
    model.record(second.b, True)
    after = state(model)
    for p in model.parts:
        p.restore(captured[p.key][0], metas[p.key])
    model.advance(second)
    model.record(second.b, True)
    again = state(model)
    assert after.keys() == again.keys()
    for k in after:
        assert np.array_equal(after[k], again[k]), k
    summary = {}
    for p in model.parts:
        summary.update(p.summary())
    assert summary, "the parts report nothing"


@pytest.mark.parametrize("scene, sets, policy", [
    ("plate_collision", [], FixedMesh),
    ("plate_collision", ["adaptivity.indicators=['contact_zone']"], ContactFollowing),
    ("heated_rock", ["adaptivity.estimator='zz'"], StationaryAdaptive),
    ("melting_block", ["adaptivity.indicators=['phase_front']"], FrontFollowing),
    ("canister", ["adaptivity.estimator='zz'"], PreAdapted),
])
def test_the_mesh_policy_follows_the_scene(scene, sets, policy):
    assert type(mesh_policy(load_scene(scene, sets), None, None)) is policy
