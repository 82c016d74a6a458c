"""Closed-form elastic solutions (ngs_geomech.verification.elastic_closed_forms): the thick-walled cylinder
with a radial temperature (verification.md section 4) and the uniaxial-strain lambda law of the seed
(eqs. (2.1)-(2.5)). Checked against the reference values, equilibrium, the free boundaries, Hooke's law with
finite differences of u_r, an independent quadrature of I(r), dW/deps = sigma and the traction inversion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from ngs_geomech.verification.elastic_closed_forms import (
    CYLINDER_REFERENCE,
    bar_displacement,
    cylinder_axial_strain,
    cylinder_reference_errors,
    cylinder_temperature,
    cylinder_thermal_stresses,
    cylinder_thermal_stresses_profile,
    isotropic_stiffness_voigt,
    lambda_law_energy,
    lambda_law_stress,
    lame_constants,
    uniaxial_strain_energy,
    uniaxial_strain_from_stress,
    uniaxial_strain_max_stress,
    uniaxial_strain_stress,
)

A, B, TI, E, NU, ALPHA = 1.0, 2.0, 100.0, 70e9, 0.25, 8e-6
SCALE = ALPHA * E * TI  # 56 MPa, the stress scale
CASES = ("plane_strain", "generalized_plane_strain", "free_ends", "plane_stress")
# (To, stress-free temperature): the reference profile and one with a nonzero outer and stress-free temperature
TEMPS = ((0.0, 0.0), (20.0, 10.0))


# ------------------------------------------------------------------------------------------ cylinder


def test_reference_values():
    for comp, r, ref, val, rel in cylinder_reference_errors():
        assert rel < 1e-4, (comp, r, ref, val)
    p = CYLINDER_REFERENCE
    sol = cylinder_thermal_stresses(np.array([1.0, 2.0]), p["a"], p["b"], p["Ti"], p["E"], p["nu"], p["alpha"])
    assert sol.sigma_theta == pytest.approx([-45.695e6, 28.972e6], rel=1e-4)
    assert cylinder_thermal_stresses(1.5, 1.0, 2.0, 100.0, 70e9, 0.25, 8e-6).sigma_r == pytest.approx(-5.8157e6,
                                                                                                       rel=1e-4)


def test_temperature_profile():
    assert cylinder_temperature(A, A, B, TI, 20.0) == pytest.approx(TI)
    assert cylinder_temperature(B, A, B, TI, 20.0) == pytest.approx(20.0)
    r = np.linspace(A, B, 7)
    T = cylinder_temperature(r, A, B, TI, 20.0)
    h = 1e-4
    lap = (cylinder_temperature(r + h, A, B, TI, 20.0) - 2 * T + cylinder_temperature(r - h, A, B, TI, 20.0)) / h**2
    lap += (cylinder_temperature(r + h, A, B, TI, 20.0) - cylinder_temperature(r - h, A, B, TI, 20.0)) / (2 * h) / r
    assert np.max(np.abs(lap)) < 1e-4  # steady: (1/r) d/dr (r dT/dr) = 0


def test_notes_closed_form_plane_strain():
    """The C [ ... ] form of verification.md section 4 (To = 0) equals the general-T(r) formulas."""
    r = np.linspace(A, B, 11)
    L = math.log(B / A)
    C = ALPHA * E * TI / (2 * (1 - NU) * L)
    k = A**2 / (B**2 - A**2)
    s_r = C * (-np.log(B / r) - k * (1 - B**2 / r**2) * L)
    s_t = C * (1 - np.log(B / r) - k * (1 + B**2 / r**2) * L)
    sol = cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA)
    T = cylinder_temperature(r, A, B, TI)
    assert np.allclose(sol.sigma_r, s_r, rtol=0, atol=1e-10 * SCALE)
    assert np.allclose(sol.sigma_theta, s_t, rtol=0, atol=1e-10 * SCALE)
    assert np.allclose(sol.sigma_z, NU * (s_r + s_t) - ALPHA * E * T, rtol=0, atol=1e-10 * SCALE)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("To, Tsf", TEMPS)
def test_closed_form_integral_matches_quadrature(case, To, Tsf):
    r = np.linspace(A, B, 9)
    sol = cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, To, case, stress_free_temperature=Tsf)
    ref = cylinder_thermal_stresses_profile(r, A, B, lambda s: cylinder_temperature(s, A, B, TI, To) - Tsf,
                                            E, NU, ALPHA, case)
    for name in ("sigma_r", "sigma_theta", "sigma_z"):
        assert np.allclose(getattr(sol, name), getattr(ref, name), rtol=0, atol=1e-10 * SCALE), name
    assert np.allclose(sol.u_r, ref.u_r, rtol=1e-10, atol=0)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("To, Tsf", TEMPS)
def test_equilibrium_and_free_surfaces(case, To, Tsf):
    kw = {"stress_free_temperature": Tsf}
    r = np.linspace(A + 0.01, B - 0.01, 25)
    h = 1e-5
    sol = cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, To, case, **kw)
    ds_dr = (cylinder_thermal_stresses(r + h, A, B, TI, E, NU, ALPHA, To, case, **kw).sigma_r
             - cylinder_thermal_stresses(r - h, A, B, TI, E, NU, ALPHA, To, case, **kw).sigma_r) / (2 * h)
    residual = ds_dr + (sol.sigma_r - sol.sigma_theta) / r
    assert np.max(np.abs(residual)) < 1e-6 * SCALE
    ends = cylinder_thermal_stresses(np.array([A, B]), A, B, TI, E, NU, ALPHA, To, case, **kw)
    assert np.max(np.abs(ends.sigma_r)) < 1e-12 * SCALE


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("To, Tsf", TEMPS)
def test_hooke_with_u_r(case, To, Tsf):
    """eps_r = du_r/dr, eps_theta = u_r/r and eps_z of the case satisfy 3D Hooke:
    eps_i = (s_i - nu (s_j + s_k))/E + alpha theta."""
    kw = {"stress_free_temperature": Tsf}
    r = np.linspace(A, B, 21)
    h = 1e-5
    sol = cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, To, case, **kw)
    eps_r = (cylinder_thermal_stresses(r + h, A, B, TI, E, NU, ALPHA, To, case, **kw).u_r
             - cylinder_thermal_stresses(r - h, A, B, TI, E, NU, ALPHA, To, case, **kw).u_r) / (2 * h)
    eps_t = sol.u_r / r
    eps_z = cylinder_axial_strain(r, A, B, TI, E, NU, ALPHA, To, case, **kw)
    theta = cylinder_temperature(r, A, B, TI, To) - Tsf
    s_r, s_t, s_z = sol.sigma_r, sol.sigma_theta, sol.sigma_z
    strain_scale = ALPHA * TI
    assert np.max(np.abs(eps_r - ((s_r - NU * (s_t + s_z)) / E + ALPHA * theta))) < 1e-7 * strain_scale
    assert np.max(np.abs(eps_t - ((s_t - NU * (s_r + s_z)) / E + ALPHA * theta))) < 1e-12 * strain_scale
    assert np.max(np.abs(eps_z - ((s_z - NU * (s_r + s_t)) / E + ALPHA * theta))) < 1e-12 * strain_scale
    if case == "plane_strain":
        assert np.all(eps_z == 0)
    elif case == "plane_stress":
        assert np.all(s_z == 0)
    else:
        assert np.ptp(eps_z) == 0  # uniform axial strain


@pytest.mark.parametrize("To, Tsf", TEMPS)
def test_free_ends_axial_force_and_strain(To, Tsf):
    kw = {"stress_free_temperature": Tsf}
    a_s = cylinder_thermal_stresses(np.linspace(A, B, 5), A, B, TI, E, NU, ALPHA, To, "free_ends", **kw)
    assert np.allclose(a_s.sigma_z, a_s.sigma_r + a_s.sigma_theta, rtol=0, atol=1e-10 * SCALE)
    force = quad(lambda r: cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, To, "free_ends", **kw).sigma_z * r,
                 A, B, epsabs=1e-12 * SCALE, epsrel=1e-12)[0]
    assert abs(force) < 1e-10 * SCALE * B**2
    # eps_z = alpha * annulus mean of theta = alpha (To - Tsf + (Ti - To) (1/(2 ln(b/a)) - a^2/(b^2 - a^2)))
    mean = To - Tsf + (TI - To) * (1 / (2 * math.log(B / A)) - A**2 / (B**2 - A**2))
    assert cylinder_axial_strain(1.3, A, B, TI, E, NU, ALPHA, To, "free_ends", **kw) == pytest.approx(ALPHA * mean)
    # plane strain sigma_z has the axial force -alpha E int theta r dr + nu [r^2 s_r] = -alpha E (b^2 - a^2)/2 mean
    ps = quad(lambda r: cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, To, **kw).sigma_z * r, A, B)[0]
    assert ps == pytest.approx(-ALPHA * E * (B**2 - A**2) / 2 * mean, rel=1e-10)


@pytest.mark.parametrize("case, u_factor", [("plane_strain", 1 + NU), ("free_ends", 1.0), ("plane_stress", 1.0)])
def test_uniform_temperature(case, u_factor):
    """Ti = To = 30 K: no in-plane stress, free thermal expansion (plane strain: u_r = (1 + nu) alpha T r and
    sigma_z = -alpha E T)."""
    r = np.linspace(A, B, 5)
    sol = cylinder_thermal_stresses(r, A, B, 30.0, E, NU, ALPHA, 30.0, case)
    assert np.max(np.abs(sol.sigma_r)) < 1e-12 * SCALE and np.max(np.abs(sol.sigma_theta)) < 1e-12 * SCALE
    assert np.allclose(sol.u_r, u_factor * ALPHA * 30.0 * r, rtol=1e-12)
    expected_sz = -ALPHA * E * 30.0 if case == "plane_strain" else 0.0
    assert np.allclose(sol.sigma_z, expected_sz, rtol=0, atol=1e-12 * SCALE)


def test_plane_stress_is_plane_strain_times_one_minus_nu():
    r = np.linspace(A, B, 6)
    ps = cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, 0.0, "plane_stress")
    pe = cylinder_thermal_stresses(r, A, B, TI, E, NU, ALPHA, 0.0, "plane_strain")
    assert np.allclose(ps.sigma_r, (1 - NU) * pe.sigma_r, rtol=0, atol=1e-10 * SCALE)
    assert np.allclose(ps.sigma_theta, (1 - NU) * pe.sigma_theta, rtol=0, atol=1e-10 * SCALE)


def test_bad_case():
    with pytest.raises(ValueError):
        cylinder_thermal_stresses(1.5, A, B, TI, E, NU, ALPHA, case="axisymmetric")


# ------------------------------------------------------------------------------------------ lambda law

EREF = 1e-3
LAME, MU = lame_constants(E, NU)
M = LAME + 2 * MU
LAMS = (0.5, 1.0, 2.0)
DELTAS = (0.0, 1e-6, 0.1)


@pytest.mark.parametrize("lam", LAMS)
@pytest.mark.parametrize("delta", DELTAS)
def test_energy_derivative(lam, delta):
    eps = np.array([-3e-3, -1e-3, -2e-4, 1e-5, 4e-4, 1e-3, 2.5e-3])
    h = 1e-6 * np.abs(eps)
    dW = (uniaxial_strain_energy(eps + h, lam, E, NU, EREF, delta)
          - uniaxial_strain_energy(eps - h, lam, E, NU, EREF, delta)) / (2 * h)
    s_xx, _ = uniaxial_strain_stress(eps, lam, E, NU, EREF, delta)
    assert np.allclose(dW, s_xx, rtol=1e-7, atol=0)


@pytest.mark.parametrize("lam", (0.3, 0.5, 0.75, 1.0, 2.0, 3.0))
def test_uniaxial_closed_form(lam):
    eps = np.array([-2e-3, -5e-4, 3e-4, 1.5e-3])
    s_xx, s_yy = uniaxial_strain_stress(eps, lam, E, NU, EREF)
    A_ref = M * EREF**2
    assert np.allclose(s_xx, lam * M**lam / A_ref ** (lam - 1) * np.abs(eps) ** (2 * lam - 2) * eps, rtol=1e-12)
    assert np.allclose(s_yy, s_xx * LAME / M, rtol=1e-12)
    assert uniaxial_strain_stress(0.0, lam, E, NU, EREF) == (0.0, 0.0)
    if lam == 1.0:  # linear elasticity
        assert np.allclose(s_xx, M * eps, rtol=1e-12)


@pytest.mark.parametrize("lam", LAMS)
@pytest.mark.parametrize("delta", (0.0, 0.1))
def test_voigt_law_matches_uniaxial_and_energy(lam, delta):
    C = isotropic_stiffness_voigt(E, NU)
    eps = 1.7e-3
    e = np.array([eps, 0, 0, 0, 0, 0])
    s = lambda_law_stress(e, C, lam, EREF, delta)
    s_xx, s_yy = uniaxial_strain_stress(eps, lam, E, NU, EREF, delta)
    assert s == pytest.approx([s_xx, s_yy, s_yy, 0, 0, 0], rel=1e-12)
    assert lambda_law_energy(e, C, lam, EREF, delta) == pytest.approx(
        uniaxial_strain_energy(eps, lam, E, NU, EREF, delta), rel=1e-12)
    # general strain (engineering shears): dW/de_k = sigma_k
    e = np.array([1e-3, -4e-4, 2e-4, 6e-4, -3e-4, 5e-4])
    s = lambda_law_stress(e, C, lam, EREF, delta)
    grad = np.empty(6)
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-9
        grad[k] = (lambda_law_energy(e + d, C, lam, EREF, delta) - lambda_law_energy(e - d, C, lam, EREF, delta)) / 2e-9
    assert np.allclose(grad, s, rtol=1e-6, atol=1e-6 * np.max(np.abs(s)))


@pytest.mark.parametrize("lam", (0.6, 0.75, 1.0, 2.0, 3.0))
@pytest.mark.parametrize("delta", DELTAS)
def test_traction_inversion(lam, delta):
    for P in (-5e8, -1e7, -3e4, 2e3, 1e6, 7e7, 3e9):
        eps = uniaxial_strain_from_stress(P, lam, E, NU, EREF, delta)
        assert uniaxial_strain_stress(eps, lam, E, NU, EREF, delta)[0] == pytest.approx(P, rel=1e-10)
    assert uniaxial_strain_from_stress(0.0, lam, E, NU, EREF, delta) == 0.0
    if lam == 1.0 and delta == 0.0:
        assert uniaxial_strain_from_stress(1e7, lam, E, NU, EREF) == pytest.approx(1e7 / M, rel=1e-14)


def test_traction_inversion_lam_at_most_half():
    # lam = 1/2, delta > 0: increasing, bounded by M eps_ref / 2
    smax = uniaxial_strain_max_stress(0.5, E, NU, EREF, 0.1)
    assert smax == pytest.approx(0.5 * M * EREF)
    for P in (0.1 * smax, -0.9 * smax, 0.999 * smax):
        eps = uniaxial_strain_from_stress(P, 0.5, E, NU, EREF, 0.1)
        assert uniaxial_strain_stress(eps, 0.5, E, NU, EREF, 0.1)[0] == pytest.approx(P, rel=1e-10)
    with pytest.raises(ValueError):
        uniaxial_strain_from_stress(1.01 * smax, 0.5, E, NU, EREF, 0.1)
    with pytest.raises(ValueError):
        uniaxial_strain_from_stress(1e6, 0.5, E, NU, EREF, 0.0)
    # lam < 1/2, delta > 0: the rising branch up to the peak |eps| = eps_ref sqrt(delta/(1 - 2 lam))
    lam, delta = 0.3, 0.1
    x_peak = math.sqrt(delta / (1 - 2 * lam))
    smax = uniaxial_strain_max_stress(lam, E, NU, EREF, delta)
    assert smax == pytest.approx(uniaxial_strain_stress(EREF * x_peak, lam, E, NU, EREF, delta)[0], rel=1e-14)
    for P in (0.2 * smax, -0.7 * smax, 0.99 * smax):
        eps = uniaxial_strain_from_stress(P, lam, E, NU, EREF, delta)
        assert abs(eps) < EREF * x_peak
        assert uniaxial_strain_stress(eps, lam, E, NU, EREF, delta)[0] == pytest.approx(P, rel=1e-10)
    with pytest.raises(ValueError):
        uniaxial_strain_from_stress(1.01 * smax, lam, E, NU, EREF, delta)


@pytest.mark.parametrize("lam", LAMS + (0.3,))
@pytest.mark.parametrize("delta", (1e-6, 0.1))
def test_tangent_sign(lam, delta):
    """d sigma_xx/d eps = lam M (x^2 + delta)^(lam - 2) ((2 lam - 1) x^2 + delta), x = eps/eps_ref."""
    eps = np.linspace(1e-4, 5e-3, 9)
    h = 1e-4 * eps
    ds = (uniaxial_strain_stress(eps + h, lam, E, NU, EREF, delta)[0]
          - uniaxial_strain_stress(eps - h, lam, E, NU, EREF, delta)[0]) / (2 * h)
    x = eps / EREF
    tangent = lam * M * (x**2 + delta) ** (lam - 2) * ((2 * lam - 1) * x**2 + delta)
    # lam = 1/2: the tangent is only ~delta/x^3 of the secant modulus, the difference quotient loses digits
    assert np.allclose(ds, tangent, rtol=1e-3 if lam == 0.5 else 1e-6)
    assert np.array_equal(ds > 0, (2 * lam - 1) * x**2 + delta > 0)


def test_bar():
    x = np.linspace(0, 2.0, 5)
    sol = bar_displacement(x, 2.0, 2.0, E, NU, EREF, end_displacement=-3e-3)
    assert sol.strain == pytest.approx(-1.5e-3)
    assert np.allclose(sol.displacement, -1.5e-3 * x)
    sol = bar_displacement(x, 2.0, 2.0, E, NU, EREF, 1e-6, end_traction=-2e8)
    assert uniaxial_strain_stress(sol.strain, 2.0, E, NU, EREF, 1e-6)[0] == pytest.approx(-2e8, rel=1e-10)
    assert np.allclose(sol.displacement, sol.strain * x)
    assert bar_displacement(1.0, 2.0, 1.0, E, NU, EREF, end_traction=1e7).displacement == pytest.approx(1e7 / M)
    with pytest.raises(ValueError):
        bar_displacement(x, 2.0, 1.0, E, NU, EREF, end_displacement=1e-3, end_traction=1e6)
    with pytest.raises(ValueError):
        bar_displacement(x, 2.0, 1.0, E, NU, EREF)
