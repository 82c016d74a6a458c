"""Contact interfaces between blocks that do not touch (an initial gap, ``[[interfaces]] sides = [...]``):
closed forms of a block pushed onto another across a gap (plane strain, 3D), a heated block closing the gap
while no heat crosses it, a canister resting in a borehole (axisymmetric, semi-coercive), and the errors for
bad ``sides``.

Plane strain stack: lower block (height H1) on a roller base (u_y = 0), upper block (height H2) a gap g0
above it, its top moved by u_y = -d; both held along x by symmetry on x = 0, the other sides free. Every block
is then in uniaxial stress: sigma_xx = 0, eps_zz = 0, so sigma_zz = nu sigma_yy and
eps_yy = (1 - nu^2) sigma_yy / E (+ (1 + nu) alpha dT, the free plane-strain expansion of a block heated by
dT). Once the gap is closed the stack shortens by d - g0 (+ the upper block's expansion (1 + nu) alpha dT H2):

    p = E / (1 - nu^2) * (d - g0 + (1 + nu) alpha dT H2) / (H1 + H2),

and while the bracket is negative p = 0 and the gap is minus the bracket (g0 - d without heating).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from ngs_geomech.errors import SceneError
from ngs_geomech.heat.problem import heat_setup
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

E, NU, W, H1, H2, G0 = 10e9, 0.25, 1.0, 0.5, 0.4, 1e-4
EP = E / (1 - NU ** 2)          # plane strain, sigma_xx = 0


def stack(d: float, *, thermal: bool = False, mechanics: bool = True, **itf) -> dict:
    """The plane-strain stack of the module docstring (non-matching meshes on the two sides of the gap)."""
    mat = {"youngs_modulus": E, "poisson_ratio": NU}
    if thermal:
        mat.update(conductivity=2.0, thermal_expansion=1e-5)
    s = {"scene": {"name": "stack_gap"},
         "physics": {"mechanics": "static" if mechanics else None, "thermal": "steady" if thermal else None},
         "mesh": {"maxh": 0.2},
         "blocks": [{"name": "lower", "shape": "rectangle", "origin": [0, 0], "size": [W, H1], "maxh": 0.15,
                     "boundaries": {"base": "ymin", "left": "xmin", "lower_top": "ymax"}},
                    {"name": "upper", "shape": "rectangle", "origin": [0, H1 + G0], "size": [W, H2],
                     "boundaries": {"top": "ymax", "left": "xmin", "upper_base": "ymin"}}],
         "interfaces": [{"name": "gap", "blocks": ["upper", "lower"], "type": "contact",
                         "sides": ["upper_base", "lower_top"], **itf}],
         "materials": {"lower": dict(mat), "upper": dict(mat)},
         "boundary_conditions": {}}
    bc = s["boundary_conditions"]
    if mechanics:
        bc.update(base={"displacement": ["free", 0.0]}, left={"symmetry": True},
                  top={"displacement": ["free", -d]})
    if thermal:
        bc.setdefault("base", {})["temperature"] = 0.0
        bc.setdefault("top", {})["temperature"] = 100.0
    s["physics"] = {k: v for k, v in s["physics"].items() if v is not None}
    return s


@pytest.mark.parametrize("d", [3e-4, 0.5e-4])
def test_block_pushed_across_gap(d):
    """d > g0: uniform pressure E' (d - g0) / (H1 + H2) at every node; d < g0: no contact, gap g0 - d."""
    r = run_scene(scene_from_dict(stack(d)), None, progress=False)
    res = r.mechanics.contact_output.latest[0]
    item = r.summary["mechanics"]["contact"]["interfaces"]["gap"]
    p_ref = EP * max(d - G0, 0.0) / (H1 + H2)
    print(f"\ngap stack d = {d:.1e} m: p_ref {p_ref / 1e6:.9f} MPa, nodal p {res['pressure'].min() / 1e6:.9f}.."
          f"{res['pressure'].max() / 1e6:.9f} MPa, gap {res['gap'].min():.6e}..{res['gap'].max():.6e} m, "
          f"initial gap {item['initial_gap_m']}, search distance {item['search_distance_m']} m")
    assert len(res["pressure"]) == 6                                # upper side: 6 nodes (lower: 8, non-matching)
    assert item["initial_gap_m"] == pytest.approx([G0, G0], rel=1e-8)
    assert item["search_distance_m"] == pytest.approx(0.25 * W)   # the default: a quarter of the side
    if d > G0:
        assert np.allclose(res["pressure"], p_ref, rtol=1e-8, atol=0)
        assert np.all(np.abs(res["gap"]) < 1e-15)
        assert item["normal_force"] == pytest.approx(p_ref * W, rel=1e-8)
        assert item["action_reaction"] < 1e-10
        assert item["nodes"]["open"] == 0
    else:
        assert np.all(res["pressure"] == 0.0)
        assert np.allclose(res["gap"], G0 - d, rtol=0, atol=1e-8 * G0)
        assert item["nodes"]["open"] == 6
    assert r.summary["warnings"] == []


def test_block_pushed_across_gap_3d():
    """The same in 3D (boxes, symmetry on x = 0 and y = 0, free sides): p = E (d - g0) / (H1 + H2)."""
    d = 3e-4
    s = {"scene": {"name": "stack3d", "dimension": "3d"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.5},
         "blocks": [{"name": "lower", "shape": "box", "origin": [0, 0, 0], "size": [1, 1, H1],
                     "boundaries": {"base": "zmin", "sx": "xmin", "sy": "ymin", "lower_top": "zmax"}},
                    {"name": "upper", "shape": "box", "origin": [0, 0, H1 + G0], "size": [1, 1, H2], "maxh": 0.4,
                     "boundaries": {"top": "zmax", "sx": "xmin", "sy": "ymin", "upper_base": "zmin"}}],
         "interfaces": [{"name": "gap", "blocks": ["lower", "upper"], "type": "contact",
                         "sides": ["lower_top", "upper_base"]}],
         "materials": {n: {"youngs_modulus": E, "poisson_ratio": NU} for n in ("lower", "upper")},
         "boundary_conditions": {"base": {"displacement": ["free", "free", 0.0]}, "sx": {"symmetry": True},
                                 "sy": {"symmetry": True}, "top": {"displacement": ["free", "free", -d]}}}
    r = run_scene(scene_from_dict(s), None, progress=False)
    p = r.mechanics.contact_output.latest[0]["pressure"]
    p_ref = E * (d - G0) / (H1 + H2)
    print(f"\n3D gap stack: p_ref {p_ref / 1e6:.9f} MPa, nodal p {p.min() / 1e6:.9f}..{p.max() / 1e6:.9f} MPa")
    assert np.allclose(p, p_ref, rtol=1e-8, atol=0)


def test_heated_block_closes_gap_no_heat_crosses(tmp_path):
    """Thermal + mechanics: the upper block at 100, the lower at 0 (each held by its own temperature; the gap
    is insulating, so both stay uniform and no interface heat flow is reported); the upper block's thermal
    expansion closes the gap against the fixed top: the closed form with dT = 100. Contact VTK and figure."""
    alpha, dT = 1e-5, 100.0
    out = tmp_path / "stack"
    r = run_scene(scene_from_dict(stack(0.0, thermal=True)), out, progress=False)
    T = r.forms.temperature()
    mesh = r.mesh
    t_lower = np.array([T(mesh(x, y)) for x, y in [(0.1, 0.05), (0.9, 0.45), (0.5, H1)]])
    t_upper = np.array([T(mesh(x, y)) for x, y in [(0.1, H1 + G0), (0.9, 0.7), (0.5, H1 + G0 + H2)]])
    assert r.forms.setup.contacts == []
    assert r.summary["interface_heat_flow_W"] == {}
    assert np.allclose(t_lower, 0.0, atol=1e-10) and np.allclose(t_upper, dT, rtol=1e-12)
    res = r.mechanics.contact_output.latest[0]
    p_ref = EP * (0.0 - G0 + (1 + NU) * alpha * dT * H2) / (H1 + H2)
    print(f"\nheated gap stack: T lower {t_lower.max():.2e}, upper {t_upper.min():.12f}; p_ref {p_ref / 1e6:.9f} MPa, "
          f"nodal p {res['pressure'].min() / 1e6:.9f}..{res['pressure'].max() / 1e6:.9f} MPa")
    assert np.allclose(res["pressure"], p_ref, rtol=1e-8, atol=0)
    assert (out / "figures" / "contact_gap.png").stat().st_size > 1000
    vtp = ET.parse(out / "stack_gap_contact_gap_step00000.vtp").getroot()
    piece = next(vtp.iter("Piece"))
    arrays = {a.get("Name"): np.array(a.text.split(), dtype=float) for a in piece.find("PointData")}
    assert int(piece.get("NumberOfPoints")) == 6 and int(piece.get("NumberOfLines")) == 5
    assert np.allclose(arrays["pressure"], p_ref, rtol=1e-8)


def test_thermal_only_scene_with_gap_interface():
    """Without mechanics the gap sides are plain insulated boundaries: no mortar coupling, uniform blocks."""
    sc = scene_from_dict(stack(0.0, thermal=True, mechanics=False))
    geo = validate(sc)
    cs = geo.contacts["gap"]
    assert cs.initial_gap and (cs.master, cs.minion) == ("upper_base", "lower_top")
    assert cs.gap == pytest.approx(G0, rel=1e-9)
    r = run_scene(sc, None, progress=False, geometry=geo)
    T = r.forms.temperature()
    assert heat_setup(sc, geo, r.mesh).contacts == []
    assert T(r.mesh(0.5, H1)) == pytest.approx(0.0, abs=1e-10)
    assert T(r.mesh(0.5, H1 + G0)) == pytest.approx(100.0, rel=1e-12)


def test_canister_resting_in_borehole_axisymmetric():
    """A canister a gap above the floor of a borehole (axisymmetric, a notch in the rock profile), held by the
    contact alone under gravity: the gap closes, the floor carries the weight (N per radian)."""
    R, Hc, gb = 0.5, 2.0, 1e-3
    rock = {"name": "rock", "shape": "profile", "start": [0, -5],
            "segments": [{"line": [5, -5], "name": "base"}, {"line": [5, 5]}, {"line": [0, 5]},
                         {"line": [0, Hc + 0.5]}, {"line": [R + 0.05, Hc + 0.5]},
                         {"line": [R + 0.05, 0], "name": "hole_wall"}, {"line": [0, 0], "name": "hole_floor"},
                         {"line": [0, -5]}]}
    can = {"name": "canister", "shape": "rectangle", "origin": [0, gb], "size": [R, Hc], "maxh": 0.1,
           "boundaries": {"can_bottom": "ymin"}}
    s = {"scene": {"name": "canister_gap", "dimension": "axisymmetric"}, "physics": {"mechanics": "static"},
         "mesh": {"maxh": 0.6}, "blocks": [rock, can],
         "interfaces": [{"name": "seat", "blocks": ["canister", "rock"], "type": "contact",
                         "sides": ["can_bottom", "hole_floor"]}],
         "materials": {"rock": {"youngs_modulus": 50e9, "poisson_ratio": 0.25, "density": 2700.0},
                       "canister": {"youngs_modulus": 200e9, "poisson_ratio": 0.3, "density": 8000.0}},
         "mechanics": {"gravity": [0.0, -9.81]},
         "boundary_conditions": {"base": {"displacement": [0.0, 0.0]}}}
    r = run_scene(scene_from_dict(s), None, progress=False)
    c = r.summary["mechanics"]["contact"]
    seat = c["interfaces"]["seat"]
    weight = 8000.0 * 9.81 * R ** 2 * Hc / 2          # rho g pi R^2 Hc / (2 pi), N/rad
    res = r.mechanics.contact_output.latest[0]
    print(f"\ncanister on the borehole floor: normal force {seat['normal_force']:.6f} N/rad (weight {weight}), "
          f"initial gap {seat['initial_gap_m']}, max |gap| after {np.max(np.abs(res['gap'])):.1e} m")
    assert seat["initial_gap_m"] == pytest.approx([gb, gb], rel=1e-8)
    assert seat["normal_force"] == pytest.approx(weight, rel=1e-8)
    assert np.all(np.abs(res["gap"]) < 1e-12) and np.all(res["pressure"] > 0)
    assert c["force_balance"]["imbalance_rel"] < 1e-8


def test_gap_beyond_search_distance_warns():
    """A gap wider than the default search distance (a quarter of the contact side) can never close: the run
    says so (and the pressure stays 0)."""
    s = stack(3e-4)          # (an explicit search_distance below the gap is refused by validation: next test)
    s["blocks"][0]["size"] = [W, 0.1]          # lower side 0.1 m wide: default reach 0.025 m
    s["blocks"][0]["origin"] = [0.0, H1 - 0.1 - 0.05]
    s["blocks"][1]["size"] = [0.1, H2]
    r = run_scene(scene_from_dict(s), None, progress=False)
    print(f"\nwarnings: {r.summary['warnings']}")
    assert any("interfaces (gap): no point of 'upper_base' sees side 'lower_top'" in w
               and "0.025 m (the sides are 0.0501 m apart)" in w for w in r.summary["warnings"])
    assert np.all(r.mechanics.contact_output.latest[0]["pressure"] == 0.0)


def _problems(data: dict) -> dict[str, str]:
    """item -> its messages (joined by ' | ')."""
    with pytest.raises(SceneError) as exc:
        validate(scene_from_dict(data))
    out: dict[str, str] = {}
    for p in exc.value.problems:
        out[p.item] = f"{out[p.item]} | {p.message}" if p.item in out else p.message
    return out


def test_bad_sides_are_named():
    path = "interfaces[0] (gap).sides"
    s = stack(3e-4)
    s["interfaces"][0]["sides"] = ["upper_base", "nope"]
    msg = _problems(s)[path]
    assert "no boundary 'nope' on block 'lower'" in msg and "'base', 'left', 'lower_top'" in msg
    s["interfaces"][0]["sides"] = ["lower_top", "upper_base"]          # swapped
    assert "no boundary 'lower_top' on block 'upper': it is on block(s) ['lower']" in _problems(s)[path]
    s["interfaces"][0]["sides"] = ["left", "lower_top"]                # 'left' names a side of both blocks
    assert "boundary 'left' is also on block(s) ['lower']" in _problems(s)[path]
    s["interfaces"][0]["sides"] = ["upper_base", "upper_base"]
    assert "both sides are called 'upper_base'" in _problems(s)[path]
    s["interfaces"][0]["sides"] = ["upper_base"]
    assert "interfaces[0].sides" in _problems(s)                        # schema: two names
    s = stack(3e-4)
    s["interfaces"][0]["type"] = "glued"
    assert "applies to type = 'contact' only" in _problems(s)[path]
    s = stack(3e-4)                                                     # no sides: the hint
    del s["interfaces"][0]["sides"]
    assert "name the two sides: sides = [boundary on 'upper', boundary on 'lower']" in \
        _problems(s)["interfaces[0] (gap)"]
    s = stack(3e-4)                                                     # touching blocks
    s["blocks"][1]["origin"] = [0.0, H1]
    assert "touch: their shared side is the contact side" in _problems(s)[path]
    s = stack(3e-4, search_distance=0.5 * G0)
    assert "smaller than the initial gap 0.0001 m" in _problems(s)["interfaces[0] (gap).search_distance"]
    s = stack(3e-4)
    s["boundary_conditions"]["lower_top"] = {"pressure": 1e6}
    assert "is a side of contact interface 'gap': mechanical conditions (pressure)" in \
        _problems(s)["boundary_conditions.lower_top"]
    s = stack(3e-4)                                                     # glued to each other through 'wall'
    s["blocks"].append({"name": "wall", "shape": "rectangle", "origin": [W, 0], "size": [0.2, H1 + G0 + H2]})
    s["materials"]["wall"] = dict(s["materials"]["lower"])
    s["interfaces"] += [{"name": "w1", "blocks": ["lower", "wall"]}, {"name": "w2", "blocks": ["upper", "wall"]}]
    assert "also joined through glued interfaces" in _problems(s)["interfaces[0] (gap)"]


def test_thermal_conditions_on_gap_sides_and_steady_bodies():
    """Thermal conditions on a gap side are fine (it is an outer boundary for heat); a steady scene needs a
    temperature or Robin condition on each body the gap isolates."""
    s = stack(3e-4, thermal=True)
    s["boundary_conditions"]["lower_top"] = {"heat_transfer_coefficient": 5.0, "ambient_temperature": 20.0}
    validate(scene_from_dict(s))
    s = stack(3e-4, thermal=True)
    del s["boundary_conditions"]["top"]["temperature"]
    msg = _problems(s)["boundary_conditions"]
    assert "block(s) ['upper'] have none (interface(s) ['gap'] have an initial gap and carry no heat)" in msg
