"""Scene files and the names, temperatures, sizes and shapes in them that validation must refuse before any
expensive work: names that would put output files outside the output directory, temperatures below absolute
zero, meshes too large to make, polygons that are not simple, blocks too thin for the geometry kernel, binary
files and files with a byte order mark. All cheap: validation only (one small mesh for the size estimate)."""

from __future__ import annotations

import copy
import time
from pathlib import Path

import numpy as np
import pytest

from ngs_geomech import cli
from ngs_geomech.errors import SceneError
from ngs_geomech.geometry.shapes import polygon_problem
from ngs_geomech.io.lines_vtk import LineSeries
from ngs_geomech.io.vtk import VtkSeries
from ngs_geomech.scene.names import name_problem
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate

BAD = Path(__file__).parent / "scenes" / "bad"

SCENE = {
    "scene": {"name": "slab"},
    "physics": {"thermal": "steady"},
    "mesh": {"maxh": 0.5},
    "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 1.0],
                "boundaries": {"left": "xmin", "right": "xmax"}},
               {"name": "core", "shape": "rectangle", "origin": [0.25, 0.25], "size": [0.5, 0.5]}],
    "interfaces": [{"name": "rim", "blocks": ["rock", "core"]}],
    "materials": {"rock": {"conductivity": 3.0}, "core": {"conductivity": 2.0}},
    "boundary_conditions": {"left": {"temperature": 10.0}, "right": {"temperature": 0.0}},
    "output": {"probes": [{"name": "core_max", "region": "core", "statistic": "max"}]},
}
BAD_NAMES = ["./../../x", "../../x", "/abs/x", "a/b", "a\\b", "x\0y", "", ".hidden", "a..b", "-x", "a" * 65, "a b"]


def problems_of(data: dict) -> list:
    """The problems validation finds in ``data`` (item, message)."""
    try:
        validate(scene_from_dict(data))
    except SceneError as exc:
        return [(p.item, p.message) for p in exc.problems]
    return []


def with_(path: str, value) -> dict:
    """SCENE with the item at the dotted ``path`` (list items by index) set to ``value``."""
    data = copy.deepcopy(SCENE)
    node = data
    *parents, last = path.split(".")
    for part in parents:
        node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return data


def test_the_base_scene_is_valid():
    assert problems_of(SCENE) == []


# -- names ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", BAD_NAMES, ids=range(len(BAD_NAMES)))
@pytest.mark.parametrize("path, item", [("scene.name", "scene.name"),
                                        ("output.probes.0.name", "output.probes[0].name"),
                                        ("interfaces.0.name", "interfaces[0].name")])
def test_a_name_that_is_no_plain_file_name_is_refused(path, item, name):
    found = problems_of(with_(path, name))
    assert [i for i, _ in found] == [item], found
    assert "letters, digits, '_', '-' and '.'" in found[0][1]


@pytest.mark.parametrize("name", ["canister", "run-2.v1", "_x", "A" * 64])
def test_plain_file_names_pass(name):
    assert name_problem(name) is None
    assert problems_of(with_("scene.name", name)) == []


def test_a_scene_named_with_parent_directories_writes_nothing(tmp_path, capsys):
    out = tmp_path / "a" / "b" / "out"
    out.parent.mkdir(parents=True)
    rc = cli.main(["run", str(BAD / "name_scene_parent_dirs.toml"), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2 and "scene.name" in err and "Traceback" not in err
    assert [p for p in tmp_path.rglob("*") if p.is_file()] == []


@pytest.mark.parametrize("name", ["../x", "a/b", "", ".pvd"])
def test_the_writers_refuse_a_name_that_is_no_plain_file_name(tmp_path, name):
    with pytest.raises(ValueError, match="refusing to write"):
        LineSeries(tmp_path, name)
    with pytest.raises(ValueError, match="refusing to write"):
        VtkSeries(None, {}, tmp_path / "vtk", name)
    assert list(tmp_path.iterdir()) == []


def test_the_writers_take_joined_names_longer_than_one_name(tmp_path):
    assert LineSeries(tmp_path, f"{'s' * 64}_contact_{'i' * 64}").basename.startswith("s")


def test_an_uncertainty_criterion_name_that_is_no_plain_file_name_is_refused(tmp_path):
    from ngs_geomech.uncertainty.study import run_uncertainty
    with pytest.raises(SceneError, match=r"uncertainty.criteria\[0\].name: '\.\./x' is not allowed"):
        run_uncertainty(Path(__file__).parent / "scenes" / "uncertainty" / "slab.toml", tmp_path / "u",
                        overrides=["uncertainty.criteria.peak_temperature.name=../x"], executor="serial",
                        progress=False)
    assert not (tmp_path / "u").exists()


# -- temperatures --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("path, value, unit", [
    ("boundary_conditions.left.temperature", -5.0, "K"),
    ("boundary_conditions.left.temperature", -273.2, "C"),
    ("initial.temperature", -260.0, "K"),
    ("materials.rock.stress_free_temperature", -1.0, "K"),
    ("materials.rock.phase_change_temperature", -300.0, "C"),
    ("materials.rock.reference_temperature", -0.5, "K"),
])
def test_a_temperature_below_absolute_zero_is_refused(path, value, unit):
    data = with_(path, value)
    data["scene"]["temperature_unit"] = unit
    found = [(i, m) for i, m in problems_of(data) if i == path]
    assert found and "below absolute zero" in found[0][1], problems_of(data)


def test_temperatures_down_to_absolute_zero_pass():
    data = with_("boundary_conditions.right.temperature", -273.15)
    assert problems_of(data) == []
    data = with_("boundary_conditions.right.temperature", 0.0)
    data["scene"]["temperature_unit"] = "K"
    assert problems_of(data) == []


# -- mesh size -----------------------------------------------------------------------------------------------

def test_a_3d_mesh_too_large_is_refused_within_a_second(capsys):
    tic = time.perf_counter()
    rc = cli.main(["validate", str(BAD / "mesh_maxh_3d.toml")])
    assert time.perf_counter() - tic < 1.0
    assert rc == 2 and "mesh.max_elements" in capsys.readouterr().err


def test_raising_max_elements_lets_the_scene_through(capsys):
    assert cli.main(["validate", str(BAD / "mesh_maxh_3d.toml"), "--set", "mesh.max_elements=2000000000"]) == 0
    assert cli.main(["validate", str(BAD / "mesh_maxh_3d.toml"), "--set", "mesh.max_elements=0"]) == 2
    assert "mesh.max_elements: must be >= 1" in capsys.readouterr().err


@pytest.mark.parametrize("path, value, item", [("mesh.maxh", 1e-9, "mesh.maxh"),
                                               ("blocks.1.maxh", 1e-4, "blocks[1].maxh"),
                                               ("mesh.boundary_maxh", {"left": 1e-7}, "mesh.boundary_maxh.left")])
def test_the_size_that_makes_the_mesh_too_large_is_named(path, value, item):
    assert [i for i, _ in problems_of(with_(path, value))] == [item]


def test_the_element_estimate_is_near_the_mesh():
    """2D (3D meshing costs seconds even for a few tetrahedra; measured on the built-in scenes: 0.5 to 2.9)."""
    from ngs_geomech.geometry.mesh import make_mesh
    scene = scene_from_dict(with_("mesh.maxh", 0.05))
    geo = validate(scene)
    ratio = make_mesh(geo, scene.mesh).ne / sum(geo.element_estimate(scene.mesh.maxh).values())
    assert 0.8 < ratio < 1.5, ratio


# -- shapes --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("points, why", [
    ([[0, 0], [1, 1], [1, 0], [0, 1]], "sides 0 and 2 cross"),
    ([[0, 0], [2, 0], [2, 2], [1, 0], [0, 2]], "sides 0 and 2 cross or touch"),
    ([[0, 0], [1, 0], [2, 0]], "zero area"),
    ([[0, 0], [1, 0], [1, 0], [0, 1]], "points 1 and 2 coincide"),
    ([[0, 0], [2, 0], [1, 0], [1, 1]], "sides 0 and 2 cross or touch"),      # folding back
])
def test_a_polygon_that_is_not_simple_is_named(points, why):
    assert why in polygon_problem(np.array(points, float))


@pytest.mark.parametrize("points", [[[0, 0], [1, 0], [0.5, 1]], [[0, 0], [2, 0], [2, 1], [0, 1], [0, 0.5]],
                                    [[0, 0], [4, 0], [4, 4], [2, 4], [2, 1e-4], [1, 4], [0, 4]]])
def test_simple_polygons_pass(points):
    assert polygon_problem(np.array(points, float)) is None


def test_blocks_of_a_1000_km_model_and_a_1_mm_block_in_it_are_valid():
    data = with_("blocks.0.size", [1e6, 1e6])
    data["blocks"][1].update(origin=[5e5, 5e5], size=[1e-3, 1e-3])
    data["mesh"]["maxh"] = 1e5
    assert problems_of(data) == []


def test_covered_only_when_covered():
    data = with_("blocks.1.size", [1.0, 1.0])
    data["blocks"][1]["origin"] = [0.0, 0.0]
    assert ("blocks.rock", "is entirely covered by blocks declared after it") in problems_of(data)


# -- files ---------------------------------------------------------------------------------------------------

def test_a_scene_file_with_a_byte_order_mark_is_read(tmp_path, capsys):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + (BAD.parent.parent.parent / "geometries" / "heated_rock.toml").read_bytes())
    assert cli.main(["validate", str(path)]) == 0, capsys.readouterr().err


def test_a_binary_scene_file_is_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_bytes(bytes(range(256)))
    assert cli.main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "not a text (UTF-8) file: byte 0x80 at offset 128" in err and "Traceback" not in err
    assert ": 1 problem(s)" in err
