"""Verification of thermo-elasticity: closed forms and manufactured solutions, run through the package's path
(scene dict -> :func:`validate` -> :func:`make_mesh` -> :func:`heat_setup` / :class:`HeatForms` ->
:func:`elastic_setup` / :class:`ElasticForms` -> :class:`ElasticSolver`; the cylinders through
:func:`ngs_geomech.api.run`).

Seed (J. Nedoma 2001): problem (P) (2.17)-(2.22) without contact, with the stress law (2.18)/(2.37)
tau_ij = c_ijkl e_kl(u) - beta_ij (T - T0), beta_ij = c_ijkl alpha_kl, c symmetric positive definite (2.38),
equilibrium -div tau = f, prescribed displacements (2.20) and symmetry u_n = 0, tau_t = 0 (2.16).

1. :func:`cylinder`: thick-walled cylinder a < r < b with free surfaces, steady temperature from the thermal
   solve (Ti at r = a, 0 at r = b), against the closed forms of
   :mod:`ngs_geomech.verification.elastic_closed_forms` (verification.md section 4): a plane strain quarter
   ring with symmetry conditions on the two straight edges, an axisymmetric (r, z) section with u_z = 0 on
   z = 0 and z = L (plane strain), and an axisymmetric long cylinder with free ends (generalized plane strain
   far from the end).
2. :func:`manufactured`: plane strain thermo-elasticity on the unit square split at x = 0.5 into two regions
   with different anisotropic stiffnesses and thermal expansion tensors; the temperature is the thermal
   solve's solution; exact body force and Dirichlet data; L2 and H1 errors and orders for P1, P2.
3. :func:`near_incompressible`: plane strain without temperature at nu = 0.3 and nu = 0.4999: P1 locking.
4. :func:`incompressible_cylinder`: the thick-walled cylinder (plane strain quarter ring or axisymmetric section)
   under an internal pressure (Lame) or the thermal load, at any nu < 1/2, with the displacement or the mixed
   displacement-pressure formulation: errors of u_r, sigma_r, sigma_theta, sigma_z and the mean stress.

Units: lengths m, displacements m, stresses and moduli Pa, temperatures K, alpha in 1/K. In 2D the L2 norm
of u is in m^2 (m per m of depth: the integral over the area), the H1 seminorm of u in m.

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import functools
import math
import time

import ngsolve as ngs
import numpy as np

from ..api import run as run_scene
from ..fem.coefficients import Steady
from ..geometry.mesh import make_mesh
from ..heat.forms import HeatForms
from ..heat.problem import heat_setup
from ..heat.solver import HeatSolver
from ..mechanics.forms import ElasticForms
from ..mechanics.materials import plane_strain, rotate_voigt, rotation, transversely_isotropic
from ..mechanics.problem import elastic_setup
from ..mechanics.solver import ElasticSolver
from ..scene.parse import scene_from_dict
from ..validation.validate import validate
from .elastic_closed_forms import cylinder_pressure_stresses, cylinder_thermal_stresses
from .manufactured import observed_order

# ------------------------------------------------------------------------------------------------------------
# 1. Thick-walled cylinder
# ------------------------------------------------------------------------------------------------------------

CYLINDER = {"a": 1.0, "b": 2.0, "Ti": 100.0, "E": 70e9, "nu": 0.25, "alpha": 8e-6}
"""Reference data (verification.md section 4): radii (m), inner temperature (K; outer 0, stress free at 0),
E (Pa), nu, alpha (1/K)."""
CYLINDER_CASES = ("plane_strain", "axisymmetric", "free_ends")
CYLINDER_LEVELS = {0: (0.2, 0.1, 0.05), 1: (0.2, 0.1, 0.05, 0.025), 2: (0.1, 0.05, 0.025, 0.0125)}
"""Mesh sizes (m) per level; the error at the last (finest) is the level's result."""
AXI_LENGTH = 0.5
"""Height L (m) of the axisymmetric section with u_z = 0 on z = 0 and z = L."""
FREE_LENGTH = 12.0
"""Half length (m) of the free-ended cylinder (symmetry at z = 0, free end at z = L): 12 wall thicknesses
(with L = 8 m the end effect left a floor of 3e-4 in the relative error at h = 0.0125)."""
FREE_SAMPLE_Z = (0.0, 0.5, 1.0)
"""Heights (m) where the free-ended cylinder is compared, at least 11 wall thicknesses from the free end (the
end disturbance decays, oscillating, like exp(-k d) at the distance d from the end, k ~ (3 (1 - nu^2))^(1/4) /
sqrt(R t) = 1.06 1/m by the shell estimate with R = 1.5 m, t = 1 m: exp(-11.7) = 8e-6 at d = 11 m)."""
SAMPLE_FRACTIONS = np.linspace(0.002, 0.998, 41)
"""Sample radii r = a + s (b - a): 41 points, just inside the surfaces (the curved quarter ring's
approximate boundary need not contain the exact one)."""
ARC_POINTS = 17
"""Points of the OCC splines through which the quarter ring's arcs are drawn (the arcs are not exact circles)."""
RING_ANGLES = (0.1, 0.45, 0.8, 1.15, 1.47)
"""Polar angles (rad) of the sampled rays of the quarter ring."""


def _cylinder_scene(case: str, h: float, order: int):
    c = CYLINDER
    a, b = c["a"], c["b"]
    material = {"conductivity": 1.0, "youngs_modulus": c["E"], "poisson_ratio": c["nu"],
                "thermal_expansion": c["alpha"], "stress_free_temperature": 0.0}
    bcs = {"inner": {"temperature": c["Ti"]}, "outer": {"temperature": 0.0}}
    if case == "plane_strain":
        arc = np.linspace(0.0, math.pi / 2, ARC_POINTS)
        block = {"name": "wall", "shape": "profile", "start": [a, 0.0], "segments": [
            {"line": [b, 0.0], "name": "sym_x"},
            {"spline": [[b * math.cos(t), b * math.sin(t)] for t in arc[1:]], "name": "outer"},
            {"line": [0.0, a], "name": "sym_y"},
            {"spline": [[a * math.cos(t), a * math.sin(t)] for t in arc[::-1][1:]], "name": "inner"}]}
        bcs.update({"sym_x": {"symmetry": True}, "sym_y": {"symmetry": True}})
        dimension = "plane"
    else:
        length = AXI_LENGTH if case == "axisymmetric" else FREE_LENGTH
        bnd = {"inner": "xmin", "outer": "xmax", "bottom": "ymin", "top": "ymax"}
        block = {"name": "wall", "shape": "rectangle", "origin": [a, 0.0], "size": [b - a, length],
                 "boundaries": bnd}
        bcs["bottom"] = {"symmetry": True}
        if case == "axisymmetric":
            bcs["top"] = {"symmetry": True}
        dimension = "axisymmetric"
    data = {"scene": {"name": f"cylinder_{case}", "dimension": dimension, "temperature_unit": "K"},
            "physics": {"thermal": "steady", "mechanics": "static", "plane_model": "plane_strain"},
            "mesh": {"maxh": h, "order": order}, "blocks": [block], "materials": {"wall": material},
            "boundary_conditions": bcs, "output": {"vtk": False, "figures": False}}
    return scene_from_dict(data, source=f"cylinder_{case}")


def _sample_cylinder(case: str, mesh, sigma):
    """(r, sigma_r, sigma_theta, sigma_z) in m and Pa at the sample points of ``case``."""
    c = CYLINDER
    rs = c["a"] + (c["b"] - c["a"]) * SAMPLE_FRACTIONS
    out = []
    if case == "plane_strain":
        for th in RING_ANGLES:
            pts = mesh(rs * math.cos(th), rs * math.sin(th))
            if np.any(pts["nr"] < 0):
                raise RuntimeError(f"cylinder sample points at angle {th} outside the mesh")
            S = np.asarray(sigma(pts)).reshape(-1, 3, 3)
            cs, sn = math.cos(th), math.sin(th)
            er, et = np.array([cs, sn, 0.0]), np.array([-sn, cs, 0.0])
            out.append((rs, np.einsum("i,nij,j->n", er, S, er), np.einsum("i,nij,j->n", et, S, et), S[:, 2, 2]))
    else:
        zs = (0.0, 0.5 * AXI_LENGTH, AXI_LENGTH) if case == "axisymmetric" else FREE_SAMPLE_Z
        for z in zs:
            pts = mesh(rs, np.full_like(rs, z))
            if np.any(pts["nr"] < 0):
                raise RuntimeError(f"cylinder sample points at z = {z} outside the mesh")
            S = np.asarray(sigma(pts)).reshape(-1, 3, 3)   # axes (r, z, theta)
            out.append((rs, S[:, 0, 0], S[:, 2, 2], S[:, 1, 1]))
    return out


def cylinder(case: str, level: int = 0, order: int = 2) -> dict:
    """Thermal stresses of the thick-walled cylinder (reference data :data:`CYLINDER`) through the scene path.

    ``case``: "plane_strain" (quarter ring, symmetry on the straight edges, sampled on 5 rays),
    "axisymmetric" (the section a < r < b, 0 < z < 0.5 m with u_z = 0 on z = 0 and z = L: plane strain,
    compared with the plane strain closed form at z = 0, L/2, L) or "free_ends" (0 < z < 12 m, symmetry at
    z = 0 only, free end at z = 12 m: compared with the generalized plane strain closed form at z = 0, 0.5,
    1 m). The temperature is the steady thermal solve (Ti at r = a, 0 at r = b; P``order``, same mesh).

    Errors: at 41 radii (:data:`SAMPLE_FRACTIONS`) on each ray/height, the largest |sigma_h - sigma| of each
    component (sigma_r, sigma_theta, sigma_z) **divided by max |sigma_theta| of the closed form** (45.7 MPa,
    at r = a); ``max_rel_error`` is the largest of the three. Returns per mesh size of
    :data:`CYLINDER_LEVELS` [``level``]: ``h``, ``dofs`` (thermal + mechanical), ``sigma_r``, ``sigma_theta``,
    ``sigma_z``, ``max_rel_errors`` and ``wall_s``; the finest mesh's ``max_rel_error`` and per-component
    ``errors``; ``order_max_error`` (fitted slope), ``scale_Pa`` (the normalization).
    """
    if case not in CYLINDER_CASES:
        raise ValueError(f"case must be one of {CYLINDER_CASES}, got {case!r}")
    if level not in CYLINDER_LEVELS:
        raise ValueError(f"level must be one of {sorted(CYLINDER_LEVELS)}, got {level}")
    c = CYLINDER
    closed_case = "free_ends" if case == "free_ends" else "plane_strain"
    fine = np.linspace(c["a"], c["b"], 2001)
    scale = float(np.max(np.abs(cylinder_thermal_stresses(fine, c["a"], c["b"], c["Ti"], c["E"], c["nu"],
                                                          c["alpha"], case=closed_case).sigma_theta)))
    out = {"case": case, "level": level, "order": order, "closed_form": closed_case, "scale_Pa": scale,
           "h": [], "dofs": [], "sigma_r": [], "sigma_theta": [], "sigma_z": [], "max_rel_errors": [],
           "wall_s": []}
    for h in CYLINDER_LEVELS[level]:
        tic = time.perf_counter()
        res = run_scene(_cylinder_scene(case, h, order), None, progress=False)
        errs = {"sigma_r": 0.0, "sigma_theta": 0.0, "sigma_z": 0.0}
        for rs, sr, st, sz in _sample_cylinder(case, res.mesh, res.mechanics.sigma):
            ex = cylinder_thermal_stresses(rs, c["a"], c["b"], c["Ti"], c["E"], c["nu"], c["alpha"],
                                           case=closed_case)
            for key, num, ref in (("sigma_r", sr, ex.sigma_r), ("sigma_theta", st, ex.sigma_theta),
                                  ("sigma_z", sz, ex.sigma_z)):
                errs[key] = max(errs[key], float(np.max(np.abs(num - ref))) / scale)
        out["h"].append(float(h))
        out["dofs"].append(int(res.summary["mesh"]["dofs"]))
        for key, v in errs.items():
            out[key].append(v)
        out["max_rel_errors"].append(max(errs.values()))
        out["wall_s"].append(time.perf_counter() - tic)
    out["max_rel_error"] = out["max_rel_errors"][-1]
    out["errors"] = {k: out[k][-1] for k in ("sigma_r", "sigma_theta", "sigma_z")}
    out["order_max_error"] = observed_order(out["h"], out["max_rel_errors"])
    return out


# ------------------------------------------------------------------------------------------------------------
# helpers of the manufactured problems
# ------------------------------------------------------------------------------------------------------------

def plane_strain_data(props: dict) -> dict:
    """Per region (D 3x3 Pa, b 3-vector Pa/K, sigma_zz row 3-vector Pa, beta_zz Pa/K, T0 K) of the plane strain
    law [s_xx, s_yy, s_xy] = D e - b (T - T0), e = (e_xx, e_yy, 2 e_xy), computed here from the region's
    :class:`ElasticProperties` with :func:`ngs_geomech.mechanics.materials.plane_strain` (independently of
    :class:`ElasticForms`)."""
    out = {}
    for name, p in props.items():
        red = plane_strain(p.C, p.beta)
        out[name] = (np.asarray(red.D), np.asarray(red.beta), np.asarray(red.stress_out[0]),
                     float(red.beta_out[0]), float(p.T0))
    return out


def _strain(u):
    """Plane Voigt strain (e_xx, e_yy, 2 e_xy) of a vector CF u(x, y), by CoefficientFunction.Diff."""
    return (u[0].Diff(ngs.x), u[1].Diff(ngs.y), u[0].Diff(ngs.y) + u[1].Diff(ngs.x))


def _stresses(data, u, T=None):
    """Exact plane strain stresses of ``u`` for one region's :func:`plane_strain_data`: ([s_xx, s_yy, s_xy],
    s_zz) in Pa; ``T`` the exact temperature CF (K) or None (no thermal stress)."""
    D, b, row, bz, t0 = data
    e = _strain(u)
    s = [sum(float(D[i, j]) * e[j] for j in range(3)) for i in range(3)]
    szz = sum(float(row[j]) * e[j] for j in range(3))
    if T is not None:
        s = [s[i] - float(b[i]) * (T - t0) for i in range(3)]
        szz = szz - bz * (T - t0)
    return s, szz


def _body_force(data, u, T=None):
    """The body force f = -div sigma (N/m^3) of the exact stresses of ``u`` (one region's data), by Diff."""
    (sxx, syy, sxy), _ = _stresses(data, u, T)
    return (-(sxx.Diff(ngs.x) + sxy.Diff(ngs.y)), -(sxy.Diff(ngs.x) + syy.Diff(ngs.y)))


def _steady(cfs) -> list:
    """TimeFunctions (constant in time) of a tuple of CFs."""
    return [Steady(lambda t, c=c: c) for c in cfs]


def _build(data: dict, temperature=None):
    """Scene dict -> (mesh, solved heat forms or None, elastic setup using the heat solution).

    ``temperature`` (a CF of x, y, K): replaces the Dirichlet data of every boundary with a temperature
    condition, and the heat source becomes Q = -div(kappa grad T) with the scene's (scalar) conductivity, so
    that T is the exact solution of the thermal problem (2.17), (2.19)."""
    scene = scene_from_dict(data, source=data["scene"]["name"])
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    heat = None
    if scene.physics.thermal:
        hsetup = heat_setup(scene, geo, mesh)
        if temperature is not None:
            lap = temperature.Diff(ngs.x).Diff(ngs.x) + temperature.Diff(ngs.y).Diff(ngs.y)
            hsetup.dirichlet = {name: Steady(lambda t: temperature) for name in hsetup.dirichlet}
            hsetup.sources = {r: Steady(lambda t, k=float(scene.materials[r].conductivity): -k * lap)
                              for r in scene.materials}
        heat = HeatForms(mesh, hsetup)
        heat.t_new.Set(0.0)
        HeatSolver(heat).solve("manufactured temperature")
    setup = elastic_setup(scene, geo, mesh, heat.temperature() if heat is not None else None)
    return mesh, heat, setup


def _integrate(cf, mesh, order: int, region: str) -> float:
    return float(ngs.Integrate(cf, mesh, order=2 * order + 6, definedon=mesh.Materials(region)))


def _errors(forms: ElasticForms, pdata: dict, exact: dict, order: int, T=None) -> dict:
    """L2 (m^2) and H1 seminorm (m) errors of u, L2 error of the 3x3 stress (Pa m) and the same norms of the
    exact solution (keys ``n_*``), integrated region by region (quadrature order 2p + 6). ``exact`` maps
    region -> u CF; ``T`` is the exact temperature CF (the discrete stress uses the computed one)."""
    mesh = forms.mesh
    uh = forms.displacement()
    sig_h = forms.stress_tensor(uh)
    acc = dict.fromkeys(("l2", "h1", "stress", "n_l2", "n_h1", "n_stress"), 0.0)
    for r, u in exact.items():
        G = ngs.CoefficientFunction((u[0].Diff(ngs.x), u[0].Diff(ngs.y), u[1].Diff(ngs.x), u[1].Diff(ngs.y)),
                                    dims=(2, 2))
        (sxx, syy, sxy), szz = _stresses(pdata[r], u, T)
        S = ngs.CoefficientFunction((sxx, sxy, 0, sxy, syy, 0, 0, 0, szz), dims=(3, 3))
        du, dG, dS = uh - u, ngs.grad(uh) - G, sig_h - S
        for key, a, b in (("l2", du, u), ("h1", dG, G), ("stress", dS, S)):
            acc[key] += _integrate(ngs.InnerProduct(a, a), mesh, order, r)
            acc["n_" + key] += _integrate(ngs.InnerProduct(b, b), mesh, order, r)
    return {k: math.sqrt(v) for k, v in acc.items()}


def _append(out: dict, h: float, dofs: int, errs: dict) -> None:
    out["h"].append(float(h))
    out["dofs"].append(int(dofs))
    for key in ("l2", "h1", "stress"):
        out[key].append(errs[key])
        out[key + "_rel"].append(errs[key] / errs["n_" + key])


def _orders(out: dict) -> None:
    for key in ("l2", "h1", "stress"):
        out[f"order_{key}"] = observed_order(out["h"], out[key])


# ------------------------------------------------------------------------------------------------------------
# 2. Manufactured thermo-elasticity on two anisotropic regions
# ------------------------------------------------------------------------------------------------------------

REGIONS = ("left", "right")
INTERFACE = "mid"
U_SCALE = 1e-3
"""Amplitude of the manufactured displacement, m (strains ~1e-3, thermal strains ~5e-4)."""
T0 = {"left": 0.0, "right": 15.0}
"""Stress-free temperatures of the regions, K."""
MATERIALS = {
    # orthotropic, material axes turned 30 degrees about z: in-plane normal/shear coupling D_xs != 0
    "left": {"orthotropic": {"E": [60e9, 25e9, 40e9], "nu": [0.25, 0.2, 0.3], "G": [15e9, 12e9, 10e9]},
             "elastic_rotation": 30.0,
             "thermal_expansion": [[8e-6, 2e-6, 0.0], [2e-6, 5e-6, 0.0], [0.0, 0.0, 6e-6]]},
    # a full 6x6 stiffness (transversely isotropic, axis turned by Euler angles [20, 35, 50]) given as is
    "right": {"stiffness_voigt": rotate_voigt(transversely_isotropic(30e9, 80e9, 0.2, 0.25, 20e9),
                                              rotation([20.0, 35.0, 50.0], 3)).tolist(),
              "thermal_expansion": [[6e-6, -1.5e-6, 1e-6], [-1.5e-6, 9e-6, 0.5e-6], [1e-6, 0.5e-6, 7e-6]]},
}
"""Anisotropic elastic data of the two regions (Pa, 1/K), in the scene's keys; both regions have in-plane
shear thermal stresses (beta_xy != 0) and normal/shear stiffness coupling."""


def manufactured_temperature(X=None, Y=None):
    """T = 20 + 60 sin(1.2 x + 0.3) cos(0.9 y) + 10 x y (K) as a CF of X, Y (default x, y)."""
    X = ngs.x if X is None else X
    Y = ngs.y if Y is None else Y
    return 20 + 60 * ngs.sin(1.2 * X + 0.3) * ngs.cos(0.9 * Y) + 10 * X * Y


def _w(X, Y):
    """The smooth part of the manufactured displacement (m) as CFs of X, Y."""
    return (U_SCALE * (ngs.sin(2 * X + 0.5 * Y) + 0.3 * Y * Y),
            U_SCALE * (ngs.cos(1.5 * X - Y) + 0.5 * X * Y))


def manufactured_displacement(pdata: dict) -> dict:
    """Exact u per region (vector CFs, m), continuous with continuous traction across x = 0.5 (2.22).

    u_left = w, u_right = w + (x - 0.5) a(y). On x = 0.5 the correction adds nothing to u and [a_x, 0, a_y]
    to the Voigt strain (exx, eyy, 2exy), so traction continuity sigma_left e_x = sigma_right e_x reads

        Dr[s, s] a = (Dl - Dr)[s, :] e(w) - bl[s] (T - T0_l) + br[s] (T - T0_r),    s = (xx, xy),

    at x = 0.5, with D, b the plane strain stiffness and thermal stress vectors (:func:`plane_strain_data`).
    The values at x = 0.5 are CFs of y: w and T written with an ngs.Parameter X = 0.5 in place of x and
    differentiated with respect to X by CoefficientFunction.Diff.
    """
    X = ngs.Parameter(0.5)
    wh = _w(X, ngs.y)
    ew = (wh[0].Diff(X), wh[1].Diff(ngs.y), wh[0].Diff(ngs.y) + wh[1].Diff(X))
    Th = manufactured_temperature(X, ngs.y)
    (Dl, bl, _, _, t0l), (Dr, br, _, _, t0r) = pdata["left"], pdata["right"]
    rows = (0, 2)
    rhs = [sum(float(Dl[i, j] - Dr[i, j]) * ew[j] for j in range(3)) - float(bl[i]) * (Th - t0l)
           + float(br[i]) * (Th - t0r) for i in rows]
    Minv = np.linalg.inv(np.array([[Dr[i, j] for j in rows] for i in rows]))
    a = [float(Minv[k, 0]) * rhs[0] + float(Minv[k, 1]) * rhs[1] for k in range(2)]
    w = _w(ngs.x, ngs.y)
    return {"left": ngs.CoefficientFunction(w),
            "right": ngs.CoefficientFunction((w[0] + (ngs.x - 0.5) * a[0], w[1] + (ngs.x - 0.5) * a[1]))}


def interface_jumps(pdata: dict, exact: dict, mesh) -> dict:
    """Largest jumps of u (m) and of the traction sigma e_x (Pa) of the exact solution over 401 points of
    x = 0.5 (both must vanish), and the largest traction there (Pa) for scale."""
    T = manufactured_temperature()
    ys = np.linspace(0.0, 1.0, 401)
    pts = mesh(np.full_like(ys, 0.5), ys)
    (sl, _), (sr, _) = _stresses(pdata["left"], exact["left"], T), _stresses(pdata["right"], exact["right"], T)
    ju = max(float(np.max(np.abs(exact["left"][k](pts) - exact["right"][k](pts)))) for k in range(2))
    jt = max(float(np.max(np.abs(sl[i](pts) - sr[i](pts)))) for i in (0, 2))
    tmax = max(float(np.max(np.abs(sl[i](pts)))) for i in (0, 2))
    return {"displacement_jump": ju, "traction_jump": jt, "traction_max": tmax}


def _two_region_data(h: float, order: int) -> dict:
    materials = {r: {"conductivity": 1.0, "stress_free_temperature": T0[r], **MATERIALS[r]} for r in REGIONS}
    return {
        "scene": {"name": "thermoelastic_mms", "dimension": "plane", "temperature_unit": "K"},
        "physics": {"thermal": "steady", "mechanics": "static", "plane_model": "plane_strain"},
        "mesh": {"maxh": h, "order": order},
        "blocks": [
            {"name": "left", "shape": "rectangle", "origin": [0.0, 0.0], "size": [0.5, 1.0],
             "boundaries": {"outer_left": ["xmin", "ymin", "ymax"]}},
            {"name": "right", "shape": "rectangle", "origin": [0.5, 0.0], "size": [0.5, 1.0],
             "boundaries": {"outer_right": ["xmax", "ymin", "ymax"]}}],
        "interfaces": [{"name": INTERFACE, "blocks": ["left", "right"], "type": "glued"}],
        "materials": materials,
        # placeholders: the exact data replace them in manufactured()
        "boundary_conditions": {f"outer_{r}": {"temperature": 0.0, "displacement": [0.0, 0.0]} for r in REGIONS},
        "output": {"vtk": False, "figures": False},
    }


def manufactured_problem(h: float, order: int) -> dict:
    """The solved manufactured thermo-elastic problem of :func:`manufactured` at mesh size ``h`` (m): {"mesh",
    "heat" (the solved HeatForms of T_h), "forms" (the solved ElasticForms), "pdata"
    (:func:`plane_strain_data`), "exact" (region -> exact u CF, m), "strain" (region -> exact reduced Voigt
    strain (e_xx, e_yy, 2 e_xy) CF)}."""
    T = manufactured_temperature()
    mesh, heat, setup = _build(_two_region_data(h, order), temperature=T)
    pdata = plane_strain_data(setup.props)
    exact = manufactured_displacement(pdata)
    setup.dirichlet = {f"outer_{r}": _steady((exact[r][0], exact[r][1])) for r in REGIONS}
    setup.body_force = {r: _steady(_body_force(pdata[r], exact[r], T)) for r in REGIONS}
    forms = ElasticForms(mesh, setup)
    ElasticSolver(forms).solve("manufactured thermo-elasticity")
    strain = {r: ngs.CoefficientFunction(_strain(u)) for r, u in exact.items()}
    return {"mesh": mesh, "heat": heat, "forms": forms, "pdata": pdata, "exact": exact, "strain": strain}


def manufactured(order: int, hs) -> dict:
    """Plane strain thermo-elasticity (2.17)-(2.22), law (2.37), on the unit square (m) split at x = 0.5 into
    ``left`` and ``right`` with the anisotropic data :data:`MATERIALS` (glued, conforming mesh), for mesh
    sizes ``hs`` (m) and elements of ``order``.

    Temperature: the steady thermal problem with kappa = 1 W/(m K), Dirichlet data and source chosen so that
    :func:`manufactured_temperature` is its exact solution, solved with the same P``order`` elements on the
    same mesh; the elastic problem uses that computed T_h, so the thermal error enters the displacement error
    (it is of higher order: ||T - T_h||_L2 = O(h^(p+1)) perturbs u by O(h^(p+1)) in H1). Displacement:
    :func:`manufactured_displacement`, Dirichlet data on the outer boundary, body force f = -div sigma(u, T)
    by CoefficientFunction.Diff (given to :class:`ElasticSetup` as ``body_force``).

    Returns ``h``, ``dofs`` (elastic), ``l2`` (m^2), ``h1`` (H1 seminorm, m), ``stress`` (L2 of the 3x3
    stress incl. sigma_zz, Pa m), the same relative to the exact norms (``*_rel``), ``thermal_l2`` (K m),
    fitted orders ``order_l2``, ``order_h1``, ``order_stress`` and the exact solution's ``interface_jumps``.
    """
    out = {"order": order, "h": [], "dofs": [], "l2": [], "h1": [], "stress": [], "l2_rel": [], "h1_rel": [],
           "stress_rel": [], "thermal_l2": []}
    T = manufactured_temperature()
    for h in hs:
        with ngs.TaskManager():
            prob = manufactured_problem(h, order)
            mesh, heat, forms, pdata, exact = (prob[k] for k in ("mesh", "heat", "forms", "pdata", "exact"))
            errs = _errors(forms, pdata, exact, order, T)
        _append(out, h, forms.X.ndof, errs)
        dT = heat.temperature() - T
        out["thermal_l2"].append(math.sqrt(float(ngs.Integrate(dT * dT, mesh, order=2 * order + 6))))
        if "interface_jumps" not in out:
            out["interface_jumps"] = interface_jumps(pdata, exact, mesh)
    _orders(out)
    return out


# ------------------------------------------------------------------------------------------------------------
# 3. Near incompressibility
# ------------------------------------------------------------------------------------------------------------

NI_YOUNG = 10e9
"""Young's modulus of the near-incompressibility problem, Pa."""


def incompressible_displacement(lam_over_mu: float):
    """The displacement u = U [curl psi + (mu/lambda) grad phi] (m), psi = sin^2(pi x) sin^2(pi y),
    phi = sin(x + 2 y) e^y (psi's curl vanishes on the boundary of the unit square): div u = (mu/lambda)
    lap phi, so the pressure lambda div u stays O(mu) and the body force f = -div sigma stays bounded as
    nu -> 1/2 (the regime where P1 locks)."""
    psi = ngs.sin(math.pi * ngs.x) ** 2 * ngs.sin(math.pi * ngs.y) ** 2
    phi = ngs.sin(ngs.x + 2 * ngs.y) * ngs.exp(ngs.y)
    c = 1.0 / lam_over_mu
    return ngs.CoefficientFunction((U_SCALE * (psi.Diff(ngs.y) + c * phi.Diff(ngs.x)),
                                    U_SCALE * (-psi.Diff(ngs.x) + c * phi.Diff(ngs.y))))


def near_incompressible(nu: float, order: int, hs, formulation: str = "auto") -> dict:
    """Plane strain, no temperature, isotropic E = 10 GPa and Poisson ratio ``nu`` on the unit square (m),
    exact :func:`incompressible_displacement` as Dirichlet data on the whole boundary and body force
    f = -div sigma (Diff), elements of ``order``, mesh sizes ``hs`` (m), ``formulation`` of
    :class:`ElasticSetup` ("displacement" shows the locking; ``mixed`` in the result: whether the mixed
    formulation was used).

    Returns ``nu``, ``lambda_over_mu``, ``h``, ``dofs``, absolute errors ``l2`` (m^2), ``h1`` (m), ``stress``
    (L2 of the 3x3 stress incl. sigma_zz, Pa m), relative errors ``*_rel`` (to the exact solution's norms,
    comparable across nu) and fitted orders ``order_l2``, ``order_h1``, ``order_stress``. With P1 at
    nu = 0.4999 (lambda/mu = 5000) the errors are far larger than at nu = 0.3 and converge slowly (locking);
    P2 is not locking-free on general triangular meshes either: measure, do not assume.
    """
    lam_over_mu = 2 * nu / (1 - 2 * nu)
    exact = incompressible_displacement(lam_over_mu)
    out = {"nu": nu, "order": order, "lambda_over_mu": lam_over_mu, "formulation": formulation, "mixed": None,
           "h": [], "dofs": [], "l2": [], "h1": [], "stress": [], "l2_rel": [], "h1_rel": [], "stress_rel": []}
    for h in hs:
        data = {"scene": {"name": "near_incompressible", "dimension": "plane"},
                "physics": {"mechanics": "static", "plane_model": "plane_strain"},
                "mesh": {"maxh": h, "order": order},
                "blocks": [{"name": "body", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 1.0],
                            "boundaries": {"outer": "all"}}],
                "materials": {"body": {"youngs_modulus": NI_YOUNG, "poisson_ratio": nu}},
                "boundary_conditions": {"outer": {"displacement": [0.0, 0.0]}},   # replaced by the exact data
                "output": {"vtk": False, "figures": False}}
        mesh, _, setup = _build(data)
        pdata = plane_strain_data(setup.props)
        setup.dirichlet = {"outer": _steady((exact[0], exact[1]))}
        setup.body_force = {"body": _steady(_body_force(pdata["body"], exact))}
        setup.formulation = formulation
        forms = ElasticForms(mesh, setup)
        out["mixed"] = bool(forms.mixed)
        with ngs.TaskManager():
            ElasticSolver(forms).solve("near-incompressible manufactured solution")
            errs = _errors(forms, pdata, {"body": exact}, order)
        _append(out, h, forms.X.ndof, errs)
    _orders(out)
    return out


# ------------------------------------------------------------------------------------------------------------
# 4. Near incompressibility: the cylinder with the displacement and the mixed formulation
# ------------------------------------------------------------------------------------------------------------

P_INNER = 10e6
"""Internal pressure (Pa) of the Lame cylinder of :func:`incompressible_cylinder`."""


def _ni_cylinder_scene(case: str, h: float, order: int, nu: float, load: str) -> dict:
    c = CYLINDER
    thermal = load == "thermal"
    a, b = c["a"], c["b"]
    material = {"conductivity": 1.0, "youngs_modulus": c["E"], "poisson_ratio": nu,
                "thermal_expansion": c["alpha"] if thermal else 0.0, "stress_free_temperature": 0.0}
    bcs = {"inner": {"temperature": c["Ti"]}, "outer": {"temperature": 0.0}} if thermal else \
        {"inner": {"pressure": P_INNER}}
    if case == "plane_strain":
        arc = np.linspace(0.0, math.pi / 2, ARC_POINTS)
        block = {"name": "wall", "shape": "profile", "start": [a, 0.0], "segments": [
            {"line": [b, 0.0], "name": "sym_x"},
            {"spline": [[b * math.cos(t), b * math.sin(t)] for t in arc[1:]], "name": "outer"},
            {"line": [0.0, a], "name": "sym_y"},
            {"spline": [[a * math.cos(t), a * math.sin(t)] for t in arc[::-1][1:]], "name": "inner"}]}
        bcs.update({"sym_x": {"symmetry": True}, "sym_y": {"symmetry": True}})
        dimension = "plane"
    elif case == "axisymmetric":
        block = {"name": "wall", "shape": "rectangle", "origin": [a, 0.0], "size": [b - a, AXI_LENGTH],
                 "boundaries": {"inner": "xmin", "outer": "xmax", "bottom": "ymin", "top": "ymax"}}
        bcs.update({"bottom": {"symmetry": True}, "top": {"symmetry": True}})
        dimension = "axisymmetric"
    else:
        raise ValueError(f"case must be 'plane_strain' or 'axisymmetric', got {case!r}")
    physics = {"mechanics": "static", "plane_model": "plane_strain"}
    if thermal:
        physics["thermal"] = "steady"
    return {"scene": {"name": f"ni_cylinder_{case}", "dimension": dimension, "temperature_unit": "K"},
            "physics": physics, "mesh": {"maxh": h, "order": order}, "blocks": [block],
            "materials": {"wall": material}, "boundary_conditions": bcs, "output": {"vtk": False, "figures": False}}


@functools.lru_cache(maxsize=16)
def _ni_cylinder_mesh(case: str, h: float, order: int, load: str):
    """(mesh, geometry model, temperature CF or None) of :func:`incompressible_cylinder`: independent of nu, kept
    for the next nu (meshing the splines and the thermal solve cost more than the elastic solve)."""
    mesh, heat, _ = _build(_ni_cylinder_scene(case, h, order, 0.3, load))
    scene = scene_from_dict(_ni_cylinder_scene(case, h, order, 0.3, load), source="ni_cylinder")
    return mesh, validate(scene), heat.temperature() if heat is not None else None


def incompressible_cylinder(case: str, nu: float, order: int, hs, *, load: str = "pressure",
                            formulation: str = "auto") -> dict:
    """The thick-walled cylinder (:data:`CYLINDER` radii, E) of ``case`` ("plane_strain": quarter ring with
    symmetry on the straight edges; "axisymmetric": the section 0 < z < 0.5 m with u_z = 0 on both ends) at
    Poisson ratio ``nu`` under ``load`` "pressure" (:data:`P_INNER` inside, Lame's closed form) or "thermal"
    (the steady temperature of the thermal solve, alpha of :data:`CYLINDER`), P``order``, mesh sizes ``hs``
    (m), solved with ``formulation`` (:class:`ElasticSetup`).

    Errors at the sample points of :func:`cylinder` (41 radii on 5 rays / 3 heights), each the largest
    |num - exact|: ``u_r`` over max |u_r|, ``sigma_r``, ``sigma_theta``, ``sigma_z`` and ``mean`` (the mean
    stress) over max |sigma_theta|; ``max_stress`` the largest of the stress errors; fitted orders
    ``order_<key>``; ``mixed`` whether the mixed formulation was used; ``dofs``."""
    c = CYLINDER
    rs = c["a"] + (c["b"] - c["a"]) * SAMPLE_FRACTIONS
    fine = np.linspace(c["a"], c["b"], 2001)

    def exact(r):
        if load == "pressure":
            return cylinder_pressure_stresses(r, c["a"], c["b"], P_INNER, c["E"], nu)
        return cylinder_thermal_stresses(r, c["a"], c["b"], c["Ti"], c["E"], nu, c["alpha"], case="plane_strain")

    scale = float(np.max(np.abs(exact(fine).sigma_theta)))
    uscale = float(np.max(np.abs(exact(fine).u_r)))
    keys = ("u_r", "sigma_r", "sigma_theta", "sigma_z", "mean")
    out = {"case": case, "nu": nu, "order": order, "load": load, "formulation": formulation, "h": [], "dofs": [],
           **{k: [] for k in keys}, "max_stress": [], "mixed": None}
    for h in hs:
        mesh, geo, temperature = _ni_cylinder_mesh(case, h, order, load)
        scene = scene_from_dict(_ni_cylinder_scene(case, h, order, nu, load), source="ni_cylinder")
        setup = elastic_setup(scene, geo, mesh, temperature)
        setup.formulation = formulation
        forms = ElasticForms(mesh, setup)
        out["mixed"] = bool(forms.mixed)
        ElasticSolver(forms).solve("near-incompressible cylinder")
        sigma = forms.stress_tensor()
        u = forms.displacement()
        errs = dict.fromkeys(keys, 0.0)
        rays = [(math.cos(t), math.sin(t), None) for t in RING_ANGLES] if case == "plane_strain" else \
            [(1.0, 0.0, z) for z in (0.0, 0.5 * AXI_LENGTH, AXI_LENGTH)]
        for cs, sn, z in rays:
            xs, ys = (rs * cs, rs * sn) if z is None else (rs, np.full_like(rs, z))
            inside = mesh(xs, ys)["nr"] >= 0     # (P1: the straight-sided ring lies inside the curved one)
            pts = mesh(xs[inside], ys[inside])
            S = np.asarray(sigma(pts)).reshape(-1, 3, 3)
            U = np.asarray(u(pts)).reshape(-1, 2)
            ex = exact(rs[inside])
            if z is None:
                er, et = np.array([cs, sn, 0.0]), np.array([-sn, cs, 0.0])
                sr, st, sz = (np.einsum("i,nij,j->n", er, S, er), np.einsum("i,nij,j->n", et, S, et), S[:, 2, 2])
                ur = U[:, 0] * cs + U[:, 1] * sn
            else:
                sr, st, sz, ur = S[:, 0, 0], S[:, 2, 2], S[:, 1, 1], U[:, 0]
            for key, num, ref, sc in (("u_r", ur, ex.u_r, uscale), ("sigma_r", sr, ex.sigma_r, scale),
                                      ("sigma_theta", st, ex.sigma_theta, scale), ("sigma_z", sz, ex.sigma_z, scale),
                                      ("mean", (sr + st + sz) / 3, (ex.sigma_r + ex.sigma_theta + ex.sigma_z) / 3,
                                       scale)):
                errs[key] = max(errs[key], float(np.max(np.abs(num - ref))) / sc)
        out["h"].append(float(h))
        out["dofs"].append(int(forms.X.ndof))
        for k in keys:
            out[k].append(errs[k])
        out["max_stress"].append(max(errs[k] for k in keys[1:]))
    for k in (*keys, "max_stress"):
        out[f"order_{k}"] = observed_order(out["h"], out[k]) if len(out["h"]) > 1 else float("nan")
    return out
