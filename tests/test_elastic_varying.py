"""Elastic data that vary in space (and E with the temperature), seed (2.18)/(2.37) with c_ijkl(x), beta(x), T0(x):
the stiffness built from expressions against the number path at points; the validation of varying elastic and
contact values (key, region, point); the representative values; manufactured thermo-elasticity with E(x, y, T),
nu(x, y), alpha(x, y), T0(x), rho(x, y) (errors printed, orders asserted: plane strain and axisymmetric, P1 and P2,
displacement and mixed formulations); gravity and inertia with a varying density; a Coulomb friction coefficient
that varies along a contact: the slip zone where it is below the slope."""

from __future__ import annotations

import math
import re

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech.api import run
from ngs_geomech.errors import MaterialError, SceneError, SolverError
from ngs_geomech.mechanics import materials as em
from ngs_geomech.scene import expressions
from ngs_geomech.scene.model import Material, Orthotropic, TransverselyIsotropic
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.scene.schema import material_at
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import varying_elastic as ve

pytestmark = pytest.mark.usefixtures("one_thread")

_TI = em.rotate_voigt(em.transversely_isotropic(30e9, 80e9, 0.2, 0.25, 20e9), em.rotation([20.0, 35.0, 50.0], 3))
_VOIGT = [[f"{float(_TI[i, j])!r}*(1 + 0.2*x*y)" if i < 3 and j < 3 else float(_TI[i, j]) for j in range(6)]
          for i in range(6)]
MATERIALS = {
    "isotropic": Material(youngs_modulus="30e9*(1 + x)", poisson_ratio="0.2 + 0.1*y",
                          thermal_expansion="1e-5*(1 + 0.5*z)", stress_free_temperature="3*y", density="2600 + x"),
    "lame": Material(lame_lambda="1e10*(1 + x*y)", lame_mu="8e9 + 1e9*y", elastic_rotation=[10.0, 20.0, 30.0],
                     thermal_expansion=[["8e-6*(1 + x)", 1e-6, 0.0], [1e-6, "5e-6 + 1e-6*y", 0.0], [0.0, 0.0, 6e-6]]),
    "orthotropic": Material(orthotropic=Orthotropic(E=["60e9*(1 + 0.5*x)", 25e9, 40e9], nu=[0.25, "0.2 + 0.05*y", 0.3],
                                                    G=[15e9, "12e9*(1 + 0.1*x)", 10e9]),
                            elastic_rotation=[30.0, 10.0, 5.0], thermal_expansion="7e-6*(1 + y)"),
    "transversely_isotropic": Material(transversely_isotropic=TransverselyIsotropic(
        E_plane="30e9*(1 + 0.5*y)", E_axis=80e9, nu_plane=0.2, nu_axis="0.25 - 0.05*x", G_axis=20e9),
        elastic_rotation=[0.0, 0.0, 90.0], thermal_expansion=[[6e-6, 0, 0], [0, 6e-6, 0], [0, 0, "9e-6*(1 + x)"]]),
    "stiffness_voigt": Material(stiffness_voigt=_VOIGT, thermal_expansion=1e-5),
}
"""Materials of every stiffness group with expressions in some entries (x, y, z in m)."""
POINTS = ((0.0, 0.0, 0.0), (0.3, 0.7, 0.2), (1.0, 0.4, 0.9), (0.8, 1.0, 0.5))


def _scalar(values):
    def scalar(v):
        return float(v) if not isinstance(v, str) else expressions.float_function(v, expressions.ALL_VARIABLES)(
            **values)
    return scalar


def _rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1e-300))


@pytest.mark.parametrize("kind", sorted(MATERIALS))
def test_expressions_give_the_number_path_data_at_every_point(kind):
    """elastic_tensors with float operands at a point = elastic_properties of the material evaluated there, and the
    reductions (plane strain, plane stress, axisymmetric, 3D) = the number path's."""
    m = MATERIALS[kind]
    keys = em.elastic_varying_keys(m)
    worst = 0.0
    for x, y, z in POINTS:
        values = {"x": x, "y": y, "z": z, "r": x, "T": 0.0}
        t = em.elastic_tensors(m, 3, _scalar(values))
        p = em.elastic_properties(material_at(m, keys, {}, values), 3)
        worst = max(worst, _rel(t.C, p.C), _rel(t.b, em.to_voigt_stress(p.beta)))
        numbers = {"3d": (p.C, em.to_voigt_stress(p.beta)), "plane_strain": em.plane_strain(p.C, p.beta)[:2],
                   "plane_stress": em.plane_stress(p.C, p.beta)[:2]}
        if kind in ("isotropic", "transversely_isotropic"):
            numbers["axisymmetric"] = em.axisymmetric(p.C, p.beta)
        for model, (D, b) in numbers.items():
            red = em.reduce_tensors(model, t.C, t.b)
            worst = max(worst, _rel(red.D, D), _rel(red.b, b))
        assert float(t.T0) == pytest.approx(p.T0) and (t.density is None) == (p.density is None)
    print(f"\n{kind}: {len(keys)} varying keys, max relative difference to the number path {worst:.2e}")
    assert worst < 1e-12


def test_a_number_material_takes_the_number_path_and_refuses_samples_as_varying():
    plain = Material(youngs_modulus=1e10, poisson_ratio=0.25)
    assert em.elastic_varying_keys(plain) == []
    with pytest.raises(MaterialError, match="varying_elastic_properties"):
        em.elastic_properties(MATERIALS["isotropic"], 2)


def test_representative_values_are_the_stiffest_point_and_the_extremes():
    samples = [{"x": x, "y": y, "z": z, "r": x, "T": 0.0} for x, y, z in POINTS]
    p = em.varying_elastic_properties(MATERIALS["isotropic"], 2, samples)
    assert p.varying.points == 4 and p.varying.isotropic
    E, nu = p.youngs_modulus_and_poisson()
    assert E == pytest.approx(54e9) and nu == pytest.approx(0.3)         # x = 0.8, y = 1: the largest C11
    assert p.max_poisson == pytest.approx(0.3)                            # y = 1
    assert p.T0 == 0.0 and p.density == pytest.approx(2601.0)
    q = em.varying_elastic_properties(MATERIALS["orthotropic"], 3, samples)
    assert q.youngs_modulus_and_poisson() is None and not q.varying.isotropic


# ------------------------------------------------------------------------------------------------ validation

def _square(material: dict, **physics):
    data = {"scene": {"name": "varying_elastic", "dimension": physics.pop("dimension", "plane")},
            "physics": {"mechanics": "static", **physics},
            "mesh": {"maxh": 0.25},
            "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0.0, -1.0], "size": [1.0, 1.0],
                        "boundaries": {"bottom": "ymin", "top": "ymax"}}],
            "materials": {"rock": {"youngs_modulus": 1e10, "poisson_ratio": 0.25, **material}},
            "boundary_conditions": {"bottom": {"displacement": [0.0, 0.0]}},
            "output": {"vtk": False, "figures": False}}
    if physics.get("thermal"):
        data["materials"]["rock"]["conductivity"] = 2.0
        data["boundary_conditions"]["top"] = {"temperature": 50.0}
        data["boundary_conditions"]["bottom"]["temperature"] = 10.0
    return data


BAD = [
    ({"youngs_modulus": "1e10*(1 + 2*y)"}, {}, "materials.rock.youngs_modulus",
     "must be positive, got -1e+10 Pa at x=0, y=-1 of region 'rock' (expression '1e10*(1 + 2*y)')"),
    ({"poisson_ratio": "0.3 - 0.3*y"}, {}, "materials.rock.poisson_ratio",
     "must be in (-1, 0.5), got 0.6 at x=0, y=-1"),
    ({"density": "2000 + 3000*y"}, {}, "materials.rock.density", "must be positive, got -1000 kg/m^3 at x=0, y=-1"),
    ({"youngs_modulus": "1e10*(1 - T/40)"}, {"thermal": "steady"}, "materials.rock.youngs_modulus",
     "must be positive, got -2.5e+09 Pa at x=0, y=-1 and T = 50"),
    ({"youngs_modulus": None, "poisson_ratio": None,
      "orthotropic": {"E": [1e9, 1e9, 1e9], "nu": ["1.2*x", 0.1, 0.1], "G": [1e9, 1e9, 1e9]}}, {},
     "materials.rock.orthotropic", "stiffness is not positive definite"),
    ({"youngs_modulus": "1e10*(1 + y*y)", "rheology_lambda": 0.5}, {}, "materials.rock.youngs_modulus",
     "the lambda law"),
    ({"youngs_modulus": "1e10*(1 + T/100)"}, {}, "materials.rock.youngs_modulus", "physics.thermal is off"),
    ({"rheology_lambda": "1 + x"}, {}, "materials.rock.rheology_lambda", "takes a number, not the expression"),
    ({"youngs_modulus": None, "poisson_ratio": None, "elastic_rotation": [0, 30, 0],
      "transversely_isotropic": {"E_plane": "1e10*(1 - y)", "E_axis": 2e10, "nu_plane": 0.2, "nu_axis": 0.2,
                                 "G_axis": 5e9}}, {"dimension": "axisymmetric"},
     "materials.rock.transversely_isotropic", "torsional shears (z-theta, r-theta) (relative size 0.065)"),
]


@pytest.mark.parametrize("material, physics, item, message", BAD, ids=[b[2] + ":" + b[3][:24] for b in BAD])
def test_validation_names_key_region_and_point(material, physics, item, message):
    data = _square({k: v for k, v in material.items() if v is not None}, **physics)
    for k in [k for k, v in material.items() if v is None]:
        data["materials"]["rock"].pop(k)
    if physics.get("dimension") == "axisymmetric":
        data["blocks"][0]["origin"] = [0.5, -1.0]
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    problems = info.value.problems
    print("\n" + "\n".join(f"{p.item}: {p.message}" for p in problems))
    assert [p.item for p in problems] == [item] and message in problems[0].message


def test_coupled_scene_checks_the_stress_free_temperature_field():
    data = _square({"thermal_expansion": 1e-5, "stress_free_temperature": "-273.15 - 10*y", "rho_c": 2e6},
                   thermal="transient")
    data["physics"]["coupling"] = "staggered"
    data["time"] = {"end": 10.0, "dt": 1.0}
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    problems = info.value.problems
    print("\n" + "\n".join(f"{p.item}: {p.message}" for p in problems))
    assert [p.item for p in problems] == ["materials.rock.stress_free_temperature"]
    assert "absolute reference temperature > 0 K" in problems[0].message and "x=0, y=0" in problems[0].message


def test_rate_terms_refuse_varying_stiffness():
    data = _square({"youngs_modulus": "1e10*(1 - y)", "density": 2500.0, "viscosity_time": 10.0})
    data["physics"]["mechanics"] = "viscous"
    data["time"] = {"end": 10.0, "dt": 1.0}
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    assert [p.item for p in info.value.problems] == ["materials.rock.youngs_modulus"]
    assert "rate terms" in info.value.problems[0].message


def test_varying_data_pass_validation():
    validate(scene_from_dict(_square({"youngs_modulus": "1e10*(1 - y)*(1 + T/1000)", "poisson_ratio": "0.25 + 0.1*y",
                                      "thermal_expansion": [["1e-5", 0, 0], [0, "1e-5*(1 - y)", 0], [0, 0, 1e-5]],
                                      "stress_free_temperature": "10 - 5*y", "density": "2700 - 100*y"},
                                     thermal="steady")))


# ------------------------------------------------------------------------------- manufactured thermo-elasticity

EXPECTED = {1: {"l2": 2.0, "h1": 1.0, "stress": 1.0}, 2: {"l2": 3.0, "h1": 2.0, "stress": 2.0}}


@pytest.mark.parametrize("model, order, formulation", [("plane_strain", 1, "displacement"),
                                                       ("plane_strain", 2, "displacement"),
                                                       ("axisymmetric", 1, "displacement"),
                                                       ("axisymmetric", 2, "displacement"),
                                                       ("plane_strain", 1, "mixed"), ("plane_strain", 2, "mixed")])
def test_manufactured_orders(model, order, formulation):
    """E(x, y, T), nu(x, y), alpha(x, y), T0(x), rho(x, y) under gravity: the orders of smooth problems."""
    r = ve.convergence(model, order, (0.2, 0.1, 0.05), formulation)
    print(f"\n{model} P{order} {formulation}: h {r['h']}, dofs {r['dofs']}")
    for key in ("l2", "h1", "stress"):
        print(f"  {key}: " + ", ".join(f"{e:.3e}" for e in r[key]) + f"  order {r[f'order_{key}']:.2f}"
              f"  (relative {r[key + '_rel'][-1]:.2e})")
        assert r[f"order_{key}"] > EXPECTED[order][key] - 0.15
    assert r["sample_points"] > 10


def test_varying_data_with_number_values_match_the_number_path():
    """A material of constant expressions ('30e9 + 0*x') solves the problem the numbers solve (to rounding)."""
    out = []
    for E, nu in ((30e9, 0.25), ("30e9 + 0*x", "0.25 + 0*y")):
        data = _square({"youngs_modulus": E, "poisson_ratio": nu, "density": 2500.0})
        data["mechanics"] = {"gravity": [0.0, -9.81]}
        res = run(scene_from_dict(data), None, progress=False, threads=1)
        u = res.mechanics.forms.displacement()
        out.append(np.array(u(res.mesh(0.5, 0.0))))
    print(f"\nnumbers {out[0]}, expressions {out[1]}")
    assert np.allclose(out[0], out[1], rtol=1e-10, atol=0)


def test_gravity_with_a_density_of_depth_matches_the_column_closed_form():
    """A column -1 < y < 0 (m), depth d = -y, confined (u_x = 0 on its sides, plane strain), fixed at its base, under
    its weight with rho = rho0 (1.5 - d): sigma_yy = -g rho0 (1.5 d - d^2/2) (the weight above) and, with
    M = E (1 - nu)/((1 + nu)(1 - 2 nu)), u_y = -(g rho0 / M) [(0.75 - 1/6) - (0.75 d^2 - d^3/6)] (a cubic: P3 is
    exact)."""
    rho0, E, nu, g = 3000.0, 1e9, 0.25, 9.81
    data = _square({"youngs_modulus": E, "poisson_ratio": nu, "density": f"{rho0}*(1.5 + y)"})
    data["blocks"][0]["boundaries"] = {"bottom": "ymin", "sides": ["xmin", "xmax"]}
    data["boundary_conditions"] = {"bottom": {"displacement": [0.0, 0.0]}, "sides": {"displacement": [0.0, "free"]}}
    data["mechanics"] = {"gravity": [0.0, -g]}
    data["mesh"] = {"maxh": 0.2, "order": 3}
    res = run(scene_from_dict(data), None, progress=False, threads=1)
    f = res.mechanics.forms
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    d = np.linspace(0.05, 0.95, 10)
    syy = -g * rho0 * (1.5 * d - d ** 2 / 2)
    uy = -(g * rho0 / M) * ((0.75 - 1 / 6) - (0.75 * d ** 2 - d ** 3 / 6))
    pts = res.mesh(np.full_like(d, 0.5), -d)
    err_s = float(np.max(np.abs(np.asarray(f.stress_tensor()(pts))[:, 4] - syy))) / float(np.max(np.abs(syy)))
    err_u = float(np.max(np.abs(np.asarray(f.displacement()(pts))[:, 1] - uy))) / float(np.max(np.abs(uy)))
    print(f"\ncolumn: max relative error sigma_yy {err_s:.2e}, u_y {err_u:.2e}")
    assert err_s < 1e-8 and err_u < 1e-8


# --------------------------------------------------------------------------------- friction along a contact

def _incline(friction, tan_slope: float = 0.3, method: str = "ssn"):
    """A block [0, 1] x [0, 0.25] m on a rigid flat foundation under gravity tilted by the slope angle a (the block on
    an incline of slope tan a = ``tan_slope``), Coulomb friction ``friction`` on its base."""
    a = math.atan(tan_slope)
    return {"scene": {"name": "incline", "dimension": "plane"},
            "physics": {"mechanics": "static"},
            "mesh": {"maxh": 0.05, "order": 1},
            "blocks": [{"name": "block", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 0.25],
                        "boundaries": {"base": "ymin"}}],
            "materials": {"block": {"youngs_modulus": 1e9, "poisson_ratio": 0.25, "density": 2500.0}},
            "mechanics": {"gravity": [9.81 * math.sin(a), -9.81 * math.cos(a)]},
            "boundary_conditions": {"base": {"foundation": {"point": [0.0, 0.0], "normal": [0.0, 1.0],
                                                            "law": "coulomb", "friction": friction,
                                                            "method": method}}},
            "output": {"vtk": False, "figures": False}}


def _base(friction, method: str = "ssn") -> dict:
    res = run(scene_from_dict(_incline(friction, method=method)), None, progress=False, threads=1)
    return res.mechanics.contact_output.latest[0]


@pytest.mark.parametrize("method", ["ssn", "uzawa"])
def test_friction_that_varies_along_the_base_sets_the_slip_zone(method):
    """F = 0.1 on x < 0.5 (below the slope 0.3: those nodes slip, q = F p) and 0.8 beyond (they stick but next to
    the change, where the load moves over); the uniform F = 0.8 holds every node."""
    r = _base("if(x < 0.5, 0.1, 0.8)", method)
    x, p, q, status = (np.asarray(r[k]) for k in ("x", "pressure", "traction", "status"))
    low, high = x < 0.5 - 1e-9, x > 0.65
    print(f"\n{method}: slip nodes at x = {np.sort(x[status == 2]).round(3).tolist()}; q/p on F = 0.1: "
          f"{np.abs(q[low] / p[low]).min():.4f}..{np.abs(q[low] / p[low]).max():.4f}")
    assert np.all(status[low] == 2) and np.all(status[high] == 1)
    assert np.allclose(np.abs(q[low]), 0.1 * p[low], rtol=1e-6)
    uniform = _base(0.8, method)
    assert np.all(np.asarray(uniform["status"]) == 1)


def test_friction_expression_is_checked_along_the_contact():
    data = _incline("0.5 - x")
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    problems = info.value.problems
    print("\n" + "\n".join(f"{p.item}: {p.message}" for p in problems))
    assert [p.item for p in problems] == ["boundary_conditions.base.foundation.friction"]
    assert re.fullmatch(r"must be >= 0, got -\S+ at x=\S+, y=0 of boundary 'base' "
                        r"\(expression '0.5 - x'\)", problems[0].message)


def test_the_mass_matrix_takes_a_varying_density():
    """Dynamic mechanics with rho = 2000 + 1000 x y (kg/m^3) on the unit square: the mass of a rigid translation
    t^T M t = int rho dA = 2250 kg per m of depth (consistent mass, any quadrature: the basis sums to 1)."""
    data = _square({"density": "2000 + 1000*x*(y + 1)"})
    data["physics"]["mechanics"] = "dynamic"
    data["time"] = {"end": 1e-4, "dt": 1e-4}
    res = run(scene_from_dict(data), None, progress=False, threads=1)
    dyn = res.mechanics
    t = np.zeros(dyn.forms.X.ndof)
    t[:dyn.forms.V.ndof // 2] = 1.0                   # the x components of VectorH1 come first
    mass = float(t @ (dyn.vforms.M @ t))
    print(f"\nmass of the x translation {mass:.10g} kg/m (exact 2250)")
    assert mass == pytest.approx(2250.0, rel=1e-12)


@pytest.mark.parametrize("order", [1, 2])
def test_estimators_take_the_varying_stiffness(order):
    """ZZ and residual estimators on the manufactured solution: effectivity (estimate / true energy error) close to
    one and stable under refinement; the residual estimator holds (d_k D) e(u_h) and the thermal terms of the
    varying data (without them its P2 effectivity drifted from 8 to 15 between h = 0.1 and 0.05)."""
    from ngs_geomech.adapt import estimators as es
    eff = {"zz": [], "residual": []}
    for h in (0.1, 0.05):
        prob = ve.solve("plane_strain", h, order)
        f, u = prob["forms"], prob["exact"]
        strain = {"rock": ngs.CoefficientFunction((u[0].Diff(ngs.x), u[1].Diff(ngs.y),
                                                   u[0].Diff(ngs.y) + u[1].Diff(ngs.x)))}
        true = es.elastic_energy_error(f, strain)
        for name, est in (("zz", es.zz_elastic(f)), ("residual", es.residual_elastic(f))):
            eff[name].append(float(np.sqrt(np.sum(est.eta ** 2))) / true)
    print(f"\nP{order} effectivities at h = 0.1, 0.05: " + ", ".join(
        f"{k} {v[0]:.3f} {v[1]:.3f}" for k, v in eff.items()))
    assert all(0.8 < v < 1.2 for v in eff["zz"]) and all(1.0 < v < 2.0 for v in eff["residual"])
    assert all(abs(v[1] / v[0] - 1) < 0.1 for v in eff.values())


def test_deformation_heating_takes_the_stress_free_temperature_field():
    """Coupled adiabatic compression (verification.coupled) with T0 = 20 + 10 x (degC): the source is
    Q = -(T0(x) + 273.15) beta . e(u_t) point by point (beta = E alpha / (1 - 2 nu) (1, 1, 0), plane strain)."""
    from ngs_geomech.run import run_scene
    from ngs_geomech.verification import coupled as cp
    data = cp.adiabatic_compression_scene(coupling="staggered", dt=20.0, end=40.0)
    data["materials"]["block"]["stress_free_temperature"] = "20 + 10*x"
    res = run_scene(scene_from_dict(data), None, progress=False)
    heating = res.model.coupling.heating
    xs, ys = np.array([0.1, 0.4, 0.9, 0.6]), np.array([0.2, 0.8, 0.5, 0.1])
    pts = res.mesh(xs, ys)
    G = np.asarray(ngs.grad(heating.rate)(pts)).reshape(len(xs), 4)       # d(u_t)_i / dx_j, row by row
    expected = -(20 + 10 * xs + 273.15) * cp.BETA * (G[:, 0] + G[:, 3])
    got = np.asarray(heating.source(pts)).ravel()
    print(f"\nsource {got}, expected {expected}")
    assert np.all(np.abs(expected) > 0)
    assert np.allclose(got, expected, rtol=1e-12, atol=0)


def test_a_stiffness_of_temperature_follows_the_heat_solution_in_time():
    """Transient heat and static mechanics with E = 1e10 (1 + 0.01 T): the mechanics at the end takes E at the
    end's temperature (its matrix re-assembled; a factorization kept from t = 0 would hold E(T = 0))."""
    from ngs_geomech.mechanics.forms import ElasticForms
    from ngs_geomech.mechanics.solver import ElasticSolver
    data = _square({"youngs_modulus": "1e10*(1 + 0.01*T)", "thermal_expansion": 1e-5, "rho_c": 2e6},
                   thermal="transient")
    data["time"] = {"end": 2e5, "dt": 1e5}
    data["initial"] = {"temperature": 10.0}
    res = run(scene_from_dict(data), None, progress=False, threads=1)
    forms = res.mechanics.forms
    assert forms.stiffness_uses_temperature
    fresh = ElasticForms(res.mesh, forms.setup)
    fresh.t.Set(forms.t.Get())
    ElasticSolver(fresh).solve("a fresh solve at the end's temperature")
    a, b = forms.displacement().vec.FV().NumPy(), fresh.displacement().vec.FV().NumPy()
    diff = float(np.max(np.abs(a - b)) / np.max(np.abs(b)))
    print(f"\nmax |u_run - u_fresh| / max |u| = {diff:.2e}")
    assert diff < 1e-10


def test_dynamic_mechanics_refuses_a_stiffness_of_temperature():
    data = _square({"youngs_modulus": "1e10*(1 + 0.01*T)", "density": 2500.0, "rho_c": 2e6}, thermal="transient")
    data["physics"]["mechanics"] = "dynamic"
    data["time"] = {"end": 1e-3, "dt": 1e-3}
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    assert [p.item for p in info.value.problems] == ["materials.rock.youngs_modulus"]
    assert "assembles its stiffness matrix once" in info.value.problems[0].message


def test_run_names_the_material_where_a_stiffness_of_temperature_stops_holding():
    """Validation sees E = 1e10 (1 - T/200) positive at the temperatures the region surely takes (10-50); a heat
    source takes T past 200 and the mechanics solve stops naming the material, the key and the point."""
    data = _square({"youngs_modulus": "1e10*(1 - T/200)", "rho_c": 2e6}, thermal="transient")
    data["boundary_conditions"]["top"] = {"temperature": 50.0}
    data["sources"] = [{"region": "rock", "density": 2e6}]
    data["initial"] = {"temperature": 10.0}
    data["time"] = {"end": 400.0, "dt": 200.0}
    sc = scene_from_dict(data)
    validate(sc)
    with pytest.raises(SolverError, match=r"materials\.rock\.youngs_modulus must be positive, got -.* Pa at x=.* "
                                          r"T=.*: the temperature of the run"):
        run(sc, None, progress=False, threads=1)


def test_friction_that_varies_along_a_3d_base_sets_the_slip_zone():
    """The incline in 3D: a box 1 x 0.5 x 0.25 m with E(z), nu(x), rho(y) on a rigid plane, gravity tilted along x
    (slope 0.3), F = 0.1 on x < 0.5 and 0.8 beyond: the first half slips (|q| = F p), the far part sticks."""
    a = math.atan(0.3)
    data = {"scene": {"name": "incline3d", "dimension": "3d"}, "physics": {"mechanics": "static"},
            "mesh": {"maxh": 0.12, "order": 1},
            "blocks": [{"name": "block", "shape": "box", "origin": [0, 0, 0], "size": [1.0, 0.5, 0.25],
                        "boundaries": {"base": "zmin"}}],
            "materials": {"block": {"youngs_modulus": "1e9*(1 + z)", "poisson_ratio": "0.25 + 0.05*x",
                                    "density": "2500 + 100*y"}},
            "mechanics": {"gravity": [9.81 * math.sin(a), 0.0, -9.81 * math.cos(a)]},
            "boundary_conditions": {"base": {"foundation": {"point": [0, 0, 0], "normal": [0, 0, 1], "law": "coulomb",
                                                            "friction": "if(x < 0.5, 0.1, 0.8)"}}},
            "output": {"vtk": False, "figures": False}}
    r = run(scene_from_dict(data), None, progress=False, threads=1).mechanics.contact_output.latest[0]
    x, p, q, status = (np.asarray(r[k]) for k in ("x", "pressure", "traction", "status"))
    low, high = x < 0.5 - 1e-9, x > 0.7
    print(f"\n3D: {len(x)} base nodes, slip {int(np.sum(status == 2))}, stick {int(np.sum(status == 1))}")
    assert np.all(status[low] == 2) and np.all(status[high] == 1)
    assert np.allclose(q[low], 0.1 * p[low], rtol=1e-6)


def test_friction_that_varies_along_an_interface_between_blocks():
    """The incline with an elastic base: the block rests on a second block (fixed at its bottom) through a contact
    interface whose friction is 0.1 on x < 0.5 and 0.8 beyond, with a slip bound check of a Tresca variant."""
    data = _incline(0.0)
    a = math.atan(0.3)
    data["blocks"] = [{"name": "block", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 0.25]},
                      {"name": "base", "shape": "rectangle", "origin": [0.0, -0.25], "size": [1.0, 0.25],
                       "boundaries": {"bottom": "ymin"}}]
    data["materials"]["base"] = {"youngs_modulus": "2e9*(1 - y)", "poisson_ratio": 0.25, "density": 2500.0}
    data["interfaces"] = [{"name": "joint", "blocks": ["block", "base"], "type": "contact", "law": "coulomb",
                           "friction": "if(x < 0.5, 0.1, 0.8)"}]
    data["boundary_conditions"] = {"bottom": {"displacement": [0.0, 0.0]}}
    data["mechanics"]["gravity"] = [9.81 * math.sin(a), -9.81 * math.cos(a)]
    r = run(scene_from_dict(data), None, progress=False, threads=1).mechanics.contact_output.latest[0]
    x, p, q, status = (np.asarray(r[k]) for k in ("x", "pressure", "traction", "status"))
    low, high = x < 0.5 - 1e-9, x > 0.7
    print(f"\ninterface: {len(x)} nodes, slip at x = {np.sort(x[status == 2]).round(3).tolist()}")
    assert np.all(status[low] == 2) and np.all(status[high] == 1)
    assert np.allclose(np.abs(q[low]), 0.1 * p[low], rtol=1e-6)
    data["interfaces"][0].update(law="tresca", slip_bound="1e3*(0.5 - x)")
    data["interfaces"][0].pop("friction")
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    assert [pr.item for pr in info.value.problems] == ["interfaces[0] (joint).slip_bound"]
    assert "must be >= 0 Pa, got -" in info.value.problems[0].message
