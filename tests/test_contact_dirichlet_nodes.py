"""A contact node whose normal displacement is prescribed (a foundation's end node on a boundary with u_n given)
takes no multiplier: it was undetermined (1.9e21 Pa reported, balanced by an equal support reaction)."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict

pytestmark = pytest.mark.usefixtures("one_thread")


def test_foundation_end_node_with_a_prescribed_normal_displacement():
    d = {"scene": {"name": "corner"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.1},
         "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 0.5],
                     "boundaries": {"bottom": "ymin", "left": "xmin", "top": "ymax"}}],
         "materials": {"block": {"youngs_modulus": 10e9, "poisson_ratio": 0.25}},
         "boundary_conditions": {"left": {"displacement": [0.0, 0.0]}, "top": {"pressure": 1e6},
                                 "bottom": {"foundation": {"point": [0, 0], "normal": [0, 1]}}},
         "output": {"vtk": False, "figures": False}}
    res = run_scene(scene_from_dict(d), None, progress=False)
    c = res.summary["mechanics"]["contact"]
    f = c["interfaces"]["bottom"]
    bal = c["force_balance"]
    lam_n = res.mechanics.solver.contact.multipliers[0][0]
    x = res.mechanics.contacts[0].op.coords[:, 0]
    print(f"\nfoundation force {f['normal_force']:.6e} N/m, support {bal['support_reactions'][1]:.6e}, max pressure "
          f"{f['max_pressure_Pa']:.4e} Pa, corner multiplier {lam_n[np.argmin(x)]:.3g}")
    assert f["max_pressure_Pa"] < 2e6 and lam_n[np.argmin(x)] == 0.0
    assert 0.5e6 < f["normal_force"] < 1e6 and bal["imbalance_rel"] < 1e-10
