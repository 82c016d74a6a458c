"""Closed-form elastic solutions for verifying the mechanics (numpy/scipy only, no NGSolve).

Units: lengths m, temperatures K (or degC: only differences enter), stresses and moduli Pa, energy density
J/m^3, strains and ``alpha`` T dimensionless (``alpha`` in 1/K). Every function broadcasts over arrays of
its position/strain argument.

1. Thermal stresses in a thick-walled cylinder a < r < b with free surfaces r = a, r = b and a steady
   radial temperature (../shared/notes/verification.md section 4; Timoshenko & Goodier, Theory of
   Elasticity, 3rd ed., sections 149-150 (disc and long cylinder); Boley & Weiner, Theory of Thermal
   Stresses, section 9.10).

   Temperature. The steady field (Laplace in r, no source) with T(a) = Ti, T(b) = To is

       T(r) = To + (Ti - To) ln(b/r) / ln(b/a).

   Only the rise theta(r) = T(r) - T_sf above the stress-free temperature T_sf produces stress; by
   default T_sf = 0, i.e. Ti and To are measured from the stress-free state, as in verification.md.

   General theta(r). With I(r) = int_a^r theta(s) s ds, and for plane strain (eps_z = 0):

       sigma_r     = alpha E / ((1 - nu) r^2) [ (r^2 - a^2)/(b^2 - a^2) I(b) - I(r) ]
       sigma_theta = alpha E / ((1 - nu) r^2) [ (r^2 + a^2)/(b^2 - a^2) I(b) + I(r) - theta r^2 ]
       sigma_z     = nu (sigma_r + sigma_theta) - alpha E theta.

   They satisfy d(sigma_r)/dr + (sigma_r - sigma_theta)/r = 0 and sigma_r(a) = sigma_r(b) = 0, and
   sigma_r + sigma_theta = alpha E/(1 - nu) [ 2 I(b)/(b^2 - a^2) - theta ] (this sum is used below).

   Displacement, plane strain. 3D Hooke's law eps_theta = (sigma_theta - nu (sigma_r + sigma_z))/E + alpha theta
   with the sigma_z above is eps_theta = (1 + nu)/E [ (1 - nu) sigma_theta - nu sigma_r ] + (1 + nu) alpha theta;
   inserting the stresses, the theta terms cancel and u_r = r eps_theta is

       u_r = (1 + nu) alpha / ((1 - nu) r) [ I(r) + ((1 - 2 nu) r^2 + a^2) I(b) / (b^2 - a^2) ]

   (Timoshenko & Goodier section 150 with eps_z = 0).

   Generalized plane strain / free ends ("generalized_plane_strain", "free_ends"). A long cylinder with free
   ends has, far from the ends (Saint-Venant), a constant axial strain eps_z = eps0. Then 3D Hooke gives
   sigma_z = nu (sigma_r + sigma_theta) - alpha E theta + E eps0, and the in-plane strains become the plane-strain
   ones minus nu eps0. The uniform in-plane strain -nu eps0 is compatible and stress free (u_r = -nu eps0 r), so
   sigma_r and sigma_theta are the plane-strain ones for every eps0, and

       u_r = u_r(plane strain) - nu eps0 r.

   eps0 follows from zero axial force, int_a^b sigma_z r dr = 0. Equilibrium gives
   d(r^2 sigma_r)/dr = r (sigma_r + sigma_theta), so int_a^b (sigma_r + sigma_theta) r dr = [r^2 sigma_r]_a^b = 0
   (free surfaces), and therefore -alpha E I(b) + E eps0 (b^2 - a^2)/2 = 0:

       eps0 = 2 alpha I(b) / (b^2 - a^2) = alpha * (area mean of theta over the annulus).

   Inserting eps0 and the sum sigma_r + sigma_theta above, the nu terms combine to

       sigma_z = alpha E/(1 - nu) [ 2 I(b)/(b^2 - a^2) - theta ] = sigma_r + sigma_theta   (exactly),

   the classical result (Timoshenko & Goodier section 150); the correction to sigma_r + sigma_theta is zero.
   For the logarithmic profile the annulus mean is
   theta_mean = To - T_sf + (Ti - To) [ 1/(2 ln(b/a)) - a^2/(b^2 - a^2) ].

   Plane stress ("plane_stress", thin disc, sigma_z = 0; an approximation for a thin disc, since the resulting
   eps_z = -nu (sigma_r + sigma_theta)/E + alpha theta is not linear in x, y for the ln profile):

       sigma_r     = alpha E / r^2 [ (r^2 - a^2)/(b^2 - a^2) I(b) - I(r) ]
       sigma_theta = alpha E / r^2 [ (r^2 + a^2)/(b^2 - a^2) I(b) + I(r) - theta r^2 ]
       u_r = r eps_theta = r [ (sigma_theta - nu sigma_r)/E + alpha theta ]
           = alpha / r [ (1 + nu) I(r) + ((1 - nu) r^2 + (1 + nu) a^2) I(b) / (b^2 - a^2) ]

   (Timoshenko & Goodier section 149), i.e. the plane-strain stresses times (1 - nu).

   For the logarithmic profile, with L = ln(b/a), dT = Ti - To, theta0 = To - T_sf and
   int s ln(b/s) ds = s^2/2 ln(b/s) + s^2/4:

       I(r) = theta0 (r^2 - a^2)/2 + dT/L [ r^2/2 ln(b/r) + r^2/4 - a^2/2 L - a^2/4 ].

   A uniform theta0 gives no in-plane stress (only sigma_z = -alpha E theta0 in plane strain).

   Reference (verification.md section 4): a = 1, b = 2 m, Ti = 100 K, To = 0, E = 70 GPa, nu = 0.25,
   alpha = 8e-6 1/K, plane strain: sigma_theta(1) = -45.695 MPa, sigma_theta(2) = 28.972 MPa,
   sigma_r(1.5) = -5.8157 MPa (:data:`CYLINDER_REFERENCE`, :func:`cylinder_reference_errors`).

2. The nonlinear law of the seed (000_373559dfe1d3dece, eqs. (2.1)-(2.5): W = A1^lambda,
   tau = 2 lambda A1^(lambda-1) c e) in the normalized form of ``ngs_geomech.mechanics.forms``:

       W(e) = (A_ref/2) ((A1/A_ref + delta)^lam - delta^lam),     A1 = e : C : e,
       sigma = dW/de = lam (A1/A_ref + delta)^(lam - 1) C e,      A_ref = eps_ref^2 C[0, 0],

   with e in Voigt order (xx, yy, zz, yz, xz, xy) and engineering shear strains, C the 6x6 stiffness (Pa),
   eps_ref the strain scale (A_ref is the A1 of a uniaxial strain eps_ref for isotropic C) and delta >= 0 a
   regularization. lam = 1 is linear elasticity with C (the seed's c equals C/2); lam < 1 softens,
   lam > 1 hardens.

   Uniaxial strain e = diag(eps, 0, 0), isotropic C with Lame constants lambda_L, mu and
   M = lambda_L + 2 mu (P-wave modulus): A1 = M eps^2, A1/A_ref = (eps/eps_ref)^2,

       sigma_xx = lam ((eps/eps_ref)^2 + delta)^(lam - 1) M eps,
       sigma_yy = sigma_zz = lam ((eps/eps_ref)^2 + delta)^(lam - 1) lambda_L eps,

   and for delta = 0:  sigma_xx(eps) = lam M^lam / A_ref^(lam - 1) |eps|^(2 lam - 2) eps.

   Monotonicity (x = eps/eps_ref): d sigma_xx/d eps = lam M (x^2 + delta)^(lam - 2) [ (2 lam - 1) x^2 + delta ].
   For delta = 0 this is lam (2 lam - 1) M |x|^(2 lam - 2) > 0 iff lam > 1/2: sigma_xx(eps) is then strictly
   increasing and unbounded and every traction has exactly one strain. lam = 1/2 with delta = 0 gives the
   constant |sigma_xx| = M eps_ref / 2 (no unique strain); lam < 1/2 gives a stress decreasing in |eps|.
   With delta > 0: lam = 1/2 is increasing but bounded by M eps_ref / 2; lam < 1/2 increases only up to
   |x| = sqrt(delta/(1 - 2 lam)) (peak traction) and softens beyond (:func:`uniaxial_strain_from_stress`
   returns the rising, stable branch).

   Bar 0 < x < L in uniaxial strain (u_x(0) = 0, u_y = u_z = 0 everywhere, e.g. rollers/symmetry on the sides):
   with u_x(L) = d the solution is the homogeneous strain eps = d/L (equilibrium holds because the stress is
   constant); with an end traction sigma_xx(L) = P it is the eps solving sigma_xx(eps) = P; u_x(x) = eps x.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

CASES = ("plane_strain", "generalized_plane_strain", "free_ends", "plane_stress")
"""Accepted values of ``case``; "free_ends" is an alias of "generalized_plane_strain"."""

CYLINDER_REFERENCE = {
    "a": 1.0, "b": 2.0, "Ti": 100.0, "To": 0.0, "E": 70e9, "nu": 0.25, "alpha": 8e-6,
    "values": (("sigma_theta", 1.0, -45.695e6), ("sigma_theta", 2.0, 28.972e6), ("sigma_r", 1.5, -5.8157e6)),
}
"""verification.md section 4: geometry (m), temperatures (K), E (Pa), nu, alpha (1/K) and plane-strain
reference values (component, r in m, stress in Pa)."""


class CylinderSolution(NamedTuple):
    """Thick-walled cylinder fields at r: stresses in Pa, radial displacement in m."""

    sigma_r: np.ndarray | float
    sigma_theta: np.ndarray | float
    sigma_z: np.ndarray | float
    u_r: np.ndarray | float


class BarSolution(NamedTuple):
    """Uniaxial-strain bar: homogeneous strain (-) and u_x(x) = strain * x (m)."""

    strain: float
    displacement: np.ndarray | float


def _out(x):
    """Return a float for 0-d input, else the array."""
    x = np.asarray(x)
    return float(x) if x.ndim == 0 else x


def _case(case: str) -> str:
    if case not in CASES:
        raise ValueError(f"case must be one of {CASES}, got {case!r}")
    return "generalized_plane_strain" if case == "free_ends" else case


# ---------------------------------------------------------------------------------------------------------
# 1. Thick-walled cylinder
# ---------------------------------------------------------------------------------------------------------


def cylinder_temperature(r, a: float, b: float, Ti: float, To: float = 0.0):
    """Steady radial temperature T(r) = To + (Ti - To) ln(b/r)/ln(b/a) in K (r, a < b in m; T(a) = Ti, T(b) = To)."""
    r = np.asarray(r, dtype=float)
    return _out(To + (Ti - To) * np.log(b / r) / math.log(b / a))


def _log_profile_integral(r, a: float, b: float, Ti: float, To: float, stress_free_temperature: float):
    """I(r) = int_a^r (T(s) - T_sf) s ds for the logarithmic profile, K m^2."""
    r = np.asarray(r, dtype=float)
    L = math.log(b / a)
    theta0 = To - stress_free_temperature
    dT = Ti - To
    return theta0 * (r**2 - a**2) / 2 + dT / L * (r**2 / 2 * np.log(b / r) + r**2 / 4 - a**2 / 2 * L - a**2 / 4)


def _cylinder_from_integrals(r, a, b, theta, I_r, I_b, E, nu, alpha, case) -> CylinderSolution:
    """Stresses and u_r from theta(r), I(r) and I(b) (module docstring, section 1)."""
    case = _case(case)
    r = np.asarray(r, dtype=float)
    theta = np.asarray(theta, dtype=float)
    D = b**2 - a**2
    s_r = alpha * E / r**2 * ((r**2 - a**2) / D * I_b - I_r)
    s_t = alpha * E / r**2 * ((r**2 + a**2) / D * I_b + I_r - theta * r**2)
    if case == "plane_stress":
        u_r = alpha / r * ((1 + nu) * I_r + ((1 - nu) * r**2 + (1 + nu) * a**2) * I_b / D)
        s_z = np.zeros_like(s_r)
    else:
        s_r = s_r / (1 - nu)
        s_t = s_t / (1 - nu)
        u_r = (1 + nu) * alpha / ((1 - nu) * r) * (I_r + ((1 - 2 * nu) * r**2 + a**2) * I_b / D)
        s_z = nu * (s_r + s_t) - alpha * E * theta
        if case == "generalized_plane_strain":
            eps0 = 2 * alpha * I_b / D
            s_z = s_z + E * eps0
            u_r = u_r - nu * eps0 * r
    return CylinderSolution(_out(s_r), _out(s_t), _out(s_z), _out(u_r))


def cylinder_thermal_stresses(r, a: float, b: float, Ti: float, E: float, nu: float, alpha: float,
                              To: float = 0.0, case: str = "plane_strain", *,
                              stress_free_temperature: float = 0.0) -> CylinderSolution:
    """Thermal stresses (Pa) and radial displacement (m) of a thick-walled cylinder with free surfaces.

    ``r`` radius in m (a <= r <= b), ``a`` < ``b`` inner/outer radius in m, ``Ti``/``To`` inner/outer surface
    temperature (steady profile :func:`cylinder_temperature`), ``E`` Young's modulus in Pa, ``nu`` Poisson's
    ratio, ``alpha`` linear expansion in 1/K, ``stress_free_temperature`` T_sf (stress arises from T - T_sf).
    ``case``: "plane_strain" (eps_z = 0), "generalized_plane_strain" or "free_ends" (uniform eps_z with zero
    axial force: sigma_z = sigma_r + sigma_theta, the long free-ended or finite axisymmetric cylinder far
    from its ends), "plane_stress" (thin disc, sigma_z = 0). Returns :class:`CylinderSolution`
    (sigma_r, sigma_theta, sigma_z, u_r). Formulas and derivations: module docstring, section 1.
    """
    theta = np.asarray(cylinder_temperature(r, a, b, Ti, To), dtype=float) - stress_free_temperature
    I_r = _log_profile_integral(r, a, b, Ti, To, stress_free_temperature)
    I_b = float(_log_profile_integral(b, a, b, Ti, To, stress_free_temperature))
    return _cylinder_from_integrals(r, a, b, theta, I_r, I_b, E, nu, alpha, case)


def cylinder_axial_strain(r, a: float, b: float, Ti: float, E: float, nu: float, alpha: float,
                          To: float = 0.0, case: str = "plane_strain", *, stress_free_temperature: float = 0.0):
    """Axial strain eps_z (-) of :func:`cylinder_thermal_stresses` (same arguments).

    plane strain: 0; free ends: the constant 2 alpha I(b)/(b^2 - a^2) = alpha * (annulus mean of T - T_sf);
    plane stress: -nu (sigma_r + sigma_theta)/E + alpha (T - T_sf), varying with r.
    """
    case = _case(case)
    r = np.asarray(r, dtype=float)
    if case == "plane_strain":
        return _out(np.zeros_like(r))
    if case == "generalized_plane_strain":
        I_b = float(_log_profile_integral(b, a, b, Ti, To, stress_free_temperature))
        return _out(np.full_like(r, 2 * alpha * I_b / (b**2 - a**2)))
    sol = cylinder_thermal_stresses(r, a, b, Ti, E, nu, alpha, To, case,
                                    stress_free_temperature=stress_free_temperature)
    theta = np.asarray(cylinder_temperature(r, a, b, Ti, To)) - stress_free_temperature
    return _out(-nu * (np.asarray(sol.sigma_r) + np.asarray(sol.sigma_theta)) / E + alpha * theta)


def cylinder_thermal_stresses_profile(r, a: float, b: float, theta: Callable[[float], float], E: float, nu: float,
                                      alpha: float, case: str = "plane_strain") -> CylinderSolution:
    """Same as :func:`cylinder_thermal_stresses` for any radial temperature rise theta(r) (K above T_sf).

    I(r) = int_a^r theta(s) s ds is evaluated with scipy.integrate.quad (``theta`` a scalar function of r in m).
    """
    r = np.asarray(r, dtype=float)
    flat = r.reshape(-1)
    I_r = np.array([quad(lambda s: theta(s) * s, a, ri, epsabs=0.0, epsrel=1e-13)[0] for ri in flat])
    I_b = quad(lambda s: theta(s) * s, a, b, epsabs=0.0, epsrel=1e-13)[0]
    th = np.array([theta(ri) for ri in flat], dtype=float)
    return _cylinder_from_integrals(r, a, b, th.reshape(r.shape), I_r.reshape(r.shape), I_b, E, nu, alpha, case)


def cylinder_pressure_stresses(r, a: float, b: float, p_in: float, E: float, nu: float) -> CylinderSolution:
    """Lame's thick-walled cylinder a < r < b under an internal pressure ``p_in`` (Pa), free outer surface, plane
    strain (eps_z = 0; Timoshenko & Goodier section 28): with A = p_in a^2 / (b^2 - a^2), B = A b^2,

        sigma_r = A - B / r^2,   sigma_theta = A + B / r^2,   sigma_z = 2 nu A,
        u_r = (1 + nu) / E ((1 - 2 nu) A r + B / r),

    valid up to nu = 1/2 (mean stress 2 (1 + nu) A / 3, uniform). Stresses in Pa, u_r in m."""
    r = np.asarray(r, dtype=float)
    A = p_in * a ** 2 / (b ** 2 - a ** 2)
    B = A * b ** 2
    return CylinderSolution(_out(A - B / r ** 2), _out(A + B / r ** 2), _out(np.full_like(r, 2 * nu * A)),
                            _out((1 + nu) / E * ((1 - 2 * nu) * A * r + B / r)))


def cylinder_reference_errors() -> list[tuple[str, float, float, float, float]]:
    """(component, r in m, reference Pa, computed Pa, relative error) for :data:`CYLINDER_REFERENCE`."""
    p = CYLINDER_REFERENCE
    rows = []
    for comp, r, ref in p["values"]:
        sol = cylinder_thermal_stresses(r, p["a"], p["b"], p["Ti"], p["E"], p["nu"], p["alpha"], p["To"])
        val = getattr(sol, comp)
        rows.append((comp, r, ref, val, abs(val / ref - 1)))
    return rows


# ---------------------------------------------------------------------------------------------------------
# 2. The nonlinear lambda law
# ---------------------------------------------------------------------------------------------------------


def lame_constants(E: float, nu: float) -> tuple[float, float]:
    """Lame lambda_L = E nu/((1 + nu)(1 - 2 nu)) and mu = E/(2 (1 + nu)), Pa (E in Pa, nu in (-1, 1/2))."""
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


def isotropic_stiffness_voigt(E: float, nu: float) -> np.ndarray:
    """6x6 isotropic stiffness in Voigt order xx, yy, zz, yz, xz, xy with engineering shear strains, Pa."""
    lam_L, mu = lame_constants(E, nu)
    C = np.zeros((6, 6))
    C[:3, :3] = lam_L
    C[np.arange(3), np.arange(3)] = lam_L + 2 * mu
    C[np.arange(3, 6), np.arange(3, 6)] = mu
    return C


def lambda_law_stress(strain_voigt, C, lam: float, eps_ref: float, delta: float = 0.0) -> np.ndarray:
    """Stress lam (A1/A_ref + delta)^(lam - 1) C e in Pa (Voigt), A1 = e.C.e, A_ref = eps_ref^2 C[0, 0].

    ``strain_voigt`` e (6,) or (..., 6) with engineering shear strains, ``C`` 6x6 stiffness in Pa.
    For e = 0 with delta = 0 the stress 0 is returned (the law is singular there for lam <= 1/2).
    """
    e = np.asarray(strain_voigt, dtype=float)
    C = np.asarray(C, dtype=float)
    Ce = e @ C.T
    A1 = np.sum(e * Ce, axis=-1)
    base = A1 / (eps_ref**2 * C[0, 0]) + delta
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(base > 0, lam * np.where(base > 0, base, 1.0) ** (lam - 1), 0.0)
    return factor[..., None] * Ce


def lambda_law_energy(strain_voigt, C, lam: float, eps_ref: float, delta: float = 0.0):
    """W = (A_ref/2) ((A1/A_ref + delta)^lam - delta^lam) in J/m^3 (arguments as :func:`lambda_law_stress`)."""
    e = np.asarray(strain_voigt, dtype=float)
    C = np.asarray(C, dtype=float)
    A_ref = eps_ref**2 * C[0, 0]
    A1 = np.sum(e * (e @ C.T), axis=-1)
    return _out(0.5 * A_ref * ((A1 / A_ref + delta) ** lam - delta**lam))


def uniaxial_strain_stress(eps, lam: float, E: float, nu: float, eps_ref: float, delta: float = 0.0):
    """(sigma_xx, sigma_yy) in Pa of the lambda law for the uniaxial strain e = diag(eps, 0, 0), isotropic C.

    ``eps`` strain (-), ``lam`` the exponent lambda (> 0), ``E`` Pa, ``nu``, ``eps_ref`` strain scale (-),
    ``delta`` regularization (-). sigma_xx = lam ((eps/eps_ref)^2 + delta)^(lam-1) (lambda_L + 2 mu) eps and
    sigma_yy = sigma_zz = lam (...)^(lam-1) lambda_L eps; for delta = 0,
    sigma_xx = lam (lambda_L + 2 mu)^lam / A_ref^(lam-1) |eps|^(2 lam - 2) eps with A_ref = (lambda_L + 2 mu) eps_ref^2.
    At eps = 0 with delta = 0 both are 0.
    """
    lam_L, mu = lame_constants(E, nu)
    eps = np.asarray(eps, dtype=float)
    base = (eps / eps_ref) ** 2 + delta
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(base > 0, lam * np.where(base > 0, base, 1.0) ** (lam - 1), 0.0)
    return _out(factor * (lam_L + 2 * mu) * eps), _out(factor * lam_L * eps)


def uniaxial_strain_energy(eps, lam: float, E: float, nu: float, eps_ref: float, delta: float = 0.0):
    """W = (A_ref/2) ((A1/A_ref + delta)^lam - delta^lam) in J/m^3 for e = diag(eps, 0, 0), isotropic C.

    A1 = (lambda_L + 2 mu) eps^2 and A_ref = (lambda_L + 2 mu) eps_ref^2, so
    W = (lambda_L + 2 mu) eps_ref^2 / 2 ((eps/eps_ref)^2 + delta)^lam - ...; dW/deps = sigma_xx.
    """
    lam_L, mu = lame_constants(E, nu)
    M = lam_L + 2 * mu
    eps = np.asarray(eps, dtype=float)
    return _out(0.5 * M * eps_ref**2 * (((eps / eps_ref) ** 2 + delta) ** lam - delta**lam))


def uniaxial_strain_max_stress(lam: float, E: float, nu: float, eps_ref: float, delta: float = 0.0) -> float:
    """Supremum of |sigma_xx| over the rising branch of the uniaxial-strain law, Pa (inf for lam > 1/2).

    lam = 1/2: M eps_ref/2 (approached for eps -> inf if delta > 0, attained everywhere if delta = 0);
    lam < 1/2, delta > 0: the peak at |eps| = eps_ref sqrt(delta/(1 - 2 lam)); lam < 1/2, delta = 0: 0.
    """
    lam_L, mu = lame_constants(E, nu)
    M = lam_L + 2 * mu
    if lam > 0.5:
        return math.inf
    if lam == 0.5:
        return 0.5 * M * eps_ref
    if delta == 0:
        return 0.0
    x = math.sqrt(delta / (1 - 2 * lam))
    return lam * (x * x + delta) ** (lam - 1) * M * eps_ref * x


def uniaxial_strain_from_stress(P: float, lam: float, E: float, nu: float, eps_ref: float,
                                delta: float = 0.0) -> float:
    """The strain eps (-) with sigma_xx(eps) = P (Pa) in uniaxial strain (inverse of :func:`uniaxial_strain_stress`).

    Unique for lam > 1/2 (strictly increasing, unbounded). For lam <= 1/2 (delta > 0 required) only
    |P| < :func:`uniaxial_strain_max_stress` has a solution on the rising branch, which is returned;
    otherwise ValueError. delta = 0, lam > 1/2: eps = sign(P) eps_ref (|P|/(lam M eps_ref))^(1/(2 lam - 1)).
    """
    lam_L, mu = lame_constants(E, nu)
    M = lam_L + 2 * mu
    if P == 0:
        return 0.0
    p = abs(P) / (M * eps_ref)  # solve g(x) = lam (x^2 + delta)^(lam - 1) x = p, x = |eps|/eps_ref >= 0
    smax = uniaxial_strain_max_stress(lam, E, nu, eps_ref, delta)
    if lam <= 0.5 and (delta == 0 or abs(P) >= smax):
        raise ValueError(f"no strain on the rising branch gives |P| = {abs(P):g} Pa for lam = {lam} <= 1/2, "
                         f"delta = {delta} (supremum {smax:g} Pa)")
    if delta == 0:
        x = (p / lam) ** (1 / (2 * lam - 1))
        return math.copysign(eps_ref * x, P)

    def g(x: float) -> float:
        return lam * (x * x + delta) ** (lam - 1) * x - p

    x_cap = math.sqrt(delta / (1 - 2 * lam)) if lam < 0.5 else math.inf
    # initial guesses: linear regime (x^2 << delta) and power regime (x^2 >> delta)
    x_lin = p / (lam * delta ** (lam - 1))
    x_pow = (p / lam) ** (1 / (2 * lam - 1)) if lam > 0.5 else x_lin
    hi = min(max(x_lin, x_pow), x_cap)
    while g(hi) < 0:
        hi = min(2 * hi, x_cap)
    lo = min(hi / 2, min(x_lin, x_pow))
    while g(lo) > 0:
        lo /= 2
    x = brentq(g, lo, hi, xtol=1e-16 * lo, rtol=4 * np.finfo(float).eps, maxiter=500)
    return math.copysign(eps_ref * x, P)


def bar_displacement(x, L: float, lam: float, E: float, nu: float, eps_ref: float, delta: float = 0.0, *,
                     end_displacement: float | None = None, end_traction: float | None = None) -> BarSolution:
    """Bar 0 < x < L (m) in uniaxial strain: u_x(0) = 0, u_y = u_z = 0, and at x = L either u_x = d or sigma_xx = P.

    Exactly one of ``end_displacement`` d (m) and ``end_traction`` P (Pa, tension positive) is given. The
    solution is homogeneous: eps = d/L, or eps solving sigma_xx(eps) = P (:func:`uniaxial_strain_from_stress`;
    unique for lam > 1/2). Returns :class:`BarSolution` (eps, u_x(x) = eps x in m); the stresses are
    :func:`uniaxial_strain_stress` of eps (sigma_yy = sigma_zz is the lateral reaction of the rollers).
    """
    if (end_displacement is None) == (end_traction is None):
        raise ValueError("give exactly one of end_displacement and end_traction")
    if end_displacement is not None:
        eps = end_displacement / L
    else:
        eps = uniaxial_strain_from_stress(end_traction, lam, E, nu, eps_ref, delta)
    return BarSolution(eps, _out(eps * np.asarray(x, dtype=float)))
