"""The Stefan problem with conductivities that vary in x, y, z (:mod:`ngs_geomech.verification.stefan_varying`):

- the steady temperature of d/dx (k(x) dT/dx) = 0 through a phase-change region (kept solid) and a plain region,
  both with k of x, against the closed form (second order, error <= 1e-4 at h = 0.025);
- a slab melted from a hot wall with k_s(x) = k_s g(x), k_l(x) = k_l g(x) against a converged 1D enthalpy reference
  with the same g (relative front error <= 1e-2, observed order asserted);
- every run's energy balance closes to 1e-8;
- the forms: the stiffness takes G at the element centroid, its columns sum to zero, an M-matrix on a non-obtuse
  mesh; the material read at points (scale, ratio, shape); validation of the keys.
"""

from __future__ import annotations

import copy

import ngsolve as ngs
import numpy as np
import pytest
import scipy.sparse as sp
from netgen.geom2d import unit_square

from ngs_geomech.errors import MaterialError, SceneError
from ngs_geomech.fem.coefficients import material_cf
from ngs_geomech.heat.materials import conductivity_field
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan.forms import StefanForms, StefanSetup
from ngs_geomech.stefan.materials import PlainThermalMaterial
from ngs_geomech.stefan.problem import stefan_materials
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import stefan_varying as sv

pytestmark = pytest.mark.usefixtures("one_thread")


def test_steady_temperature_with_conductivities_of_x():
    out = sv.steady_varying_conductivity()
    rows = ", ".join(f"h = {lv['h']:g}: {lv['max_error']:.2e} ({lv['ndofs']} dofs, {lv['wall_s']:.2f} s)"
                     for lv in out["levels"])
    print(f"\nsteady strip, max nodal error / (T_b - T_a): {rows}; order {out['order']:.2f}; energy imbalance "
          f"{out['energy_imbalance_rel']:.1e}")
    assert out["stefan_varying_steady_error"] <= 1e-4
    assert out["order"] >= 1.8
    assert out["energy_imbalance_rel"] <= 1e-8
    assert all(lv["melted"] == 0.0 for lv in out["levels"])          # the phase-change region stays solid


def test_front_with_conductivities_of_x_against_the_1d_reference():
    out = sv.varying_front()
    ref = out["reference"]
    rows = ", ".join(f"h = {lv['h']:g}: {lv['front_rel_error']:.2e} ({lv['wall_s']:.2f} s)" for lv in out["levels"])
    print(f"\nvarying slab: 1D fronts {np.round(ref['front'], 6)} (differences {np.round(ref['differences'], 6)}, "
          f"order {ref['order']:.2f}, uncertainty {ref['front_uncertainty_rel']:.1e}, {ref['wall_s']:.2f} s); "
          f"constant k front {out['front_constant']:.6f}\nscene front relative errors {rows}; order "
          f"{out['order']:.2f}; energy imbalance {out['energy_imbalance_rel']:.1e}")
    assert ref["front_uncertainty_rel"] <= 5e-4 and ref["imbalance_rel_max"] <= 1e-8
    assert ref["front_reference"] > 1.2 * out["front_constant"]       # the variation moves the front
    assert out["stefan_varying_front_rel_error"] <= 1e-2
    assert out["order"] >= 0.75
    assert out["energy_imbalance_rel"] <= 1e-8


def test_stiffness_takes_g_at_the_centroid_and_stays_an_m_matrix():
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.2, quad_dominated=False))
    g = "1 + 3*x*x + y"
    mat = PlainThermalMaterial(rho_c=1.0, conductivity=2.0, variation=((g, 0.0), (0.0, g)))
    forms = StefanForms(mesh, StefanSetup(materials={"default": mat}))
    K = forms.stiffness[0]
    V = ngs.H1(mesh, order=1)
    u, v = V.TnT()
    centroid = {ngs.TRIG: ngs.IntegrationRule([(1 / 3, 1 / 3)], [0.5])}
    a = ngs.BilinearForm(V)
    a += (1 + 3 * ngs.x * ngs.x + ngs.y) * ngs.grad(u) * ngs.grad(v) * ngs.dx(intrules=centroid)
    a.Assemble()
    vals, cols, ptr = a.mat.CSR()
    ref = sp.csr_matrix((np.array(vals), np.array(cols), np.array(ptr)), shape=(V.ndof, V.ndof)).toarray()
    dense = K.toarray()
    off = dense - np.diag(np.diag(dense))
    print(f"\nmax |K - K_centroid| {np.max(np.abs(dense - ref)):.1e}, max |column sum| "
          f"{np.max(np.abs(dense.sum(axis=0))):.1e}, largest off-diagonal {off.max():.1e}")
    assert np.allclose(dense, ref, rtol=0, atol=1e-13 * np.abs(ref).max())
    assert np.max(np.abs(dense.sum(axis=0))) <= 1e-13 * np.abs(dense).max()
    assert np.allclose(dense, dense.T)
    assert off.max() <= 1e-13 * np.abs(dense).max()          # non-obtuse mesh: an M-matrix


def _scene() -> dict:
    return sv.varying_scene(sv.VaryingSlab(), 0.1, 0.05, 0.02)


def test_conductivity_field_reads_scale_ratio_and_shape():
    scene = scene_from_dict(_scene())
    m = scene.materials["pcm"]
    pts = np.array([[x, 0.0, 0.0] for x in np.linspace(0.0, 1.0, 11)])
    field = conductivity_field(m, 2, pts)
    print(f"\nk_s = {field.k_s}, k_l = {field.k_l}, G = {field.shape}")
    assert field.k_s == pytest.approx(1.5 * 3.0) and field.k_l == pytest.approx(1.0 * 3.0)
    g = material_cf(field.shape[0][0])          # the shape's expression: 1.5 (1 + 2x) / 4.5
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.5))
    assert g(mesh(0.5, 0.5)) == pytest.approx(2.0 / 3.0, rel=1e-14)
    assert field.shape[0][1] == 0.0
    with pytest.raises(MaterialError) as info:
        conductivity_field(scene_from_dict(_changed(conductivity_liquid="1 + x*x")).materials["pcm"], 2, pts)
    assert info.value.key == "conductivity_liquid" and "x=0.1" in str(info.value)


def test_numbers_keep_the_constant_path():
    mats = stefan_materials(scene_from_dict(_changed(conductivity=1.5, conductivity_liquid=1.0)))   # no mesh needed
    assert mats["pcm"].variation is None and mats["pcm"].conductivity_solid == 1.5


def _changed(**material) -> dict:
    data = copy.deepcopy(_scene())
    data["materials"]["pcm"].update(material)
    return data


@pytest.mark.parametrize("material", [
    {"conductivity": [["1 + x", 0.0], [0.0, "2*(1 + x)"]], "conductivity_liquid": [["0.5*(1 + x)", 0], [0, "1 + x"]]},
    {"conductivity": None, "conductivity_principal": ["1 + x", "2*(1 + x)"], "conductivity_angle": 30.0,
     "conductivity_liquid": None, "conductivity_liquid_principal": ["0.7*(1 + x)", "1.4*(1 + x)"]},
    {"conductivity": "2 + sin(3*x)*y", "conductivity_liquid": "0.3*(2 + sin(3*x)*y)"},
])
def test_validation_takes_shared_variations(material):
    validate(scene_from_dict(_changed(**material)))


def test_plain_region_of_a_stefan_scene_takes_any_conductivity_of_x():
    data = sv.steady_scene(sv.SteadyStrip(), 0.1)
    data["materials"]["rock"]["conductivity"] = [["1 + x*x", "0.1*x"], ["0.1*x", "2 + y"]]
    validate(scene_from_dict(data))


@pytest.mark.parametrize("material, key, message", [
    ({"conductivity": None, "conductivity_principal": ["1 + x", "2*(1 + x)"], "conductivity_liquid": None,
      "conductivity_liquid_principal": ["0.7*(1 + x)", "1 + y"]}, "conductivity_liquid_principal", "not proportional"),
    ({"conductivity_liquid": "0.5*(1 + x) + 0.01*y"}, "conductivity_liquid", "times the solid's conductivity at"),
    ({"conductivity_liquid": "x - 0.5"}, "conductivity_liquid", "must be positive"),
    ({"conductivity_liquid": "1 + T"}, "conductivity_liquid", "unknown name(s) 'T'"),
])
def test_validation_refuses_naming_the_key(material, key, message):
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(_changed(**material)))
    problem = info.value.problems[0]
    print(f"\n{problem}")
    assert problem.item == f"materials.pcm.{key}" and message in problem.message
