"""The built-in scene ``canister_gap`` (the canister of ``canister`` with a 0.5 mm gap to its buffer that its
thermal expansion closes; static thermo-elastic contact coupled with the heat, contact conductance across the gap),
coarse (:data:`COARSE`: two years, a coarser canister and buffer), checked against what its data imply.

- The gap: at the start only the floor (the canister's weight) is closed; the expansion closes the whole canister
  surface within weeks.
- Heat across it: while open, the air in the gap and radiation: the effective conductance of the first step is
  k_gap / 0.5 mm plus radiation, and it grows as k_gap / g while the gap narrows; once closed, the air in the
  roughness (k_gap / minimum_gap) and h_c(p): more than ten times the first. Every body's energy balance closes.
- The peak canister temperature with the gap lies between perfect contact's (the closed gap's h_c is large but
  finite) and that of the gap kept open for heat (minimum_gap = 0.5 mm, no h_c); the open one is hotter by about
  the drop q / h across the air of a 0.5 mm gap. All three on the same mesh (overrides of the interface keys).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.heat.conductance import STEFAN_BOLTZMANN, effective_emissivity

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_canister_gap")]

YEAR = 365.25 * 86400.0
R, L, GAP, K_AIR, G_MIN = 0.525, 4.8, 5e-4, 0.028, 3e-5
AREA = 2 * math.pi * R * L + 2 * math.pi * R ** 2          # the canister's surface, m^2
COARSE = ["time.end=2 year", "blocks.canister.maxh=0.3", "blocks.buffer.maxh=0.3", "output.vtk=false",
          "output.figures=false"]
VARIANTS = {
    "gap": [],
    # the gap kept open for heat: the air conducts as across 0.5 mm whatever the mechanics, no contact conductance
    "open": [f"interfaces.canister_gap.minimum_gap={GAP}", "interfaces.canister_gap.conductance_coefficient=1e-30"],
    # perfect contact's limit: air of 1000 W/(m K), at least 2e6 W/(m^2 K) across the gap
    "perfect": ["interfaces.canister_gap.gap_conductivity=1000"],
}


@pytest.fixture(scope="module")
def runs():
    return {name: api.run("canister_gap", None, overrides=COARSE + extra, progress=False)
            for name, extra in VARIANTS.items()}


def closed_lengths(run) -> tuple[np.ndarray, np.ndarray]:
    """(times in years, closed length of the interface in m) of the mechanics solves."""
    hist = run.summary["mechanics"]["contact"]["history"]
    return (np.array([h["time_s"] for h in hist]) / YEAR,
            np.array([h["canister_gap"]["closed_length_m"] for h in hist]))


def test_the_scene_as_shipped_is_valid():
    assert "axisymmetric" in api.validate_scene("canister_gap")


def test_the_gap_is_open_at_the_start_and_closes(runs):
    run = runs["gap"]
    c = run.summary["mechanics"]["contact"]
    t, closed = closed_lengths(run)
    surface = 2 * R + L
    k = int(np.argmax(closed > 0.5 * surface))
    print(f"\ncanister_gap: closed length {closed[0]:.2f} m at the start (the floor, {R} m), "
          f"{closed[k]:.2f} of {surface} m at {t[k]:.3f} years, initial gaps "
          f"{c['interfaces']['canister_gap']['initial_gap_m']} m")
    assert c["interfaces"]["canister_gap"]["initial_gap_m"] == pytest.approx([1e-4, GAP], rel=1e-6)
    assert closed[0] <= R + 1e-9                                  # the floor only
    assert closed[-1] == pytest.approx(surface, rel=1e-9)          # closed all round
    assert 0.01 < t[k] < 0.2                                       # within weeks
    assert c["force_balance"]["imbalance_rel"] < 1e-8


def effective_conductance(run) -> tuple[np.ndarray, np.ndarray]:
    """(end time of each heat step in years, Q / (A (T_canister - T_buffer))), the surface means of the probes
    (integral means, weighted by r) and the step's flow across the interface, W/(m^2 K)."""
    s = run.summary
    series = s["probe_series"]
    t = np.array(series["times_s"]["canister_surface_mean"][1:]) / YEAR
    jump = np.array(series["canister_surface_mean"][1:]) - np.array(series["buffer_pocket_mean"][1:])
    return t, np.array(s["interface_heat_flow_W"]["canister_surface"]) / (AREA * jump)


def test_heat_crosses_the_open_gap_and_more_once_closed(runs):
    run = runs["gap"]
    t, h = effective_conductance(run)
    tc, closed = closed_lengths(run)
    # heat step k uses the state of mechanics solve k (the previous step's end; staggered)
    open_steps = closed[:len(h)] < 0.5 * (2 * R + L)
    h_open, h_closed = h[open_steps], h[~open_steps]
    h_rad = 4 * STEFAN_BOLTZMANN * effective_emissivity(0.1, 0.8) * (273.15 + 60.0) ** 3
    print(f"\ncanister_gap: effective conductance while open {h_open.min():.0f}-{h_open.max():.0f} W/(m^2 K) "
          f"(air across 0.5 mm: {K_AIR / GAP:.0f}, radiation {h_rad:.2f}), once closed {h_closed.min():.0f}-"
          f"{h_closed.max():.0f} W/(m^2 K) (air in the roughness alone: {K_AIR / G_MIN:.0f})")
    assert len(h_open) >= 3 and np.all(np.array(run.summary["interface_heat_flow_W"]["canister_surface"]) > 0)
    assert h_open[0] == pytest.approx(K_AIR / GAP + h_rad, rel=0.1)    # the first step: across about 0.5 mm
    assert np.all(np.diff(h_open) > 0)                                  # k_gap / g as the gap narrows
    assert h_closed.min() > K_AIR / G_MIN and h_closed.min() > 10 * h_open[0]


def test_every_body_balance_closes(runs):
    for name, run in runs.items():
        bal = run.summary["heat_balance"]
        print(f"\ncanister_gap ({name}): heat balance imbalance {bal['imbalance_rel']:.1e}, across the gap "
              f"{bal['interface_heat']['canister_gap']:.4e} J")
        assert bal["imbalance_rel"] <= 1e-8
        assert bal["bodies"]["canister"]["interface_heat_in"] == pytest.approx(
            -bal["bodies"]["buffer+granite"]["interface_heat_in"], rel=1e-12)


def test_the_peak_lies_between_perfect_contact_and_the_open_gap(runs):
    peak = {name: max(run.summary["probe_series"]["canister_max"]) for name, run in runs.items()}
    run = runs["open"]
    k = int(np.argmax(run.summary["probe_series"]["canister_max"]))
    q = run.summary["interface_heat_flow_W"]["canister_surface"][k - 1] / AREA      # W/m^2 at the peak
    h_rad = 4 * STEFAN_BOLTZMANN * effective_emissivity(0.1, 0.8) * (273.15 + 61.0) ** 3
    drop = q / (K_AIR / GAP + h_rad)
    print(f"\ncanister_gap peak canister temperature: perfect contact {peak['perfect']:.3f} C, the gap "
          f"{peak['gap']:.3f} C, kept open {peak['open']:.3f} C (q / h across the open gap {drop:.2f} K)")
    assert peak["perfect"] < peak["gap"] < peak["open"]
    assert peak["gap"] - peak["perfect"] < 0.2                     # closed weeks before the peak
    assert peak["open"] - peak["perfect"] == pytest.approx(drop, rel=0.2)
