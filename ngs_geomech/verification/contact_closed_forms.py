"""Closed-form contact solutions for verifying the contact and friction solvers (numpy/scipy only, no NGSolve).

Units: lengths m, stresses, pressures, tractions and moduli Pa, loads per unit depth (plane strain) N/m,
friction coefficients and ratios dimensionless. Functions of a position (x or z) broadcast over arrays and
return a float for scalar input.

Sources: ../shared/notes/verification.md sections 2 and 3; K. L. Johnson, Contact Mechanics (1985),
chapter 4 (Hertz line contact, subsurface stresses on the axis) and chapter 7 (Cattaneo-Mindlin partial
slip of cylinders).

1. Hertz line contact (plane strain). A cylinder of radius R pressed on a flat by a load P per unit length
   (two cylinders: 1/R = 1/R1 + 1/R2), frictionless, with the effective modulus

       1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2            (rigid second body: only the first term).

   Contact half width and peak pressure

       a  = sqrt(4 P R / (pi E*)),      p0 = 2 P / (pi a) = sqrt(P E* / (pi R)),

   elliptical pressure p(x) = p0 sqrt(1 - x^2/a^2) for |x| < a (0 outside), int p dx = pi a p0 / 2 = P.

   Stresses on the symmetry axis x = 0 at depth z >= 0 below the surface (compression negative):

       sigma_z = -p0 a / sqrt(a^2 + z^2),
       sigma_x = -p0 [ (a^2 + 2 z^2) / (a sqrt(a^2 + z^2)) - 2 z / a ],

   both principal (no shear on the axis by symmetry). The in-plane principal shear stress
   tau_max = (sigma_x - sigma_z)/2 vanishes at the surface and peaks at 0.300 p0 at z = 0.786 a
   (Johnson chapter 4). In plane strain sigma_y = nu (sigma_x + sigma_z); tau_max here ignores that
   out-of-plane component (near the surface (sigma_z - sigma_y)/2 can be the larger shear, e.g. 0.2 p0 at
   z = 0 for nu = 0.3, but it stays below 0.300 p0).

   Reference (verification.md section 2): steel cylinder R = 0.05 m, E = 210 GPa, nu = 0.3 on a rigid flat,
   P = 1e5 N/m: E* = 2.3077e11 Pa, a = 1.6609e-4 m, p0 = 3.8329e8 Pa (:data:`HERTZ_REFERENCE`).
   Compare the pressure, a and p0, not displacements (in 2D the indentation depends on the body size).

2. Cattaneo-Mindlin partial slip (2D). The Hertz contact above, then a monotonically applied tangential force
   Q < mu P per unit length (Coulomb coefficient mu). A central stick zone |x| < c and two slip zones
   c < |x| < a form with

       c / a = sqrt(1 - Q / (mu P)),
       q(x)  = mu p0 sqrt(1 - x^2/a^2) - [|x| < c] mu p0 (c/a) sqrt(1 - x^2/c^2)     (|x| < a; 0 outside).

   In the slip zones q = mu p (sliding), in the stick zone q < mu p; int q dx = mu P (1 - c^2/a^2) = Q.
   The solution is exact for elastically similar bodies (no coupling between normal and tangential
   problems); for an elastic body on a rigid flat it is an approximation.
   Reference: mu = 0.3, Q/P = 0.05 / 0.15 / 0.25 -> c/a = 0.912871 / 0.707107 / 0.408248
   (:data:`CATTANEO_REFERENCE`).

3. Global sliding. A rigid block of weight G on a slope of angle alpha with Coulomb friction mu, pushed up the
   slope by a horizontal force F, starts to slide when F cos(alpha) = G sin(alpha) + mu (G cos(alpha) +
   F sin(alpha)), i.e.

       F / G = (tan(alpha) + mu) / (1 - mu tan(alpha))                 (NAFEMS CGS-4 type benchmark),

   0.412371 for tan(alpha) = 0.1, mu = 0.3 (:data:`INCLINE_REFERENCE`). For mu tan(alpha) >= 1 no horizontal
   force moves the block up (self-locking). With Tresca friction (slip bound g_c in Pa, independent of the
   normal pressure) on a contact length L the friction force saturates at g_c L per unit depth.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

HERTZ_REFERENCE = {
    "R": 0.05, "E": 210e9, "nu": 0.3, "P": 1e5,
    "E_star": 2.3077e11, "a": 1.6609e-4, "p0": 3.8329e8,
}
"""verification.md section 2: steel cylinder (R m, E Pa, nu) on a rigid flat under P (N/m) and the reference
E* (Pa), a (m), p0 (Pa), each given to 5 significant digits."""

CATTANEO_REFERENCE = {"mu": 0.3, "values": ((0.05, 0.912871), (0.15, 0.707107), (0.25, 0.408248))}
"""verification.md section 3: (Q/P, c/a) pairs for mu = 0.3."""

INCLINE_REFERENCE = {"tan_alpha": 0.1, "mu": 0.3, "F_over_G": 0.412371}
"""verification.md section 3: global sliding limit F/G on an incline."""

HERTZ_MAX_SHEAR = {"z_over_a": 0.786, "tau_over_p0": 0.300}
"""verification.md section 2 / Johnson (1985) chapter 4: location and value of the maximum of tau_max on
the axis (3 digits)."""


class HertzLine(NamedTuple):
    """Hertz line contact: half width ``a`` (m) and peak pressure ``p0`` (Pa)."""

    a: float
    p0: float


class HertzSubsurface(NamedTuple):
    """Stresses (Pa, compression negative) on the axis below a Hertz line contact."""

    sigma_x: np.ndarray | float
    sigma_z: np.ndarray | float
    tau_max: np.ndarray | float


def _out(x):
    """Return a float for 0-d input, else the array."""
    x = np.asarray(x)
    return float(x) if x.ndim == 0 else x


def _positive(**kwargs: float) -> None:
    for name, value in kwargs.items():
        if not value > 0:
            raise ValueError(f"{name} must be positive, got {value!r}")


# ---------------------------------------------------------------------------------------------------------
# 1. Hertz line contact
# ---------------------------------------------------------------------------------------------------------


def effective_modulus(E1: float, nu1: float, E2: float | None = None, nu2: float | None = None) -> float:
    """Effective contact modulus E* in Pa: 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2.

    ``E1``, ``E2`` Young's moduli in Pa, ``nu1``, ``nu2`` Poisson's ratios. ``E2=None`` is a rigid second body
    (E* = E1/(1 - nu1^2)); ``nu2`` is then ignored. ``nu2=None`` with a given ``E2`` is an error.
    """
    _positive(E1=E1)
    compliance = (1.0 - nu1**2) / E1
    if E2 is not None:
        if nu2 is None:
            raise ValueError("nu2 is required when E2 is given")
        _positive(E2=E2)
        compliance += (1.0 - nu2**2) / E2
    return 1.0 / compliance


def hertz_line(P: float, R: float, E_star: float) -> HertzLine:
    """Hertz line contact: half width a = sqrt(4 P R/(pi E*)) in m and peak pressure p0 = 2 P/(pi a) in Pa.

    ``P`` load per unit length in N/m, ``R`` radius in m (two cylinders: 1/R = 1/R1 + 1/R2), ``E_star``
    effective modulus in Pa (:func:`effective_modulus`). Module docstring, section 1.
    """
    _positive(P=P, R=R, E_star=E_star)
    a = math.sqrt(4.0 * P * R / (math.pi * E_star))
    return HertzLine(a, 2.0 * P / (math.pi * a))


def hertz_pressure(x, a: float, p0: float):
    """Hertz pressure p(x) = p0 sqrt(1 - x^2/a^2) in Pa for |x| < a, 0 outside (``x``, ``a`` in m, ``p0`` Pa)."""
    _positive(a=a)
    x = np.asarray(x, dtype=float)
    return _out(p0 * np.sqrt(np.clip(1.0 - (x / a) ** 2, 0.0, None)))


def hertz_subsurface(z, a: float, p0: float) -> HertzSubsurface:
    """Stresses on the axis x = 0 at depth ``z`` >= 0 (m) below a Hertz line contact (Johnson ch. 4).

    ``a`` half width in m, ``p0`` peak pressure in Pa. Returns :class:`HertzSubsurface` (sigma_x, sigma_z,
    tau_max) in Pa, compression negative, tau_max = (sigma_x - sigma_z)/2 the in-plane principal shear
    (maximum 0.300 p0 at z = 0.786 a). Module docstring, section 1.
    """
    _positive(a=a)
    z = np.asarray(z, dtype=float)
    if np.any(z < 0):
        raise ValueError("z is the depth below the surface and must be >= 0")
    root = np.sqrt(a**2 + z**2)
    sigma_z = -p0 * a / root
    sigma_x = -p0 * ((a**2 + 2.0 * z**2) / (a * root) - 2.0 * z / a)
    tau = 0.5 * (sigma_x - sigma_z)
    return HertzSubsurface(_out(sigma_x), _out(sigma_z), _out(tau))


# ---------------------------------------------------------------------------------------------------------
# 2. Cattaneo-Mindlin partial slip
# ---------------------------------------------------------------------------------------------------------


def cattaneo_stick_half_width(Q: float, P: float, mu: float, a: float) -> float:
    """Stick-zone half width c = a sqrt(1 - Q/(mu P)) in m (Cattaneo-Mindlin, 2D).

    ``Q`` tangential and ``P`` normal load per unit length in N/m, ``mu`` Coulomb coefficient, ``a`` Hertz half
    width in m. Only |Q| enters (the traction has the direction of Q). Raises ValueError for |Q| >= mu P
    (full sliding, no stick zone). Module docstring, section 2.
    """
    _positive(P=P, mu=mu, a=a)
    ratio = abs(Q) / (mu * P)
    if ratio >= 1.0:
        raise ValueError(f"|Q| = {abs(Q)!r} >= mu P = {mu * P!r}: full sliding, no stick zone")
    return a * math.sqrt(1.0 - ratio)


def cattaneo_traction(x, a: float, c: float, p0: float, mu: float):
    """Cattaneo-Mindlin tangential traction q(x) in Pa (magnitude, in the direction of Q).

    q = mu p0 sqrt(1 - x^2/a^2) - [|x| < c] mu p0 (c/a) sqrt(1 - x^2/c^2) for |x| < a, 0 outside; ``x``, ``a``,
    ``c`` (0 <= c <= a, :func:`cattaneo_stick_half_width`) in m, ``p0`` Hertz peak pressure in Pa, ``mu``
    Coulomb coefficient. q = mu p in the slip zones c < |x| < a and q < mu p in the stick zone.
    """
    _positive(a=a)
    if not 0.0 <= c <= a:
        raise ValueError(f"need 0 <= c <= a, got c = {c!r}, a = {a!r}")
    x = np.asarray(x, dtype=float)
    q = mu * np.asarray(hertz_pressure(x, a, p0))
    if c > 0:
        q = q - mu * p0 * (c / a) * np.sqrt(np.clip(1.0 - (x / c) ** 2, 0.0, None))
    return _out(q)


# ---------------------------------------------------------------------------------------------------------
# 3. Global sliding
# ---------------------------------------------------------------------------------------------------------


def incline_sliding_force_ratio(tan_alpha: float, mu: float) -> float:
    """Global sliding limit F/G = (tan(alpha) + mu)/(1 - mu tan(alpha)) (dimensionless).

    Horizontal force F that starts to push a rigid block of weight G up a slope of angle alpha with Coulomb
    friction ``mu``. Raises ValueError for mu tan(alpha) >= 1 (self-locking). Module docstring, section 3.
    """
    denom = 1.0 - mu * tan_alpha
    if denom <= 0:
        raise ValueError(f"mu tan(alpha) = {mu * tan_alpha!r} >= 1: self-locking, no finite sliding force")
    return (tan_alpha + mu) / denom


def tresca_sliding_force(g_c: float, contact_length: float) -> float:
    """Saturated Tresca friction force per unit depth, g_c * contact_length in N/m.

    ``g_c`` Tresca slip bound (Pa), ``contact_length`` length of the sliding contact in m (both >= 0): a block
    on a Tresca foundation slides once the tangential load per unit depth reaches this value, independent of
    the normal load.
    """
    if g_c < 0 or contact_length < 0:
        raise ValueError(f"g_c and contact_length must be >= 0, got {g_c!r}, {contact_length!r}")
    return g_c * contact_length
