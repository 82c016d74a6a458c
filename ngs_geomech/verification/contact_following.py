"""Hertz line contact under a growing load, as a time-dependent scene: the check of meshes that follow the contact
zone (:mod:`ngs_geomech.adapt.contact_following`).

A quarter cylinder (R = 1 m, E = 200 GPa, nu = 0.3, plane strain; the arc a 40-point spline through the circle)
with a symmetry condition on x = 0 rests on a rigid frictionless foundation y = 0 and is held by the contact alone;
its top carries the traction P(t) / (2 R) with P(t) = P1 t (N per m of the whole cylinder), t = 1 ... ``steps`` s.
Hertz (plane strain): a(t) = sqrt(4 P R / (pi E*)) = a1 sqrt(t) with a1 = R / 50, p0(t) = 2 P / (pi a),
E* = E / (1 - nu^2). The contact zone's end moves from a1 to a1 sqrt(steps): a mesh that follows it must move its
fine band with it.

Measured per mechanics time: the peak pressure (the nodal maximum) against p0, the closed length (the contact
output's ``closed_length_m``: the midpoint between the last closed and the first open node) against a, the normal
force against P / 2 (force balance), and the unknowns.
"""

from __future__ import annotations

import math
import time

import numpy as np

R = 1.0
E = 200e9
NU = 0.3
E_STAR = E / (1 - NU ** 2)
A1 = R / 50
P1 = math.pi * E_STAR * A1 ** 2 / (4 * R)
"""Load per m of the whole cylinder at t = 1 s (N/m)."""


def hertz_growing_scene(*, maxh: float = 0.1, order: int = 2, steps: int = 4, adaptivity: dict | None = None,
                        arc_maxh: float | None = None) -> dict:
    """The scene (a dict for :func:`ngs_geomech.scene.parse.scene_from_dict`): ``maxh`` (m) the global size,
    ``arc_maxh`` (m) a size along the whole contact arc (a fixed mesh fine along the contact side),
    ``adaptivity`` the ``[adaptivity]`` table (e.g. {"indicators": ["contact_zone"], "levels": 4})."""
    th = np.linspace(0.0, math.pi / 2, 41)
    arc = [[R * math.sin(t), R - R * math.cos(t)] for t in th[1:]]
    mesh = {"maxh": maxh, "order": order}
    if arc_maxh is not None:
        mesh["boundary_maxh"] = {"arc": arc_maxh}
    d = {"scene": {"name": "hertz_growing"}, "physics": {"mechanics": "static"}, "mesh": mesh,
         "time": {"start": 1.0, "end": float(steps), "dt": 1.0},
         "blocks": [{"name": "cylinder", "shape": "profile", "start": [0.0, 0.0],
                     "segments": [{"spline": arc, "name": "arc"}, {"line": [0.0, R], "name": "top"},
                                  {"line": [0.0, 0.0], "name": "sym"}]}],
         "materials": {"cylinder": {"youngs_modulus": E, "poisson_ratio": NU}},
         "boundary_conditions": {"arc": {"foundation": {"point": [0.0, 0.0], "normal": [0.0, 1.0]}},
                                 "top": {"traction": ["0", f"-{P1 / (2 * R)!r}*t"]},
                                 "sym": {"symmetry": True}},
         "output": {"vtk": False, "figures": False}}
    if adaptivity is not None:
        d["adaptivity"] = adaptivity
    return d


def hertz_growing(**kw) -> dict:
    """Run :func:`hertz_growing_scene` (writes nothing) and compare with Hertz at every mechanics time: {"times",
    "a", "closed_length", "a_error" (m), "p0_rel_error", "force_balance" (the run's global imbalance),
    "normal_force_rel_error" (|int p ds - P/2| / (P/2): O((a/R)^2), the arc's normal is not vertical), "dofs" (of the
    final mesh), "dofs_per_solve" (following meshes; else the fixed mesh's), "wall_s", "summary"}."""
    from ..run import run_scene
    from ..scene.parse import scene_from_dict

    tic = time.perf_counter()
    res = run_scene(scene_from_dict(hertz_growing_scene(**kw)), None, progress=False)
    wall = time.perf_counter() - tic
    out = {"times": [], "a": [], "closed_length": [], "a_error": [], "p0_rel_error": [], "force_balance": [],
           "normal_force_rel_error": []}
    for e in res.summary["mechanics"]["contact"]["history"]:
        t = e["time_s"]
        arc = e["arc"]
        P = P1 * t
        a = A1 * math.sqrt(t)
        p0 = 2 * P / (math.pi * a)
        out["times"].append(t)
        out["a"].append(a)
        out["closed_length"].append(arc["closed_length_m"])
        out["a_error"].append(abs(arc["closed_length_m"] - a))
        out["p0_rel_error"].append(abs(arc["max_pressure_Pa"] / p0 - 1))
        out["normal_force_rel_error"].append(abs(arc["normal_force"] - P / 2) / (P / 2))
        out["force_balance"].append(e["imbalance_rel"])
    adapt = res.summary.get("adaptivity")
    out["dofs"] = res.summary["mesh"]["dofs"]
    out["dofs_per_solve"] = [out["dofs"]] * len(out["times"]) if adapt is None else adapt["dofs"]["per_solve"]
    out["wall_s"] = wall
    out["summary"] = res.summary
    return out
