"""Elasticity through the scene path: exact solutions of simple load cases in every model (plane strain,
plane stress, axisymmetric, 3D), oblique symmetry conditions, gravity with a lithostatic initial stress,
a quasi-static displacement history, and the thermo-mechanical built-in scene with its outputs."""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest

from ngs_geomech import cli
from ngs_geomech.api import run
from ngs_geomech.errors import SceneError
from ngs_geomech.scene.parse import scene_from_dict

E, NU, ALPHA = 70e9, 0.25, 8e-6
ROCK = {"conductivity": 3.0, "youngs_modulus": E, "poisson_ratio": NU, "thermal_expansion": ALPHA,
        "stress_free_temperature": 0.0}


pytestmark = pytest.mark.usefixtures("one_thread")


def scene(dimension, blocks, bcs, physics=None, order=2, maxh=0.3, **extra):
    d = {"scene": {"name": "t", "dimension": dimension},
         "physics": physics or {"thermal": "steady", "mechanics": "static"},
         "mesh": {"maxh": maxh, "order": order}, "blocks": blocks,
         "materials": {b["name"]: dict(ROCK) for b in blocks}, "boundary_conditions": bcs,
         "output": {"vtk": False, "figures": False}}
    d.update(extra)
    return scene_from_dict(d)


def sample(result, pts):
    mesh, mech = result.mesh, result.mechanics
    u, sig = mech.forms.displacement(), mech.sigma
    out = []
    for p in pts:
        mip = mesh(*p)
        out.append((np.array(u(mip)), np.array(sig(mip)).reshape(3, 3)))
    return out


def test_free_thermal_expansion_with_oblique_symmetry():
    """A square rotated by 30 degrees, rollers on two perpendicular oblique sides meeting at the origin,
    uniform heating by 50 K: free expansion, u = alpha dT x, no stress (needs the multiplier symmetry)."""
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    pts = [[0, 0], [c, s], [c - s, s + c], [-s, c]]
    blocks = [{"name": "rock", "shape": "polygon", "points": pts, "edges": ["sym_a", "free", "free", "sym_b"]}]
    bcs = {"sym_a": {"symmetry": True, "temperature": 50.0}, "sym_b": {"symmetry": True, "temperature": 50.0},
           "free": {"temperature": 50.0}}
    res = run(scene("plane", blocks, bcs), None, progress=False)
    assert len(res.mechanics.forms.oblique) == 2
    worst_u, worst_s = 0.0, 0.0
    for p, (u, sig) in zip(pts[1:] + [[0.3, 0.5]], sample(res, pts[1:] + [[0.3, 0.5]])):
        exact = ALPHA * 50.0 * np.array(p) * (1 + NU)  # plane strain: eps_inplane = (1 + nu) alpha dT
        worst_u = max(worst_u, float(np.abs(u - exact).max() / np.abs(exact).max()))
        worst_s = max(worst_s, float(np.abs(sig[:2, :2]).max()) / (E * ALPHA * 50.0))
        assert sig[2, 2] == pytest.approx(-E * ALPHA * 50.0, rel=1e-6)   # plane strain sigma_zz
    print(f"\noblique symmetry, free expansion: max rel displacement error {worst_u:.2e}, "
          f"in-plane stress / (E alpha dT) {worst_s:.2e}")
    assert worst_u < 1e-8 and worst_s < 1e-8


def test_plane_stress_free_expansion_and_uniaxial_traction():
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [2, 1],
               "boundaries": {"left": "xmin", "bottom": "ymin", "right": "xmax"}}]
    bcs = {"left": {"symmetry": True}, "bottom": {"symmetry": True}, "right": {"traction": [1e6, 0]}}
    res = run(scene("plane", blocks, bcs, physics={"mechanics": "static", "plane_model": "plane_stress"}),
              None, progress=False)
    u, sig = sample(res, [[2.0, 0.5]])[0]
    print(f"\nplane stress bar: u_x(L) = {u[0]:.6e} m (exact {1e6 * 2 / E:.6e}), sigma_xx = {sig[0, 0]:.6e}")
    assert u[0] == pytest.approx(1e6 * 2 / E, rel=1e-9)
    assert u[1] == pytest.approx(-NU * 1e6 / E * 0.5, rel=1e-9)
    assert sig[0, 0] == pytest.approx(1e6, rel=1e-9) and abs(sig[2, 2]) < 1e-6


def test_axisymmetric_free_expansion():
    """A heated solid cylinder with u_z = 0 at the base and a free mantle: u_r = alpha dT r, u_z = alpha dT z,
    no stress (u_r = 0 on the axis is imposed automatically)."""
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 2],
               "boundaries": {"base": "ymin", "mantle": ["xmax", "ymax"]}}]
    bcs = {"base": {"symmetry": True, "temperature": 30.0}, "mantle": {"temperature": 30.0}}
    res = run(scene("axisymmetric", blocks, bcs), None, progress=False)
    assert "axis" in res.mechanics.setup.axis
    u, sig = sample(res, [[0.7, 1.3]])[0]
    assert u[0] == pytest.approx(ALPHA * 30 * 0.7, rel=1e-8) and u[1] == pytest.approx(ALPHA * 30 * 1.3, rel=1e-8)
    assert np.abs(sig).max() < 1e-6 * E * ALPHA * 30


def test_3d_box_under_traction():
    blocks = [{"name": "rock", "shape": "box", "origin": [0, 0, 0], "size": [2, 1, 1],
               "boundaries": {"x0": "xmin", "y0": "ymin", "z0": "zmin", "end": "xmax"}}]
    bcs = {"x0": {"symmetry": True}, "y0": {"symmetry": True}, "z0": {"symmetry": True},
           "end": {"traction": [-2e6, 0, 0]}}
    res = run(scene("3d", blocks, bcs, physics={"mechanics": "static"}, order=1, maxh=0.5), None, progress=False)
    u, sig = sample(res, [[2.0, 1.0, 1.0]])[0]
    assert u[0] == pytest.approx(-2e6 * 2 / E, rel=1e-9)
    assert u[1] == pytest.approx(NU * 2e6 / E, rel=1e-9) and u[2] == pytest.approx(NU * 2e6 / E, rel=1e-9)
    assert sig[0, 0] == pytest.approx(-2e6, rel=1e-9)


def test_gravity_balanced_by_lithostatic_initial_stress():
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, -100], "size": [50, 100],
               "boundaries": {"sides": ["xmin", "xmax"], "bottom": "ymin", "top": "ymax"}}]
    bcs = {"sides": {"symmetry": True}, "bottom": {"symmetry": True}}
    mat = dict(ROCK, density=2700.0)
    d = {"scene": {"name": "litho"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 10.0, "order": 2},
         "blocks": blocks, "materials": {"rock": mat}, "boundary_conditions": bcs,
         "mechanics": {"gravity": [0, -9.81], "initial_stress": [["0.7*2700*9.81*y", "0"], ["0", "2700*9.81*y"]]},
         "output": {"vtk": False, "figures": False}}
    res = run(scene_from_dict(d), None, progress=False)
    u, sig = sample(res, [[25.0, -60.0]])[0]
    print(f"\nlithostatic: |u| = {np.abs(u).max():.2e} m, sigma_yy = {sig[1, 1]:.6e} Pa")
    assert np.abs(u).max() < 1e-12
    assert sig[1, 1] == pytest.approx(2700 * 9.81 * -60.0, rel=1e-9)
    assert sig[0, 0] == pytest.approx(0.7 * 2700 * 9.81 * -60.0, rel=1e-9)
    # without the initial stress gravity compacts the column: u_y(top) = -rho g H^2 / (2 M), M = lambda + 2 mu
    d["mechanics"] = {"gravity": [0, -9.81]}
    res = run(scene_from_dict(d), None, progress=False)
    u, _ = sample(res, [[25.0, 0.0]])[0]
    M = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
    assert u[1] == pytest.approx(-2700 * 9.81 * 100.0 ** 2 / (2 * M), rel=1e-8)


def test_quasi_static_displacement_history():
    """A time-dependent prescribed displacement gives a displacement history at the output times."""
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 1],
               "boundaries": {"left": "xmin", "bottom": "ymin", "right": "xmax"}}]
    bcs = {"left": {"symmetry": True}, "bottom": {"symmetry": True},
           "right": {"displacement": ["1e-4*t/year", "free"]}}
    d = {"scene": {"name": "hist"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.5, "order": 1},
         "blocks": blocks, "materials": {"rock": ROCK}, "boundary_conditions": bcs,
         "time": {"end": "10 year", "dt": "1 year"},
         "output": {"vtk": False, "figures": False, "every": 2,
                    "probes": [{"name": "ux", "quantity": "displacement_x", "point": [1.0, 0.5]}]}}
    res = run(scene_from_dict(d), None, progress=False)
    times = np.array(res.summary["probe_series"]["times_s"]["ux"])
    vals = np.array(res.summary["probe_series"]["ux"])
    year = 365.25 * 86400
    assert list(np.round(times / year, 6)) == [0, 2, 4, 6, 8, 10]   # mechanics at the output steps only
    assert np.allclose(vals, 1e-4 * times / year, rtol=1e-9, atol=1e-15)


def test_unloaded_body_in_frictionless_contact_stays_put():
    """Block b touches the fixed block a through a frictionless contact and carries no load: it is not held
    tangentially, but nothing moves it; the solve gives zero displacement (no singular-matrix crash)."""
    blocks = [{"name": "a", "shape": "rectangle", "origin": [0, 0], "size": [1, 1], "boundaries": {"l": "xmin"}},
              {"name": "b", "shape": "rectangle", "origin": [1, 0], "size": [1, 1]}]
    d = {"scene": {"name": "c"}, "physics": {"mechanics": "static"}, "blocks": blocks,
         "interfaces": [{"name": "f", "blocks": ["a", "b"], "type": "contact"}],
         "materials": {"a": ROCK, "b": ROCK}, "boundary_conditions": {"l": {"displacement": [0, 0]}}}
    res = run(scene_from_dict(d), None, progress=False)
    assert np.max(np.abs(res.mechanics.forms.gf.vec.FV().NumPy())) < 1e-12


def test_unloaded_body_in_3d_coulomb_contact_stays_put():
    """3D friction (tests/test_contact_friction_3d.py): block b touches the fixed block a through a Coulomb
    contact and carries no load: nothing moves it (zero displacement, no singular-matrix crash)."""
    blocks = [{"name": "a", "shape": "box", "origin": [0, 0, 0], "size": [1, 1, 1], "boundaries": {"l": "xmin"}},
              {"name": "b", "shape": "box", "origin": [1, 0, 0], "size": [1, 1, 1]}]
    d = {"scene": {"name": "c", "dimension": "3d"}, "physics": {"mechanics": "static"}, "blocks": blocks,
         "interfaces": [{"name": "f", "blocks": ["a", "b"], "type": "contact", "law": "coulomb", "friction": 0.5}],
         "materials": {"a": ROCK, "b": ROCK}, "boundary_conditions": {"l": {"displacement": [0, 0, 0]}}}
    res = run(scene_from_dict(d), None, progress=False)
    assert np.max(np.abs(res.mechanics.forms.gf.vec.FV().NumPy())) < 1e-12


def test_heated_rock_scene_writes_mechanics_output(tmp_path):
    out = tmp_path / "hr"
    assert cli.main(["run", "heated_rock", "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["mechanics"]["model"] == "plane_strain" and summary["mechanics"]["solves"] == 1
    for fig in ("temperature.png", "von_mises.png", "principal_stress.png", "principal_stress_zoom.png",
                "principal_stress_change.png", "principal_stress_change_zoom.png"):   # the change: it has sigma0
        assert (out / "figures" / fig).stat().st_size > 10000
    vtu = (out / "heated_rock.vtu").read_text(errors="ignore")
    for field in ("temperature", "displacement", "stress", "von_mises", "mean_stress", "sigma_1", "sigma_3",
                  "strain_energy_density", "region"):
        assert f'Name="{field}"' in vtu
    vm = summary["probes"]["max_von_mises"]["max"]
    assert 1e6 < vm < 1e8   # thermal stresses of tens of MPa around the heated zone


def test_transient_heating_gives_a_displacement_history(caplog):
    """One scene drives both solves: a bar heated from one end expands more at every output time; the
    mechanics is solved only at the output steps; P1 with nu > 0.49 in the displacement formulation is warned
    about (a logged warning)."""
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [4, 1],
               "boundaries": {"left": "xmin", "bottom": "ymin", "right": "xmax"}}]
    mat = dict(ROCK, rho_c=2.2e6, poisson_ratio=0.495)
    d = {"scene": {"name": "heat_bar"}, "physics": {"thermal": "transient", "mechanics": "static"},
         "mesh": {"maxh": 0.5, "order": 1}, "blocks": blocks, "materials": {"rock": mat},
         "boundary_conditions": {"left": {"symmetry": True, "temperature": 100.0}, "bottom": {"symmetry": True}},
         "time": {"end": "20 day", "dt": "1 day"}, "mechanics": {"formulation": "displacement"},
         "output": {"vtk": False, "figures": False, "every": 5,
                    "probes": [{"name": "ux", "quantity": "displacement_x", "point": [4.0, 0.5]},
                               {"name": "T_mid", "point": [1.0, 0.5]}]}}
    res = run(scene_from_dict(d), None, progress=True)
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any(w.startswith("materials.rock: Poisson ratio 0.4950 > 0.49 with P1") for w in warned)
    assert res.summary["warnings"] and res.summary["mechanics"]["solves"] == 5   # t = 0, 5, 10, 15, 20 days
    ux = np.array(res.summary["probe_series"]["ux"])
    assert len(res.summary["probe_series"]["T_mid"]) == 21
    assert 0 <= ux[0] < ux[-1] / 3 and np.all(np.diff(ux) > 0)   # t = 0: only the boundary nodes are hot


@pytest.mark.parametrize("solver,relaxation", [("newton", None), ("secant", None), ("secant", 1.0)])
def test_lambda_law_solvers_from_the_scene(solver, relaxation):
    """A bar under traction with lam = 1.25 (hardening) and a hole-free strain concentration from a stiff
    inclusion; Newton, the secant method with line search and the plain secant modules method (2.32)
    (relaxation 1) reach the same solution; the traction is carried: sigma_xx = P at the loaded end."""
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [2, 1],
               "boundaries": {"left": "xmin", "bottom": "ymin", "right": "xmax"}},
              {"name": "stiff", "shape": "circle", "center": [1.0, 0.5], "radius": 0.25}]
    mech = {"nonlinear_solver": solver, "tolerance": 1e-10}
    if relaxation is not None:
        mech["secant_relaxation"] = relaxation
    d = {"scene": {"name": "lam"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.25, "order": 1},
         "blocks": blocks, "interfaces": [{"name": "i", "blocks": ["rock", "stiff"]}],
         "materials": {"rock": dict(ROCK, rheology_lambda=1.25), "stiff": dict(ROCK, youngs_modulus=3 * E)},
         "boundary_conditions": {"left": {"symmetry": True}, "bottom": {"symmetry": True},
                                 "right": {"traction": [2e8, 0]}},
         "mechanics": mech, "output": {"vtk": False, "figures": False}}
    res = run(scene_from_dict(d), None, progress=False)
    info = res.mechanics.solver.history[-1]
    u, sig = sample(res, [[1.999, 0.5]])[0]
    print(f"\n{solver} (relaxation {relaxation}): {info.iterations} iterations, u_x(L) = {u[0]:.10e}")
    assert info.iterations <= (10 if solver == "newton" else 60)
    assert sig[0, 0] == pytest.approx(2e8, rel=2e-2)   # P1 stress near the end, smooth there
    test_lambda_law_solvers_from_the_scene.ux = getattr(test_lambda_law_solvers_from_the_scene, "ux", []) + [u[0]]
    assert max(test_lambda_law_solvers_from_the_scene.ux) - min(test_lambda_law_solvers_from_the_scene.ux) \
        <= 1e-7 * abs(u[0])


def test_warning_for_non_monotone_lambda_law():
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 1],
               "boundaries": {"left": "xmin", "right": "xmax"}}]
    d = {"scene": {"name": "soft"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.5, "order": 2},
         "blocks": blocks, "materials": {"rock": dict(ROCK, rheology_lambda=0.4)},
         "boundary_conditions": {"left": {"displacement": [0, 0]}, "right": {"displacement": [1e-4, 0]}},
         "output": {"vtk": False, "figures": False}}
    res = run(scene_from_dict(d), None, progress=False)
    assert any("non-monotone" in w for w in res.summary["warnings"])



@pytest.mark.parametrize("youngs_modulus", [3.0, 30e9], ids=["3_Pa", "30_GPa"])
def test_warning_when_the_displacement_leaves_the_small_strain_range(youngs_modulus, caplog):
    """A 1 km block under gravity on a fixed base, solved at three output times: with E = 3 Pa (a unit slip)
    the settlement is ~1e9 m, |grad u| ~ 1e7 >> 0.1: one warning naming the value and the region, logged
    once and kept in the summary; with E = 30 GPa (settlement 0.03 m) none."""
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, -1000.0], "size": [1000.0, 1000.0],
               "boundaries": {"base": "ymin", "left": "xmin", "right": "xmax"}}]
    d = {"scene": {"name": "soft"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 500.0, "order": 1},
         "blocks": blocks, "materials": {"rock": {"youngs_modulus": youngs_modulus, "poisson_ratio": 0.25,
                                                  "density": 2500.0}},
         "mechanics": {"gravity": [0.0, -9.81]}, "time": {"end": 2.0, "dt": 1.0},
         "boundary_conditions": {"base": {"displacement": [0.0, 0.0]}, "left": {"symmetry": True},
                                 "right": {"symmetry": True}},
         "output": {"vtk": False, "figures": False}}
    res = run(scene_from_dict(d), None, progress=True)
    out = "\n".join(r.getMessage() for r in caplog.records if r.levelno == logging.WARNING)
    found = [w for w in res.summary["warnings"] if "small-strain" in w]
    print(f"\nE = {youngs_modulus:g} Pa: {found}")
    assert res.summary["mechanics"]["solves"] == 3
    if youngs_modulus < 1e3:
        assert len(found) == 1 and "max |grad u| = " in found[0] and "(region rock)" in found[0]
        assert out.count("the displacement leaves the small-strain range") == 1
    else:
        assert not found and "small-strain" not in out

def test_unheld_rigid_motion_stops_with_a_diagnosis(tmp_path):
    """Only a roller at the base: the body can slide along x. The run stops before solving with an error that
    names the free rigid motion (never an NGSolve exception, NaN or a huge displacement) and writes no output."""
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 1],
               "boundaries": {"bottom": "ymin", "top": "ymax"}}]
    d = {"scene": {"name": "slide"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.5, "order": 1},
         "blocks": blocks, "materials": {"rock": ROCK},
         "boundary_conditions": {"bottom": {"symmetry": True}, "top": {"pressure": 1e6}}}
    with pytest.raises(SceneError) as err:
        run(scene_from_dict(d), tmp_path / "out", progress=False)
    assert "not held against translation along x" in str(err.value)
    assert not (tmp_path / "out").exists() and not list(tmp_path.glob(".out.partial-*"))


@pytest.mark.parametrize("bcs,free", [
    ({"left": {"symmetry": True}, "right": {"symmetry": True}}, "translation along y"),
    ({"left": {"symmetry": True}, "bottom": {"symmetry": True}}, None),
    ({"left": {"displacement": ["free", 0]}}, "rotation about z"),
])
def test_rigid_motion_analysis(bcs, free):
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 1],
               "boundaries": {"left": "xmin", "right": "xmax", "bottom": "ymin"}}]
    d = {"scene": {"name": "rm"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.5, "order": 2},
         "blocks": blocks, "materials": {"rock": ROCK}, "boundary_conditions": bcs,
         "output": {"vtk": False, "figures": False}}
    if free is None:
        run(scene_from_dict(d), None, progress=False)
    else:
        with pytest.raises(SceneError) as err:
            run(scene_from_dict(d), None, progress=False)
        assert f"not held against {free}" in str(err.value)


@pytest.mark.parametrize("order", [1, 2])
def test_axisymmetric_solid_cylinder_touching_the_axis(order):
    """A solid cylinder (elements on the axis r = 0) compressed by p on its top, u_z = 0 at the base: the
    exact uniaxial state u_z = -p z / E, u_r = nu p r / E (the degree-2 triangle rule had points on the axis
    edge, where u_r / r gave NaN)."""
    E, nu, p = 20e9, 0.25, 1e6
    d = {"scene": {"name": "rod", "dimension": "axisymmetric"}, "physics": {"mechanics": "static"},
         "mesh": {"maxh": 0.15, "order": order},
         "blocks": [{"name": "rod", "shape": "rectangle", "origin": [0, 0], "size": [0.3, 1.0],
                     "boundaries": {"base": "ymin", "cap": "ymax"}}],
         "materials": {"rod": {"youngs_modulus": E, "poisson_ratio": nu}},
         "boundary_conditions": {"base": {"symmetry": True}, "cap": {"pressure": p}},
         "output": {"vtk": False, "figures": False}}
    res = run(scene_from_dict(d), None, progress=False)
    mesh = res.mesh
    u = res.mechanics.forms.displacement()
    for x, y in ((0.0, 1.0), (0.3, 1.0), (0.15, 0.5), (0.0, 0.4)):
        val = np.array(u(mesh(x, y))).ravel()
        assert val == pytest.approx([nu * p * x / E, -p * y / E], abs=1e-9 * p / E)


def test_axisymmetric_stress_output_is_finite_on_the_axis(tmp_path):
    """The stress at points of the axis (VTK vertices, probes) takes the hoop strain's limit du_r/dr there, not
    u_r / r = 0 / 0: the rod of the test above gives its uniaxial stress also on the axis, in the VTK file too."""
    import meshio
    E, nu, p = 20e9, 0.25, 1e6
    d = {"scene": {"name": "rod", "dimension": "axisymmetric"},
         "physics": {"thermal": "steady", "mechanics": "static", "coupling": "none"},
         "mesh": {"maxh": 0.15, "order": 2},
         "blocks": [{"name": "rod", "shape": "rectangle", "origin": [0, 0], "size": [0.3, 1.0],
                     "boundaries": {"base": "ymin", "cap": "ymax"}}],
         "materials": {"rod": {"youngs_modulus": E, "poisson_ratio": nu, "conductivity": 1.0,
                               "thermal_expansion": 1e-5}},
         "boundary_conditions": {"base": {"symmetry": True, "temperature": 0.0},
                                 "cap": {"pressure": p, "temperature": 0.0}},
         "output": {"vtk": True, "figures": False}}
    res = run(scene_from_dict(d), tmp_path / "out", progress=False)
    sig = np.array(res.mechanics.sigma(res.mesh(0.0, 0.4))).reshape(3, 3)
    assert sig == pytest.approx(np.diag([0.0, -p, 0.0]), abs=1e-6 * p)
    vtu = meshio.read(next((tmp_path / "out").glob("*.vtu")))
    on_axis = np.abs(vtu.points[:, 0]) < 1e-12
    stress = vtu.point_data["stress"].reshape(-1, 3, 3)
    print(f"\nstress at {on_axis.sum()} axis vertices: max |sigma_zz + p| / p "
          f"{np.max(np.abs(stress[on_axis, 1, 1] + p)) / p:.1e}")
    assert on_axis.any() and np.all(np.isfinite(vtu.point_data["sigma_1"]))
    np.testing.assert_allclose(stress[on_axis, 1, 1], -p, rtol=1e-6)
