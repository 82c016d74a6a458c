"""Dynamic and viscous mechanics from scenes (issue 9 scene integration: physics.mechanics = "dynamic" |
"viscous", material viscosity_time / prony, [dynamics], initial.velocity): a Kelvin-Voigt block creeping under a
constant load against the discrete closed form, an elastic block thrown onto a rigid foundation (no energy
gain, the contact closes and opens), a failed dynamic run resumed from its checkpoint, and the bad keys."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ngs_geomech.dynamics.solver import DynamicSolver
from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

E, NU = 10e9, 0.25


def creep_scene(tau: float = 10.0, dt: float = 1.0, end: float = 30.0, prony=None) -> dict:
    mat = {"youngs_modulus": E, "poisson_ratio": NU, "viscosity_time": tau}
    if prony is not None:
        mat = {"youngs_modulus": E, "poisson_ratio": NU, "prony": prony}
    return {"scene": {"name": "creep"}, "physics": {"mechanics": "viscous"}, "mesh": {"maxh": 0.5},
            "time": {"end": end, "dt": dt},
            "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 1.0],
                        "boundaries": {"left": "xmin", "bottom": "ymin", "top": "ymax"}}],
            "materials": {"block": mat},
            "boundary_conditions": {"left": {"symmetry": True}, "bottom": {"symmetry": True},
                                    "top": {"traction": [0.0, -1e6]}},
            "output": {"vtk": False, "figures": False, "probes": [
                {"name": "uy_top", "quantity": "displacement_y", "point": [0.5, 1.0]}]}}


def test_kelvin_voigt_creep_follows_the_discrete_closed_form():
    """sigma = C (e + tau e_t) under a constant load: e_n = e_el (1 - (1 + dt/tau)^-n) by backward Euler
    (uniform state, exact in space)."""
    tau, dt = 10.0, 1.0
    res = run_scene(scene_from_dict(creep_scene(tau, dt)), None, progress=False)
    p = res.summary["probe_series"]
    t = np.array(p["times_s"]["uy_top"])
    uy = np.array(p["uy_top"], dtype=float)
    u_el = -1e6 * (1 - NU ** 2) / E                   # plane strain, sigma_xx = 0: e_yy = (1 - nu^2) sigma / E
    exact = u_el * (1 - (1 + dt / tau) ** (-np.round(t / dt)))
    err = float(np.max(np.abs(uy - exact)) / abs(u_el))
    print(f"\nKelvin-Voigt creep: u_y(top) at t = {t[-1]:g} s {uy[-1]:.6e} m, closed form {exact[-1]:.6e}; "
          f"max error / u_el {err:.1e}; dissipated {res.summary['mechanics']['viscous_dissipation_J']:.4e} J/m")
    assert err < 1e-9 and uy[0] == pytest.approx(0.0, abs=1e-15)
    assert res.summary["mechanics"]["solver"] == "viscous"


def impact_scene(end: float = 8e-4, dt: float = 2.5e-5) -> dict:
    """An elastic column (0.2 m x 1 m, steel-like, nu = 0) moving down at 1 m/s onto a rigid foundation 0.1 mm
    below: contact from 1e-4 s for about 2 L / c = 3.9e-4 s."""
    return {"scene": {"name": "impact"}, "physics": {"mechanics": "dynamic"}, "mesh": {"maxh": 0.1},
            "time": {"end": end, "dt": dt},
            "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 1e-4], "size": [0.2, 1.0],
                        "boundaries": {"bottom": "ymin", "left": "xmin"}}],
            "materials": {"block": {"youngs_modulus": 200e9, "poisson_ratio": 0.0, "density": 7800.0}},
            "initial": {"velocity": [0.0, -1.0]},
            "boundary_conditions": {"left": {"symmetry": True},
                                    "bottom": {"foundation": {"point": [0.0, 0.0], "normal": [0.0, 1.0]}}},
            "output": {"vtk": True, "figures": True, "every": 4}}


def test_block_impact_on_a_foundation_gains_no_energy(tmp_path):
    run_scene(scene_from_dict(impact_scene()), tmp_path / "OUT", progress=False)
    m = json.loads((tmp_path / "OUT" / "summary.json").read_text())["mechanics"]
    h = m["history"]
    closed = [e["bottom"]["nodes_closed"] for e in h]
    E0 = h[0]["total_J"]
    print(f"\nimpact: energy {E0:.4e} -> {h[-1]['total_J']:.4e} J/m, largest gain {m['energy_gain_rel_max']:.1e}, "
          f"closed nodes over time {closed}, switches {m['contact_switches']}")
    assert m["energy_gain_rel_max"] <= 1e-10
    assert max(closed) > 0 and closed[-1] == 0          # it hit the foundation and came off again
    assert m["contact_switches"]["node_switches_max"] <= 2
    assert h[-1]["total_J"] <= E0 * (1 + 1e-10)
    figs = {p.name for p in (tmp_path / "OUT" / "figures").iterdir()}
    assert "contact_bottom.png" in figs



@pytest.mark.parametrize("bottom, top", [("0.01*t", None), ("1e-3*t", "-1e-3*t")], ids=["pulled", "squeezed"])
def test_driven_column_gains_no_energy_beyond_the_dirichlet_work(bottom, top):
    """An elastic column (nu = 0) driven by prescribed displacements (its base pulled at 1 cm/s, or both ends
    pushed together): the energy it gains is the work of the reactions on the prescribed displacements, so the
    relative energy gain stays at round-off (it read 1 while that work was not counted)."""
    data = {"scene": {"name": "driven"}, "physics": {"mechanics": "dynamic", "plane_model": "plane_stress"},
            "mesh": {"maxh": 0.1}, "time": {"end": 2e-3, "dt": 5e-5},
            "blocks": [{"name": "bar", "shape": "rectangle", "origin": [0, 0], "size": [0.1, 1.0],
                        "boundaries": {"bottom": "ymin", "left": "xmin", "right": "xmax", "top": "ymax"}}],
            "materials": {"bar": {"youngs_modulus": 1e9, "poisson_ratio": 0.0, "density": 2500.0}},
            "boundary_conditions": {"left": {"symmetry": True}, "right": {"symmetry": True},
                                    "bottom": {"displacement": ["free", bottom]}},
            "output": {"every": 10}}
    if top:
        data["boundary_conditions"]["top"] = {"displacement": ["free", top]}
    m = run_scene(scene_from_dict(data), None, progress=False).summary["mechanics"]
    last = m["history"][-1]
    print(f"\ndriven column ({bottom}, {top}): energy {last['total_J']:.4e} J/m, Dirichlet work "
          f"{last['dirichlet_work_J']:.4e} J/m, largest relative gain {m['energy_gain_rel_max']:.1e}")
    assert last["total_J"] > 0 and last["dirichlet_work_J"] == pytest.approx(last["total_J"], rel=1e-8)
    assert m["energy_gain_rel_max"] < 1e-8

def test_failed_dynamic_run_resumes_to_the_same_state(tmp_path, monkeypatch):
    data = impact_scene(end=5e-4)
    data["output"]["vtk"] = False
    ref = run_scene(scene_from_dict(data), tmp_path / "REF", progress=False)
    original = DynamicSolver.step
    calls = {"n": 0}

    def step(self, dt):
        calls["n"] += 1
        if calls["n"] == 15:
            raise SolverError("injected")
        return original(self, dt)
    monkeypatch.setattr(DynamicSolver, "step", step)
    with pytest.raises(SolverError, match="injected"):
        run_scene(scene_from_dict(data), tmp_path / "DIR", progress=False)
    monkeypatch.undo()
    res = run_scene(scene_from_dict(data), tmp_path / "DIR", progress=False, resume=True)
    ua, ub = ref.mechanics.forms.gf.vec.FV().NumPy(), res.mechanics.forms.gf.vec.FV().NumPy()
    va, vb = ref.mechanics.solver.v, res.mechanics.solver.v
    print(f"\nresumed at step {res.summary['resumed'][0]['step']}: |u - u_ref| / |u_ref| "
          f"{np.linalg.norm(ub - ua) / np.linalg.norm(ua):.1e}, |v - v_ref| / |v_ref| "
          f"{np.linalg.norm(vb - va) / np.linalg.norm(va):.1e}")
    assert np.linalg.norm(ub - ua) <= 1e-10 * np.linalg.norm(ua)
    assert np.linalg.norm(vb - va) <= 1e-10 * np.linalg.norm(va)


@pytest.mark.parametrize("change, item, text", [
    ({"materials": {"block": {"youngs_modulus": E, "poisson_ratio": NU}}}, "physics.mechanics",
     "viscosity_time or prony"),
    ({"physics": {"mechanics": "dynamic"}}, "materials.block.density", "density"),
    ({"physics": {"mechanics": "static"}}, "materials.block.viscosity_time", "'dynamic' or 'viscous'"),
    ({"time": None}, "time", "needs [time]"),
    ({"materials": {"block": {"youngs_modulus": E, "poisson_ratio": NU, "prony": [
        {"modulus_ratio": -1.0, "relaxation_time": 1.0}]}}}, "materials.block.prony[0].modulus_ratio",
     "must be positive"),
])
def test_bad_dynamic_settings_are_named(change, item, text):
    data = creep_scene()
    for k, v in change.items():
        if v is None:
            data.pop(k)
        else:
            data[k] = v
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    assert any(p.item == item and text in p.message for p in info.value.problems), info.value.problems
