"""Verification of the nonlinear lambda law (seed (2.1)-(2.5)) and of its two solvers, the secant modules
method (2.32)-(2.34) with the convergence quantity (2.35) and Newton on the energy.

The law (:mod:`ngs_geomech.mechanics.forms`): sigma = lam (A1/A_ref + delta)^(lam-1) C e with A1 = e.C.e,
A_ref = eps_ref^2 C[0, 0], energy W = (A_ref/2)((A1/A_ref + delta)^lam - delta^lam). Rock-like data by
default: E = 10 GPa, nu = 0.25, eps_ref = 1e-3, plane strain.

* :func:`uniaxial_strain_test`: a bar 0 < x < L, 0 < y < H with u_x = 0 at x = 0, u_y = 0 on y = 0 and y = H
  (symmetry) and at x = L either u_x = eps L (the strain is then homogeneous for every law) or the traction
  sigma_xx = P (the strain solves sigma_xx(eps) = P): uniaxial strain, compared with the closed forms of
  :mod:`ngs_geomech.verification.elastic_closed_forms` (sigma_xx, sigma_yy, the strain), run through the scene
  path (scene dict -> :func:`ngs_geomech.api.run`).
* :func:`secant_vs_newton`: a genuinely inhomogeneous problem, a quarter of a 2 m x 2 m plate with a hole of
  radius 0.3 m (symmetry on x = 0 and y = 0, hole and top free) stretched by u_x = 3 mm on x = 1 m (a mean
  strain of 3 eps_ref), solved by both methods on a sequence of meshes: iteration counts, wall times, the
  relative H1 change per iteration (2.35), the observed contraction rate, the difference of the solutions.
  Also the plain secant iteration (relaxation 1, the seed's (2.32) as it stands) and Newton with the exact
  Hessian, for comparison with the defaults (energy line search, primal-dual tangent for lam < 1).
* :func:`regularization_effect`: the same plate for lam < 1 and delta from 1e-2 down to 1e-10: the change of
  the solution (relative H1 difference to the smallest-delta solution), of the reaction force and of a local
  stress, and the iteration counts.

All functions return plain dicts (numbers and lists) and print nothing.
"""

from __future__ import annotations

import dataclasses
import math
import time

import ngsolve as ngs
import numpy as np

from .. import api
from ..errors import SolverError
from ..mechanics.forms import ElasticForms
from ..mechanics.solver import ElasticSolver, h1_norm
from ..scene.parse import scene_from_dict
from .elastic_closed_forms import lame_constants, uniaxial_strain_from_stress, uniaxial_strain_stress

E, NU, EPS_REF = 10e9, 0.25, 1e-3
"""Default Young's modulus (Pa), Poisson ratio and reference strain of the lambda law."""
DEFAULT_STRAINS = (-5e-3, -1e-3, -1e-5, 1e-6, 1e-4, 1e-3, 3e-3, 1e-2)
"""Strains of the uniaxial stress-strain curve: compression and tension, from below the regularization scale
eps_ref sqrt(delta) = 1e-6 up to 10 eps_ref."""
PLATE = {"R": 0.3, "W": 1.0, "d": 3e-3}
"""Quarter plate with a hole: hole radius R (m), quarter size W x W (m), prescribed u_x = d (m) at x = W."""


# ------------------------------------------------------------------------------------------------ scenes

def _material(lam: float, E_: float, nu: float, eps_ref: float) -> dict:
    return {"youngs_modulus": E_, "poisson_ratio": nu, "rheology_lambda": lam, "reference_strain": eps_ref}


def _mechanics(method: str, tol: float, maxit: int, delta: float) -> dict:
    return {"nonlinear_solver": method, "tolerance": tol, "max_iterations": maxit, "regularization": delta}


def bar_scene(lam: float, method: str = "newton", *, end_displacement: float | None = None,
              end_traction: float | None = None, L: float = 1.0, H: float = 0.25, maxh: float = 0.125,
              order: int = 1, delta: float = 1e-6, tol: float = 1e-10, maxit: int = 200, E: float = E,
              nu: float = NU, eps_ref: float = EPS_REF) -> dict:
    """Scene dict of the uniaxial strain bar (plane strain, lengths in m, traction in Pa): u_x = 0 on
    ``left`` (x = 0), symmetry on ``bottom`` and ``top``, and on ``right`` (x = L) u_x = ``end_displacement``
    or the traction (``end_traction``, 0)."""
    if (end_displacement is None) == (end_traction is None):
        raise ValueError("give exactly one of end_displacement and end_traction")
    right = ({"displacement": [end_displacement, "free"]} if end_displacement is not None
             else {"traction": [end_traction, 0.0]})
    return {
        "scene": {"name": "uniaxial_strain_bar", "dimension": "plane"},
        "physics": {"mechanics": "static", "plane_model": "plane_strain"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0.0, 0.0], "size": [L, H],
                    "boundaries": {"left": "xmin", "right": "xmax", "bottom": "ymin", "top": "ymax"}}],
        "materials": {"rock": _material(lam, E, nu, eps_ref)},
        "boundary_conditions": {"left": {"displacement": [0.0, "free"]}, "right": right,
                                "bottom": {"symmetry": True}, "top": {"symmetry": True}},
        "mechanics": _mechanics(method, tol, maxit, delta),
        "output": {"vtk": False, "figures": False},
    }


def plate_scene(lam: float, h: float, method: str = "newton", *, delta: float = 1e-6, tol: float = 1e-8,
                maxit: int = 200, order: int = 1, E: float = E, nu: float = NU, eps_ref: float = EPS_REF) -> dict:
    """Scene dict of the quarter plate with a hole (:data:`PLATE`), plane strain, mesh size ``h`` (m); the
    hole is a spline through 7 points of the circle (the comparisons are between solvers and deltas on one
    mesh, so the geometry need not be exact)."""
    R, W, d = PLATE["R"], PLATE["W"], PLATE["d"]
    arc = [[R * math.cos(t), R * math.sin(t)] for t in np.linspace(math.pi / 2, 0.0, 7)[1:]]
    return {
        "scene": {"name": "plate_with_hole", "dimension": "plane"},
        "physics": {"mechanics": "static", "plane_model": "plane_strain"},
        "mesh": {"maxh": h, "order": order},
        "blocks": [{"name": "rock", "shape": "profile", "start": [R, 0.0], "segments": [
            {"line": [W, 0.0], "name": "bottom"}, {"line": [W, W], "name": "right"},
            {"line": [0.0, W], "name": "top"}, {"line": [0.0, R], "name": "left"},
            {"spline": [[float(a), float(b)] for a, b in arc], "name": "hole"}]}],
        "materials": {"rock": _material(lam, E, nu, eps_ref)},
        "boundary_conditions": {"right": {"displacement": [d, "free"]}, "bottom": {"symmetry": True},
                                "left": {"symmetry": True}},
        "mechanics": _mechanics(method, tol, maxit, delta),
        "output": {"vtk": False, "figures": False},
    }


# ------------------------------------------------------------------------------------------------ helpers

def contraction_rate(changes) -> float:
    """Observed contraction rate of a linearly converging sequence of changes: the geometric mean of the
    ratios c_{k+1}/c_k over the second half of the iterations (NaN with fewer than 3 changes)."""
    c = [float(v) for v in changes]
    n = len(c)
    if n < 3 or min(c) <= 0:
        return math.nan
    m = n // 2 if n - 1 - n // 2 >= 2 else 0
    return float((c[-1] / c[m]) ** (1.0 / (n - 1 - m)))


def _rel_diff(a, b, mesh) -> float:
    """||a - b||_1 / ||a||_1 of two GridFunctions on one space."""
    d = ngs.GridFunction(a.space)
    d.vec.data = a.vec - b.vec
    return h1_norm(d, mesh) / max(h1_norm(a, mesh), 1e-300)


def _copy(u):
    g = ngs.GridFunction(u.space)
    g.vec.data = u.vec
    return g


def _solve(forms: ElasticForms, method: str, tol: float, maxit: int, **kw) -> dict:
    """Solve from zero with a fresh ElasticSolver (outside any TaskManager: comparable wall times); returns
    the history and a copy of the solution (None when the solver raised)."""
    forms.gf.vec[:] = 0.0
    solver = ElasticSolver(forms, method=method, tol=tol, maxit=maxit, **kw)
    tic = time.perf_counter()
    try:
        info = solver.solve(method)
    except SolverError as exc:
        return {"converged": False, "iterations": maxit, "wall_s": time.perf_counter() - tic, "changes": [],
                "rate": math.nan, "steps": [], "residuals": [], "error": str(exc), "u": None}
    return {"converged": True, "iterations": info.iterations, "wall_s": info.wall_s,
            "changes": [float(c) for c in info.changes], "rate": contraction_rate(info.changes),
            "steps": [float(s) for s in info.steps], "residuals": [float(r) for r in info.residuals],
            "line_search_evaluations": info.line_search_evaluations, "factorizations": solver.factorizations,
            "u": _copy(forms.displacement())}


def _with(forms: ElasticForms, **changes) -> ElasticForms:
    """New forms on the same mesh with changed setup fields (``lam`` changes every region's exponent)."""
    setup = forms.setup
    if "lam" in changes:
        lam = changes.pop("lam")
        setup = dataclasses.replace(setup, props={k: dataclasses.replace(p, lam=lam)
                                                  for k, p in setup.props.items()})
    return ElasticForms(forms.mesh, dataclasses.replace(setup, **changes))


def _reaction(forms: ElasticForms, u) -> float:
    """Reaction force (N per m of depth) on the loaded edge x = W of the plate, int sigma_xx ds, computed by
    virtual work with the field phi = (x/W, 0) (1 on x = W, 0 on x = 0, phi.n = 0 on y = 0, the hole and the
    top are free): (1/W) int sigma_xx dx."""
    sig = forms.stress_tensor(u)
    return float(ngs.Integrate(sig[0, 0], forms.mesh)) / PLATE["W"]


# ------------------------------------------------------------------------------------ 1. uniaxial strain

def uniaxial_strain_test(lam: float, method: str = "newton", strains=DEFAULT_STRAINS, *, tractions=None,
                         L: float = 1.0, H: float = 0.25, maxh: float = 0.125, order: int = 1,
                         delta: float = 1e-6, tol: float = 1e-10, E: float = E, nu: float = NU,
                         eps_ref: float = EPS_REF) -> dict:
    """The uniaxial strain bar (:func:`bar_scene`) against the closed forms, for each strain of ``strains``
    (prescribed u_x = eps L at x = L) and, when lam > 1/2 (the closed-form inverse exists), each traction of
    ``tractions`` (Pa; default: the closed-form sigma_xx of ``strains``, so the traction runs must recover the
    strains). Sampled at (x, H/2) for x = 0.1 L, 0.5 L, 0.9 L (sigma) and u_x at (L, H/2).

    Returns {"lam", "method", "delta", "displacement": rows, "traction": rows, "max_rel_error_sxx",
    "max_rel_error_syy", "max_rel_error_strain", "max_rel_error", "iterations_max", "wall_s"}; a row holds
    the load, the exact and computed strain, sigma_xx, sigma_yy (Pa), their relative errors, the nonlinear
    iterations and the solve time (s)."""
    xs = (0.1 * L, 0.5 * L, 0.9 * L)
    rows_d, rows_t = [], []
    tic = time.perf_counter()

    def run(scene: dict, eps_exact: float, load: dict) -> dict:
        res = api.run(scene_from_dict(scene), None, progress=False)
        mech, mesh = res.mechanics, res.mesh
        sxx_ex, syy_ex = uniaxial_strain_stress(eps_exact, lam, E, nu, eps_ref, delta)
        sig = [mech.sigma(mesh(x, 0.5 * H)) for x in xs]
        sxx = [s[0] for s in sig]
        syy = [s[4] for s in sig]
        eps_fe = mech.forms.displacement()(mesh(L, 0.5 * H))[0] / L
        err_xx = max(abs(v - sxx_ex) for v in sxx) / abs(sxx_ex)
        err_yy = max(abs(v - syy_ex) for v in syy) / abs(syy_ex)
        info = mech.solver.history[-1]
        return {**load, "strain_exact": float(eps_exact), "strain": float(eps_fe),
                "rel_error_strain": abs(eps_fe - eps_exact) / abs(eps_exact),
                "sigma_xx_exact": float(sxx_ex), "sigma_xx": float(sxx[1]), "rel_error_sxx": float(err_xx),
                "sigma_yy_exact": float(syy_ex), "sigma_yy": float(syy[1]), "rel_error_syy": float(err_yy),
                "iterations": info.iterations, "solve_s": info.wall_s}

    common = {"L": L, "H": H, "maxh": maxh, "order": order, "delta": delta, "tol": tol, "E": E, "nu": nu,
              "eps_ref": eps_ref}
    for eps in strains:
        rows_d.append(run(bar_scene(lam, method, end_displacement=eps * L, **common), eps,
                          {"end_displacement": float(eps * L)}))
    if lam > 0.5:
        if tractions is None:
            tractions = [float(uniaxial_strain_stress(eps, lam, E, nu, eps_ref, delta)[0]) for eps in strains]
        for P in tractions:
            eps = uniaxial_strain_from_stress(P, lam, E, nu, eps_ref, delta)
            rows_t.append(run(bar_scene(lam, method, end_traction=P, **common), eps, {"end_traction": float(P)}))
    rows = rows_d + rows_t
    out = {"lam": lam, "method": method, "delta": delta, "E": E, "nu": nu, "eps_ref": eps_ref,
           "lame": lame_constants(E, nu), "displacement": rows_d, "traction": rows_t,
           "max_rel_error_sxx": max(r["rel_error_sxx"] for r in rows),
           "max_rel_error_syy": max(r["rel_error_syy"] for r in rows),
           "max_rel_error_strain": max(r["rel_error_strain"] for r in rows),
           "iterations_max": max(r["iterations"] for r in rows),
           "wall_s": time.perf_counter() - tic}
    out["max_rel_error"] = max(out["max_rel_error_sxx"], out["max_rel_error_syy"], out["max_rel_error_strain"])
    return out


# ------------------------------------------------------------------------------ 2. secant versus Newton

def _method_table(runs: list[dict]) -> dict:
    keys = ("converged", "iterations", "wall_s", "rate", "changes", "steps", "residuals")
    return {k: [r.get(k) for r in runs] for k in keys}


METHODS = {"newton": ("newton", {}), "secant": ("secant", {}),
           "secant_plain": ("secant", {"relaxation": 1.0}), "newton_exact_hessian": ("newton", {"primal_dual": False})}
"""The solver variants of :func:`secant_vs_newton`: the defaults (Newton with the primal-dual tangent for
lam < 1, the secant modules method with the energy line search), the plain secant iteration (2.32) (fixed
relaxation 1) and Newton with the exact Hessian."""


def secant_vs_newton(lam: float, hs=(0.1, 0.05), tol: float = 1e-8, *, delta: float = 1e-6, order: int = 1,
                     maxit: int = 3000, methods=("newton", "secant", "secant_plain", "newton_exact_hessian"),
                     variant_maxit: int = 200) -> dict:
    """The plate with a hole (:func:`plate_scene`) solved by Newton and by the secant modules method, both
    from the linear elastic solution with tolerance ``tol`` on the relative H1 change (2.35), on each mesh
    size of ``hs`` (m). The scene runs once per mesh through :func:`ngs_geomech.api.run` (mesh, forms, a
    Newton solve); then every method of ``methods`` (keys of :data:`METHODS`) solves again from zero on
    those forms, timed alone (at most ``maxit`` iterations, ``variant_maxit`` for "secant_plain").

    Returns {"lam", "tol", "delta", "h", "ndof", and per method a dict of lists over h: "converged",
    "iterations", "wall_s", "rate" (observed contraction, :func:`contraction_rate`), "changes" (the (2.35)
    sequence ||u_{n+1} - u_n||_1 / ||u_{n+1}||_1), "steps" (line search), "residuals"; with both "newton" and
    "secant": "difference_h1" = ||u_newton - u_secant||_1 / ||u_newton||_1 and the reaction forces
    "reaction_newton", "reaction_secant" (N/m) per h; "rate_bound_plain" = 2|1 - lam| (the contraction bound
    of the plain secant iteration) and "rate_optimal_relaxation" = |1 - lam|/lam (the best fixed
    relaxation 1/lam, which the line search attains)}."""
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"unknown methods {unknown}; choose from {sorted(METHODS)}")
    runs = {k: [] for k in methods}
    ndof, diff, reac_n, reac_s = [], [], [], []
    for h in hs:
        res = api.run(scene_from_dict(plate_scene(lam, h, delta=delta, tol=tol, order=order)), None,
                      progress=False)
        forms = res.mechanics.forms
        ndof.append(int(forms.X.ndof))
        for key in methods:
            method, kw = METHODS[key]
            runs[key].append(_solve(forms, method, tol, variant_maxit if key == "secant_plain" else maxit, **kw))
        if "newton" in runs and "secant" in runs:
            un, us = runs["newton"][-1]["u"], runs["secant"][-1]["u"]
            ok = un is not None and us is not None
            diff.append(_rel_diff(un, us, forms.mesh) if ok else math.nan)
            reac_n.append(_reaction(forms, un) if un is not None else math.nan)
            reac_s.append(_reaction(forms, us) if us is not None else math.nan)
    out = {"lam": lam, "tol": tol, "delta": delta, "order": order, "h": [float(h) for h in hs], "ndof": ndof,
           "rate_bound_plain": 2 * abs(1 - lam), "rate_optimal_relaxation": abs(1 - lam) / lam}
    if diff:
        out.update(difference_h1=diff, reaction_newton=reac_n, reaction_secant=reac_s)
    for key, rs in runs.items():
        out[key] = _method_table(rs)
    return out


# ------------------------------------------------------------------------------ 3. the regularization delta

def regularization_effect(lam: float, deltas=(1e-2, 1e-4, 1e-6, 1e-8, 1e-10), *, h: float = 0.05,
                          order: int = 1, tol: float = 1e-8, secant: bool = False, secant_maxit: int = 300,
                          exact_hessian: bool = True, maxit: int = 200) -> dict:
    """The plate with a hole for exponent ``lam`` and each regularization delta of ``deltas``, all on one
    mesh (size ``h``): Newton (primal-dual tangent) iterations, Newton with the exact Hessian (if
    ``exact_hessian``) and the secant method (if ``secant``, at most ``secant_maxit`` iterations, with the
    relative H1 difference of its solution to Newton's), and the effect on the solution: relative H1
    difference to the smallest-delta solution, the reaction force on x = W (N/m) and its relative change,
    sigma_xx at the top of the hole (Pa) and its relative change, and the area fraction where
    A1/A_ref < 100 delta (the "rigid" zones of a localized solution). Returns {"lam", "h", "ndof", "deltas",
    "rows": one dict per delta}."""
    deltas = [float(d) for d in deltas]
    base = api.run(scene_from_dict(plate_scene(1.0, h, tol=tol, order=order)), None, progress=False)
    mesh = base.mechanics.forms.mesh
    R = PLATE["R"]
    point = mesh(1e-3, R + 1e-3)
    area = float(ngs.Integrate(ngs.CoefficientFunction(1.0), mesh))
    rows, sols = [], []
    for d in deltas:
        forms = _with(base.mechanics.forms, lam=lam, regularization=d)
        newton = _solve(forms, "newton", tol, maxit)
        row = {"delta": d, "newton_converged": newton["converged"], "newton_iterations": newton["iterations"],
               "newton_wall_s": newton["wall_s"]}
        if exact_hessian:
            ex = _solve(forms, "newton", tol, maxit, primal_dual=False)
            row.update(newton_exact_hessian_converged=ex["converged"], newton_exact_hessian_iterations=ex["iterations"],
                       newton_exact_hessian_wall_s=ex["wall_s"])
        u = newton["u"]
        if secant:
            se = _solve(forms, "secant", tol, secant_maxit)
            row.update(secant_converged=se["converged"], secant_iterations=se["iterations"],
                       secant_rate=se["rate"], secant_wall_s=se["wall_s"],
                       secant_newton_difference_h1=(_rel_diff(u, se["u"], mesh) if u is not None
                                                    and se["u"] is not None else math.nan))
        if u is None:
            rows.append(row)
            sols.append(None)
            continue
        e = forms.strain_vector(u)
        p = forms.setup.props["rock"]
        a = ngs.InnerProduct(e, forms.cf_matrix(forms.D["rock"]) * e) / p.A_ref
        row.update(reaction=_reaction(forms, u), sigma_xx_hole_top=float(forms.stress_tensor(u)[0, 0](point)),
                   rigid_fraction=float(ngs.Integrate(ngs.IfPos(100 * d - a, 1.0, 0.0), mesh)) / area)
        rows.append(row)
        sols.append(u)
    ref = sols[-1]
    ref_row = rows[-1]
    for row, u in zip(rows, sols):
        if u is None or ref is None:
            row.update(rel_h1_to_smallest=math.nan, reaction_rel_change=math.nan, sigma_rel_change=math.nan)
            continue
        row["rel_h1_to_smallest"] = _rel_diff(ref, u, mesh)
        row["reaction_rel_change"] = abs(row["reaction"] - ref_row["reaction"]) / abs(ref_row["reaction"])
        row["sigma_rel_change"] = (abs(row["sigma_xx_hole_top"] - ref_row["sigma_xx_hole_top"])
                                   / abs(ref_row["sigma_xx_hole_top"]))
    return {"lam": lam, "h": h, "order": order, "tol": tol, "ndof": int(base.mechanics.forms.X.ndof),
            "deltas": deltas, "rows": rows}
