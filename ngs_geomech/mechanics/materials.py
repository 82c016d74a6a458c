"""Elastic material data in numbers: stiffness matrices, thermal stress tensors and 2D reductions (numpy only).

The seed's thermoelastic law (J. Nedoma 2001, (2.37)) is

    tau_ij = c_ijkl e_kl - beta_ij (T - T0),     beta_ij = c_ijkl alpha_kl,

with c_ijkl symmetric and positive definite (2.38). Here it is written in **Voigt notation** with the order
(xx, yy, zz, yz, xz, xy) and engineering shear strains::

    e = [e_xx, e_yy, e_zz, 2 e_yz, 2 e_xz, 2 e_xy],   s = [s_xx, s_yy, s_zz, s_yz, s_xz, s_xy],
    s = C @ e - b (T - T0),   b = to_voigt_stress(beta),

so that the 6x6 stiffness ``C`` (Pa) is symmetric and e : C : e = e^T C e (no factors of 2 in C).

Material constants (isotropic, Lame, orthotropic, transversely isotropic, a full ``stiffness_voigt``, and a
tensor ``thermal_expansion``) are given in the **material axes** 1, 2, 3; ``elastic_rotation`` rotates the
material axes into the global axes x, y, z (the columns of the rotation matrix R are the material axes in
global coordinates, as for ``conductivity_angle``), and the global stiffness is the Bond transform
C_global = M C M^T (:func:`rotate_voigt`). In 2D scenes the third axis z is the out-of-plane direction (plane)
or the hoop direction theta (axisymmetric, with x = r and y = z).

Nonlinear (power-law) elasticity (2.1)-(2.5): see :class:`ElasticProperties`.

Errors in scene data raise :class:`~ngs_geomech.errors.MaterialError` (a ValueError) whose ``key`` names the
material key at fault and whose message starts with that key, so that a caller can report
``materials.<region>.<key>``. The ranges of single keys (a positive modulus, a Poisson ratio in (-1, 0.5), ...) are
declared with the keys (:class:`~ngs_geomech.scene.model.Material`) and checked from there; the rules that join
several keys (a positive bulk modulus, a positive definite stiffness) are checked here.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import MaterialError
from ..heat.materials import check_declared, rotation_matrix
from ..scene import expressions
from ..scene.model import Material
from ..scene.schema import material_at, varying_keys

# Voigt index of each tensor component (i, j), and the (i, j) of each Voigt index
_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_NORMAL = [0, 1, 2]
_IN_PLANE = [0, 1, 5]          # xx, yy, xy
_OUT_OF_PLANE = [2, 3, 4]      # zz, yz, xz
_AXISYMMETRIC = [0, 1, 2, 5]   # rr, zz, theta-theta, rz  (x = r, y = z, third axis = theta)
_TORSION = [3, 4]              # z-theta, r-theta


# ---------------------------------------------------------------------------------------------- Voigt helpers

def to_voigt_strain(eps) -> np.ndarray:
    """Strain tensor (3x3, symmetric) -> Voigt 6-vector [e_xx, e_yy, e_zz, 2 e_yz, 2 e_xz, 2 e_xy]."""
    eps = np.asarray(eps, dtype=float)
    return np.array([eps[i, j] if i == j else eps[i, j] + eps[j, i] for i, j in _PAIRS])


def from_voigt_strain(e) -> np.ndarray:
    """Voigt strain 6-vector (engineering shears) -> symmetric 3x3 strain tensor."""
    e = np.asarray(e, dtype=float)
    out = np.empty((3, 3))
    for k, (i, j) in enumerate(_PAIRS):
        out[i, j] = out[j, i] = e[k] if i == j else 0.5 * e[k]
    return out


def to_voigt_stress(sig) -> np.ndarray:
    """Stress tensor (3x3, symmetric, Pa) -> Voigt 6-vector [s_xx, s_yy, s_zz, s_yz, s_xz, s_xy] (Pa).

    Also used for the thermal stress tensor beta (Pa/K)."""
    sig = np.asarray(sig, dtype=float)
    return np.array([0.5 * (sig[i, j] + sig[j, i]) for i, j in _PAIRS])


def from_voigt_stress(s) -> np.ndarray:
    """Voigt stress 6-vector (Pa) -> symmetric 3x3 stress tensor (Pa)."""
    s = np.asarray(s, dtype=float)
    out = np.empty((3, 3))
    for k, (i, j) in enumerate(_PAIRS):
        out[i, j] = out[j, i] = s[k]
    return out


# ------------------------------------------------------------------------------------------- stiffness matrices

def from_lame(lam: float, mu: float) -> np.ndarray:
    """Isotropic 6x6 stiffness (Pa) from the Lame constants lambda and mu (Pa)."""
    c = np.zeros((6, 6))
    c[:3, :3] = lam
    c[_NORMAL, _NORMAL] += 2.0 * mu
    c[[3, 4, 5], [3, 4, 5]] = mu
    return c


def isotropic(E: float, nu: float) -> np.ndarray:
    """Isotropic 6x6 stiffness (Pa) from Young's modulus E (Pa) and Poisson's ratio nu (-)."""
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    return from_lame(lam, mu)


def orthotropic_compliance(E, nu, G) -> np.ndarray:
    """Orthotropic 6x6 compliance S (1/Pa) in the material axes, Voigt order (11, 22, 33, 23, 13, 12).

    ``E`` = (E1, E2, E3) Pa, ``nu`` = (nu12, nu13, nu23) with nu_ij = -e_j / e_i under uniaxial stress along
    i (so nu21 = nu12 E2/E1, nu31 = nu13 E3/E1, nu32 = nu23 E3/E2), ``G`` = (G12, G13, G23) Pa."""
    E1, E2, E3 = (float(v) for v in E)
    nu12, nu13, nu23 = (float(v) for v in nu)
    G12, G13, G23 = (float(v) for v in G)
    s = np.zeros((6, 6))
    s[0, 0], s[1, 1], s[2, 2] = 1.0 / E1, 1.0 / E2, 1.0 / E3
    s[0, 1] = s[1, 0] = -nu12 / E1
    s[0, 2] = s[2, 0] = -nu13 / E1
    s[1, 2] = s[2, 1] = -nu23 / E2
    s[3, 3], s[4, 4], s[5, 5] = 1.0 / G23, 1.0 / G13, 1.0 / G12
    return s


def orthotropic(E, nu, G) -> np.ndarray:
    """Orthotropic 6x6 stiffness (Pa) in the material axes: the inverse of :func:`orthotropic_compliance`.

    ``E`` = (E1, E2, E3) Pa, ``nu`` = (nu12, nu13, nu23), ``G`` = (G12, G13, G23) Pa; nu_ij = -e_j / e_i under
    uniaxial stress along i. Raises numpy.linalg.LinAlgError when the compliance is singular."""
    c = np.linalg.inv(orthotropic_compliance(E, nu, G))
    return 0.5 * (c + c.T)


def transversely_isotropic(E_plane: float, E_axis: float, nu_plane: float, nu_axis: float,
                           G_axis: float) -> np.ndarray:
    """Transversely isotropic 6x6 stiffness (Pa): isotropic in the 1-2 plane, symmetry axis 3.

    ``E_plane`` = E1 = E2 (Pa), ``E_axis`` = E3 (Pa); ``nu_plane`` = nu12 = -e_2/e_1 under stress along 1 (in
    the plane); ``nu_axis`` = nu31 = -e_1/e_3 under stress along the axis 3 (so nu13 = nu31 E_plane/E_axis);
    ``G_axis`` = G13 = G23 (Pa), the shear modulus of planes containing the axis. The in-plane shear modulus
    is G12 = E_plane / (2 (1 + nu_plane))."""
    nu13 = nu_axis * E_plane / E_axis
    G12 = E_plane / (2.0 * (1.0 + nu_plane))
    return orthotropic((E_plane, E_plane, E_axis), (nu_plane, nu13, nu13), (G12, G_axis, G_axis))


class EngineeringConstants(NamedTuple):
    """Apparent engineering constants of a stiffness in its own axes: ``E`` = (E1, E2, E3) Pa,
    ``nu`` = (nu12, nu13, nu23), ``G`` = (G12, G13, G23) Pa (the arguments of :func:`orthotropic`)."""

    E: tuple
    nu: tuple
    G: tuple


def engineering_constants(C) -> EngineeringConstants:
    """Young's moduli, Poisson ratios nu_ij = -S_ji / S_ii and shear moduli 1/S_kk read off the compliance
    S = C^-1 in the axes of C (exact for an orthotropic C in its material axes, apparent otherwise)."""
    s = np.linalg.inv(np.asarray(C, dtype=float))
    E = tuple(1.0 / s[i, i] for i in range(3))
    nu = tuple(-s[j, i] / s[i, i] for i, j in ((0, 1), (0, 2), (1, 2)))
    G = (1.0 / s[5, 5], 1.0 / s[4, 4], 1.0 / s[3, 3])
    return EngineeringConstants(E, nu, G)


def isotropic_constants(C, rtol: float = 1e-9) -> tuple[float, float] | None:
    """(E in Pa, nu) when the 6x6 stiffness C is isotropic (to ``rtol`` of its largest entry), else None."""
    C = np.asarray(C, dtype=float)
    lam, mu = C[0, 1], C[5, 5]
    if np.abs(C - from_lame(lam, mu)).max() > rtol * np.abs(C).max() or mu <= 0 or lam + mu == 0:
        return None
    return float(mu * (3 * lam + 2 * mu) / (lam + mu)), float(lam / (2 * (lam + mu)))


def check_positive_definite(C, key: str) -> np.ndarray:
    """Check that the 6x6 stiffness C (Pa) is symmetric (to 1e-10 of its largest entry) and positive definite
    (2.38); return it as a float array, or raise :class:`MaterialError` naming ``key`` (with the eigenvalues)."""
    try:
        C = np.asarray(C, dtype=float)
    except (TypeError, ValueError) as exc:
        raise MaterialError(key, f"must be a 6x6 matrix of numbers ({exc})") from None
    if C.shape != (6, 6):
        raise MaterialError(key, f"must be a 6x6 stiffness matrix, got shape {C.shape}")
    if not np.all(np.isfinite(C)):
        raise MaterialError(key, ": stiffness has non-finite entries")
    scale = np.abs(C).max()
    asym = np.abs(C - C.T).max()
    if asym > 1e-10 * scale:
        raise MaterialError(key, f": stiffness is not symmetric (max |C - C^T| = {asym:.3g} Pa, "
                                 f"max |C| = {scale:.3g} Pa)")
    ev = np.linalg.eigvalsh(0.5 * (C + C.T))
    if ev.min() <= 1e-12 * max(ev.max(), 0.0):
        raise MaterialError(key, ": stiffness is not positive definite (eigenvalues "
                                 + ", ".join(f"{v:.4g}" for v in ev) + " Pa)")
    return C


# -------------------------------------------------------------------------------------------------- rotations

def rotation(angle, dim: int) -> np.ndarray:
    """3x3 rotation taking the material axes to the global axes (columns = material axes in x, y, z).

    2D scenes: one angle in degrees about z (the out-of-plane or hoop axis), from x. 3D scenes: Z-Y-X Euler
    angles [a, b, c] in degrees, R = Rz(a) Ry(b) Rx(c) (a single number is [a, 0, 0]).
    Three Euler angles are also accepted in 2D: they are needed to turn the axis of a transversely isotropic
    material into the plane, e.g. [0, 0, 90] puts axis 3 along -y (horizontal bedding in a plane scene, or the
    symmetry axis of an axisymmetric one)."""
    if isinstance(angle, np.ndarray):
        angle = angle.tolist()
    if isinstance(angle, (list, tuple)):
        angles = [float(a) for a in angle]
        if dim == 2 and len(angles) == 1:
            angles = [angles[0], 0.0, 0.0]
        if len(angles) != 3:
            raise ValueError(f"rotation needs {'one angle or ' if dim == 2 else ''}3 Euler angles (degrees), "
                             f"got {len(angles)} values")
    else:
        angles = [float(angle), 0.0, 0.0]
    if not all(math.isfinite(a) for a in angles):
        raise ValueError(f"rotation angles must be finite, got {angles}")
    return rotation_matrix(angles, 3)


def bond_matrix(R) -> np.ndarray:
    """6x6 Bond matrix M of a 3x3 rotation R for Voigt stresses: to_voigt_stress(R sigma R^T) =
    M @ to_voigt_stress(sigma). Voigt engineering strains transform with M^-T."""
    R = np.asarray(R, dtype=float)
    if R.shape == (2, 2):
        R = np.block([[R, np.zeros((2, 1))], [np.zeros((1, 2)), np.ones((1, 1))]])
    M = np.empty((6, 6))
    for k in range(6):
        unit = np.zeros(6)
        unit[k] = 1.0
        M[:, k] = to_voigt_stress(R @ from_voigt_stress(unit) @ R.T)
    return M


def rotate_voigt(C, R) -> np.ndarray:
    """The 6x6 stiffness (Pa) in the global axes of a material whose axes are rotated by R (3x3, or 2x2 about
    z): C_global = M C M^T with M the Bond matrix of R (:func:`bond_matrix`)."""
    M = bond_matrix(R)
    c = M @ np.asarray(C, dtype=float) @ M.T
    return 0.5 * (c + c.T)


# ------------------------------------------------------------------------------------------- thermal expansion

def expansion_tensor(value) -> np.ndarray:
    """Thermal expansion tensor alpha (3x3, 1/K): a number alpha gives alpha I; a symmetric 3x3 list is taken
    as it is. Raises :class:`MaterialError` (key ``thermal_expansion``) otherwise."""
    key = "thermal_expansion"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        a = float(value) * np.eye(3)
    else:
        try:
            a = np.array(value, dtype=float)
        except (TypeError, ValueError):
            raise MaterialError(key, f"must be a number or a symmetric 3x3 matrix, got {value!r}") from None
        if a.shape != (3, 3):
            raise MaterialError(key, f"must be a number or a symmetric 3x3 matrix (1/K), got shape {a.shape}")
        if not np.allclose(a, a.T, rtol=1e-10, atol=1e-14 * np.abs(a).max()):
            raise MaterialError(key, f"tensor {a.tolist()} is not symmetric")
    if not np.all(np.isfinite(a)):
        raise MaterialError(key, "has non-finite entries")
    return a


def thermal_stress_tensor(C, alpha) -> np.ndarray:
    """beta_ij = c_ijkl alpha_kl (3x3, Pa/K) from the 6x6 stiffness (Pa) and the 3x3 expansion tensor (1/K)."""
    return from_voigt_stress(np.asarray(C, dtype=float) @ to_voigt_strain(alpha))


def _beta_voigt(beta) -> np.ndarray:
    beta = np.asarray(beta, dtype=float)
    return to_voigt_stress(beta) if beta.shape == (3, 3) else beta.reshape(6)


# --------------------------------------------------------------------------------------------- 2D reductions

class PlaneStress(NamedTuple):
    """Plane stress reduction: in-plane stress [s_xx, s_yy, s_xy] = Q @ e - beta (T - T0) for the in-plane
    strain e = [e_xx, e_yy, 2 e_xy]; the out-of-plane strains [e_zz, 2 e_yz, 2 e_xz] =
    strain_out @ e + strain_out_thermal (T - T0)."""

    Q: np.ndarray                   #: 3x3, Pa
    beta: np.ndarray                #: 3-vector, Pa/K
    strain_out: np.ndarray          #: 3x3, -
    strain_out_thermal: np.ndarray  #: 3-vector, 1/K


def plane_stress(C, beta) -> PlaneStress:
    """Plane stress (s_zz = s_yz = s_xz = 0) by static condensation of the 6x6 stiffness C (Pa) and the thermal
    stress tensor beta (3x3 or Voigt 6-vector, Pa/K).

    With p = (xx, yy, xy) and o = (zz, yz, xz): Q = C_pp - C_po C_oo^-1 C_op, beta_p' = beta_p -
    C_po C_oo^-1 beta_o, and e_o = -C_oo^-1 C_op e_p + C_oo^-1 beta_o (T - T0). All three out-of-plane stresses
    are condensed, which is exact also for anisotropic materials whose normal stresses couple to the
    out-of-plane shears (for materials without that coupling it reduces to the usual s_zz = 0 condensation).
    Isotropic: Q = E/(1-nu^2) [[1, nu, 0], [nu, 1, 0], [0, 0, (1-nu)/2]], beta' = E alpha/(1-nu) [1, 1, 0]."""
    C = np.asarray(C, dtype=float)
    b = _beta_voigt(beta)
    p, o = _IN_PLANE, _OUT_OF_PLANE
    coo = C[np.ix_(o, o)]
    x = np.linalg.solve(coo, np.column_stack([C[np.ix_(o, p)], b[o]]))
    solve_op, solve_b = x[:, :3], x[:, 3]
    Q = C[np.ix_(p, p)] - C[np.ix_(p, o)] @ solve_op
    return PlaneStress(Q=0.5 * (Q + Q.T), beta=b[p] - C[np.ix_(p, o)] @ solve_b,
                       strain_out=-solve_op, strain_out_thermal=solve_b)


class PlaneStrain(NamedTuple):
    """Plane strain reduction (e_zz = e_yz = e_xz = 0): in-plane stress [s_xx, s_yy, s_xy] = D @ e - beta (T - T0)
    for e = [e_xx, e_yy, 2 e_xy]; out-of-plane stresses [s_zz, s_yz, s_xz] = stress_out @ e -
    beta_out (T - T0) (s_zz is row 0: s_zz = C[2, [0, 1, 5]] e - beta_zz (T - T0))."""

    D: np.ndarray         #: 3x3, Pa
    beta: np.ndarray      #: 3-vector, Pa/K
    stress_out: np.ndarray  #: 3x3, Pa
    beta_out: np.ndarray  #: 3-vector, Pa/K


def plane_strain(C, beta) -> PlaneStrain:
    """Plane strain (e_zz = e_yz = e_xz = 0) rows and columns of the 6x6 stiffness C (Pa) and the thermal stress
    tensor beta (3x3 or Voigt 6-vector, Pa/K). Exact for any anisotropy (the out-of-plane shear stresses, if
    any, do not vary along z and do not enter the in-plane equilibrium).
    Isotropic: D = E/((1+nu)(1-2nu)) [[1-nu, nu, 0], [nu, 1-nu, 0], [0, 0, (1-2nu)/2]], beta = E alpha/(1-2nu)."""
    C = np.asarray(C, dtype=float)
    b = _beta_voigt(beta)
    p, o = _IN_PLANE, _OUT_OF_PLANE
    return PlaneStrain(D=C[np.ix_(p, p)].copy(), beta=b[p].copy(), stress_out=C[np.ix_(o, p)].copy(),
                       beta_out=b[o].copy())


class Axisymmetric(NamedTuple):
    """Axisymmetric (torsionless) reduction, x = r, y = z, third axis theta: [s_rr, s_zz, s_tt, s_rz] =
    D @ [e_rr, e_zz, e_tt, 2 e_rz] - beta (T - T0)."""

    D: np.ndarray     #: 4x4, Pa
    beta: np.ndarray  #: 4-vector, Pa/K


def axisymmetric(C, beta, name: str = "material") -> Axisymmetric:
    """Axisymmetric reduction of the 6x6 global stiffness C (Pa) and beta (3x3 or Voigt 6-vector, Pa/K), with
    x = r, y = z (the symmetry axis) and the global third axis = the hoop direction theta.

    The material must not couple (rr, zz, tt, rz) to the torsional shears (z-theta = Voigt yz, r-theta = Voigt
    xz), in stiffness or thermal stress: isotropic materials, orthotropic ones with axes along (r, z, theta),
    or transversely isotropic ones with the axis along r, z or theta. Note that the unrotated material axes
    are (1, 2, 3) = (r, z, theta): a transversely isotropic material with its axis along the symmetry axis z
    needs ``elastic_rotation = [0, 0, 90]``. Raises ValueError, starting with ``name``, otherwise."""
    C = np.asarray(C, dtype=float)
    b = _beta_voigt(beta)
    a, t = _AXISYMMETRIC, _TORSION
    coupling = np.abs(C[np.ix_(a, t)]).max() / np.abs(C).max()
    if coupling > 1e-10:
        raise ValueError(f"{name}: stiffness couples the axisymmetric strains (rr, zz, theta-theta, rz) to the "
                         f"torsional shears (z-theta, r-theta) (relative size {coupling:.3g}): only isotropic "
                         "materials or material axes along (r, z, theta) are allowed in an axisymmetric scene")
    bscale = max(np.abs(b).max(), 1e-300)
    if np.abs(b[t]).max() > 1e-10 * bscale:
        raise ValueError(f"{name}: thermal stress tensor has torsional components beta_ztheta, beta_rtheta = "
                         f"{b[t].tolist()} Pa/K: not allowed in an axisymmetric scene")
    return Axisymmetric(D=C[np.ix_(a, a)].copy(), beta=b[a].copy())


# ------------------------------------------------------------------------------------------ material properties

@dataclass(frozen=True, eq=False)
class ElasticProperties:
    """Elastic data of one region, in the global axes.

    ``C`` 6x6 stiffness (Pa, Voigt order xx, yy, zz, yz, xz, xy, engineering shear strains); ``alpha`` 3x3
    thermal expansion (1/K); ``beta`` = C : alpha, 3x3 (Pa/K); ``T0`` the stress-free temperature (degC or K);
    ``density`` (kg/m^3, None when not given); ``lam`` the rheology exponent lambda (-); ``eps_ref`` the
    reference strain (-).

    Nonlinear law (seed (2.1)-(2.5)): with A1 = e : C : e = e^T C e (Pa) and A_ref = eps_ref^2 C[0, 0] (the A1
    of the uniaxial strain eps_ref along x), the stored energy density (J/m^3) is

        W = (A_ref / 2) ((A1/A_ref + delta)^lam - delta^lam),

    so that the stress is  s = dW/de = lam (A1/A_ref + delta)^(lam - 1) C e  (- beta (T - T0)): the seed's
    c* = 2 lam A1^(lam-1) c with c = C/2 and A1 measured in units of A_ref. delta >= 0 is a small
    regularization (lam < 1 is singular at zero strain). lam = 1 is linear elasticity with C; lam < 1 softens,
    lam > 1 hardens."""

    C: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    T0: float = 0.0
    density: float | None = None
    lam: float = 1.0
    eps_ref: float = 1e-3
    varying: VaryingElastic | None = None
    """Data that vary over the region (expressions): then C, alpha, beta are those of the stiffest sample point
    (the largest diagonal entry of C), T0 the smallest and density the largest over the points
    (:func:`varying_elastic_properties`): representative numbers for scales, the forms take the expressions."""

    @property
    def A_ref(self) -> float:
        """eps_ref^2 C[0, 0] (Pa): A1 = e : C : e of the uniaxial strain eps_ref along x."""
        return float(self.eps_ref ** 2 * self.C[0, 0])

    @property
    def linear(self) -> bool:
        return self.lam == 1.0

    def secant_factor(self, A1, delta: float = 0.0):
        """The factor lam (A1/A_ref + delta)^(lam - 1) (-): the stress is this times C e. Works on floats, arrays and
        any object with +, / and ** (e.g. NGSolve CoefficientFunctions)."""
        if self.lam == 1.0:
            return 1.0 + 0.0 * A1
        return self.lam * (A1 / self.A_ref + delta) ** (self.lam - 1.0)

    def energy(self, A1, delta: float = 0.0):
        """W = (A_ref/2) ((A1/A_ref + delta)^lam - delta^lam) (J/m^3) for A1 = e : C : e (Pa)."""
        if self.lam == 1.0:
            return 0.5 * A1
        return 0.5 * self.A_ref * ((A1 / self.A_ref + delta) ** self.lam - delta ** self.lam)

    def youngs_modulus_and_poisson(self) -> tuple[float, float] | None:
        """(E in Pa, nu) for an isotropic material, None otherwise (varying data: isotropic when given by
        youngs_modulus + poisson_ratio or lame_lambda + lame_mu; the representative point's values)."""
        if self.varying is not None and not self.varying.isotropic:
            return None
        return isotropic_constants(self.C)

    @property
    def max_poisson(self) -> float:
        """Poisson's ratio for the near-incompressibility warning (-): nu of an isotropic material; for an
        anisotropic one the nu = (3K - 2G) / (2 (3K + G)) of the Reuss bounds K = 1/sum(S_ij, i, j <= 3) and
        G = 15 / (4 (S11 + S22 + S33) - 4 (S12 + S13 + S23) + 3 (S44 + S55 + S66)) from the compliance
        S = C^-1 (rotation invariant, equal to nu for isotropic C, and -> 0.5 exactly when the material
        becomes incompressible under hydrostatic stress). Apparent nu_ij > 0.5 of an anisotropic material
        do not by themselves mean incompressibility. Varying data: the largest over the sample points."""
        if self.varying is not None:
            return self.varying.max_poisson
        iso = isotropic_constants(self.C)
        if iso is not None:
            return iso[1]
        s = np.linalg.inv(self.C)
        K = 1.0 / s[:3, :3].sum()
        G = 15.0 / (4.0 * np.trace(s[:3, :3]) - 4.0 * (s[0, 1] + s[0, 2] + s[1, 2]) + 3.0 * np.trace(s[3:, 3:]))
        return float((3 * K - 2 * G) / (2 * (3 * K + G)))


_GROUPS = (("youngs_modulus", "poisson_ratio"), ("lame_lambda", "lame_mu"), ("orthotropic",),
           ("transversely_isotropic",), ("stiffness_voigt",))
_GROUP_NAMES = " | ".join(" + ".join(g) for g in _GROUPS)


def elastic_group(m: Material) -> tuple[str, ...]:
    """The one group of keys that gives the stiffness (e.g. ``("youngs_modulus", "poisson_ratio")``), with each key
    of it given and meeting its declaration; raises :class:`MaterialError` naming the key at fault."""
    given = [g for g in _GROUPS if any(getattr(m, k) is not None for k in g)]
    if not given:
        raise MaterialError("", f"no elastic constants: give exactly one of {_GROUP_NAMES}")
    if len(given) > 1:
        first = [k for k in given[0] if getattr(m, k) is not None][0]
        second = [k for k in given[1] if getattr(m, k) is not None][0]
        raise MaterialError(second, f"conflicts with {first}: give exactly one of {_GROUP_NAMES}")
    group = given[0]
    missing = [k for k in group if getattr(m, k) is None]
    if missing:
        raise MaterialError(missing[0], f"missing: {' and '.join(group)} go together")
    check_declared(m, group)
    return group


def _stiffness(m: Material) -> tuple[np.ndarray, str]:
    """The stiffness in the material axes and the key it comes from."""
    group = elastic_group(m)
    if group[0] == "youngs_modulus":
        return isotropic(float(m.youngs_modulus), float(m.poisson_ratio)), "youngs_modulus"
    if group[0] == "lame_lambda":
        lam, mu = float(m.lame_lambda), float(m.lame_mu)
        if not 3.0 * lam + 2.0 * mu > 0:
            raise MaterialError("lame_lambda", f"= {lam:g} Pa gives a bulk modulus lambda + 2 mu/3 = "
                                               f"{lam + 2.0 * mu / 3.0:.4g} Pa that is not positive")
        return from_lame(lam, mu), "lame_lambda"
    if group[0] == "orthotropic":
        o = m.orthotropic
        try:
            c = orthotropic(o.E, o.nu, o.G)
        except np.linalg.LinAlgError:
            raise MaterialError("orthotropic", "constants give a singular compliance (Poisson ratios too "
                                               "large for the moduli)") from None
        return check_positive_definite(c, "orthotropic"), "orthotropic"
    if group[0] == "transversely_isotropic":
        t = m.transversely_isotropic
        try:
            c = transversely_isotropic(t.E_plane, t.E_axis, t.nu_plane, t.nu_axis, t.G_axis)
        except np.linalg.LinAlgError:
            raise MaterialError("transversely_isotropic", "constants give a singular compliance (Poisson "
                                                          "ratios too large for the moduli)") from None
        return check_positive_definite(c, "transversely_isotropic"), "transversely_isotropic"
    return check_positive_definite(m.stiffness_voigt, "stiffness_voigt"), "stiffness_voigt"


def elastic_properties(m: Material, dim: int) -> ElasticProperties:
    """All elastic data of a material in the global axes of a ``dim``-dimensional scene (2 or 3).

    Exactly one of youngs_modulus + poisson_ratio | lame_lambda + lame_mu | orthotropic | transversely_isotropic
    | stiffness_voigt gives the stiffness in the material axes; ``elastic_rotation`` (see :func:`rotation`)
    turns it, and a tensor ``thermal_expansion``, into the global axes. Raises :class:`MaterialError` naming
    the key at fault; a material whose elastic keys hold expressions is read by
    :func:`varying_elastic_properties`."""
    varying = elastic_varying_keys(m)
    if varying:
        raise MaterialError(varying[0], "is an expression: read the material with varying_elastic_properties "
                                        "(sample points of its region)")
    C, source = _stiffness(m)
    check_declared(m, _OTHER_KEYS)
    alpha = expansion_tensor(m.thermal_expansion if m.thermal_expansion is not None else 0.0)
    if m.elastic_rotation is not None:
        try:
            R = rotation(m.elastic_rotation, dim)
        except (TypeError, ValueError) as exc:
            raise MaterialError("elastic_rotation", f": {exc}") from None
        C = rotate_voigt(C, R)
        alpha = R @ alpha @ R.T
        alpha = 0.5 * (alpha + alpha.T)
    C = np.array(check_positive_definite(C, source))
    alpha = np.array(alpha)
    beta = thermal_stress_tensor(C, alpha)
    for a in (C, alpha, beta):
        a.setflags(write=False)
    density = None if m.density is None else float(m.density)
    return ElasticProperties(C=C, alpha=alpha, beta=beta, T0=float(m.stress_free_temperature), density=density,
                             lam=float(m.rheology_lambda), eps_ref=float(m.reference_strain))


# ----------------------------------------------------------------------------- data that vary (expressions)

ELASTIC_KEYS = ("youngs_modulus", "poisson_ratio", "lame_lambda", "lame_mu", "orthotropic", "transversely_isotropic",
                "stiffness_voigt", "thermal_expansion", "elastic_rotation", "density", "stress_free_temperature",
                "rheology_lambda", "reference_strain")
"""The material keys the elastic reading depends on."""
_OTHER_KEYS = ("thermal_expansion", "elastic_rotation", "density", "rheology_lambda", "reference_strain",
               "stress_free_temperature")


def elastic_varying_keys(m: Material) -> list[str]:
    """The elastic keys of a material that hold an expression (also an entry of a list, a matrix or a nested
    table)."""
    return varying_keys(m, ELASTIC_KEYS)


@dataclass(frozen=True, eq=False)
class VaryingElastic:
    """What an :class:`ElasticProperties` of varying data carries besides its representative numbers: the
    ``material`` (its expressions, read by :func:`elastic_tensors`), the ``keys`` holding expressions, whether the
    material is ``isotropic`` everywhere (given by youngs_modulus + poisson_ratio or lame_lambda + lame_mu), the
    largest Poisson ratio (:attr:`ElasticProperties.max_poisson`) over the ``points`` sampled."""

    material: Material
    keys: tuple
    isotropic: bool
    max_poisson: float
    points: int


def elastic_structure(m: Material) -> tuple[str, ...]:
    """What of a material's elastic data can be checked without values: one group of stiffness keys, each key of it
    given, and every elastic key of the declared type (numbers in range, or expressions); the group. Raises
    :class:`MaterialError` naming the key."""
    group = elastic_group(m)
    check_declared(m, _OTHER_KEYS)
    return group


def varying_elastic_properties(m: Material, dim: int, samples) -> ElasticProperties:
    """The :class:`ElasticProperties` of a material whose elastic keys hold expressions (of x, y, z, r and, for
    youngs_modulus, T): the material is read as numbers (:func:`elastic_properties`, with every check) at each of
    ``samples`` (dicts of x, y, z, r, T: e.g. the vertices of its region); the result holds representative
    numbers (:attr:`ElasticProperties.varying`) and the material. Raises :class:`MaterialError` naming the key
    and the point where the data are refused, ValueError without samples."""
    group = elastic_structure(m)
    keys = elastic_varying_keys(m)
    functions: dict = {}
    best = None
    nu, t0, rho, n = -math.inf, math.inf, None, 0
    for values in samples:
        try:
            p = elastic_properties(material_at(m, keys, functions, values), dim)
        except (ArithmeticError, ValueError) as exc:
            with_t = isinstance(m.youngs_modulus, str) and "T" in expressions.uses(m.youngs_modulus)
            names = ("x", "y", "z")[:dim] + (("T",) if with_t else ())
            where = ", ".join(f"{k}={values[k] + 0.0:.6g}" for k in names)
            key = getattr(exc, "key", "") or keys[0]
            raise MaterialError(key, f"{getattr(exc, 'detail', str(exc))} at {where}") from None
        n += 1
        if best is None or float(np.max(np.diag(p.C))) > float(np.max(np.diag(best.C))):
            best = p
        nu, t0 = max(nu, p.max_poisson), min(t0, p.T0)
        rho = p.density if rho is None else max(rho, p.density) if p.density is not None else rho
    if best is None:
        raise ValueError("varying elastic data need at least one sample point")
    info = VaryingElastic(material=m, keys=tuple(keys), isotropic=group[0] in ("youngs_modulus", "lame_lambda"),
                          max_poisson=float(nu), points=n)
    return dataclasses.replace(best, T0=float(t0), density=rho, varying=info)


class ElasticTensors(NamedTuple):
    """The elastic data of a material as arrays whose entries are numbers or whatever ``scalar`` made of the
    expressions (:func:`elastic_tensors`): the 6x6 stiffness ``C`` (Pa) and the Voigt thermal stress vector ``b``
    (Pa/K) in the global axes, the stress-free temperature ``T0`` and the ``density`` (kg/m^3, None)."""

    C: np.ndarray
    b: np.ndarray
    T0: object
    density: object


def elastic_tensors(m: Material, dim: int, scalar) -> ElasticTensors:
    """The elastic data of a material (numbers and expressions) as object arrays: ``scalar(v)`` turns each value
    (a float, or an expression string) into an operand of +, -, *, / (a float: numbers; a CoefficientFunction in
    the forms). The same formulas as the number path: isotropic and Lame constants, the orthotropic compliance
    inverted by blocks (its normal 3x3 block by cofactors), the transversely isotropic constants through it, the
    Bond rotation and beta = C alpha; exact zeros stay 0.0 (no term is built for them). The checks (positive
    definite, symmetric, ranges) are those of the number path at sample points (:func:`varying_elastic_properties`
    and validation)."""
    group = elastic_group(m)
    if group[0] == "youngs_modulus":
        E, nu = scalar(m.youngs_modulus), scalar(m.poisson_ratio)
        C = _from_lame_terms(E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu)))
    elif group[0] == "lame_lambda":
        C = _from_lame_terms(scalar(m.lame_lambda), scalar(m.lame_mu))
    elif group[0] == "orthotropic":
        o = m.orthotropic
        C = _orthotropic_terms([scalar(v) for v in o.E], [scalar(v) for v in o.nu], [scalar(v) for v in o.G])
    elif group[0] == "transversely_isotropic":
        t = m.transversely_isotropic
        Ep, Ea, nup, nua, Ga = (scalar(v) for v in (t.E_plane, t.E_axis, t.nu_plane, t.nu_axis, t.G_axis))
        nu13 = nua * Ep / Ea
        C = _orthotropic_terms([Ep, Ep, Ea], [nup, nu13, nu13], [Ep / (2.0 * (1.0 + nup)), Ga, Ga])
    else:
        C = np.array([[scalar(v) for v in row] for row in m.stiffness_voigt], dtype=object)
    a = m.thermal_expansion if m.thermal_expansion is not None else 0.0
    if isinstance(a, (list, tuple)):
        alpha = np.array([[scalar(v) for v in row] for row in a], dtype=object)
    else:
        alpha = np.full((3, 3), 0.0, dtype=object)
        for i in range(3):
            alpha[i, i] = scalar(a)
    if m.elastic_rotation is not None:
        R = rotation(m.elastic_rotation, dim)
        M = bond_matrix(R)
        C = _dot(_dot(M, C), M.T)
        alpha = _dot(_dot(R, alpha), R.T)
    strain = [alpha[i, j] if i == j else _add(alpha[i, j], alpha[j, i]) for i, j in _PAIRS]
    b = _dot(C, np.array(strain, dtype=object))
    density = None if m.density is None else scalar(m.density)
    return ElasticTensors(C=C, b=b, T0=scalar(m.stress_free_temperature), density=density)


class ReducedTensors(NamedTuple):
    """The elastic data of a model's reduced Voigt strain vector (:func:`reduce_tensors`): stiffness ``D`` (Pa),
    thermal vector ``b`` (Pa/K), and for plane strain the sigma_zz row and its thermal coefficient ``zz``."""

    D: np.ndarray
    b: np.ndarray
    zz: tuple | None


def reduce_tensors(model: str, C: np.ndarray, b: np.ndarray) -> ReducedTensors:
    """:func:`plane_strain`, :func:`plane_stress` (its 3x3 out-of-plane block inverted by cofactors) and the
    axisymmetric rows of object arrays (:func:`elastic_tensors`); "3d" keeps them. The axisymmetric torsion
    check is the number path's, at the sample points. Arrays whose entries are all numbers come back as float
    arrays."""
    p, o = _IN_PLANE, _OUT_OF_PLANE
    zz = None
    if model == "3d":
        D, bred = C, b
    elif model == "plane_strain":
        D, bred = C[np.ix_(p, p)], b[p]
        zz = (tidy(C[2, p]), tidy(np.array([b[2]], dtype=object))[0])
    elif model == "plane_stress":
        inv = _inverse3(C[np.ix_(o, o)])
        X = _dot(inv, C[np.ix_(o, p)])
        D = np.array([[_add(C[i, j], -1.0 * _dot(C[i, o], X[:, k])) for k, j in enumerate(p)] for i in p],
                     dtype=object)
        y = _dot(inv, b[o])
        bred = np.array([_add(b[i], -1.0 * _dot(C[i, o], y)) for i in p], dtype=object)
    else:
        a = _AXISYMMETRIC
        D, bred = C[np.ix_(a, a)], b[a]
    return ReducedTensors(tidy(D), tidy(bred), zz)


class DeviatoricSplit(NamedTuple):
    """The data of the mixed displacement-pressure formulation of one region (:func:`deviatoric_split`)."""

    K: object
    mu: object
    Ddev: np.ndarray
    bdev: np.ndarray
    bm: object
    zz: tuple | None


def deviatoric_split(C: np.ndarray, b: np.ndarray, D: np.ndarray, bred: np.ndarray, zz, trace) -> DeviatoricSplit:
    """Bulk modulus K = (C11 + 2 C12)/3 and shear modulus mu = C66 of an isotropic 6x6 stiffness C (Pa), the mean
    thermal stress b_m = tr(beta)/3 (Pa/K) of the Voigt thermal vector b, and the deviatoric reduced data
    Ddev = D - K m m^T, bdev = bred - b_m m and the sigma_zz row (row - K m, b_zz - b_m) of the reduced D, bred, zz
    (``trace`` m: the model's trace vector); entries numbers or operands (object arrays, :func:`elastic_tensors`)."""
    m = [float(v) for v in trace]
    K = _add(C[0, 0], 2.0 * C[0, 1]) / 3.0
    bm = _add(_add(b[0], b[1]), b[2]) / 3.0
    n = len(m)
    Ddev = np.array([[_add(D[i, j], -1.0 * _mul(K, m[i] * m[j])) for j in range(n)] for i in range(n)], dtype=object)
    bdev = np.array([_add(bred[i], -1.0 * _mul(bm, m[i])) for i in range(n)], dtype=object)
    out_zz = None
    if zz is not None:
        row, bz = zz
        out_zz = (tidy(np.array([_add(row[j], -1.0 * _mul(K, m[j])) for j in range(n)], dtype=object)),
                  _add(bz, -1.0 * bm))
    return DeviatoricSplit(K=K, mu=C[5, 5], Ddev=tidy(Ddev), bdev=tidy(bdev), bm=bm, zz=out_zz)


def tidy(a: np.ndarray) -> np.ndarray:
    """An object array of numbers as a float array; other arrays unchanged."""
    a = np.asarray(a, dtype=object) if not isinstance(a, np.ndarray) else a
    if a.dtype == object and all(isinstance(v, (int, float)) for v in a.flat):
        return np.array(a, dtype=float)
    return a


def _is_zero(v) -> bool:
    return isinstance(v, (int, float)) and v == 0.0


def _mul(a, b):
    if _is_zero(a) or _is_zero(b):
        return 0.0
    if isinstance(a, (int, float)) and a == 1.0:
        return b
    if isinstance(b, (int, float)) and b == 1.0:
        return a
    return a * b


def _add(a, b):
    if _is_zero(a):
        return b
    return a if _is_zero(b) else a + b


def _dot(A, B):
    """A @ B (matrix-matrix, matrix-vector or vector-vector) of object or float arrays, with exact zeros skipped."""
    A, B = np.asarray(A, dtype=object), np.asarray(B, dtype=object)
    if A.ndim == 1 and B.ndim == 1:
        out = 0.0
        for a, b in zip(A, B):
            out = _add(out, _mul(a, b))
        return out
    if B.ndim == 1:
        return np.array([_dot(row, B) for row in A], dtype=object)
    return np.array([[_dot(row, B[:, j]) for j in range(B.shape[1])] for row in A], dtype=object)


def _inverse3(a) -> np.ndarray:
    """The inverse of a 3x3 object array by cofactors: inv[i, j] = cof[j, i] / det."""
    cof = [[_add(_mul(a[(i + 1) % 3, (j + 1) % 3], a[(i + 2) % 3, (j + 2) % 3]),
                 -1.0 * _mul(a[(i + 1) % 3, (j + 2) % 3], a[(i + 2) % 3, (j + 1) % 3])) for j in range(3)]
           for i in range(3)]
    det = _dot(np.array([a[0, j] for j in range(3)], dtype=object), np.array(cof[0], dtype=object))
    return np.array([[0.0 if _is_zero(cof[j][i]) else cof[j][i] / det for j in range(3)] for i in range(3)],
                    dtype=object)


def _from_lame_terms(lam, mu) -> np.ndarray:
    """:func:`from_lame` of operands (object array)."""
    c = np.full((6, 6), 0.0, dtype=object)
    for i in range(3):
        for j in range(3):
            c[i, j] = lam + 2.0 * mu if i == j else lam
        c[3 + i, 3 + i] = mu
    return c


def _orthotropic_terms(E, nu, G) -> np.ndarray:
    """:func:`orthotropic` of operands: the normal 3x3 block of the compliance inverted by cofactors, the shear
    moduli on the diagonal (object array)."""
    (E1, E2, E3), (nu12, nu13, nu23) = E, nu
    s = np.array([[1.0 / E1, -1.0 * nu12 / E1, -1.0 * nu13 / E1],
                  [-1.0 * nu12 / E1, 1.0 / E2, -1.0 * nu23 / E2],
                  [-1.0 * nu13 / E1, -1.0 * nu23 / E2, 1.0 / E3]], dtype=object)
    c = np.full((6, 6), 0.0, dtype=object)
    c[:3, :3] = _inverse3(s)
    c[3, 3], c[4, 4], c[5, 5] = G[2], G[1], G[0]
    return c
