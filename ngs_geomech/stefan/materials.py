"""The materials of the Stefan problem (:mod:`ngs_geomech.stefan.forms`), seed (2.46)-(2.48): per material the
enthalpy e(T) (J/m^3, measured from the solid at the phase-change temperature Theta_R; the enthalpy graph H of
(2.48), multivalued at Theta_R), the Kirchhoff variable theta(T) = int k(s) ds (W/m) and the linear conductivity law
k(T) = k (1 + b (T - T_ref)). Plain numpy on nodal values; no mesh, no forms.

Anisotropy. The conductivity tensor of each phase may be k_phase K_hat with one symmetric positive definite shape
K_hat per material (``anisotropy``; None: the identity): the phases scale the same anisotropy, so that the flux
-k(T) K_hat grad T = -K_hat grad theta(T) keeps one Kirchhoff variable theta per material (the scalar k_s, k_l
of the laws below are the factors of K_hat).

Spatial variation. The shape may also vary in x, y, z: the tensors are then k_s G(x) and k_l G(x) with G =
``variation`` (a tensor of numbers and expressions of x, y, z, r; dimensionless), so that the flux -k(T) G grad T =
-G grad theta(T) keeps the same Kirchhoff variable: the phases share the variation, k_l(x) / k_s(x) = k_l / k_s is one
constant per material. Exact for this class: the conduction term is div(G grad theta).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SolverError


def check_number(name: str, value, *, positive: bool = False, nonnegative: bool = False) -> float:
    """A finite float; ValueError naming ``name`` and the value otherwise."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be > 0, got {v}")
    if nonnegative and v < 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    return v


class _LinearConductivityLaw:
    """k(T) = k f(T), f(T) = 1 + b (T - T_ref) (b = ``conductivity_temperature_coefficient``, 1/K;
    T_ref = ``reference_temperature``), shared by the phase-change and the plain materials."""

    def _check_anisotropy(self) -> None:
        """``anisotropy`` None or a symmetric positive definite matrix of finite floats (stored as nested tuples)."""
        a = self.anisotropy
        if a is None:
            return
        try:
            arr = np.array(a, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"anisotropy must be a square matrix of numbers, got {a!r}") from None
        if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or not np.all(np.isfinite(arr)):
            raise ValueError(f"anisotropy must be a square matrix of finite numbers, got {a!r}")
        if not np.allclose(arr, arr.T, rtol=1e-12, atol=0) or np.linalg.eigvalsh(arr).min() <= 0:
            raise ValueError(f"anisotropy {arr.tolist()} must be symmetric positive definite")
        object.__setattr__(self, "anisotropy", tuple(tuple(float(v) for v in row) for row in arr))

    def _check_variation(self) -> None:
        """``variation`` None or a square matrix of finite floats and expression strings (stored as nested tuples,
        hashable), not with ``anisotropy`` (G(x) holds the shape then)."""
        g = self.variation
        if g is None:
            return
        if self.anisotropy is not None:
            raise ValueError("give anisotropy (a constant shape) or variation (a shape of x, y, z), not both")
        try:
            rows = [list(row) for row in g]
        except TypeError:
            raise ValueError(f"variation must be a square matrix, got {g!r}") from None
        if any(len(row) != len(rows) for row in rows):
            raise ValueError(f"variation must be a square matrix, got {g!r}")
        out = tuple(tuple(v if isinstance(v, str) else check_number("variation entry", v) for v in row)
                    for row in rows)
        object.__setattr__(self, "variation", out)

    @property
    def temperature_dependent(self) -> bool:
        """Whether k depends on T (b != 0)."""
        return self.conductivity_temperature_coefficient != 0.0

    def conductivity_factor(self, T):
        """f(T) = 1 + b (T - T_ref) (dimensionless, numpy): k(T) = k f(T) in each phase."""
        return 1.0 + self.conductivity_temperature_coefficient * (np.asarray(T, dtype=float)
                                                                  - self.reference_temperature)


@dataclass(frozen=True)
class PhaseChangeMaterial(_LinearConductivityLaw):
    """A material with a phase change at ``melting_temperature`` Theta_R (K or degC; the seed's Theta_R^m).

    ``latent_heat`` L is volumetric (J/m^3, rho L of (2.46), (2.48); >= 0), ``rho_c_solid`` and
    ``rho_c_liquid`` the volumetric heat capacities C_s, C_l (J/(m^3 K), > 0), ``conductivity_solid`` and
    ``conductivity_liquid`` k_s, k_l (W/(m K), > 0), the tensors k_s K_hat and k_l K_hat with K_hat =
    ``anisotropy`` (dimensionless, symmetric positive definite; None: isotropic). The enthalpy is measured from
    the solid at Theta_R: e(T) = C_s (T - Theta_R) below, L + C_l (T - Theta_R) above (J/m^3). ``variation``
    G(x) (module docstring) makes the tensors k_s G(x) and k_l G(x) instead (None: constant).
    """

    melting_temperature: float
    latent_heat: float
    rho_c_solid: float
    rho_c_liquid: float
    conductivity_solid: float
    conductivity_liquid: float
    conductivity_temperature_coefficient: float = 0.0
    reference_temperature: float = 0.0
    anisotropy: tuple | None = None
    variation: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "melting_temperature",
                           check_number("melting_temperature", self.melting_temperature))
        object.__setattr__(self, "latent_heat", check_number("latent_heat", self.latent_heat, nonnegative=True))
        for name in ("rho_c_solid", "rho_c_liquid", "conductivity_solid", "conductivity_liquid"):
            object.__setattr__(self, name, check_number(name, getattr(self, name), positive=True))
        _check_law(self)
        self._check_anisotropy()
        self._check_variation()

    @property
    def diffusivity_solid(self) -> float:
        """k_s / C_s, m^2/s."""
        return self.conductivity_solid / self.rho_c_solid

    @property
    def diffusivity_liquid(self) -> float:
        """k_l / C_l, m^2/s."""
        return self.conductivity_liquid / self.rho_c_liquid

    def enthalpy(self, T, liquid_fraction=0.0):
        """e(T) in J/m^3 (numpy); at T = Theta_R exactly, e = liquid_fraction * L (default: solid)."""
        T = np.asarray(T, dtype=float)
        d = T - self.melting_temperature
        return np.where(d < 0, self.rho_c_solid * d,
                        np.where(d > 0, self.latent_heat + self.rho_c_liquid * d,
                                 self.latent_heat * np.asarray(liquid_fraction, dtype=float)))

    def kirchhoff(self, T):
        """theta(T) = int_{Theta_R}^T k(s) ds, W/m (numpy): k_phase (T - Theta_R) (1 + b/2 (T + Theta_R - 2 T_ref))
        on each side of Theta_R (k_phase (T - Theta_R) when b = 0)."""
        d = np.asarray(T, dtype=float) - self.melting_temperature
        if self.temperature_dependent:
            b, tr = self.conductivity_temperature_coefficient, self.reference_temperature
            u = d * (1.0 + 0.5 * b * (np.asarray(T, dtype=float) + self.melting_temperature - 2.0 * tr))
            return np.where(d < 0, self.conductivity_solid * u, self.conductivity_liquid * u)
        return np.where(d < 0, self.conductivity_solid * d, self.conductivity_liquid * d)

    def temperature_of_kirchhoff(self, theta):
        """The inverse of :meth:`kirchhoff` (K, numpy), on the branch where k stays positive."""
        theta = np.asarray(theta, dtype=float)
        k = np.where(theta < 0, self.conductivity_solid, self.conductivity_liquid)
        f0 = self.conductivity_factor(self.melting_temperature)
        return self.melting_temperature + _inverse_quadratic(theta / k, f0, self.conductivity_temperature_coefficient)


@dataclass(frozen=True)
class PlainThermalMaterial(_LinearConductivityLaw):
    """A material without phase change: ``rho_c`` C (J/(m^3 K), > 0), ``conductivity`` k (W/(m K), > 0; the
    tensor k K_hat with K_hat = ``anisotropy``, None: isotropic; k G(x) with G = ``variation``, module docstring);
    e = C T (J/m^3), theta = k T (W/m)."""

    rho_c: float
    conductivity: float
    conductivity_temperature_coefficient: float = 0.0
    reference_temperature: float = 0.0
    anisotropy: tuple | None = None
    variation: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "rho_c", check_number("rho_c", self.rho_c, positive=True))
        object.__setattr__(self, "conductivity", check_number("conductivity", self.conductivity, positive=True))
        _check_law(self)
        self._check_anisotropy()
        self._check_variation()

    def enthalpy(self, T, liquid_fraction=0.0):
        return self.rho_c * np.asarray(T, dtype=float)

    def kirchhoff(self, T):
        """K T (b = 0), k (T - T_ref) (1 + b/2 (T - T_ref)) otherwise (W/m; the same up to a constant)."""
        if self.temperature_dependent:
            d = np.asarray(T, dtype=float) - self.reference_temperature
            return self.conductivity * d * (1.0 + 0.5 * self.conductivity_temperature_coefficient * d)
        return self.conductivity * np.asarray(T, dtype=float)


StefanMaterial = PhaseChangeMaterial | PlainThermalMaterial


def _check_law(mat) -> None:
    """B and T_ref finite (their fields normalized to floats)."""
    for name in ("conductivity_temperature_coefficient", "reference_temperature"):
        object.__setattr__(mat, name, check_number(name, getattr(mat, name)))


def _inverse_quadratic(y, f0, b):
    """The d with d (f0 + b d / 2) = y on the branch through d = 0 (f0 > 0; numpy): the inverse of the
    Kirchhoff map measured from a point where the factor is f0, computed without cancellation."""
    y = np.asarray(y, dtype=float)
    if b == 0.0:
        return y / f0
    disc = f0 * f0 + 2.0 * b * y
    with np.errstate(invalid="ignore"):
        return np.where(disc >= 0, 2.0 * y / (f0 + np.sqrt(np.maximum(disc, 0.0))), np.nan)


class ConductivityRangeError(SolverError):
    """A temperature-dependent conductivity k (1 + b (T - T_ref)) is not positive at a temperature reached:
    ``regions`` are the regions of the material at fault."""

    def __init__(self, message: str, regions: list[str]):
        super().__init__(message)
        self.regions = list(regions)
