"""The built-in 3D scene ``repository_fracture_3d`` (repository_3d's KBS-3 cell cut by an inclined Coulomb
fracture zone below the hole), at repository_3d's coarse test level (P1, 30 years), checked against what its data
imply.

- The fracture under the in-situ stress (K0 = 1.5, dip 60): shear / normal = 0.433 (K0 - 1) / (0.75 K0 + 0.25)
  = 0.16 < friction 0.3, so at t = 0 every node is closed and stuck, with a pressure near sigma0's normal stress,
  rho g depth (0.75 K0 + 0.25) less the geotherm's cancelling thermal term (loosely: the coarse level has 13
  contact nodes); heated, the pressure grows (thermal
  expansion of the confined rock) and no node opens.
- Heat crosses the contact interface by the mortar coupling: the canister temperature equals repository_3d's at
  the same level (the fracture is 20 m or more from the hole).
- Slip nodes are at the Coulomb bound; the global force balance closes.
"""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.contact.problem import STATUS_OPEN, STATUS_SLIP, STATUS_STICK

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_repository_fracture_3d")]

FRICTION, K0 = 0.3, 1.5
COARSE = ["mesh.maxh=200", "mesh.order=1", "blocks.buffer.maxh=0.3", "blocks.canister.maxh=0.3",
          "blocks.tunnel.maxh=2", "time.end=30 year", "time.dt_max=5 year", "output.every=5",
          "output.vtk=false", "output.figures=false"]


@pytest.fixture(scope="module")
def runs():
    return {name: api.run(name, None, overrides=COARSE, progress=False)
            for name in ("repository_fracture_3d", "repository_3d")}


def test_fracture_closed_at_rest_and_loaded_by_the_heat(runs):
    c = runs["repository_fracture_3d"].summary["mechanics"]["contact"]
    hist = [h["fracture"] for h in c["history"]]
    print("\nrepository_fracture_3d fracture per output time: "
          + ", ".join(f"{h['nodes']['stick']}/{h['nodes']['slip']}/{h['nodes']['open']} "
                      f"p_max {h['max_pressure_Pa'] / 1e6:.2f} MPa" for h in hist))
    assert hist[0]["nodes"]["open"] == 0 and hist[0]["nodes"]["slip"] == 0 and hist[0]["nodes"]["stick"] > 5
    assert all(h["nodes"]["open"] == 0 for h in hist)
    assert hist[-1]["max_pressure_Pa"] > hist[0]["max_pressure_Pa"]
    depth_max = 525.0 + 4.5 + 17.3                  # the fracture's deepest point, m
    p_max = 2700 * 9.81 * depth_max * (0.75 * K0 + 0.25) - 1.0096e6 * 0.015 * (depth_max - 500.0)
    print(f"t = 0: max nodal pressure {hist[0]['max_pressure_Pa'] / 1e6:.2f} MPa, sigma0's normal stress at the "
          f"deepest point {p_max / 1e6:.2f} MPa")
    # the nodal pressure is a weighted mean of sigma0's normal stress over the node's support (13 nodes here)
    assert 0.7 * p_max < hist[0]["max_pressure_Pa"] < 1.05 * p_max
    out = runs["repository_fracture_3d"].mechanics.contact_output.latest[0]
    status = out["status"]
    slip, stick = status == STATUS_SLIP, status == STATUS_STICK
    assert (slip | stick | (status == STATUS_OPEN)).all()
    np.testing.assert_allclose(out["traction"][slip], FRICTION * out["pressure"][slip], rtol=1e-6)
    assert np.all(out["traction"][stick] <= out["bound"][stick] * (1 + 1e-9))
    assert c["force_balance"]["imbalance_rel"] < 1e-8


def test_canister_temperature_as_without_the_fracture(runs):
    peaks = {n: r.summary["probes"]["canister_buffer_max"]["max"] for n, r in runs.items()}
    print(f"\ncanister/buffer peak: {peaks}")
    assert peaks["repository_fracture_3d"] == pytest.approx(peaks["repository_3d"], abs=0.2)   # the meshes differ
