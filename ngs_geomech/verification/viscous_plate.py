"""The plate-collision scenario (``geometries/plate_collision.toml``) with the global model's viscous terms
against its quasi-static run: the same scene with ``physics.mechanics = "viscous"`` and Kelvin-Voigt
viscosity in the mantle wedge and the melting zone (``viscosity_time``: C^v = tau_v C), reporting the principal
stresses, the contact forces, the displacement of the arc plate and the temperatures of both runs and their
differences. Plain dicts; prints nothing.
"""

from __future__ import annotations

import time

import ngsolve as ngs
import numpy as np

from ..api import run

VISCOUS = {"mantle_wedge": "5000 year", "melt_zone": "500 year"}
"""Kelvin-Voigt relaxation times of the viscous run (illustrative: the wedge's viscosity eta = tau_v G with
G = 60 GPa and tau_v = 5000 years is ~1e22 Pa s, the upper-mantle order; the partially molten zone ten times less)."""


def _element_range(mesh, cf) -> tuple[float, float]:
    g = ngs.GridFunction(ngs.L2(mesh, order=0))
    g.Set(cf)
    v = g.vec.FV().NumPy()
    return float(v.min()), float(v.max())


def _numbers(res) -> dict:
    m = res.mechanics
    mesh = res.mesh
    s1 = _element_range(mesh, m.fields["sigma_1"])
    s3 = _element_range(mesh, m.fields["sigma_3"])
    u = m.forms.displacement()
    pts = mesh(300e3, -10e3)
    contacts = {}
    for spec, res_c in zip(m.contacts, m.contact_output.latest):
        w = np.maximum(spec.op.weight, 0.0)
        contacts[spec.name] = {"normal_force": float(w @ res_c["pressure"]),
                               "nodes_closed": int(np.count_nonzero(res_c["pressure"] > 0))}
    T = res.stefan.forms.nodal_state(res.stefan.solver.e).T
    return {"sigma_1_max_Pa": s1[1], "sigma_3_min_Pa": s3[0], "ux_arc_m": float(u(pts)[0]),
            "uy_arc_m": float(u(pts)[1]), "T_max_C": float(T.max()),
            "melted_fraction": res.summary["stefan"]["melted_fraction"]["melt_zone"][-1],
            "deformation_heat_J": res.summary["coupling"]["deformation_heat_total"], "contacts": contacts}


def viscous_vs_quasistatic(overrides=(), viscous: dict | None = None) -> dict:
    """Run the scenario quasi-static and viscous (same ``overrides``: e.g. a coarse mesh) and compare."""
    viscous = VISCOUS if viscous is None else viscous
    out = {}
    for mode in ("static", "viscous"):
        sets = list(overrides) + [f"physics.mechanics={mode}"]
        if mode == "viscous":
            sets += [f'materials.{r}.viscosity_time="{t}"' for r, t in viscous.items()]
        tic = time.perf_counter()
        res = run("plate_collision", None, overrides=sets, progress=False)
        row = _numbers(res)
        row["wall_s"] = time.perf_counter() - tic
        if mode == "viscous":
            row["viscous_dissipation_J"] = res.summary["mechanics"].get("viscous_dissipation_J", 0.0)
        out[mode] = row
    s, v = out["static"], out["viscous"]
    out["difference"] = {k: v[k] - s[k] for k in ("sigma_1_max_Pa", "sigma_3_min_Pa", "ux_arc_m", "uy_arc_m",
                                                  "T_max_C", "melted_fraction", "deformation_heat_J")}
    out["difference"]["contacts_normal_force_rel"] = {
        n: (v["contacts"][n]["normal_force"] - s["contacts"][n]["normal_force"])
        / max(abs(s["contacts"][n]["normal_force"]), 1e-300) for n in s["contacts"]}
    return out
