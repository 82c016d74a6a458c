"""A stress-free temperature T0(x) equal to the initial temperature makes the initial state stress-free exactly:
T0 is taken in the temperature's finite element space, set as the thermal part sets its initial temperature
(the seed's T0 in H1), so T - T0 = 0 at t = 0 (a T0 left as the exact expression would keep the interpolation
error of the geotherm, ~beta h^2 T'' / 8, as a thermal stress). Checked with the heat solver and with the
Stefan solver (a phase-change region in the scene), P1 and P2: u = 0 and sigma = 0 at t = 0 to round-off, and
the same scene with T0 as an expression of another form (a shifted geotherm) keeps its thermal stress."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.run.model import Model
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

GEOTHERM = "20 + 800*erf(-y/400) + 30*sin(x/150)"      # degC: curved, not in any finite element space
E, NU, ALPHA = 70e9, 0.25, 1e-5


def _scene(order, *, phase_change=False, T0=GEOTHERM):
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, -1000], "size": [600, 1000],
               "boundaries": {"sides": ["xmin", "xmax"], "bottom": "ymin", "top": "ymax"}}]
    mat = {"conductivity": 3.0, "density": 2700.0, "specific_heat": 900.0, "youngs_modulus": E,
           "poisson_ratio": NU, "thermal_expansion": ALPHA, "stress_free_temperature": T0}
    materials = {"rock": mat}
    if phase_change:                     # a Stefan region: the enthalpy solver takes the whole scene
        blocks.append({"name": "pocket", "shape": "rectangle", "origin": [200, -700], "size": [200, 200]})
        materials["pocket"] = dict(mat, phase_change_temperature=700.0, latent_heat=3.0e5,
                                   specific_heat_liquid=1000.0, conductivity_liquid=2.0)
    d = {"scene": {"name": "geotherm", "dimension": "plane", "temperature_unit": "C"},
         "physics": {"thermal": "transient", "mechanics": "static"},
         "mesh": {"maxh": 100.0, "order": order}, "blocks": blocks, "materials": materials,
         "initial": {"temperature": GEOTHERM},
         "boundary_conditions": {"sides": {"symmetry": True}, "bottom": {"symmetry": True}},
         "time": {"end": "1 year", "dt": "1 year"}, "output": {"vtk": False, "figures": False}}
    if phase_change:
        d["interfaces"] = [{"name": "pocket_wall", "blocks": ["rock", "pocket"], "type": "glued"}]
    return scene_from_dict(d)


def _t0_state(sc):
    """max |u| (m) and max |sigma| (Pa) at the vertices after the t = 0 solve."""
    geo = validate(sc)
    mesh = make_mesh(geo, sc.mesh)
    model = Model(sc, geo, mesh)
    model.start(0.0, "t = 0")
    u, sig = model.mechanics.forms.displacement(), model.mechanics.sigma
    pts = [mesh(*v.point) for v in mesh.vertices]
    return (max(float(np.abs(u(p)).max()) for p in pts), max(float(np.abs(sig(p)).max()) for p in pts))


@pytest.mark.parametrize("order, phase_change", [(1, False), (2, False), (1, True)])
def test_initial_geotherm_as_stress_free_temperature_gives_no_stress(order, phase_change):
    u, s = _t0_state(_scene(order, phase_change=phase_change))
    beta_dT = E * ALPHA / (1 - 2 * NU) * 800.0
    print(f"\nP{order} {'Stefan' if phase_change else 'heat'}: max |u| {u:.1e} m, max |sigma| {s:.1e} Pa "
          f"(beta times the geotherm's range {beta_dT:.1e} Pa)")
    assert u < 1e-12 and s < 1e-9 * beta_dT


def test_another_stress_free_temperature_keeps_its_thermal_stress():
    """T0 = the geotherm + 10 K: a uniform cooling of 10 K against T0, sigma_xx = sigma_zz = beta 10 K under the
    rollers (plane strain, free top: sigma_yy = 0), as with numbers."""
    u, s = _t0_state(_scene(1, T0=f"{GEOTHERM} + 10"))
    beta = E * ALPHA / (1 - 2 * NU)
    expected = beta * 10.0 * (1 - 2 * NU) / (1 - NU)      # e_xx = e_zz = 0, sigma_yy = 0
    print(f"\nT0 = geotherm + 10 K: max |sigma| {s:.6e} Pa, closed form {expected:.6e} Pa")
    assert s == pytest.approx(expected, rel=1e-9)
