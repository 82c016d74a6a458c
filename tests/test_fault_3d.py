"""The built-in 3D scene ``fault_3d`` (a normal fault dipping 60 degrees through rock whose stiffness and
conductivity grow with depth, gravity with a lithostatic prestress, extension on the east side), at a coarse
level, checked against what its data imply.

- Prestress: sigma0 (sigma_zz = rho g z, K0 = 0.8 horizontally) equilibrates gravity with the rollers and the
  fault carries its traction exactly (the in-situ transfer), so the first solve (t = 0, no tectonic load) moves
  the rock only by the thermal stress of the discrete geotherm's error (measured and printed: below 0.1 mm; with
  the mortar's transfer alone it was 1.8 cm at this level); the fault is closed and stuck everywhere (shear / normal
  = 0.433 (1 - K0) / (0.75 K0 + 0.25) = 0.10 < friction 0.6); its pressure at the deepest node
  is sigma0's normal stress there, rho g depth (0.75 K0 + 0.25).
- Extension: the east side's u_x lowers sigma_xx; slip starts where the lithostatic stress is small, so the
  slipping nodes lie shallower than the sticking ones, the slipping zone grows with the load, and the hanging wall
  subsides more than the footwall (a normal fault). Slip nodes are at the Coulomb bound |q| = 0.6 p, stick nodes
  below it. The global force balance closes.
- Geotherm: started from the exact steady geotherm of k = 2 + depth/3000, T = 10 + 195 ln(1 + depth/6000), the
  transient heat stays on it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.contact.problem import STATUS_OPEN, STATUS_SLIP, STATUS_STICK

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_fault_3d")]

RHO_G, K0, FRICTION, DIP = 2600.0 * 9.81, 0.8, 0.6, math.radians(60.0)
EXTENSION = 2.0                                   # m, the east side's u_x at the end
COARSE = ["mesh.maxh=800", "output.vtk=false", "output.figures=false"]


def geotherm(z):
    return 10.0 + 195.0 * np.log(1.0 - z / 6000.0)


@pytest.fixture(scope="module")
def fault():
    return api.run("fault_3d", None, overrides=COARSE, progress=False)


def test_prestress_balances_gravity_and_keeps_the_fault_closed(fault):
    c = fault.summary["mechanics"]["contact"]
    first = c["history"][0]
    assert first["time_s"] == 0.0
    nodes = first["fault"]["nodes"]
    series = fault.summary["probe_series"]
    assert all(series["times_s"][n][0] == 0.0 for n in ("east_surface_ux", "hanging_wall_surface_uz"))
    u0 = max(abs(series[n][0]) for n in ("east_surface_ux", "hanging_wall_surface_uz", "footwall_surface_uz"))
    print(f"\nfault_3d t = 0: nodes {nodes}, max |u| at the surface probes {u0:.2e} m "
          f"({u0 / EXTENSION:.1e} of the extension), max tangential displacement "
          f"{first['fault']['max_tangential_displacement_m']:.1e} m")
    assert nodes["open"] == 0 and nodes["slip"] == 0 and nodes["stick"] > 10
    assert u0 < 1e-4                              # m
    assert first["fault"]["max_tangential_displacement_m"] < 5e-3 * EXTENSION
    depth = 3000.0                                # the deepest fault nodes (at the base)
    expect = RHO_G * depth * (K0 * math.sin(DIP) ** 2 + math.cos(DIP) ** 2)
    assert first["fault"]["max_pressure_Pa"] == pytest.approx(expect, rel=0.05)


def test_extension_slips_the_shallow_fault(fault):
    c = fault.summary["mechanics"]["contact"]
    slip_counts = [h["fault"]["nodes"]["slip"] for h in c["history"]]
    print(f"\nfault_3d slip nodes per load step {slip_counts}, final {c['history'][-1]['fault']['nodes']}, "
          f"max slip {c['interfaces']['fault']['max_slip_m']:.3f} m")
    assert slip_counts[0] == 0 and slip_counts[-1] > 0
    assert all(b >= a for a, b in zip(slip_counts, slip_counts[1:]))
    out = fault.mechanics.contact_output.latest[0]
    status, z = out["status"], out["z"]
    slip, stick = status == STATUS_SLIP, status == STATUS_STICK
    assert slip.any() and (slip | stick | (status == STATUS_OPEN)).all()
    if stick.any():
        assert np.mean(z[slip]) > np.mean(z[stick])            # slip starts near the surface
    q, p, bound = out["traction"][slip], out["pressure"][slip], out["bound"][slip]
    np.testing.assert_allclose(q, FRICTION * p, rtol=1e-6)
    np.testing.assert_allclose(bound, FRICTION * p, rtol=1e-12)
    assert np.all(out["traction"][stick] <= out["bound"][stick] * (1 + 1e-9))
    probes = fault.summary["probes"]
    assert probes["east_surface_ux"]["final"] == pytest.approx(EXTENSION, rel=1e-9)
    assert probes["hanging_wall_surface_uz"]["final"] < probes["footwall_surface_uz"]["final"] < 0.0
    assert c["force_balance"]["imbalance_rel"] < 1e-8


def test_the_geotherm_stays_steady(fault):
    series = fault.summary["probe_series"]["temperature_base"]
    exact = geotherm(-3000.0)
    print(f"\nfault_3d base temperature {series[0]:.4f} .. {series[-1]:.4f} C, exact {exact:.4f} C")
    assert max(abs(v - exact) for v in series) < 0.05
