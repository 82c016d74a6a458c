"""Verification of the global evolutionary model (seed (2.6)-(2.16)): inertia, Kelvin-Voigt and Prony viscosity,
dynamic contact, solved by :mod:`ngs_geomech.dynamics.solver` on the forms of :mod:`ngs_geomech.dynamics.forms`.

* :func:`bar_vibration`: free axial vibration of a bar (length L, fixed at y = 0, free at y = L, nu = 0 so that
  the axial motion is exactly one-dimensional, plane stress, P1 on a structured column of triangles, u_x = 0 on
  the sides: a slice of a wide body; without it the lowest modes are lateral), started
  from the first discrete mode: the frequency measured from the tip displacement of the time integration against
  the closed form omega_1 = pi c / (2 L), c = sqrt(E/rho); also against the semi-discrete frequency omega_h
  (the time error alone: the average-acceleration rule has tan(Omega dt/2) = omega_h dt/2, relative error
  (omega dt)^2/12).
* :func:`creep`: homogeneous uniaxial stress (or strain) in a unit square (plane stress, symmetry on x = 0 and
  y = 0): Kelvin-Voigt creep eps = s0/E (1 - exp(-t/tau_v)) and recovery after unloading at t1; standard linear
  solid (relaxed modulus E, one Prony branch r E, tau): creep eps = s0/E (1 - r/(1+r) exp(-t/((1+r) tau))) and
  relaxation s = eps0 E (1 + r exp(-t/tau)). C^v and C_1 are proportional to C, so the plane-stress reduction is
  exact and the 1D closed forms hold for any nu.
* :func:`driven_bar`: the bar of :func:`bar_vibration` driven at its base, u(0, t) = a sin(omega t), free at
  y = L, below its first resonance: the standing wave u(y, t) = a sin(omega t) cos(k (L - y)) / cos(k L),
  k = omega / c (started from its exact state: u = 0, u_t = a omega cos(k (L - y)) / cos(k L) at t = 0). Its
  energy (per unit thickness, width A) changes only by the work of the support on the bar,
  W_D(t) = int_0^t (-E A u_y(0, s)) a omega cos(omega s) ds = -rho A a^2 omega^2 tan(k L) sin^2(omega t) / (2 k):
  the solver's Dirichlet work against that closed form and against the energy change.
* :func:`block_impact`: an elastic block (nu = 0, height L) moving with -v0 onto a rigid foundation it touches at
  t = 0, frictionless: the energy history (no gain), the contact duration against 2 L / c (the 1D wave closed
  form), the contact pressure against rho c v0, the rebound velocity, and the contact status switches per node
  (chattering).

Every function returns a plain dict and prints nothing. Units: m, s, kg, Pa.
"""

from __future__ import annotations

import math
import time

import ngsolve as ngs
import numpy as np
import scipy.sparse.linalg as spla
from ngsolve.meshes import MakeStructured2DMesh

from ..contact.forms import contact_operator_2d
from ..contact.solver import ContactLaw
from ..dynamics.forms import PronyBranch, ViscoelasticForms, ViscousProperties
from ..dynamics.solver import DynamicSolver, ViscousSolver, contact_switches
from ..fem.coefficients import expression_function
from ..mechanics.forms import ElasticForms, ElasticSetup
from ..mechanics.materials import ElasticProperties, isotropic

E_BAR, RHO_BAR = 1.0e9, 2500.0


def _props(E: float, nu: float, rho: float, region: str = "dom") -> dict:
    return {region: ElasticProperties(C=isotropic(E, nu), alpha=np.zeros((3, 3)), beta=np.zeros((3, 3)),
                                      density=rho)}


def _column(n: int, L: float, width: float):
    """A structured mesh of the rectangle [0, width] x [0, L]: one column of 2 n triangles (boundaries bottom,
    right, top, left; region dom)."""
    return MakeStructured2DMesh(quads=False, nx=1, ny=n, mapping=lambda x, y: (width * x, L * y))


def _nodes_at(mesh, y: float) -> np.ndarray:
    pts = np.array([mesh[v].point for v in mesh.vertices])
    return np.where(np.abs(pts[:, 1] - y) < 1e-9)[0]


def measured_frequency(signal: np.ndarray, dt: float) -> float:
    """Omega (rad/s) of a sampled harmonic s_n = A cos(Omega n dt + phi): least squares on the recurrence
    s_{n+1} + s_{n-1} = 2 cos(Omega dt) s_n (exact for one discrete mode)."""
    s = np.asarray(signal, dtype=float)
    c = float(np.dot(s[1:-1], s[2:] + s[:-2]) / (2 * np.dot(s[1:-1], s[1:-1])))
    return math.acos(max(-1.0, min(1.0, c))) / dt


def bar_vibration(n: int, steps_per_period: int, *, periods: float = 1.0, L: float = 1.0, E: float = E_BAR,
                  rho: float = RHO_BAR, rho_inf: float = 1.0) -> dict:
    """Free axial vibration of a bar with n elements along L, started from the first discrete mode (module
    docstring), integrated over ``periods`` periods with ``steps_per_period`` steps of the closed-form period.

    Returns {"omega_exact", "omega_h" (semi-discrete), "omega_num" (measured), "rel_error" (omega_num vs exact),
    "space_rel_error" (omega_h vs exact), "time_rel_error" (omega_num vs omega_h), "time_rel_error_theory"
    (the average-acceleration closed form, rho_inf = 1), "energy_ratio" (E_end / E_0: the numerical damping of
    rho_inf < 1),
    "energy_drift_rel" (max |E_n - E_0| / E_0), "h", "dt", "steps", "ndof", "wall_s"}."""
    tic = time.perf_counter()
    h = L / n
    mesh = _column(n, L, h)
    setup = ElasticSetup(props=_props(E, 0.0, rho), model="plane_stress", order=1, symmetry=["left", "right"])
    setup.dirichlet["bottom"] = [expression_function(0.0), expression_function(0.0)]
    forms = ViscoelasticForms(ElasticForms(mesh, setup))
    c = math.sqrt(E / rho)
    omega = math.pi * c / (2 * L)
    T = 2 * math.pi / omega
    fr = forms.free
    Kf, Mf = forms.K[fr][:, fr].tocsc(), forms.M[fr][:, fr].tocsc()
    # a fixed start vector: ARPACK's random one makes the mode, and so the measured frequency, vary in the 8th digit
    vals, vecs = spla.eigsh(Kf, k=1, M=Mf, sigma=0.0, v0=np.ones(Kf.shape[0]))
    omega_h = math.sqrt(float(vals[0]))
    u0 = np.zeros(forms.elastic.X.ndof)
    u0[fr] = vecs[:, 0] / np.max(np.abs(vecs[:, 0])) * 1e-4
    dt = T / steps_per_period
    solver = DynamicSolver(forms, rho_inf=rho_inf)
    solver.set_initial(u0=u0)
    ns = forms.nv // 2
    top = ns + _nodes_at(mesh, L)
    tip = [float(np.mean(solver.u[top]))]
    nsteps = int(round(periods * steps_per_period))
    for _ in range(nsteps):
        solver.step(dt)
        tip.append(float(np.mean(solver.u[top])))
    omega_num = measured_frequency(np.array(tip), dt)
    theory = 2 * math.atan(omega_h * dt / 2) / dt if rho_inf == 1.0 else math.nan
    e = np.array([r.total for r in solver.energy_history])
    return {"omega_exact": omega, "omega_h": omega_h, "omega_num": omega_num, "rel_error": abs(omega_num / omega - 1),
            "space_rel_error": abs(omega_h / omega - 1), "time_rel_error": abs(omega_num / omega_h - 1),
            "time_rel_error_theory": abs(theory / omega_h - 1), "energy_ratio": float(e[-1] / e[0]),
            "energy_drift_rel": float(np.max(np.abs(e - e[0])) / e[0]),
            "h": h, "dt": dt, "steps": nsteps, "ndof": int(forms.elastic.X.ndof), "wall_s": time.perf_counter() - tic}


def driven_bar(n: int, steps_per_period: int, *, frequency_ratio: float = 0.5, periods: float = 1.0, L: float = 1.0,
               a: float = 1e-4, E: float = E_BAR, rho: float = RHO_BAR, rho_inf: float = 1.0) -> dict:
    """The base-driven bar (module docstring) with n elements along L, omega = ``frequency_ratio`` x the first
    resonance pi c / (2 L), over ``periods`` periods of ``steps_per_period`` steps.

    Returns {"balance_rel_error" (max_n |E_n - E_0 - W_D,n| / max_n |E_n|: 0 up to round-off for rho_inf = 1),
    "work_rel_error" (max_n |W_D,n - W_D(t_n)| / max |W_D|: the discretization error), "tip_rel_error"
    (max_n |u(L, t_n) - a sin(omega t_n) / cos(k L)| / (a / cos(k L))), "work_max" (max |W_D| closed form, J per
    unit thickness), "h", "dt", "steps", "wall_s"}."""
    tic = time.perf_counter()
    h = L / n
    mesh = _column(n, L, h)
    c = math.sqrt(E / rho)
    omega = frequency_ratio * math.pi * c / (2 * L)
    k = omega / c
    setup = ElasticSetup(props=_props(E, 0.0, rho), model="plane_stress", order=1, symmetry=["left", "right"])
    setup.dirichlet["bottom"] = [None, expression_function(f"{a}*sin({omega}*t)")]
    forms = ViscoelasticForms(ElasticForms(mesh, setup))
    ns = forms.nv // 2
    pts = np.array([mesh[v].point for v in mesh.vertices])
    v0 = np.zeros(forms.elastic.X.ndof)
    v0[ns:2 * ns] = a * omega * np.cos(k * (L - pts[:, 1])) / math.cos(k * L)
    solver = DynamicSolver(forms, rho_inf=rho_inf)
    solver.set_initial(v0=v0)
    dt = 2 * math.pi / omega / steps_per_period
    top = ns + _nodes_at(mesh, L)
    tip = [float(np.mean(solver.u[top]))]
    nsteps = int(round(periods * steps_per_period))
    for _ in range(nsteps):
        solver.step(dt)
        tip.append(float(np.mean(solver.u[top])))
    hist = solver.energy_history
    t = np.array([r.t for r in hist])
    e = np.array([r.total for r in hist])
    work = np.array([r.dirichlet_work for r in hist])
    exact = -rho * h * a * a * omega * omega * math.tan(k * L) * np.sin(omega * t) ** 2 / (2 * k)
    amp = a / math.cos(k * L)
    return {"balance_rel_error": float(np.max(np.abs(e - e[0] - work)) / np.max(np.abs(e))),
            "work_rel_error": float(np.max(np.abs(work - exact)) / np.max(np.abs(exact))),
            "tip_rel_error": float(np.max(np.abs(np.array(tip) - amp * np.sin(omega * t))) / amp),
            "work_max": float(np.max(np.abs(exact))), "h": h, "dt": dt, "steps": nsteps,
            "wall_s": time.perf_counter() - tic}


def creep(model: str, test: str, dt: float, *, t_end: float = 3.0, E: float = 1.0e9, nu: float = 0.25,
          s0: float = 1.0e6, tau: float = 1.0, ratio: float = 1.5, n: int = 2,
          branch_rule: str = "exponential") -> dict:
    """Homogeneous viscoelastic tests (module docstring) on a unit square with n x n cells: ``model`` in
    "kelvin_voigt" (C^v = tau C) or "sls" (one Prony branch ``ratio`` x C with relaxation time tau); ``test`` in
    "creep" (traction s0 on x = 1 from t = 0; Kelvin-Voigt: removed at t_end / 2, the recovery) or "relaxation"
    (SLS only: u_x = eps0 = s0/E on x = 1 from t = 0). Backward Euler with step dt (SLS: the instantaneous jump
    at t = 0 first).

    Returns {"t", "num", "exact" (strain e_xx for creep, stress s_xx (Pa) for relaxation, at the step ends),
    "max_rel_error" (max |num - exact| / max |exact|), "dt", "steps", "dissipated" (J per unit thickness,
    Kelvin-Voigt), "wall_s"}."""
    if model not in ("kelvin_voigt", "sls") or test not in ("creep", "relaxation"):
        raise ValueError(f"unknown test {model!r} / {test!r}")
    if model == "kelvin_voigt" and test == "relaxation":
        raise ValueError("Kelvin-Voigt has no relaxation test here (its stress under a held strain is E eps0): "
                         "the creep test includes the recovery after unloading")
    tic = time.perf_counter()
    mesh = MakeStructured2DMesh(quads=False, nx=n, ny=n)
    C = isotropic(E, nu)
    setup = ElasticSetup(props=_props(E, nu, 1.0), model="plane_stress", order=1, symmetry=["left", "bottom"])
    t_off = t_end / 2
    if test == "creep":
        if model == "kelvin_voigt":   # s0 up to t_off (a plain callable: time dependent), then 0

            def load(t):
                return s0 * ngs.IfPos(t - (t_off + 1e-6 * dt), 0.0, 1.0)
        else:
            load = expression_function(s0)
        setup.traction["right"] = [load, expression_function(0.0)]
    else:
        setup.dirichlet["right"] = [expression_function(s0 / E), None]
    visc = (ViscousProperties(viscosity=tau * C) if model == "kelvin_voigt"
            else ViscousProperties(branches=(PronyBranch(ratio * C, tau),)))
    forms = ViscoelasticForms(ElasticForms(mesh, setup), {"dom": visc})
    solver = ViscousSolver(forms, branch_rule=branch_rule)
    solver.set_initial()
    ef = forms.elastic
    ts, num = [], []

    def measure():
        u = ef.displacement()
        if test == "creep":
            return float(ngs.Integrate(ngs.grad(u)[0, 0], mesh))
        D = ef.cf_matrix(ef.D["dom"])
        s = (D * ef.strain_vector(u))[0] + forms.branch_stress(forms.branches[0])[0]
        return float(ngs.Integrate(s, mesh))
    if model == "sls":
        solver.jump()
        ts.append(0.0)
        num.append(measure())
    nsteps = int(round(t_end / dt))
    for _ in range(nsteps):
        solver.step(dt)
        ts.append(solver.t)
        num.append(measure())
    t = np.array(ts)
    if model == "kelvin_voigt":
        e1 = s0 / E * (1 - np.exp(-np.minimum(t, t_off) / tau))
        exact = np.where(t <= t_off + 1e-12, e1, s0 / E * (1 - math.exp(-t_off / tau)) * np.exp(-(t - t_off) / tau))
    elif test == "creep":
        exact = s0 / E * (1 - ratio / (1 + ratio) * np.exp(-t / ((1 + ratio) * tau)))
    else:
        exact = s0 * (1 + ratio * np.exp(-t / tau))
    num = np.array(num)
    return {"t": t.tolist(), "num": num.tolist(), "exact": exact.tolist(),
            "max_rel_error": float(np.max(np.abs(num - exact)) / np.max(np.abs(exact))), "dt": dt, "steps": nsteps,
            "dissipated": float(getattr(solver, "dissipated", 0.0)), "wall_s": time.perf_counter() - tic}


def block_impact(n: int, *, cfl: float = 1.0, L: float = 1.0, width: float | None = None, E: float = E_BAR,
                 rho: float = RHO_BAR, v0: float = 1.0, rho_inf: float = 1.0, mass: str = "lumped",
                 redistribute: bool = True, t_factor: float = 1.6, gap: float = 0.0) -> dict:
    """An elastic block (height L, n elements over L, nu = 0, plane stress) touching a rigid foundation at
    y = 0 with the velocity -v0 at t = 0 (frictionless contact), integrated with dt = cfl h / c up to
    t_factor x 2 L / c.

    Returns {"duration_exact" (2 L / c), "duration_num" (steps with a node in contact x dt), "duration_rel_error",
    "energy_gain_rel" (max_n (E_n - E_0) / E_0, <= 0 up to round-off), "energy_loss_rel" ((E_0 - E_end) / E_0),
    "energy" (E_n / E_0 per step), "t", "pressure_exact" (rho c v0), "pressure_mean" (mean of the contact force
    per width over the contact steps), "rebound_velocity_rel" (the mean velocity after the release, momentum /
    mass, over v0; 1 in the closed form), "impulse_rel" (the contact impulse over 2 m v0), node_switches,
    node_switches_max, status_switches, contact_periods (:func:`contact_switches`), "max_penetration" (m),
    "h", "dt", "steps", "ndof", "wall_s"}."""
    tic = time.perf_counter()
    h = L / n
    width = width if width is not None else h
    mesh = _column(n, L, width)
    setup = ElasticSetup(props=_props(E, 0.0, rho), model="plane_stress", order=1, symmetry=["left", "right"])
    forms = ViscoelasticForms(ElasticForms(mesh, setup))
    op = contact_operator_2d(mesh, forms.elastic.V, "foundation", "bottom", None, axisymmetric=False,
                             obstacle=((0.0, -gap), (0.0, 1.0)))
    solver = DynamicSolver(forms, rho_inf=rho_inf, scheme="generalized_alpha",
                           contact=[(op, ContactLaw("frictionless"))], mass=mass,
                           redistribute_contact_mass=redistribute)
    ns = forms.nv // 2
    v_init = np.zeros(forms.elastic.X.ndof)
    v_init[ns:2 * ns] = -v0
    solver.set_initial(v0=v_init)
    c = math.sqrt(E / rho)
    duration = 2 * L / c
    dt = cfl * h / c
    nsteps = int(math.ceil((t_factor * duration + gap / v0) / dt))
    forces, pen = [], 0.0
    for _ in range(nsteps):
        solver.step(dt)
        lam_n, _ = solver.multipliers[0]
        forces.append(float(np.dot(lam_n, op.weight)))
        pen = max(pen, float(np.max(-solver.gaps(solver.u)[0], initial=0.0)))
    sw = contact_switches(solver.steps)
    in_contact = np.array([bool(np.concatenate(s.active).any()) for s in solver.steps])
    e = np.array([r.total for r in solver.energy_history])
    e0 = e[0]
    last = int(np.max(np.where(in_contact)[0])) if in_contact.any() else -1
    my = solver.M.diagonal()[ns:2 * ns]
    momentum = float(my @ solver.v[ns:2 * ns])
    fm = np.array(forces)[in_contact] / width
    return {"duration_exact": duration, "duration_num": float(in_contact.sum() * dt),
            "duration_rel_error": abs(float(in_contact.sum() * dt) / duration - 1),
            "energy_gain_rel": float(np.max(e - e0) / e0), "energy_loss_rel": float((e0 - e[-1]) / e0),
            "energy": (e / e0).tolist(), "t": [r.t for r in solver.energy_history],
            "pressure_exact": rho * c * v0, "pressure_mean": float(np.mean(fm)) if len(fm) else 0.0,
            "rebound_velocity_rel": momentum / (float(my.sum()) * v0),
            "impulse_rel": float(np.sum(forces) * dt / (2 * float(my.sum()) * v0)), "release_step": last + 1, **sw,
            "max_penetration": pen, "h": h, "dt": dt, "steps": nsteps, "ndof": int(forms.elastic.X.ndof),
            "wall_s": time.perf_counter() - tic}
