"""Closed-form contact solutions (ngs_geomech.verification.contact_closed_forms): Hertz line contact,
Cattaneo-Mindlin partial slip and the global sliding limits (verification.md sections 2 and 3). Checked against
the reference values, load balance by quadrature (int p = P, int q = Q), the Coulomb bound q <= mu p with
equality in the slip zones, and the location/value of the subsurface shear maximum.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

from ngs_geomech.verification.contact_closed_forms import (
    CATTANEO_REFERENCE,
    HERTZ_MAX_SHEAR,
    HERTZ_REFERENCE,
    INCLINE_REFERENCE,
    HertzLine,
    cattaneo_stick_half_width,
    cattaneo_traction,
    effective_modulus,
    hertz_line,
    hertz_pressure,
    hertz_subsurface,
    incline_sliding_force_ratio,
    tresca_sliding_force,
)

REF = HERTZ_REFERENCE
MU = 0.3


@pytest.fixture(scope="module")
def steel():
    E_star = effective_modulus(REF["E"], REF["nu"])
    return REF["P"], E_star, hertz_line(REF["P"], REF["R"], E_star)


# ------------------------------------------------------------------------------------------ Hertz


def test_effective_modulus():
    E_star = effective_modulus(210e9, 0.3)
    assert E_star == pytest.approx(2.3077e11, rel=1e-4)
    assert E_star == pytest.approx(210e9 / 0.91)
    # two identical bodies: half the rigid-flat value
    assert effective_modulus(210e9, 0.3, 210e9, 0.3) == pytest.approx(E_star / 2)
    # very stiff second body tends to the rigid value
    assert effective_modulus(210e9, 0.3, 1e20, 0.3) == pytest.approx(E_star, rel=1e-8)
    # steel on granite: compliances add
    expected = 1.0 / (0.91 / 210e9 + (1 - 0.24**2) / 70e9)
    assert effective_modulus(210e9, 0.3, 70e9, 0.24) == pytest.approx(expected)
    with pytest.raises(ValueError):
        effective_modulus(210e9, 0.3, 70e9)
    with pytest.raises(ValueError):
        effective_modulus(-1.0, 0.3)


def test_hertz_reference(steel):
    P, E_star, sol = steel
    assert isinstance(sol, HertzLine)
    assert E_star == pytest.approx(REF["E_star"], rel=1e-4)
    assert sol.a == pytest.approx(REF["a"], rel=1e-4)
    assert sol.p0 == pytest.approx(REF["p0"], rel=1e-4)
    assert sol.a == pytest.approx(1.6609e-4, rel=1e-4)
    assert sol.p0 == pytest.approx(3.8329e8, rel=1e-4)
    # the alternative form of p0 and R/a large (the notes' mesh advice)
    assert sol.p0 == pytest.approx(math.sqrt(P * E_star / (math.pi * REF["R"])))
    assert REF["R"] / sol.a > 50
    # scaling: a ~ sqrt(P), p0 ~ sqrt(P)
    sol4 = hertz_line(4 * P, REF["R"], E_star)
    assert sol4.a == pytest.approx(2 * sol.a)
    assert sol4.p0 == pytest.approx(2 * sol.p0)
    with pytest.raises(ValueError):
        hertz_line(-1.0, 0.05, E_star)


def test_hertz_pressure_profile_and_load(steel):
    P, _, (a, p0) = steel
    x = np.array([-2 * a, -a, -0.5 * a, 0.0, 0.5 * a, a, 1.5 * a])
    p = hertz_pressure(x, a, p0)
    assert isinstance(p, np.ndarray) and p.shape == x.shape
    np.testing.assert_allclose(p, p0 * np.array([0, 0, math.sqrt(0.75), 1, math.sqrt(0.75), 0, 0]), atol=1e-9 * p0)
    assert isinstance(hertz_pressure(0.0, a, p0), float)
    assert hertz_pressure(0.0, a, p0) == pytest.approx(p0)
    total, _ = quad(lambda s: hertz_pressure(s, a, p0), -2 * a, 2 * a, points=(-a, a), epsabs=0.0, epsrel=1e-10)
    assert total == pytest.approx(P, rel=1e-8)


def test_hertz_subsurface_surface_and_far_field(steel):
    _, _, (a, p0) = steel
    s = hertz_subsurface(0.0, a, p0)
    assert s.sigma_x == pytest.approx(-p0)
    assert s.sigma_z == pytest.approx(-p0)
    assert s.tau_max == pytest.approx(0.0, abs=1e-12 * p0)
    z = np.array([0.5, 1.0, 3.0, 10.0]) * a
    sol = hertz_subsurface(z, a, p0)
    assert sol.sigma_z.shape == z.shape
    # compressive and decaying; sigma_z -> -p0 a/z, sigma_x ~ -p0 a^3/(4 z^3)
    assert np.all(np.asarray(sol.sigma_z) < 0) and np.all(np.asarray(sol.sigma_x) < 0)
    assert np.all(np.diff(sol.sigma_z) > 0)
    np.testing.assert_allclose(sol.tau_max, 0.5 * (sol.sigma_x - sol.sigma_z))
    far = hertz_subsurface(1e3 * a, a, p0)
    assert far.sigma_z == pytest.approx(-p0 * 1e-3, rel=1e-5)
    assert far.sigma_x == pytest.approx(-p0 * 1e-9 / 4, rel=1e-3)
    with pytest.raises(ValueError):
        hertz_subsurface(-a, a, p0)


def test_hertz_subsurface_shear_maximum(steel):
    _, _, (a, p0) = steel
    res = minimize_scalar(lambda t: -hertz_subsurface(t * a, a, p0).tau_max / p0, bounds=(0.1, 3.0),
                          method="bounded", options={"xatol": 1e-10})
    z_over_a, tau_over_p0 = res.x, -res.fun
    assert z_over_a == pytest.approx(HERTZ_MAX_SHEAR["z_over_a"], abs=5e-4)
    assert tau_over_p0 == pytest.approx(HERTZ_MAX_SHEAR["tau_over_p0"], abs=5e-4)
    # cross-check on a dense grid
    t = np.linspace(0.0, 5.0, 50001)
    tau = hertz_subsurface(t * a, a, p0).tau_max / p0
    i = int(np.argmax(tau))
    assert t[i] == pytest.approx(0.786, abs=1e-3)
    assert tau[i] == pytest.approx(0.300, abs=5e-4)


# ------------------------------------------------------------------------------------------ Cattaneo-Mindlin


def test_cattaneo_reference_ratios():
    assert CATTANEO_REFERENCE["mu"] == MU
    for q_over_p, c_over_a in CATTANEO_REFERENCE["values"]:
        assert cattaneo_stick_half_width(q_over_p, 1.0, MU, 1.0) == pytest.approx(c_over_a, abs=1e-6)
    got = [cattaneo_stick_half_width(r * 1e5, 1e5, MU, 2.0) / 2.0 for r in (0.05, 0.15, 0.25)]
    np.testing.assert_allclose(got, [0.912871, 0.707107, 0.408248], atol=1e-6)
    assert cattaneo_stick_half_width(0.0, 1.0, MU, 1.0) == pytest.approx(1.0)
    assert cattaneo_stick_half_width(-0.15, 1.0, MU, 1.0) == pytest.approx(0.707107, abs=1e-6)
    for q in (0.3, 0.31, -0.3):
        with pytest.raises(ValueError):
            cattaneo_stick_half_width(q, 1.0, MU, 1.0)


@pytest.mark.parametrize("q_over_p", [0.05, 0.15, 0.25])
def test_cattaneo_traction_balance_and_coulomb(steel, q_over_p):
    P, _, (a, p0) = steel
    Q = q_over_p * P
    c = cattaneo_stick_half_width(Q, P, MU, a)
    total, _ = quad(lambda s: cattaneo_traction(s, a, c, p0, MU), -1.5 * a, 1.5 * a, points=(-a, -c, c, a),
                    epsabs=0.0, epsrel=1e-10)
    assert total == pytest.approx(Q, rel=1e-8)

    x = np.linspace(-1.5 * a, 1.5 * a, 6001)
    q = cattaneo_traction(x, a, c, p0, MU)
    p = hertz_pressure(x, a, p0)
    tol = 1e-12 * p0
    assert np.all(q >= -tol)
    assert np.all(q <= MU * p + tol)  # Coulomb bound everywhere
    slip = (np.abs(x) > c) & (np.abs(x) < a)
    stick = np.abs(x) < c
    outside = np.abs(x) >= a
    np.testing.assert_allclose(q[slip], MU * p[slip], rtol=0, atol=tol)  # equality in the slip zones
    assert np.all(q[stick] < MU * p[stick])  # strictly below in the stick zone
    np.testing.assert_array_equal(q[outside], 0.0)
    # the stick-zone traction is the difference of two ellipses; its centre value
    assert cattaneo_traction(0.0, a, c, p0, MU) == pytest.approx(MU * p0 * (1 - c / a))
    assert isinstance(cattaneo_traction(0.0, a, c, p0, MU), float)


def test_cattaneo_limits(steel):
    _, _, (a, p0) = steel
    x = np.linspace(-a, a, 101)
    # no tangential load: c = a, no traction; c = 0: full sliding traction mu p
    np.testing.assert_allclose(cattaneo_traction(x, a, a, p0, MU), 0.0, atol=1e-9 * p0)
    np.testing.assert_allclose(cattaneo_traction(x, a, 0.0, p0, MU), MU * hertz_pressure(x, a, p0))
    with pytest.raises(ValueError):
        cattaneo_traction(x, a, 1.1 * a, p0, MU)


# ------------------------------------------------------------------------------------------ global sliding


def test_incline_sliding_force_ratio():
    r = incline_sliding_force_ratio(0.1, 0.3)
    assert r == pytest.approx(0.412371, abs=1e-6)
    assert r == pytest.approx(INCLINE_REFERENCE["F_over_G"], abs=1e-6)
    # force balance along and normal to the slope at the sliding limit
    alpha = math.atan(0.1)
    F, G = r, 1.0
    normal = G * math.cos(alpha) + F * math.sin(alpha)
    assert F * math.cos(alpha) - G * math.sin(alpha) == pytest.approx(0.3 * normal)
    # equivalent form tan(alpha + phi) with tan(phi) = mu
    assert r == pytest.approx(math.tan(alpha + math.atan(0.3)))
    assert incline_sliding_force_ratio(0.0, 0.3) == pytest.approx(0.3)
    assert incline_sliding_force_ratio(0.1, 0.0) == pytest.approx(0.1)
    with pytest.raises(ValueError):
        incline_sliding_force_ratio(10.0, 0.1)


def test_tresca_sliding_force():
    assert tresca_sliding_force(2e6, 0.5) == pytest.approx(1e6)
    assert tresca_sliding_force(0.0, 0.5) == 0.0
    with pytest.raises(ValueError):
        tresca_sliding_force(-1.0, 0.5)
