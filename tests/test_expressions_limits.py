"""Bounded cost of the expression checker: long, deep and explosive expressions are refused in well under a
second with one message; constants are folded with bounded arithmetic; the values of scene expressions are
checked before meshing; k(T) <= 0 during a run names the material."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from ngs_geomech.api import run
from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.scene import expressions
from ngs_geomech.scene.parse import load_scene, scene_from_dict
from ngs_geomech.validation.validate import validate

BAD = Path(__file__).parent / "scenes" / "bad"


def _check(text: str) -> str:
    t0 = time.perf_counter()
    problems = expressions.check(text)
    assert time.perf_counter() - t0 < 1.0, "the check must be bounded"
    assert len(problems) == 1, problems
    assert len(problems[0]) < 400, "a long expression is not echoed whole"
    return problems[0]


@pytest.mark.parametrize("text, expected", [
    ("+".join(["x"] * 100_000), "characters long"),
    ("1+" * 500_000 + "1", "characters long"),                   # 1 MB
    ("-" * 100_000 + "x", "characters long"),
    ("-" * 5_000 + "x", "too deeply nested"),                    # the parser's own RecursionError
    ("x**" * 3_000 + "2", "too deeply nested"),                  # the parser's own MemoryError
    ("-" * 300 + "x", "too deeply nested"),
    ("+".join(["x"] * 2_500), "too deeply nested"),
    ("+".join(["x*x"] * 1_200)[:9_999], "too deeply nested"),
])
def test_size_and_depth_are_bounded(text, expected):
    assert expected in _check(text)


@pytest.mark.parametrize("text, expected", [
    ("(y+10)**9**9", "exponent 387420489"),
    ("x**65", "exponent 65"),
    ("x**-100", "exponent -100"),
    ("9**9**9", "too large"),
    ("0.5**-2000", "too large"),
    ("1/0", "division by zero"),
    ("x/(2-2)", "division by zero"),
    ("0**-1", "division by zero"),
    ("1" + "0" * 400 + "*x", "too large"),
    ("1e400*x", "the number 1e400 is too large"),
    ("1e308*10+x", "overflows"),
    ("sqrt(-1)*x", "sqrt(-1) has no finite value"),
    ("log(0)+y", "log(0) has no finite value"),
    ("exp(1000)", "exp(1000) has no finite value"),
    ("(-8)**(1/3)", "negative number to a fractional power"),
    ("exp + 1", "function 'exp' without an argument"),
])
def test_constants_are_folded_with_bounded_arithmetic(text, expected):
    assert expected in _check(text)


@pytest.mark.parametrize("text", ["x**64", "x**0.5", "(x+1)**-3", "10 + 0.03*(-y)", "1700*exp(-t/(50*year))",
                                  "2**1000*x", "+".join(["x"] * 150), "sqrt(x*x + y*y)"])
def test_ordinary_expressions_pass(text):
    assert expressions.check(text) == []


def test_float_function_reports_points_without_value():
    f = expressions.float_function("sqrt(-1-x)")
    with pytest.raises(ValueError):
        f(x=0.0)
    assert expressions.float_function("(x-1)**0.5")(x=2.0) == 1.0
    with pytest.raises(ValueError, match="fractional power"):
        expressions.float_function("(x-1)**0.5")(x=0.0)


PLATE = {
    "scene": {"name": "plate"},
    "physics": {"thermal": "transient"},
    "mesh": {"maxh": 0.5},
    "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0.0, -1.0], "size": [1.0, 1.0],
                "boundaries": {"left": "xmin"}}],
    "materials": {"rock": {"conductivity": 2.0, "rho_c": 2.0e6}},
    "boundary_conditions": {"left": {"temperature": 0.0}},
    "time": {"end": 2.0, "dt": 1.0},
    "output": {"vtk": False, "figures": False},
}


def _scene(**changes):
    import copy
    data = copy.deepcopy(PLATE)
    for path, value in changes.items():
        node = data
        *head, last = path.split("__")
        for k in head:
            node = node.setdefault(k, {})
        node[last] = value
    return scene_from_dict(data)


@pytest.mark.parametrize("key, value, expected", [
    ("initial__temperature", "sqrt(-1-x)", "at x=0, y=-1"),
    ("initial__temperature", "1/(y-y)", "division by zero"),
    ("boundary_conditions__left__temperature", "log(y+0.5)", "boundary_conditions.left.temperature"),
    ("boundary_conditions__left__temperature", "1/(t-1)", "t=1 s"),
])
def test_validate_names_where_an_expression_is_not_finite(key, value, expected):
    with pytest.raises(SceneError) as info:
        validate(_scene(**{key: value}))
    (problem,) = info.value.problems
    assert problem.item == key.replace("__", ".")
    assert "is not finite" in str(problem) and expected in str(problem)


def test_expressions_finite_only_where_they_apply_pass():
    # log(x) is not finite at x = 0 but the boundary 'right' is x = 1; sqrt(y+1) is finite on the plate
    sc = _scene(blocks=[{"name": "rock", "shape": "rectangle", "origin": [0.0, -1.0], "size": [1.0, 1.0],
                         "boundaries": {"left": "xmin", "right": "xmax"}}],
                boundary_conditions={"left": {"temperature": 0.0}, "right": {"temperature": "log(x)"}},
                initial={"temperature": "sqrt(y+1)"})
    validate(sc)


def test_validate_checks_k_of_T_at_the_prescribed_temperatures():
    sc = _scene(materials__rock__conductivity_temperature_coefficient=-0.15,
                boundary_conditions__left__temperature=10.0)
    with pytest.raises(SceneError) as info:
        validate(sc)
    (problem,) = info.value.problems
    assert problem.item == "materials.rock.conductivity_temperature_coefficient"
    assert "T = 10" in problem.message and "boundary_conditions.left.temperature" in problem.message


def test_run_names_the_material_where_k_of_T_becomes_negative():
    sc = _scene(materials__rock__conductivity_temperature_coefficient=-0.01,
                sources=[{"region": "rock", "density": 2.0e4}], time={"end": 86400.0, "dt": 86400.0})
    validate(sc)                      # the data are in range: the source heats beyond T = 100
    with pytest.raises(SolverError, match=r"material 'rock'.* not positive at T = .*positive only for T < 100"):
        run(sc, None, progress=False, threads=1)


def test_bad_number_files_name_the_key():
    with pytest.raises(SceneError) as info:
        load_scene(BAD / "number_huge_integer.toml")
    assert info.value.problems[0].item == "materials.rock.conductivity"


# -- what the sampling of validation misses shows on the mesh, named -------------------------------------------
HOLE = "sqrt((x-0.3)**2 + (y+0.6)**2 - 9e-4)"      # NaN in a disk of radius 0.03 between the sampled points


def test_run_names_an_initial_temperature_not_finite_between_the_sampled_points():
    sc = _scene(mesh__maxh=0.05, initial__temperature=HOLE)
    validate(sc)
    with pytest.raises(SceneError) as info:
        run(sc, None, progress=False, threads=1)
    assert info.value.problems[0].item == "initial.temperature"
    assert "not finite at some points of the mesh" in str(info.value)


def test_run_names_a_boundary_temperature_not_finite_between_the_sampled_points():
    sc = _scene(mesh__maxh=0.05, boundary_conditions__left__temperature="sqrt((y+0.6)**2 - 4e-4)")
    validate(sc)
    with pytest.raises(SolverError, match=r"boundary_conditions\.left\.temperature is not finite"):
        run(sc, None, progress=False, threads=1)


def test_stefan_run_names_an_initial_temperature_not_finite_between_the_sampled_points():
    sc = _scene(mesh__maxh=0.05, initial__temperature=f"{HOLE} - 1",
                materials__rock__phase_change_temperature=0.0, materials__rock__latent_heat_volumetric=1e6,
                materials__rock__rho_c_liquid=2e6, materials__rock__conductivity_liquid=1.0)
    validate(sc)
    with pytest.raises(SceneError) as info:
        run(sc, None, progress=False, threads=1)
    assert info.value.problems[0].item == "initial.temperature"
    assert "not finite at some vertices of the mesh" in str(info.value)       # the Stefan run's nodal check
