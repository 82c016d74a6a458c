"""The global evolutionary model (issue 9): inertia, Kelvin-Voigt and Prony viscosity, dynamic contact."""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest
from ngsolve.meshes import MakeStructured2DMesh

from ngs_geomech.contact.forms import contact_operator_2d
from ngs_geomech.contact.solver import ContactLaw
from ngs_geomech.dynamics.forms import PronyBranch, ViscoelasticForms, ViscousProperties, branch_coefficients
from ngs_geomech.dynamics.solver import DynamicSolver, ViscousSolver, generalized_alpha_parameters
from ngs_geomech.fem.coefficients import expression_function
from ngs_geomech.mechanics.forms import ElasticForms, ElasticSetup
from ngs_geomech.mechanics.materials import ElasticProperties, isotropic
from ngs_geomech.verification import dynamics as vd
from ngs_geomech.verification.study import observed_order

pytestmark = pytest.mark.usefixtures("one_thread")


def test_generalized_alpha_parameters():
    assert generalized_alpha_parameters(1.0) == pytest.approx((0.5, 0.5, 0.25, 0.5))
    am, af, beta, gamma = generalized_alpha_parameters(0.0)
    assert (am, af, beta, gamma) == pytest.approx((-1.0, 0.0, 1.0, 1.5))
    with pytest.raises(ValueError):
        generalized_alpha_parameters(1.5)
    assert branch_coefficients(0.0, 1.0) == (1.0, 1.0)
    a, c = branch_coefficients(0.1, 1.0)
    assert a == pytest.approx(math.exp(-0.1)) and c == pytest.approx((1 - math.exp(-0.1)) / 0.1)


def test_bar_frequency_orders_in_h_and_dt():
    hs, errs = [], []
    for n in (4, 8, 16):
        r = vd.bar_vibration(n, 1000)
        hs.append(r["h"])
        errs.append(r["rel_error"])
        assert r["energy_drift_rel"] < 1e-10
    order_h = observed_order(hs, errs)
    dts, terrs = [], []
    for s in (10, 20, 40):
        r = vd.bar_vibration(16, s)
        dts.append(r["dt"])
        terrs.append(r["time_rel_error"])
        assert r["time_rel_error"] == pytest.approx(r["time_rel_error_theory"], rel=1e-2)
    order_dt = observed_order(dts, terrs)
    print(f"bar frequency: rel errors {[f'{e:.2e}' for e in errs]} (h order {order_h:.2f}); time errors "
          f"{[f'{e:.2e}' for e in terrs]} (dt order {order_dt:.2f})")
    assert errs[-1] < 5e-4
    assert abs(order_h - 2) < 0.15 and abs(order_dt - 2) < 0.15



def test_base_driven_bar_energy_balance_counts_the_dirichlet_work():
    """A bar driven at its base, u(0, t) = a sin(omega t) (a standing wave, :func:`vd.driven_bar`): the change of
    the energy equals the work of the support's reaction on the prescribed displacement to round-off (Newmark,
    rho_inf = 1), and that work converges to the closed form -rho A a^2 omega^2 tan(k L) sin^2(omega t) / (2 k)
    with order 2 in h and dt together (measured 1.5e-2, 3.9e-3)."""
    r = [vd.driven_bar(n, 5 * n) for n in (8, 16)]
    def col(key):
        return ", ".join(f"{x[key]:.2e}" for x in r)
    print(f"driven bar, n = 8, 16: energy balance {col('balance_rel_error')}, Dirichlet work vs closed form "
          f"{col('work_rel_error')}, tip {col('tip_rel_error')}")
    assert all(x["balance_rel_error"] < 1e-10 for x in r)
    assert r[1]["work_rel_error"] < 0.02 and r[1]["tip_rel_error"] < 5e-3
    assert 3.5 < r[0]["work_rel_error"] / r[1]["work_rel_error"] < 4.5

def test_generalized_alpha_damps_and_keeps_second_order():
    r1 = vd.bar_vibration(8, 8, periods=4)
    r5 = vd.bar_vibration(8, 8, periods=4, rho_inf=0.5)
    print(f"energy after 4 periods of 8 steps: rho_inf = 1 {r1['energy_ratio']:.12f}, 0.5 {r5['energy_ratio']:.6f}")
    assert r1["energy_ratio"] == pytest.approx(1.0, abs=1e-10)
    assert r5["energy_ratio"] < 0.999
    e = [vd.bar_vibration(8, s, rho_inf=0.5)["time_rel_error"] for s in (20, 40)]
    assert math.log2(e[0] / e[1]) == pytest.approx(2.0, abs=0.2)


@pytest.mark.parametrize("model,test,expected", [("kelvin_voigt", "creep", 1), ("sls", "creep", 2),
                                                 ("sls", "relaxation", None)])
def test_viscoelastic_closed_forms(model, test, expected):
    dts = (0.1, 0.05, 0.025)
    errs = [vd.creep(model, test, dt)["max_rel_error"] for dt in dts]
    print(f"{model} {test}: max rel errors {[f'{e:.2e}' for e in errs]}")
    if expected is None:       # constant strain: the exponential branch rule is exact
        assert max(errs) < 1e-12
    else:
        assert abs(observed_order(dts, errs) - expected) < 0.15
        assert errs[-1] < (1e-2 if expected == 1 else 1e-5)


def test_impact_energy_duration_no_chattering():
    r = vd.block_impact(16)
    print(f"impact: energy gain {r['energy_gain_rel']:.1e}, duration {r['duration_num']:.4e} vs "
          f"{r['duration_exact']:.4e} (rel {r['duration_rel_error']:.3f}), switches per node max "
          f"{r['node_switches_max']}, rebound {r['rebound_velocity_rel']:.3f}")
    assert r["energy_gain_rel"] <= 1e-10
    assert abs(r["energy_loss_rel"]) <= 1e-10      # persistent contact and release: no loss either
    assert r["duration_rel_error"] <= 1.01 / 32    # one step (dt = h/c, 32 steps of contact)
    assert r["node_switches_max"] == 2 and r["status_switches"] == 2   # closes once, opens once
    assert r["max_penetration"] < 1e-15
    # the consistent mass chatters and loses energy (why the redistribution is the default of the study)
    c = vd.block_impact(16, mass="consistent", redistribute=False)
    assert c["energy_gain_rel"] <= 1e-10 and c["node_switches_max"] > 2


def test_impact_with_gap_only_loses_energy():
    """A block a gap above the foundation (closed within a step): the contact removes lam g_n, never adds."""
    dt = 0.7 / 8 / math.sqrt(vd.E_BAR / vd.RHO_BAR)
    r = vd.block_impact(8, cfl=0.7, gap=0.37 * dt * 1.0)     # closes 0.37 of a step into the step (v0 = 1 m/s)
    print(f"impact after a gap: energy loss {r['energy_loss_rel']:.2e}, gain {r['energy_gain_rel']:.1e}")
    assert r["energy_gain_rel"] <= 1e-10 and r["energy_loss_rel"] > 1e-6


def _block(E=1e9, nu=0.25, rho=1000.0):
    mesh = MakeStructured2DMesh(quads=False, nx=2, ny=2)
    props = {"dom": ElasticProperties(C=isotropic(E, nu), alpha=np.zeros((3, 3)), beta=np.zeros((3, 3)),
                                      density=rho)}
    return mesh, props


def test_viscous_block_on_foundation_contact_and_dissipation():
    """A Kelvin-Voigt block (no lateral support: held by friction-free contact and a symmetry side) under a top
    pressure on a rigid foundation: quasi-static backward Euler creeps to the elastic contact solution, the
    contact force balances the load, and the dissipation density integrates to the dissipated energy."""
    E, p, tau = 1e9, 1e6, 1.0
    mesh, props = _block(E)
    setup = ElasticSetup(props=props, model="plane_strain", order=1, symmetry=["left"])
    setup.pressure["top"] = expression_function(p)
    forms = ViscoelasticForms(ElasticForms(mesh, setup), {"dom": ViscousProperties(viscosity=tau * props["dom"].C)})
    op = contact_operator_2d(mesh, forms.elastic.V, "f", "bottom", None, axisymmetric=False,
                             obstacle=((0.0, 0.0), (0.0, 1.0)))
    solver = ViscousSolver(forms, contact=[(op, ContactLaw())])
    solver.set_initial()
    dt, integral = 0.25, 0.0
    for _ in range(40):
        solver.step(dt)
        integral += dt * ngs.Integrate(forms.dissipation_density(), mesh)
    lam_n, _ = solver.multipliers[0]
    assert float(lam_n @ op.weight) == pytest.approx(p * 1.0, rel=1e-8)
    eyy = ngs.Integrate(ngs.grad(forms.elastic.displacement())[1, 1], mesh)
    nu = 0.25
    # plane strain uniaxial stress, relaxed (the backward Euler creep is (1 + dt/tau)^-40 = 1.3e-4 from the end)
    assert eyy == pytest.approx(-p * (1 - nu ** 2) / E, rel=3e-4)
    assert integral == pytest.approx(solver.dissipated, rel=1e-10)
    assert solver.dissipated > 0


def test_dynamic_prony_energy_balance_and_checks():
    """SLS block vibrating freely: the energy balance (stored + dissipated = initial) closes to round-off with
    rho_inf = 1, and the branch dissipation is positive; bad input is refused by name."""
    mesh, props = _block()
    setup = ElasticSetup(props=props, model="plane_strain", order=1, symmetry=["left", "bottom"])
    visc = {"dom": ViscousProperties(branches=(PronyBranch(0.5 * props["dom"].C, 1e-4),))}
    forms = ViscoelasticForms(ElasticForms(mesh, setup), visc)
    solver = DynamicSolver(forms)
    u0 = np.zeros(forms.elastic.X.ndof)
    u0[:forms.nv] = 1e-5 * np.random.default_rng(0).standard_normal(forms.nv)
    u0[~forms.free] = 0.0
    solver.set_initial(u0=u0)
    for _ in range(50):
        solver.step(2e-5)
    rec = solver.energy()
    assert abs(rec.numerical_dissipation) < 1e-10 * solver.energy_history[0].total
    assert rec.branch_dissipation > 0 and rec.total < solver.energy_history[0].total
    with pytest.raises(ValueError, match="relaxation time"):
        PronyBranch(props["dom"].C, 0.0)
    with pytest.raises(ValueError, match="unknown regions"):
        ViscoelasticForms(forms.elastic, {"granite": ViscousProperties()})
    with pytest.raises(ValueError, match="Kelvin-Voigt"):
        f2 = ViscoelasticForms(forms.elastic, {"dom": ViscousProperties(viscosity=props["dom"].C)})
        s2 = ViscousSolver(f2)
        s2.set_initial()
        s2.jump()
