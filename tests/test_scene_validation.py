"""Broken scenes: every file under ``tests/scenes/bad/`` holds one problem (or several, on purpose) and
declares in its first line the substrings the error message must contain::

    # expect: materials.granite.rho_c | must be positive

``ngs-geomech validate FILE`` must fail with exit status 2, print nothing on stdout and name the offending
item on stderr; ``ngs-geomech run FILE --out DIR`` must fail the same way before meshing and without
creating DIR (or a staging directory beside it).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ngs_geomech import cli
from ngs_geomech.errors import SceneError
from ngs_geomech.scene.parse import load_scene, scene_from_dict
from ngs_geomech.validation.validate import validate

BAD = Path(__file__).parent / "scenes" / "bad"
SCRIPT = Path(sys.executable).with_name("ngs-geomech")     # the installed console script
COMMAND = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "ngs_geomech.cli"]
BAD_FILES = sorted(BAD.glob("*.toml"))


def expectations(path: Path) -> list[str]:
    first = path.read_text().splitlines()[0]
    assert first.startswith("# expect:"), f"{path.name}: first line must be '# expect: a | b | ...'"
    subs = [s.strip() for s in first[len("# expect:"):].split("|") if s.strip()]
    assert subs, f"{path.name}: no expected substrings"
    return subs


def test_bad_scene_folder_is_populated():
    assert len(BAD_FILES) >= 25


@pytest.mark.parametrize("path", BAD_FILES, ids=[p.stem for p in BAD_FILES])
def test_validate_names_the_offending_item(path, capsys):
    rc = cli.main(["validate", str(path)])
    out, err = capsys.readouterr()
    assert rc == 2
    assert out == "", "stdout must stay empty when validation fails"
    assert err.startswith("ngs-geomech: error: ")
    for sub in expectations(path):
        assert sub in err, f"{path.name}: {sub!r} not in the message:\n{err}"
    if not path.stem.startswith("several"):
        assert ": 1 problem(s)" in err, f"{path.name} should hold exactly one problem:\n{err}"


def test_validate_through_subprocess_exit_status_and_streams():
    path = BAD / "several_problems.toml"
    proc = subprocess.run([*COMMAND, "validate", str(path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert "ngs-geomech: error:" in proc.stderr
    for sub in expectations(path):
        assert sub in proc.stderr
    assert "Traceback" not in proc.stderr


def test_validate_good_scene_through_subprocess_writes_only_stdout():
    proc = subprocess.run([*COMMAND, "validate", "canister"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert "scene 'canister' is valid" in proc.stdout


# -- every problem is reported ----------------------------------------------------------------------

def test_three_different_problems_are_all_reported():
    with pytest.raises(SceneError) as info:
        validate(load_scene(BAD / "several_problems.toml"))
    items = sorted(p.item for p in info.value.problems)
    assert items == ["boundary_conditions.top", "materials.host.rho_c", "time.dt"]
    assert "3 problem(s)" in str(info.value)


def test_three_schema_problems_are_all_reported():
    with pytest.raises(SceneError) as info:
        load_scene(BAD / "several_schema_problems.toml")
    items = sorted(p.item for p in info.value.problems)
    assert items == ["blocks[0].sise", "mesh.order", "time.end"]


def test_conductivity_and_heat_capacity_problems_of_one_material_are_both_reported():
    data = {"scene": {"name": "two_in_one"}, "physics": {"thermal": "transient"},
            "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 1.0],
                        "boundaries": {"left": "xmin"}}],
            "materials": {"rock": {"conductivity": [[1.0, 0.5], [0.0, 1.0]], "rho_c": -1.0}},
            "boundary_conditions": {"left": {"temperature": 0.0}},
            "time": {"end": 10.0, "dt": 1.0}}
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    items = sorted(p.item for p in info.value.problems)
    assert items == ["materials.rock.conductivity", "materials.rock.rho_c"]


# -- nothing expensive, nothing written -------------------------------------------------------------

@pytest.fixture
def no_meshing(monkeypatch):
    """Make any meshing fail loudly: validation must not need it."""
    from ngs_geomech.run import driver as run_mod

    def forbidden(*args, **kwargs):
        raise AssertionError("a mesh was generated for an invalid scene")
    monkeypatch.setattr(run_mod, "make_mesh", forbidden)


@pytest.mark.parametrize("name", ["several_problems", "syntax_error", "probe_in_notch",
                                  "touching_without_interface", "rho_c_not_positive"])
def test_failed_run_creates_no_output_directory(name, tmp_path, capsys, no_meshing):
    out = tmp_path / "results" / "run1"
    rc = cli.main(["run", str(BAD / f"{name}.toml"), "--out", str(out), "--quiet"])
    captured = capsys.readouterr()
    assert rc == 2
    assert captured.out == ""
    assert expectations(BAD / f"{name}.toml")[0] in captured.err
    assert not out.exists()
    assert list(tmp_path.rglob("*")) == [], "nothing may be created, not even a staging directory"


def test_bad_override_is_reported_before_anything_is_written(tmp_path, capsys, no_meshing):
    out = tmp_path / "run"
    rc = cli.main(["run", "canister", "--out", str(out), "--set", "time.dt=-5", "--set", "materials.granite.rho_c=0",
                   "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "time.dt" in err and "materials.granite.rho_c" in err
    assert list(tmp_path.iterdir()) == []


def test_override_with_unknown_key_gets_a_suggestion(capsys):
    rc = cli.main(["validate", "canister", "--set", "mesh.maxhh=3"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "mesh.maxhh" in err and "did you mean 'maxh'" in err


# -- valid scenes near the edges of the rules -------------------------------------------------------

def test_small_axisymmetric_scene_on_the_axis_is_valid():
    """A geometry of centimetres touching the axis: OCC's padded bounding box must not count as x < 0."""
    data = {"scene": {"name": "small_axi", "dimension": "axisymmetric"}, "physics": {"thermal": "steady"},
            "blocks": [{"name": "sample", "shape": "rectangle", "origin": [0.0, 0.0], "size": [0.01, 0.02],
                        "boundaries": {"mantle": "xmax"}}],
            "materials": {"sample": {"conductivity": 1.0}},
            "boundary_conditions": {"mantle": {"temperature": 20.0}}}
    geo = validate(scene_from_dict(data))
    assert geo.regions == ["sample"]


def test_probe_inside_a_concave_block_is_valid():
    data = {"scene": {"name": "ell"}, "physics": {"thermal": "steady"},
            "blocks": [{"name": "ell", "shape": "polygon",
                        "points": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]],
                        "edges": ["bottom", "", "", "", "", "left"]}],
            "materials": {"ell": {"conductivity": 2.0}},
            "boundary_conditions": {"bottom": {"temperature": 0.0}},
            "output": {"probes": [{"name": "arm", "point": [0.5, 1.5]}, {"name": "corner", "point": [1.0, 1.0]},
                                  {"name": "foot", "point": [1.5, 0.5]}]}}
    validate(scene_from_dict(data))


def test_every_builtin_scene_is_valid(capsys):
    from ngs_geomech.scene.parse import builtin_scenes
    names = builtin_scenes()
    assert "canister" in names
    for name in names:
        assert cli.main(["validate", name]) == 0, capsys.readouterr().err
    assert capsys.readouterr().err == ""
