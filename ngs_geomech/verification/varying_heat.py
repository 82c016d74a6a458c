"""Manufactured solutions of heat conduction with material data that vary in space and with the temperature,
run through the package's own path (a scene whose material values are expressions -> :func:`validate` ->
:func:`make_mesh` -> :func:`heat_setup` -> :class:`HeatForms` -> :class:`HeatSolver`).

Steady (2.17), (2.19) on the unit square (m), Dirichlet data from the exact temperature on the whole boundary:

    -div(kappa grad T) = Q,   T = (sin 2x + 1)(cos 1.5y + y)  (K),

with (a) kappa(x, y) = :data:`KAPPA_X` (W/(m K); erfc and a product: 1.6 to 3.3 W/(m K) on the square), a linear
problem, and (b) kappa(x, y, T) = :data:`KAPPA_XT` (W/(m K), T in K: the conductivity varies 2.5-fold over the
solution's range), solved by Newton's method whose tangent holds the term d kappa/dT dT grad T . grad v.

Transient (2.43): rho c(T) dT/dt - div(kappa(x, y, T) grad T) = Q with rho c(T) = :data:`RHO_C_T` (J/(m^3 K)) and
T = (sin 2t + e^-t) P(x, y), P quadratic, from its exact initial value, exact Dirichlet data: the heat capacity
enters the step as rho c(theta T + (1 - theta) T0) (T - T0)/dt and Newton's tangent holds d(rho c)/dT. Newton's
relative residuals of every step are returned: their observed order of convergence shows that the tangent is
exact (2; a tangent without the derivative terms converges linearly).

Q is derived exactly with ``CoefficientFunction.Diff`` from the CoefficientFunctions the forms use
(:func:`ngs_geomech.fem.coefficients.material_cf` with T replaced by the exact temperature); errors are integrated
with quadrature order 2p + 6. Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import math

import ngsolve as ngs

from ..fem.coefficients import expression_function, material_cf
from ..fem.timesteps import schedule
from ..geometry.mesh import make_mesh
from ..heat.forms import HeatForms
from ..heat.problem import heat_setup
from ..heat.solver import HeatSolver
from ..scene.parse import scene_from_dict
from ..validation.validate import validate
from .study import observed_order

T_STEADY = "(sin(2*x) + 1)*(cos(1.5*y) + y)"
"""The steady exact temperature, K (1 to 2.2 K on the unit square)."""
KAPPA_X = "1.5 + erfc(2*x - 1)*(1 + y*y)/2"
"""kappa(x, y), W/(m K)."""
KAPPA_XT = "(1 + 0.5*x*y)*(1 + 0.5*T**2)"
"""kappa(x, y, T), W/(m K) (T in K)."""
T_TRANSIENT = "(sin(2*t) + exp(-t))*(1 + x - 0.5*y + x**2 - x*y + 0.75*y**2)"
"""The transient exact temperature, K (t in s)."""
KAPPA_T = "(1 + 0.5*x*y)*(1 + 0.2*T**2)"
"""kappa(x, y, T) of the transient problem, W/(m K)."""
RHO_C_T = "2 + 0.5*T + 0.1*x"
"""rho c(x, T) of the transient problem, J/(m^3 K)."""
NOISE = 1e-13
"""Relative residuals below this are rounding: left out of the observed Newton order."""


def square_scene(maxh: float, order: int, conductivity: str, exact: str, *, rho_c: str | None = None,
                 scheme: str | None = None, dt: float = 0.1, t_end: float = 1.0):
    """The unit square ``square`` with the given material values and the exact temperature ``exact`` on its whole
    boundary (and as the initial value); ``scheme`` None: steady, else transient to ``t_end`` with steps ``dt``."""
    material = {"conductivity": conductivity}
    if rho_c is not None:
        material["rho_c"] = rho_c
    data = {
        "scene": {"name": "varying_heat", "dimension": "plane", "temperature_unit": "K"},
        "physics": {"thermal": "steady" if scheme is None else "transient"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [{"name": "square", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 1.0],
                    "boundaries": {"outer": "all"}}],
        "materials": {"square": material},
        "boundary_conditions": {"outer": {"temperature": exact}},
        "output": {"vtk": False, "figures": False},
    }
    if scheme is not None:
        data["initial"] = {"temperature": exact}
        data["time"] = {"start": 0.0, "end": t_end, "dt": dt, "scheme": scheme}
    return scene_from_dict(data, source="varying_heat")


def exact_source(exact: str, conductivity: str, rho_c: str | None, t):
    """Q = rho c(T) dT/dt - div(kappa(x, y, T) grad T) of the exact T (W/m^3; steady without ``rho_c``);
    ``t`` the Parameter the forms evaluate the load at."""
    T = expression_function(exact)(t)
    kappa = material_cf(conductivity, T)
    q = kappa * ngs.CoefficientFunction((T.Diff(ngs.x), T.Diff(ngs.y)))
    div = q[0].Diff(ngs.x) + q[1].Diff(ngs.y)
    return -div if rho_c is None else material_cf(rho_c, T) * T.Diff(t) - div


def prepare(scene, exact: str, conductivity: str, rho_c: str | None):
    """Mesh, forms (with the manufactured source) and solver of a square scene."""
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    setup = heat_setup(scene, geo, mesh)
    setup.sources = {"square": lambda t: exact_source(exact, conductivity, rho_c, t)}
    forms = HeatForms(mesh, setup)
    return mesh, forms, HeatSolver(forms)


def _errors(mesh, Th, exact: str, t, order: int) -> tuple[float, float]:
    """L2 (K m) and H1-seminorm (K) errors."""
    T = expression_function(exact)(t)
    dT, dG = Th - T, ngs.grad(Th) - ngs.CoefficientFunction((T.Diff(ngs.x), T.Diff(ngs.y)))
    e0 = float(ngs.Integrate(dT * dT, mesh, order=2 * order + 6))
    e1 = float(ngs.Integrate(ngs.InnerProduct(dG, dG), mesh, order=2 * order + 6))
    return math.sqrt(e0), math.sqrt(e1)


def steady_convergence(order: int, hs, law: str = "x") -> dict:
    """The steady manufactured solution with kappa(x, y) (``law`` 'x') or kappa(x, y, T) ('xT') for the mesh
    sizes ``hs`` (m): ``h``, ``ndofs``, ``l2`` (K m), ``h1`` (K) errors, ``newton_iterations`` per h and the
    fitted orders ``order_l2``, ``order_h1``."""
    conductivity = {"x": KAPPA_X, "xT": KAPPA_XT}[law]
    out = {"order": order, "law": law, "conductivity": conductivity, "h": [], "ndofs": [], "l2": [], "h1": [],
           "newton_iterations": []}
    for h in hs:
        mesh, forms, solver = prepare(square_scene(h, order, conductivity, T_STEADY), T_STEADY, conductivity, None)
        forms.t_new.Set(0.0)
        info = solver.solve(f"steady manufactured solution, kappa({law})")
        e0, e1 = _errors(mesh, forms.temperature(), T_STEADY, forms.t_new, order)
        out["h"].append(float(h))
        out["ndofs"].append(int(forms.X.ndof))
        out["l2"].append(e0)
        out["h1"].append(e1)
        out["newton_iterations"].append(int(info.iterations))
    out["order_l2"] = observed_order(out["h"], out["l2"])
    out["order_h1"] = observed_order(out["h"], out["h1"])
    return out


def newton_orders(residuals) -> list[float]:
    """Observed orders of convergence log(r_{k+1}/r_k) / log(r_k/r_{k-1}) of a residual history, over the triples
    whose residuals all lie above :data:`NOISE`."""
    r = [v for v in residuals if v > NOISE]
    return [math.log(r[k + 1] / r[k]) / math.log(r[k] / r[k - 1]) for k in range(1, len(r) - 1)]


def transient_run(scheme: str, dt: float, *, order: int = 2, maxh: float = 0.25, t_end: float = 1.0) -> dict:
    """The transient manufactured solution with kappa(x, y, T) and rho c(x, T), integrated with the theta
    ``scheme`` at the constant step ``dt`` (s): the L2 error at ``t_end`` (K m), ``ndofs``, ``steps``, per step
    the Newton ``residuals`` (relative) and ``iterations``, and ``newton_order_last``: per step the observed order
    of the last triple of residuals above :data:`NOISE` (None for steps with too few)."""
    scene = square_scene(maxh, order, KAPPA_T, T_TRANSIENT, rho_c=RHO_C_T, scheme=scheme, dt=dt, t_end=t_end)
    mesh, forms, solver = prepare(scene, T_TRANSIENT, KAPPA_T, RHO_C_T)
    T = forms.temperature()
    forms.t_new.Set(0.0)
    T.Set(expression_function(T_TRANSIENT)(forms.t_new))
    solver.set_dirichlet()
    out = {"scheme": scheme, "dt": dt, "order_space": order, "maxh": maxh, "ndofs": int(forms.X.ndof),
           "residuals": [], "iterations": [], "newton_order_last": []}
    steps = list(schedule(0.0, t_end, dt))
    for a, b in steps:
        forms.gf_old.vec.data = forms.gf.vec
        forms.t_old.Set(a)
        forms.t_new.Set(b)
        forms.inv_dt.Set(1.0 / (b - a))
        info = solver.solve(f"manufactured step to t = {b:g} s")
        out["residuals"].append([float(v) for v in info.residuals])
        out["iterations"].append(int(info.iterations))
        orders = newton_orders(info.residuals)
        out["newton_order_last"].append(orders[-1] if orders else None)
    out["steps"] = len(steps)
    out["l2"] = _errors(mesh, T, T_TRANSIENT, forms.t_new, order)[0]
    return out


def transient_convergence(scheme: str, dts, **kw) -> dict:
    """:func:`transient_run` for the steps ``dts`` (s): ``dt``, ``l2``, ``steps``, ``ndofs``, the fitted time
    ``order``, the Newton ``iterations_max`` and ``newton_order_min`` (the smallest last observed order over all
    steps with one)."""
    runs = [transient_run(scheme, dt, **kw) for dt in dts]
    orders = [q for r in runs for q in r["newton_order_last"] if q is not None]
    return {"scheme": scheme, "dt": [float(d) for d in dts], "l2": [r["l2"] for r in runs],
            "steps": [r["steps"] for r in runs], "ndofs": [r["ndofs"] for r in runs],
            "order": observed_order(list(dts), [r["l2"] for r in runs]),
            "iterations_max": max(max(r["iterations"]) for r in runs),
            "newton_order_min": min(orders) if orders else math.nan, "first_run": runs[0]}
