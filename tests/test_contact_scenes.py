"""Contact mechanics in scenes: problem (P) whole (heat, thermal stress, the lambda law and contact with
foundations) against a closed form, friction on a foundation, the contact output (boundary VTK, figures,
summary force balance), and the errors for bad contact input."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification.contact_scenes import heated_bar, heated_bar_scene


@pytest.mark.parametrize("lam", [1.0, 0.8, 1.3])
def test_heated_bar_between_foundations(one_thread, lam):
    """Thermal stress + lambda law + two Signorini contacts (semi-coercive along x): exact uniform pressure."""
    r = heated_bar(lam=lam)
    print(f"\nheated bar lam = {lam}: p_ref {r['p_ref'] / 1e6:.6f} MPa, max nodal error {r['p_error']:.1e}, "
          f"imbalance {r['imbalance_rel']:.1e}, {r['iterations']} secant iterations, "
          f"{r['contact_iterations']} active-set steps")
    assert r["p_ref"] > 1e7
    assert r["p_error"] < 1e-8
    assert r["imbalance_rel"] < 1e-8
    if lam != 1.0:
        assert r["iterations"] <= 40


def test_heated_bar_gap_stays_open(one_thread):
    """Expansion smaller than the gap: no pressure anywhere, finite displacements (the x translation is free
    and unloaded; it is fixed at the regularization's minimum-norm value)."""
    r = heated_bar(gap=1e-3)
    assert r["p_ref"] == 0.0
    assert r["p_left"] == [0.0, 0.0] and r["p_right"] == [0.0, 0.0]
    contact = r["summary"]["mechanics"]["contact"]["interfaces"]
    assert contact["right"]["nodes"]["open"] == contact["right"]["nodes"]["open"] + contact["right"]["nodes"]["slip"]


def _block_scene(push_ratio: float, **found) -> dict:
    p, mu, L, H = 5e6, 0.3, 1.0, 0.5
    return {
        "scene": {"name": "block"},
        "physics": {"mechanics": "static"},
        "mesh": {"maxh": 0.1},
        "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 0], "size": [L, H],
                    "boundaries": {"base": "ymin", "top": "ymax", "left": "xmin"}}],
        "materials": {"block": {"youngs_modulus": 10e9, "poisson_ratio": 0.25}},
        "boundary_conditions": {
            "base": {"foundation": {"point": [0, 0], "normal": [0, 1], "law": "coulomb", "friction": mu, **found}},
            "top": {"pressure": p},
            "left": {"traction": [push_ratio * mu * p * L / H, 0.0]},
        },
    }


def test_block_on_foundation_output(one_thread, tmp_path):
    """A block held only by a Coulomb foundation, pushed at half its capacity: the friction force balances
    the push; boundary VTK, the contact figure and the summary's force balance are written."""
    out = tmp_path / "block"
    r = run_scene(scene_from_dict(_block_scene(0.5)), out, progress=False)
    c = r.summary["mechanics"]["contact"]
    base = c["interfaces"]["base"]
    print(f"\nblock on foundation: friction force {base['tangential_force']:.6e} N/m (push 3.75e5), "
          f"imbalance {c['force_balance']['imbalance_rel']:.1e}, nodes {base['nodes']}")
    assert base["tangential_force"] == pytest.approx(0.5 * 0.3 * 5e6, rel=1e-9)
    assert base["normal_force"] == pytest.approx(5e6, rel=1e-9)
    assert base["resultant_on_side"]["x"] == pytest.approx(-0.5 * 0.3 * 5e6, rel=1e-9)
    assert c["force_balance"]["imbalance_rel"] < 1e-8
    assert base["nodes"]["stick"] > 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["mechanics"]["contact"]["interfaces"]["base"]["law"] == "coulomb"
    assert (out / "figures" / "contact_base.png").stat().st_size > 1000
    pvd = ET.parse(out / "block_contact_base.pvd").getroot()
    files = [d.get("file") for d in pvd.iter("DataSet")]
    assert files == ["block_contact_base_step00000.vtp"]
    vtp = ET.parse(out / files[0]).getroot()
    piece = next(vtp.iter("Piece"))
    npts = int(piece.get("NumberOfPoints"))
    arrays = {a.get("Name"): np.array(a.text.split(), dtype=float) for a in piece.find("PointData")}
    assert set(arrays) == {"pressure", "traction", "gap", "slip", "status", "bound"}
    assert npts == 11 and int(piece.get("NumberOfLines")) == 10
    assert np.all(arrays["pressure"] > 0) and np.all(np.isin(arrays["status"], [1.0, 2.0]))


def test_block_pulled_off_foundation_names_body(one_thread):
    scene = _block_scene(0.0)
    scene["boundary_conditions"]["top"] = {"traction": [0.0, 1e6]}       # pulls the block off
    with pytest.raises(SolverError, match=r"body block: translation along y is not held"):
        run_scene(scene_from_dict(scene), None, progress=False)


def test_block_pushed_beyond_friction_names_body(one_thread):
    with pytest.raises(SolverError, match=r"body block: translation along x is not held"):
        run_scene(scene_from_dict(_block_scene(1.5)), None, progress=False)


def _problems(data: dict) -> list[str]:
    with pytest.raises(SceneError) as exc:
        validate(scene_from_dict(data))
    return [p.item for p in exc.value.problems]


def test_contact_scene_validation():
    s = heated_bar_scene()
    left = s["boundary_conditions"]["left"]["foundation"]
    left.update(law="tresca")
    right = s["boundary_conditions"]["right"]["foundation"]
    right.update(normal=[0.0, 0.0], friction=-1.0, augmentation=0.0)
    items = _problems(s)
    assert "boundary_conditions.left.foundation.slip_bound" in items
    assert "boundary_conditions.right.foundation.normal" in items
    assert "boundary_conditions.right.foundation.friction" in items
    assert "boundary_conditions.right.foundation.augmentation" in items


def test_contact_keys_on_glued_interface_rejected():
    s = _block_scene(0.5)
    s["blocks"][0]["boundaries"]["mid"] = "xmax"
    s["blocks"].append({"name": "other", "shape": "rectangle", "origin": [1.0, 0], "size": [1.0, 0.5]})
    s["materials"]["other"] = {"youngs_modulus": 10e9, "poisson_ratio": 0.25}
    s["interfaces"] = [{"name": "joint", "blocks": ["block", "other"], "type": "glued", "law": "coulomb"}]
    assert "interfaces[0] (joint).law" in _problems(s)


def _two_blocks() -> dict:
    s = _block_scene(0.0)
    s["blocks"] = [{"name": "lower", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 0.5]},
                   {"name": "upper", "shape": "rectangle", "origin": [0, 0.5], "size": [1.0, 0.5],
                    "boundaries": {"top": "ymax"}},
                   {"name": "loose", "shape": "rectangle", "origin": [2.0, 0], "size": [0.5, 0.5]}]
    s["materials"] = {n: {"youngs_modulus": 10e9, "poisson_ratio": 0.25, "density": 2500.0}
                      for n in ("lower", "upper", "loose")}
    s["interfaces"] = [{"name": "joint", "blocks": ["upper", "lower"], "type": "contact"}]
    s["boundary_conditions"] = {"top": {"displacement": [0.0, 0.0]}}
    return s


def test_floating_body_without_contact_is_named(one_thread):
    """A block that touches no contact and no support: the error names it and its free motions."""
    with pytest.raises(SceneError, match=r"body loose is not held against translation along x"):
        run_scene(scene_from_dict(_two_blocks()), None, progress=False)


def test_hanging_body_pulled_off_by_gravity_is_named(one_thread):
    """The lower block hangs under the fixed upper one: contact cannot pull, the error names the body."""
    s = _two_blocks()
    s["blocks"].pop()
    s["materials"].pop("loose")
    s["mechanics"] = {"gravity": [0.0, -9.81]}
    with pytest.raises(SolverError, match=r"body lower: translation along y is not held"):
        run_scene(scene_from_dict(s), None, progress=False)


@pytest.mark.parametrize("law", ["frictionless", "coulomb"])
def test_block_resting_on_block(one_thread, law):
    """The upper block rests on the fixed lower one under gravity (held by the contact alone): the contact
    carries its weight, the two sides' forces are opposite, the global balance closes."""
    s = _two_blocks()
    s["blocks"].pop()
    s["materials"].pop("loose")
    s["blocks"][0]["boundaries"] = {"base": "ymin"}
    s["blocks"][1]["boundaries"] = {}
    s["mechanics"] = {"gravity": [0.0, -9.81]}
    s["interfaces"][0].update(law=law, **({"friction": 0.5} if law == "coulomb" else {}))
    s["boundary_conditions"] = {"base": {"displacement": [0.0, 0.0]}}
    r = run_scene(scene_from_dict(s), None, progress=False)
    c = r.summary["mechanics"]["contact"]
    joint = c["interfaces"]["joint"]
    weight = 1.0 * 0.5 * 2500.0 * 9.81
    print(f"\nstack ({law}): contact force {joint['normal_force']:.6f} N/m (weight {weight}), action-reaction "
          f"{joint['action_reaction']:.1e}, imbalance {c['force_balance']['imbalance_rel']:.1e}")
    assert joint["normal_force"] == pytest.approx(weight, rel=1e-9)
    assert joint["resultant_on_side"]["y"] == pytest.approx(weight, rel=1e-9)     # pushes the upper block up
    assert joint["action_reaction"] < 1e-10
    assert c["force_balance"]["imbalance_rel"] < 1e-8
    assert c["force_balance"]["support_reactions"][1] == pytest.approx(2 * weight, rel=1e-9)


def test_penalty_method_softens_by_the_closed_form(one_thread):
    """Plain penalty (method = 'penalty', augmentation c): each side penetrates p / c, so the heated bar's
    pressure is p_exact / (1 + 2 E' / (c L)) with E' = E / (1 - nu^2) (plane strain, sigma_yy = 0)."""
    E, nu, L = 20e9, 0.25, 1.0
    Ep = E / (1 - nu ** 2)
    for c in (1e10, 1e11):
        s = heated_bar_scene(method="penalty")
        for side in ("left", "right"):
            s["boundary_conditions"][side]["foundation"]["augmentation"] = c
        res = run_scene(scene_from_dict(s), None, progress=False)
        exact = heated_bar()["p_ref"]
        expect = exact / (1 + 2 * Ep / (c * L))
        p = res.mechanics.contact_output.latest[0]["pressure"]
        pen = res.summary["mechanics"]["contact"]["interfaces"]["left"]["max_penetration_m"]
        print(f"\npenalty c = {c:.0e} Pa/m: p {p.mean() / 1e6:.6f} MPa (exact constraint {exact / 1e6:.6f}), "
              f"penetration {pen:.3e} m = p/c {expect / c:.3e}")
        assert np.allclose(p, expect, rtol=1e-8)
        assert pen == pytest.approx(expect / c, rel=1e-8)


def test_uzawa_method_in_a_scene_matches_ssn(one_thread):
    """method = 'uzawa' (the seed's (2.66)) on the Coulomb block gives the semi-smooth Newton answer."""
    ref = run_scene(scene_from_dict(_block_scene(0.5)), None, progress=False)
    uz = run_scene(scene_from_dict(_block_scene(0.5, method="uzawa")), None, progress=False)
    a = ref.mechanics.contact_output.latest[0]
    b = uz.mechanics.contact_output.latest[0]
    steps = uz.summary["mechanics"]["contact"]["iterations_per_solve"][-1]
    print(f"\nUzawa in a scene: {steps} steps; max |dp| {np.max(np.abs(a['pressure'] - b['pressure'])):.2e} Pa, "
          f"max |dq| {np.max(np.abs(a['traction'] - b['traction'])):.2e} Pa")
    assert np.allclose(a["pressure"], b["pressure"], rtol=0, atol=1e-8 * 5e6)
    assert np.allclose(a["traction"], b["traction"], rtol=0, atol=1e-8 * 5e6)
    assert uz.summary["mechanics"]["contact"]["force_balance"]["imbalance_rel"] < 1e-8


def test_uzawa_non_convergence_names_the_scene_keys(one_thread):
    """Uzawa stopped by its step limit: the advice names the scene keys of the step and of the limit, and
    those keys act (the step given is the step used; a higher limit converges)."""
    s = _block_scene(0.5, method="uzawa", uzawa_step=3e10)
    s["mechanics"] = {"uzawa_max_steps": 100}
    with pytest.raises(SolverError, match=r"after 100 Uzawa steps .*rho 3e\+10 Pa/m\): lower "
                                          r"boundary_conditions\.base\.foundation\.uzawa_step \(.*\) or raise "
                                          r"mechanics\.uzawa_max_steps"):
        run_scene(scene_from_dict(s), None, progress=False)
    s["mechanics"] = {"uzawa_max_steps": 200}
    info = run_scene(scene_from_dict(s), None, progress=False).mechanics.solver.contact_infos[-1][-1]
    assert info.rho == [3e10] and 100 < info.iterations <= 200


def test_uzawa_must_be_used_on_every_contact():
    s = heated_bar_scene()
    s["boundary_conditions"]["left"]["foundation"]["method"] = "uzawa"
    assert "boundary_conditions.right.foundation.method" in _problems(s)


def test_axisymmetric_heated_cylinder_between_plates(one_thread):
    """Axisymmetric contact (weight r): a heated cylinder squeezed between two rigid plates, held along the
    axis by the contacts alone; the uniaxial closed form p = E (alpha dT - g0 / H) at every node."""
    from ngs_geomech.verification.contact_scenes import heated_cylinder

    r = heated_cylinder()
    print(f"\nheated cylinder (axisymmetric): p_ref {r['p_ref'] / 1e6:.6f} MPa, max nodal error {r['p_error']:.1e}, "
          f"imbalance {r['imbalance_rel']:.1e}")
    assert r["p_ref"] == pytest.approx(20e9 * (1e-5 * 60 - 1e-4))
    assert r["p_error"] < 1e-8
    assert r["imbalance_rel"] < 1e-8


def test_tresca_slip_bound_varying_along_the_interface(one_thread):
    """g_c(x) = 1 MPa (1 + x): a block dragged by a displacement slides everywhere, the friction force is
    int g_c dx = 1.5 MPa m over x in [0, 1]."""
    s = _block_scene(0.0, law="tresca", slip_bound="1e6*(1 + x)")
    s["boundary_conditions"]["base"]["foundation"].pop("friction")
    s["boundary_conditions"]["left"] = {"displacement": [1e-3, "free"]}
    r = run_scene(scene_from_dict(s), None, progress=False)
    base = r.summary["mechanics"]["contact"]["interfaces"]["base"]
    res = r.mechanics.contact_output.latest[0]
    print(f"\nTresca g_c(x): friction force {base['tangential_force']:.6e} N/m (exact 1.5e6), nodes {base['nodes']}")
    assert abs(base["tangential_force"]) == pytest.approx(1.5e6, rel=1e-9)
    assert base["nodes"]["stick"] == 0
    assert np.allclose(np.abs(res["traction"]), 1e6 * (1 + res["x"]), rtol=1e-9)


def test_fault_wedge_scene(one_thread):
    """The built-in scene with everything of (P): heat across the fault, thermal stress, gravity, the lambda law
    (secant loop) and a Coulomb fault holding a wedge that only contact supports; coarse."""
    from ngs_geomech.scene.parse import load_scene

    scene = load_scene("fault_wedge", ["mesh.maxh=80.0", "blocks.wedge.maxh=50.0", "mesh.order=1",
                                       "output.vtk=false", "output.figures=false"])
    r = run_scene(scene, None, progress=False)
    c = r.summary["mechanics"]["contact"]
    fault = c["interfaces"]["fault"]
    print(f"\nfault_wedge (coarse): {r.summary['mechanics']['iterations']} secant iterations, "
          f"{c['iterations_per_solve']} active-set steps, nodes {fault['nodes']}, imbalance "
          f"{c['force_balance']['imbalance_rel']:.1e}, action-reaction {fault['action_reaction']:.1e}")
    assert c["force_balance"]["imbalance_rel"] < 1e-8
    assert fault["action_reaction"] < 1e-10
    assert fault["nodes"]["stick"] > 0 and fault["nodes"]["slip"] > 0
    assert abs(fault["tangential_force"]) <= 0.6 * fault["normal_force"] * (1 + 1e-9)
    assert r.summary["mechanics"]["iterations"][-1] <= 30


def _gap_blocks(top: dict, law: str = "frictionless") -> dict:
    """An upper block held only by a contact across a 0.1 mm gap to a fixed lower block, loaded on top by
    ``top`` over t in [0, 1] (one step: solves at t = 0 and t = 1)."""
    return {"scene": {"name": "gap_blocks"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.25},
            "time": {"end": 1.0, "dt": 1.0},
            "blocks": [{"name": "lower", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 0.5],
                        "boundaries": {"base": "ymin", "lower_top": "ymax"}},
                       {"name": "upper", "shape": "rectangle", "origin": [0, 0.5001], "size": [1.0, 0.5],
                        "boundaries": {"top": "ymax", "upper_base": "ymin"}}],
            "materials": {n: {"youngs_modulus": 10e9, "poisson_ratio": 0.25} for n in ("lower", "upper")},
            "interfaces": [{"name": "joint", "blocks": ["upper", "lower"], "type": "contact", "law": law,
                            "sides": ["upper_base", "lower_top"], **({"friction": 0.3} if law == "coulomb" else {})}],
            "boundary_conditions": {"base": {"displacement": [0.0, 0.0]}, "top": top}}


@pytest.mark.parametrize("law", ["frictionless", "coulomb"])
def test_load_ramping_from_zero_starts_at_rest(one_thread, law):
    """A pressure P t on a block held only by a contact across a gap: at t = 0 the load is zero and u = 0
    (the unloaded rigid motion fixed at zero), not a singular system; at t = 1 the contact carries P."""
    r = run_scene(scene_from_dict(_gap_blocks({"pressure": "5e6*t"}, law)), None, progress=False)
    hist = r.summary["mechanics"]["contact"]["history"]
    assert [h["time_s"] for h in hist] == [0.0, 1.0]
    assert hist[0]["joint"]["normal_force"] == 0.0 and hist[0]["joint"]["nodes"]["stick"] == 0
    assert hist[1]["joint"]["normal_force"] == pytest.approx(5e6, rel=1e-9)


def test_unheld_contact_set_names_body_motion_load_and_reason(one_thread, monkeypatch):
    """Truly singular (a push beyond the friction capacity) with the solvability LP skipped, as the condensed
    path's inner problem does: the active-set iteration's own error names the body, the motion, the load's
    component along it and why the contacts do not hold it."""
    from ngs_geomech.contact.solver import ContactSolver

    monkeypatch.setattr(ContactSolver, "check_load", lambda *a, **k: None)
    s = _gap_blocks({"pressure": "5e6*t"}, "coulomb")
    s["blocks"][1]["boundaries"]["upper_left"] = "xmin"
    s["boundary_conditions"]["upper_left"] = {"traction": ["1e7*t", 0.0]}
    with pytest.raises(SolverError, match=r"body upper: translation along x is not held by the contact set \(load "
                                          r"component 5e\+06, .*\): its \d+ closed nodes? all slip: the load exceeds"):
        run_scene(scene_from_dict(s), None, progress=False)


def test_nodes_held_by_supports_are_marked_prescribed(one_thread, tmp_path):
    """Two blocks on symmetry planes (x = 0), a Coulomb bedding between them: at the bedding's node on the
    symmetry line both sides' tangential displacements are given, so its friction multiplier is undetermined
    (the support carries it). It is reported as 'prescribed' (status 3) with q = 0, its pressure kept (the
    normal displacement is free); in the .vtp too."""
    s = _two_blocks()
    s["blocks"].pop()
    s["materials"].pop("loose")
    s["blocks"][0]["boundaries"] = {"base": "ymin", "lower_left": "xmin"}
    s["blocks"][1]["boundaries"] = {"top": "ymax", "upper_left": "xmin", "upper_right": "xmax"}
    s["interfaces"][0].update(law="coulomb", friction=0.6)
    s["boundary_conditions"] = {"base": {"displacement": [0.0, 0.0]}, "lower_left": {"symmetry": True},
                                "upper_left": {"symmetry": True}, "top": {"pressure": 5e6},
                                "upper_right": {"traction": [-1e6, 0.0]}}
    s["output"] = {"figures": False}
    r = run_scene(scene_from_dict(s), tmp_path / "out", progress=False)
    res = r.mechanics.contact_output.latest[0]
    corner = np.isclose(res["x"], 0.0)
    nodes = r.summary["mechanics"]["contact"]["interfaces"]["joint"]["nodes"]
    print(f"\nsymmetry corner: p {res['pressure'][corner]} Pa, q {res['traction'][corner]} Pa, nodes {nodes}")
    assert res["status"][corner].tolist() == [3.0] and res["traction"][corner].tolist() == [0.0]
    assert res["pressure"][corner][0] > 0
    assert nodes["prescribed"] == 1 and nodes["slip"] + nodes["stick"] == int(np.sum(res["pressure"] > 0)) - 1
    vtp = ET.parse(next((tmp_path / "out").glob("*_contact_joint_step*.vtp"))).getroot()
    arrays = {a.get("Name"): np.array(a.text.split(), dtype=float) for a in next(vtp.iter("Piece")).find("PointData")}
    assert np.count_nonzero(arrays["status"] == 3.0) == 1 and np.all(np.isfinite(arrays["traction"]))


def _ramped_block(out_keys: dict) -> dict:
    s = _block_scene(0.5)
    s["time"] = {"end": 1.0, "dt": 0.5}
    s["boundary_conditions"]["top"] = {"pressure": "5e6*(1 + t)"}
    s["output"] = {"figures": False, **out_keys}
    return s


@pytest.mark.parametrize("keys, series", [({"vtk": False}, True), ({"vtk": False, "contact_vtp": False}, False)])
def test_contact_series_does_not_follow_output_vtk(one_thread, tmp_path, keys, series):
    """output.vtk = false drops the .vtu series only: the contact .vtp series (the only nodal multipliers)
    stays unless output.contact_vtp = false."""
    run_scene(scene_from_dict(_ramped_block(keys)), tmp_path / "out", progress=False)
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert not [n for n in names if n.endswith((".vtu", "block.pvd"))]
    vtp = [n for n in names if n.startswith("block_contact_base_step")]
    assert vtp == ([f"block_contact_base_step0000{k}.vtp" for k in range(3)] if series else [])
    assert ("block_contact_base.pvd" in names) == series


def test_solve_time_excludes_writing_the_series(one_thread, tmp_path, monkeypatch):
    """summary.json's solve_s leaves out the VTK and .vtp writing (output_s has it): writers slowed by 0.15 s
    a call (2 per output time, 2 output times in the steps: 0.6 s) add their time to output_s, not to solve_s;
    solve_s + output_s <= total_s."""
    import time

    from ngs_geomech.io.lines_vtk import LineSeries
    from ngs_geomech.io.vtk import VtkSeries

    def slow(write):
        def wrapped(self, *a, **k):
            time.sleep(0.15)
            return write(self, *a, **k)
        return wrapped

    monkeypatch.setattr(VtkSeries, "write", slow(VtkSeries.write))
    monkeypatch.setattr(LineSeries, "write", slow(LineSeries.write))
    run_scene(scene_from_dict(_ramped_block({})), tmp_path / "out", progress=False)
    w = json.loads((tmp_path / "out" / "summary.json").read_text())["wall_time_s"]
    print(f"\nwall times: {w}")
    assert w["output_s"] >= 6 * 0.15          # 3 output times (t = 0 included) x (1 .vtu + 1 .vtp)
    assert w["solve_s"] < 0.3
    assert w["solve_s"] + w["output_s"] <= w["total_s"]
