"""Problem (P) whole, through a scene: heat conduction, thermal stress, the lambda law and frictional contact
with rigid foundations, against a closed form.

:func:`heated_bar` : a block L x H (plane strain) between two rigid foundations, touching the one at x = 0
and a gap g0 away from the one at x = L + g0; symmetry u_y = 0 at the bottom, free top; the steady heat
problem with T = T1 on the whole boundary gives a uniform T, and the thermal stress -beta (T1 - T0) (2.18)
expands the block. The block is held along x by the contacts alone (semi-coercive). When the free
expansion exceeds g0 both contacts close and the state is uniform: e_xx = g0 / L, sigma_yy = 0 (free top),
e_zz = 0 (plane strain), and the law s = lam (A1/A_ref + delta)^(lam-1) C e - beta (T1 - T0) gives the
contact pressure p = -sigma_xx; for lam = 1 in closed form, for lam != 1 from one scalar equation (sigma_yy
(e_yy) = 0, solved by Brent's method). A uniform state is in the P1 space and the dual mortar multipliers
reproduce a uniform pressure, so the discrete solution equals the exact one up to the solver tolerances.

:func:`heated_bar_3d` : the same in 3D (lam = 1), a box L x H x W between rigid plane foundations at x = 0
and x = L + g0, symmetry on the faces y = 0 and z = 0, free faces y = H and z = W: the closed state is
uniaxial, sigma_yy = sigma_zz = 0, e_xx = g0 / L, so sigma_xx = E (e_xx - alpha (T1 - T0)) and the pressure
p = E (alpha (T1 - T0) - g0 / L) when the free expansion alpha (T1 - T0) L exceeds g0 (else 0); the lateral
strains are e_yy = e_zz = alpha (T1 - T0) + nu p / E.

:func:`heated_cylinder` : axisymmetric, a solid cylinder between two rigid plates (the contact weight r):
the same uniaxial closed form along the axis.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from ..mechanics.materials import isotropic
from ..run import run_scene
from ..scene.parse import scene_from_dict


def heated_bar_scene(*, lam: float = 1.0, gap: float = 1e-4, dT: float = 60.0, L: float = 1.0, H: float = 0.4,
                     E: float = 20e9, nu: float = 0.25, alpha: float = 1e-5, maxh: float = 0.2, order: int = 1,
                     law: str = "frictionless", method: str = "ssn") -> dict:
    """The scene dict of :func:`heated_bar` (T0 = 0, T1 = dT)."""
    found = {"law": law, "method": method}
    if law == "coulomb":
        found["friction"] = 0.5
    return {
        "scene": {"name": "heated_bar"},
        "physics": {"thermal": "steady", "mechanics": "static"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [{"name": "bar", "shape": "rectangle", "origin": [0, 0], "size": [L, H],
                    "boundaries": {"left": "xmin", "right": "xmax", "bottom": "ymin", "top": "ymax"}}],
        "materials": {"bar": {"conductivity": 3.0, "youngs_modulus": E, "poisson_ratio": nu,
                              "thermal_expansion": alpha, "stress_free_temperature": 0.0,
                              "rheology_lambda": lam}},
        "mechanics": {"tolerance": 1e-10},
        "boundary_conditions": {
            "left": {"temperature": dT, "foundation": {"point": [0.0, 0.0], "normal": [1.0, 0.0], **found}},
            "right": {"temperature": dT, "foundation": {"point": [L + gap, 0.0], "normal": [-1.0, 0.0], **found}},
            "bottom": {"temperature": dT, "symmetry": True},
            "top": {"temperature": dT},
        },
        "output": {"vtk": False, "figures": False},
    }


def heated_bar_pressure(*, lam: float, gap: float, dT: float, L: float, E: float, nu: float, alpha: float,
                        eps_ref: float = 1e-3, delta: float = 1e-6) -> tuple[float, float]:
    """(p, e_yy): the closed-form contact pressure (Pa, 0 when the gap stays open) and vertical strain."""
    C = isotropic(E, nu)
    D = C[np.ix_([0, 1, 5], [0, 1, 5])]           # plane strain: xx, yy, xy (engineering shear)
    beta = (C @ np.array([alpha, alpha, alpha, 0, 0, 0]))[[0, 1, 5]] * dT
    A_ref = eps_ref ** 2 * C[0, 0]
    exx = gap / L

    def stress(eyy):
        e = np.array([exx, eyy, 0.0])
        A1 = float(e @ D @ e)
        fac = 1.0 if lam == 1.0 else lam * (A1 / A_ref + delta) ** (lam - 1.0)
        return fac * (D @ e) - beta

    free_exx = (1 + nu) * alpha * dT            # plane strain free expansion along x (sigma_yy = sigma_xx = 0)
    if free_exx <= exx:
        return 0.0, free_exx
    scale = 10 * alpha * dT
    eyy = brentq(lambda v: stress(v)[1], -scale, scale, xtol=1e-16, rtol=1e-14)
    return float(-stress(eyy)[0]), float(eyy)


def heated_bar(**kw) -> dict:
    """Run the scene and compare: {"p_ref", "p_left", "p_right" (nodal pressure ranges [min, max], Pa),
    "p_error" (max relative deviation of any nodal pressure on either side), "imbalance_rel",
    "iterations" (secant), "contact_iterations", "summary"}."""
    params = {k: kw[k] for k in ("lam", "gap", "dT", "L", "E", "nu", "alpha") if k in kw}
    defaults = dict(lam=1.0, gap=1e-4, dT=60.0, L=1.0, E=20e9, nu=0.25, alpha=1e-5)
    p_ref, eyy = heated_bar_pressure(**{**defaults, **params})
    return _compare(heated_bar_scene(**kw), p_ref, eyy)[0]


def heated_bar_3d_scene(*, gap: float = 1e-4, dT: float = 60.0, L: float = 1.0, H: float = 0.4, W: float = 0.4,
                        E: float = 20e9, nu: float = 0.25, alpha: float = 1e-5, maxh: float = 0.2, order: int = 1,
                        method: str = "ssn") -> dict:
    """The scene dict of :func:`heated_bar_3d` (T0 = 0, T1 = dT; linear elasticity, frictionless)."""
    found = {"law": "frictionless", "method": method}
    return {
        "scene": {"name": "heated_bar_3d", "dimension": "3d"},
        "physics": {"thermal": "steady", "mechanics": "static"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [{"name": "bar", "shape": "box", "origin": [0, 0, 0], "size": [L, H, W],
                    "boundaries": {"left": "xmin", "right": "xmax", "bottom": "ymin", "top": "ymax",
                                   "back": "zmin", "front": "zmax"}}],
        "materials": {"bar": {"conductivity": 3.0, "youngs_modulus": E, "poisson_ratio": nu,
                              "thermal_expansion": alpha, "stress_free_temperature": 0.0}},
        "mechanics": {"tolerance": 1e-10},
        "boundary_conditions": {
            "left": {"temperature": dT, "foundation": {"point": [0.0, 0.0, 0.0], "normal": [1.0, 0.0, 0.0],
                                                       **found}},
            "right": {"temperature": dT, "foundation": {"point": [L + gap, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0],
                                                        **found}},
            "bottom": {"temperature": dT, "symmetry": True},
            "back": {"temperature": dT, "symmetry": True},
            "top": {"temperature": dT},
            "front": {"temperature": dT},
        },
        "output": {"vtk": False, "figures": False},
    }


def heated_bar_3d_pressure(*, gap: float, dT: float, L: float, E: float, nu: float,
                           alpha: float) -> tuple[float, float]:
    """(p, e_yy = e_zz): the closed-form contact pressure (Pa, 0 when the gap stays open) and lateral strain
    of the 3D bar (uniaxial stress along x)."""
    free = alpha * dT                 # free expansion along x (all stresses zero)
    if free * L <= gap:
        return 0.0, free
    p = E * (free - gap / L)          # sigma_xx = E (gap / L - alpha dT) = -p
    return float(p), float(free + nu * p / E)


def heated_bar_3d(**kw) -> dict:
    """Run the 3D scene and compare: the keys of :func:`heated_bar` (``e_yy_ref`` is also e_zz) and the
    lateral strains e_yy, e_zz measured from the displacement at the corner (L, H, W) ("e_yy", "e_zz")."""
    params = {k: kw[k] for k in ("gap", "dT", "L", "E", "nu", "alpha", "H", "W") if k in kw}
    defaults = dict(gap=1e-4, dT=60.0, L=1.0, H=0.4, W=0.4, E=20e9, nu=0.25, alpha=1e-5)
    prm = {**defaults, **params}
    p_ref, eyy = heated_bar_3d_pressure(**{k: v for k, v in prm.items() if k not in ("H", "W")})
    out, result = _compare(heated_bar_3d_scene(**kw), p_ref, eyy)
    mesh = result.mesh
    u = np.array(result.mechanics.forms.displacement()(mesh(prm["L"], prm["H"], prm["W"]))).ravel()
    out["e_yy"], out["e_zz"] = float(u[1] / prm["H"]), float(u[2] / prm["W"])
    return out


def heated_cylinder_scene(*, gap: float = 1e-4, dT: float = 60.0, R: float = 0.3, H: float = 1.0,
                          E: float = 20e9, nu: float = 0.25, alpha: float = 1e-5, maxh: float = 0.15,
                          order: int = 1) -> dict:
    """The scene dict of :func:`heated_cylinder` (axisymmetric, T0 = 0, T1 = dT, frictionless)."""
    found = {"law": "frictionless"}
    return {
        "scene": {"name": "heated_cylinder", "dimension": "axisymmetric"},
        "physics": {"thermal": "steady", "mechanics": "static"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [{"name": "rod", "shape": "rectangle", "origin": [0, 0], "size": [R, H],
                    "boundaries": {"base": "ymin", "cap": "ymax", "mantle": "xmax"}}],
        "materials": {"rod": {"conductivity": 3.0, "youngs_modulus": E, "poisson_ratio": nu,
                              "thermal_expansion": alpha, "stress_free_temperature": 0.0}},
        "mechanics": {"tolerance": 1e-10},
        "boundary_conditions": {
            "base": {"temperature": dT, "foundation": {"point": [0.0, 0.0], "normal": [0.0, 1.0], **found}},
            "cap": {"temperature": dT, "foundation": {"point": [0.0, H + gap], "normal": [0.0, -1.0], **found}},
            "mantle": {"temperature": dT},
        },
        "output": {"vtk": False, "figures": False},
    }


def heated_cylinder(**kw) -> dict:
    """A solid cylinder (axisymmetric, radius R, height H) heated uniformly between two rigid plates, at z = 0
    and z = H + g0, free mantle: the closed state is uniaxial along z, p = E (alpha dT - g0 / H) (the 3D
    bar's closed form with L = H); the contact weight is r. The keys of :func:`heated_bar`."""
    params = {k: kw[k] for k in ("gap", "dT", "E", "nu", "alpha") if k in kw}
    defaults = dict(gap=1e-4, dT=60.0, E=20e9, nu=0.25, alpha=1e-5)
    p_ref, err = heated_bar_3d_pressure(**{**defaults, **params}, L=kw.get("H", 1.0))
    return _compare(heated_cylinder_scene(**kw), p_ref, err)[0]


def _compare(scene: dict, p_ref: float, eyy: float) -> tuple[dict, object]:
    """Run a heated bar scene: (the comparison of the nodal pressures with p_ref, the RunResult)."""
    result = run_scene(scene_from_dict(scene), None, progress=False)
    mech = result.mechanics
    out = {"p_ref": p_ref, "e_yy_ref": eyy}
    errs = []
    for spec, res in zip(mech.contacts, mech.contact_output.latest):
        keep = spec.op.coverage > 1 - 1e-6
        p = res["pressure"][keep]
        out[f"p_{spec.name}"] = [float(p.min()), float(p.max())]
        errs.append(float(np.max(np.abs(p - p_ref))) / max(abs(p_ref), 1.0))
    out["p_error"] = max(errs)
    summ = result.summary["mechanics"]
    out["imbalance_rel"] = summ["contact"]["force_balance"]["imbalance_rel"]
    out["iterations"] = summ["iterations"][-1]
    out["contact_iterations"] = summ["contact"]["iterations_per_solve"][-1]
    out["summary"] = result.summary
    return out, result
