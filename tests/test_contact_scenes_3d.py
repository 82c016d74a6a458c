"""Contact mechanics in 3D scenes (frictionless): a heated bar between two rigid plane foundations against
the closed form, two stacked boxes held by a contact interface (force balance, boundary VTK with triangles),
and the validation of what 3D does not do (Uzawa). 3D friction: tests/test_contact_friction_3d.py."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.io.lines_vtk import polyline_vtp
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification.contact_scenes import heated_bar_3d, heated_bar_3d_pressure, heated_bar_3d_scene

pytestmark = pytest.mark.usefixtures("one_thread")

E, NU, ALPHA, DT, GAP, L, H, W = 20e9, 0.25, 1e-5, 60.0, 1e-4, 1.0, 0.4, 0.4


def test_heated_bar_3d_closed_form():
    """Uniaxial stress (free lateral faces): p = E (alpha dT - gap / L), e_yy = e_zz = alpha dT + nu p / E."""
    p, eyy = heated_bar_3d_pressure(gap=GAP, dT=DT, L=L, E=E, nu=NU, alpha=ALPHA)
    assert p == pytest.approx(E * (ALPHA * DT - GAP / L), rel=1e-14)
    # Hooke's law with sigma_yy = sigma_zz = 0, sigma_xx = -p reproduces both strains
    exx = -p / E + ALPHA * DT
    assert exx == pytest.approx(GAP / L, rel=1e-12)
    assert eyy == pytest.approx(ALPHA * DT + NU * p / E, rel=1e-14)
    assert heated_bar_3d_pressure(gap=1e-3, dT=DT, L=L, E=E, nu=NU, alpha=ALPHA)[0] == 0.0


@pytest.mark.parametrize("order", [1, 2])
def test_heated_bar_3d_between_foundations(order):
    """Heat (uniform T), thermal stress and two Signorini contacts with rigid planes (the bar is held along x
    by the contacts alone): the exact uniform pressure at every node, the lateral strains, the balance."""
    r = heated_bar_3d(order=order)
    c = r["summary"]["mechanics"]["contact"]
    print(f"\n3D heated bar P{order}: p_ref {r['p_ref'] / 1e6:.6f} MPa, max nodal error {r['p_error']:.1e}, "
          f"imbalance {r['imbalance_rel']:.1e}, {r['contact_iterations']} active-set steps, "
          f"e_yy {r['e_yy']:.12e} e_zz {r['e_zz']:.12e} (ref {r['e_yy_ref']:.12e})")
    assert r["p_ref"] == pytest.approx(1e7, rel=1e-12)
    assert r["p_error"] < 1e-8
    assert r["imbalance_rel"] < 1e-8
    assert r["e_yy"] == pytest.approx(r["e_yy_ref"], rel=1e-8)
    assert r["e_zz"] == pytest.approx(r["e_yy_ref"], rel=1e-8)
    fb = c["force_balance"]
    assert fb["directions"] == ["x", "y", "z"] and fb["units"] == "N"
    left, right = c["interfaces"]["left"], c["interfaces"]["right"]
    assert left["normal_force"] == pytest.approx(r["p_ref"] * H * W, rel=1e-9)
    assert left["resultant_on_side"]["x"] == pytest.approx(r["p_ref"] * H * W, rel=1e-9)
    assert right["resultant_on_side"]["x"] == pytest.approx(-r["p_ref"] * H * W, rel=1e-9)
    assert left["nodes"]["open"] == 0 and right["nodes"]["open"] == 0
    assert left["tangential_force"] == 0.0


def test_heated_bar_3d_gap_stays_open():
    """Expansion smaller than the gap: no pressure, finite displacements (the x translation is unloaded)."""
    r = heated_bar_3d(gap=1e-3)
    assert r["p_ref"] == 0.0
    assert r["p_left"] == [0.0, 0.0] and r["p_right"] == [0.0, 0.0]
    assert r["e_yy"] == pytest.approx(ALPHA * DT, rel=1e-8)


def test_heated_bar_3d_penalty_softens_by_the_closed_form():
    """method = 'penalty' (c Pa/m): each side penetrates p / c, so p = p_exact / (1 + 2 E / (c L))."""
    c = 1e11
    s = heated_bar_3d_scene(method="penalty")
    for side in ("left", "right"):
        s["boundary_conditions"][side]["foundation"]["augmentation"] = c
    res = run_scene(scene_from_dict(s), None, progress=False)
    exact = heated_bar_3d_pressure(gap=GAP, dT=DT, L=L, E=E, nu=NU, alpha=ALPHA)[0]
    expect = exact / (1 + 2 * E / (c * L))
    for spec, out in zip(res.mechanics.contacts, res.mechanics.contact_output.latest):
        keep = spec.op.coverage > 1 - 1e-6
        assert np.allclose(out["pressure"][keep], expect, rtol=1e-8)
    pen = res.summary["mechanics"]["contact"]["interfaces"]["left"]["max_penetration_m"]
    assert pen == pytest.approx(expect / c, rel=1e-8)


ROCK = {"youngs_modulus": 10e9, "poisson_ratio": 0.25, "density": 2500.0}


def _stack(**interface) -> dict:
    """Box 'upper' (1 x 0.8 x 0.5) on box 'lower' (same footprint, base clamped), non-matching meshes, gravity
    along -z; the upper box is held by the contact interface alone."""
    return {"scene": {"name": "stack", "dimension": "3d"}, "physics": {"mechanics": "static"},
            "mesh": {"maxh": 0.35, "order": 1},
            "blocks": [{"name": "lower", "shape": "box", "origin": [0, 0, 0], "size": [1.0, 0.8, 0.5],
                        "boundaries": {"base": "zmin"}},
                       {"name": "upper", "shape": "box", "origin": [0, 0, 0.5], "size": [1.0, 0.8, 0.5],
                        "maxh": 0.25}],
            "materials": {"lower": dict(ROCK), "upper": dict(ROCK)},
            "interfaces": [{"name": "joint", "blocks": ["upper", "lower"], "type": "contact", **interface}],
            "mechanics": {"gravity": [0.0, 0.0, -9.81]},
            "boundary_conditions": {"base": {"displacement": [0.0, 0.0, 0.0]}}}


def test_box_resting_on_box(tmp_path):
    """The contact carries the upper box's weight, the two sides' forces are opposite, the global balance
    closes; the interface is written as triangles (.vtp with <Polys>, outward normals) with its arrays."""
    out = tmp_path / "stack"
    r = run_scene(scene_from_dict(_stack()), out, progress=False)
    c = r.summary["mechanics"]["contact"]
    joint = c["interfaces"]["joint"]
    weight = 1.0 * 0.8 * 0.5 * 2500.0 * 9.81
    fb = c["force_balance"]
    print(f"\n3D stack: contact force {joint['normal_force']:.9f} N (weight {weight}), action-reaction "
          f"{joint['action_reaction']:.1e}, imbalance {fb['imbalance_rel']:.1e}, nodes {joint['nodes']}, "
          f"{r.summary['wall_time_s']['total_s']:.2f} s")
    assert joint["normal_force"] == pytest.approx(weight, rel=1e-9)
    assert joint["resultant_on_side"]["z"] == pytest.approx(weight, rel=1e-9)     # pushes the upper box up
    assert joint["resultant_on_opposite"]["z"] == pytest.approx(-weight, rel=1e-9)
    assert abs(joint["resultant_on_side"]["x"]) < 1e-9 * weight and abs(joint["resultant_on_side"]["y"]) < 1e-9 * weight
    assert joint["action_reaction"] < 1e-10
    assert fb["imbalance_rel"] < 1e-8
    assert fb["support_reactions"][2] == pytest.approx(2 * weight, rel=1e-9)
    assert fb["load"][2] == pytest.approx(-2 * weight, rel=1e-12)
    assert joint["max_penetration_m"] < 1e-15
    # boundary VTK: one step, triangles of the upper box's bottom face, the arrays of the 2D output
    pvd = ET.parse(out / "stack_contact_joint.pvd").getroot()
    files = [d.get("file") for d in pvd.iter("DataSet")]
    assert files == ["stack_contact_joint_step00000.vtp"]
    piece = next(ET.parse(out / files[0]).getroot().iter("Piece"))
    spec = r.mechanics.contacts[0]
    npts, npolys = int(piece.get("NumberOfPoints")), int(piece.get("NumberOfPolys"))
    assert npts == spec.op.size and npolys == len(spec.cells) > 0 and int(piece.get("NumberOfLines")) == 0
    arrays = {a.get("Name"): np.array(a.text.split(), dtype=float) for a in piece.find("PointData")}
    assert set(arrays) == {"pressure", "traction", "gap", "slip", "status", "bound"}
    assert all(len(v) == npts for v in arrays.values())
    assert np.all(arrays["pressure"] > 0) and np.all(arrays["status"] == 2.0)         # frictionless: slip
    assert np.all(arrays["traction"] == 0.0) and np.all(arrays["bound"] == 0.0)
    pts = np.array(piece.find("Points")[0].text.split(), dtype=float).reshape(-1, 3)
    assert np.allclose(pts[:, 2], 0.5)
    polys = {a.get("Name"): np.array(a.text.split(), dtype=int) for a in piece.find("Polys")}
    tri = polys["connectivity"].reshape(-1, 3)
    assert np.array_equal(polys["offsets"], 3 * np.arange(1, npolys + 1))
    nz = np.cross(pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]])[:, 2]
    assert np.all(nz < 0) and -nz.sum() / 2 == pytest.approx(0.8, rel=1e-12)      # out of the upper box
    # the nodal pressures integrate to the weight
    assert float(np.dot(spec.op.weight, arrays["pressure"])) == pytest.approx(weight, rel=1e-9)
    assert not (out / "figures" / "contact_joint.png").exists()                       # 2D only


def test_hanging_box_pulled_off_by_gravity_is_named():
    """Gravity along +z pulls the upper box off: contact cannot pull, the error names the body."""
    s = _stack()
    s["mechanics"]["gravity"] = [0.0, 0.0, 9.81]
    with pytest.raises(SolverError, match=r"body upper: translation along z is not held"):
        run_scene(scene_from_dict(s), None, progress=False)


def test_polyline_vtp_segments_and_triangles():
    """2D segments stay <Lines>; 3D triangles are <Polys>; the I/O module needs no physics."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    two = polyline_vtp(pts, np.array([[0, 1], [1, 2]]), {"p": np.ones(3)})
    assert 'NumberOfLines="2"' in two and 'NumberOfPolys="0"' in two and "<Lines>" in two and "<Polys>" not in two
    three = polyline_vtp(np.column_stack([pts, np.zeros(3)]), np.array([[0, 1, 2]]), {"p": np.ones(3)})
    assert 'NumberOfLines="0"' in three and 'NumberOfPolys="1"' in three and "<Polys>" in three
    assert "<Lines>" not in three
    with pytest.raises(ValueError, match="2 .* or 3"):
        polyline_vtp(pts, np.array([[0, 1, 2, 0]]), {})


def _problems(data: dict) -> dict[str, str]:
    with pytest.raises(SceneError) as exc:
        validate(scene_from_dict(data))
    return {p.item: p.message for p in exc.value.problems}


def test_3d_uzawa_is_refused_friction_accepted():
    """3D friction (Tresca, Coulomb: tests/test_contact_friction_3d.py) is accepted; the Uzawa method is 2D only."""
    s = _stack(law="coulomb", friction=0.5)
    s["interfaces"][0]["name"] = "fault"
    validate(scene_from_dict(s))
    s = _stack(method="uzawa")
    assert "2D only" in _problems(s)["interfaces[0] (joint).method"]
    b = heated_bar_3d_scene()
    b["boundary_conditions"]["left"]["foundation"].update(law="tresca", slip_bound=1e6)
    b["boundary_conditions"]["right"]["foundation"].update(point=[1.0, 0.0])
    probs = _problems(b)
    assert "needs 3 components" in probs["boundary_conditions.right.foundation.point"]
    assert set(probs) == {"boundary_conditions.right.foundation.point"}
    validate(scene_from_dict(heated_bar_3d_scene(method="penalty")))      # frictionless ssn/penalty: accepted
    validate(scene_from_dict(_stack()))
