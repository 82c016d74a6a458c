"""The plate collision scene (geometries/plate_collision.toml) at its quick level: the lithostatic state at t = 0,
the slab geotherm's consistency (one temperature field: the regions' expressions agree on the interfaces, the
boundary temperatures and the stress-free temperatures are the initial temperature), and the megathrust closed
along most of its length under the convergence at the end time."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.run.model import Model
from ngs_geomech.scene import expressions
from ngs_geomech.scene.parse import load_scene
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

RHO_G = 3300.0 * 9.81           # Pa/m, the reference density of the section times g
# interface name -> (its polyline (m), the two regions on its sides)
INTERFACES = {"megathrust": ([[100.0e3, 0.0], [200.0e3, -40.0e3], [207272.727, -50.0e3]],
                             ("arc_plate", "pacific_plate")),
              "slab_wedge": ([[207272.727, -50.0e3], [280.0e3, -150.0e3]], ("mantle_wedge", "pacific_plate")),
              "arc_base": ([[207272.727, -50.0e3], [400.0e3, -50.0e3]], ("arc_plate", "mantle_wedge")),
              "melt_zone_top": ([[300.0e3, -90.0e3], [360.0e3, -90.0e3]], ("mantle_wedge", "melt_zone"))}
# boundary with a prescribed temperature -> (its end points, the region it bounds)
BOUNDARIES = {"slab_end": ([[205810.161, -150.0e3], [280.0e3, -150.0e3]], "pacific_plate"),
              "ocean_base": ([[0.0, -60.0e3], [88445.056, -60.0e3]], "pacific_plate"),
              "slab_base_1": ([[88445.056, -60.0e3], [161652.255, -89282.880]], "pacific_plate"),
              "slab_base_2": ([[161652.255, -89282.880], [205810.161, -150.0e3]], "pacific_plate"),
              "wedge_base": ([[280.0e3, -150.0e3], [400.0e3, -150.0e3]], "mantle_wedge")}


@pytest.fixture(scope="module")
def scene():
    return load_scene("plate_collision")


def _along(line, n=41):
    """n points on each segment of a polyline."""
    return [np.asarray(a) + s * (np.asarray(b) - np.asarray(a))
            for a, b in zip(line[:-1], line[1:]) for s in np.linspace(0.0, 1.0, n)]


def _geotherm(scene, region):
    return expressions.float_function(scene.initial.regions[region])


def test_the_geotherm_is_one_field_and_the_stress_free_state(scene):
    """Every region's stress-free temperature is its initial temperature (the same text); the regions'
    expressions agree on the interfaces; each prescribed boundary temperature is its region's initial one."""
    for name, mat in scene.materials.items():
        assert mat.stress_free_temperature == scene.initial.regions[name], name
    worst = {}
    for name, (ends, (a, b)) in INTERFACES.items():
        fa, fb = _geotherm(scene, a), _geotherm(scene, b)
        worst[name] = max(abs(fa(x=p[0], y=p[1]) - fb(x=p[0], y=p[1])) for p in _along(ends))
    for name, (ends, region) in BOUNDARIES.items():
        fb = expressions.float_function(scene.boundary_conditions[name].temperature)
        fr = _geotherm(scene, region)
        worst[name] = max(abs(fb(x=p[0], y=p[1]) - fr(x=p[0], y=p[1])) for p in _along(ends))
    print("\nlargest temperature difference (K) across the interfaces and against the boundary values: "
          + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    assert max(worst.values()) < 1e-4            # K: the vertices are given to 1 mm
    slab, wedge = _geotherm(scene, "pacific_plate"), _geotherm(scene, "mantle_wedge")
    cold, hot = slab(x=240.0e3, y=-120.0e3), wedge(x=380.0e3, y=-120.0e3)
    print(f"T at 120 km depth: slab interior {cold:.0f} C, back-arc wedge {hot:.0f} C")
    assert cold < hot - 200.0                      # the cold slab


def test_lithostatic_state_at_t0(scene):
    """The t = 0 solve (gravity, the lithostatic prestress, the initial geotherm as T0): the prestress balances
    gravity, the supports and the slab end's pressure, and the contact interfaces carry its traction exactly (the
    in-situ transfer), so the displacement is round-off and sigma_zz is the lithostatic prestress (rho g y)."""
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    model = Model(scene, geo, mesh)
    model.start(0.0, "t = 0")
    mech = model.mechanics
    u, sig = mech.forms.displacement(), mech.sigma
    pts = [v.point for v in mesh.vertices]
    U = np.array([u(mesh(*p)) for p in pts])
    S = np.array([sig(mesh(*p)) for p in pts])
    umax = float(np.abs(U).max())
    trench = float(u(mesh(100.0e3, 0.0))[1])
    y = np.array([p[1] for p in pts])
    zz = float(np.abs(S[:, 8] - RHO_G * y).max())
    vm = float(np.array([mech.fields["von_mises"](mesh(*p)) for p in pts]).max())
    print(f"\nt = 0: max |u| {umax:.3e} m, trench u_y {trench:.3e} m; max |sigma_zz - rho g y| {zz:.3e} Pa; "
          f"max von Mises {vm:.3e} Pa (lithostatic pressure at 150 km {RHO_G * 150.0e3:.3e} Pa)")
    assert umax < 1e-6                 # m
    assert abs(trench) < 1e-6
    assert zz < 1e-6 * RHO_G * 150.0e3 and vm < 1e-6 * RHO_G * 150.0e3


def test_megathrust_closed_under_convergence():
    """At the end (1e5 years, 6 km of convergence) the megathrust is closed (stick or slip) at most nodes."""
    res = api.run("plate_collision", None, overrides=["output.vtk=false", "output.figures=false"], progress=False)
    c = res.summary["mechanics"]["contact"]
    nodes = c["interfaces"]["megathrust"]["nodes"]
    closed = nodes["stick"] + nodes["slip"]
    total = closed + nodes["open"] + nodes["prescribed"]
    print(f"\nmegathrust nodes {nodes}: closed {closed} of {total}; slab_wedge "
          f"{c['interfaces']['slab_wedge']['nodes']}; dofs {res.summary['mesh']['dofs']}")
    assert closed >= 0.75 * total
    assert c["force_balance"]["imbalance_rel"] < 1e-8
    assert not res.summary["warnings"]
