"""The built-in scene ``fault_heating`` (a thrust fault pushed up its dip at 2 cm/year for 100 kyr, Coulomb friction
0.6, its frictional work heating both sides), at its quick level, checked against what its data imply.

- t = 0: gravity and the lithostatic prestress are in equilibrium and the fault carries the prestress's traction
  exactly: the rock is at rest and the fault stuck.
- The slip spreads from the surface down; from the time the whole fault slides, every node is at the Coulomb
  bound |q| = 0.6 p, and the frictional heat balance closes (dissipated = entered + owed to the next heat step).
- Heating: the temperature on the fault rises above the geotherm, more at depth (tau = 0.6 p grows with depth).
  At 10 km depth the rise is close to a half-space's under the flux q/2 = 0.6 p V / 2 from the time the node
  slides, (2 (q/2) / k) sqrt(kappa t / pi) (Carslaw & Jaeger 2.9; the closed form ignores the finite fault and the
  time-varying pressure, so within 25 %).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.contact.problem import STATUS_SLIP

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_fault_heating")]

YEAR = 365.25 * 86400.0
V, MU, K, RHO_C = 0.02 / YEAR, 0.6, 2.5, 2700.0 * 1000.0


@pytest.fixture(scope="module")
def run():
    return api.run("fault_heating", None, overrides=["output.vtk=false", "output.figures=false"], progress=False)


def test_at_rest_and_stuck_at_t0_then_sliding(run):
    c = run.summary["mechanics"]["contact"]
    hist = [h["fault"] for h in c["history"]]
    print(f"\nfault_heating slip nodes per step {[h['nodes']['slip'] for h in hist]}")
    assert hist[0]["nodes"]["slip"] == 0 and hist[0]["nodes"]["open"] == 0
    assert hist[0]["max_tangential_displacement_m"] < 1e-6
    slips = [h["nodes"]["slip"] for h in hist]
    assert all(b >= a for a, b in zip(slips, slips[1:]))
    out = run.mechanics.contact_output.latest[0]
    slip = out["status"] == STATUS_SLIP
    assert slip.sum() >= len(slip) - 1
    np.testing.assert_allclose(np.abs(out["traction"][slip]), MU * out["pressure"][slip], rtol=1e-6)
    assert c["force_balance"]["imbalance_rel"] < 1e-8


def test_frictional_heat_balance_closes(run):
    fh = run.summary["coupling"]["frictional_heating"]
    e = fh["energy"]
    print(f"\nfault_heating frictional heat: dissipated {e['dissipated']:.4e} J/m, entered {e['entered']:.4e}, "
          f"owed {e['owed']:.4e}, imbalance {e['imbalance_rel']:.1e}")
    assert e["dissipated"] > 0 and e["imbalance_rel"] < 1e-8
    assert fh["contacts"]["fault"]["share_side"] == pytest.approx(0.5, rel=1e-12)


def test_the_fault_heats_more_at_depth_as_a_half_space_would(run):
    series = run.summary["probe_series"]
    rise = {d: series[f"fault_T_{d}km"][-1] - series[f"fault_T_{d}km"][0] for d in (5, 10, 15, 20)}
    print(f"\nfault_heating temperature rise on the fault: {rise}")
    assert 0 < rise[5] < rise[10] < rise[15] < rise[20]
    # at 10 km depth: q/2 = MU p V / 2 from the time the node slides (p from the contact output at the end)
    out = run.mechanics.contact_output.latest[0]
    depth = -np.asarray(out["y"])
    order = np.argsort(depth)
    p10 = float(np.interp(10.0e3, depth[order], np.asarray(out["pressure"])[order]))
    times = np.asarray(series["times_s"]["fault_T_10km"])
    hist = run.summary["mechanics"]["contact"]["history"]
    share = float(np.mean(depth <= 10.0e3))          # the slip spreads down: the node slides once this share does
    onset = next(h["time_s"] for h in hist if h["fault"]["nodes"]["slip"] >= share * sum(h["fault"]["nodes"].values()))
    t = times[-1] - onset
    kappa = K / RHO_C
    expect = 2 * (MU * p10 * V / 2) / K * math.sqrt(kappa * t / math.pi)
    print(f"at 10 km: rise {rise[10]:.1f} K, half-space estimate {expect:.1f} K (p {p10 / 1e6:.0f} MPa, "
          f"sliding {t / YEAR:.0f} years)")
    assert rise[10] == pytest.approx(expect, rel=0.25)
