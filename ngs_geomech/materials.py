"""Material data in numbers: conductivity tensors and heat capacities from scene materials (numpy only).

Problem (P) of the seed allows an anisotropic conductivity kappa_ij per body (2.17); it must be
symmetric positive definite. A temperature-dependent conductivity kappa_ij(T) = kappa_ij f(T) with
f(T) = 1 + b (T - T_ref) is handled through the Kirchhoff transform Theta(T) = int_{T_ref}^T f(s) ds
(seed, before (2.39)), so that the flux is -kappa_ij dTheta/dx_j.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .scene.model import Material


@dataclass(frozen=True)
class ThermalProperties:
    """Thermal data of one region: ``kappa`` (dim x dim, W/(m K)) at T_ref, ``rho_c`` (J/(m^3 K),
    None when not given), ``b`` (1/K) and ``t_ref`` of f(T) = 1 + b (T - T_ref)."""

    kappa: np.ndarray
    rho_c: float | None
    b: float = 0.0
    t_ref: float = 0.0

    @property
    def nonlinear(self) -> bool:
        return self.b != 0.0


def rotation_matrix(angle, dim: int) -> np.ndarray:
    """Rotation from principal axes to x-y(-z): one angle in degrees (2D, from the x axis) or Z-Y-X Euler
    angles in degrees (3D)."""
    if dim == 2:
        a = math.radians(float(angle if not isinstance(angle, (list, tuple)) else angle[0]))
        return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    angles = angle if isinstance(angle, (list, tuple)) else [angle, 0.0, 0.0]
    if len(angles) != 3:
        raise ValueError(f"3D rotation needs 3 Euler angles, got {angles}")
    a, b, c = (math.radians(float(v)) for v in angles)
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rx = np.array([[1, 0, 0], [0, math.cos(c), -math.sin(c)], [0, math.sin(c), math.cos(c)]])
    return rz @ ry @ rx


def conductivity_tensor(m: Material, dim: int) -> np.ndarray:
    """The conductivity tensor of a material; raises ValueError naming the key at fault."""
    given = [k for k in ("conductivity", "conductivity_principal") if getattr(m, k) is not None]
    if len(given) != 1:
        raise ValueError("give exactly one of 'conductivity' or 'conductivity_principal'"
                         + (" (both given)" if len(given) == 2 else " (none given)"))
    if m.conductivity is not None:
        if m.conductivity_angle is not None:
            raise ValueError("'conductivity_angle' goes with 'conductivity_principal', not 'conductivity'")
        k = m.conductivity
        if isinstance(k, (int, float)):
            kappa = float(k) * np.eye(dim)
        else:
            kappa = np.array(k, dtype=float)
            if kappa.shape != (dim, dim):
                raise ValueError(f"'conductivity' must be {dim}x{dim} in this scene, got shape {kappa.shape}")
            if not np.allclose(kappa, kappa.T, rtol=1e-12, atol=0):
                raise ValueError(f"'conductivity' tensor {kappa.tolist()} is not symmetric")
    else:
        p = np.array(m.conductivity_principal, dtype=float)
        if p.shape != (dim,):
            raise ValueError(f"'conductivity_principal' needs {dim} values, got {len(p)}")
        rot = rotation_matrix(m.conductivity_angle or 0.0, dim)
        kappa = rot @ np.diag(p) @ rot.T
    ev = np.linalg.eigvalsh(kappa)
    if ev.min() <= 0:
        raise ValueError(f"conductivity {kappa.tolist()} is not positive definite (eigenvalues {ev.tolist()})")
    return kappa


def volumetric_heat_capacity(m: Material) -> float | None:
    """rho*c in J/(m^3 K), from 'rho_c' or 'density' * 'specific_heat'; None when not given.

    'density' alone is allowed (gravity needs it); 'specific_heat' needs 'density'.
    """
    if m.rho_c is not None:
        if m.specific_heat is not None:
            raise ValueError("give either 'rho_c' or 'density' and 'specific_heat', not both")
        value = m.rho_c
    elif m.specific_heat is not None:
        if m.density is None:
            raise ValueError("'specific_heat' needs 'density'")
        value = m.density * m.specific_heat
    else:
        return None
    if value <= 0:
        raise ValueError(f"rho*c = {value:g} J/(m^3 K) must be positive")
    return float(value)


def thermal_properties(m: Material, dim: int) -> ThermalProperties:
    """All thermal data of a material (raises ValueError naming the key at fault)."""
    return ThermalProperties(kappa=conductivity_tensor(m, dim), rho_c=volumetric_heat_capacity(m),
                             b=m.conductivity_temperature_coefficient, t_ref=m.reference_temperature)
