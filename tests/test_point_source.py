"""Decaying point heat source in an infinite medium (verification.md section 5): closed form and the
axisymmetric model run through scene_from_dict -> run_scene.

Measured (P2, Crank-Nicolson, ngsolve 6.2.2608, 2 cores; wall time idle, and the worst seen while other
NGSolve runs shared the cores), max |numeric / exact - 1| over r = 2, 5, 10 m and t ~ 1, 10, 50 years:

    level 0:  3 650 dofs, 141 steps,  0.6 s (52 s),  1.28e-3  (against the ball source 1.24e-3)
    level 1: 11 948 dofs, 278 steps,  3.3 s (120 s), 7.90e-4  (7.78e-4)
    level 2: 43 507 dofs, 552 steps, 27.8 s (142 s), 1.91e-4  (6.70e-5)

The modelling errors are far below these: the finite source (ball of radius 0.25 m) changes T by 1.2e-4
relative, the far boundary (T = 0 at 300 m) by < 4e-7 relative (maximum-principle bound).
"""

from __future__ import annotations

import math

import pytest
from scipy.integrate import quad

from ngs_geomech.scene.units import DAY, YEAR
from ngs_geomech.verification.point_source import (
    CONDUCTIVITY,
    DECAY_TIME,
    Q0,
    REFERENCE_VALUES,
    RHO_C,
    TIMES_YEARS,
    ball_source_temperature,
    decaying_point_source_temperature,
    error_table,
    point_source_errors,
)

KAPPA = CONDUCTIVITY / RHO_C
LAM = 1.0 / DECAY_TIME

LEVEL0_TOL = 1e-2
"""Level-0 tolerance on the relative error. Measured 1.28e-3 at the probes; the P2 pointwise error on the
circle r = 2 m of the level-0 mesh ranges over -3.6e-3 ... +4.4e-3 with the angle (so a netgen version that
places the nodes differently may move the probe value within that band), and the time error at ~1 year is
~1.2e-3: 1e-2 leaves a margin of ~2 over their sum while staying well below the few-percent target."""


def exact(r, t):
    return decaying_point_source_temperature(r, t, Q0, LAM, CONDUCTIVITY, KAPPA)


@pytest.mark.parametrize("r, t_years, ref", REFERENCE_VALUES)
def test_closed_form_reference_values(r, t_years, ref):
    """verification.md quotes 84.674, 17.648 and 0.705 K. The first two agree to rel. 1e-4; 0.705 has only
    3 significant digits (the closed form gives 0.70464, 5e-4 away), so every value is also checked to round
    to the quoted digits, which is all the quoted figure states."""
    value = exact(r, t_years * YEAR)
    decimals = len(str(ref).split(".")[1])
    assert round(value, decimals) == ref
    if ref > 1.0:
        assert value == pytest.approx(ref, rel=1e-4)


def test_references_use_the_julian_year():
    """With 365-day years T(0.5 m, 1 y) = 84.6723 K, which does not round to the quoted 84.674 K."""
    assert YEAR == 365.25 * DAY
    y365 = 365.0 * DAY
    value = decaying_point_source_temperature(0.5, y365, Q0, 1.0 / (50 * y365), CONDUCTIVITY, KAPPA)
    assert round(value, 3) != 84.674


@pytest.mark.parametrize("r, t_years", [(0.5, 1.0), (2.0, 10.0), (10.0, 100.0), (5.0, 0.1), (50.0, 1e4)])
def test_closed_form_matches_duhamel_integral(r, t_years):
    t = t_years * YEAR

    def integrand(s):
        tau = t - s
        green = math.exp(-r * r / (4 * KAPPA * tau)) / (RHO_C * (4 * math.pi * KAPPA * tau) ** 1.5)
        return Q0 * math.exp(-LAM * s) * green
    ref = quad(integrand, 0.0, t, limit=500, epsabs=0.0, epsrel=1e-11)[0]
    assert exact(r, t) == pytest.approx(ref, rel=1e-9)


def test_closed_form_limits():
    t = 10 * YEAR
    constant = decaying_point_source_temperature(2.0, t, Q0, 0.0, CONDUCTIVITY, KAPPA)
    steady = Q0 / (4 * math.pi * CONDUCTIVITY * 2.0)
    assert constant == pytest.approx(steady * math.erfc(2.0 / (2 * math.sqrt(KAPPA * t))))
    slow = decaying_point_source_temperature(2.0, t, Q0, 1e-18, CONDUCTIVITY, KAPPA)
    assert slow == pytest.approx(constant, rel=1e-9)
    assert exact(2.0, 0.0) == 0.0
    assert exact(1e-3, 1.0) > 0.0  # erfc of a large argument: no overflow, no NaN
    # long after the decay (l t = 2e4: exp(l t) would overflow): the released energy q0 / l diffused as from
    # an instantaneous point source, T = (q0 / l) / (rho c (4 pi kappa t)^(3/2)) for r^2 << kappa t
    t_late = 1e6 * YEAR
    assert exact(1.0, t_late) == pytest.approx(Q0 / LAM / (RHO_C * (4 * math.pi * KAPPA * t_late) ** 1.5), rel=1e-3)
    assert ball_source_temperature(2.0, t, 1e-3, Q0, LAM, CONDUCTIVITY, KAPPA) == pytest.approx(exact(2.0, t),
                                                                                              rel=1e-9)


def test_point_source_level0():
    res = point_source_errors(0)
    print()
    print(error_table(res))
    assert len(res["errors"]) == 9
    for e in res["errors"]:
        assert abs(e["t_years"] - e["target_years"]) <= 0.05 * e["target_years"]
        assert abs(e["rel_error"]) < LEVEL0_TOL, e
    assert res["max_rel_error"] < LEVEL0_TOL
    # the finite source and the finite domain are negligible against the tolerance
    assert res["source_size_effect"] < 1e-3
    assert res["far_boundary_bound"] < 1e-5
    assert res["dofs"] > 0 and res["wall_s"] > 0


@pytest.mark.slow
def test_point_source_convergence():
    results = [point_source_errors(level) for level in range(3)]
    for res in results:
        print()
        print(error_table(res))
    errs = [res["max_rel_error"] for res in results]
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 5e-4
    assert {e["target_years"] for e in results[0]["errors"]} == set(TIMES_YEARS)
