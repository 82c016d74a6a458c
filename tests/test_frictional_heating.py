"""Frictional heating of sliding contacts (:mod:`ngs_geomech.coupling.frictional`): a block sliding on a block (in
contact, and across a closed initial gap that passes no heat), on a rigid foundation, and on a nearly insulating
Stefan interface with a given partition, against the half-space
surface temperature of Carslaw and Jaeger (:mod:`ngs_geomech.verification.frictional_heating`); the energy balance
of the frictional heat with staggered coupling, in 3D and across a resumed run; negative work of the static law
clipped and reported; the keys refused where they do not apply."""

from __future__ import annotations

import json
import math

import pytest

from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.io.checkpoint import load_checkpoint
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import frictional_heating as fh

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_frictional_heating")]


def _effusivity_share() -> float:
    e1, e2 = (math.sqrt(m["conductivity"] * m["rho_c"]) for m in (fh.SLIDER, fh.BASE))
    return e1 / (e1 + e2)


def test_sliding_blocks_heat_like_half_spaces():
    r = fh.frictional_heating(levels=2, coarse=10, steps=5)
    print()
    for case, c in r["cases"].items():
        print(f"{case:10s} h {c['h']} steps {c['steps']}: surface temperature rel. errors "
              + ", ".join(f"{e:.3e}" for e in c["rel_error"]) + f"; observed order {c['orders'][0]:.2f}")
    print({k: v for k, v in r.items() if k != "cases"})
    orders = {"interface": 1.5, "gap": 1.5, "foundation": 1.5, "stefan": 1.0}      # measured 1.76, 1.8, 1.78, 1.34
    for case, c in r["cases"].items():
        assert c["rel_error"][-1] <= 2e-2
        assert c["orders"][0] >= orders[case]
    assert r["frictional_heating_rel_error"] <= 2e-2
    assert r["frictional_heating_energy_rel_error"] <= 1e-8
    assert r["frictional_heating_rate_rel_error"] <= 1e-8              # q = mu p V, slip rate V, traction mu p
    shares = {"interface": _effusivity_share(), "gap": _effusivity_share(), "foundation": 1.0,
              "stefan": fh.STEFAN_SHARE}
    for case, c in r["cases"].items():
        for run in c["runs"]:
            assert run["share_side"] == pytest.approx(shares[case], rel=1e-12)
            assert run["work_rel_error"] <= 1e-8                      # dissipated = mu p V W t


def test_staggered_coupling_hands_each_step_the_previous_work():
    r = fh.sliding_strip(h=fh.DEPTH / 10, steps=5, case="interface", coupling="staggered")
    print(f"\nstaggered: dissipated {r['dissipated']:.6g} J/m, entered {r['entered']:.6g}, owed {r['owed']:.6g}, "
          f"surface temperature rel. error {r['rel_error']:.3e}")
    assert r["owed"] == pytest.approx(r["dissipated"] / 5, rel=1e-9)  # the last step's work
    assert r["energy_rel_error"] <= 1e-12 and r["gain_rel_error"] <= 1e-12
    assert r["rel_error"] > 5e-2                                       # one step late


def test_frictional_heating_in_3d():
    r = fh.sliding_strip(h=fh.DEPTH / 5, steps=3, case="interface", dim3=True)
    print(f"\n3D: surface temperature rel. error {r['rel_error']:.3e}, heat density {r['heat_density_rel_error']:.1e},"
          f" energy {r['energy_rel_error']:.1e}, {r['ndof']} dofs, {r['wall_s']:.1f} s")
    assert r["heat_density_rel_error"] <= 1e-8 and r["traction_rel_error"] <= 1e-8
    assert r["energy_rel_error"] <= 1e-8 and r["gain_rel_error"] <= 1e-8
    assert r["rel_error"] <= 5e-2


def test_negative_work_of_the_static_law_is_clipped_and_reported():
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=4, case="interface")
    top = data["boundary_conditions"]["slider_top"]["displacement"]
    top[0] = f"{fh.SPEED!r}*(t+20) - {2 * fh.SPEED!r}*max(t - 50, 0)"     # back at V from t = 50 s: the slip shrinks
    res = run_scene(scene_from_dict(data), None, progress=False)
    c = res.summary["coupling"]["frictional_heating"]["contacts"]["sliding"]
    print(f"\nreversed slide: dissipated {c['dissipated']:.6g}, negative work clipped {c['negative_work']:.6g}; "
          f"{res.summary['warnings']}")
    forward = fh.FRICTION * fh.PRESSURE * fh.SPEED * fh.WIDTH * 50
    assert c["dissipated"] == pytest.approx(forward, rel=1e-8)          # the way back gives no heat
    assert c["negative_work"] == pytest.approx(forward, rel=1e-8)       # the static law's traction kept its sign
    assert c["negative_work_steps"] == 2
    assert any("interfaces.sliding: friction did negative work" in w for w in res.summary["warnings"])


def test_switched_off_the_coupling_has_no_frictional_source():
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=2, case="interface")
    data["interfaces"][0]["frictional_heating"] = False
    res = run_scene(scene_from_dict(data), None, progress=False)
    assert res.model.coupling.friction is None
    assert "frictional_heating" not in res.summary["coupling"]
    assert float(abs(res.model.thermal.T.vec.FV().NumPy()).max()) == 0.0


def test_coupled_run_with_frictional_heating_resumes_after_a_failed_step(tmp_path, monkeypatch):
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=8, case="stefan", coupling="staggered")
    data["output"]["every"] = 2
    ref = run_scene(scene_from_dict(data), tmp_path / "REF", progress=False)
    original = StefanSolver.step
    calls = {"n": 0}

    def step(self, t_old, t_new, extra_load=None):
        calls["n"] += 1
        if calls["n"] >= 6:
            raise SolverError("Stefan Newton step diverged (injected)")
        return original(self, t_old, t_new, extra_load)
    monkeypatch.setattr(StefanSolver, "step", step)
    with pytest.raises(SolverError, match="injected"):
        run_scene(scene_from_dict(data), tmp_path / "DIR", progress=False)
    monkeypatch.undo()
    (staging,) = [p for p in tmp_path.glob(".DIR.partial-*") if p.is_dir()]
    ck = load_checkpoint(staging / "checkpoint")
    assert "coupling/friction/sliding/owed" in ck.arrays
    run_scene(scene_from_dict(data), tmp_path / "DIR", progress=False, resume=True)
    a = json.loads((tmp_path / "REF" / "summary.json").read_text())["coupling"]["frictional_heating"]
    b = json.loads((tmp_path / "DIR" / "summary.json").read_text())["coupling"]["frictional_heating"]
    assert b["heat_per_step"] == a["heat_per_step"]
    assert b["energy"] == a["energy"]
    assert ref.summary["coupling"]["frictional_heating"]["energy"]["owed"] > 0


def _refused(data: dict) -> list[str]:
    with pytest.raises(SceneError) as exc:
        validate(scene_from_dict(data))
    return [str(p) for p in exc.value.problems]


@pytest.mark.parametrize("change, key, words", [
    (lambda d: d["physics"].update(coupling="none"), "interfaces[0] (sliding).frictional_heating", "coupling"),
    (lambda d: (d["interfaces"][0].update(law="frictionless"), d["interfaces"][0].pop("friction")),
     "interfaces[0] (sliding).frictional_heating", "frictional law"),
    (lambda d: d["interfaces"][0].update(friction=0.0), "interfaces[0] (sliding).frictional_heating",
     "frictional law"),
    (lambda d: d["interfaces"][0].update(frictional_heating=False, heat_partition=0.5),
     "interfaces[0] (sliding).heat_partition", "frictional_heating = true"),
    (lambda d: d["interfaces"][0].update(heat_partition=1.5), "heat_partition", "[0, 1]"),
    (lambda d: d["interfaces"][0].update(heat_partition="half"), "heat_partition", "effusivity"),
    (lambda d: d.update(adaptivity={"indicators": ["contact_zone"]}), "frictional_heating", "contact zones"),
])
def test_frictional_heating_keys_are_refused_where_they_do_not_apply(change, key, words):
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=2, case="interface")
    change(data)
    problems = _refused(data)
    assert any(p.split(":")[0].endswith(key) and words in p for p in problems), problems


def test_effusivity_is_refused_on_a_foundation_and_for_anisotropic_materials():
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=2, case="foundation")
    data["boundary_conditions"]["slider_bottom"]["foundation"]["heat_partition"] = "effusivity"
    assert any(p.startswith("boundary_conditions.slider_bottom.foundation.heat_partition") and "rigid" in p
               for p in _refused(data))
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=2, case="interface")
    data["materials"]["base"]["conductivity"] = [[4.0, 0.0], [0.0, 2.0]]
    with pytest.raises(SceneError, match=r"interfaces.sliding.heat_partition: 'effusivity' .* anisotropic"):
        run_scene(scene_from_dict(data), None, progress=False)


@pytest.mark.parametrize("mechanics", ["dynamic", "viscous"])
def test_rate_mechanics_heat_by_the_work_on_the_slip_increment(mechanics):
    data = fh.sliding_strip_scene(h=fh.DEPTH / 5, steps=4, case="interface", coupling="staggered")
    data["physics"]["mechanics"] = mechanics
    for m in data["materials"].values():
        m["density"] = 2500.0
        if mechanics == "viscous":
            m["viscosity_time"] = 1.0
    res = run_scene(scene_from_dict(data), None, progress=False)
    f = res.summary["coupling"]["frictional_heating"]
    c = f["contacts"]["sliding"]
    print(f"\n{mechanics}: dissipated {c['dissipated']:.6g} J/m (steady sliding: "
          f"{fh.FRICTION * fh.PRESSURE * fh.SPEED * fh.WIDTH * fh.END:.6g}), per step {f['heat_per_step']}")
    assert c["negative_work"] == 0.0                  # friction on the step's slip increment: W_j >= 0 node by node
    assert c["dissipated"] > 0 and f["energy"]["imbalance_rel"] <= 1e-12
