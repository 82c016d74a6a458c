"""A decaying point heat source in an infinite medium (../shared/notes/verification.md, section 5).

Closed form. A point source of power P(t) = q0 exp(-l t) (W), switched on at t = 0 in an infinite
homogeneous medium at T = 0, with conductivity k (W/(m K)) and diffusivity kappa = k / (rho c) (m^2/s),
gives the temperature rise (K) at distance r (m) and time t (s)

    T(r, t) = q0 e^{-l t} / (4 pi k r) Re[ e^{-i r sqrt(l/kappa)} erfc( r / (2 sqrt(kappa t)) - i sqrt(l t) ) ],

with the limit l -> 0: T = q0 / (4 pi k r) erfc(r / (2 sqrt(kappa t))). With a = r / (2 sqrt(kappa t)),
b = sqrt(l t) and erfc(z) = exp(-z^2) w(i z) (w the Faddeeva function, scipy.special.wofz), the factors
e^{-l t} = e^{-b^2} and e^{-i r sqrt(l/kappa)} = e^{-2 i a b} cancel the growing parts of exp(-z^2), and

    T(r, t) = q0 / (4 pi k r) Re[ exp(-a^2) w(b + i a) ],

which is evaluated without overflow for every t (|w| <= 1 in the upper half plane). It reproduces the
Duhamel integral int_0^t q0 e^{-l s} exp(-r^2 / (4 kappa (t - s))) / (rho c (4 pi kappa (t - s))^{3/2}) ds to
~1e-15 and the reference values of verification.md with the Julian year (365.25 d,
:data:`ngs_geomech.scene.units.YEAR`):
T(0.5 m, 1 y) = 84.67355, T(2 m, 10 y) = 17.64760, T(10 m, 100 y) = 0.70464 K for q0 = 1700 W, 1/l = 50 y,
k = 3 W/(m K), rho c = 2.2e6 J/(m^3 K) (quoted 84.674, 17.648, 0.705). With 365-day years the first value
would be 84.6723 K, which does not round to the quoted 84.674: the references use the Julian year.

Numerical check (:func:`point_source_errors`). The same problem through the package's normal path (scene
dict -> scene_from_dict -> run_scene), axisymmetric (r = x >= 0, z = y): the source is a ball of radius
``SOURCE_RADIUS`` (in the r-z half plane a half disc, a ``profile`` block with a spline arc) releasing
q0 e^{-l t} in total (``power`` and ``decay``), inside a refined ``near`` block, inside a rectangle
[0, R] x [-R, R] with T = 0 on its outer sides (the axis is insulated, i.e. symmetric), initial T = 0,
Crank-Nicolson with geometrically growing steps, P2 elements. Probes on the plane z = 0 at ``RADII`` are
compared with the closed form at the step times nearest to ``TIMES_YEARS``, evaluated at those exact
step times (no interpolation in time). Two modelling errors are quantified and returned next to the
discretisation error, both far below it:

- source size: the exact field of a uniform ball source is the ball mean of the point field,
  T_ball = T + a^2/10 lap T + ... = T + a^2/(10 kappa) dT/dt + ... outside the ball
  (:func:`ball_source_temperature`); for a = 0.25 m the relative difference is ~1e-4 at the compared points;
- far boundary: the difference between the infinite-medium field and the one with T = 0 on the outer
  sides solves the source-free heat equation with zero initial data and boundary data equal to the
  infinite-medium field there, so by the maximum principle it is bounded by max_{s <= t} T(R, s)
  (R the distance of the nearest outer side from the source); R = 300 m gives < 1e-6 K.
"""

from __future__ import annotations

import math
import time as _time

import numpy as np
from scipy.special import erfc, wofz

from ..run import run_scene
from ..scene.parse import scene_from_dict
from ..scene.units import YEAR

Q0 = 1700.0
"""Initial source power, W (a KBS-3 type canister, verification.md section 5)."""
DECAY_TIME = 50.0 * YEAR
"""Decay time 1/l of the source power, s."""
CONDUCTIVITY = 3.0
"""Rock conductivity k, W/(m K)."""
RHO_C = 2.2e6
"""Rock volumetric heat capacity rho c, J/(m^3 K)."""
SOURCE_RADIUS = 0.25
"""Radius of the ball that stands for the point source in the numerical model, m."""
DOMAIN_HALF_WIDTH = 300.0
"""R: the model is the rectangle [0, R] x [-R, R] (r, z) with T = 0 on r = R and z = +-R, m."""
NEAR_HALF_WIDTH = 15.0
"""The refined block around the source and the probes: [0, 15] x [-15, 15] m."""
RADII = (2.0, 5.0, 10.0)
"""Distances from the source of the compared points (on z = 0), m."""
TIMES_YEARS = (1.0, 10.0, 50.0)
"""Compared times, years (the nearest step times are used)."""
REFERENCE_VALUES = ((0.5, 1.0, 84.674), (2.0, 10.0, 17.648), (10.0, 100.0, 0.705))
"""(r in m, t in years, T in K) of verification.md section 5, for the parameters above."""


def decaying_point_source_temperature(r, t, q0: float, decay_rate: float, k: float, kappa: float):
    """Temperature rise T(r, t) in K of a point source of power q0 exp(-decay_rate t) switched on at t = 0.

    ``r`` distance from the source in m (> 0), ``t`` time in s (T = 0 for t <= 0), ``q0`` initial power in W,
    ``decay_rate`` l in 1/s (>= 0; 0 gives a constant source), ``k`` conductivity in W/(m K), ``kappa``
    diffusivity k / (rho c) in m^2/s. ``r`` and ``t`` broadcast; a float is returned for scalar input.
    See the module docstring for the formula and its overflow-free form.
    """
    if decay_rate < 0:
        raise ValueError(f"decay_rate must be >= 0, got {decay_rate}")
    r_arr, t_arr = np.broadcast_arrays(np.asarray(r, dtype=float), np.asarray(t, dtype=float))
    if np.any(r_arr <= 0):
        raise ValueError("r must be positive")
    out = np.zeros(r_arr.shape)
    on = t_arr > 0
    rr, tt = r_arr[on], t_arr[on]
    a = rr / (2.0 * np.sqrt(kappa * tt))
    if decay_rate == 0:
        shape = erfc(a)
    else:
        b = np.sqrt(decay_rate * tt)
        shape = (np.exp(-a * a) * wofz(b + 1j * a)).real
    out[on] = q0 / (4.0 * math.pi * k * rr) * shape
    return float(out) if out.ndim == 0 else out


def canister_array_peak_rise(power: float, decay, hole_spacing: float, tunnel_spacing: float, half_length: float,
                             tunnels: int, radius: float, k: float, kappa: float, years: float = 1000.0) -> float:
    """Largest temperature rise (K) at a canister wall over ``years``: the decaying point sources (verification.md
    section 5) of a panel of canisters ``hole_spacing`` x ``tunnel_spacing`` apart (m; +-``half_length`` along the
    tunnels, +-``tunnels`` tunnels) summed at the wall (``radius``, m) of the middle one; ``decay`` the terms
    (fraction, time constant in s) of the power ``power`` (W); conductivity k (W/(m K)), diffusivity kappa (m^2/s);
    no buffer. An upper bound of a repository's canister-wall temperature rise (the buffer aside)."""
    xs = np.arange(-round(half_length / hole_spacing), round(half_length / hole_spacing) + 1)
    zs = np.arange(-tunnels, tunnels + 1)
    X, Z = np.meshgrid(xs * hole_spacing, zs * tunnel_spacing)
    r = np.hypot(X, Z).ravel()
    r[r == 0.0] = radius
    times = np.geomspace(0.5, years, 60) * YEAR
    return max(sum(float(np.sum(decaying_point_source_temperature(r, t, power * a, 1.0 / tau, k, kappa)))
                   for a, tau in decay) for t in times)


def ball_source_temperature(r, t, radius: float, q0: float, decay_rate: float, k: float, kappa: float,
                            n: int = 24):
    """Temperature rise in K at distance ``r`` (m, > ``radius``) from the centre of a ball of radius ``radius``
    (m) releasing q0 exp(-decay_rate t) W uniformly: the ball mean of the point-source field,

        T_ball(r, t) = 3 / (2 r a^3) int_0^a s int_{r-s}^{r+s} rho T(rho, t) drho ds,

    by n x n point Gauss-Legendre quadrature (the integrand is smooth for r > a). Other arguments as in
    :func:`decaying_point_source_temperature`; ``r`` and ``t`` are scalars.
    """
    if not r > radius:
        raise ValueError(f"r = {r} must lie outside the ball (radius {radius})")
    x, w = np.polynomial.legendre.leggauss(n)
    s = 0.5 * radius * (x + 1.0)
    ws = 0.5 * radius * w
    total = 0.0
    for si, wi in zip(s, ws):
        rho = r + si * x
        inner = si * np.sum(w * rho * decaying_point_source_temperature(rho, t, q0, decay_rate, k, kappa))
        total += wi * si * inner
    return 3.0 / (2.0 * r * radius**3) * total


def level_parameters(level: int) -> dict:
    """Mesh and time-step parameters of a refinement level (every length and step halves per level).

    Returns ``h_source``, ``h_near`` (block maxh, m), ``h_far`` (global maxh, m), ``order`` (P2),
    ``dt0`` (first step, s), ``growth`` (step growth factor, 1 + 0.2 / 2^level) and ``dt_max`` (largest step, s).
    """
    if level < 0:
        raise ValueError(f"level must be >= 0, got {level}")
    f = 2.0**-level
    return {"h_source": 0.1 * f, "h_near": 1.0 * f, "h_far": DOMAIN_HALF_WIDTH / 6.0 * f, "order": 2, "dt0": 3600.0 * f,
            "growth": 1.0 + 0.2 * f, "dt_max": 0.5 * YEAR * f}


def point_source_scene(level: int = 0) -> dict:
    """The scene dict (same keys as a scene TOML file) of the numerical point-source model at ``level``."""
    p = level_parameters(level)
    a, R, H = SOURCE_RADIUS, DOMAIN_HALF_WIDTH, NEAR_HALF_WIDTH
    n_arc = 8
    arc = [[a * math.sin(math.pi * i / n_arc), -a * math.cos(math.pi * i / n_arc)] for i in range(1, n_arc)]
    arc.append([0.0, a])
    rock = {"conductivity": CONDUCTIVITY, "rho_c": RHO_C}
    t_end = max(TIMES_YEARS) * YEAR
    return {
        "scene": {"name": "point_source", "dimension": "axisymmetric",
                  "description": "decaying point heat source in an infinite medium (verification.md section 5)"},
        "physics": {"thermal": "transient"},
        "mesh": {"maxh": p["h_far"], "order": p["order"], "grading": 0.3},
        "blocks": [
            {"name": "rock", "shape": "rectangle", "origin": [0.0, -R], "size": [R, 2.0 * R],
             "boundaries": {"far": ["xmax", "ymin", "ymax"]}},
            {"name": "near", "shape": "rectangle", "origin": [0.0, -H], "size": [H, 2.0 * H],
             "maxh": p["h_near"]},
            {"name": "source", "shape": "profile", "start": [0.0, -a],
             "segments": [{"spline": arc, "name": "source_surface"}, {"line": [0.0, -a], "name": "source_axis"}],
             "maxh": p["h_source"]},
        ],
        "interfaces": [{"name": "near_edge", "blocks": ["rock", "near"]},
                       {"name": "source_surface", "blocks": ["near", "source"]}],
        "materials": {"rock": rock, "near": rock, "source": rock},
        "boundary_conditions": {"far": {"temperature": 0.0}},
        "sources": [{"region": "source", "power": Q0, "decay": [[1.0, DECAY_TIME]]}],
        "initial": {"temperature": 0.0},
        "time": {"end": t_end, "dt": p["dt0"], "dt_growth": p["growth"], "dt_max": p["dt_max"],
                 "scheme": "crank_nicolson"},
        "output": {"vtk": False, "figures": False,
                   "probes": [{"name": f"r_{r:g}m", "point": [r, 0.0]} for r in RADII]},
    }


def point_source_errors(level: int = 0) -> dict:
    """Run the numerical point-source model at ``level`` and compare it with the closed form.

    Returns ``max_rel_error`` (max |numeric / exact - 1| over the compared points), ``errors`` (one dict per
    radius and time: ``r`` in m, ``t_years`` the step time used, ``target_years``, ``numeric`` and ``exact``
    in K, ``rel_error``, and ``exact_ball``, ``rel_error_ball`` against the uniform ball source the model
    actually contains), ``max_rel_error_ball`` (the discretisation error alone), ``dofs``, ``steps``,
    ``wall_s`` (s, the whole run including meshing),
    ``source_size_effect`` (max relative difference between the uniform ball source and the point source at
    the compared points) and ``far_boundary_bound`` (max over the compared points of the maximum-principle
    bound max_{s <= t} T(R, s) / T(r, t) of the error due to the finite domain).
    """
    scene = scene_from_dict(point_source_scene(level), source=f"point source level {level}")
    tic = _time.perf_counter()
    result = run_scene(scene, None, progress=False)
    wall = _time.perf_counter() - tic
    series = result.summary["probe_series"]
    times = np.asarray(series["time_s"])
    kappa = CONDUCTIVITY / RHO_C
    lam = 1.0 / DECAY_TIME

    def exact(r, t):
        return decaying_point_source_temperature(r, t, Q0, lam, CONDUCTIVITY, kappa)

    errors, size_effect, boundary = [], 0.0, 0.0
    for target in TIMES_YEARS:
        i = int(np.argmin(np.abs(times - target * YEAR)))
        t = float(times[i])
        far = float(np.max(exact(DOMAIN_HALF_WIDTH, np.linspace(0.0, t, 201))))
        for r in RADII:
            num = float(series[f"r_{r:g}m"][i])
            ex = exact(r, t)
            ball = ball_source_temperature(r, t, SOURCE_RADIUS, Q0, lam, CONDUCTIVITY, kappa)
            size_effect = max(size_effect, abs(ball / ex - 1.0))
            boundary = max(boundary, far / ex)
            errors.append({"r": r, "t_years": t / YEAR, "target_years": target, "numeric": num, "exact": ex,
                           "rel_error": num / ex - 1.0, "exact_ball": ball, "rel_error_ball": num / ball - 1.0})
    return {"level": level, "max_rel_error": max(abs(e["rel_error"]) for e in errors),
            "max_rel_error_ball": max(abs(e["rel_error_ball"]) for e in errors), "errors": errors,
            "dofs": int(result.summary["mesh"]["dofs"]), "steps": int(result.summary["steps"]),
            "wall_s": wall, "source_size_effect": size_effect, "far_boundary_bound": boundary}


def error_table(res: dict) -> str:
    """The errors of :func:`point_source_errors` as a plain-text table."""
    lines = [f"level {res['level']}: {res['dofs']} dofs, {res['steps']} steps, {res['wall_s']:.1f} s; "
             f"source size effect {res['source_size_effect']:.1e}, far boundary bound "
             f"{res['far_boundary_bound']:.1e}",
             f"{'r (m)':>6} {'t (y)':>8} {'numeric (K)':>12} {'exact (K)':>10} {'rel. error':>11} "
             f"{'vs ball':>10}"]
    for e in res["errors"]:
        lines.append(f"{e['r']:6.1f} {e['t_years']:8.3f} {e['numeric']:12.5f} {e['exact']:10.5f} "
                     f"{e['rel_error']:+11.2e} {e['rel_error_ball']:+10.2e}")
    lines.append(f"max relative error {res['max_rel_error']:.2e} (against the ball source "
                 f"{res['max_rel_error_ball']:.2e})")
    return "\n".join(lines)
