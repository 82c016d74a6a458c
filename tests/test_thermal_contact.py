"""Contact conductance across contact interfaces (:mod:`ngs_geomech.heat.conductance`): the closed forms of
:mod:`ngs_geomech.verification.thermal_contact` (two slabs, a Hertz contact with h = C p^m, a gap closing under
thermal expansion, gas conduction and radiation across an open gap), the scene keys' validation, the warning for a
closed interface that carries no heat, and that scenes without the keys are solved as before."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from ngs_geomech.errors import SceneError
from ngs_geomech.heat.conductance import (
    ConstantConductance,
    ContactNodes,
    InterfaceConductance,
    PowerLawConductance,
    TableConductance,
    heatless_closed,
)
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import thermal_contact as tc

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_thermal_contact")]


@pytest.mark.parametrize("kw", [{}, {"order": 2}, {"dimension": "axisymmetric"}, {"dimension": "3d", "maxh": 0.2},
                                {"stefan": True}, {"h": 1e5}])
def test_two_slabs_jump_and_flux_match_the_closed_form(kw):
    r = tc.two_slabs(**kw)
    print(f"\ntwo slabs {kw}: q {r['q_num']:.10g} (closed form {r['q_ref']:.10g}), jump error "
          f"{r['jump_max_error']:.2e}, flow error {r['flow_rel_error']:.2e}")
    assert r["conductance_rel_error"] <= 1e-6


def test_heat_across_a_hertz_contact_follows_the_pressure_law():
    """h = C p^m with the mechanics' nodal pressure: the heat flow against the integral of h(p(x)) dT of the
    Hertz pressure, converging under refinement of the contact (P2)."""
    a = tc.R_HERTZ / 50
    rs = [tc.hertz_conductance(exponent=0.95, h_contact=a / n, order=2) for n in (10, 20)]
    errs = [r["pressure_conductance_rel_error"] for r in rs]
    order = math.log(errs[0] / errs[1]) / math.log(2)
    print(f"\nHertz, h = C p^0.95: Q {rs[-1]['Q_num']:.6g} W/m (closed form {rs[-1]['Q_ref']:.6g}), errors "
          f"{errs[0]:.2e} (a/10), {errs[1]:.2e} (a/20), observed order {order:.2f}")
    assert errs[1] <= 1e-2 and errs[1] < errs[0]


@pytest.mark.parametrize("coupling", ["staggered", "iterated"])
def test_a_gap_closed_by_thermal_expansion_carries_heat_and_the_balance_closes(coupling):
    r = tc.gap_closing(coupling=coupling)
    print(f"\ngap closing ({coupling}): closed at mechanics solve {r['closing_step']}, flow while open "
          f"{r['flow_while_open']}, after {r['flow_after_closing']:.4g}, steady {r['flow_final']:.10g} (closed form "
          f"{r['flow_ref']:.10g}), imbalance {r['energy_imbalance_rel']:.2e}")
    assert r["closing_step"] is not None and r["closing_step"] > 0
    assert r["flow_while_open"] == 0.0 and r["flow_after_closing"] > 0
    assert r["steady_flow_rel_error"] <= 1e-8
    assert r["energy_imbalance_rel"] <= 1e-8
    assert r["warned_without_keys"] and not r["warned_with_keys"]


def test_a_gap_closed_by_thermal_expansion_conducts_in_a_stefan_scene():
    """The gap-closing scene solved by the Stefan solver (solid slabs): the conductance follows the mechanics there
    too, the interface passes heat, and the Stefan energy balance closes."""
    res = run_scene(scene_from_dict(tc.gap_closing_scene(stefan=True)), None, progress=False).summary
    st = res["stefan"]
    q_ref = tc.slab_flux(50.0, *(tc.SLABS[k] for k in ("L1", "L2", "k1", "k2", "T_a", "T_b"))) * tc.SLABS["H"]
    print(f"\nStefan gap closing: interface heat {st['interface_heat']['joint']:.6g} J/m, conductance "
          f"{st['interface_conductance']['joint']}, imbalance {st['energy']['imbalance_rel']:.2e}")
    assert st["interface_conductance"]["joint"]["state"] == "mechanics"
    assert st["interface_conductance"]["joint"]["conductance_min"] == 50.0
    assert st["interface_heat"]["joint"] > 0.9 * q_ref * 9e8 and st["energy"]["imbalance_rel"] <= 1e-8
    assert not any("the mechanics closes it" in w for w in res["warnings"])


@pytest.mark.parametrize("kw", [{}, {"emissivities": None}, {"gap_conductivity": None},
                                {"radiation": "linearized"}, {"stefan": True, "radiation": "linearized"}])
def test_gas_conduction_and_radiation_across_an_open_gap(kw):
    r = tc.gap_slabs(**kw)
    print(f"\nopen gap {kw}: q {r['q_num']:.10g} (closed form {r['q_ref']:.10g}), error {r['gap_flux_rel_error']:.2e}, "
          f"Newton iterations {r['newton_iterations_max']}")
    assert r["gap_flux_rel_error"] <= 1e-8
    if kw.get("radiation", "exact") == "exact" and not kw.get("stefan"):
        assert r["newton_iterations_max"] <= 4           # Newton on T^4 with its exact Jacobian


@pytest.mark.parametrize("order", [1, 2])
def test_crank_nicolson_steps_keep_the_body_balances(order):
    """With a source in one slab; P2: the balance sums the vertex dofs (the test function 1), not the bubbles."""
    d = tc.two_slabs_scene(h=20.0, order=order)
    d["physics"]["thermal"] = "transient"
    d["initial"] = {"temperature": 0.0}
    d["time"] = {"end": 4e5, "dt": 5e4, "scheme": "crank_nicolson"}
    d["sources"] = [{"region": "right", "density": 50.0}]
    summ = run_scene(scene_from_dict(d), None, progress=False).summary
    bal = summ["heat_balance"]
    print(f"\nCrank-Nicolson: imbalance {bal['imbalance_rel']:.2e}, interface heat "
          f"{bal['interface_heat']['joint']:.6g} J/m")
    assert bal["imbalance_rel"] <= 1e-8
    assert bal["bodies"]["left"]["interface_heat_in"] == pytest.approx(-bal["interface_heat"]["joint"])


def test_laws():
    spec = InterfaceConductance("i", "m", "s", law=PowerLawConductance(2.0, 0.5), gap_conductivity=0.1,
                                minimum_gap=1e-3)
    h = spec.conductance(np.array([4.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.01]))
    assert h == pytest.approx([2 * 2 + 100, 100, 10])
    table = TableConductance((0.0, 1e6), (10.0, 30.0))
    assert table(np.array([-1.0, 5e5, 2e6])) == pytest.approx([10, 20, 30])
    assert not ConstantConductance(5.0).uses_pressure and table.uses_pressure


def test_a_closed_interface_without_conductance_warns():
    nodes = ContactNodes("side", np.array([0, 1]), np.array([0.0, 1e8]), np.array([1e-5, 0.0]))
    warned = heatless_closed({"gap": nodes}, [], set())
    assert len(warned) == 1 and "1e+08 Pa" in warned[0] and "no conductance keys" in warned[0]
    assert heatless_closed({"gap": nodes}, [], {"side"}) == []
    zero = InterfaceConductance("gap", "side", "other", law=TableConductance((0.0,), (0.0,)))
    assert "zero" in heatless_closed({"gap": nodes}, [zero], set())[0]


def test_a_steady_scene_warns_where_the_mechanics_closes_a_heatless_gap():
    """Steady heat with mechanics (no coupling): the hot block expands across the gap, which carries no heat."""
    d = tc.gap_closing_scene(h=None)
    d["physics"] = {"thermal": "steady", "mechanics": "static"}
    del d["time"], d["initial"]
    d["boundary_conditions"]["rs_t"] = {"temperature": 0.0}
    d["blocks"][1]["boundaries"]["rs_t"] = "ymax"
    summ = run_scene(scene_from_dict(d), None, progress=False).summary
    assert any("the mechanics closes it" in w for w in summ["warnings"]), summ["warnings"]


BASE = tc.two_slabs_scene()


@pytest.mark.parametrize("keys, item, message", [
    ({"conductance": -1.0}, "conductance", "must be positive"),
    ({"conductance": [[0, 1], [0, 2]]}, "conductance", "must increase"),
    ({"conductance": [[0, -1.0]]}, "conductance", ">= 0"),
    ({"conductance": 5.0, "conductance_coefficient": 1.0, "conductance_exponent": 1.0}, "conductance", "not both"),
    ({"conductance_coefficient": 1.0, "conductance_exponent": 0.9}, "conductance_coefficient", "physics.mechanics"),
    ({"conductance_exponent": 0.9}, "conductance_coefficient", "needs both"),
    ({"conductance": "perfect", "gap_conductivity": 0.1}, "gap_conductivity", "nothing adds"),
    ({"radiation": "linearized"}, "radiation", "emissivities"),
    ({"conductance": 5.0, "minimum_gap": 1e-5}, "minimum_gap", "gap_conductivity"),
    ({"emissivities": [0.5, 1.5]}, "emissivities", "(0, 1]"),
    ({"emissivities": [0.5, 0.5], "radiation": "linearized"}, "radiation", "use 'exact'"),
    ({"type": "glued", "conductance": 3.0}, "conductance", "contact interfaces"),
])
def test_bad_conductance_keys_are_refused_by_name(keys, item, message):
    d = copy.deepcopy(BASE)
    d["interfaces"][0].pop("conductance")
    d["interfaces"][0].update(keys)
    with pytest.raises(SceneError) as exc:
        validate(scene_from_dict(d))
    assert any(p.item.endswith(item) or f".{item}" in p.item for p in exc.value.problems), exc.value.problems
    assert message in str(exc.value)


def test_perfect_contact_across_an_initial_gap_is_refused():
    d = tc.gap_slabs_scene(gap_conductivity=None, emissivities=None)
    d["interfaces"][0]["conductance"] = "perfect"
    with pytest.raises(SceneError, match="needs touching blocks"):
        validate(scene_from_dict(d))


def test_a_contact_conductance_across_a_gap_nothing_closes_is_refused():
    d = tc.gap_slabs_scene(gap_conductivity=None, emissivities=None)
    d["interfaces"][0]["conductance"] = 50.0
    with pytest.raises(SceneError, match="would never act"):
        validate(scene_from_dict(d))


def test_exact_radiation_is_refused_in_stefan_scenes():
    with pytest.raises(SceneError, match="radiation = 'linearized'"):
        validate(scene_from_dict(tc.gap_slabs_scene(stefan=True, radiation="exact")))


def test_scenes_without_the_keys_keep_the_mortar_coupling():
    """An interface without conductance keys is coupled as before (mortar; 'perfect' is the same), and the run's
    summary has no conductance blocks."""
    runs = {}
    for perfect in (False, True):
        d = copy.deepcopy(BASE)
        d["interfaces"][0].pop("conductance")
        if perfect:
            d["interfaces"][0]["conductance"] = "perfect"
        runs[perfect] = run_scene(scene_from_dict(d), None, progress=False)
    for r in runs.values():
        f = r.model.thermal.forms
        assert f.setup.conductances == [] and f.interface_terms is None and f.coupling is f._mortar
        assert "heat_balance" not in r.summary and "interface_conductance" not in r.summary
    a, b = (r.model.thermal.forms.gf.vec.FV().NumPy() for r in runs.values())
    assert np.array_equal(a, b)


def test_a_coupled_conductance_run_resumes_to_the_uninterrupted_result(tmp_path, monkeypatch):
    """The gap-closing scene fails in its mechanics at step 6; resumed from the checkpoint it gives the
    uninterrupted run's interface flows and energy balance (the contact state comes back from the recorded
    mechanics)."""
    from ngs_geomech.errors import SolverError
    from ngs_geomech.mechanics.contact import ElasticContactSolver

    d = tc.gap_closing_scene(end=2e6)
    d["output"]["checkpoint_every"] = 2
    ref = run_scene(scene_from_dict(d), tmp_path / "REF", progress=False).summary
    original = ElasticContactSolver.solve
    calls = {"n": 0}

    def solve(self, where):
        calls["n"] += 1
        if calls["n"] == 7:
            raise SolverError(f"contact solve at {where} diverged (injected)")
        return original(self, where)
    monkeypatch.setattr(ElasticContactSolver, "solve", solve)
    with pytest.raises(SolverError):
        run_scene(scene_from_dict(d), tmp_path / "DIR", progress=False)
    monkeypatch.undo()
    res = run_scene(scene_from_dict(d), tmp_path / "DIR", progress=False, resume=True).summary
    assert res["resumed"]
    assert res["interface_heat_flow_W"]["ls"] == pytest.approx(ref["interface_heat_flow_W"]["ls"], rel=1e-10)
    for body, terms in ref["heat_balance"]["bodies"].items():
        assert res["heat_balance"]["bodies"][body]["interface_heat_in"] == pytest.approx(
            terms["interface_heat_in"], rel=1e-10)


def test_the_balance_continues_across_a_mesh_transfer():
    """A heat run carried to a finer mesh (as contact-zone following does): the flows and the body balances go
    on, the heat content the interpolation changed counted per body."""
    import dataclasses

    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.heat.run import HeatRun
    from ngs_geomech.parts import Step

    d = tc.two_slabs_scene(h=20.0)
    d["physics"]["thermal"] = "transient"
    d["initial"] = {"temperature": 0.0}
    d["time"] = {"end": 1e6, "dt": 1e5}
    scene = scene_from_dict(d)
    geo = validate(scene)
    old = HeatRun(scene, geo, make_mesh(geo, scene.mesh))
    old.start(0.0, "start")
    for k in range(3):
        old.advance(Step(k * 1e5, (k + 1) * 1e5, k, False, f"step {k}"))
    fine = make_mesh(geo, dataclasses.replace(scene.mesh, maxh=0.05), [(1.0, 0.2, 0.0, 0.03)])
    new = HeatRun(scene, geo, fine)
    _, _, commit = new.take_state(old, None)
    commit()
    for k in range(3, 6):
        new.advance(Step(k * 1e5, (k + 1) * 1e5, k, False, f"step {k}"))
    bal = new.summary()["heat_balance"]
    assert len(new.flows["joint__left"]) == 6
    assert bal["imbalance_rel"] <= 1e-8 and bal["bodies"]["left"]["heat_transferred"] != 0.0
