"""Verification of heat across contacts, frictional heating and the extended Stefan problem (closed forms of
``../shared/notes/verification.md`` section 8, the seed's (2.22), (2.43), (2.49)-(2.58)).

Physics and checks (the functions of :mod:`ngs_geomech.verification.thermal_contact`,
:mod:`ngs_geomech.verification.frictional_heating` and :mod:`ngs_geomech.verification.stefan_extended`):

1. Contact conductance. Two slabs pressed together (non-matching meshes), conductance h on the interface: the
   steady flux q = (T_a - T_b) / (L1/k1 + 1/h + L2/k2) and the jump q / h (heat plane P1 and P2, axisymmetric, 3D;
   Stefan plane and 3D): ``conductance_rel_error``. A Hertz contact with h = C p^0.95 from the mechanics' nodal
   pressure: the heat flow against the integral of h(p(x)) (T_1 - T_2) with the closed-form pressure, P2, contact
   elements a/10, a/20: ``pressure_conductance_rel_error`` and its observed order. An open gap: gas conduction
   and exact radiation (``gap_flux_rel_error``). A gap that thermal expansion closes (coupled): no heat while open,
   the steady flow after, and the energy balance.
2. Frictional heating. A block sliding at constant speed on a half-space under uniform pressure (Coulomb): the
   surface temperature rise (2 q_i / k_i) sqrt(alpha_i t / pi), q = mu p V shared by effusivity (interface, a gap
   closed by the load, a rigid foundation, the Stefan solver), at 3 levels (h and dt halved together):
   ``frictional_heating_rel_error`` (the finest level's worst case) with observed orders.
3. Stefan extensions. Freezing around a line sink (axisymmetric; Carslaw & Jaeger 11.2, its transcription checked
   against a fine 1D radial enthalpy solution): ``axisymmetric_stefan_front_rel_error``; melting under a Robin
   condition against a converged 1D reference: ``robin_stefan_front_rel_error``; an anisotropic two-phase Neumann
   problem (conductivity ratio 4 at 30 degrees): ``anisotropic_stefan_front_rel_error``.
4. ``energy_imbalance_rel``: the largest relative energy imbalance of every coupled and Stefan run above (the gap
   closing with staggered and iterated coupling and in a Stefan scene, the frictional heating runs, the Stefan
   extension levels).

Command (writes ``results.json``; prints the tables)::

    python studies/thermal_contact_verification/run.py --level 0 --out docs/results/thermal_contact_verification
 Level 0 as above (about a minute on one thread); level 1 adds a finer
level to the Stefan extensions and a third Hertz mesh (a/40).

Limits: the Hertz error of P1 levels off near 1e-3 .. 1e-2 (the mechanics' contact width); the frictional heating
uses the static contact's slip increments; the Stefan extensions converge at first order in h (the front from
the melted volume, backward Euler).
"""

from __future__ import annotations

import time
from pathlib import Path

from ngs_geomech.verification import frictional_heating as vf
from ngs_geomech.verification import stefan_extended as vs
from ngs_geomech.verification import thermal_contact as vt
from ngs_geomech.verification.study import convergence_entry, one_ngsolve_thread, report, study_cli, study_main

STUDY = "thermal_contact_verification"
LEVELS = {
    0: {"hertz_divisions": (10, 20), "friction_levels": 3, "stefan_hs": {"line_sink": (0.1, 0.05, 0.025),
                                                                          "robin": (0.05, 0.025, 0.0125),
                                                                          "anisotropic": (0.05, 0.025, 0.0125)}},
    1: {"hertz_divisions": (10, 20, 40), "friction_levels": 4,
        "stefan_hs": {"line_sink": (0.1, 0.05, 0.025, 0.0125), "robin": (0.05, 0.025, 0.0125, 0.00625),
                      "anisotropic": (0.05, 0.025, 0.0125, 0.00625)}},
}
"""Per level: the Hertz contact's element divisions of a, the frictional heating's levels, the Stefan meshes (m)."""

LIMITS = {"conductance_rel_error": 1e-6, "pressure_conductance_rel_error": 1e-2, "frictional_heating_rel_error": 2e-2,
          "axisymmetric_stefan_front_rel_error": 2e-2, "robin_stefan_front_rel_error": 1e-2,
          "energy_imbalance_rel": 1e-8}
"""The issue's thresholds (recorded with the results; the tests assert them)."""


def _conductance(p: dict, metrics: dict, convergence: list, tables: dict) -> list[float]:
    """Section 1; returns the energy imbalances of its coupled runs."""
    slabs = {"heat_p1": vt.two_slabs(), "heat_p2": vt.two_slabs(order=2),
             "heat_axisymmetric": vt.two_slabs(dimension="axisymmetric"),
             "heat_3d": vt.two_slabs(dimension="3d", maxh=0.2), "stefan_plane": vt.two_slabs(stefan=True),
             "stefan_3d": vt.two_slabs(stefan=True, dimension="3d", maxh=0.2)}
    tables["two_slabs"] = slabs
    for name, r in slabs.items():
        metrics[f"conductance_rel_error_{name}"] = r["conductance_rel_error"]
    metrics["conductance_rel_error"] = max(r["conductance_rel_error"] for r in slabs.values())
    hertz = vt.hertz_conductance_convergence(divisions=p["hertz_divisions"])
    tables["hertz"] = hertz
    convergence.append(convergence_entry("pressure_conductance_rel_error", hertz["h_contact"],
                                         [0] * len(hertz["h_contact"]), hertz["errors"], 1.5))   # p ~ sqrt(a^2 - x^2)
    metrics["pressure_conductance_rel_error"] = hertz["pressure_conductance_rel_error"]
    metrics["gap_flux_rel_error"] = vt.gap_slabs()["gap_flux_rel_error"]
    gaps = {"staggered": vt.gap_closing(), "iterated": vt.gap_closing(coupling="iterated")}
    tables["gap_closing"] = gaps
    metrics["gap_closing_steady_flow_rel_error"] = max(g["steady_flow_rel_error"] for g in gaps.values())
    metrics["gap_closing_flow_while_open"] = max(abs(g["flow_while_open"]) for g in gaps.values())
    return [g["energy_imbalance_rel"] for g in gaps.values()]


def _friction(p: dict, metrics: dict, convergence: list, tables: dict) -> list[float]:
    """Section 2; returns its runs' energy errors."""
    r = vf.frictional_heating(levels=p["friction_levels"])
    tables["frictional_heating"] = {c: {k: v for k, v in d.items() if k != "runs"} for c, d in r["cases"].items()}
    for case, d in r["cases"].items():
        convergence.append(convergence_entry(f"frictional_heating_rel_error_{case}", d["h"],
                                             [0] * len(d["h"]), d["rel_error"], 1 if case == "stefan" else 2))
    for key in ("frictional_heating_rel_error", "frictional_heating_rate_rel_error"):
        metrics[key] = r[key]
    metrics["frictional_heating_energy_rel_error"] = r["frictional_heating_energy_rel_error"]
    return [r["frictional_heating_energy_rel_error"]]


def _stefan(p: dict, metrics: dict, convergence: list, tables: dict) -> list[float]:
    """Section 3; returns the energy imbalances of its levels."""
    hs = p["stefan_hs"]
    runs = {"axisymmetric_stefan": vs.line_sink_freezing(hs=hs["line_sink"]),
            "robin_stefan": vs.robin_melting(hs=hs["robin"]),
            "anisotropic_stefan": vs.anisotropic_neumann(hs=hs["anisotropic"])}
    for name, r in runs.items():
        tables[name] = {k: v for k, v in r.items() if k != "levels"}
        dofs = [lv["ndofs"] for lv in r["levels"]]
        convergence.append(convergence_entry(f"{name}_front_rel_error", r["h"], dofs, r["front_rel_error"], 1))
        metrics[f"{name}_front_rel_error"] = r[f"{name}_front_rel_error"]
    metrics["line_sink_reference_front_rel_error_max"] = runs["axisymmetric_stefan"]["reference"].get(
        "front_rel_error_max", float("nan"))
    return [r["energy_imbalance_rel"] for r in runs.values()]


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the raw dicts of the verification functions (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    p = LEVELS[level]
    t_start = time.perf_counter()
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {}
    timing: dict[str, float] = {}
    imbalances: list[float] = []
    with one_ngsolve_thread():
        for name, part in (("conductance", _conductance), ("frictional_heating", _friction), ("stefan", _stefan)):
            tic = time.perf_counter()
            imbalances += part(p, metrics, convergence, tables)
            timing[f"{name}_s"] = time.perf_counter() - tic
    metrics["energy_imbalance_rel"] = max(imbalances)
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing,
              "limits": LIMITS}
    return result, tables


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level``; write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
