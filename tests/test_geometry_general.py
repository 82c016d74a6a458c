"""General geometry: circular arcs in profiles, prisms (extruded outlines), blocks cut by planes of any dip and
strike (faults: contact, glued, or a removed part with a symmetry condition), STEP / BREP import.

Verification against closed forms (printed with pytest -s): the inclined, non-matching contact patch test
(uniform pressure to 1e-8), the STEP round trip (volumes to 1e-10, names), arc areas and lengths and prism
volumes at the geometric order (:mod:`ngs_geomech.verification.geometry`). Then the refusals: each bad input
gives one error naming the key, before any meshing.
"""

from __future__ import annotations

import hashlib
import math
import os
from pathlib import Path

import numpy as np
import pytest

from ngs_geomech.errors import SceneError
from ngs_geomech.geometry.assemble import build_geometry
from ngs_geomech.geometry.cuts import cut_normal
from ngs_geomech.geometry.shapes import arc_circle, cells
from ngs_geomech.run import run_scene
from ngs_geomech.scene.model import Cut
from ngs_geomech.scene.parse import load_scene, scene_from_dict
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import geometry as vg

pytestmark = pytest.mark.usefixtures("one_thread")


def problems_of(data: dict) -> list:
    """The problems validation reports for a scene dict (none: [])."""
    try:
        validate(scene_from_dict(data))
    except SceneError as exc:
        return exc.problems
    return []


def heat_scene(blocks, *, dimension="3d", cuts=(), interfaces=(), materials=None, maxh=0.5) -> dict:
    names = materials or [b["name"] for b in blocks]
    return {"scene": {"name": "general_geometry", "dimension": dimension}, "physics": {"thermal": "transient"},
            "time": {"end": 1.0, "dt": 1.0}, "mesh": {"maxh": maxh}, "blocks": list(blocks),
            "cuts": list(cuts), "interfaces": list(interfaces),
            "materials": {n: {"conductivity": 1.0, "rho_c": 1e6} for n in names},
            "output": {"vtk": False, "figures": False}}


# -- cuts: the convention, the inclined contact patch test, glued and symmetry faces ---------------------------

def test_cut_normal_convention():
    """Strike clockwise from north (+y), dipping to the right: strike 0 dips east (+x), strike 90 dips south."""
    def normal(dip, strike, dim=3):
        return cut_normal(Cut(name="c", point=[0.0] * dim, dip=dip, strike=strike, blocks=["b"], parts=[["a", "b"]]),
                          dim)
    assert np.allclose(normal(0, 0), [0, 0, 1])
    s = math.sin(math.radians(30))
    assert np.allclose(normal(30, 0), [s, 0, math.cos(math.radians(30))])      # upward normal leans east
    assert np.allclose(normal(30, 90), [0, -s, math.cos(math.radians(30))])    # strike east: dips south
    assert np.allclose(normal(90, 180), [-1, 0, 0])
    assert np.allclose(normal(40, 180, 2), [-math.sin(math.radians(40)), math.cos(math.radians(40)), 0])


@pytest.mark.parametrize("order", [1, 2])
def test_inclined_contact_patch_test_3d(order):
    """A fault dipping 50 degrees, strike 30 (not axis-aligned), made by a cut, frictionless contact on
    non-matching meshes: the uniform pressure is transmitted to 1e-8 at every node and u is the exact
    hydrostatic state."""
    r = vg.inclined_fault_patch(order=order)
    print(f"\ninclined contact patch test P{order}: max |lam_n - p|/p = {r['max_deviation']:.2e}, imbalance "
          f"{r['imbalance_rel']:.1e}, u error {r['u_error']:.1e}, {r['nodes']} contact nodes, side vertices "
          f"{r['side_vertices']} ({r['matching_vertices']} shared positions), {r['ndof']} dofs")
    assert r["max_deviation"] < 1e-8
    assert r["imbalance_rel"] < 1e-8
    assert r["u_error"] < 1e-8
    assert r["nodes"] >= 20
    fine, coarse = r["side_vertices"]
    assert fine > coarse and r["matching_vertices"] < coarse          # non-matching meshes
    exact = cut_normal(Cut(name="f", point=[0, 0, 0], dip=50, strike=30, blocks=["r"], parts=[["a", "b"]]), 3)
    assert np.allclose(r["normal"], exact, atol=1e-12)
    assert 30 < math.degrees(math.acos(r["normal"][2])) < 60


@pytest.mark.parametrize("mode", ["glued", "symmetry"])
def test_inclined_cut_face_glued_and_symmetry_3d(mode):
    """The cut face glued (the parts share their nodes), and as an outer boundary (the part below removed) with
    the oblique symmetry u_n = 0 meeting the axis-aligned symmetry planes at the origin: exact to round-off."""
    r = vg.inclined_fault_patch(mode=mode)
    print(f"\ninclined cut, {mode}: u error {r['u_error']:.1e}, {r['ndof']} dofs")
    assert r["u_error"] < 1e-10


@pytest.mark.parametrize("mode", ["contact", "glued", "symmetry"])
def test_inclined_cut_2d(mode):
    """2D (plane strain): a line dipping 40 degrees towards -x (strike 180), contact, glued, or symmetry."""
    r = vg.inclined_fault_patch(dim=2, mode=mode, dip=40.0, strike=180.0, maxh=0.25, fine=0.13)
    print(f"\n2D inclined cut, {mode}: {r}")
    assert r["u_error"] < 1e-8
    assert np.allclose(r["normal"], [-math.sin(math.radians(40)), math.cos(math.radians(40))], atol=1e-12)
    if mode == "contact":
        assert r["max_deviation"] < 1e-8 and r["imbalance_rel"] < 1e-8


def test_cut_without_a_declared_interface_is_glued_and_names_follow_the_blocks():
    """Two layers cut by one fault: each layer's parts are glued by default across '<cut>_<block>'; the
    layers' parts on each side are joined by the interfaces the scene declares between them."""
    blocks = [{"name": "lower", "shape": "box", "origin": [0, 0, 0], "size": [2, 1, 1]},
              {"name": "upper", "shape": "box", "origin": [0, 0, 1], "size": [2, 1, 1]}]
    cut = {"name": "fault", "point": [1, 0.5, 1], "dip": 60, "strike": 0, "blocks": ["lower", "upper"],
           "parts": [["lower_hw", "lower_fw"], ["upper_hw", "upper_fw"]]}
    itfs = [{"name": "bed_hw", "blocks": ["lower_hw", "upper_hw"]},
            {"name": "bed_fw", "blocks": ["lower_fw", "upper_fw"]}]
    data = heat_scene(blocks, cuts=[cut], interfaces=itfs,
                      materials=["lower_hw", "lower_fw", "upper_hw", "upper_fw"])
    geo = validate(scene_from_dict(data))
    assert geo.regions == ["lower_hw", "lower_fw", "upper_hw", "upper_fw"]
    assert {n: sorted(p) for n, p in geo.glued.items()} == {
        "bed_hw": ["lower_hw", "upper_hw"], "bed_fw": ["lower_fw", "upper_fw"],
        "fault_lower": ["lower_fw", "lower_hw"], "fault_upper": ["upper_fw", "upper_hw"]}
    vol = {c.name: c.mass for c in cells(geo.shape, 3)}
    assert sum(vol.values()) == pytest.approx(4.0, rel=1e-12)
    # the hanging wall lies east of the fault (dipping east at 60 degrees through x = 1 at z = 1)
    assert vol["lower_hw"] + vol["upper_hw"] == pytest.approx(2.0, rel=1e-12)


def test_cut_refusals():
    box = {"name": "rock", "shape": "box", "origin": [0, 0, 0], "size": [1, 1, 1]}
    good = {"name": "fault", "point": [0.5, 0.5, 0.5], "dip": 45, "strike": 10, "blocks": ["rock"],
            "parts": [["hw", "fw"]]}
    cases = [
        ({"point": [5, 5, 5]}, "cuts[0] (fault).blocks[0] (rock)", "does not cross it: all of it lies below"),
        ({"blocks": ["granite"]}, "cuts[0] (fault).blocks[0]", "no block 'granite'"),
        ({"parts": [["hw", "fw"], ["a", "b"]]}, "cuts[0] (fault).parts", "one pair [above, below] per block"),
        ({"parts": [["hw", "hw"]]}, "cuts[0] (fault).parts[0]", "name 'hw' is taken"),
        ({"parts": [["", ""]]}, "cuts[0] (fault).parts[0]", "both parts are removed"),
        ({"point": [0.5, 0.5]}, "cuts[0] (fault).point", "needs 3 coordinates"),
        ({"dip": 95}, "cuts[0].dip", "must be in [0, 90] deg"),
        ({"strike": 360}, "cuts[0].strike", "in [0, 360) deg"),
    ]
    for change, item, words in cases:
        probs = problems_of(heat_scene([box], cuts=[{**good, **change}], materials=["hw", "fw"]))
        assert len(probs) == 1, (change, probs)
        assert probs[0].item == item and words in probs[0].message, (change, probs)
    # an interface naming the block the cut replaced: the parts are named in the message
    probs = problems_of(heat_scene([box, {"name": "cap", "shape": "box", "origin": [0, 0, 1], "size": [1, 1, 1]}],
                                   cuts=[good], interfaces=[{"name": "top", "blocks": ["rock", "cap"]}],
                                   materials=["hw", "fw", "cap"]))
    assert any("cut 'fault' split 'rock' into ['hw', 'fw']" in p.message for p in probs), probs
    # 2D: a line dips towards +x or -x only
    rect = {"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 1]}
    probs = problems_of(heat_scene([rect], dimension="plane", cuts=[{**good, "point": [0.5, 0.5]}],
                                   materials=["hw", "fw"]))
    assert [p.item for p in probs] == ["cuts[0] (fault).strike"]


def test_cut_keeps_a_trimmed_block_name_and_names_the_face():
    """parts = ['', 'rock']: the part below the line keeps the block's name; the cut side is the boundary
    'slope'. The line through (2, 1) rising to the right at 20 degrees (dipping towards -x) crosses x = 0 and
    x = 4 inside [0, 2]: the area below it is 4 x 1."""
    rect = {"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [4, 2]}
    cut = {"name": "slope", "point": [2, 1], "dip": 20, "strike": 180, "blocks": ["rock"], "parts": [["", "rock"]]}
    geo = validate(scene_from_dict(heat_scene([rect], dimension="plane", cuts=[cut])))
    assert geo.regions == ["rock"] and "slope" in geo.boundaries
    assert sum(c.mass for c in cells(geo.shape, 2)) == pytest.approx(4.0, rel=1e-12)
    slope = [e for e in geo.shape.edges if e.name == "slope"]
    assert len(slope) == 1 and slope[0].mass == pytest.approx(4 / math.cos(math.radians(20)), rel=1e-12)


# -- STEP / BREP import ---------------------------------------------------------------------------------------

def test_step_round_trip():
    """Two boxes written by netgen.occ to a temporary STEP file and read back through a scene: the same
    volumes (OCC and mesh) and the mapped region and boundary names; the layers are glued (series flux)."""
    r = vg.step_round_trip()
    print(f"\nSTEP round trip: volumes {r['volumes']}, read back {r['occ_volumes']}, meshed {r['mesh_volumes']}: "
          f"errors {r['volume_error']:.1e} (OCC), {r['mesh_volume_error']:.1e} (mesh); flux error "
          f"{r['flux_error']:.1e}; regions {r['regions']}, boundaries {r['boundaries']}")
    assert r["volume_error"] < 1e-10 and r["mesh_volume_error"] < 1e-10
    assert r["regions"] == ["clay", "granite"]
    assert {"bottom", "top", "west_low", "west_up", "layering"} <= set(r["boundaries"])
    assert r["flux_error"] < 1e-10


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_import_relative_to_the_scene_file_and_read_only(tmp_path, monkeypatch):
    """A TOML scene names its STEP file relative to itself; the run leaves the file as it was."""
    step = tmp_path / "cad" / "two.step"
    step.parent.mkdir()
    vg.write_two_boxes(step)
    before, mtime = _sha(step), step.stat().st_mtime_ns
    step.chmod(0o444)
    scene = tmp_path / "scene.toml"
    scene.write_text('''[scene]
name = "imported"
dimension = "3d"
[physics]
thermal = "steady"
[mesh]
maxh = 0.5
[[blocks]]
name = "model"
shape = "import"
file = "cad/two.step"
length_unit = "m"
solids = { lower = "clay", upper = "granite" }
faces = { base = "bottom", surface = "top" }
[[interfaces]]
name = "layering"
blocks = ["clay", "granite"]
type = "contact"
[materials.clay]
conductivity = 1.5
[materials.granite]
conductivity = 3.0
[boundary_conditions.bottom]
temperature = 10.0
[boundary_conditions.top]
temperature = 0.0
[output]
vtk = false
figures = false
''')
    monkeypatch.chdir(Path("/"))
    sc = load_scene(scene)
    assert sc.blocks[0].file == str(step)
    res = run_scene(sc, None, progress=False)
    assert set(res.mesh.GetMaterials()) == {"clay", "granite"}
    assert {"layering__clay", "layering__granite"} <= set(res.mesh.GetBoundaries())
    assert _sha(step) == before and step.stat().st_mtime_ns == mtime
    assert sorted(p.name for p in step.parent.iterdir()) == ["two.step"]


def test_import_length_units(tmp_path):
    """OCC's reader converts to mm from the declared unit: 'declared' honours the declaration, a unit name
    takes the numbers as written. netgen.occ labels its numbers mm; the same file relabelled m and cm."""
    step = tmp_path / "two.step"
    vol = sum(vg.write_two_boxes(step).values())
    text = step.read_text(encoding="latin-1")
    assert "SI_UNIT(.MILLI.,.METRE.)" in text
    (tmp_path / "two_m.step").write_text(text.replace("SI_UNIT(.MILLI.,.METRE.)", "SI_UNIT($,.METRE.)"),
                                         encoding="latin-1")
    (tmp_path / "two_cm.step").write_text(text.replace("SI_UNIT(.MILLI.,.METRE.)", "SI_UNIT(.CENTI.,.METRE.)"),
                                          encoding="latin-1")

    def volume(name, unit):
        block = {"name": "model", "shape": "import", "file": str(tmp_path / name), "length_unit": unit}
        sc = scene_from_dict(heat_scene([block]))
        return sum(c.mass for c in cells(build_geometry(sc).shape, 3))
    assert volume("two.step", "m") == pytest.approx(vol, rel=1e-12)
    assert volume("two.step", "declared") == pytest.approx(vol * 1e-9, rel=1e-12)     # 1 "mm" = 1 mm
    assert volume("two_m.step", "declared") == pytest.approx(vol, rel=1e-12)
    assert volume("two_m.step", "m") == pytest.approx(vol, rel=1e-12)
    assert volume("two_cm.step", "declared") == pytest.approx(vol * 1e-6, rel=1e-12)
    assert volume("two_cm.step", "km") == pytest.approx(vol * 1e9, rel=1e-12)


def test_import_brep_keeps_no_names(tmp_path):
    """BREP holds plain numbers and no names: one region (the block's), selectors name the faces."""
    from netgen import occ

    occ.Box(occ.Pnt(0, 0, 0), occ.Pnt(2, 1, 1)).WriteBrep(str(tmp_path / "box.brep"))
    block = {"name": "rock", "shape": "import", "file": str(tmp_path / "box.brep"), "boundaries": {"top": "zmax"}}
    geo = validate(scene_from_dict(heat_scene([block])))
    assert geo.regions == ["rock"] and "top" in geo.boundaries
    assert sum(c.mass for c in cells(geo.shape, 3)) == pytest.approx(2.0, rel=1e-12)
    probs = problems_of(heat_scene([{**block, "solids": {"a": "b"}}]))
    assert len(probs) == 1 and "no solid 'a'" in probs[0].message and "BREP files keep no names" in probs[0].message


def test_import_refusals(tmp_path):
    """Each bad import gives one error naming the block and the cause, before meshing."""
    step = tmp_path / "two.step"
    vg.write_two_boxes(step)
    (tmp_path / "bad.step").write_text("not a step file\n")
    (tmp_path / "folder.step").mkdir()
    (tmp_path / "two.iges").write_text("x")
    base = {"name": "model", "shape": "import", "length_unit": "m"}
    cases = [
        ({"file": str(tmp_path / "missing.step")}, "does not exist"),
        ({"file": str(tmp_path / "two.iges")}, "not a STEP or BREP file"),
        ({"file": str(tmp_path / "folder.step")}, "is not a regular file"),
        ({"file": str(tmp_path / "bad.step")}, "could not read it as STEP"),
        ({"file": str(step), "solids": {"middle": "x"}}, "no solid 'middle'"),
        ({"file": str(step), "faces": {"roof": "top"}}, "no face 'roof'"),
        ({}, "an import needs 'file'"),
    ]
    for change, words in cases:
        probs = problems_of(heat_scene([{**base, **change}], materials=["model"]))
        assert len(probs) == 1 and probs[0].item == "blocks[0] (model)" and words in probs[0].message, (change, probs)
    if os.geteuid() != 0:                       # root reads any file
        locked = tmp_path / "locked.step"
        vg.write_two_boxes(locked)
        locked.chmod(0)
        probs = problems_of(heat_scene([{**base, "file": str(locked)}], materials=["model"]))
        assert len(probs) == 1 and "cannot be read" in probs[0].message
    probs = problems_of(heat_scene([{**base, "file": str(step), "solids": {"lower": "clay", "upper": "clay"}},
                                    {"name": "clay", "shape": "box", "origin": [5, 5, 5], "size": [1, 1, 1]}],
                                   materials=["clay"]))
    assert any("region 'clay' is also another block's region" in p.message for p in probs), probs


# -- arcs ---------------------------------------------------------------------------------------------------

def test_arc_circle():
    o, r = arc_circle(np.array([1.0, 0.0]), np.array([0.0, 1.0]), np.array([-1.0, 0.0]))
    assert np.allclose(o, [0, 0], atol=1e-15) and r == pytest.approx(1.0, rel=1e-15)
    with pytest.raises(ValueError, match="lie on one line"):
        arc_circle(np.array([0.0, 0.0]), np.array([1.0, 1.0]), np.array([2.0, 2.0]))
    with pytest.raises(ValueError, match="start and end coincide"):
        arc_circle(np.array([0.0, 0.0]), np.array([1.0, 1.0]), np.array([0.0, 0.0]))


def test_arc_profile_area_and_length_at_the_geometric_order():
    """A tunnel section with a semicircular arc roof: the OCC face is exact; the order-2 mesh's area and roof
    length converge at order 4 (curved P2 elements), order 1 at order 2."""
    r2 = vg.arc_profile(order=2, sizes=(0.4, 0.2, 0.1, 0.05))
    r1 = vg.arc_profile(order=1, sizes=(0.4, 0.2, 0.1, 0.05))
    for k, r in ((1, r1), (2, r2)):
        print(f"\narc profile, order {k}: h {r['h']}, area errors {[f'{e:.2e}' for e in r['area_error']]}, orders "
              f"{[f'{o:.2f}' for o in r['area_orders']]}; roof length errors "
              f"{[f'{e:.2e}' for e in r['length_error']]}, orders {[f'{o:.2f}' for o in r['length_orders']]}")
    assert r2["occ_area_error"] < 1e-14
    assert min(r2["area_orders"][-2:]) > 3.5 and min(r2["length_orders"][-2:]) > 3.5
    assert min(r1["area_orders"][-2:]) > 1.8 and min(r1["length_orders"][-2:]) > 1.8
    assert r2["area_error"][-1] < 1e-7


def test_2d_scenes_with_arcs_run():
    """A plane and an axisymmetric heat scene on outlines with arcs (clockwise and counterclockwise arcs)."""
    res = run_scene(scene_from_dict(vg.arc_profile_scene(maxh=0.3)), None, progress=False)
    assert {"roof", "floor"} <= set(res.mesh.GetBoundaries())
    T = res.forms.temperature()
    assert T(res.mesh(0.0, 1.5)) == pytest.approx(1.0, abs=0.05) and T(res.mesh(0.0, 0.05)) < 0.1
    # axisymmetric: a quarter disc of radius 1 (r >= 0) with a bite (a clockwise arc) out of its rim
    block = {"name": "disc", "shape": "profile", "start": [0, 0], "segments": [
        {"line": [1, 0], "name": "base"}, {"arc": [[0.8, 0.45], [0.6, 0.8]], "name": "bite"},
        {"arc": [[0.31, 0.95], [0, 1]], "name": "rim"}, {"line": [0, 0]}]}
    data = {"scene": {"name": "arc_axi", "dimension": "axisymmetric"}, "physics": {"thermal": "steady"},
            "mesh": {"maxh": 0.1, "order": 2}, "blocks": [block], "materials": {"disc": {"conductivity": 1.0}},
            "boundary_conditions": {"base": {"temperature": 1.0}, "rim": {"temperature": 0.0}},
            "output": {"vtk": False, "figures": False}}
    res = run_scene(scene_from_dict(data), None, progress=False)
    assert {"base", "bite", "rim", "axis"} <= set(res.mesh.GetBoundaries())


def test_arc_refusals_name_the_block_and_segment():
    seg = [{"line": [1, 0]}, {"arc": [[1, 0.5], [1, 1]], "name": "roof"}, {"line": [0, 1]}, {"line": [0, 0]}]
    block = {"name": "rock", "shape": "profile", "start": [0, 0], "segments": seg}
    probs = problems_of(heat_scene([block], dimension="plane"))
    assert len(probs) == 1 and probs[0].item == "blocks[0] (rock)"
    assert "segments[1].arc" in probs[0].message and "lie on one line" in probs[0].message
    seg[1] = {"arc": [[1, 0.5], [1, 0]]}
    probs = problems_of(heat_scene([block], dimension="plane"))
    assert "segments[1].arc" in probs[0].message and "coincide" in probs[0].message
    seg[1] = {"arc": [[1, 0.5], [1, 1]], "line": [1, 1]}
    probs = problems_of(heat_scene([block], dimension="plane"))
    assert "segments[1] must have exactly one of 'line', 'spline' or 'arc'" in probs[0].message


# -- prisms ----------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("axis", [None, [0.3, 1.0, 0.2]])
def test_prism_of_a_profile_with_an_arc_has_the_exact_volume(axis):
    """The tunnel section (arc roof) drawn in the x-z plane and extruded along y (and obliquely): the OCC solid's
    volume is area x length x |a.n|; the order-2 mesh converges at order 4; side faces carry the segment names."""
    r = vg.arc_prism(axis=axis, sizes=(0.4, 0.2, 0.1))
    print(f"\nprism, axis {axis}: exact volume {r['exact']:.12f}, OCC error {r['occ_error']:.1e}, mesh errors "
          f"{[f'{e:.2e}' for e in r['mesh_error']]}, orders {[f'{o:.2f}' for o in r['orders']]}")
    assert r["occ_error"] < 1e-10
    assert min(r["orders"]) > 3.5
    assert r["boundaries"] == ["face", "floor", "left_wall", "portal", "right_wall", "roof"]


def test_prism_of_a_polygon_in_a_tilted_plane():
    """A triangle in the plane through (1, 2, 3) spanned by u = (1, 1, 0)/sqrt 2, v = z, extruded along
    u x v by 2: volume = area x 2; named sides; the end faces by the 'bottom' and 'top' selectors."""
    block = {"name": "plate", "shape": "prism", "origin": [1, 2, 3], "directions": [[1, 1, 0], [0, 0, 1]],
             "points": [[0, 0], [2, 0], [0, 1]], "edges": ["a", "b", "c"], "length": 2.0,
             "boundaries": {"near": "bottom", "far": "top"}}
    geo = validate(scene_from_dict(heat_scene([block])))
    assert sum(c.mass for c in cells(geo.shape, 3)) == pytest.approx(2.0, rel=1e-12)
    assert geo.boundaries == {"a", "b", "c", "near", "far"}
    near = [f for f in geo.shape.faces if f.name == "near"][0].center
    assert np.allclose([near.x, near.y, near.z], [1 + 2 / 3 / math.sqrt(2), 2 + 2 / 3 / math.sqrt(2), 3 + 1 / 3])


def test_prism_refusals():
    base = {"name": "p", "shape": "prism", "points": [[0, 0], [1, 0], [0, 1]], "length": 1.0}
    cases = [
        ({"directions": [[1, 0, 0], [1, 1, 0]]}, "must be orthogonal"),
        ({"axis": [1, 1, 0]}, "lies in the outline's plane"),
        ({"length": None}, "'length' (of the extrusion) must be given"),
        ({"start": [0, 0], "segments": [{"line": [1, 0]}]}, "give one"),
        ({"directions": [[0, 0, 0], [0, 1, 0]]}, "must not hold the zero vector"),
    ]
    for change, words in cases:
        data = heat_scene([{k: v for k, v in {**base, **change}.items() if v is not None}], materials=["p"])
        probs = problems_of(data)
        assert len(probs) == 1 and probs[0].item == "blocks[0] (p)" and words in probs[0].message, (change, probs)
