"""Verification of the Stefan problem's axisymmetric form, heat transfer (Robin) conditions and anisotropic
conductivity per phase (:mod:`ngs_geomech.stefan.forms`; seed (2.46)-(2.51), (2.55)), each run as a scene
(validation, the scene keys, the run and its summary) against a closed form or a converged 1D reference.

1. :func:`line_sink_freezing` (Carslaw & Jaeger 11.2, "Paterson's solution"; ../shared/notes/verification.md
   section 8). A line sink extracting Q' (W per metre) from t = 0 out of a liquid at T_i > T_f freezes a cylinder
   of radius R(t) = 2 lam sqrt(a_s t), lam the root of

       (Q'/(4 pi)) exp(-lam^2) + k_l (T_i - T_f) exp(-lam^2 a_s/a_l) / Ei(-lam^2 a_s/a_l) = lam^2 a_s L   (1)

   (L volumetric, J/m^3; Ei(-x) < 0 the exponential integral, scipy.special.expi). Solid (r < R):
   T = T_f + Q'/(4 pi k_s) (Ei(-r^2/(4 a_s t)) - Ei(-lam^2)); liquid: T = T_i - (T_i - T_f) Ei(-r^2/(4 a_l t)) /
   Ei(-lam^2 a_s/a_l). The model: an axisymmetric slab r0 < r < r_out, 0 < z < H (insulated top and bottom: the
   solution does not depend on z), the flux -Q'/(2 pi r0) into the body on r = r0 (the sink; r0 << R, the volume
   r < r0 missing from the frozen body is (r0/R)^2 of it), T = T_i on r = r_out (far enough that the closed form
   differs from T_i there by < 1e-7 (T_i - T_f)), T_i initially. The front is read from the frozen volume,
   R = sqrt(r0^2 + V_frozen/(pi H)). The transcription of (1) is checked first against a fine 1D radial enthalpy
   solution of the same annulus (:func:`enthalpy_1d`), at three radial resolutions.
2. :func:`robin_melting` (no closed form: a converged 1D reference). A slab 0 < x < length of a two-phase material
   at T_S, melted from x = 0 through a heat transfer condition q = h (T_amb - T) (T_amb > Theta_R), x = length
   insulated; the 1D reference (:func:`enthalpy_1d` at three resolutions with dt ~ h, its front converging at
   first order: the finest level's error bound is the Richardson estimate) against the scene's strip.
3. :func:`anisotropic_neumann` (Neumann two-phase similarity solution, section 1). A strip at an angle to the
   axes, its axis along the second principal direction of the tensors K_s = k_s R diag(1, a) R^T,
   K_l = k_l R diag(1, a) R^T (R the rotation by ``conductivity_angle``): along the strip the material conducts
   with a k_s, a k_l, across it with k_s, k_l, and the off-diagonal entries in x, y carry the rotation; the 1D
   solution in the strip's coordinate is the Neumann solution with a k_s, a k_l (the sides stay insulated since
   the strip's axis is a principal direction).

Each function returns a plain dict with the levels' errors, observed orders (polyfit of log error on log h),
the runs' relative energy imbalance (the summary's ``energy.imbalance_rel_max``: |heat gain - heat supplied| /
scale, the Robin exchange included) and wall times. Nothing here prints or writes files.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_banded
from scipy.optimize import brentq
from scipy.special import expi

from ..api import run
from ..scene.parse import scene_from_dict
from .stefan import NeumannProblem
from .study import observed_order, one_ngsolve_thread


# -- 1. the line sink --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LineSink:
    """Freezing around a line sink (module docstring, (1)): ``power`` Q' (W per metre of the line, extracted),
    ``t_initial`` T_i > ``t_freeze`` T_f (K), conductivities ``k_solid``, ``k_liquid`` (W/(m K)), heat capacities
    ``c_solid``, ``c_liquid`` (J/(m^3 K)), volumetric latent heat ``latent`` (J/m^3)."""

    power: float = 10.0
    t_initial: float = 1.0
    t_freeze: float = 0.0
    k_solid: float = 2.0
    k_liquid: float = 0.5
    c_solid: float = 1.0
    c_liquid: float = 2.0
    latent: float = 10.0

    @property
    def a_solid(self) -> float:
        return self.k_solid / self.c_solid

    @property
    def a_liquid(self) -> float:
        return self.k_liquid / self.c_liquid

    def residual(self, lam: float) -> float:
        """Left minus right side of (1), W/m."""
        x = lam * lam * self.a_solid / self.a_liquid
        return (self.power / (4 * math.pi) * math.exp(-lam * lam)
                + self.k_liquid * (self.t_initial - self.t_freeze) * math.exp(-x) / expi(-x)
                - lam * lam * self.a_solid * self.latent)

    @property
    def lam(self) -> float:
        """The root of (1): the residual is +Q'/(4 pi) > 0 at lam -> 0 and falls below 0 for large lam (bracket
        (1e-9, 5): beyond, exp(-x)/Ei(-x) underflows to 0/0)."""
        return float(brentq(self.residual, 1e-9, 5.0, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200))

    def front(self, t: float) -> float:
        """R(t) = 2 lam sqrt(a_s t), m."""
        return 2.0 * self.lam * math.sqrt(self.a_solid * t)

    def temperature(self, r, t: float) -> np.ndarray:
        """T(r, t), K (numpy)."""
        r = np.asarray(r, dtype=float)
        lam = self.lam
        solid = self.t_freeze + self.power / (4 * math.pi * self.k_solid) * (
            expi(-r * r / (4 * self.a_solid * t)) - expi(-lam * lam))
        liquid = self.t_initial - (self.t_initial - self.t_freeze) * expi(-r * r / (4 * self.a_liquid * t)) / expi(
            -lam * lam * self.a_solid / self.a_liquid)
        return np.where(r < self.front(t), solid, liquid)

    def far_radius(self, t: float, tol: float = 1e-7) -> float:
        """A radius (m) beyond which the liquid differs from T_i by less than tol (T_i - T_f) up to t."""
        ratio = lambda r: expi(-r * r / (4 * self.a_liquid * t)) / expi(   # noqa: E731
            -self.lam ** 2 * self.a_solid / self.a_liquid) - tol
        return float(brentq(ratio, self.front(t), 1e3 * self.front(t) + 10.0))


# -- the 1D enthalpy reference ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Phases:
    """One phase-change material in numbers: ``melt`` Theta_R (K), ``latent`` L (J/m^3), ``c_solid``, ``c_liquid``
    (J/(m^3 K)), ``k_solid``, ``k_liquid`` (W/(m K))."""

    melt: float
    latent: float
    c_solid: float
    c_liquid: float
    k_solid: float
    k_liquid: float

    def enthalpy(self, T) -> np.ndarray:
        d = np.asarray(T, dtype=float) - self.melt
        return np.where(d < 0, self.c_solid * d, self.latent + self.c_liquid * np.maximum(d, 0.0))

    def state(self, e: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """T, dT/de, the Kirchhoff variable k (T - Theta_R) and its derivative in e, per node (mushy nodes closed:
        0 <= e <= L has T = Theta_R, dT/de = 0)."""
        solid, liquid = e < 0, e > self.latent
        T = self.melt + np.where(solid, e / self.c_solid, np.where(liquid, (e - self.latent) / self.c_liquid, 0.0))
        dT = np.where(solid, 1 / self.c_solid, np.where(liquid, 1 / self.c_liquid, 0.0))
        k = np.where(solid, self.k_solid, self.k_liquid)
        return T, dT, k * (T - self.melt), k * dT


def graded_nodes(r0: float, r1: float, h: float, h0: float | None = None, growth: float = 1.1) -> np.ndarray:
    """Nodes from r0 to r1 (m): elements growing geometrically by ``growth`` from ``h0`` (default h) at r0 to h,
    then uniform h (the last element stretched to end at r1)."""
    nodes, size = [r0], min(h0 or h, h)
    while nodes[-1] < r1:
        nodes.append(nodes[-1] + size)
        size = min(size * growth, h)
    if len(nodes) > 2 and nodes[-1] - r1 > 0.5 * (nodes[-1] - nodes[-2]):
        nodes.pop()
    nodes[-1] = r1
    return np.array(nodes)


@dataclass
class _Line:
    """The 1D system of :func:`enthalpy_1d`: lumped masses ``m``, element conductances ``kel`` (stiffness
    -kel off the diagonal), its diagonal ``diag``, the Robin conductances ``rob``, the ``fixed`` (Dirichlet)
    nodes."""

    m: np.ndarray
    kel: np.ndarray
    diag: np.ndarray
    rob: np.ndarray
    fixed: np.ndarray


def _line(r: np.ndarray, weight_power: int, left: tuple, right: tuple, factor=None) -> _Line:
    a, b = r[:-1], r[1:]
    length = b - a
    m = np.zeros(len(r))
    if weight_power == 1:
        np.add.at(m, np.arange(len(a)), length * (2 * a + b) / 6)
        np.add.at(m, np.arange(1, len(r)), length * (a + 2 * b) / 6)
        kel = (a + b) / 2 / length
    else:
        np.add.at(m, np.arange(len(a)), length / 2)
        np.add.at(m, np.arange(1, len(r)), length / 2)
        kel = 1.0 / length
    if factor is not None:                      # k(x) = k g(x): the harmonic element mean of g (4-point Gauss)
        gauss = np.polynomial.legendre.leggauss(4)
        inv = sum(w / 2 / factor(0.5 * (a + b) + 0.5 * q * length) for q, w in zip(*gauss))
        kel = kel / inv
    diag = np.zeros(len(r))
    np.add.at(diag, np.arange(len(a)), kel)
    np.add.at(diag, np.arange(1, len(r)), kel)
    rob = np.zeros(len(r))
    if left[0] == "robin":
        rob[0] = r[0] ** weight_power * left[1]
    fixed = np.zeros(len(r), dtype=bool)
    fixed[0] = left[0] == "dirichlet"
    fixed[-1] = right[0] == "dirichlet"
    return _Line(m, kel, diag, rob, fixed)


def _residual(ln: _Line, mat: Phases, e, e_old, dt, F):
    T, dT, theta, dtheta = mat.state(e)
    R = ln.m * (e - e_old) / dt + ln.diag * theta - F + ln.rob * T
    R[:-1] -= ln.kel * theta[1:]
    R[1:] -= ln.kel * theta[:-1]
    return R, T, dT, dtheta


def _newton_1d(ln: _Line, mat: Phases, e_old, dt, F, tol, maxit, scale):
    """One backward Euler step (semi-smooth Newton, tridiagonal Jacobian): (e, R, iterations), or None when
    Newton does not converge in ``maxit`` iterations (the step is then split)."""
    e = e_old.copy()
    for it in range(maxit + 1):
        R, T, dT, dtheta = _residual(ln, mat, e, e_old, dt, F)
        res = np.where(ln.fixed, 0.0, R)
        if np.max(np.abs(res) * dt / ln.m) <= tol * scale:
            return e, R, it
        band = np.zeros((3, len(e)))
        band[1] = ln.m / dt + ln.diag * dtheta + ln.rob * dT
        band[0, 1:] = -ln.kel * dtheta[1:]
        band[2, :-1] = -ln.kel * dtheta[:-1]
        band[1, ln.fixed] = 1.0
        band[0, 1:][ln.fixed[:-1]] = 0.0
        band[2, :-1][ln.fixed[1:]] = 0.0
        e = e - solve_banded((1, 1), band, res)
    return None


def enthalpy_1d(nodes: np.ndarray, weight_power: int, mat: Phases, t_initial: float, steps, left: tuple,
                right: tuple, tol: float = 1e-12, maxit: int = 30, factor=None) -> dict:
    """A 1D enthalpy solution independent of the mesh-based forms: lumped P1 on ``nodes`` (m) with the weight
    r^``weight_power`` (0: slab, J per m^2; 1: radial, J per m of the axis and per radian), nodal enthalpy, backward
    Euler over ``steps`` ((t0, t1) pairs, s), semi-smooth Newton with the tridiagonal Jacobian
    m/dt + K d(theta)/de + diag(r) dT/de (the same method as the forms', written anew in numpy); a step whose
    Newton iteration does not converge is split in halves.

    ``left``: ("flux", q) (W/m^2 into the body), ("robin", h, T_amb) or ("dirichlet", T); ``right``:
    ("dirichlet", T) or ("insulated",). ``factor``: a conductivity k_phase g(x) varying along the line, g a numpy
    function of the coordinate (the element conductances take its harmonic element mean: exact for a steady
    solution). Returns the final nodal ``T`` and liquid fraction ``phi``, ``melted``
    sum m_i phi_i, ``frozen`` sum m_i (1 - phi_i) (m^2 per radian radially, m in the slab), ``imbalance_rel``
    (|heat gain - heat in| / heat in), ``newton_max``, ``splits``."""
    r = np.asarray(nodes, dtype=float)
    ln = _line(r, weight_power, left, right, factor)
    w0 = r[0] ** weight_power
    F = np.zeros(len(r))
    F[0] = w0 * left[1] if left[0] == "flux" else (w0 * left[1] * left[2] if left[0] == "robin" else 0.0)
    e = mat.enthalpy(np.full(len(r), float(t_initial)))
    scale = mat.latent + max(mat.c_solid, mat.c_liquid) * abs(t_initial - mat.melt) + 1.0
    heat0, heat_in, newton_max, splits = float(ln.m @ e), 0.0, 0, 0
    pending = list(steps)[::-1]
    while pending:
        t0, t1 = pending.pop()
        e_old = e.copy()
        if left[0] == "dirichlet":
            e_old[0] = mat.enthalpy(left[1])
        if right[0] == "dirichlet":
            e_old[-1] = mat.enthalpy(right[1])
        out = _newton_1d(ln, mat, e_old, t1 - t0, F, tol, maxit, scale)
        if out is None:
            if splits > 10000:
                raise RuntimeError(f"1D enthalpy reference: Newton did not converge at t = {t1:g}")
            splits += 1
            pending += [(0.5 * (t0 + t1), t1), (t0, 0.5 * (t0 + t1))]
            continue
        e_new, R, it = out
        # heat in: the fixed nodes' residuals (the boundary heat) and the first node's flux or Robin exchange
        heat_in += float(np.sum(ln.m[ln.fixed] * (e_new - e)[ln.fixed])) + (t1 - t0) * (
            float(np.sum(R[ln.fixed])) + F[0] - ln.rob[0] * mat.state(e_new)[0][0])
        e = e_new
        newton_max = max(newton_max, it)
    phi = np.clip(e / mat.latent, 0.0, 1.0)
    gain = float(ln.m @ e) - heat0
    return {"T": mat.state(e)[0], "phi": phi, "melted": float(ln.m @ phi), "frozen": float(ln.m @ (1 - phi)),
            "imbalance_rel": abs(gain - heat_in) / max(abs(heat_in), 1e-300), "newton_max": newton_max,
            "splits": splits, "nodes": len(r)}


def _phases(p: LineSink) -> Phases:
    return Phases(p.t_freeze, p.latent, p.c_solid, p.c_liquid, p.k_solid, p.k_liquid)


def _pcm(m: Phases) -> dict:
    """The scene material of ``m`` (isotropic)."""
    return {"conductivity": m.k_solid, "rho_c": m.c_solid, "phase_change_temperature": m.melt,
            "latent_heat_volumetric": m.latent, "rho_c_liquid": m.c_liquid, "conductivity_liquid": m.k_liquid}


def fitted_order(hs, errors) -> float:
    """The observed order of |errors| over hs (nan with fewer than two nonzero errors)."""
    errs = np.abs(np.asarray(errors, dtype=float))
    return observed_order(hs, errs) if len(hs) > 1 and np.all(errs > 0) else float("nan")


def line_sink_reference(problem: LineSink, r0: float, t1: float, hs=(0.02, 0.01, 0.005, 0.0025)) -> dict:
    """The closed form's transcription checked against :func:`enthalpy_1d` on the annulus r0 < r < r_out + 0.5 m
    (radial weight r; elements from r0/4 at the sink growing by 1.1 to h; steps from 1e-5 t1 growing by 1.1 to
    h t1 / 2) at the radial sizes ``hs`` (m): ``front_rel_error`` per level (R_1D/R - 1, R_1D from the frozen
    volume; its sign changes between levels, so no order is fitted: ``front_rel_error_max`` is the largest
    |error|), ``temperature_rel_error`` (max over the nodes at r >= 10 r0 of |T_1D - T| / (T_i - T_f), T the
    closed form at t1; largest at the front, where the mushy node sits at T_f) with its ``temperature_order``,
    ``imbalance_rel_max`` and ``wall_s``."""
    from ..fem.timesteps import schedule

    tic = time.perf_counter()
    mat = _phases(problem)
    r_out = problem.far_radius(t1) + 0.5
    errors, t_errors, imbalance = [], [], 0.0
    for h in hs:
        nodes = graded_nodes(r0, r_out, h, h0=r0 / 4)
        steps = list(schedule(0.0, t1, 1e-5 * t1, 1.1, 0.5 * h * t1))
        out = enthalpy_1d(nodes, 1, mat, problem.t_initial, steps,
                          ("flux", -problem.power / (2 * math.pi * r0)), ("dirichlet", problem.t_initial))
        errors.append(math.sqrt(r0 * r0 + 2 * out["frozen"]) / problem.front(t1) - 1.0)
        away = nodes >= 10 * r0             # the hole r < r0 changes T near the sink (the closed form's r -> 0)
        exact = problem.temperature(nodes[away], t1)
        t_errors.append(float(np.max(np.abs(out["T"][away] - exact))) / (problem.t_initial - problem.t_freeze))
        imbalance = max(imbalance, out["imbalance_rel"])
    return {"h": list(hs), "r0": r0, "front_rel_error": errors,
            "front_rel_error_max": float(np.max(np.abs(errors))), "temperature_rel_error": t_errors,
            "temperature_order": fitted_order(hs, t_errors), "imbalance_rel_max": float(imbalance),
            "wall_s": time.perf_counter() - tic}


def line_sink_scene(problem: LineSink, r0: float, r_out: float, height: float, h: float, t1: float) -> dict:
    """The line sink's annulus as an axisymmetric scene dict (module docstring): block 'pcm' r0 < r < r_out,
    0 < z < height, the flux -Q'/(2 pi r0) on 'sink' (r = r0, elements of size r0/2 there), T_i on 'far',
    steps from 1e-4 t1 growing by 1.15 to h t1 / 2 (s)."""
    return {"scene": {"name": "line_sink", "dimension": "axisymmetric"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": h, "boundary_maxh": {"sink": min(h, r0 / 2)}},
            "blocks": [{"name": "pcm", "shape": "rectangle", "origin": [r0, 0.0], "size": [r_out - r0, height],
                        "boundaries": {"sink": "xmin", "far": "xmax"}}],
            "materials": {"pcm": _pcm(_phases(problem))},
            "boundary_conditions": {"sink": {"flux": -problem.power / (2 * math.pi * r0)},
                                    "far": {"temperature": problem.t_initial}},
            "initial": {"temperature": problem.t_initial},
            "time": {"end": t1, "dt": 1e-4 * t1, "dt_growth": 1.15, "dt_max": 0.5 * h * t1},
            "output": {"every": 10 ** 6}}


def line_sink_freezing(problem: LineSink | None = None, hs=(0.1, 0.05, 0.025), r0: float = 0.01,
                       height: float = 0.1, reference_hs=(0.02, 0.01, 0.005, 0.0025),
                       reference_r0: float = 0.005) -> dict:
    """Freezing around a line sink (module docstring, 1) until R(t1) = 1 m: the closed form checked against the
    1D reference (:func:`line_sink_reference` with the sink radius ``reference_r0``), then the axisymmetric scene
    (:func:`line_sink_scene`) at the mesh sizes ``hs`` (m). Returns ``lam``, ``t1`` (s), ``front_exact`` (m),
    ``reference`` (the 1D check), per level ``front`` (m), ``front_rel_error``, ``energy_imbalance_rel``,
    ``ndofs``, ``steps``, ``newton_mean``, ``wall_s``; ``order`` (front), and the figures of the issue,
    ``axisymmetric_stefan_front_rel_error`` (the finest level's) and ``energy_imbalance_rel`` (the largest)."""
    p = problem or LineSink(power=60.0)
    t1 = 1.0 / (4 * p.lam ** 2 * p.a_solid)
    r_out = p.far_radius(t1) + 0.5
    out = {"lam": p.lam, "t1": t1, "front_exact": p.front(t1), "r0": r0, "r_out": r_out, "height": height,
           "reference": line_sink_reference(p, reference_r0, t1, reference_hs), "levels": []}
    def front(st: dict) -> float:
        frozen = st["phase_change_regions"]["pcm"]["volume"] - st["melted_volume"]["pcm"][-1]
        return math.sqrt(r0 * r0 + frozen / (math.pi * height))
    out["levels"] = run_levels(lambda h: line_sink_scene(p, r0, r_out, height, h, t1), hs, front)
    for lv in out["levels"]:
        lv["front_rel_error"] = abs(lv["front"] / p.front(t1) - 1.0)
    errors = [lv["front_rel_error"] for lv in out["levels"]]
    out.update(h=list(hs), front_rel_error=errors, order=fitted_order(hs, errors),
               axisymmetric_stefan_front_rel_error=errors[-1],
               energy_imbalance_rel=max(lv["energy_imbalance_rel"] for lv in out["levels"]))
    return out


# -- 2. a heat transfer condition ---------------------------------------------------------------------------------
ROBIN_SLAB = Phases(melt=0.0, latent=2.0, c_solid=3.0, c_liquid=1.0, k_solid=1.5, k_liquid=1.0)
"""The two-phase material of :data:`ngs_geomech.verification.stefan.TWO_PHASE` (a_s = 0.5, a_l = 1 m^2/s)."""


@dataclass(frozen=True)
class RobinSlab:
    """The slab of :func:`robin_melting`: ``material``, initial temperature ``t_solid`` (K, below Theta_R),
    heat transfer coefficient ``h`` (W/(m^2 K)) to the ambient ``t_ambient`` (K, above Theta_R) at x = 0,
    ``length`` (m; insulated at x = length), end time ``t1`` (s)."""

    material: Phases = ROBIN_SLAB
    t_solid: float = -0.5
    h: float = 2.0
    t_ambient: float = 2.0
    length: float = 1.0
    t1: float = 0.5


def robin_reference(problem: RobinSlab, hs=(1 / 100, 1 / 200, 1 / 400, 1 / 800, 1 / 1600),
                    dt_over_h: float = 0.4) -> dict:
    """The slab in 1D (:func:`enthalpy_1d`, uniform elements of size h, steps dt = dt_over_h h) at the sizes
    ``hs`` (m): ``front`` per level (the melted volume, m), the successive ``differences`` with their ``order``,
    ``front_reference`` (the finest level's) and ``front_uncertainty_rel`` (the largest difference of the two
    next finer levels from it, relative: at fine levels the nodal melted volume moves by steps, so the differences
    stop falling smoothly at ~1e-4)."""
    return slab_reference(problem.length, problem.material, problem.t_solid, problem.t1, hs, dt_over_h,
                          ("robin", problem.h, problem.t_ambient))


def slab_reference(length: float, material, t_initial: float, t1: float, hs, dt_over_h: float, left: tuple,
                   factor=None) -> dict:
    """A slab 0 < x < length (m) in 1D (:func:`enthalpy_1d`, uniform elements of size h, steps dt = dt_over_h h,
    from ``t_initial`` to ``t1`` s, the condition ``left`` at x = 0, insulated at x = length, the conductivity
    times ``factor`` if given) at the sizes ``hs`` (m): ``front`` per level (the melted volume, m), the successive
    ``differences`` with their ``order``, ``front_reference`` (the finest level's), ``front_uncertainty_rel`` (the
    largest difference of the two next finer levels from it, relative), ``imbalance_rel_max``, ``wall_s``."""
    from ..fem.timesteps import schedule

    tic = time.perf_counter()
    fronts, imbalance = [], 0.0
    for h in hs:
        n = int(round(length / h))
        out = enthalpy_1d(np.linspace(0.0, length, n + 1), 0, material, t_initial,
                          list(schedule(0.0, t1, dt_over_h * h)), left, ("insulated",), factor=factor)
        fronts.append(out["melted"])
        imbalance = max(imbalance, out["imbalance_rel"])
    diffs = np.abs(np.diff(fronts))
    return {"h": list(hs), "front": fronts, "differences": diffs.tolist(), "order": fitted_order(hs[1:], diffs),
            "front_reference": fronts[-1],
            "front_uncertainty_rel": float(np.max(np.abs(np.array(fronts[-3:-1]) - fronts[-1])) / fronts[-1]),
            "imbalance_rel_max": float(imbalance), "wall_s": time.perf_counter() - tic}


def robin_scene(problem: RobinSlab, height: float, h: float, dt: float) -> dict:
    """The slab as a plane scene dict: the strip 'pcm' 0 < x < length, 0 < y < height, the heat transfer
    condition on 'wall' (x = 0), insulated elsewhere, mesh size h (m), steps dt (s)."""
    return {"scene": {"name": "robin_melting", "dimension": "plane"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": h},
            "blocks": [{"name": "pcm", "shape": "rectangle", "origin": [0.0, 0.0], "size": [problem.length, height],
                        "boundaries": {"wall": "xmin"}}],
            "materials": {"pcm": _pcm(problem.material)},
            "boundary_conditions": {"wall": {"heat_transfer_coefficient": problem.h,
                                             "ambient_temperature": problem.t_ambient}},
            "initial": {"temperature": problem.t_solid},
            "time": {"end": problem.t1, "dt": dt},
            "output": {"every": 10 ** 6}}


def run_levels(make, hs, front_of) -> list[dict]:
    """Run the scene ``make(h)`` at each mesh size: the front (``front_of(summary)``, m), the energy imbalance,
    dofs, steps, Newton iterations and wall time (s) per level."""
    levels = []
    with one_ngsolve_thread():
        for h in hs:
            tic = time.perf_counter()
            res = run(scene_from_dict(make(h)), None, progress=False)
            st = res.summary["stefan"]
            levels.append({"h": h, "front": front_of(st), "energy_imbalance_rel": st["energy"]["imbalance_rel_max"],
                           "ndofs": res.stefan.forms.n, "steps": st["newton_iterations"]["steps"],
                           "newton_mean": st["newton_iterations"]["mean"], "wall_s": time.perf_counter() - tic,
                           "energy": {k: v[-1] for k, v in st["energy"].items() if isinstance(v, list)}})
    return levels


def robin_melting(problem: RobinSlab | None = None, hs=(0.05, 0.025, 0.0125), height: float = 0.1,
                  dt_over_h: float = 0.4) -> dict:
    """The Robin slab (module docstring, 2): the 1D reference (:func:`robin_reference`), then the scene
    (:func:`robin_scene`) at the mesh sizes ``hs`` (m) with dt = dt_over_h h, the front from the melted volume /
    height. Returns ``reference``, per level ``front``, ``front_rel_error`` (against the reference's front),
    ``energy_imbalance_rel`` (Robin exchange included), the level's last ``energy`` figures, ``ndofs``, ``steps``,
    ``newton_mean``, ``wall_s``; the ``order`` (front) and the figures of the issue ``robin_stefan_front_rel_error``
    (the finest level's) and ``energy_imbalance_rel`` (the largest)."""
    p = problem or RobinSlab()
    ref = robin_reference(p)
    levels = run_levels(lambda h: robin_scene(p, height, h, dt_over_h * h), hs,
                         lambda st: st["melted_volume"]["pcm"][-1] / height)
    for lv in levels:
        lv["front_rel_error"] = abs(lv["front"] / ref["front_reference"] - 1.0)
    errors = [lv["front_rel_error"] for lv in levels]
    return {"reference": ref, "levels": levels, "h": list(hs), "front_rel_error": errors,
            "order": fitted_order(hs, errors), "robin_stefan_front_rel_error": errors[-1],
            "energy_imbalance_rel": max(lv["energy_imbalance_rel"] for lv in levels)}


# -- 3. anisotropic conductivity per phase -----------------------------------------------------------------------
def anisotropic_scene(problem: NeumannProblem, ratio: float, angle: float, length: float, width: float, h: float,
                      dt: float, t0: float, t1: float) -> dict:
    """The rotated strip of :func:`anisotropic_neumann` as a plane scene dict: 'pcm' the rectangle of ``length``
    along n = (cos angle, sin angle) and ``width`` across (m), 'hot' (its side through the origin, across n) at
    T_L, 'far' at T_S, the long sides insulated; the conductivities conductivity_principal [k_s / ratio, k_s] and
    conductivity_liquid_principal [k_l / ratio, k_l] with conductivity_angle = angle - 90 degrees (the second
    principal axis along n), k_s, k_l those of ``problem``; from the exact state at t0 to t1 with steps dt (s)."""
    from .stefan_adaptive import exact_temperature_expression

    m = problem.material
    a = math.radians(angle)
    n, q = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    pts = [np.zeros(2), length * n, length * n + width * q, width * q]
    xi = f"(x * {math.cos(a)!r} + y * {math.sin(a)!r})"          # the coordinate along the strip
    import re
    initial = re.sub(r"\bx\b", xi, exact_temperature_expression(problem, t0))
    return {"scene": {"name": "anisotropic_neumann", "dimension": "plane"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": h},
            "blocks": [{"name": "pcm", "shape": "polygon", "points": [p.tolist() for p in pts],
                        "edges": ["side", "far", "side", "hot"]}],
            "materials": {"pcm": {"conductivity_principal": [m.conductivity_solid / ratio, m.conductivity_solid],
                                  "conductivity_angle": angle - 90.0, "rho_c": m.rho_c_solid,
                                  "phase_change_temperature": m.melting_temperature,
                                  "latent_heat_volumetric": m.latent_heat, "rho_c_liquid": m.rho_c_liquid,
                                  "conductivity_liquid_principal": [m.conductivity_liquid / ratio,
                                                                    m.conductivity_liquid]}},
            "boundary_conditions": {"hot": {"temperature": problem.t_hot}, "far": {"temperature": problem.t_cold}},
            "initial": {"temperature": initial},
            "time": {"start": t0, "end": t1, "dt": dt},
            "output": {"every": 10 ** 6}}


def anisotropic_neumann(ratio: float = 4.0, angle: float = 30.0, hs=(0.05, 0.025, 0.0125), width: float = 0.1,
                        dt_over_h: float = 0.05, t0: float = 0.025, t1: float = 0.125) -> dict:
    """The two-phase Neumann problem (:data:`ngs_geomech.verification.stefan.TWO_PHASE` with both conductivities
    times ``ratio``: the conductivity along the strip) in a strip at ``angle`` degrees to x (module docstring, 3;
    across the strip the conductivities are 1/ratio of those along it) at the mesh sizes ``hs`` (m), dt =
    dt_over_h h (s). Returns ``front_exact`` (m) and per level ``front`` (melted volume / width),
    ``front_rel_error``, ``energy_imbalance_rel``, ...; the ``order`` and ``anisotropic_stefan_front_rel_error`` (the
    finest level's), ``energy_imbalance_rel`` (the largest)."""
    from .stefan import TWO_PHASE

    m = TWO_PHASE.material
    problem = NeumannProblem(type(m)(melting_temperature=m.melting_temperature, latent_heat=m.latent_heat,
                                     rho_c_solid=m.rho_c_solid, rho_c_liquid=m.rho_c_liquid,
                                     conductivity_solid=ratio * m.conductivity_solid,
                                     conductivity_liquid=ratio * m.conductivity_liquid),
                             t_hot=TWO_PHASE.t_hot, t_cold=TWO_PHASE.t_cold)
    length = problem.domain_length(t1)
    exact = problem.front(t1)
    levels = run_levels(lambda h: anisotropic_scene(problem, ratio, angle, length, width, h, dt_over_h * h, t0, t1),
                         hs, lambda st: st["melted_volume"]["pcm"][-1] / width)
    for lv in levels:
        lv["front_rel_error"] = abs(lv["front"] / exact - 1.0)
    errors = [lv["front_rel_error"] for lv in levels]
    return {"ratio": ratio, "angle_deg": angle, "length": length, "front_exact": exact, "lam": problem.lam,
            "levels": levels, "h": list(hs), "front_rel_error": errors, "order": fitted_order(hs, errors),
            "anisotropic_stefan_front_rel_error": errors[-1],
            "energy_imbalance_rel": max(lv["energy_imbalance_rel"] for lv in levels)}
