"""The two-phase Stefan problem with a temperature-dependent conductivity per phase,
k_phase(T) = k_phase (1 + b (T - T_ref)) (:mod:`ngs_geomech.stefan.forms`: the Kirchhoff variable
theta(T) = int_{Theta_R}^T k(s) ds is piecewise quadratic in T): a steady slab with a closed form and a melting
strip measured against its finest mesh, with the cost of a step against the same step with b = 0.

Steady slab (exact). On 0 <= x <= length with T(0) = T_hot > Theta_R, T(length) = T_cold < Theta_R, insulated
sides and no source, the steady state has div grad theta = 0 with theta continuous across the phase boundary,
so theta is linear in x:

    theta(T(x)) = theta_hot + (x / length) (theta_cold - theta_hot),     T(x) = theta^-1(...),
    front x_f = length theta_hot / (theta_hot - theta_cold)   (where theta = 0, T = Theta_R).

The linear theta is in the P1 space and solves the lumped discrete equations K theta = 0 exactly (the mass
term vanishes at steady state), so the nodal temperatures are exact up to round-off on any mesh; the front from
the nodal theta (linear interpolation along the bottom edge) too. The P1 interpolant of T converges at order 2
in L2 (T is smooth in each phase, with a kink at the front).

Melting strip (refinement). The strip [0, length] x [0, height] at T_cold, face x = 0 held at T_hot from t = 0,
backward Euler with dt = c h, measured at t1 against the finest level: the front from the melted volume (lumped
liquid fraction / height) and the temperature along the line y = height/2 (sampled, an L2 norm in x), the
energy balance (heat content gained against the heat that entered at the Dirichlet nodes), Newton iterations
per step, and the time per step against the same run with b = 0 (the fast path: one factorization reused with
low-rank corrections, or window-boundary solves on large meshes).

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import math
import time

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..fem.timesteps import schedule
from ..stefan.forms import StefanForms, StefanSetup
from ..stefan.materials import PhaseChangeMaterial
from ..stefan.solver import StefanSolver
from .stefan import NeumannProblem, single_threaded_blas, strip_mesh
from .study import observed_order, one_ngsolve_thread


def with_law(material: PhaseChangeMaterial, b: float, t_ref: float = 0.0) -> PhaseChangeMaterial:
    """``material`` with k(T) = k (1 + b (T - T_ref)) in both phases."""
    data = {k: getattr(material, k) for k in ("melting_temperature", "latent_heat", "rho_c_solid", "rho_c_liquid",
                                              "conductivity_solid", "conductivity_liquid")}
    return PhaseChangeMaterial(**data, conductivity_temperature_coefficient=b, reference_temperature=t_ref)


SLAB = with_law(PhaseChangeMaterial(melting_temperature=0.0, latent_heat=3.06e8, rho_c_solid=1.9e6,
                                    rho_c_liquid=4.2e6, conductivity_solid=2.2, conductivity_liquid=0.6), 0.01)
"""Ice-like data (SI, degC) with b = 0.01 1/K, T_ref = 0 in both phases (for T_hot = 30, T_cold = -40 degC the
conductivity ranges over 0.6 - 1.3 times its value at 0 degC)."""

STRIP = with_law(PhaseChangeMaterial(melting_temperature=0.0, latent_heat=60.0, rho_c_solid=3.0, rho_c_liquid=1.0,
                                     conductivity_solid=1.5, conductivity_liquid=1.0), 0.01)
"""Melting strip data: the two-phase Neumann case of :mod:`ngs_geomech.verification.stefan` with temperatures
x 30 (Theta_R = 0, T_hot = 30, T_cold = -20 K, L = 60 J/m^3: St_L = 0.5, St_S = 1) and b = 0.01 1/K (k 0.8 - 1.3
times its value at T_ref = 0)."""


def slab_exact(material: PhaseChangeMaterial, t_hot: float, t_cold: float, length: float, x) -> np.ndarray:
    """T(x) (K) of the steady slab (module docstring)."""
    th0, th1 = float(material.kirchhoff(t_hot)), float(material.kirchhoff(t_cold))
    x = np.asarray(x, dtype=float)
    return material.temperature_of_kirchhoff(th0 + (x / length) * (th1 - th0))


def slab_front(material: PhaseChangeMaterial, t_hot: float, t_cold: float, length: float) -> float:
    """X (m) of the steady phase boundary, theta = 0."""
    th0, th1 = float(material.kirchhoff(t_hot)), float(material.kirchhoff(t_cold))
    return length * th0 / (th0 - th1)


def _bottom_nodes(mesh) -> np.ndarray:
    nodes = {v.nr for el in mesh.Boundaries("bottom").Elements() for v in el.vertices}
    return np.array(sorted(nodes, key=lambda i: mesh.vertices[i].point[0]))


def steady_slab(material: PhaseChangeMaterial = SLAB, t_hot: float = 30.0, t_cold: float = -40.0,
                hs=(0.1, 0.05, 0.025), length: float = 1.0, height: float = 0.1, dt0: float = 1e4,
                steps: int = 30) -> dict:
    """The steady slab on netgen strips of size h: ``steps`` backward Euler steps from T linear in x, the first
    of ``dt0`` (s), each next one twice as long (the last ones far beyond the diffusion time, 7e6 s for SLAB, so
    that the state is steady to round-off; one huge step from the start needs about one Newton iteration per
    element layer the front crosses). Per level: the largest nodal
    error |T_i - T(x_i)| (K) relative to |T_hot - T_cold|, the L2 error of the P1 interpolant of T against the
    exact T (K m^(dim/2)), the front from the nodal theta (bottom edge) and from the melted volume against the
    exact one, Newton iterations per step."""
    out = {"h": list(hs), "levels": [], "front_exact": slab_front(material, t_hot, t_cold, length)}
    span = abs(t_hot - t_cold)
    with one_ngsolve_thread():
        for h in hs:
            mesh = strip_mesh(length, height, h)
            forms = StefanForms(mesh, StefanSetup(materials={"pcm": material},
                                                  dirichlet={"hot": t_hot, "far": t_cold}))
            solver = StefanSolver(forms)
            xs = np.array([v.point[0] for v in mesh.vertices])
            solver.set_initial(t_hot + (t_cold - t_hot) * xs / length)
            halvings = 0
            for k in range(steps):
                halvings += _step_or_split(solver, dt0 * (2.0 ** k - 1), dt0 * (2.0 ** (k + 1) - 1))
            T = solver.temperature()
            exact = slab_exact(material, t_hot, t_cold, length, xs)
            gf = ngs.GridFunction(forms.V)
            gf.vec.FV().NumPy()[:] = T
            th0, th1 = float(material.kirchhoff(t_hot)), float(material.kirchhoff(t_cold))
            exact_cf = _slab_exact_cf(material, th0, th1, length)
            l2 = math.sqrt(float(ngs.Integrate((gf - exact_cf) ** 2, mesh, order=10)))
            bottom = _bottom_nodes(mesh)
            theta = material.kirchhoff(T[bottom])
            j = int(np.nonzero(theta <= 0)[0][0])
            xb = xs[bottom]
            front_theta = xb[j - 1] + theta[j - 1] / (theta[j - 1] - theta[j]) * (xb[j] - xb[j - 1])
            out["levels"].append({
                "h": h, "ndofs": forms.n, "nodal_error_rel": float(np.max(np.abs(T - exact))) / span,
                "l2": l2, "front_theta_error": abs(front_theta - out["front_exact"]),
                "front_volume_error": abs(forms.melted_volume(solver.e) / height - out["front_exact"]),
                "newton_mean": float(np.mean(solver.iterations)), "newton_max": int(max(solver.iterations)),
                "factorizations": solver.factorizations, "halvings": halvings, "steps": len(solver.iterations)})
    out["l2"] = [lv["l2"] for lv in out["levels"]]
    out["order_l2"] = observed_order(list(hs), out["l2"])
    return out


def _step_or_split(solver: StefanSolver, a: float, b: float, infos: list | None = None, depth: int = 0) -> int:
    """One step from a to b, split in halves (recursively, at most 8 times) when Newton fails, as a scene run
    does (:class:`ngs_geomech.stefan.problem.StefanRun`); the steps' infos are appended to ``infos``; returns
    the number of splits."""
    mark = solver.mark()
    try:
        info = solver.step(a, b)
    except SolverError:
        if depth >= 8:
            raise
        solver.rewind(mark)
        mid = 0.5 * (a + b)
        return 1 + _step_or_split(solver, a, mid, infos, depth + 1) + _step_or_split(solver, mid, b, infos, depth + 1)
    if infos is not None:
        infos.append(info)
    return 0


def _slab_exact_cf(material: PhaseChangeMaterial, th0: float, th1: float, length: float):
    """The exact slab temperature as a CoefficientFunction of x (the inverse Kirchhoff map in closed form)."""
    m = material
    b = m.conductivity_temperature_coefficient
    f0 = 1.0 + b * (m.melting_temperature - m.reference_temperature)
    theta = th0 + (ngs.x / length) * (th1 - th0)
    out = []
    for k in (m.conductivity_liquid, m.conductivity_solid):
        y = theta / k
        out.append(m.melting_temperature + 2.0 * y / (f0 + ngs.sqrt(f0 * f0 + 2.0 * b * y)))
    return ngs.IfPos(theta, out[0], out[1])


def _line_values(mesh, gf, xs: np.ndarray, y: float) -> np.ndarray:
    return np.array([gf(mesh(float(x), y)) for x in xs])


def melting_strip(material: PhaseChangeMaterial = STRIP, t_hot: float = 30.0, t_cold: float = -20.0,
                  hs=(0.05, 0.025, 0.0125), h_ref: float = 0.00625, dt_over_h: float = 0.4, t0: float = 0.05,
                  t1: float = 0.4, length: float = 2.0, height: float = 0.1, samples: int = 801,
                  timing: bool = True) -> dict:
    """The melting strip (module docstring) on levels ``hs`` and the reference level ``h_ref`` (dt = dt_over_h h,
    s), from t0 to t1 (s), started at t0 from the nodal values of the Neumann solution of the same material with
    b = 0 (the same initial function on every level; from a uniform T_cold at t = 0 the first steps of the
    finest level asked the front to cross several layers). Steps whose Newton iteration fails are split in halves
    as in a scene run (counted in ``halvings``). Per level: front (m, from the melted volume) and its difference
    to the reference, the sampled L2
    difference of T along y = height/2 (K m^(1/2)), the energy imbalance |gain - heat in| / |heat in|, Newton
    iterations (mean, max), factorizations and extra solves (low-rank corrections) per step, the wall time per
    step, and with
    ``timing`` the same run with b = 0 (same mesh and steps): its time per step and its factorizations."""
    xs = np.linspace(0.0, length, samples)
    ymid = 0.5 * height
    b0 = with_law(material, 0.0)
    start_problem = NeumannProblem(b0, t_hot, t_cold)
    runs = []
    with one_ngsolve_thread(), single_threaded_blas():
        for h in list(hs) + [h_ref]:
            mesh = strip_mesh(length, height, h)
            lv = {"h": h}
            for tag, mat in (("", material), ("b0_", b0)) if (timing and h != h_ref) else (("", material),):
                forms = StefanForms(mesh, StefanSetup(materials={"pcm": mat}, dirichlet={"hot": t_hot,
                                                                                         "far": t_cold}))
                solver = StefanSolver(forms)
                xv = np.array([v.point[0] for v in mesh.vertices])
                solver.set_initial(start_problem.temperature(xv, t0), (xv < start_problem.front(t0)).astype(float))
                e0 = forms.heat_content(solver.e)
                infos: list = []
                halvings = 0
                start = time.perf_counter()
                for a, b in schedule(t0, t1, dt_over_h * h):
                    halvings += _step_or_split(solver, a, b, infos)
                wall = time.perf_counter() - start
                steps = len(infos)
                heat_in = sum(i.boundary_heat + i.source_heat for i in infos)
                corrections = sum(i.corrections for i in infos)
                gain = forms.heat_content(solver.e) - e0
                lv.update({f"{tag}time_per_step": wall / steps, f"{tag}factorizations_per_step":
                           solver.factorizations / steps, f"{tag}newton_mean": float(np.mean(solver.iterations)),
                           f"{tag}newton_max": int(max(solver.iterations))})
                if tag == "":
                    T = solver.temperature()
                    lv.update({"ndofs": forms.n, "steps": steps, "dt": dt_over_h * h, "halvings": halvings,
                               "corrections_per_step": corrections / steps,
                               "front": forms.melted_volume(solver.e) / height,
                               "energy_imbalance_rel": abs(gain - heat_in) / abs(heat_in),
                               "heat_in": heat_in, "T_min": float(T.min()), "T_max": float(T.max()),
                               "line": _line_values(mesh, forms.gf_temperature, xs, ymid)})
                else:
                    lv["b0_front"] = forms.melted_volume(solver.e) / height
            runs.append(lv)
    ref = runs[-1]
    dx = xs[1] - xs[0]
    for lv in runs[:-1]:
        d = lv["line"] - ref["line"]
        lv["front_diff"] = abs(lv["front"] - ref["front"])
        lv["l2_diff"] = math.sqrt(float(np.sum(d * d) - 0.5 * (d[0] ** 2 + d[-1] ** 2)) * dx)
    for lv in runs:
        del lv["line"]
    levels = runs[:-1]
    return {"levels": levels, "reference": ref, "h": list(hs),
            "order_front": observed_order(list(hs), [lv["front_diff"] for lv in levels]),
            "order_l2": observed_order(list(hs), [lv["l2_diff"] for lv in levels])}
