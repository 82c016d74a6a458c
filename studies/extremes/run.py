"""Stability at the extremes: a test matrix of small problems at the edges of the parameter
ranges, each classified as 'accurate', 'clear_error' or 'nan_or_hang'.

Every case is a small problem run through the product's public paths (scene dicts through
``run_scene(scene, None)``, or the verification library where the closed form lives there), in a worker process
with a wall-time limit of 60 s per case (a case over it is killed: a hang). Outcomes: 'accurate' (finished and
within the stated tolerance of a closed form or an exactly reproducible solution, every extra check too),
'clear_error' (stopped with a SceneError / SolverError / ValueError whose message contains the expected words
naming the item), 'nan_or_hang' (everything else: NaN/inf, a time-out, a crash, an unexpected exception or one
without the expected words, a result outside its tolerance, a result where a stop was expected).

Cases (references): Poisson ratio 0.3 ... 0.4999 (thick-walled cylinder, axisymmetric plane-strain section, P2,
h = 0.05, closed form; all stresses, or u_r and the deviatoric stresses) and 0.5; stiffness contrast 1e-6 ... 1e6
between two stacked blocks (contact: uniform pressure exact; glued with nu = 0: uniform stress exact); initial
gaps (closing, staying open) and overlaps (a rigid foundation 0.1 mm inside a bar, heated and not); conductivity
anisotropy 1 ... 1e4 (piecewise quadratic patch test across a glued or contact interface, P2); lam 0.3 ... 3
(uniaxial strain bar against the closed form, Newton and secant) and lam = 0, -1; Stefan numbers 0.01 ... 100
(Neumann one- and two-phase closed forms, front from the melted volume, energy balance); time steps 1e-3 and
1e3 element diffusion times h^2/a (Stefan) and 1e-4, ~4e2 (heat, manufactured solution exact in space,
backward Euler and Crank-Nicolson); slip bound g_c = 0 ... 1e15 and Coulomb F_c = 0 ... 1 (a block on a rigid
foundation pushed below its capacity: friction force = push; moved: friction force = capacity); floating bodies
(held by Coulomb contact only; pushed over the capacity; pulled off; a second body with no support); element
aspect ratio 1.6e2, 1.6e3 and a 10 um thin bar; coarse (maxh 100 m on 1 m) and very fine meshes (exact
solutions); geologic (100 km, 1e5 years, 2.6 GPa) against laboratory (1 cm, 10 s) scales with the same scaled
problem (transient heat against erfc, a gravity column, the heated bar between foundations).

What the cases guard: a body with no support at all is named (rigid motions are checked body by body); a
block netgen cannot mesh completely is named with the share it covers; floating blocks with small friction
whose nodes slip both ways are solved (the slip-direction turning point is moved until one sticking node
balances the load); a contact problem driven by its gaps alone is solved; F_c = 0 is frictionless contact;
the P2 mean stress near nu = 1/2 is accurate with the mixed displacement-pressure formulation.

Command: ``python studies/extremes/run.py --level 0 --out out/extremes`` (writes ``results.json`` with the
metrics and the per-case table under ``cases``; prints the table). Level 1 refines the Stefan strips (h = 0.025)
and the 'very fine' meshes (h = 0.004).

Cost on one NGSolve thread: level 0 about 8 s, level 1 about 30 s.
"""

from __future__ import annotations

import json
import math
import os
import select
import subprocess
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ngs_geomech.verification.study import json_safe, metrics_lines, study_cli, study_main

STUDY = "extremes"
LEVELS = {0: {"fine_h": 0.01, "fine_h_mech": 0.01, "stefan_h": 0.05},
          1: {"fine_h": 0.004, "fine_h_mech": 0.004, "stefan_h": 0.025}}
"""Per level: the mesh size (m) of the 'very fine' heat and mechanics meshes (on a unit square / 1 m x 0.25 m
bar) and of the Stefan strips; everything else is the same at every level."""
TIME_LIMIT_S = 60.0
"""Wall-time limit of one case (s); a case over it is a hang (its worker process is killed)."""
OUTCOMES = ("accurate", "clear_error", "nan_or_hang")


class Case(NamedTuple):
    """One case: ``fn(level)`` returns {"error", "tol"[, "checks": {name: [value, limit]}, "note"]} for a case
    compared with a reference (accurate when every value is finite and at most its limit), or raises. ``expect``
    (message fragments, all required, case-insensitive) marks a case that must stop with a SceneError,
    SolverError or ValueError whose message names the offending item."""

    name: str
    group: str
    parameter: str
    fn: Callable[[int], dict]
    expect: tuple[str, ...] = ()


CASES: list[Case] = []


def case(name: str, group: str, parameter: str, expect: tuple[str, ...] = ()):
    def deco(fn):
        CASES.append(Case(name, group, parameter, fn, expect))
        return fn
    return deco


# ------------------------------------------------------------------------------------------------ helpers

def _run(data: dict):
    from ngs_geomech.run import run_scene
    from ngs_geomech.scene.parse import scene_from_dict
    return run_scene(scene_from_dict(data, source=data["scene"]["name"]), None, progress=False)


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a, float) - b)) / max(abs(b), 1e-300))


def _aspect(mesh) -> float:
    """Largest element aspect ratio (longest edge^2 / (2 area), i.e. longest edge over its height)."""
    pts = np.array([v.point for v in mesh.vertices])
    worst = 0.0
    for el in mesh.Elements():
        p = pts[[v.nr for v in el.vertices]]
        e = [np.linalg.norm(p[i] - p[(i + 1) % 3]) for i in range(3)]
        area = 0.5 * abs(np.cross(p[1] - p[0], p[2] - p[0]))
        worst = max(worst, max(e) ** 2 / (2 * area))
    return worst


# ---------------------------------------------------------------------- Poisson ratio: cylinder closed form

CYL = {"a": 1.0, "b": 2.0, "Ti": 100.0, "E": 70e9, "alpha": 8e-6, "length": 0.5}


def _cylinder(nu: float, h: float = 0.05, order: int = 2, part: str = "stress") -> dict:
    """Thick-walled cylinder a < r < b, axisymmetric section 0 < z < 0.5 m with u_z = 0 on both ends (plane
    strain), steady T (100 K inside, 0 outside), P2, h = 0.05 m, against the closed form (verification.md
    section 4) at 41 radii at z = L/2. ``part`` "stress": max |sigma_h - sigma| of sigma_r, sigma_theta,
    sigma_z over max |sigma_theta|; "deviatoric": the radial displacement (relative to max |u_r|) and the
    deviatoric stresses (over max |sigma_theta|), i.e. everything but the mean stress."""
    from ngs_geomech.verification.elastic_closed_forms import cylinder_thermal_stresses
    c = CYL
    data = {"scene": {"name": "cylinder_nu", "dimension": "axisymmetric", "temperature_unit": "K"},
            "physics": {"thermal": "steady", "mechanics": "static", "plane_model": "plane_strain"},
            "mesh": {"maxh": h, "order": order},
            "blocks": [{"name": "wall", "shape": "rectangle", "origin": [c["a"], 0.0],
                        "size": [c["b"] - c["a"], c["length"]],
                        "boundaries": {"inner": "xmin", "outer": "xmax", "bottom": "ymin", "top": "ymax"}}],
            "materials": {"wall": {"conductivity": 1.0, "youngs_modulus": c["E"], "poisson_ratio": nu,
                                   "thermal_expansion": c["alpha"], "stress_free_temperature": 0.0}},
            "boundary_conditions": {"inner": {"temperature": c["Ti"]}, "outer": {"temperature": 0.0},
                                    "bottom": {"symmetry": True}, "top": {"symmetry": True}},
            "output": {"vtk": False, "figures": False}}
    res = _run(data)
    rs = c["a"] + (c["b"] - c["a"]) * np.linspace(0.002, 0.998, 41)
    pts = res.mesh(rs, np.full_like(rs, c["length"] / 2))
    S = np.asarray(res.mechanics.sigma(pts)).reshape(-1, 3, 3)
    num = np.stack([S[:, 0, 0], S[:, 2, 2], S[:, 1, 1]])           # r, theta, z
    ex = cylinder_thermal_stresses(rs, c["a"], c["b"], c["Ti"], c["E"], nu, c["alpha"], case="plane_strain")
    ref = np.stack([ex.sigma_r, ex.sigma_theta, ex.sigma_z])
    fine = np.linspace(c["a"], c["b"], 2001)
    scale = float(np.max(np.abs(cylinder_thermal_stresses(fine, c["a"], c["b"], c["Ti"], c["E"], nu, c["alpha"],
                                                          case="plane_strain").sigma_theta)))
    mean_err = float(np.max(np.abs(num.mean(axis=0) - ref.mean(axis=0)))) / scale
    dev_err = float(np.max(np.abs((num - num.mean(axis=0)) - (ref - ref.mean(axis=0))))) / scale
    u = np.asarray(res.mechanics.forms.displacement()(pts))[:, 0]
    u_err = float(np.max(np.abs(u - ex.u_r)) / np.max(np.abs(ex.u_r)))
    warn = "; ".join(res.summary.get("warnings", [])) or "none"
    note = (f"P{order} h = {h}, {res.summary['mesh']['dofs']} dofs; u_r {u_err:.2e}, deviatoric {dev_err:.2e}, "
            f"mean stress {mean_err:.2e}; warnings: {warn}")
    if part == "stress":
        return {"error": float(np.max(np.abs(num - ref))) / scale, "tol": 1e-2, "note": note}
    return {"error": max(u_err, dev_err), "tol": 1e-2, "note": note}


for _nu in (0.3, 0.45, 0.49, 0.4999):
    case(f"poisson_{_nu:g}", "Poisson ratio", f"nu = {_nu:g}, P2, all stresses")(lambda level, nu=_nu: _cylinder(nu))
for _nu in (0.49, 0.4999):
    case(f"poisson_{_nu:g}_u_deviatoric", "Poisson ratio", f"nu = {_nu:g}, P2, u_r and deviatoric stress")(
        lambda level, nu=_nu: _cylinder(nu, part="deviatoric"))


@case("poisson_0.5", "Poisson ratio", "nu = 0.5", expect=("poisson_ratio", "0.5"))
def _poisson_half(level):
    return _cylinder(0.5)


# -------------------------------------------------------------- stiffness contrast: stacked blocks, contact

def _stack(E_lower: float, E_upper: float, *, d: float = 1e-4, gap: float = 0.0, itype: str = "contact",
           nu: float = 0.25, maxh: float = 0.2) -> dict:
    """Lower block [0, 1] x [0, 0.5] on a roller base, upper block [0, 1] x [0.5 + gap, 0.9 + gap] with its top
    moved by -d, symmetry on x = 0: uniaxial stress in both, p = (d - gap) / ((1 - nu^2) (H1/E1 + H2/E2))."""
    H1, H2 = 0.5, 0.4
    lower = {"name": "lower", "shape": "rectangle", "origin": [0, 0], "size": [1.0, H1], "maxh": 0.15,
             "boundaries": {"base": "ymin", "left": "xmin"}}
    upper = {"name": "upper", "shape": "rectangle", "origin": [0, H1 + gap], "size": [1.0, H2],
             "boundaries": {"top": "ymax", "left": "xmin"}}
    itf = {"name": "itf", "blocks": ["upper", "lower"], "type": itype}
    if gap:
        lower["boundaries"]["lower_top"] = "ymax"
        upper["boundaries"]["upper_base"] = "ymin"
        itf["sides"] = ["upper_base", "lower_top"]
    data = {"scene": {"name": "stack"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": maxh},
            "blocks": [lower, upper], "interfaces": [itf],
            "materials": {"lower": {"youngs_modulus": E_lower, "poisson_ratio": nu},
                          "upper": {"youngs_modulus": E_upper, "poisson_ratio": nu}},
            "boundary_conditions": {"base": {"displacement": ["free", 0.0]}, "left": {"symmetry": True},
                                    "top": {"displacement": ["free", -d]}},
            "output": {"vtk": False, "figures": False}}
    p_ref = max(d - gap, 0.0) / ((1 - nu ** 2) * (H1 / E_lower + H2 / E_upper))
    res = _run(data)
    if itype == "glued":
        pts = [(0.3, 0.25), (0.7, 0.7)]
        syy = [float(np.asarray(res.mechanics.sigma(res.mesh(x, y))).ravel()[4]) for x, y in pts]
        return {"error": _rel(-np.array(syy), p_ref), "tol": 1e-6, "note": f"p_ref {p_ref:.6e} Pa"}
    p = res.mechanics.contact_output.latest[0]["pressure"]
    if p_ref == 0.0:
        g = res.mechanics.contact_output.latest[0]["gap"]
        return {"error": float(np.max(np.abs(p))) / 1e6 + _rel(g, gap - d), "tol": 1e-6,
                "note": f"open: gap {np.min(g):.4e}..{np.max(g):.4e} m (exact {gap - d:.4e})"}
    return {"error": _rel(p, p_ref), "tol": 1e-6, "note": f"p_ref {p_ref:.6e} Pa, nodal p {np.min(p):.6e}.."
                                                        f"{np.max(p):.6e}"}


for _ratio in (1e-6, 1.0, 1e6):
    case(f"contrast_contact_{_ratio:g}", "stiffness contrast", f"E_upper/E_lower = {_ratio:g}, contact")(
        lambda level, r=_ratio: _stack(10e9, 10e9 * r))
# glued: with nu = 0 the blocks' lateral strains vanish, so the stress stays uniaxial across the interface
case("contrast_glued_1e6", "stiffness contrast", "E_upper/E_lower = 1e6, glued, nu = 0")(
    lambda level: _stack(10e9, 10e15, itype="glued", nu=0.0))
case("contrast_glued_1e-6", "stiffness contrast", "E_upper/E_lower = 1e-6, glued, nu = 0")(
    lambda level: _stack(10e9, 10e3, itype="glued", nu=0.0))


# ----------------------------------------------------------------------------- contact gaps and overlaps

case("gap_closes", "gaps and overlaps", "initial gap 1e-4 m, push 3e-4 m")(
    lambda level: _stack(10e9, 10e9, d=3e-4, gap=1e-4))
case("gap_stays_open", "gaps and overlaps", "initial gap 1e-4 m, push 0.5e-4 m")(
    lambda level: _stack(10e9, 10e9, d=0.5e-4, gap=1e-4))
case("gap_contrast_1e6", "gaps and overlaps", "initial gap 1e-4 m, E ratio 1e6")(
    lambda level: _stack(10e9, 10e15, d=3e-4, gap=1e-4))


def _heated_bar(gap: float, dT: float = 60.0) -> dict:
    from ngs_geomech.verification.contact_scenes import heated_bar
    r = heated_bar(gap=gap, dT=dT)
    return {"error": r["p_error"], "tol": 1e-8, "checks": {"imbalance_rel": [r["imbalance_rel"], 1e-8]},
            "note": f"p_ref {r['p_ref']:.6e} Pa"}


case("overlap_foundation_heated", "gaps and overlaps", "foundation 1e-4 m inside the body, heated")(
    lambda level: _heated_bar(-1e-4))
@case("overlap_foundation_cold", "gaps and overlaps", "foundation 1e-4 m inside the body, no heating")
def _overlap_cold(level):
    """Without heating the overlap alone compresses the bar: e_xx = -1e-4, sigma_yy = 0 (free top), plane
    strain, so p = E / (1 - nu^2) 1e-4 at every node."""
    from ngs_geomech.verification.contact_scenes import _compare, heated_bar_scene
    E, nu, overlap = 20e9, 0.25, 1e-4
    p_ref = E / (1 - nu ** 2) * overlap
    r = _compare(heated_bar_scene(gap=-overlap, dT=0.0, E=E, nu=nu), p_ref, 0.0)[0]
    return {"error": r["p_error"], "tol": 1e-8, "checks": {"imbalance_rel": [r["imbalance_rel"], 1e-8]},
            "note": f"p_ref {p_ref:.6e} Pa"}


# ------------------------------------------------------------------ conductivity anisotropy: patch tests

def _kappa(ratio: float, angle_deg: float):
    t = math.radians(angle_deg)
    R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    K = R @ np.diag([ratio, 1.0]) @ R.T
    return tuple(tuple(float(v) for v in row) for row in K)


def _anisotropy(ratio: float, interface: str = "glued", maxh: float = 0.25, order: int = 2) -> dict:
    """Piecewise quadratic steady solution across x = 0.5 with two rotated anisotropic conductivities of
    eigenvalue ratio ``ratio`` (30 and -50 degrees): P2 must reproduce it (patch test). Error: L2 over the
    L2 norm of the exact T."""
    import ngsolve as ngs

    from ngs_geomech.verification import manufactured as mf
    sol = mf.patch_solution(2, _kappa(ratio, 30.0), _kappa(ratio, -50.0))
    mesh, forms, solver = mf.prepare_two_region(mf.two_region_scene(sol, maxh, order, interface, 0.7), sol)
    forms.t_new.Set(0.0)
    solver.solve("anisotropy patch test")
    e0, e1 = mf._errors(mesh, forms.temperature(), sol, forms.t_new, order)
    norm = math.sqrt(sum(float(ngs.Integrate(sol.temperature(r, forms.t_new) ** 2, mesh, order=8,
                                             definedon=mesh.Materials(r))) for r in mf.REGIONS))
    return {"error": e0 / norm, "tol": 1e-8, "note": f"{interface}, P{order}, maxh {maxh}, H1 error {e1:.2e} K, "
                                                     f"|T|_L2 {norm:.3g}"}


for _ratio in (1.0, 1e2, 1e4):
    case(f"anisotropy_glued_{_ratio:g}", "conductivity anisotropy", f"k1/k2 = {_ratio:g}, glued")(
        lambda level, r=_ratio: _anisotropy(r))
case("anisotropy_contact_1e4", "conductivity anisotropy", "k1/k2 = 1e4, contact (mortar)")(
    lambda level: _anisotropy(1e4, "contact"))


# ---------------------------------------------------------------------------- the lambda law: lam 0.3..3

def _lam(lam: float, method: str = "newton") -> dict:
    from ngs_geomech.verification.nonlinear_law import uniaxial_strain_test
    strains = (-1e-3, 3e-3)
    r = uniaxial_strain_test(lam, method, strains=strains, tractions=() if lam > 0.5 else None)
    return {"error": r["max_rel_error"], "tol": 1e-6,
            "note": f"uniaxial strain bar, strains {strains}, {method} iterations <= {r['iterations_max']}"}


for _lam_v in (0.3, 0.5, 1.0, 2.0, 3.0):
    case(f"lam_{_lam_v:g}_newton", "lambda law", f"lam = {_lam_v:g}, Newton")(
        lambda level, v=_lam_v: _lam(v))
for _lam_v in (0.3, 3.0):
    case(f"lam_{_lam_v:g}_secant", "lambda law", f"lam = {_lam_v:g}, secant modules")(
        lambda level, v=_lam_v: _lam(v, "secant"))


@case("lam_0", "lambda law", "lam = 0", expect=("rheology_lambda",))
def _lam_zero(level):
    return _lam(0.0)


@case("lam_-1", "lambda law", "lam = -1", expect=("rheology_lambda",))
def _lam_negative(level):
    return _lam(-1.0)


# ----------------------------------------------------------------- Stefan numbers and time steps vs tau

def _stefan(st_l: float, st_s: float = 0.0, *, h: float, dt_over_tau: float | None = None, steps: int = 40,
            tol: float = 0.03) -> dict:
    """Neumann melting strip (verification/stefan.py), a_l = a_s = 1 m^2/s, k = C = 1, T_L = 1, Theta_R = 0,
    L = 1/St_L (T_S = -St_S/St_L): from s(t0) to s(t1) = 1 m (t0 = t1/4) in ``steps`` steps, or with
    dt = ``dt_over_tau`` h^2/a (the element diffusion time). Error: the front from the melted volume against
    the closed form, relative to s(t1); check: the discrete energy balance."""
    from ngs_geomech.stefan.materials import PhaseChangeMaterial
    from ngs_geomech.verification.stefan import NeumannProblem, neumann_strip
    mat = PhaseChangeMaterial(melting_temperature=0.0, latent_heat=1.0 / st_l, rho_c_solid=1.0, rho_c_liquid=1.0,
                              conductivity_solid=1.0, conductivity_liquid=1.0)
    prob = NeumannProblem(mat, t_hot=1.0, t_cold=-st_s / st_l)
    lam = prob.lam
    t1 = (1.0 / (2 * lam)) ** 2
    t0 = t1 / 4
    tau = h * h
    if dt_over_tau is None:
        dt = (t1 - t0) / steps
    else:
        dt = dt_over_tau * tau
        if dt_over_tau < 1:               # far below: a short run of 40 steps
            t1 = t0 + 40 * dt
        else:                             # far above: start at t0 = dt, run 8 steps
            t0, t1 = dt, 9 * dt
    r = neumann_strip(prob, h, dt, t0, t1, height=2 * h, linear_reference=False)
    err = r["front_error_volume"] / r["front_exact"]
    return {"error": err, "tol": tol, "checks": {"energy_imbalance_rel": [r["energy_imbalance_rel"], 1e-8]},
            "note": f"lam {lam:.4g}, front {r['front_exact']:.4g} m, h {h}, dt/tau {dt / tau:.3g}, "
                    f"{r['steps']} steps, Newton mean {r['newton_mean']:.2f} max {r['newton_max']}"}


for _st in (0.01, 0.1, 1.0, 10.0, 100.0):
    case(f"stefan_{_st:g}", "Stefan number", f"St = {_st:g}, one phase")(
        lambda level, s=_st: _stefan(s, h=LEVELS[level]["stefan_h"]))
for _st in (0.01, 100.0):
    case(f"stefan_two_phase_{_st:g}", "Stefan number", f"St_L = St_S = {_st:g}, two phases")(
        lambda level, s=_st: _stefan(s, s, h=LEVELS[level]["stefan_h"]))
case("stefan_dt_1e-3_tau", "time step vs element diffusion time", "Stefan, St = 1, dt = 1e-3 h^2/a")(
    lambda level: _stefan(1.0, h=0.05, dt_over_tau=1e-3, tol=0.03))
case("stefan_dt_1e3_tau", "time step vs element diffusion time", "Stefan, St = 1, dt = 1e3 h^2/a")(
    lambda level: _stefan(1.0, h=0.01, dt_over_tau=1e3, tol=0.05))


def _heat_dt(scheme: str, dt_over_tau: float) -> dict:
    """Transient two-region manufactured solution (quadratic in space: P2 is exact, the error is the time
    error alone) on maxh = 0.05, tau = h^2 min(rho c / k) ~ 8e-4 s: steps dt and dt/2; error relative to
    max |T|; checks: the observed time order at least the scheme's less 0.35 (for dt >> tau)."""
    from ngs_geomech.verification import manufactured as mf
    h = 0.05
    tau = h * h * min(mf.RHO_C[r] / max(np.linalg.eigvalsh(np.array(k)))
                      for r, k in (("left", mf.K_LEFT), ("right", mf.K_RIGHT)))
    dt = dt_over_tau * tau
    t_end = 4 * dt if dt_over_tau < 1 else min(1.0, 4 * dt)
    dt = min(dt, t_end / 2)
    r = mf.transient_convergence(scheme, [dt, dt / 2], t_end=t_end, order=2, maxh=h)
    expected = 1 if scheme == "backward_euler" else 2
    # the error at dt/2 relative to max |T| ~ 3 K; far above tau the time error of 2-4 steps over one time
    # scale is O(1e-2) (backward Euler), so the tolerance is that of the scheme, and the order is checked
    out = {"error": r["l2"][-1] / 3.0, "tol": 2e-2 if dt_over_tau > 1 else 1e-8,
           "note": f"dt {dt:.3g} s = {dt / tau:.3g} tau, t_end {t_end:.3g} s, errors {r['l2'][0]:.3e}, "
                   f"{r['l2'][1]:.3e}, order {r['order']:.2f}"}
    if dt_over_tau > 1:
        out["checks"] = {"order_shortfall": [expected - r["order"], 0.35]}
    return out


case("heat_dt_1e-4_tau_be", "time step vs element diffusion time", "heat, backward Euler, dt = 1e-4 tau")(
    lambda level: _heat_dt("backward_euler", 1e-4))
case("heat_dt_1e3_tau_be", "time step vs element diffusion time", "heat, backward Euler, dt ~ 1e3 tau")(
    lambda level: _heat_dt("backward_euler", 1e3))
case("heat_dt_1e3_tau_cn", "time step vs element diffusion time", "heat, Crank-Nicolson, dt ~ 1e3 tau")(
    lambda level: _heat_dt("crank_nicolson", 1e3))


# ----------------------------------------------------------------------- friction: g_c and F_c, floating

P_TOP, L_BLOCK, H_BLOCK = 5e6, 1.0, 0.5


def _block(law: str, *, push: float = 0.0, slip_bound: float | None = None, friction: float | None = None,
           displacement: float | None = None, p_top: float = P_TOP) -> dict:
    """A block on a rigid foundation (law ``law``) under the top pressure ``p_top``, pushed by a left traction
    with the resultant ``push`` (N/m) or moved by u_x = ``displacement`` on its left side (held along x by it);
    without a displacement it is held by the contact alone (floating). Returns the foundation's summary."""
    found = {"point": [0, 0], "normal": [0, 1], "law": law}
    if slip_bound is not None:
        found["slip_bound"] = slip_bound
    if friction is not None:
        found["friction"] = friction
    left = ({"displacement": [displacement, "free"]} if displacement is not None
            else {"traction": [push / H_BLOCK, 0.0]})
    data = {"scene": {"name": "block"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.1},
            "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 0], "size": [L_BLOCK, H_BLOCK],
                        "boundaries": {"base": "ymin", "top": "ymax", "left": "xmin"}}],
            "materials": {"block": {"youngs_modulus": 10e9, "poisson_ratio": 0.25}},
            "boundary_conditions": {"base": {"foundation": found}, "top": {"pressure": p_top}, "left": left},
            "output": {"vtk": False, "figures": False}}
    res = _run(data)
    c = res.summary["mechanics"]["contact"]
    return {**c["interfaces"]["base"], "imbalance_rel": c["force_balance"]["imbalance_rel"]}


def _held(law: str, push: float, **kw) -> dict:
    """Stick (at least in part): the friction force balances the push."""
    b = _block(law, push=push, **kw)
    return {"error": abs(abs(b["tangential_force"]) - push) / push, "tol": 1e-8, "nodes": b["nodes"],
            "checks": {"normal_force": [abs(b["normal_force"] - P_TOP * L_BLOCK) / (P_TOP * L_BLOCK), 1e-8]},
            "note": f"friction force {b['tangential_force']:.6e} N/m (push {push:.4e}), nodes {b['nodes']}"}


def _sliding(law: str, capacity: float, **kw) -> dict:
    """Moved by u_x = 1 cm: it slides (the capacity needs a mean strain of at most 1e-3), the friction force
    is the capacity (0 for g_c = 0)."""
    b = _block(law, displacement=1e-2, **kw)
    scale = P_TOP * L_BLOCK
    return {"error": abs(abs(b["tangential_force"]) - capacity) / scale, "tol": 1e-8,
            "note": f"friction force {b['tangential_force']:.6e} N/m (capacity {capacity:.4e}), nodes {b['nodes']}"}


PUSH = 0.5 * 0.3 * P_TOP * L_BLOCK
case("gc_0_sliding", "slip bound g_c", "g_c = 0, moved 1 cm")(lambda level: _sliding("tresca", 0.0, slip_bound=0.0))
case("gc_0_pushed", "slip bound g_c", "g_c = 0, floating, pushed",
     expect=("block", "translation along x", "not held"))(lambda level: _block("tresca", push=PUSH, slip_bound=0.0))
case("gc_5e4_pushed", "slip bound g_c", "g_c = 5e4 Pa, floating, pushed at 0.5 g_c L")(
    lambda level: _held("tresca", 0.25e5, slip_bound=5e4))
case("gc_1e6_pushed", "slip bound g_c", "g_c = 1e6 Pa, pushed at 0.5 g_c L")(
    lambda level: _held("tresca", 0.5e6, slip_bound=1e6))
case("gc_1e6_sliding", "slip bound g_c", "g_c = 1e6 Pa, moved 1 cm")(
    lambda level: _sliding("tresca", 1e6 * L_BLOCK, slip_bound=1e6))


@case("gc_1e15_pushed", "slip bound g_c", "g_c = 1e15 Pa (stick everywhere), pushed")
def _gc_huge(level):
    r = _held("tresca", PUSH, slip_bound=1e15)
    r["checks"]["slip_nodes"] = [float(r["nodes"]["slip"]), 0.0]
    return r


case("fc_0_pushed", "Coulomb F_c", "F_c = 0 in a scene (frictionless), floating, pushed",
     expect=("block", "translation along x", "not held"))(lambda level: _block("coulomb", push=PUSH, friction=0.0))
case("fc_0_sliding", "Coulomb F_c", "F_c = 0 in a scene (frictionless), moved 1 cm")(
    lambda level: _sliding("coulomb", 0.0, friction=0.0))


@case("fc_0_library", "Coulomb F_c", "F_c = 0 (ContactLaw), moved 1 mm", expect=("coulomb", "positive coefficient"))
def _fc_zero_library(level):
    from ngs_geomech.verification.contact_problems import friction_block
    r = friction_block("displacement", law="coulomb", friction=0.0)
    return {"error": abs(r["friction_force"]) / r["load"], "tol": 1e-10,
            "checks": {"normal_force": [abs(r["normal_force"] - r["load"]) / r["load"], 1e-8]},
            "note": f"friction force {r['friction_force']:.3e} N/m, normal {r['normal_force']:.6e}"}


for _fc in (1e-3, 1e-2, 0.1, 0.3, 1.0):
    case(f"fc_{_fc:g}_pushed", "Coulomb F_c", f"F_c = {_fc:g}, floating, pushed at 0.5 F_c p L")(
        lambda level, f=_fc: _held("coulomb", 0.5 * f * P_TOP * L_BLOCK, friction=f))
case("fc_1_sliding", "Coulomb F_c", "F_c = 1, moved 1 cm")(
    lambda level: _sliding("coulomb", P_TOP * L_BLOCK, friction=1.0))
case("fc_1_pushed_0.99", "Coulomb F_c", "F_c = 1, floating, pushed at 0.99 F_c p L")(
    lambda level: _held("coulomb", 0.99 * P_TOP * L_BLOCK, friction=1.0))

case("floating_push_over_capacity", "floating bodies", "pushed at 1.5 F_c p L (F_c = 0.3)",
     expect=("block", "translation along x", "not held"))(
    lambda level: _block("coulomb", push=1.5 * 0.3 * P_TOP * L_BLOCK, friction=0.3))
case("floating_pulled_off", "floating bodies", "top pulled up (tension), frictionless",
     expect=("block", "translation along y", "not held"))(
    lambda level: _block("frictionless", p_top=-1e6, displacement=0.0))


@case("floating_no_contact", "floating bodies", "a loaded block touching no contact",
      expect=("loose", "not held"))
def _floating_no_contact(level):
    """Two separate blocks: 'held' fixed at its base, 'loose' (not touching) under gravity, no support."""
    data = {"scene": {"name": "loose"}, "physics": {"mechanics": "static"}, "mesh": {"maxh": 0.25},
            "blocks": [{"name": "held", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 0.5],
                        "boundaries": {"base": "ymin"}},
                       {"name": "loose", "shape": "rectangle", "origin": [0, 1.0], "size": [1.0, 0.5]}],
            "materials": {n: {"youngs_modulus": 10e9, "poisson_ratio": 0.25, "density": 2700.0}
                          for n in ("held", "loose")},
            "mechanics": {"gravity": [0.0, -9.81]},
            "boundary_conditions": {"base": {"displacement": [0.0, 0.0]}},
            "output": {"vtk": False, "figures": False}}
    _run(data)
    return {"error": 0.0, "tol": 0.0}


@case("floating_solvable_two_blocks", "floating bodies", "upper block held by Coulomb contact only")
def _two_blocks(level):
    from ngs_geomech.verification.contact_problems import two_blocks_coulomb
    r = two_blocks_coulomb(0.1, order=1)
    return {"error": max(r["force_balance_n"], r["force_balance_t"]), "tol": 1e-8,
            "note": f"stick {r['stick']}, slip {r['slip']} nodes, {r['iterations']} iterations"}


# ------------------------------------------------------------------ element shape and mesh size extremes

def _bar(H: float, maxh: float, order: int = 1) -> dict:
    """Uniaxial strain bar (lam = 1) 1 m x H, u_x = 1e-3 m at x = 1 m: the exact displacement is linear,
    so any mesh reproduces it; error: max relative error of sigma_xx, sigma_yy, u_x."""
    from ngs_geomech.verification.elastic_closed_forms import uniaxial_strain_stress
    from ngs_geomech.verification.nonlinear_law import EPS_REF, NU, E, bar_scene
    eps = 1e-3
    res = _run(bar_scene(1.0, end_displacement=eps, H=H, maxh=maxh, order=order))
    sxx, syy = uniaxial_strain_stress(eps, 1.0, E, NU, EPS_REF, 1e-6)
    S = [np.asarray(res.mechanics.sigma(res.mesh(x, 0.5 * H))).ravel() for x in (0.1, 0.5, 0.9)]
    ux = res.mechanics.forms.displacement()(res.mesh(1.0, 0.5 * H))[0]
    err = max(_rel([s[0] for s in S], sxx), _rel([s[4] for s in S], syy), abs(ux - eps) / eps)
    return {"error": err, "tol": 1e-8, "note": f"{res.mesh.ne} elements, max aspect ratio {_aspect(res.mesh):.3g}"}


case("aspect_bar_H1e-3", "high aspect ratio", "bar 1 m x 1 mm, maxh 1 m")(lambda level: _bar(1e-3, 1.0))
case("aspect_bar_H1e-4", "high aspect ratio", "bar 1 m x 0.1 mm, maxh 1 m")(lambda level: _bar(1e-4, 1.0))
case("aspect_bar_H1e-5", "high aspect ratio", "bar 1 m x 10 um, maxh 1 m (netgen fails)",
     expect=("blocks.rock", "could not mesh"))(lambda level: _bar(1e-5, 1.0))
case("coarse_bar", "mesh size", "bar 1 m x 0.25 m, maxh 100 m")(lambda level: _bar(0.25, 100.0))
case("fine_bar", "mesh size", "bar 1 m x 0.25 m, very fine")(
    lambda level: _bar(0.25, LEVELS[level]["fine_h_mech"]))
case("coarse_heat_patch", "mesh size", "two-region heat patch test P2, maxh 10 m")(
    lambda level: _anisotropy(10.0, maxh=10.0))
case("fine_heat_patch", "mesh size", "two-region heat patch test P1, very fine")(
    lambda level: _fine_heat(LEVELS[level]["fine_h"]))


def _fine_heat(h: float) -> dict:
    import ngsolve as ngs

    from ngs_geomech.verification import manufactured as mf
    sol = mf.patch_solution(1, _kappa(10.0, 30.0), _kappa(10.0, -50.0))
    mesh, forms, solver = mf.prepare_two_region(mf.two_region_scene(sol, h, 1, "glued", 0.7), sol)
    forms.t_new.Set(0.0)
    solver.solve("fine patch test")
    e0, _ = mf._errors(mesh, forms.temperature(), sol, forms.t_new, 1)
    norm = math.sqrt(sum(float(ngs.Integrate(sol.temperature(r, forms.t_new) ** 2, mesh, order=4,
                                             definedon=mesh.Materials(r))) for r in mf.REGIONS))
    return {"error": e0 / norm, "tol": 1e-8, "note": f"P1 linear patch, h {h}, {forms.X.ndof} dofs"}


# ---------------------------------------------------------------------------------- geologic and lab scales

SCALES = {"geologic": {"L": 100e3, "t_end": "100000 year", "t_s": 1e5 * 365.25 * 86400.0},
          "laboratory": {"L": 0.01, "t_end": "10 s", "t_s": 10.0}}
FOURIER = 0.01
"""a t_end / L^2 of the scaled heat problem (both scales)."""


def _scaled_heat(scale: str) -> np.ndarray:
    """Strip [0, L] x [0, L/20], T = 100 K on x = 0 from t = 0 (initially 0), insulated elsewhere, backward
    Euler, 100 steps, h = L/100, k = 3 W/(m K), rho c = k t_end / (Fo L^2): T(x/L) at t_end (K)."""
    from scipy.special import erfc
    s = SCALES[scale]
    L, t = s["L"], s["t_s"]
    a = FOURIER * L * L / t
    data = {"scene": {"name": f"heat_{scale}", "temperature_unit": "K"}, "physics": {"thermal": "transient"},
            "mesh": {"maxh": L / 100, "order": 1},
            "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [L, L / 20],
                        "boundaries": {"hot": "xmin"}}],
            "materials": {"rock": {"conductivity": 3.0, "rho_c": 3.0 / a}},
            "boundary_conditions": {"hot": {"temperature": 100.0}},
            "initial": {"temperature": 0.0},
            "time": {"end": s["t_end"], "dt": t / 100, "scheme": "backward_euler"},
            "output": {"vtk": False, "figures": False}}
    res = _run(data)
    xi = np.linspace(0.02, 0.5, 25)
    T = np.asarray(res.forms.temperature()(res.mesh(xi * L, np.full_like(xi, L / 40)))).ravel()
    return T, 100.0 * erfc(xi * L / (2 * math.sqrt(a * t)))


@case("scales_heat", "geologic vs laboratory scale", "heat: 100 km / 1e5 years vs 1 cm / 10 s, Fo = 0.01")
def _scales_heat(level):
    Tg, ref = _scaled_heat("geologic")
    Tl, _ = _scaled_heat("laboratory")
    return {"error": max(float(np.max(np.abs(Tg - ref))) / 100.0,
                         float(np.max(np.abs(Tl - ref))) / 100.0), "tol": 1e-2,
            "checks": {"scaled_difference": [float(np.max(np.abs(Tg - Tl))) / 100.0, 1e-3]},
            "note": f"error vs erfc over x/L in [0.02, 0.5], relative to the face temperature; scaled difference "
                    f"{float(np.max(np.abs(Tg - Tl))) / 100.0:.2e} (the netgen meshes differ slightly)"}


def _column(scale: str) -> tuple[np.ndarray, np.ndarray]:
    """Gravity column (uniaxial strain: symmetry on the sides and base), height H (100 km or 1 cm), width
    H/10, rho = 2700 kg/m^3, E = 1e11 Pa, P2: sigma_yy / (rho g H) at 5 heights (exact: -(1 - y/H))."""
    H = SCALES[scale]["L"]
    data = {"scene": {"name": f"column_{scale}"}, "physics": {"mechanics": "static"},
            "mesh": {"maxh": H / 4, "order": 2},
            "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [H / 10, H],
                        "boundaries": {"sides": ["xmin", "xmax"], "base": "ymin"}}],
            "materials": {"rock": {"youngs_modulus": 1e11, "poisson_ratio": 0.25, "density": 2700.0}},
            "mechanics": {"gravity": [0.0, -9.81]},
            "boundary_conditions": {"sides": {"symmetry": True}, "base": {"symmetry": True}},
            "output": {"vtk": False, "figures": False}}
    res = _run(data)
    ys = np.linspace(0.1, 0.9, 5)
    S = [np.asarray(res.mechanics.sigma(res.mesh(H / 20, y * H))).ravel()[4] for y in ys]
    return np.array(S) / (2700.0 * 9.81 * H), -(1 - ys)


@case("scales_gravity", "geologic vs laboratory scale", "gravity column 100 km (2.6 GPa) vs 1 cm, P2")
def _scales_gravity(level):
    sg, ref = _column("geologic")
    sl, _ = _column("laboratory")
    return {"error": max(float(np.max(np.abs(sg - ref))), float(np.max(np.abs(sl - ref)))), "tol": 1e-8,
            "checks": {"scaled_difference": [float(np.max(np.abs(sg - sl))), 1e-8]},
            "note": "sigma_yy / (rho g H) at 5 heights against -(1 - y/H)"}


@case("scales_contact", "geologic vs laboratory scale", "heated bar between foundations: 100 km vs 1 cm")
def _scales_contact(level):
    from ngs_geomech.verification.contact_scenes import heated_bar
    out = {}
    for scale in ("geologic", "laboratory"):
        L = SCALES[scale]["L"]
        out[scale] = heated_bar(gap=1e-4 * L, L=L, H=0.4 * L, maxh=0.2 * L, E=1e11, dT=1000.0)
    g, lab = out["geologic"], out["laboratory"]
    return {"error": max(g["p_error"], lab["p_error"]), "tol": 1e-8,
            "checks": {"scaled_difference": [abs(g["p_ref"] - lab["p_ref"]) / g["p_ref"], 1e-12],
                       "imbalance_rel": [max(g["imbalance_rel"], lab["imbalance_rel"]), 1e-8]},
            "note": f"p_ref {g['p_ref']:.6e} Pa (both scales)"}


# ------------------------------------------------------------------------------------ running the cases

def _execute(name: str, level: int) -> dict:
    """Run one case in this process: {"kind": "result", ...} or {"kind": "exception", "type", "clear_type",
    "message"}, with "wall_s"."""
    from ngs_geomech.errors import SceneError, SolverError
    c = next(c for c in CASES if c.name == name)
    tic = time.perf_counter()
    try:
        out = {"kind": "result", **c.fn(level)}
    except Exception as exc:   # noqa: BLE001 (every exception is classified)
        out = {"kind": "exception", "type": type(exc).__name__,
               "clear_type": isinstance(exc, (SceneError, SolverError, ValueError)), "message": str(exc),
               "traceback": traceback.format_exc()[-2000:]}
    out["wall_s"] = time.perf_counter() - tic
    return out


def _worker() -> None:
    """The worker loop: one JSON request per line on stdin, one JSON answer per line on the original stdout
    (everything else the cases print goes to stderr)."""
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    import ngsolve as ngs
    ngs.SetNumThreads(1)
    for line in sys.stdin:
        req = json.loads(line)
        proto.write(json.dumps(json_safe(_execute(req["case"], req["level"]))) + "\n")


class _Worker:
    """A worker process running cases one at a time with a wall-time limit (killed and restarted on a hang or
    a crash)."""

    def __init__(self):
        self.proc = None
        self.log = tempfile.TemporaryFile(mode="w+")

    def _start(self):
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--worker"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.log, text=True,
                                     env=env)

    def run(self, name: str, level: int, limit: float) -> dict:
        if self.proc is None or self.proc.poll() is not None:
            self._start()
        tic = time.perf_counter()
        self.proc.stdin.write(json.dumps({"case": name, "level": level}) + "\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], limit)
        if not ready:
            self.stop()
            return {"kind": "timeout", "wall_s": time.perf_counter() - tic}
        line = self.proc.stdout.readline()
        if not line:
            code = self.proc.wait()
            self.proc = None
            return {"kind": "crash", "returncode": code, "wall_s": time.perf_counter() - tic}
        return json.loads(line)

    def stop(self):
        if self.proc is not None:
            if self.proc.poll() is None:
                self.proc.kill()
            self.proc.wait()
            self.proc = None


def classify(c: Case, out: dict, limit: float = TIME_LIMIT_S) -> dict:
    """The row of the case table: outcome, error, tolerance, wall time, message excerpt."""
    row = {"case": c.name, "group": c.group, "parameter": c.parameter, "outcome": "nan_or_hang", "error": None,
           "tol": None, "wall_s": out.get("wall_s"), "message": ""}
    kind = out["kind"]
    if kind == "timeout":
        row["message"] = f"exceeded the time limit of {limit:g} s"
    elif kind == "crash":
        row["message"] = f"the process died (exit status {out['returncode']})"
    elif kind == "exception":
        msg = out["message"]
        row["message"] = " ".join(msg.split())[:240]
        if not c.expect:
            row["message"] = f"unexpected {out['type']}: " + row["message"]
        elif not out["clear_type"]:
            row["message"] = f"{out['type']} (not a SceneError/SolverError/ValueError): " + row["message"]
        elif not all(f.lower() in msg.lower() for f in c.expect):
            row["message"] = f"vague: the message lacks {list(c.expect)}: " + row["message"]
        else:
            row["outcome"] = "clear_error"
    else:
        row["error"], row["tol"] = out.get("error"), out.get("tol")
        checks = out.get("checks", {})
        row["checks"] = checks
        values = [row["error"]] + [v for v, _ in checks.values()]
        bad = [k for k, (v, lim) in checks.items() if v is None or not math.isfinite(v) or v > lim]
        note = out.get("note", "")
        if c.expect:
            row["message"] = f"ran to the end where a stop naming {list(c.expect)} was expected; {note}"
        elif any(v is None or not math.isfinite(v) for v in values):
            row["message"] = f"NaN or inf in the result; {note}"
        elif row["error"] > row["tol"] or bad:
            too_big = row["error"] > row["tol"]
            row["message"] = (f"inaccurate: error {row['error']:.3g} > tol {row['tol']:.3g}" if too_big
                              else f"check(s) failed: {bad}") + f"; {note}"
        else:
            row["outcome"] = "accurate"
            row["message"] = note
    return row


def run_cases(names=None, level: int = 0, limit: float = TIME_LIMIT_S) -> list[dict]:
    """Run the named cases (default all) each in the worker process with the wall-time limit; the rows."""
    cases = [c for c in CASES if names is None or c.name in names]
    if names is not None:
        missing = set(names) - {c.name for c in cases}
        if missing:
            raise ValueError(f"unknown cases: {sorted(missing)}")
    worker = _Worker()
    rows = []
    try:
        for c in cases:
            rows.append(classify(c, worker.run(c.name, level, limit), limit))
    finally:
        worker.stop()
    return rows


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the case rows (for the report)."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    tic = time.perf_counter()
    rows = run_cases(level=level)
    counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    metrics = {"cases_total": len(rows), "cases_accurate": counts["accurate"],
               "cases_clear_error": counts["clear_error"], "cases_nan_or_hang": counts["nan_or_hang"]}
    timing = {"total_s": time.perf_counter() - tic,
              "cases_s": float(sum(r["wall_s"] or 0.0 for r in rows)),
              "slowest_case_s": float(max(r["wall_s"] or 0.0 for r in rows))}
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": [], "timing_s": timing,
              "time_limit_s": TIME_LIMIT_S, "cases": json_safe(rows)}
    return result, {"rows": rows}


def table(rows) -> list[str]:
    lines = [f"{'case':30} {'parameter':52} {'outcome':12} {'error':>9} {'tol':>7} {'wall s':>6}  message"]
    for r in rows:
        err = "-" if r["error"] is None else f"{r['error']:9.2e}"
        tol = "-" if r["tol"] is None else f"{r['tol']:7.0e}"
        wall = "-" if r["wall_s"] is None else f"{r['wall_s']:6.2f}"
        lines.append(f"{r['case']:30} {r['parameter'][:52]:52} {r['outcome']:12} {err:>9} {tol:>7} {wall:>6}  "
                     f"{r['message'][:110]}")
    return lines


def report(result: dict) -> str:
    return "\n".join([f"study {result['study']}, level {result['level']}", ""] + table(result["cases"])
                     + metrics_lines(result, width=20))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1 finer 'very fine' meshes); write ``out/results.json``."""
    return study_main(run, level, out)


if __name__ == "__main__":
    if "--worker" in sys.argv:
        _worker()
    else:
        study_cli(__doc__, run, report)
