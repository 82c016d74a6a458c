"""The built-in scene ``canister_gap`` (a canister whose thermal expansion closes its gap to the buffer) against the
same scene with the gap kept open for heat and with perfect contact, all three on the same mesh (overrides of the
interface's keys):

- ``open``: ``minimum_gap`` = the initial gap and no contact conductance: the air conducts as across the initial
  gap whatever the mechanics (radiation as in the scene);
- ``perfect``: ``gap_conductivity`` = 1000 W/(m K): at least 2e6 W/(m^2 K) across the gap, perfect contact's limit.

What the scene's data imply: the whole canister surface closes within the run (at the start only the floor, under
the canister's weight); while open the interface's effective conductance Q / (A (T_canister - T_buffer)) (the
surface means of the probes ``canister_surface_mean`` and ``buffer_pocket_mean``, integral means weighted by r)
is k_gap / g plus radiation, k_gap / g0 at the first step, growing as the gap narrows; once closed at least
k_gap / minimum_gap; the peak canister temperature lies between perfect contact's and the open gap's, the open one
above perfect contact by about q / (k_gap / g0 + h_rad) (q the flux across the surface at the peak). Every body's
energy balance closes.

Nothing here prints or writes files; :func:`canister_gap` returns a plain dict of floats.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..api import run
from ..heat.conductance import STEFAN_BOLTZMANN, effective_emissivity
from ..scene.parse import load_scene

YEAR = 365.25 * 86400.0
KELVIN = 273.15
COARSE = ["time.end=2 year", "blocks.canister.maxh=0.3", "blocks.buffer.maxh=0.3"]
"""The coarse level of the tests: two years (past the peak), a coarser canister and buffer."""
QUIET = ["output.vtk=false", "output.figures=false"]
ITF = "canister_gap"


def variants(gap: float) -> dict[str, list[str]]:
    """The overrides of the three runs (module docstring) for the initial gap ``gap`` (m)."""
    key = f"interfaces.{ITF}"
    return {"gap": [], "open": [f"{key}.minimum_gap={gap:.17g}", f"{key}.conductance_coefficient=1e-30"],
            "perfect": [f"{key}.gap_conductivity=1000"]}


def _effective_conductance(summary: dict, area: float) -> np.ndarray:
    """Q / (A (T_canister - T_buffer)) of every heat step (the flow of the step over the jump of the surface means
    at its end), W/(m^2 K)."""
    series = summary["probe_series"]
    jump = np.array(series["canister_surface_mean"][1:]) - np.array(series["buffer_pocket_mean"][1:])
    return np.array(summary["interface_heat_flow_W"]["canister_surface"]) / (area * jump)


def _cycle(summary: dict, surface: float) -> dict:
    """The closing (first mechanics solve with more than half the surface closed) and reopening (first one after
    it with less) times, years (None where it does not happen), and the closed lengths."""
    hist = summary["mechanics"]["contact"]["history"]
    t = np.array([h["time_s"] for h in hist]) / YEAR
    closed = np.array([h[ITF]["closed_length_m"] for h in hist])
    shut = closed > 0.5 * surface
    k = int(np.argmax(shut)) if shut.any() else None
    back = None if k is None or shut[k:].all() else k + int(np.argmin(shut[k:]))
    return {"closing_time_y": None if k is None else float(t[k]),
            "reopening_time_y": None if back is None else float(t[back]),
            "initial_closed_m": float(closed[0]), "final_closed_m": float(closed[-1]), "closed": shut}


def canister_gap(*, overrides: list[str] | None = None) -> dict:
    """Run the three variants of ``canister_gap`` with ``overrides`` (default :data:`COARSE`; [] the scene as
    shipped) and return {"peak_gap_C", "peak_open_C", "peak_perfect_C" (the largest canister_max probe), "peak_time_y",
    "open_drop_K" (q / (k_gap / g0 + h_rad) at the open run's peak), "closing_time_y", "reopening_time_y",
    "initial_closed_m" (closed length at the start: the floor), "final_closed_m", "surface_m" (the canister's
    outline, m), "initial_gap_m" (the largest), "h_first_step", "h_open_max", "h_closed_min" (effective
    conductances of the gap run, W/(m^2 K), over the heat steps with at most / more than half the surface closed),
    "h_open_increasing" (over the steps before the closing), "h_expected_first" (k_gap / g0 + h_rad),
    "h_closed_floor" (k_gap / minimum_gap), "open_steps" (heat steps with at most half closed), "max_pressure_Pa",
    "energy_imbalance_rel" (the largest of the three runs'), "force_imbalance_rel", "dofs", "steps", "wall_s" (the
    gap run)}."""
    over = (COARSE if overrides is None else list(overrides)) + QUIET
    sc = load_scene(ITF, over)
    itf = next(i for i in sc.interfaces if i.name == ITF)
    canister = next(b for b in sc.blocks if b.name == "canister")
    R, L = canister.size
    area, surface = 2 * math.pi * R * L + 2 * math.pi * R ** 2, 2 * R + L
    tic = time.perf_counter()
    runs = {"gap": run(sc, None, progress=False)}
    wall = time.perf_counter() - tic
    c = runs["gap"].summary["mechanics"]["contact"]
    g0 = max(c["interfaces"][ITF]["initial_gap_m"])
    for name, extra in list(variants(g0).items())[1:]:
        runs[name] = run(ITF, None, overrides=over + extra, progress=False)
    peaks = {n: np.array(r.summary["probe_series"]["canister_max"]) for n, r in runs.items()}
    cyc = _cycle(runs["gap"].summary, surface)
    h = _effective_conductance(runs["gap"].summary, area)
    shut = cyc.pop("closed")[:len(h)]         # heat step k uses mechanics solve k (staggered: the previous end)
    offset = KELVIN if sc.scene.temperature_unit == "C" else 0.0
    eps = effective_emissivity(*itf.emissivities)

    def h_air(T: float) -> float:                  # air across g0 and radiation (linearized at T), W/(m^2 K)
        return itf.gap_conductivity / g0 + 4 * STEFAN_BOLTZMANN * eps * (T + offset) ** 3
    k_open = int(np.argmax(peaks["open"]))
    q = runs["open"].summary["interface_heat_flow_W"]["canister_surface"][k_open - 1] / area
    series = runs["gap"].summary["probe_series"]
    return {**{f"peak_{n}_C": float(v.max()) for n, v in peaks.items()},
            "peak_time_y": float(series["times_s"]["canister_max"][int(np.argmax(peaks["gap"]))] / YEAR),
            "open_drop_K": float(q / h_air(peaks["open"][k_open])),
            **cyc, "surface_m": surface, "initial_gap_m": g0, "h_first_step": float(h[0]),
            "h_open_max": float(h[~shut].max()), "h_closed_min": float(h[shut].min()),
            "h_expected_first": h_air(series["canister_surface_mean"][1]),
            "h_closed_floor": itf.gap_conductivity / itf.minimum_gap, "open_steps": int((~shut).sum()),
            "h_open_increasing": bool(np.all(np.diff(h[:int(np.argmax(shut))]) > 0)) if shut.any() else None,
            "max_pressure_Pa": float(max(e[ITF]["max_pressure_Pa"] for e in c["history"])),
            "energy_imbalance_rel": max(r.summary["heat_balance"]["imbalance_rel"] for r in runs.values()),
            "force_imbalance_rel": float(c["force_balance"]["imbalance_rel"]),
            "dofs": int(runs["gap"].summary["mesh"]["dofs"]), "steps": int(runs["gap"].summary["steps"]),
            "wall_s": wall}
