"""Figures of the built-in scenes that the documentation quotes: runs of the scenes as shipped.

Physics. ``contact_melting`` (problem (P_c), seed (2.37)-(2.66)): two years of a heated salt core (the enthalpy
form (2.55) with the deformation heating -Theta_0 beta : e(u_t) of (2.49)) under a rock block in Coulomb contact
(bedding plane, F_c = 0.6), squeezed by a prescribed plate motion; once as shipped (staggered coupling) and once
with the deformation heating switched off (``physics.coupling = "none"``), to measure what the heating adds to the
melted fraction. The figures are the run's final state from ``summary.json``: the melted fraction of the salt, the
bedding's node states (stick, slip, open, prescribed: held on both sides by the supports), its largest contact
pressure, the deformation heat and the relative energy imbalance of the Stefan problem.

Command: ``python studies/scene_figures/run.py --level 1 --out docs/results/scene_figures`` writes the results the
README quotes (``studies/quote.py`` fills them in). Level 0 runs the same scene coarse and short (60 days, maxh
0.25 m: the contract test of the suite, about 2 s); level 1 the scene as shipped (about 20 s on one thread).
"""

from __future__ import annotations

import time
from pathlib import Path

from ngs_geomech import api
from ngs_geomech.verification.study import report, study_cli, study_main

STUDY = "scene_figures"
LEVELS = {0: ["time.end=60 day", "time.dt=10 day", "mesh.maxh=0.25"], 1: []}
"""The overrides of the ``contact_melting`` scene per level (level 1: as shipped)."""


def _contact_melting(overrides: list[str]) -> tuple[dict, float]:
    tic = time.perf_counter()
    res = api.run("contact_melting", None, overrides=overrides, progress=False, threads=1)
    return res.summary, time.perf_counter() - tic


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the two runs' summaries (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}")
    shipped, wall = _contact_melting(LEVELS[level])
    unheated, wall_unheated = _contact_melting([*LEVELS[level], "physics.coupling=none"])
    bedding = shipped["mechanics"]["contact"]["interfaces"]["bedding"]
    nodes = bedding["nodes"]
    salt = shipped["stefan"]["melted_fraction"]["salt"][-1]
    metrics = {
        "contact_melting_melted_fraction_salt": salt,
        "contact_melting_melted_percent_salt": 100 * salt,
        "contact_melting_heating_melted_fraction_gain": salt - unheated["stefan"]["melted_fraction"]["salt"][-1],
        "contact_melting_bedding_nodes": sum(nodes.values()),
        "contact_melting_stick_nodes": nodes["stick"],
        "contact_melting_slip_nodes": nodes["slip"],
        "contact_melting_open_nodes": nodes["open"],
        "contact_melting_prescribed_nodes": nodes["prescribed"],
        "contact_melting_max_pressure_GPa": bedding["max_pressure_Pa"] / 1e9,
        "contact_melting_deformation_heat_J_per_m": shipped["coupling"]["deformation_heat_total"],
        "contact_melting_energy_imbalance_rel": shipped["stefan"]["energy"]["imbalance_rel_max"],
        "contact_melting_wall_s": wall,
    }
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": [],
              "timing_s": {"contact_melting_s": wall, "contact_melting_unheated_s": wall_unheated}}
    return result, {"shipped": shipped, "unheated": unheated}


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1 as shipped); write ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
