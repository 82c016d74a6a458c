"""Verification of the adaptive refinement: estimator effectivity indices on manufactured problems,
the re-entrant corner heat problem (uniform against adaptive, orders in dofs), and Hertz contact (uniform
against adaptive refinement: p0 and half-width errors against dofs and wall time).

* :func:`effectivities`: eta / ||e|| (energy norm) of the ``zz`` and ``residual`` estimators on the steady
  two-region anisotropic heat solution of :mod:`.manufactured` (glued interface) and on the two-region
  anisotropic thermo-elastic solution of :mod:`.thermoelastic` (plane strain, with thermal stress).
* :func:`corner_problem` / :func:`corner_convergence`: Laplace's equation on the L-shaped domain
  (-1, 1)^2 minus [0, 1] x [-1, 0] (m, kappa = 1 W/(m K)) with the exact singular solution
  T = r^(2/3) sin(2 theta/3) (K; theta in [0, 3 pi/2] from the +x axis): T = 0 on the two edges at the
  re-entrant corner ("reentrant", Dirichlet), the exact flux kappa grad T . n on the others ("outer", Neumann).
  grad T ~ r^(-1/3): T is in H^(1 + 2/3 - eps) only, so uniform P1 converges like h^(2/3) = dofs^(-1/3) in the
  energy norm, an optimal adaptive mesh like dofs^(-1/2). The energy error is exact by Galerkin orthogonality:
  ||grad(T - T_h)||^2 = ||grad T||^2 - int_outer q0 T_h ds (no quadrature of the singular gradient).
* :class:`HertzAdaptive` / :func:`hertz_convergence`: :func:`.contact_problems.hertz` (P1 or P2, frictionless,
  a quarter cylinder on a rigid flat) solved through :func:`ngs_geomech.adapt.loop.adaptive_solve` on a coarse
  :func:`.contact_problems.hertz_mesh`: the forms and the contact operators are rebuilt on every refined
  (and re-curved) mesh, the contact solver starts from the previous active set carried over by position. The
  uniform series refines every element of the same start mesh. Errors: p0 (nodal pressure on the axis) and
  the half width (midpoint of the last contact node and the first open one) against the closed form, and p0
  against a reference p0 computed on a finer adaptive mesh (the closed form is that of a half space: the
  finite cylinder differs from it by ~3e-3 in p0, which no refinement removes).

Nothing here prints or writes files; functions return plain dicts.
"""

from __future__ import annotations

import math
import time

import ngsolve as ngs
import numpy as np
from netgen.occ import Face as OccFace
from netgen.occ import OCCGeometry, Pnt, Segment, Wire

from ..adapt import estimators as est
from ..adapt.loop import StationaryHeat, adaptive_solve, refine_mesh, transfer_contact_sets
from ..adapt.marking import StopRule
from ..fem.coefficients import Steady
from ..heat.forms import HeatSetup
from ..heat.materials import ThermalProperties
from . import contact_problems as cp
from . import manufactured as mms
from . import thermoelastic as te


def dof_order(ndofs, errors) -> float:
    """-slope of log(error) against log(dofs) (least squares): the convergence order in dofs (2D P1 smooth: 1/2)."""
    if len(ndofs) < 2:
        return math.nan
    return float(-np.polyfit(np.log(np.asarray(ndofs, float)), np.log(np.asarray(errors, float)), 1)[0])


# ------------------------------------------------------------------------------------------------------------
# effectivity indices
# ------------------------------------------------------------------------------------------------------------

def effectivities(order: int = 1, hs=(0.2, 0.1, 0.05), estimators=("zz", "residual")) -> dict:
    """Effectivity indices eta / ||e|| (energy norm) of ``estimators`` on the manufactured heat (two anisotropic
    regions, glued) and thermo-elastic (two anisotropic regions, plane strain, thermal stress) solutions,
    elements of ``order``, mesh sizes ``hs`` (m). Returns {"heat": {...}, "elastic": {...}}, each with "h",
    "ndof", "error" (energy norm) and per estimator a list of effectivities."""
    out = {}
    heat = {"h": [], "ndof": [], "error": [], **{name: [] for name in estimators}}
    sol = mms.steady_solution()
    for h in hs:
        _, forms, solver = mms.prepare_two_region(mms.two_region_scene(sol, h, order, "glued", 0.7), sol)
        forms.t_new.Set(0.0)
        solver.solve("effectivity, manufactured heat")
        err = est.heat_energy_error(forms, {r: sol.gradient(r, forms.t_new) for r in mms.REGIONS})
        heat["h"].append(h)
        heat["ndof"].append(int(forms.X.ndof))
        heat["error"].append(err)
        for name in estimators:
            heat[name].append(est.get_estimator(name).function(forms).total / err)
    out["heat"] = heat
    elastic = {"h": [], "ndof": [], "error": [], **{name: [] for name in estimators}}
    for h in hs:
        prob = te.manufactured_problem(h, order)
        forms = prob["forms"]
        err = est.elastic_energy_error(forms, prob["strain"])
        elastic["h"].append(h)
        elastic["ndof"].append(int(forms.X.ndof))
        elastic["error"].append(err)
        for name in estimators:
            elastic[name].append(est.get_estimator(name).function(forms).total / err)
    out["elastic"] = elastic
    return out


# ------------------------------------------------------------------------------------------------------------
# re-entrant corner
# ------------------------------------------------------------------------------------------------------------

def corner_exact():
    """(T, grad T) of the corner solution as CFs of x, y (K, K/m)."""
    r = ngs.sqrt(ngs.x * ngs.x + ngs.y * ngs.y)
    a = ngs.atan2(ngs.y, ngs.x)
    theta = ngs.IfPos(-a, a + 2 * math.pi, a)
    T = r ** (2 / 3) * ngs.sin(2 * theta / 3)
    g = (2 / 3) * r ** (-1 / 3)
    return T, ngs.CoefficientFunction((-g * ngs.sin(theta / 3), g * ngs.cos(theta / 3)))


def corner_mesh(maxh: float = 0.5):
    """The L-shaped domain's mesh (module docstring), region "plate", boundaries "reentrant" and "outer"."""
    pts = [(0, 0), (1, 0), (1, 1), (-1, 1), (-1, -1), (0, -1)]
    face = OccFace(Wire([Segment(Pnt(*pts[k], 0), Pnt(*pts[(k + 1) % 6], 0)) for k in range(6)]))
    for k in range(6):
        face.edges[k].name = "reentrant" if k in (0, 5) else "outer"
    face.name = "plate"
    return ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=maxh))


def corner_problem(maxh: float = 0.5, order: int = 1) -> StationaryHeat:
    """The corner problem as a :class:`StationaryHeat` on a fresh :func:`corner_mesh`."""
    mesh = corner_mesh(maxh)
    _, g = corner_exact()
    n = ngs.specialcf.normal(2)
    setup = HeatSetup(props={"plate": ThermalProperties(kappa=np.eye(2), rho_c=None)}, order=order, steady=True,
                      dirichlet={"reentrant": Steady(lambda t: ngs.CoefficientFunction(0.0))},
                      flux={"outer": Steady(lambda t: g * n)})
    return StationaryHeat(mesh, setup)


def corner_energy_error(problem: StationaryHeat) -> float:
    """||grad(T - T_h)|| (K) by Galerkin orthogonality (module docstring)."""
    mesh = problem.mesh
    T, g = corner_exact()
    n = ngs.specialcf.normal(2)
    outer = mesh.Boundaries("outer")
    q = 2 * problem.setup.order + 10
    norm2 = float(ngs.Integrate(g * n * T, mesh, ngs.BND, order=q, definedon=outer))
    disc2 = float(ngs.Integrate(g * n * problem.forms.temperature(), mesh, ngs.BND, order=q, definedon=outer))
    return math.sqrt(max(norm2 - disc2, 0.0))


def corner_convergence(*, order: int = 1, maxh: float = 0.5, uniform_levels: int = 4, max_dofs: int = 20000,
                       estimator: str = "zz", marker: str = "doerfler", theta: float = 0.5) -> dict:
    """Uniform (``uniform_levels`` meshes, each refinement of every element of the last) against adaptive
    (``estimator``, ``marker``, ``theta``, up to ``max_dofs``) P``order`` solutions of the corner problem from
    the same start mesh (``maxh``, m). Returns per series "ndof", "error" (K), "estimate", "effectivity",
    "solve_s", "wall_s" (cumulative, s), and "order_uniform", "order_adaptive" (in dofs, fitted over the points
    with at least 4x the start mesh's dofs)."""
    out = {"order": order, "estimator": estimator, "marker": marker, "theta": theta}
    for kind in ("uniform", "adaptive"):
        problem = corner_problem(maxh, order)
        series = {"ndof": [], "error": [], "estimate": [], "solve_s": []}

        def record(step, prob, series=series):
            series["ndof"].append(step.ndof)
            series["error"].append(corner_energy_error(prob))
            series["estimate"].append(step.estimate)
            series["solve_s"].append(step.solve_s)
        if kind == "uniform":
            run = adaptive_solve(problem, estimator=estimator, marker="uniform",
                                 stop=StopRule(max_refinements=uniform_levels - 1), callback=record)
        else:
            run = adaptive_solve(problem, estimator=estimator, marker=marker, theta=theta,
                                 stop=StopRule(max_dofs=max_dofs, max_refinements=60), callback=record)
        series["wall_s"] = run.cumulative_wall_s()
        series["effectivity"] = [e / x for e, x in zip(series["estimate"], series["error"])]
        keep = [k for k, d in enumerate(series["ndof"]) if d >= 4 * series["ndof"][0]] \
            or list(range(len(series["ndof"])))
        series["fitted_order"] = dof_order([series["ndof"][k] for k in keep], [series["error"][k] for k in keep])
        series["stop"] = run.stop
        out[kind] = series
    out["order_uniform"] = out["uniform"]["fitted_order"]
    out["order_adaptive"] = out["adaptive"]["fitted_order"]
    return out


# ------------------------------------------------------------------------------------------------------------
# Hertz contact
# ------------------------------------------------------------------------------------------------------------

class HertzAdaptive:
    """:func:`.contact_problems.hertz` on a refinable :func:`.contact_problems.hertz_mesh` (an
    :class:`~ngs_geomech.adapt.loop.AdaptiveProblem`): each solve builds the forms and the contact operator on
    the current mesh; after a refinement the mesh is curved again to order max(order, 2) and the contact
    solver starts from the last active set carried to the new nodes (``warm``)."""

    def __init__(self, h_contact: float, order: int = 1, *, maxh: float | None = None, warm: bool = True):
        self.order = order
        self.curve_order = max(order, 2)
        self.mesh = cp.hertz_mesh(h_contact, order, maxh)
        self.warm = warm
        self._old = None
        self.result: dict = {}
        self.state: dict = {}

    @property
    def ndof(self) -> int:
        return int(self.state["forms"].X.ndof) if self.state else 0

    def solve(self) -> dict:
        sets = None
        if self.warm and self._old is not None:
            coords, old_sets = self._old
            sets = lambda op: [transfer_contact_sets(coords, old_sets, op.coords)]  # noqa: E731
        r = cp.hertz(0.0, self.order, mesh=self.mesh, initial_sets=sets, return_state=True)
        self.state = r.pop("state")
        forms = self.state["forms"]
        forms.gf.vec.FV().NumPy()[:] = self.state["u"][:forms.X.ndof]
        self.result = r
        return {k: r[k] for k in ("p0_num", "p0_rel_error", "a_num", "a_next", "a", "p0", "iterations",
                                  "factorizations", "wall_s")}

    def status(self) -> np.ndarray:
        lam_n, lam_t = self.state["solver"].multipliers[0]
        return est.contact_status("frictionless", lam_n, lam_t)

    def estimator_input(self, needs: str):
        if needs == "forms":
            return self.state["forms"]
        if needs == "contact":
            return self.mesh, [(self.state["op"], self.status())]
        raise ValueError(f"the Hertz problem has no {needs!r} input for an estimator")

    def refine(self, marks) -> None:
        status = self.status()
        self._old = (self.state["op"].coords.copy(), (status > 0, status == 1, np.zeros(len(status), bool)))
        refine_mesh(self.mesh, marks, self.curve_order)


def _hertz_errors(q: dict, p0_ref: float | None) -> dict:
    a_mid = 0.5 * (q["a_num"] + q["a_next"])
    out = {"p0_error": abs(q["p0_num"] / q["p0"] - 1), "a_error": abs(a_mid / q["a"] - 1)}
    if p0_ref is not None:
        out["p0_ref_error"] = abs(q["p0_num"] / p0_ref - 1)
    return out


def hertz_convergence(*, order: int = 1, h_contact_over_a: float = 1.0, uniform_levels: int = 4,
                      max_dofs: int = 20000, theta: float = 0.5, estimator: str = "zz",
                      indicators=("contact_zone",), options: dict | None = None, reference_dofs: int | None = None,
                      warm: bool = True) -> dict:
    """Hertz contact, uniform against adaptive refinement from the same start mesh (h_contact =
    ``h_contact_over_a`` x a on the contact arc), P``order``. Uniform: ``uniform_levels`` meshes; adaptive:
    ``estimator`` + ``indicators``, Doerfler ``theta``, up to ``max_dofs``; a reference p0 from an adaptive run
    to ``reference_dofs`` (default 4 x ``max_dofs``; 0: none). Returns per series "ndof", "p0_error",
    "a_error" (relative to the closed form), "p0_ref_error" (to the reference), "solve_s" (each solve: forms,
    contact operator and contact solve), "wall_s" (cumulative: solves, estimates, refinements), "iterations";
    and "p0_ref", "a" (m), "p0" (Pa)."""
    a = cp.R_HERTZ / 50
    runs = {}
    for kind, stop, marker in (("uniform", StopRule(max_refinements=uniform_levels - 1), "uniform"),
                               ("adaptive", StopRule(max_dofs=max_dofs, max_refinements=60), "doerfler")):
        problem = HertzAdaptive(h_contact_over_a * a, order, warm=warm)
        steps = []
        run = adaptive_solve(problem, estimator=estimator, indicators=indicators if kind == "adaptive" else (),
                             marker=marker, theta=theta, stop=stop, options=options,
                             callback=lambda step, prob, steps=steps: steps.append(step))
        runs[kind] = (run, steps)
    p0_ref = None
    if reference_dofs != 0:
        ref = HertzAdaptive(h_contact_over_a * a, order)
        run = adaptive_solve(ref, estimator=estimator, indicators=indicators, theta=theta, options=options,
                             stop=StopRule(max_dofs=reference_dofs or 4 * max_dofs, max_refinements=80))
        p0_ref = run.steps[-1].quantities["p0_num"]
        ref_ndof = run.steps[-1].ndof
    out = {"order": order, "a": a, "p0_ref": p0_ref, "reference_ndof": ref_ndof if p0_ref is not None else None}
    for kind, (run, steps) in runs.items():
        series = {"ndof": [s.ndof for s in steps], "solve_s": [s.solve_s for s in steps],
                  "wall_s": run.cumulative_wall_s(), "iterations": [s.quantities["iterations"] for s in steps],
                  "estimate": [s.estimate for s in steps], "p0_error": [], "a_error": [], "p0_ref_error": []}
        for s in steps:
            for k, v in _hertz_errors(s.quantities, p0_ref).items():
                series[k].append(v)
        out[kind] = series
    out["p0"] = runs["uniform"][1][0].quantities["p0"]
    return out


def reach_ratios(uniform: dict, adaptive: dict, key: str) -> dict:
    """How much the adaptive series needs to reach the error ``key`` of the finest uniform mesh: the first adaptive
    step with an error at most that of the finest uniform mesh, its dofs and cumulative wall time, and their
    ratios to the finest uniform mesh's dofs and solve time (a uniform solve on that mesh alone, no coarser
    ones). NaN ratios when the adaptive series never reaches it."""
    target = uniform[key][-1]
    hit = next((k for k, e in enumerate(adaptive[key]) if e <= target), None)
    if hit is None:
        return {"target": target, "step": None, "dof_ratio": math.nan, "time_ratio": math.nan}
    return {"target": target, "step": hit, "ndof": adaptive["ndof"][hit], "wall_s": adaptive["wall_s"][hit],
            "dof_ratio": adaptive["ndof"][hit] / uniform["ndof"][-1],
            "time_ratio": adaptive["wall_s"][hit] / uniform["solve_s"][-1]}


def timed(fn, *args, **kwargs):
    """(result, wall seconds) of fn(*args, **kwargs)."""
    tic = time.perf_counter()
    res = fn(*args, **kwargs)
    return res, time.perf_counter() - tic
