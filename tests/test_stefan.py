"""Verification of the two-phase Stefan problem in enthalpy form (seed (2.46)-(2.51), (2.55)): the Neumann
closed forms, the enthalpy method with the semi-smooth Newton solver on a strip against them (front, L2 error,
energy balance, Newton iterations, time per step against a linear heat step), the smeared apparent heat
capacity method on the same problem, a PCM glued to a plain rock with sources and fluxes, and bad data.

Levels: h = 0.05, 0.025, 0.0125 m with dt = 0.2 h s (h and dt refined together), t = 0.05 -> 0.5 s. Expected:
P1 with lumping and backward Euler across the kink of the solution: about first order in h for the L2 error,
the front and the energy (measured orders 0.9-1.4, asserted >= 0.7 or 0.8); the front from the temperatures
moves from node to node (a mushy node is at Theta_R), so its error is only bounded by about one element.
"""

from __future__ import annotations

import functools
import math

import ngsolve as ngs
import numpy as np
import pytest
from netgen.occ import Box, Glue, OCCGeometry, Rectangle, X, Y

from ngs_geomech.errors import SolverError
from ngs_geomech.fem.timesteps import schedule
from ngs_geomech.stefan.forms import StefanForms, StefanSetup
from ngs_geomech.stefan.materials import PhaseChangeMaterial, PlainThermalMaterial
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.verification import stefan as st

pytestmark = pytest.mark.usefixtures("one_thread")

HS = (0.05, 0.025, 0.0125)
DT_OVER_H = 0.2
T0, T1 = 0.05, 0.5


def rates(hs, errors) -> list[str]:
    out = ["-"]
    for k in range(1, len(hs)):
        out.append(f"{math.log(errors[k - 1] / errors[k]) / math.log(hs[k - 1] / hs[k]):.2f}")
    return out


def print_levels(title: str, res: dict, columns: tuple[str, ...]) -> None:
    print(f"\n{title}")
    print(f"{'h':>8} {'dt':>8} {'dofs':>6} " + " ".join(f"{c[:22]:>22} {'rate':>5}" for c in columns)
          + f" {'newton mean/max':>16} {'ms/step':>8} {'lin ms':>7} {'lin+fact':>8}")
    r = {c: rates(res["h"], [lv[c] for lv in res["levels"]]) for c in columns}
    for k, lv in enumerate(res["levels"]):
        timing = (f" {1e3 * lv['time_per_step']:8.2f} {1e3 * lv['linear_step_time']:7.2f} "
                  f"{1e3 * lv['linear_step_time_factor']:8.2f}" if "linear_step_time" in lv else "")
        print(f"{lv['h']:8.4g} {lv['dt']:8.4g} {lv['ndofs']:6d} "
              + " ".join(f"{lv[c]:22.3e} {r[c][k]:>5}" for c in columns)
              + f" {lv['newton_mean']:9.2f} / {lv['newton_max']:<4d}" + timing)


@functools.cache
def convergence(case: str, method: str = "enthalpy") -> dict:
    problem = st.TWO_PHASE if case == "two_phase" else st.ONE_PHASE
    return st.neumann_convergence(problem, HS, DT_OVER_H, T0, T1, method=method,
                                  delta_over_h=1.0 if method == "apparent" else None,
                                  linear_reference=method == "enthalpy")


# -- the closed forms ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("st_value, lam", [(0.1, 0.220016), (0.5, 0.464786), (1.0, 0.620063)])
def test_one_phase_lambda_references(st_value, lam):
    one = st.one_phase_lambda(st_value)
    two = st.neumann_lambda(st_value, 0.0, 1.0)
    print(f"\nSt {st_value}: one-phase lam {one:.9f}, two-phase equation with St_S = 0: {two:.9f} (ref {lam})")
    assert abs(one - lam) < 5e-7
    assert abs(two - one) < 1e-12


def test_two_phase_lambda_satisfies_the_transcendental_equation():
    lam = st.neumann_lambda(1.0, 1.0, 1.0)
    assert abs(lam - 0.3777598) < 5e-8
    p = st.TWO_PHASE
    res = st.transcendental_residual(p.lam, p.stefan_liquid, p.stefan_solid, p.nu)
    print(f"\nTWO_PHASE: lam {p.lam:.12f}, residual {res:.2e}; St_L {p.stefan_liquid}, St_S {p.stefan_solid}, "
          f"nu {p.nu:.6f}")
    assert abs(res) < 1e-13
    # the one-phase limit: St_S -> 0
    lams = [st.neumann_lambda(0.5, s, p.nu) for s in (1e-2, 1e-4, 1e-6)]
    assert abs(lams[-1] - st.one_phase_lambda(0.5)) < 1e-6
    assert lams[0] < lams[1] < lams[2]


@pytest.mark.parametrize("problem", [st.TWO_PHASE, st.ONE_PHASE], ids=["two_phase", "one_phase"])
def test_closed_form_satisfies_the_stefan_conditions(problem):
    """T = Theta_R on the front from both sides and L ds/dt = -k_l T_x(s-) + k_s T_x(s+) (2.46), by finite
    differences of the closed form."""
    m = problem.material
    t, eps = 0.3, 1e-6
    s = problem.front(t)
    tl = problem.temperature(s - 1e-12, t)
    ts = problem.temperature(s + 1e-12, t)
    grad_l = (problem.temperature(s - eps, t) - problem.temperature(s - 2 * eps, t)) / eps
    grad_s = (problem.temperature(s + 2 * eps, t) - problem.temperature(s + eps, t)) / eps
    speed = (problem.front(t + eps) - problem.front(t - eps)) / (2 * eps)
    lhs = m.latent_heat * speed
    rhs = -m.conductivity_liquid * grad_l + m.conductivity_solid * grad_s
    print(f"\nfront {s:.6f} m: T(s-) {tl:.2e}, T(s+) {ts:.2e}; L ds/dt {lhs:.6f}, flux jump {rhs:.6f} W/m^2")
    assert abs(tl - m.melting_temperature) < 1e-9 and abs(ts - m.melting_temperature) < 1e-9
    assert abs(lhs - rhs) < 1e-4 * abs(lhs)
    assert float(problem.temperature(problem.domain_length(T1), T1)) - problem.t_cold < 1e-6


# -- the enthalpy method against the Neumann solutions --------------------------------------------------------
@pytest.mark.parametrize("case, front_min, l2_min, energy_min",
                         [("two_phase", 0.8, 0.8, 0.7), ("one_phase", 0.8, 0.8, None)])
def test_neumann_convergence(case, front_min, l2_min, energy_min):
    res = convergence(case)
    lv0 = res["levels"][0]
    print_levels(f"Neumann {case} (lam {lv0['lam']:.6f}, front {lv0['front_exact']:.4f} m at t = {T1} s, "
                 f"strip {lv0['length']:.3f} x {lv0['height']} m), enthalpy method, semi-smooth Newton", res,
                 ("front_error_volume", "front_error_temperature", "l2", "energy_error_rel"))
    print(f"fitted orders: front (volume) {res['order_front_volume']:.2f}, front (T crossing) "
          f"{res['order_front_temperature']:.2f}, L2 {res['order_l2']:.2f}, energy {res['order_energy']:.2f}")
    assert res["order_front_volume"] >= front_min
    assert res["order_l2"] >= l2_min
    if energy_min is not None:
        assert res["order_energy"] >= energy_min
    for lv in res["levels"]:
        assert lv["front_error_temperature"] <= 1.5 * lv["h"]       # node to node
        assert lv["front_error_volume"] < 0.15 * lv["h"]
        assert lv["l2_rel"] < 0.01
        assert lv["energy_error_rel"] < 0.01


@pytest.mark.parametrize("case", ["two_phase", "one_phase"])
def test_energy_balance_and_newton_iterations(case):
    res = convergence(case)
    print(f"\n{case}: energy gain vs heat entering at the Dirichlet nodes (relative imbalance), vs the exact heat "
          f"input (relative error); Newton iterations; factorizations; time per step (ms) vs a linear heat step "
          f"reusing its factorization / factoring")
    for lv in res["levels"]:
        print(f"h {lv['h']:<7g} imbalance {lv['energy_imbalance_rel']:.1e}  vs exact {lv['energy_error_rel']:.2e}  "
              f"Newton mean {lv['newton_mean']:.2f} max {lv['newton_max']}  factorizations {lv['factorizations']} "
              f"/ {lv['steps']} steps  {1e3 * lv['time_per_step']:.2f} ms vs {1e3 * lv['linear_step_time']:.2f} / "
              f"{1e3 * lv['linear_step_time_factor']:.2f} ms; initial heat content error "
              f"{lv['initial_energy_error_rel']:.1e}")
        assert lv["energy_imbalance_rel"] < 1e-10
        assert lv["initial_energy_error_rel"] < 1e-6
        assert lv["newton_mean"] <= 4.0
        assert lv["newton_max"] <= 6
    means = [lv["newton_mean"] for lv in res["levels"]]
    assert max(means) <= means[0] + 1.5          # not growing much with refinement


def test_apparent_heat_capacity_on_the_same_problem():
    """The smeared method (delta = h K/m, capacity lagged) on the two-phase problem: it converges more slowly
    in L2 and does not conserve energy (measured imbalance 0.3-0.8 %)."""
    app, ent = convergence("two_phase", "apparent"), convergence("two_phase")
    print_levels("Neumann two_phase, apparent heat capacity (delta = h K/m, C_app lagged)", app,
                 ("front_error_volume", "front_error_temperature", "l2", "energy_imbalance_rel"))
    print(f"fitted orders apparent: L2 {app['order_l2']:.2f}, front (volume) {app['order_front_volume']:.2f}; "
          f"enthalpy: L2 {ent['order_l2']:.2f}, front (volume) {ent['order_front_volume']:.2f}")
    for a, e in zip(app["levels"], ent["levels"]):
        assert a["energy_imbalance_rel"] > 1e-4 > 1e-10 > e["energy_imbalance_rel"]
        assert a["newton_max"] <= 6
    assert app["l2"][-1] > 2 * ent["l2"][-1]


# -- several regions, sources and fluxes --------------------------------------------------------------------
def ice_and_rock(h: float = 0.1):
    a = Rectangle(1, 1).Face()
    a.faces.name = "ice"
    a.edges.Min(X).name = "cold"
    b = Rectangle(1, 1).Face().Move((1, 0, 0))
    b.faces.name = "rock"
    b.edges.Max(Y).name = "heated"
    return ngs.Mesh(OCCGeometry(Glue([a, b]), dim=2).GenerateMesh(maxh=h))


ICE = PhaseChangeMaterial(melting_temperature=0.0, latent_heat=3.06e8, rho_c_solid=1.9e6, rho_c_liquid=4.2e6,
                          conductivity_solid=2.2, conductivity_liquid=0.6)
ROCK = PlainThermalMaterial(rho_c=2.1e6, conductivity=3.0)


def test_ice_glued_to_rock_conserves_energy():
    """Ice (SI data) glued to a heated rock with a source: the nodal graph mixes the two materials on the
    interface; the heat gained equals the heat supplied (sources, flux, Dirichlet side) to rounding."""
    mesh = ice_and_rock()
    setup = StefanSetup(materials={"ice": ICE, "rock": ROCK}, dirichlet={"cold": -5.0}, flux={"heated": 40.0},
                        sources={"rock": 20.0})
    forms = StefanForms(mesh, setup)
    solver = StefanSolver(forms)
    solver.set_initial(np.full(forms.n, -5.0))
    e0 = forms.heat_content(solver.e)
    supplied, iters = 0.0, []
    day = 86400.0
    for a, b in schedule(0.0, 400 * day, 4 * day):
        info = solver.step(a, b)
        supplied += info.boundary_heat + info.source_heat
        iters.append(info.iterations)
    gain = forms.heat_content(solver.e) - e0
    T = solver.temperature()
    melted = forms.melted_volume(solver.e)
    print(f"\nice + rock, 100 steps of 4 d: gain {gain:.6e} J/m, supplied {supplied:.6e} J/m, relative imbalance "
          f"{abs(gain - supplied) / abs(supplied):.1e}; T {T.min():.3f} .. {T.max():.3f} degC; melted "
          f"{melted:.4f} m^2, latent heat {forms.latent_heat_stored(solver.e):.4e} J/m; Newton mean "
          f"{np.mean(iters):.2f} max {max(iters)}")
    assert abs(gain - supplied) < 1e-10 * abs(supplied)
    assert 0.0 < melted < 1.0
    assert T.min() >= -5.0 - 1e-9
    assert max(iters) <= 6
    phi = forms.gf_liquid_fraction.vec.FV().NumPy()
    assert phi.min() >= 0.0 and phi.max() <= 1.0


def test_three_dimensional_box_conserves_energy():
    """A PCM box heated on one face (tetrahedra, vertex rule with weights 1/24): energy balance to rounding."""
    box = Box((0, 0, 0), (1, 0.5, 0.5))
    box.faces.Min(X).name = "hot"
    box.solids.name = "pcm"
    mesh = ngs.Mesh(OCCGeometry(box).GenerateMesh(maxh=0.15))
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": st.ONE_PHASE.material}, dirichlet={"hot": 1.0}))
    solver = StefanSolver(forms)
    solver.set_initial(np.full(forms.n, -0.2))
    e0, supplied, iters = forms.heat_content(solver.e), 0.0, []
    for a, b in schedule(0.0, 0.3, 0.02):
        info = solver.step(a, b)
        supplied += info.boundary_heat
        iters.append(info.iterations)
    gain = forms.heat_content(solver.e) - e0
    print(f"\n3D box, {forms.n} nodes: gain {gain:.6f} J, supplied {supplied:.6f} J, melted "
          f"{forms.melted_volume(solver.e):.4f} m^3, Newton {iters}")
    assert abs(gain - supplied) < 1e-10 * supplied
    assert 0.0 < forms.melted_volume(solver.e) < 0.25
    assert max(iters) <= 6


def test_newton_failure_is_a_solver_error_with_a_diagnosis():
    """A step far too large for the mesh (the front must cross dozens of element layers) and too few
    iterations: a SolverError naming the time and the remedy, no NaN."""
    p = st.ONE_PHASE
    mesh = st.strip_mesh(p.domain_length(T1), 0.1, 0.025)
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": p.material}, dirichlet={"hot": p.t_hot, "far": 0.0}))
    solver = StefanSolver(forms, maxit=5)
    solver.set_initial_enthalpy(st.initial_enthalpy(forms, p, T0))
    with pytest.raises(SolverError, match=r"t = 0\.5 s did not converge in 5 iterations.*reduce the time step"):
        solver.step(T0, T1)
    assert np.all(np.isfinite(solver.e))


# -- bad data -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("key, value, pattern", [
    ("latent_heat", -1.0, r"latent_heat must be >= 0, got -1\.0"),
    ("rho_c_solid", 0.0, r"rho_c_solid must be > 0, got 0\.0"),
    ("rho_c_liquid", -2.0, r"rho_c_liquid must be > 0, got -2\.0"),
    ("conductivity_liquid", 0.0, r"conductivity_liquid must be > 0, got 0\.0"),
    ("melting_temperature", float("nan"), r"melting_temperature must be finite, got nan")])
def test_bad_phase_change_data(key, value, pattern):
    data = dict(melting_temperature=0.0, latent_heat=1.0, rho_c_solid=1.0, rho_c_liquid=1.0,
                conductivity_solid=1.0, conductivity_liquid=1.0)
    data[key] = value
    with pytest.raises(ValueError, match=pattern):
        PhaseChangeMaterial(**data)


def test_bad_plain_data_and_setup():
    with pytest.raises(ValueError, match=r"rho_c must be > 0, got -1\.0"):
        PlainThermalMaterial(rho_c=-1.0, conductivity=1.0)
    with pytest.raises(ValueError, match=r"conductivity must be > 0, got 0\.0"):
        PlainThermalMaterial(rho_c=1.0, conductivity=0.0)
    mesh = ice_and_rock(0.5)
    with pytest.raises(ValueError, match=r"no material for the region\(s\) \['rock'\]"):
        StefanForms(mesh, StefanSetup(materials={"ice": ICE}))
    with pytest.raises(ValueError, match=r"dirichlet boundary\(ies\) \['hot'\] not in the mesh"):
        StefanForms(mesh, StefanSetup(materials={"ice": ICE, "rock": ROCK}, dirichlet={"hot": 1.0}))
    with pytest.raises(ValueError, match=r"t_hot = -1\.0 must be above the melting temperature 0\.0"):
        st.NeumannProblem(ICE, t_hot=-1.0, t_cold=-2.0)
    forms = StefanForms(mesh, StefanSetup(materials={"ice": ICE, "rock": ROCK}))
    with pytest.raises(ValueError, match=r"dt must be positive"):
        StefanSolver(forms).step(1.0, 1.0)


def test_freezing_is_the_mirror_image_of_melting():
    """Freezing (verification notes section 1: the mirror image). The two-phase Neumann melting solution T of a
    material M gives, with T' = 2 Theta_R - T, the freezing of a liquid M' whose liquid has M's solid properties
    and whose solid has M's liquid properties, from a face held at 2 Theta_R - T_L: the frozen layer grows as
    s(t) = 2 lam sqrt(a t). The enthalpy solver on M' (started from the mirrored exact state at t0) must give
    the same front and L2 error as on the melting strip, at first order in h."""
    p = st.TWO_PHASE
    m = p.material
    tm = m.melting_temperature
    mirror = PhaseChangeMaterial(melting_temperature=tm, latent_heat=m.latent_heat, rho_c_solid=m.rho_c_liquid,
                                 rho_c_liquid=m.rho_c_solid, conductivity_solid=m.conductivity_liquid,
                                 conductivity_liquid=m.conductivity_solid)
    t0, t1 = 0.05, 0.5
    rows = []
    for h in (0.025, 0.0125):
        length = p.domain_length(t1)
        mesh = st.strip_mesh(length, 0.1, h)
        forms = StefanForms(mesh, StefanSetup(materials={"pcm": mirror},
                                              dirichlet={"hot": 2 * tm - p.t_hot, "far": 2 * tm - p.t_cold}))
        solver = StefanSolver(forms)
        xs = np.array([v.point[0] for v in mesh.vertices])
        solver.set_initial(2 * tm - p.temperature(xs, t0), (xs >= p.front(t0)).astype(float))
        for a, b in schedule(t0, t1, 0.2 * h):
            solver.step(a, b)
        frozen = (forms.mass.sum() - forms.melted_volume(solver.e)) / 0.1
        T = solver.temperature()
        Th = ngs.GridFunction(forms.V)
        Th.vec.FV().NumPy()[:] = T
        exact = 2 * tm - p.temperature_cf(t1)
        l2 = math.sqrt(float(ngs.Integrate((Th - exact) ** 2, mesh, order=12)))
        melt = st.neumann_strip(p, h, 0.2 * h, t0, t1, linear_reference=False, initial="interpolate")
        rows.append((h, abs(frozen - p.front(t1)) / p.front(t1), l2, melt["front_error_volume"] / p.front(t1),
                     melt["l2"]))
    for h, fe, l2, mfe, ml2 in rows:
        print(f"\nfreezing h = {h}: front rel. error {fe:.3e} (melting {mfe:.3e}), L2 {l2:.3e} (melting {ml2:.3e})")
        assert fe == pytest.approx(mfe, rel=1e-6, abs=1e-12)
        assert l2 == pytest.approx(ml2, rel=1e-6)
    order = math.log(rows[0][1] / rows[1][1]) / math.log(2.0)
    print(f"freezing front order {order:.2f}")
    assert rows[1][1] < 0.01 and order > 0.7
