"""Manufactured thermo-elasticity with material data that vary in space and with the temperature, run through the
package's own path (a scene whose elastic values are expressions -> :func:`validate` -> :func:`make_mesh` ->
:func:`heat_setup` / :class:`HeatForms` / :class:`HeatSolver` -> :func:`elastic_setup` (representative values at the
mesh vertices) -> :class:`ElasticForms` -> :class:`ElasticSolver`).

Problem (P) (2.17)-(2.22) without contact, isotropic law (2.18)/(2.37) with every datum varying:

    sigma = lam tr(e) I + 2 mu e - beta (T - T0) I + rho g-loaded equilibrium  -div sigma = rho g + f,
    lam = E nu / ((1 + nu)(1 - 2 nu)),  mu = E / (2 (1 + nu)),  beta = (3 lam + 2 mu) alpha,

with E(x, y, T) = :data:`YOUNG` (Pa; a factor 2 over the square and a few per cent with T), nu(x, y) =
:data:`POISSON`, alpha(x, y) = :data:`EXPANSION` (1/K), T0(x) = :data:`STRESS_FREE` (K) and rho(x, y) =
:data:`DENSITY` (kg/m^3) under gravity (0, -9.81) m/s^2. The temperature is the thermal solve's solution T_h of the
manufactured T = :data:`TEMPERATURE` (kappa = 1 W/(m K), exact Dirichlet data and source, the same elements), so
E(T_h) and the thermal stress take the computed temperature (a perturbation of order h^(p+1), below the
displacement error in both norms). Displacement: u = :func:`displacement`, Dirichlet data on the whole boundary,
body force f = -div sigma(u, T) - rho g from exact stresses written here with the formulas above (independent of
the package's stiffness assembly; the scalar data are the package's :func:`material_cf` of the same strings with T
the exact temperature), derived by ``CoefficientFunction.Diff``.

Models: plane strain on the unit square (m) and axisymmetric on (r, z) in [0.5, 1.5] x [0, 1] (x = r, y = z; the hoop
strain u_r / r and the equilibrium terms (sigma_rr - sigma_tt) / r, sigma_rz / r). Errors: L2 of u (m^2), H1
seminorm of u (m), L2 of the full 3x3 stress with sigma_zz / sigma_tt (Pa m), integrated with quadrature order
2p + 6 (plain area integrals in both models). Expected orders for P1 / P2: 2 / 3 (L2), 1 / 2 (H1, stress).

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import math

import ngsolve as ngs

from ..fem.coefficients import Steady, expression_function, material_cf
from ..geometry.mesh import make_mesh
from ..heat.forms import HeatForms
from ..heat.problem import heat_setup
from ..heat.solver import HeatSolver
from ..mechanics.forms import ElasticForms
from ..mechanics.problem import elastic_setup
from ..mechanics.solver import ElasticSolver
from ..scene.parse import scene_from_dict
from ..validation.validate import validate
from .study import observed_order

TEMPERATURE = "20 + 30*sin(1.2*x + 0.3)*cos(0.9*y) + 10*x*y"
"""The exact temperature, K (about -5 to 50 K on the domains)."""
YOUNG = "30e9*(1 + 0.6*x + 0.4*y*y)*(1 + 2e-3*(T - 20))"
"""E(x, y, T), Pa."""
POISSON = "0.25 + 0.1*sin(x + 2*y)"
"""nu(x, y) (0.15 to 0.35)."""
EXPANSION = "8e-6*(1 + 0.5*x*y)"
"""alpha(x, y), 1/K."""
STRESS_FREE = "5*x"
"""T0(x), K."""
DENSITY = "2600 + 300*y"
"""rho(x, y), kg/m^3."""
GRAVITY = (0.0, -9.81)
"""m/s^2."""
U_SCALE = 1e-3
"""Amplitude of the manufactured displacement, m."""
DOMAINS = {"plane_strain": ([0.0, 0.0], "plane"), "axisymmetric": ([0.5, 0.0], "axisymmetric")}
"""Origin of the unit square and scene dimension per model."""


def displacement(X=None, Y=None):
    """The exact displacement (m) as a vector CF of X, Y (default x, y)."""
    X = ngs.x if X is None else X
    Y = ngs.y if Y is None else Y
    return ngs.CoefficientFunction((U_SCALE * (ngs.sin(2 * X + 0.5 * Y) + 0.3 * Y * Y),
                                    U_SCALE * (ngs.cos(1.5 * X - Y) + 0.5 * X * Y)))


def scene(model: str, maxh: float, order: int, formulation: str = "displacement", mesh_keys: dict | None = None):
    """The scene of ``model`` ('plane_strain' | 'axisymmetric'): one block ``rock`` with the varying data, exact
    temperatures on its boundary ``outer`` (the displacement data and the body force are set on the setup);
    ``mesh_keys``: more ``[mesh]`` keys (e.g. a structured mesh)."""
    origin, dimension = DOMAINS[model]
    material = {"conductivity": 1.0, "youngs_modulus": YOUNG, "poisson_ratio": POISSON,
                "thermal_expansion": EXPANSION, "stress_free_temperature": STRESS_FREE, "density": DENSITY}
    data = {
        "scene": {"name": f"varying_elastic_{model}", "dimension": dimension, "temperature_unit": "K"},
        "physics": {"thermal": "steady", "mechanics": "static", "plane_model": "plane_strain"},
        "mesh": {"maxh": maxh, "order": order, **(mesh_keys or {})},
        "blocks": [{"name": "rock", "shape": "rectangle", "origin": origin, "size": [1.0, 1.0],
                    "boundaries": {"outer": "all"}}],
        "materials": {"rock": material},
        "mechanics": {"gravity": list(GRAVITY), "formulation": formulation},
        "boundary_conditions": {"outer": {"temperature": TEMPERATURE, "displacement": [0.0, 0.0]}},
        "output": {"vtk": False, "figures": False},
    }
    return scene_from_dict(data, source=f"varying_elastic_{model}")


def exact_stress(model: str, u, T):
    """The exact stress of ``u`` at the exact temperature ``T`` (CFs): (sigma_xx, sigma_yy, sigma_xy, sigma_zz)
    (axisymmetric: rr, zz, rz, theta-theta), Pa, from lam, mu and beta of the module docstring."""
    E, nu = material_cf(YOUNG, T), material_cf(POISSON, T)
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    thermal = (3 * lam + 2 * mu) * material_cf(EXPANSION, T) * (T - material_cf(STRESS_FREE, T))
    exx, eyy = u[0].Diff(ngs.x), u[1].Diff(ngs.y)
    gxy = u[0].Diff(ngs.y) + u[1].Diff(ngs.x)
    ezz = u[0] / ngs.x if model == "axisymmetric" else 0
    tr = exx + eyy + ezz
    return (lam * tr + 2 * mu * exx - thermal, lam * tr + 2 * mu * eyy - thermal, mu * gxy,
            lam * tr + 2 * mu * ezz - thermal)


def body_force(model: str, u, T):
    """The body force f = -div sigma - rho g (N/m^3) the forms must add to their rho g for ``u`` to solve (P)."""
    sxx, syy, sxy, szz = exact_stress(model, u, T)
    fx = -(sxx.Diff(ngs.x) + sxy.Diff(ngs.y))
    fy = -(sxy.Diff(ngs.x) + syy.Diff(ngs.y))
    if model == "axisymmetric":
        fx, fy = fx - (sxx - szz) / ngs.x, fy - sxy / ngs.x
    rho = material_cf(DENSITY, T)
    return fx - rho * GRAVITY[0], fy - rho * GRAVITY[1]


def _steady(cf):
    return Steady(lambda t, c=cf: c)


def solve(model: str, maxh: float, order: int, formulation: str = "displacement",
          mesh_keys: dict | None = None) -> dict:
    """The solved problem of ``model`` at mesh size ``maxh`` (m): {"mesh", "heat" (HeatForms), "forms"
    (ElasticForms), "exact" (u CF), "T" (the exact temperature CF)}."""
    sc = scene(model, maxh, order, formulation, mesh_keys)
    geo = validate(sc)
    mesh = make_mesh(geo, sc.mesh)
    T = expression_function(TEMPERATURE)(0.0)
    hsetup = heat_setup(sc, geo, mesh)
    lap = T.Diff(ngs.x).Diff(ngs.x) + T.Diff(ngs.y).Diff(ngs.y)
    if model == "axisymmetric":
        lap = lap + T.Diff(ngs.x) / ngs.x
    hsetup.sources = {"rock": _steady(-lap)}
    heat = HeatForms(mesh, hsetup)
    heat.t_new.Set(0.0)
    HeatSolver(heat).solve("manufactured temperature")
    setup = elastic_setup(sc, geo, mesh, heat.temperature())
    u = displacement()
    setup.dirichlet = {"outer": [_steady(u[0]), _steady(u[1])]}
    setup.body_force = {"rock": [_steady(c) for c in body_force(model, u, T)]}
    forms = ElasticForms(mesh, setup)
    ElasticSolver(forms).solve(f"manufactured varying thermo-elasticity ({model})")
    return {"mesh": mesh, "heat": heat, "forms": forms, "exact": u, "T": T}


def errors(model: str, forms: ElasticForms, u, T, order: int) -> dict:
    """L2 (m^2) and H1-seminorm (m) errors of u and the L2 error of the 3x3 stress (Pa m), with the exact norms
    (``n_*``)."""
    mesh = forms.mesh
    uh = forms.displacement()
    sxx, syy, sxy, szz = exact_stress(model, u, T)
    S = ngs.CoefficientFunction((sxx, sxy, 0, sxy, syy, 0, 0, 0, szz), dims=(3, 3))
    G = ngs.CoefficientFunction((u[0].Diff(ngs.x), u[0].Diff(ngs.y), u[1].Diff(ngs.x), u[1].Diff(ngs.y)),
                                dims=(2, 2))
    out = {}
    for key, a, b in (("l2", uh - u, u), ("h1", ngs.grad(uh) - G, G), ("stress", forms.stress_tensor(uh) - S, S)):
        out[key] = math.sqrt(float(ngs.Integrate(ngs.InnerProduct(a, a), mesh, order=2 * order + 6)))
        out["n_" + key] = math.sqrt(float(ngs.Integrate(ngs.InnerProduct(b, b), mesh, order=2 * order + 6)))
    return out


def convergence(model: str, order: int, hs, formulation: str = "displacement", mesh_keys: dict | None = None) -> dict:
    """Errors of the manufactured problem of ``model`` for the mesh sizes ``hs`` (m) and elements of ``order``:
    ``h``, ``dofs``, ``l2``, ``h1``, ``stress`` (and ``*_rel`` relative to the exact norms), the fitted orders
    ``order_l2``, ``order_h1``, ``order_stress`` and the number of sample points of the representative values."""
    out = {"model": model, "order": order, "formulation": formulation, "h": [], "dofs": []}
    for key in ("l2", "h1", "stress"):
        out[key], out[key + "_rel"] = [], []
    for h in hs:
        with ngs.TaskManager():
            prob = solve(model, h, order, formulation, mesh_keys)
            errs = errors(model, prob["forms"], prob["exact"], prob["T"], order)
        out["h"].append(float(h))
        out["dofs"].append(int(prob["forms"].X.ndof))
        for key in ("l2", "h1", "stress"):
            out[key].append(errs[key])
            out[key + "_rel"].append(errs[key] / errs["n_" + key])
        out["sample_points"] = prob["forms"].setup.props["rock"].varying.points
    for key in ("l2", "h1", "stress"):
        out[f"order_{key}"] = observed_order(out["h"], out[key])
    return out
