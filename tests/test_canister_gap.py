"""The built-in scene ``canister_gap`` (the canister of ``canister`` with a 0.5 mm gap to its buffer that its
thermal expansion closes; static thermo-elastic contact coupled with the heat, contact conductance across the gap),
coarse (two years, a coarser canister and buffer), with the same scene with the gap kept open for heat and with
perfect contact (:func:`ngs_geomech.verification.canister_gap.canister_gap`), checked against what its data imply.

- The gap: at the start only the floor (the canister's weight) is closed; the expansion closes the whole canister
  surface within weeks.
- Heat across it: while open, the air in the gap and radiation: the effective conductance of the first step is
  k_gap / 0.5 mm plus radiation, and it grows as k_gap / g while the gap narrows; once closed, the air in the
  roughness (k_gap / minimum_gap) and h_c(p): more than ten times the first. Every body's energy balance closes.
- The peak canister temperature with the gap lies between perfect contact's (the closed gap's h_c is large but
  finite; the gap closes months before the peak) and that of the gap kept open for heat, which is above perfect
  contact's by about the drop q / h across the air of a 0.5 mm gap.
"""

from __future__ import annotations

import pytest

from ngs_geomech import api
from ngs_geomech.verification.canister_gap import canister_gap

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_canister_gap")]

R, L, GAP = 0.525, 4.8, 5e-4


@pytest.fixture(scope="module")
def figures():
    return canister_gap()


def test_the_scene_as_shipped_is_valid():
    assert "axisymmetric" in api.validate_scene("canister_gap")


def test_the_gap_is_open_at_the_start_and_closes(figures):
    f = figures
    print(f"\ncanister_gap: closed length {f['initial_closed_m']:.2f} m at the start (the floor, {R} m), more than "
          f"half of the {f['surface_m']} m at {f['closing_time_y']:.3f} years, {f['final_closed_m']:.2f} m at the "
          f"end; largest initial gap {f['initial_gap_m']:.2e} m; {f['dofs']} dofs, {f['steps']} steps, "
          f"{f['wall_s']:.1f} s")
    assert f["initial_gap_m"] == pytest.approx(GAP, rel=1e-6)
    assert f["initial_closed_m"] <= R + 1e-9                      # the floor only
    assert f["final_closed_m"] == pytest.approx(2 * R + L, rel=1e-9)   # closed all round
    assert 0.01 < f["closing_time_y"] < 0.2                       # within weeks
    assert f["max_pressure_Pa"] > 0 and f["force_imbalance_rel"] < 1e-8


def test_heat_crosses_the_open_gap_and_more_once_closed(figures):
    f = figures
    print(f"\ncanister_gap: effective conductance while open {f['h_first_step']:.1f} (air across the initial gap "
          f"and radiation: {f['h_expected_first']:.1f}) to {f['h_open_max']:.0f} W/(m^2 K) over "
          f"{f['open_steps']} steps; once closed at least {f['h_closed_min']:.0f} W/(m^2 K) (the air in the "
          f"roughness alone: {f['h_closed_floor']:.0f})")
    assert f["open_steps"] >= 3 and f["h_open_increasing"]
    assert f["h_first_step"] == pytest.approx(f["h_expected_first"], rel=0.1)
    assert f["h_closed_min"] > f["h_closed_floor"] and f["h_closed_min"] > 10 * f["h_first_step"]


def test_every_body_balance_closes(figures):
    print(f"\ncanister_gap: largest energy imbalance of the three runs {figures['energy_imbalance_rel']:.1e}")
    assert figures["energy_imbalance_rel"] <= 1e-8


def test_the_peak_lies_between_perfect_contact_and_the_open_gap(figures):
    f = figures
    print(f"\ncanister_gap peak canister temperature at {f['peak_time_y']:.2f} years: perfect contact "
          f"{f['peak_perfect_C']:.3f} C, the gap {f['peak_gap_C']:.3f} C, kept open {f['peak_open_C']:.3f} C "
          f"(q / h across the open gap {f['open_drop_K']:.2f} K)")
    assert f["peak_perfect_C"] < f["peak_gap_C"] < f["peak_open_C"]
    assert f["closing_time_y"] < f["peak_time_y"]
    assert f["peak_gap_C"] - f["peak_perfect_C"] < 0.2
    assert f["peak_open_C"] - f["peak_perfect_C"] == pytest.approx(f["open_drop_K"], rel=0.2)
