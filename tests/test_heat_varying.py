"""Material data that vary in space and with the temperature (seed (2.17), (2.43) with kappa(x, T), rho c(x, T)):
the expression functions min, max, if, erfc and interp against numpy / scipy through the float evaluator and the
CoefficientFunction; the validation of varying material values (key, region, point); manufactured solutions with
kappa(x, y) and kappa(x, y, T) (errors printed, orders asserted); Newton's quadratic convergence with kappa(T) and
rho c(T) in transient steps; the Stefan solver's refusal."""

from __future__ import annotations

import functools
import math

import ngsolve as ngs
import numpy as np
import pytest
from scipy import special

from ngs_geomech.api import run
from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.fem.coefficients import expression_function, material_cf
from ngs_geomech.scene import expressions
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import varying_heat as vh

XS = np.linspace(-2.0, 2.0, 17)
"""Sample abscissae (the points of a 1 x 1 mesh are mapped from them: x = (X + 2)/4)."""

TABLE_X, TABLE_Y = [0.0, 0.25, 0.5, 1.0], [2.0, 3.0, 2.5, 4.0]

CASES = [
    ("min(x, 0.5)", lambda x, y: np.minimum(x, 0.5)),
    ("min(x, y, 0.3)", lambda x, y: np.minimum(np.minimum(x, y), 0.3)),
    ("max(x, 1 - x)", lambda x, y: np.maximum(x, 1 - x)),
    ("max(x*y, 0.1, y - 0.5)", lambda x, y: np.maximum(np.maximum(x * y, 0.1), y - 0.5)),
    ("if(x < 0.5, 1 + x, 2*y)", lambda x, y: np.where(x < 0.5, 1 + x, 2 * y)),
    ("if(x <= 0.5, 1 + x, 2*y)", lambda x, y: np.where(x <= 0.5, 1 + x, 2 * y)),
    ("if(x > y, x - y, 0)", lambda x, y: np.where(x > y, x - y, 0.0)),
    ("if(x >= 0.5, 3, -1)", lambda x, y: np.where(x >= 0.5, 3.0, -1.0)),
    ("erfc(4*x - 2)", lambda x, y: special.erfc(4 * x - 2)),
    ("erfc(3*y)*exp(x)", lambda x, y: special.erfc(3 * y) * np.exp(x)),
    (f"interp(x, {TABLE_X}, {TABLE_Y})", lambda x, y: np.interp(x, TABLE_X, TABLE_Y)),
    (f"interp(1.5*x - 0.25, {TABLE_X}, {TABLE_Y})", lambda x, y: np.interp(1.5 * x - 0.25, TABLE_X, TABLE_Y)),
    ("interp(-y, [-1, -0.5], [7, 9]) + min(x, y)", lambda x, y: np.interp(-y, [-1, -0.5], [7, 9]) + np.minimum(x, y)),
]


@functools.cache
def _mesh():
    return ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.2))


def _points():
    """Points of the unit square: a grid through the table's breakpoints and the ends (x = 0.5 exactly)."""
    g = np.linspace(0.0, 1.0, 9)
    x, y = np.meshgrid(g, g[::-1] * 0.9 + 0.05)
    return x.ravel(), y.ravel()


@pytest.mark.parametrize("text, reference", CASES, ids=[c[0] for c in CASES])
def test_functions_against_numpy_and_scipy(text, reference):
    x, y = _points()
    expected = reference(x, y)
    f = expressions.float_function(text)
    python = np.array([f(x=a, y=b) for a, b in zip(x, y)])
    cf = expression_function(text)(ngs.Parameter(0.0))
    mesh = _mesh()
    ngsolve = np.asarray(cf(mesh(x, y)), dtype=float).ravel()
    err_py = float(np.max(np.abs(python - expected)))
    err_cf = float(np.max(np.abs(ngsolve - expected)))
    print(f"\n{text}: {len(x)} points, max |python - ref| {err_py:.2e}, max |CF - ref| {err_cf:.2e}")
    assert err_py <= 1e-14 * max(1.0, float(np.max(np.abs(expected))))
    assert err_cf <= 4e-15 * max(1.0, float(np.max(np.abs(expected)))) + (2e-16 if "erfc" in text else 0.0)


def test_erfc_relative_accuracy_of_the_float_evaluator():
    for v in (0.0, 0.5, 2.0, 5.0, 10.0, 26.0):
        assert expressions.evaluate("erfc(x)", x=v) == pytest.approx(float(special.erfc(v)), rel=1e-15)


def test_interp_is_constant_beyond_the_ends_and_linear_between():
    text = "interp(x, [0, 1000, 5000], [2e3, 2.5e3, 3e3])"
    f = expressions.float_function(text)
    assert [f(x=v) for v in (-10.0, 0.0, 500.0, 1000.0, 3000.0, 5000.0, 1e6)] == \
        [2e3, 2e3, 2250.0, 2500.0, 2750.0, 3e3, 3e3]


def test_derivatives_of_the_new_functions_in_coefficient_functions():
    """d/dx of the CFs (what Newton's tangent takes of an expression of T) against finite differences."""
    mesh = _mesh()
    x, y = _points()
    texts = ("min(x*x, 0.3)", "max(x, 1 - x)", "if(x < 0.5, x*x, 2*x)", "erfc(2*x)", f"interp(x, {TABLE_X}, {TABLE_Y})")
    for text in texts:
        cf = expression_function(text)(ngs.Parameter(0.0))
        d = np.asarray(cf.Diff(ngs.x)(mesh(x, y)), dtype=float).ravel()
        f = expressions.float_function(text)
        kinks = {0.0, 0.25, 0.5, 1.0, math.sqrt(0.3)}
        for a, b, dv in zip(x, y, d):
            if min(abs(a - k) for k in kinks) < 1e-3:
                continue
            fd = (f(x=a + 1e-6, y=b) - f(x=a - 1e-6, y=b)) / 2e-6
            assert dv == pytest.approx(fd, rel=1e-6, abs=1e-6), (text, a)


@pytest.mark.parametrize("text, message", [
    ("interp(-y, [0, 1000, 500], [1, 2, 3])", "not strictly increasing (1000 then 500"),
    ("interp(-y, [0, 1000], [1, 2, 3])", "2 abscissae and 3 values"),
    ("interp(-y, [0], [1])", "from 2 to 256"),
    ("interp(-y, [0, x], [1, 2])", "must be numbers (constants)"),
    ("interp(-y, 0, 1)", "tables of interp() must be lists"),
    ("interp(-y, " + str(list(range(300))) + ", " + str(list(range(300))) + ")", "from 2 to 256"),
    ("if(x, 1, 2)", "condition of if() must be a comparison"),
    ("if(x == 1, 1, 2)", "compares with <, <=, > or >="),
    ("if(0 < x < 1, 1, 2)", "one comparison"),
    ("x < 1", "only as the condition of if"),
    ("min(x)", "min() takes at least 2 arguments, got 1"),
    ("erfc(x, 1)", "erfc() takes 1 argument, got 2"),
    ("[1, 2]", "only as a table of interp"),
    ("if_(x < 1, 1, 2)", "unknown name(s) 'if_'"),
    ("T + 1", "unknown name(s) 'T'"),
])
def test_bad_uses_are_refused_naming_the_key(text, message):
    data = _plate()
    data["boundary_conditions"]["left"]["temperature"] = text
    with pytest.raises(SceneError) as info:
        scene_from_dict(data)
    (problem,) = info.value.problems
    print(f"\n{problem}")
    assert problem.item == "boundary_conditions.left.temperature"
    assert message in problem.message


# -- material values: validation -------------------------------------------------------------------------------
def _plate(**material) -> dict:
    return {"scene": {"name": "plate"}, "physics": {"thermal": "transient"}, "mesh": {"maxh": 0.25},
            "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0.0, -1.0], "size": [1.0, 1.0],
                        "boundaries": {"left": "xmin", "right": "xmax"}}],
            "materials": {"rock": {"conductivity": 2.0, "rho_c": 2.0e6, **material}},
            "boundary_conditions": {"left": {"temperature": 0.0}, "right": {"temperature": 100.0}},
            "time": {"end": 2.0, "dt": 1.0}, "output": {"vtk": False, "figures": False}}


@pytest.mark.parametrize("material, key, message", [
    ({"conductivity": "x - 0.5"}, "conductivity", "must be positive, got -0.5 W/(m K) at x=0, y=-1 of region 'rock'"),
    ({"conductivity": "1 - 0.02*T"}, "conductivity", "must be positive, got 0 W/(m K) at x=0, y=-1 and T = 50"),
    ({"rho_c": "2e6*log(x)"}, "rho_c", "is not finite (a function outside its domain) at x=0, y=-1"),
    ({"rho_c": None, "density": "2700 - 3000*(x > 0.5)"}, "density", "comparison"),
    ({"rho_c": None, "density": "2700*(1 + y)", "specific_heat": 800.0}, "density", "must be positive, got 0 kg/m^3"),
    ({"conductivity": [["1", "2*x"], ["2*x", "1"]]}, "conductivity", "is not positive definite"),
    ({"conductivity": [["1", "x"], ["0.5*x", "1"]]}, "conductivity", "not symmetric: entries [1][0]"),
    ({"conductivity": None, "conductivity_principal": ["1 + x", "y"], "conductivity_angle": 30.0},
     "conductivity_principal[1]", "must be positive, got -1 W/(m K)"),
    ({"conductivity": "2 + t"}, "conductivity", "unknown name(s) 't' (variables x, y, z, r, T"),
    ({"density": "2700 + T"}, "density", "unknown name(s) 'T' (variables x, y, z, r;"),
])
def test_validation_names_key_region_and_point(material, key, message):
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(_plate(**material)))
    problems = [p for p in info.value.problems if p.item == f"materials.rock.{key}"]
    print(f"\n{info.value.problems}")
    assert problems and message in problems[0].message


def test_valid_varying_materials_pass():
    validate(scene_from_dict(_plate(conductivity="interp(-y, [0, 0.5, 1], [1.5, 2.5, 3])*(1 + 0.002*T)",
                                    rho_c=None, density="2700 + 100*(-y)", specific_heat="800 + T")))
    validate(scene_from_dict(_plate(conductivity=None, conductivity_principal=["1 + x", "2"],
                                    conductivity_angle=30.0)))


@pytest.mark.parametrize("material, key, message", [
    ({"conductivity": "2 + x", "conductivity_liquid": 1.0}, "conductivity_liquid", "times the solid's conductivity"),
    ({"conductivity": "2 + x", "conductivity_liquid": "1 + x"}, "conductivity_liquid", "times the solid's"),
    ({"conductivity": "2 + T", "conductivity_liquid": 1.0}, "conductivity", "depends on T"),
    ({"rho_c": "2e6 + x"}, "rho_c", "takes the heat capacity as a number"),
])
def test_phase_change_scenes_refuse_varying_data_naming_the_key(material, key, message):
    """Conductivities of x, y, z are taken when the phases share the variation (tests/test_stefan_varying.py);
    a ratio that changes, a conductivity of T and a heat capacity expression are refused by key."""
    data = _plate(**{"conductivity": 2.0, "phase_change_temperature": 0.0, "latent_heat_volumetric": 1e6,
                     "rho_c_liquid": 2e6, "conductivity_liquid": 1.0, **material})
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    (problem,) = info.value.problems
    print(f"\n{problem}")
    assert problem.item == f"materials.rock.{key}"
    assert "Stefan" in problem.message and message in problem.message


def test_mechanics_takes_a_density_expression():
    """The density of the heat capacity is also the mechanics' (gravity, inertia: tests/test_elastic_varying.py)."""
    data = _plate(density="2700 + x", youngs_modulus=1e10, poisson_ratio=0.25, thermal_expansion=1e-5)
    data["physics"]["mechanics"] = "static"
    data["boundary_conditions"]["left"]["displacement"] = [0.0, 0.0]
    validate(scene_from_dict(data))


def test_run_names_the_material_where_a_conductivity_of_T_stops_being_positive():
    """The sampled temperatures (0 to 100) keep kappa positive; the source heats past T = 200."""
    data = _plate(conductivity="2*(1 - T/200)")
    data["sources"] = [{"region": "rock", "density": 4.0e5}]
    data["time"] = {"end": 86400.0, "dt": 86400.0}
    sc = scene_from_dict(data)
    validate(sc)
    with pytest.raises(SolverError, match=r"conductivity of material 'rock' is not positive at x=.* where T = "):
        run(sc, None, progress=False, threads=1)


def test_a_constant_expression_gives_the_number_path_result():
    """A material value "2 + 0*x" (an expression) and 2.0 (a number) give the same temperatures (to rounding)."""
    series = []
    for k, c in ((2.0, 2.0), ("2 + 0*x", "2 + 0*y*T")):
        data = _plate(conductivity=k, rho_c=c)
        data["output"]["probes"] = [{"name": "mid", "point": [0.5, -0.5]}]
        summary = run(scene_from_dict(data), None, progress=False, threads=1).summary
        series.append(np.array(summary["probe_series"]["mid"]))
    print(f"\nnumbers {series[0]}, expressions {series[1]}")
    assert np.max(np.abs(series[0] - series[1])) < 1e-9 * np.max(np.abs(series[0]))


def test_material_cf_substitutes_the_temperature():
    mesh = _mesh()
    T = ngs.GridFunction(ngs.H1(mesh, order=1))
    T.Set(10 * ngs.x)
    cf = material_cf("interp(T, [0, 5, 10], [1, 2, 4]) + y", T)
    assert cf(mesh(0.75, 0.5)) == pytest.approx(2 + 2 * 2.5 / 5 + 0.5)
    with pytest.raises(ValueError, match="depends on T"):
        material_cf("1 + T")


# -- verification ----------------------------------------------------------------------------------------------
HS = (0.2, 0.1, 0.05, 0.025)
DTS = (0.2, 0.1, 0.05, 0.025)


def _rates(hs, errors) -> str:
    return " ".join(f"{math.log(errors[k - 1] / errors[k]) / math.log(hs[k - 1] / hs[k]):.2f}"
                    for k in range(1, len(hs)))


@pytest.mark.parametrize("law", ["x", "xT"])
@pytest.mark.parametrize("order, l2_min, h1_min", [(1, 1.9, 0.95), (2, 2.9, 1.9)])
def test_steady_manufactured_solution_with_varying_conductivity(law, order, l2_min, h1_min):
    res = vh.steady_convergence(order, HS, law)
    print(f"\nsteady P{order}, kappa = {res['conductivity']}: h, L2 (K m), H1 (K), Newton iterations")
    for h, e0, e1, n in zip(res["h"], res["l2"], res["h1"], res["newton_iterations"]):
        print(f"  {h:6.3f} {e0:11.3e} {e1:11.3e} {n:3d}")
    print(f"  rates L2 {_rates(res['h'], res['l2'])}, H1 {_rates(res['h'], res['h1'])}; fitted L2 "
          f"{res['order_l2']:.3f}, H1 {res['order_h1']:.3f}")
    assert res["order_l2"] >= l2_min and res["order_h1"] >= h1_min
    if law == "xT":
        assert max(res["newton_iterations"]) <= 8


@pytest.mark.parametrize("scheme, order_min", [("backward_euler", 0.9), ("crank_nicolson", 1.9)])
def test_transient_newton_is_quadratic_and_the_time_order_holds(scheme, order_min):
    res = vh.transient_convergence(scheme, DTS)
    print(f"\ntransient {scheme}, kappa = {vh.KAPPA_T}, rho c = {vh.RHO_C_T} (P2, {res['ndofs'][0]} dofs): dt, "
          f"L2 error at t = 1 s (K m)")
    for dt, e in zip(res["dt"], res["l2"]):
        print(f"  {dt:6.3f} {e:11.3e}")
    print(f"  fitted time order {res['order']:.3f}")
    first = res["first_run"]
    for k, (r, q) in enumerate(zip(first["residuals"], first["newton_order_last"])):
        ratios = " ".join(f"{r[i + 1] / r[i] ** 2:.2e}" for i in range(len(r) - 1) if r[i + 1] > vh.NOISE)
        print(f"  dt {first['dt']} step {k + 1}: residuals {' '.join(f'{v:.1e}' for v in r)}; r_k+1/r_k^2 "
              f"{ratios}; observed order {q if q is None else round(q, 3)}")
    print(f"  Newton iterations at most {res['iterations_max']}, smallest observed order {res['newton_order_min']:.3f}")
    assert res["order"] >= order_min
    assert res["newton_order_min"] >= 1.8
    assert res["iterations_max"] <= 6


@pytest.mark.parametrize("law", ["x", "xT"])
def test_estimators_take_the_varying_conductivity(law):
    """ZZ and residual effectivities on the steady manufactured solution stay bounded and do not drift with h
    (the residual holds the derivatives of kappa(x, T); measured: ZZ 0.98-1.10, residual 1.4-2.6)."""
    from ngs_geomech.adapt import estimators as est

    kappa = {"x": vh.KAPPA_X, "xT": vh.KAPPA_XT}[law]
    for order in (1, 2):
        eff = []
        for h in (0.1, 0.05):
            mesh, forms, solver = vh.prepare(vh.square_scene(h, order, kappa, vh.T_STEADY), vh.T_STEADY, kappa,
                                              None)
            forms.t_new.Set(0.0)
            solver.solve("estimator check")
            T = expression_function(vh.T_STEADY)(forms.t_new)
            err = est.heat_energy_error(forms, {"square": ngs.CoefficientFunction((T.Diff(ngs.x), T.Diff(ngs.y)))})
            estimates = (est.zz_heat(forms), est.residual_heat(forms))
            eff.append([float(np.sqrt(np.sum(e.eta ** 2))) / err for e in estimates])
        print(f"\nkappa({law}) P{order}: effectivities (ZZ, residual) at h = 0.1, 0.05: {np.round(eff, 3).tolist()}")
        for k in range(2):
            assert 0.8 < eff[0][k] < 3.0 and abs(eff[1][k] / eff[0][k] - 1) < 0.1


@pytest.mark.parametrize("dimension", ["3d", "axisymmetric"])
def test_scenes_with_depth_and_temperature_tables_run(dimension):
    """A conductivity table in depth times a table in T (Newton through interp's IfPos pieces), a heat capacity
    of depth, in a 3D box and an axisymmetric section: the runs converge, and the temperatures match the 1D closed
    form G(T(d)) = G(100) A(d) / A(1), G = int g(T) dT, A = int dd / a(d) (within 0.3 K at h = 0.1 m, P1)."""
    depth = "-z" if dimension == "3d" else "-y"
    block = ({"name": "rock", "shape": "box", "origin": [0.0, 0.0, -1.0], "size": [0.5, 0.5, 1.0],
              "boundaries": {"top": "zmax", "bottom": "zmin"}} if dimension == "3d" else
             {"name": "rock", "shape": "rectangle", "origin": [0.0, -1.0], "size": [0.5, 1.0],
              "boundaries": {"top": "ymax", "bottom": "ymin"}})
    data = {"scene": {"name": "tables", "dimension": dimension}, "physics": {"thermal": "steady"},
            "mesh": {"maxh": 0.1}, "blocks": [block],
            "materials": {"rock": {"conductivity": f"interp({depth}, [0, 0.5, 1], [1.0, 2.0, 4.0])"
                                                  "*interp(T, [0, 50, 100], [3, 2.5, 2])",
                                   "rho_c": f"2e6 + 1e5*{depth}"}},
            "boundary_conditions": {"top": {"temperature": 0.0}, "bottom": {"temperature": 100.0}},
            "output": {"vtk": False, "figures": False,
                       "probes": [{"name": f"p{k}", "point": [0.25, 0.25, -0.25 * k] if dimension == "3d"
                                   else [0.25, -0.25 * k]} for k in (1, 2, 3)]}}
    summary = run(scene_from_dict(data), None, progress=False, threads=1).summary
    values = [summary["probes"][f"p{k}"]["final"] for k in (1, 2, 3)]
    print(f"\n{dimension}: T at depths 0.25, 0.5, 0.75 m: {values}; Newton iterations "
          f"{summary['newton_iterations_max']}")
    d = np.linspace(0.0, 1.0, 200001)
    a, temps = np.interp(d, [0, 0.5, 1], [1.0, 2.0, 4.0]), np.linspace(0.0, 100.0, 200001)
    g = np.interp(temps, [0, 50, 100], [3.0, 2.5, 2.0])
    A = np.concatenate([[0.0], np.cumsum((1 / a[1:] + 1 / a[:-1]) / 2 * np.diff(d))])
    G = np.concatenate([[0.0], np.cumsum((g[1:] + g[:-1]) / 2 * np.diff(temps))])
    exact = [float(np.interp(G[-1] * np.interp(0.25 * k, d, A) / A[-1], G, temps)) for k in (1, 2, 3)]
    print(f"  closed form {exact}")
    assert np.max(np.abs(np.array(values) - exact)) < 0.3
    assert summary["newton_iterations_max"] <= 10
