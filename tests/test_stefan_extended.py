"""The Stefan problem in axisymmetric scenes, with heat transfer (Robin) conditions and with anisotropic
conductivity per phase (:mod:`ngs_geomech.stefan.forms`, :mod:`ngs_geomech.verification.stefan_extended`):

- the line sink (Carslaw & Jaeger 11.2): the closed form checked against a fine 1D radial enthalpy solution, then
  the axisymmetric scene's front against it at three mesh sizes (relative error <= 2e-2, first order);
- a slab melted through a heat transfer condition against a converged 1D reference (<= 1e-2, first order);
- the two-phase Neumann problem in a rotated strip with anisotropic conductivities (<= 1e-2, first order);
- every run's energy balance (the Robin exchange included) closes to 1e-8;
- the forms: r-weighted lumped masses, a body at the ambient temperature exchanges nothing, anisotropic stiffness
  columns sum to zero, the Robin heat in the step info; validation of the new keys.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest
from netgen.occ import OCCGeometry, Rectangle, X

from ngs_geomech.errors import SceneError
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan.forms import StefanForms, StefanSetup
from ngs_geomech.stefan.materials import PhaseChangeMaterial, PlainThermalMaterial
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import stefan_extended as se

pytestmark = pytest.mark.usefixtures("one_thread")

PCM = PhaseChangeMaterial(melting_temperature=0.0, latent_heat=2.0, rho_c_solid=3.0, rho_c_liquid=1.0,
                          conductivity_solid=1.5, conductivity_liquid=1.0)


def _print_levels(name: str, out: dict) -> None:
    rows = ", ".join(f"h = {lv['h']:g}: {lv['front_rel_error']:.2e} ({lv['wall_s']:.2f} s)" for lv in out["levels"])
    print(f"\n{name}: front relative errors {rows}; order {out['order']:.2f}; energy imbalance "
          f"{out['energy_imbalance_rel']:.1e}")


@pytest.fixture(scope="module")
def line_sink():
    return se.line_sink_freezing()


def test_line_sink_closed_form_matches_the_1d_radial_reference(line_sink):
    """Transcription check of (1): the 1D radial enthalpy solution (sink radius 5 mm) freezes to within 4e-4 of
    the closed-form radius at every resolution, and its temperatures (r >= 10 r0) approach the closed form."""
    ref = line_sink["reference"]
    print(f"\nlam = {line_sink['lam']:.6f}; 1D reference h = {ref['h']}: front {np.round(ref['front_rel_error'], 6)}, "
          f"temperature {np.round(ref['temperature_rel_error'], 5)} (order {ref['temperature_order']:.2f}), "
          f"{ref['wall_s']:.2f} s")
    assert ref["front_rel_error_max"] <= 4e-4
    assert ref["temperature_rel_error"][-1] <= 5e-3 and ref["temperature_order"] >= 0.8
    assert ref["imbalance_rel_max"] <= 1e-8


def test_axisymmetric_line_sink_front(line_sink):
    _print_levels("line sink (axisymmetric)", line_sink)
    assert line_sink["axisymmetric_stefan_front_rel_error"] <= 2e-2
    assert line_sink["order"] >= 0.8
    assert line_sink["energy_imbalance_rel"] <= 1e-8
    power = line_sink["levels"][-1]["energy"]["heat_supplied_sources_fluxes"]
    assert power == pytest.approx(-60.0 * line_sink["height"] * line_sink["t1"], rel=1e-12)   # J, the whole body


def test_robin_melting_front():
    out = se.robin_melting()
    ref = out["reference"]
    print(f"\n1D reference h = {ref['h']}: fronts {np.round(ref['front'], 6)} (order {ref['order']:.2f}, uncertainty "
          f"{ref['front_uncertainty_rel']:.1e})")
    _print_levels("Robin slab", out)
    assert ref["front_uncertainty_rel"] <= 1e-3 and ref["order"] >= 0.8
    assert out["robin_stefan_front_rel_error"] <= 1e-2
    assert out["order"] >= 0.8
    assert out["energy_imbalance_rel"] <= 1e-8
    last = out["levels"][-1]["energy"]
    assert last["heat_supplied_robin"] == pytest.approx(last["heat_supplied"], rel=1e-12) and last["heat_supplied"] > 0


def test_anisotropic_neumann_front():
    out = se.anisotropic_neumann()
    _print_levels(f"anisotropic Neumann strip (ratio {out['ratio']:g}, {out['angle_deg']:g} deg)", out)
    assert out["anisotropic_stefan_front_rel_error"] <= 1e-2
    assert out["order"] >= 0.8
    assert out["energy_imbalance_rel"] <= 1e-8


# -- the forms ----------------------------------------------------------------------------------------------------
def _box(r0=0.5, r1=1.5, height=1.0, h=0.2):
    face = Rectangle(r1 - r0, height).Face().Move((r0, 0, 0))
    face.faces.name = "pcm"
    face.edges.Min(X).name = "inner"
    face.edges.Max(X).name = "outer"
    return ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=h))


def test_axisymmetric_lumped_masses_are_the_r_weighted_row_sums():
    """m_i = int r phi_i: they add up to int r dA = (r1^2 - r0^2) H / 2 (per radian), and on a mesh touching the
    axis every node (also on r = 0) has positive storage."""
    mesh = _box()
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": PCM}, axisymmetric=True))
    assert forms.mass.sum() == pytest.approx((1.5 ** 2 - 0.5 ** 2) / 2, rel=1e-12)
    axis = _box(r0=0.0, r1=1.0)
    forms = StefanForms(axis, StefanSetup(materials={"pcm": PCM}, axisymmetric=True))
    assert np.all(forms.mass > 0) and forms.mass.sum() == pytest.approx(0.5, rel=1e-12)


def test_a_body_at_the_ambient_temperature_exchanges_nothing_and_the_step_reports_the_robin_heat():
    """Robin on 'inner' and 'outer' with T_amb = the body's temperature: the state stays (to rounding); with a
    warmer ambient the step's robin_heat is the body's heat gain (no other supply)."""
    mesh = _box()
    for axi in (False, True):
        setup = StefanSetup(materials={"pcm": PCM}, axisymmetric=axi,
                            robin={"inner": (4.0, -1.0), "outer": (2.0, "-1 + 0*t")})
        forms = StefanForms(mesh, setup)
        solver = StefanSolver(forms)
        solver.set_initial(np.full(forms.n, -1.0))
        solver.step(0.0, 0.1)
        assert np.max(np.abs(solver.temperature() + 1.0)) <= 1e-12
        setup.robin["outer"] = (2.0, 3.0)
        forms = StefanForms(mesh, setup)
        solver = StefanSolver(forms)
        solver.set_initial(np.full(forms.n, -1.0))
        before = forms.heat_content(solver.e)
        info = solver.step(0.0, 0.1)
        gain = forms.heat_content(solver.e) - before
        assert info.robin_heat > 0 and gain == pytest.approx(info.robin_heat, rel=1e-10)


def test_anisotropic_stiffness_conserves_and_matches_the_tensor():
    """K_hat enters the stiffness: its columns sum to zero (the energy balance) and, for T = x (a uniform
    gradient), the heat leaving through the boundary equals int K_hat grad T . n (here |K_hat e_x| along x)."""
    mesh = _box(r0=0.0, r1=1.0)
    shape = ((1.0, 0.3), (0.3, 0.5))
    mat = PlainThermalMaterial(rho_c=1.0, conductivity=2.0, anisotropy=shape)
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": mat}))
    K = forms.stiffness[0]
    assert np.max(np.abs(np.asarray(K.sum(axis=0)).ravel())) <= 1e-12
    x = np.array([v.point[0] for v in mesh.vertices])
    y = np.array([v.point[1] for v in mesh.vertices])
    # int K grad T . grad v for T = x, v = y: int (K_hat e_x) . e_y dA = 0.3 (unit square)
    assert y @ (K @ x) == pytest.approx(0.3, rel=1e-12)
    assert x @ (K @ x) == pytest.approx(1.0, rel=1e-12)
    with pytest.raises(ValueError, match="symmetric positive definite"):
        PlainThermalMaterial(rho_c=1.0, conductivity=2.0, anisotropy=((1.0, 2.0), (2.0, 1.0)))


# -- validation ---------------------------------------------------------------------------------------------------
def _scene(**changes) -> dict:
    data = se.robin_scene(se.RobinSlab(), 0.1, 0.05, 0.02)
    for key, value in changes.items():
        node = data
        *path, last = key.split(".")
        for p in path:
            node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
        node[last] = value
    return data


@pytest.mark.parametrize("changes, item, text", [
    ({"materials.pcm.conductivity": [[1.5, 0.0], [0.0, 3.0]], "materials.pcm.conductivity_liquid": 1.0},
     "materials.pcm.conductivity_liquid", "not proportional"),
    ({"materials.pcm.conductivity": None, "materials.pcm.conductivity_principal": [1.5, 3.0],
      "materials.pcm.conductivity_angle": 20.0, "materials.pcm.conductivity_liquid": None,
      "materials.pcm.conductivity_liquid_principal": [1.0, 1.0]},
     "materials.pcm.conductivity_liquid_principal", "not proportional"),
    ({"materials.pcm.conductivity_liquid": None, "materials.pcm.conductivity_liquid_principal": [1.0, 1.0, 1.0]},
     "materials.pcm.conductivity_liquid_principal", "needs 2 values"),
    ({"boundary_conditions.wall.ambient_temperature": None}, "boundary_conditions.wall",
     "heat_transfer_coefficient and ambient_temperature go together"),
    ({"boundary_conditions.wall.heat_transfer_coefficient": -1.0},
     "boundary_conditions.wall.heat_transfer_coefficient", "must be positive"),
])
def test_validation_names_the_key(changes, item, text):
    data = _scene(**changes)
    for key in ("conductivity", "conductivity_liquid"):
        if data["materials"]["pcm"].get(key, 0) is None:
            del data["materials"]["pcm"][key]
    if data["boundary_conditions"]["wall"].get("ambient_temperature", 0) is None:
        del data["boundary_conditions"]["wall"]["ambient_temperature"]
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    problems = info.value.problems
    print(f"\n{changes}: " + "; ".join(map(str, problems)))
    assert any(p.item == item and text in p.message for p in problems), problems


def test_proportional_tensors_axisymmetric_and_robin_scenes_are_valid():
    data = _scene(**{"materials.pcm.conductivity": [[1.5, 0.3], [0.3, 3.0]],
                     "materials.pcm.conductivity_liquid": [[1.0, 0.2], [0.2, 2.0]]})
    validate(scene_from_dict(data))
    p = se.LineSink(power=60.0)
    validate(scene_from_dict(se.line_sink_scene(p, 0.01, 3.0, 0.1, 0.1, 1.0)))
    axis = se.line_sink_scene(p, 0.01, 3.0, 0.1, 0.1, 1.0)
    axis["blocks"][0].update(origin=[0.0, 0.0], boundaries={"far": "xmax", "sink": "ymax"})
    axis["boundary_conditions"]["sink"] = {"heat_transfer_coefficient": 5.0, "ambient_temperature": -2.0}
    validate(scene_from_dict(axis))
    assert math.isfinite(p.lam)


def test_axisymmetric_coupled_contact_scene_closes_its_energy_balance():
    """The built-in contact_melting made axisymmetric (the deformation heating holds u_r / r: the lumped rule
    has interior points only) with its contact interface's heat penalty (r-weighted mortar): the run finishes and
    the energy balance, deformation heat included, closes; volumes and heats are those of the whole body."""
    from ngs_geomech.api import run

    res = run("contact_melting", None, overrides=["scene.dimension=axisymmetric", "time.end=30 day"],
              progress=False)
    st = res.summary["stefan"]
    print(f"\naxisymmetric contact_melting: imbalance {st['energy']['imbalance_rel_max']:.1e}, units {st['units']}")
    assert st["units"] == {"volume": "m^3", "heat": "J"}
    assert st["energy"]["imbalance_rel_max"] <= 1e-8
    salt = st["phase_change_regions"]["salt"]["volume"]
    assert salt == pytest.approx(math.pi * 2.0 ** 2 * 1.0 - math.pi * (1.2 ** 2 - 0.8 ** 2) * 0.3, rel=1e-3)


def test_heat_flux_field_takes_the_phase_tensor():
    """The output heat flux is -K_phase grad T with the liquid's tensor where T > Theta_R."""
    from ngs_geomech.api import run

    data = _scene(**{"materials.pcm.conductivity": [[1.5, 0.3], [0.3, 3.0]],
                     "materials.pcm.conductivity_liquid": [[1.0, 0.2], [0.2, 2.0]]})
    res = run(scene_from_dict(data), None, progress=False)
    T = res.stefan.forms.gf_temperature
    mip = res.mesh(0.1, 0.05)
    assert T(mip) > 0.0                                   # liquid near the wall
    want = -np.array([[1.0, 0.2], [0.2, 2.0]]) @ np.array(ngs.grad(T)(mip))
    assert np.allclose(res.stefan.fields["heat_flux"](mip), want, rtol=1e-12, atol=0)
