"""The seed's reference algorithms for contact against the default semi-smooth Newton (primal-dual active set)
ContactSolver: Uzawa's algorithm (2.66) for Tresca and Coulomb friction (solvers.contact_uzawa) on the friction
block of verification.contact_problems, and the plain penalty method (ContactSolver(method="penalty")) on the
Hertz and patch tests: penetration ~ p / c and the pressure tends to the exact-constraint one like 1 / c.
Figures are printed (pytest -s)."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from ngs_geomech.contact.solver import ContactLaw, ContactSolver
from ngs_geomech.contact.uzawa import RHO_FACTOR, UzawaSolver
from ngs_geomech.errors import SolverError
from ngs_geomech.mechanics.materials import isotropic
from ngs_geomech.verification import contact_problems as cp

pytestmark = pytest.mark.usefixtures("one_thread")

E_BLOCK, NU_BLOCK, P_TOP = 10e9, 0.25, 5e6
MOD_BLOCK = float(isotropic(E_BLOCK, NU_BLOCK)[0, 0])     # the solvers' modulus (Pa); the block is L = 1 m wide


def _compare(push, law, **kw):
    ref = cp.friction_block(push, law=law)
    r = cp.friction_block(push, law=law, solver_factory=partial(UzawaSolver, **kw))
    info = r["info"]
    d_t = float(np.max(np.abs(r["lam_t"] - ref["lam_t"]))) / P_TOP
    d_n = float(np.max(np.abs(r["lam_n"] - ref["lam_n"]))) / P_TOP
    d_u = float(np.linalg.norm(r["u"] - ref["u"]) / np.linalg.norm(ref["u"]))
    print(f"\nUzawa {law} block, push {push}: {info.iterations} outer steps, {info.inner_iterations} inner "
          f"iterations ({info.factorizations} factorizations; ssn {ref['iterations']}), rho {info.rho[0]:.3g} Pa/m, "
          f"{info.wall_s:.2f} s; friction {r['friction_force']:.8e} (ssn {ref['friction_force']:.8e}) N/m, "
          f"max |dlam_t|, |dlam_n| = {d_t:.1e}, {d_n:.1e} p_top, |du|/|u| = {d_u:.1e}; stick {r['stick']}/"
          f"{ref['stick']}, slip {r['slip']}/{ref['slip']}")
    return r, ref, d_t, d_n, d_u


@pytest.mark.parametrize("law,push,max_outer", [
    ("tresca", "traction", 250),        # floating block, sticks in the middle: measured 180 steps
    ("tresca", "displacement", 5),      # slides: every node at the bound after the first projection (2)
    ("coulomb", "traction", 250),       # measured 173
    ("coulomb", "displacement", 20),    # measured 11 (the bound follows lam_n)
])
def test_uzawa_block_matches_ssn(law, push, max_outer):
    r, ref, d_t, d_n, d_u = _compare(push, law)
    info = r["info"]
    if push == "traction":     # sticks: the friction force balances the push
        assert r["friction_force"] == pytest.approx(r["applied"], rel=1e-8)
    else:                      # slides: the friction force is the capacity g_c L or F_c p L
        assert r["friction_force"] == pytest.approx(r["capacity"], rel=1e-8)
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)
    assert d_t < 1e-7 and d_n < 1e-7
    assert d_u < 1e-8
    assert (r["stick"], r["slip"]) == (ref["stick"], ref["slip"])
    assert info.iterations <= max_outer
    assert info.inner_iterations <= 2 * info.iterations + 5
    assert info.changes[-1] < 1e-10


def test_uzawa_step_size():
    """The number of steps goes like 1 / rho below the stability limit (about 4.5 modulus / L here), beyond it
    the iteration does not converge and the error names the interface and the last change."""
    counts = {}
    for fac in (1.0, 4.0):
        r = cp.friction_block("traction", law="tresca",
                              solver_factory=partial(UzawaSolver, rho=fac * MOD_BLOCK / 1.0))
        counts[fac] = r["info"].iterations
        assert r["friction_force"] == pytest.approx(r["applied"], rel=1e-8)
    print(f"\nUzawa Tresca block (stick), steps at rho = (1, 4) x modulus / L: {counts[1.0]}, {counts[4.0]} "
          f"(default factor {RHO_FACTOR})")
    assert 3.0 < counts[1.0] / counts[4.0] < 5.0
    with pytest.raises(SolverError, match=r"multipliers on foundation still change by .* after 60 Uzawa steps"):
        cp.friction_block("traction", law="tresca",
                          solver_factory=partial(UzawaSolver, rho=8 * MOD_BLOCK / 1.0, maxit=60))


@pytest.mark.parametrize("law,ratio", [("tresca", 1.1), ("coulomb", 1.5)])
def test_uzawa_floating_block_overload_is_reported(law, ratio):
    with pytest.raises(SolverError, match="friction on foundation cannot hold the tangential load"):
        cp.friction_block("traction", law=law, ratio=ratio, solver_factory=UzawaSolver)


def test_uzawa_frictionless_is_one_subproblem():
    r = cp.friction_block("none", law="frictionless", solver_factory=UzawaSolver)
    assert r["info"].iterations == 1
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)
    assert not np.any(r["lam_t"])


def _slope(c, e):
    return float(np.polyfit(np.log(c), np.log(e), 1)[0])


def test_penalty_hertz_converges_like_one_over_c(monkeypatch):
    """Plain penalty lam_n = c x penetration on the Hertz test (P1, h = a / 10): the penetration is p / c and
    the pressure on the axis tends to the exact-constraint (ssn) value like 1 / c."""
    a = cp.R_HERTZ / 50
    h = 0.1 * a
    mod = float(isotropic(cp.E_HERTZ, cp.NU_HERTZ)[0, 0])
    ref = cp.hertz(h, 1)
    cs, pens, diffs, errors = [], [], [], []
    for k in (1, 10, 100, 1000):
        c = k * mod / h
        monkeypatch.setattr(cp, "ContactLaw", partial(ContactLaw, augmentation=c))
        r = cp.hertz(h, 1, method="penalty")
        cs.append(c)
        pens.append(r["max_penetration"])
        diffs.append(abs(r["p0_num"] - ref["p0_num"]) / ref["p0"])
        errors.append(r["p0_rel_error"])
        assert r["force_balance"] < 1e-8
        assert r["max_penetration"] == pytest.approx(r["p0_num"] / c, rel=1e-6)   # the largest at the axis
    s_pen, s_p0 = _slope(cs, pens), _slope(cs, diffs)
    print("\npenalty Hertz P1 h = a/10, c = (1, 10, 100, 1000) x modulus / h: penetration "
          + ", ".join(f"{p:.3e}" for p in pens) + f" m (slope {s_pen:.3f}); p0 error "
          + ", ".join(f"{e:+.4%}" for e in errors) + f" (ssn {ref['p0_rel_error']:+.4%}); |p0 - p0_ssn| / p0 "
          + ", ".join(f"{d:.2e}" for d in diffs) + f" (slope {s_p0:.3f})")
    assert -1.1 < s_pen < -0.9
    assert -1.1 < s_p0 < -0.9
    assert abs(errors[-1] - ref["p0_rel_error"]) < 1e-3


def test_penalty_patch_test(monkeypatch):
    """The penalty method passes the patch test for every c (the uniform penetration p / c is a rigid shift
    the discrete space holds): uniform pressure p, penetration exactly p / c."""
    p, h = 1e6, 0.07
    mod = MOD_BLOCK
    monkeypatch.setattr(cp, "ContactSolver", partial(ContactSolver, method="penalty"))
    cs, pens = [], []
    for k in (1, 10, 100, 1000):
        c = k * mod / h
        monkeypatch.setattr(cp, "ContactLaw", partial(ContactLaw, augmentation=c))
        r = cp.patch_test(p, h_upper=h)
        cs.append(c)
        pens.append(r["max_penetration"])
        assert r["max_deviation"] < 1e-8
        assert r["max_penetration"] == pytest.approx(p / c, rel=1e-6)
    s = _slope(cs, pens)
    print("\npenalty patch test, c = (1, 10, 100, 1000) x modulus / h: penetration "
          + ", ".join(f"{x:.4e}" for x in pens) + f" m (slope {s:.4f})")
    assert -1.1 < s < -0.9
