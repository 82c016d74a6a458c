"""Verification of the Stefan problem with conductivities that vary in x, y, z (:mod:`ngs_geomech.stefan.forms`,
``variation`` G(x) of :mod:`ngs_geomech.stefan.materials`; seed (2.46)-(2.51), (2.55)), each run as a scene
(validation, the scene keys, the run and its summary) against a closed form or a converged 1D reference.

1. :func:`steady_varying_conductivity` (closed form). A strip 0 < x < 1 of two regions: a phase-change material
   0 < x < x_m with k_s(x) = k_a (1 + x) (its liquid's c k_s(x)), kept solid (its Theta_R above every temperature
   reached), and a plain material x_m < x < 1 with k(x) = k_b (2 + x^2); T = T_a at x = 0 and T_b at x = 1, insulated
   sides. Backward Euler steps up to many diffusion times give the steady temperature of
   d/dx (k(x) dT/dx) = 0,

       T(x) = T_a + (T_b - T_a) R(x) / R(1),    R(x) = int_0^x ds / k(s),                                       (1)

   with R = ln(1 + x) / k_a in the first region and R(x_m) + (atan(x / sqrt 2) - atan(x_m / sqrt 2)) /
   (sqrt 2 k_b) in the second. The nodal error is measured at three mesh sizes: the P1 stiffness takes G at the
   element's centroid (not the harmonic mean that makes 1D P1 nodally exact), so it falls at second order.
2. :func:`varying_front` (a converged 1D reference). A slab 0 < x < length of a two-phase material with
   k_s(x) = k_s g(x), k_l(x) = k_l g(x), g = 1 + slope x / length, at T_S, melted from x = 0 held at T_hot > Theta_R,
   x = length insulated; the 1D reference (:func:`ngs_geomech.verification.stefan_extended.enthalpy_1d` with the
   factor g, uniform elements h = 1/100 ... 1/1600, steps dt = 0.4 h) against the scene's strip at three mesh sizes,
   the front read from the melted volume.

Each function returns a plain dict with the levels' errors, observed orders (polyfit of log error on log h), the
runs' relative energy imbalance (the summary's ``energy.imbalance_rel_max``) and wall times. Nothing here prints
or writes files.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..api import run
from ..scene.parse import scene_from_dict
from .stefan_extended import ROBIN_SLAB, Phases, enthalpy_1d, fitted_order, run_levels, slab_reference
from .study import one_ngsolve_thread


# -- 1. the steady strip -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteadyStrip:
    """The strip of :func:`steady_varying_conductivity`: ``k_a`` (W/(m K)) of k_s = k_a (1 + x) in 0 < x < ``x_m``
    (a phase-change material at ``melt`` K, liquid ratio ``ratio``), ``k_b`` of k = k_b (2 + x^2) in x_m < x < 1,
    wall temperatures ``t_a``, ``t_b`` (K), height (m)."""

    k_a: float = 1.5
    k_b: float = 0.8
    x_m: float = 0.5
    ratio: float = 0.7
    melt: float = 10.0
    t_a: float = 0.0
    t_b: float = 1.0
    height: float = 0.2

    def resistance(self, x) -> np.ndarray:
        """R(x) = int_0^x ds / k(s) of (1), m^2 K/W."""
        x = np.asarray(x, dtype=float)
        first = np.log1p(np.minimum(x, self.x_m)) / self.k_a
        s2 = math.sqrt(2.0)
        second = (np.arctan(np.maximum(x, self.x_m) / s2) - math.atan(self.x_m / s2)) / (s2 * self.k_b)
        return first + second

    def temperature(self, x) -> np.ndarray:
        """The steady temperature (1), K."""
        return self.t_a + (self.t_b - self.t_a) * self.resistance(x) / float(self.resistance(1.0))


def steady_scene(p: SteadyStrip, h: float) -> dict:
    """The strip as a plane scene dict, mesh size h (m), steps from 0.05 s growing to 10 s up to 50 s (the
    diffusion time is about 1 s: the transient has died out to round-off)."""
    pcm = {"conductivity": f"{p.k_a!r}*(1 + x)", "conductivity_liquid": f"{p.ratio * p.k_a!r}*(1 + x)",
           "rho_c": 2.0, "rho_c_liquid": 1.0, "phase_change_temperature": p.melt, "latent_heat_volumetric": 1.0}
    return {"scene": {"name": "steady_varying", "dimension": "plane"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": h},
            "blocks": [{"name": "pcm", "shape": "rectangle", "origin": [0.0, 0.0], "size": [p.x_m, p.height],
                        "boundaries": {"hot": "xmin"}},
                       {"name": "rock", "shape": "rectangle", "origin": [p.x_m, 0.0],
                        "size": [1.0 - p.x_m, p.height], "boundaries": {"cold": "xmax"}}],
            "interfaces": [{"name": "contact", "blocks": ["pcm", "rock"], "type": "glued"}],
            "materials": {"pcm": pcm, "rock": {"conductivity": f"{p.k_b!r}*(2 + x*x)", "rho_c": 1.0}},
            "boundary_conditions": {"hot": {"temperature": p.t_a}, "cold": {"temperature": p.t_b}},
            "initial": {"temperature": 0.5 * (p.t_a + p.t_b)},
            "time": {"end": 50.0, "dt": 0.05, "dt_growth": 1.5, "dt_max": 10.0},
            "output": {"every": 10 ** 6}}


def steady_varying_conductivity(problem: SteadyStrip | None = None, hs=(0.1, 0.05, 0.025)) -> dict:
    """The steady strip (module docstring, 1) at the mesh sizes ``hs`` (m). Returns per level ``max_error`` (max
    over the vertices of |T - T_exact| / |T_b - T_a|), ``energy_imbalance_rel``, ``ndofs``, ``wall_s``; the
    ``order`` and the figures ``stefan_varying_steady_error`` (the finest level's max_error) and
    ``energy_imbalance_rel`` (the largest)."""
    p = problem or SteadyStrip()
    levels = []
    with one_ngsolve_thread():
        for h in hs:
            tic = time.perf_counter()
            res = run(scene_from_dict(steady_scene(p, h)), None, progress=False)
            f = res.stefan.forms
            x = np.array([v.point[0] for v in res.mesh.vertices])
            T = f.gf_temperature.vec.FV().NumPy()
            st = res.summary["stefan"]
            levels.append({"h": h, "max_error": float(np.max(np.abs(T - p.temperature(x)))) / abs(p.t_b - p.t_a),
                           "energy_imbalance_rel": st["energy"]["imbalance_rel_max"], "ndofs": f.n,
                           "melted": st["melted_volume"]["pcm"][-1], "wall_s": time.perf_counter() - tic})
    errors = [lv["max_error"] for lv in levels]
    return {"levels": levels, "h": list(hs), "max_error": errors, "order": fitted_order(hs, errors),
            "stefan_varying_steady_error": errors[-1],
            "energy_imbalance_rel": max(lv["energy_imbalance_rel"] for lv in levels)}


# -- 2. the transient front -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class VaryingSlab:
    """The slab of :func:`varying_front`: ``material`` (k_s, k_l the values at x = 0), g(x) = 1 + ``slope`` x /
    ``length``, initial temperature ``t_solid`` (K), ``t_hot`` (K) at x = 0, ``length`` (m; insulated at x = length),
    end time ``t1`` (s)."""

    material: Phases = ROBIN_SLAB
    slope: float = 2.0
    t_solid: float = -0.5
    t_hot: float = 2.0
    length: float = 1.0
    t1: float = 0.5

    def factor(self, x):
        return 1.0 + self.slope * np.asarray(x, dtype=float) / self.length

    def expression(self, k: float) -> str:
        return f"{k!r}*(1 + {self.slope / self.length!r}*x)"


def varying_reference(p: VaryingSlab, hs=(1 / 100, 1 / 200, 1 / 400, 1 / 800, 1 / 1600),
                      dt_over_h: float = 0.4) -> dict:
    """The slab in 1D (uniform elements of size h, steps dt = dt_over_h h): ``front`` per level (the melted
    volume, m), the successive ``differences`` with their ``order``, ``front_reference`` (the finest level's),
    ``front_uncertainty_rel`` (the largest difference of the two next finer levels from it, relative),
    ``imbalance_rel_max``, ``wall_s``."""
    return slab_reference(p.length, p.material, p.t_solid, p.t1, hs, dt_over_h, ("dirichlet", p.t_hot),
                          factor=p.factor)


def varying_scene(p: VaryingSlab, height: float, h: float, dt: float) -> dict:
    """The slab as a plane scene dict: the strip 'pcm' 0 < x < length, 0 < y < height, T_hot on 'wall' (x = 0),
    insulated elsewhere, the conductivities as expressions of x, mesh size h (m), steps dt (s)."""
    m = p.material
    pcm = {"conductivity": p.expression(m.k_solid), "conductivity_liquid": p.expression(m.k_liquid),
           "rho_c": m.c_solid, "rho_c_liquid": m.c_liquid, "phase_change_temperature": m.melt,
           "latent_heat_volumetric": m.latent}
    return {"scene": {"name": "varying_front", "dimension": "plane"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": h},
            "blocks": [{"name": "pcm", "shape": "rectangle", "origin": [0.0, 0.0], "size": [p.length, height],
                        "boundaries": {"wall": "xmin"}}],
            "materials": {"pcm": pcm},
            "boundary_conditions": {"wall": {"temperature": p.t_hot}},
            "initial": {"temperature": p.t_solid},
            "time": {"end": p.t1, "dt": dt},
            "output": {"every": 10 ** 6}}


def varying_front(problem: VaryingSlab | None = None, hs=(0.05, 0.025, 0.0125), height: float = 0.1,
                  dt_over_h: float = 0.4) -> dict:
    """The slab (module docstring, 2): the 1D reference (:func:`varying_reference`), then the scene
    (:func:`varying_scene`) at the mesh sizes ``hs`` (m) with dt = dt_over_h h, the front from the melted volume /
    height. Returns ``reference``, ``front_constant`` (the 1D front with g = 1, to show what the variation moves),
    per level ``front``, ``front_rel_error``, ``energy_imbalance_rel``, ``ndofs``, ``steps``, ``newton_mean``,
    ``wall_s``; the ``order`` and the figures ``stefan_varying_front_rel_error`` (the finest level's) and
    ``energy_imbalance_rel`` (the largest)."""
    from ..fem.timesteps import schedule

    p = problem or VaryingSlab()
    ref = varying_reference(p)
    constant = enthalpy_1d(np.linspace(0.0, p.length, 801), 0, p.material, p.t_solid,
                           list(schedule(0.0, p.t1, 0.4 / 800)), ("dirichlet", p.t_hot), ("insulated",))["melted"]
    levels = run_levels(lambda h: varying_scene(p, height, h, dt_over_h * h), hs,
                         lambda st: st["melted_volume"]["pcm"][-1] / height)
    for lv in levels:
        lv["front_rel_error"] = abs(lv["front"] / ref["front_reference"] - 1.0)
    errors = [lv["front_rel_error"] for lv in levels]
    return {"reference": ref, "front_constant": constant, "levels": levels, "h": list(hs),
            "front_rel_error": errors, "order": fitted_order(hs, errors), "stefan_varying_front_rel_error": errors[-1],
            "energy_imbalance_rel": max(lv["energy_imbalance_rel"] for lv in levels)}
