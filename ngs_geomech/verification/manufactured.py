"""Manufactured and closed-form solutions of heat conduction, run through the package's own path
(scene dict -> :func:`validate` / :func:`build_geometry` -> :func:`make_mesh` -> :func:`heat_setup` ->
:class:`HeatForms` -> :class:`HeatSolver`).

Problem (P) of the seed: steady conduction (2.17) -div(kappa grad T) = Q with Dirichlet data (2.19) and
transient conduction (2.43) rho c dT/dt - div(kappa grad T) = Q, on the unit square (m) split at x = 0.5
into the regions ``left`` and ``right``, each with its own full anisotropic SPD tensor kappa (W/(m K)).
Across the interface the temperature and the normal heat flux are continuous (2.22):

    T_left = T_right,    (kappa_left grad T_left) . n = (kappa_right grad T_right) . n    at x = 0.5.

Construction: with a smooth u(x, y), T_left = u and T_right = u + (x - 0.5) a(y). T is continuous, and as
d/dy [(x - 0.5) a(y)] = 0 on x = 0.5, the flux condition (n = e_x) gives

    a(y) = [(kl_xx - kr_xx) u_x(0.5, y) + (kl_xy - kr_xy) u_y(0.5, y)] / kr_xx.

The interface is either ``glued`` (one conforming mesh) or ``contact`` (independent, non-matching meshes
coupled by the mortar method of :mod:`ngs_geomech.heat.forms`). Q is derived exactly with NGSolve's
``CoefficientFunction.Diff``; errors are integrated with quadrature order 2p + 6.

The Kirchhoff slab checks k(T) = k0 (1 + b T) (seed, Kirchhoff transform before (2.39)) against the closed
form T(x) = (-1 + sqrt(1 + 2 b Theta(x))) / b with Theta = T + b T^2 / 2 linear in x.

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ..fem.coefficients import expression_function
from ..fem.timesteps import schedule
from ..geometry.mesh import make_mesh
from ..heat.forms import HeatForms
from ..heat.problem import heat_setup
from ..heat.solver import HeatSolver
from ..scene.parse import scene_from_dict
from ..validation.validate import validate
from .study import observed_order  # noqa: F401  (re-exported: studies and tests use it from here)

K_LEFT = ((2.0, 0.5), (0.5, 1.0))
"""Conductivity of the region x < 0.5, W/(m K) (SPD, eigenvalues 0.79 and 2.21)."""
K_RIGHT = ((1.0, -0.3), (-0.3, 3.0))
"""Conductivity of the region x > 0.5, W/(m K) (SPD, eigenvalues 0.96 and 3.04)."""
RHO_C = {"left": 1.0, "right": 2.5}
"""Volumetric heat capacities of the transient problem, J/(m^3 K)."""
REGIONS = ("left", "right")
INTERFACE = "mid"


# -- the manufactured solutions ---------------------------------------------------------------------------
@dataclass(frozen=True)
class TwoRegionSolution:
    """A temperature field (K) given per region as expressions in x, y (m) and t (s), with the region
    conductivities (W/(m K)) and heat capacities (J/(m^3 K)) it was built for."""

    left: str
    right: str
    kappa: dict
    rho_c: dict

    def expression(self, region: str) -> str:
        return self.left if region == "left" else self.right

    def temperature(self, region: str, t):
        """T in ``region`` as a CoefficientFunction (t: a Parameter or number, s)."""
        return expression_function(self.expression(region))(t)

    def gradient(self, region: str, t):
        """The gradient grad T in ``region``, K/m."""
        T = self.temperature(region, t)
        return ngs.CoefficientFunction((T.Diff(ngs.x), T.Diff(ngs.y)))

    def flux(self, region: str, t):
        """The vector kappa grad T in ``region`` (minus the heat flux vector), W/m^2."""
        (kxx, kxy), (kyx, kyy) = self.kappa[region]
        g = self.gradient(region, t)
        return ngs.CoefficientFunction((kxx * g[0] + kxy * g[1], kyx * g[0] + kyy * g[1]))

    def source(self, region: str, t, steady: bool):
        """Q = rho c dT/dt - div(kappa grad T) in ``region`` (2.17), (2.43), W/m^3; t must be the Parameter
        the forms evaluate the load at (dT/dt is taken by differentiating with respect to it)."""
        q = self.flux(region, t)
        div = q[0].Diff(ngs.x) + q[1].Diff(ngs.y)
        if steady:
            return -div
        return self.rho_c[region] * self.temperature(region, t).Diff(t) - div


def _two_region(u: str, ux_half: str, uy_half: str, factor: str, k_left, k_right, rho_c) -> TwoRegionSolution:
    """T_left = factor u, T_right = factor (u + (x - 0.5) a(y)) (module docstring); ``ux_half``, ``uy_half``
    are u_x(0.5, y) and u_y(0.5, y), derived by hand."""
    ca = (k_left[0][0] - k_right[0][0]) / k_right[0][0]
    cb = (k_left[0][1] - k_right[0][1]) / k_right[0][0]
    left = f"({factor})*({u})"
    right = f"({factor})*(({u}) + (x - 0.5)*({ca!r}*({ux_half}) + {cb!r}*({uy_half})))"
    return TwoRegionSolution(left, right, {"left": k_left, "right": k_right}, dict(rho_c))


def steady_solution(k_left=K_LEFT, k_right=K_RIGHT) -> TwoRegionSolution:
    """Smooth steady solution: u = (sin(2x) + 1)(cos(1.5y) + y), K."""
    g_half, dg_half = math.sin(1.0) + 1.0, 2.0 * math.cos(1.0)
    return _two_region("(sin(2*x) + 1)*(cos(1.5*y) + y)", f"{dg_half!r}*(cos(1.5*y) + y)",
                       f"{g_half!r}*(-1.5*sin(1.5*y) + 1)", "1", k_left, k_right, RHO_C)


def transient_solution(k_left=K_LEFT, k_right=K_RIGHT) -> TwoRegionSolution:
    """T = (sin(2t) + exp(-t)) P(x, y) with P quadratic in each region, K (t in s).

    P2 elements represent T(t) exactly, so the semi-discrete (method of lines) solution is the exact one
    and the error at the end time is the time discretization error alone (across a contact interface this
    holds only if the coupling passes :func:`patch_test`).
    """
    return _two_region("1 + x - 0.5*y + x**2 - x*y + 0.75*y**2", "2 - y", "-1 + 1.5*y", "sin(2*t) + exp(-t)",
                       k_left, k_right, RHO_C)


def patch_solution(degree: int, k_left=K_LEFT, k_right=K_RIGHT) -> TwoRegionSolution:
    """Piecewise polynomial steady solution of ``degree`` 1 (linear) or 2 (quadratic) per region, K: a
    method must reproduce it to rounding error with elements of that order (patch test)."""
    if degree == 1:
        return _two_region("1 + x - 0.5*y", "1", "-0.5", "1", k_left, k_right, RHO_C)
    return _two_region("1 + x - 0.5*y + x**2 - x*y + 0.75*y**2", "2 - y", "-1 + 1.5*y", "1", k_left, k_right,
                       RHO_C)


def interface_jumps(solution: TwoRegionSolution, t: float = 0.0) -> dict:
    """Largest jumps of T (K) and of the normal flux (W/m^2) of a manufactured solution over 401 points of
    x = 0.5, 0 <= y <= 1: both must vanish (2.22)."""
    mesh = ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.1))
    tp = ngs.Parameter(t)
    # the expressions are defined everywhere: evaluate both on the line x = 0.5 (a mapped 1D rule)
    ys = np.linspace(0.0, 1.0, 401)
    pts = mesh(np.full_like(ys, 0.5), ys)
    jt = solution.temperature("left", tp)(pts).ravel() - solution.temperature("right", tp)(pts).ravel()
    jq = solution.flux("left", tp)[0](pts).ravel() - solution.flux("right", tp)[0](pts).ravel()
    return {"temperature_jump": float(np.max(np.abs(jt))), "flux_jump": float(np.max(np.abs(jq)))}


# -- scenes -------------------------------------------------------------------------------------------------
def two_region_scene(solution: TwoRegionSolution, maxh: float, order: int, interface: str, ratio: float,
                     scheme: str | None = None, dt: float = 0.1, t_end: float = 1.0, startup_steps: int = 0):
    """The scene dict of the split unit square: blocks ``left`` and ``right`` (the latter meshed with
    ``maxh * ratio``), interface ``mid`` of the given type, exact Dirichlet data on the outer boundary.
    ``scheme`` None: steady; else transient with that theta scheme, step ``dt`` up to ``t_end`` (s)."""
    if interface not in ("glued", "contact"):
        raise ValueError(f"interface must be 'glued' or 'contact', got {interface!r}")
    data = {
        "scene": {"name": "heat_mms", "dimension": "plane"},
        "physics": {"thermal": "steady" if scheme is None else "transient"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [
            {"name": "left", "shape": "rectangle", "origin": [0.0, 0.0], "size": [0.5, 1.0],
             "boundaries": {"outer_left": ["xmin", "ymin", "ymax"]}},
            {"name": "right", "shape": "rectangle", "origin": [0.5, 0.0], "size": [0.5, 1.0],
             "maxh": maxh * ratio, "boundaries": {"outer_right": ["xmax", "ymin", "ymax"]}}],
        "interfaces": [{"name": INTERFACE, "blocks": ["left", "right"], "type": interface}],
        "materials": {r: {"conductivity": [list(row) for row in solution.kappa[r]], "rho_c": solution.rho_c[r]}
                      for r in REGIONS},
        "boundary_conditions": {f"outer_{r}": {"temperature": solution.expression(r)} for r in REGIONS},
        "output": {"vtk": False, "figures": False},
    }
    if scheme is not None:
        data["time"] = {"start": 0.0, "end": t_end, "dt": dt, "scheme": scheme, "startup_steps": startup_steps}
    return scene_from_dict(data, source="heat_mms")


def prepare_two_region(scene, solution: TwoRegionSolution):
    """Mesh, forms (with the manufactured sources) and solver of a two-region scene."""
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    setup = heat_setup(scene, geo, mesh)
    steady = setup.steady
    setup.sources = {r: (lambda t, r=r: solution.source(r, t, steady)) for r in REGIONS}
    forms = HeatForms(mesh, setup)
    return mesh, forms, HeatSolver(forms)


def _errors(mesh, Th, solution: TwoRegionSolution, t, order: int) -> tuple[float, float]:
    """L2 (K m) and H1-seminorm (K) errors, integrated region by region."""
    e0 = e1 = 0.0
    for r in REGIONS:
        where = mesh.Materials(r)
        dT = Th - solution.temperature(r, t)
        dG = ngs.grad(Th) - solution.gradient(r, t)
        e0 += float(ngs.Integrate(dT * dT, mesh, order=2 * order + 6, definedon=where))
        e1 += float(ngs.Integrate(ngs.InnerProduct(dG, dG), mesh, order=2 * order + 6, definedon=where))
    return math.sqrt(e0), math.sqrt(e1)


# -- studies ------------------------------------------------------------------------------------------------
def steady_convergence(order: int, hs, interface: str = "glued", ratio: float = 0.7) -> dict:
    """Steady two-region manufactured solution (2.17), (2.19), (2.22) for mesh sizes ``hs`` (m).

    The right region is meshed with ``h * ratio``: with ``contact`` its nodes are independent of the left
    ones (non-matching meshes on x = 0.5); with ``glued`` the same sizes give a conforming mesh, so the
    two interface types are compared on like meshes. Returns ``h``, ``ndofs`` (including multiplier dofs),
    ``l2`` (K m), ``h1`` (H1 seminorm, K) errors and the fitted orders ``order_l2``, ``order_h1``.
    """
    solution = steady_solution()
    out = {"order": order, "interface": interface, "ratio": ratio, "h": [], "ndofs": [], "l2": [], "h1": []}
    for h in hs:
        mesh, forms, solver = prepare_two_region(two_region_scene(solution, h, order, interface, ratio), solution)
        forms.t_new.Set(0.0)
        solver.solve("steady manufactured solution")
        e0, e1 = _errors(mesh, forms.temperature(), solution, forms.t_new, order)
        out["h"].append(float(h))
        out["ndofs"].append(int(forms.X.ndof))
        out["l2"].append(e0)
        out["h1"].append(e1)
    out["order_l2"] = observed_order(out["h"], out["l2"])
    out["order_h1"] = observed_order(out["h"], out["h1"])
    return out


def patch_test(order: int, interface: str = "glued", maxh: float = 0.25, ratio: float = 0.7) -> dict:
    """Steady patch test: the piecewise polynomial :func:`patch_solution` of degree ``order`` (at most 2)
    must be reproduced exactly by elements of that order, also across a contact interface with
    non-matching meshes (a consistent coupling). Returns ``l2`` (K m) and ``h1`` (K) errors, ``ndofs``.

    Measured with the mortar coupling as of this writing: glued ~1e-14; contact on non-matching meshes
    H1 errors ~1e-2 K for P1 and P2 (multiplier end dofs removed, element-based quadrature of the coupling).
    """
    solution = patch_solution(min(order, 2))
    mesh, forms, solver = prepare_two_region(two_region_scene(solution, maxh, order, interface, ratio), solution)
    forms.t_new.Set(0.0)
    solver.solve("steady patch test")
    e0, e1 = _errors(mesh, forms.temperature(), solution, forms.t_new, order)
    return {"order": order, "interface": interface, "maxh": maxh, "ndofs": int(forms.X.ndof), "l2": e0, "h1": e1}


def transient_convergence(scheme: str, dts, t_end: float = 1.0, order: int = 2, maxh: float = 0.25,
                          interface: str = "glued", ratio: float = 0.7, startup_steps: int = 0) -> dict:
    """Transient two-region manufactured solution (2.43) with time-dependent Dirichlet data, integrated with
    the theta ``scheme`` ('backward_euler' or 'crank_nicolson') at constant steps ``dts`` (s) to ``t_end``.

    The solution is in the P2 space at every time (see :func:`transient_solution`), so with ``order >= 2``
    the L2 error at ``t_end`` (K m) is the time error alone. ``startup_steps``: backward Euler steps first
    (Crank-Nicolson's start-up; they keep the second order: two O(dt^2) local errors). Returns ``dt``,
    ``steps``, ``ndofs``, ``l2`` and the fitted ``order`` (slope of log error against log dt).
    """
    solution = transient_solution()
    out = {"scheme": scheme, "order_space": order, "maxh": maxh, "interface": interface, "t_end": t_end,
           "dt": [], "steps": [], "ndofs": [], "l2": []}
    for dt in dts:
        scene = two_region_scene(solution, maxh, order, interface, ratio, scheme=scheme, dt=dt, t_end=t_end,
                                 startup_steps=startup_steps)
        mesh, forms, solver = prepare_two_region(scene, solution)
        ts = scene.time
        T = forms.temperature()
        forms.t_new.Set(ts.start)
        T.Set(mesh.MaterialCF({r: solution.temperature(r, forms.t_new) for r in REGIONS}))
        solver.set_dirichlet()
        steps = list(schedule(ts.start, ts.end, ts.dt))
        for a, b in steps:
            forms.gf_old.vec.data = forms.gf.vec
            forms.t_old.Set(a)
            forms.t_new.Set(b)
            forms.inv_dt.Set(1.0 / (b - a))
            solver.solve(f"manufactured step to t = {b:g} s")
        e0, _ = _errors(mesh, T, solution, forms.t_new, order)
        out["dt"].append(float(dt))
        out["steps"].append(len(steps))
        out["ndofs"].append(int(forms.X.ndof))
        out["l2"].append(e0)
    out["order"] = observed_order(out["dt"], out["l2"])
    return out


def kirchhoff_exact(x, length: float, b: float, t0: float, t1: float):
    """Closed-form T(x) (K) of the slab with k = k0 (1 + b T): Theta(T) = T + b T^2 / 2 is linear in x."""
    th0, th1 = t0 + b * t0 ** 2 / 2, t1 + b * t1 ** 2 / 2
    theta = th0 + (th1 - th0) * x / length
    sqrt = ngs.sqrt if isinstance(theta, ngs.CoefficientFunction) else np.sqrt
    return (-1 + sqrt(1 + 2 * b * theta)) / b


def kirchhoff_slab(order: int = 1, hs=(0.1, 0.05, 0.025), length: float = 1.0, height: float = 0.2,
                   k0: float = 2.0, b: float = 0.01, t0: float = 0.0, t1: float = 100.0) -> dict:
    """Steady slab 0 < x < ``length`` (m), top and bottom insulated (2.20), T(0) = ``t0``, T(L) = ``t1`` (2.19),
    k(T) = k0 (1 + b T) (W/(m K), b in 1/K, T_ref = 0), solved by Newton's method in
    :class:`HeatSolver` from the scene's material data (the path of :func:`ngs_geomech.run.run_scene`).

    With b = 0.01 1/K and T from 0 to 100 K the conductivity doubles across the slab. Returns per h the
    ``max_nodal`` error (K, over mesh vertices), ``max_sampled`` error (K, at 2001 points of the mid line
    y = height/2), ``l2`` error (K m), ``newton_iterations``, ``ndofs``, the fitted orders ``order_max_nodal``,
    ``order_max_sampled``, ``order_l2``, and ``nonlinear_effect`` = max |T - T_linear| (K), the distance of
    the exact solution from the constant-k one (how strong the nonlinearity is).
    """
    xs = np.linspace(0.0, length, 2001)
    exact_line = kirchhoff_exact(xs, length, b, t0, t1)
    out = {"order": order, "b": b, "h": [], "ndofs": [], "max_nodal": [], "max_sampled": [], "l2": [],
           "newton_iterations": [],
           "nonlinear_effect": float(np.max(np.abs(exact_line - (t0 + (t1 - t0) * xs / length))))}
    for h in hs:
        data = {
            "scene": {"name": "kirchhoff_slab", "dimension": "plane"},
            "physics": {"thermal": "steady"},
            "mesh": {"maxh": h, "order": order},
            "blocks": [{"name": "slab", "shape": "rectangle", "origin": [0.0, 0.0], "size": [length, height],
                        "boundaries": {"cold": "xmin", "hot": "xmax"}}],
            "materials": {"slab": {"conductivity": k0, "conductivity_temperature_coefficient": b,
                                   "reference_temperature": 0.0}},
            "boundary_conditions": {"cold": {"temperature": t0}, "hot": {"temperature": t1}},
            "output": {"vtk": False, "figures": False},
        }
        scene = scene_from_dict(data, source="kirchhoff_slab")
        geo = validate(scene)
        mesh = make_mesh(geo, scene.mesh)
        forms = HeatForms(mesh, heat_setup(scene, geo, mesh))
        forms.t_new.Set(0.0)
        info = HeatSolver(forms).solve("Kirchhoff slab")
        Th = forms.temperature()
        xy = np.array([v.point for v in mesh.vertices])
        nodal = Th(mesh(xy[:, 0], xy[:, 1])).ravel()
        exact = kirchhoff_exact(ngs.x, length, b, t0, t1)
        out["h"].append(float(h))
        out["ndofs"].append(int(forms.X.ndof))
        out["max_nodal"].append(float(np.max(np.abs(nodal - kirchhoff_exact(xy[:, 0], length, b, t0, t1)))))
        line = Th(mesh(xs, np.full_like(xs, height / 2))).ravel()
        out["max_sampled"].append(float(np.max(np.abs(line - exact_line))))
        out["l2"].append(math.sqrt(float(ngs.Integrate((Th - exact) ** 2, mesh, order=2 * order + 6))))
        out["newton_iterations"].append(int(info.iterations))
    out["order_max_nodal"] = observed_order(out["h"], out["max_nodal"])
    out["order_max_sampled"] = observed_order(out["h"], out["max_sampled"])
    out["order_l2"] = observed_order(out["h"], out["l2"])
    return out
