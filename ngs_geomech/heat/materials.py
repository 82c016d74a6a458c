"""Material data in numbers: conductivity tensors and heat capacities from scene materials (numpy only).

Problem (P) of the seed allows an anisotropic conductivity kappa_ij per body (2.17); it must be
symmetric positive definite. A temperature-dependent conductivity kappa_ij(T) = kappa_ij f(T) with
f(T) = 1 + b (T - T_ref) is handled through the Kirchhoff transform Theta(T) = int_{T_ref}^T f(s) ds
(seed, before (2.39)), so that the flux is -kappa_ij dTheta/dx_j.

A conductivity (the scalar, the tensor's entries, the principal values), a heat capacity rho c, a density and a
specific heat may also be expressions of x, y, z, r and (not the density) of T
(:func:`~ngs_geomech.scene.schema.material_value`): the tensor then holds :class:`~ngs_geomech.scene.schema.Expression`
entries, and the checks that need values (positive definite, positive) are made by validation at sample points
(:mod:`ngs_geomech.validation.material_values`, which calls these same functions on the material's values at a
point) and by the heat solver at the mesh vertices (T-dependent data).

The ranges of single keys (a positive heat capacity, a latent heat >= 0, ...) are declared with the keys
(:class:`~ngs_geomech.scene.model.Material`) and checked from there (:func:`check_declared`); the rules that join
several keys or the entries of a tensor (one of two ways to give a datum, a positive definite conductivity) are
checked here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MaterialError
from ..scene import expressions
from ..scene.model import Material
from ..scene.schema import Expression, first_problem, material_at


def check_declared(m: Material, keys: tuple[str, ...]) -> None:
    """Raise :class:`~ngs_geomech.errors.MaterialError` for the first of the material's ``keys`` whose value does
    not meet its declaration (type and range, :class:`~ngs_geomech.scene.model.Material`)."""
    problem = first_problem(m, keys)
    if problem is not None:
        raise MaterialError(problem.item, problem.message)


@dataclass(frozen=True)
class ThermalProperties:
    """Thermal data of one region: ``kappa`` (dim x dim, W/(m K)) at T_ref, ``rho_c`` (J/(m^3 K),
    None when not given), ``b`` (1/K) and ``t_ref`` of f(T) = 1 + b (T - T_ref).

    ``kappa`` is a float array for numbers; an object array of floats and expression strings (of x, y, z, r, T)
    when an entry varies. ``rho_c`` is a float or an expression string."""

    kappa: np.ndarray
    rho_c: float | str | None
    b: float = 0.0
    t_ref: float = 0.0

    @property
    def varying(self) -> bool:
        """Whether a conductivity entry or the heat capacity is an expression."""
        return self.kappa.dtype == object or isinstance(self.rho_c, str)

    @property
    def conductivity_uses_temperature(self) -> bool:
        return self.kappa.dtype == object and any(uses_temperature(e) for e in self.kappa.flat)

    @property
    def capacity_uses_temperature(self) -> bool:
        return uses_temperature(self.rho_c)

    @property
    def nonlinear(self) -> bool:
        """The law k(T) = k (1 + b (T - T_ref)) or a conductivity or heat capacity that depends on T."""
        return self.b != 0.0 or self.conductivity_uses_temperature or self.capacity_uses_temperature


def uses_temperature(value) -> bool:
    """Whether a material value is an expression of the temperature T."""
    return isinstance(value, str) and expressions.TEMPERATURE in expressions.uses(value)


def is_expression(value) -> bool:
    return isinstance(value, str)


def _combination(terms: list[tuple[float, object]]):
    """The sum c_k v_k of numbers and expressions: a float when every v_k with c_k != 0 is a number, else an
    expression string (ValueError when it is too large for an expression)."""
    terms = [(c, v) for c, v in terms if c != 0.0]
    if all(not is_expression(v) for _, v in terms):
        return float(sum(c * v for c, v in terms))
    text = " + ".join(f"({v})" if c == 1.0 else f"{c!r}*({v})" for c, v in terms)
    problems = expressions.check(text, expressions.ALL_VARIABLES)
    if problems:
        raise ValueError(f"the rotated tensor of the principal values is too large an expression ({problems[0]})")
    return Expression(text)


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
    """The conductivity tensor of a material; raises ValueError naming the key at fault (a
    :class:`~ngs_geomech.errors.MaterialError` for a value outside its declared range)."""
    given = [k for k in ("conductivity", "conductivity_principal") if getattr(m, k) is not None]
    if len(given) != 1:
        raise ValueError("give exactly one of 'conductivity' or 'conductivity_principal'"
                         + (" (both given)" if len(given) == 2 else " (none given)"))
    check_declared(m, ("conductivity", "conductivity_principal", "conductivity_angle"))
    if m.conductivity is not None:
        if m.conductivity_angle is not None:
            raise ValueError("'conductivity_angle' goes with 'conductivity_principal', not 'conductivity'")
        k = m.conductivity
        if is_expression(k):
            return _diagonal(k, dim)
        if isinstance(k, (int, float)):
            kappa = float(k) * np.eye(dim)
        else:
            kappa = _tensor(k, dim)
            if kappa.dtype == object:
                return kappa
    else:
        p = list(m.conductivity_principal)
        if len(p) != dim:
            raise ValueError(f"'conductivity_principal' needs {dim} values, got {len(p)}")
        rot = rotation_matrix(m.conductivity_angle or 0.0, dim)
        if any(is_expression(v) for v in p):
            return _rotated(rot, p)
        kappa = rot @ np.diag(np.array(p, dtype=float)) @ rot.T
    ev = np.linalg.eigvalsh(kappa)
    if ev.min() <= 0:
        raise ValueError(f"conductivity {kappa.tolist()} is not positive definite (eigenvalues {ev.tolist()})")
    return kappa


def _diagonal(k: str, dim: int) -> np.ndarray:
    """The tensor k I of an expression k (object array)."""
    kappa = np.zeros((dim, dim), dtype=object)
    for i in range(dim):
        kappa[i, i] = k
    return kappa


def _tensor(k: list, dim: int) -> np.ndarray:
    """The 'conductivity' matrix: a float array, or an object array when an entry is an expression; ValueError when
    it is not dim x dim or not symmetric (expressions: the two entries the same text)."""
    if len(k) != dim or any(not isinstance(row, list) or len(row) != dim for row in k):
        shape = (len(k), len(k[0]) if k and isinstance(k[0], list) else 0)
        raise ValueError(f"'conductivity' must be {dim}x{dim} in this scene, got shape {shape}")
    if not any(is_expression(v) for row in k for v in row):
        kappa = np.array(k, dtype=float)
        if not np.allclose(kappa, kappa.T, rtol=1e-12, atol=0):
            raise ValueError(f"'conductivity' tensor {kappa.tolist()} is not symmetric")
        return kappa
    kappa = np.array([[v if is_expression(v) else float(v) for v in row] for row in k], dtype=object)
    for i in range(dim):
        for j in range(i):
            a, b = kappa[i, j], kappa[j, i]
            same = "".join(a.split()) == "".join(b.split()) if is_expression(a) and is_expression(b) else \
                not is_expression(a) and not is_expression(b) and np.isclose(a, b, rtol=1e-12, atol=0)
            if not same:
                raise ValueError(f"'conductivity' tensor is not symmetric: entries [{i}][{j}] = {a!r} and "
                                 f"[{j}][{i}] = {b!r} differ (give the same number or expression)")
    return kappa


def _rotated(rot: np.ndarray, p: list) -> np.ndarray:
    """R diag(p) R^T of principal values of which some are expressions (object array)."""
    dim = len(p)
    kappa = np.zeros((dim, dim), dtype=object)
    for i in range(dim):
        for j in range(dim):
            kappa[i, j] = _combination([(float(rot[i, k] * rot[j, k]), p[k]) for k in range(dim)])
    return kappa


def volumetric_heat_capacity(m: Material) -> float | str | None:
    """rho*c in J/(m^3 K), from 'rho_c' or 'density' * 'specific_heat'; None when not given.

    'density' alone is allowed (gravity needs it); 'specific_heat' needs 'density'. Each is positive (declared).
    An expression (of x, y, z, r, T) is returned as such: rho_c itself, or the product ``(density)*(specific_heat)``.
    """
    if m.rho_c is not None:
        if m.specific_heat is not None:
            raise ValueError("give either 'rho_c' or 'density' and 'specific_heat', not both")
        check_declared(m, ("rho_c",))
        return m.rho_c if is_expression(m.rho_c) else float(m.rho_c)
    if m.specific_heat is not None:
        if m.density is None:
            raise ValueError("'specific_heat' needs 'density'")
        check_declared(m, ("density", "specific_heat"))
        if is_expression(m.density) or is_expression(m.specific_heat):
            return _combination_product(m.density, m.specific_heat)
        return float(m.density * m.specific_heat)
    return None


def _combination_product(a, b) -> str:
    """The expression ``(a)*(b)`` of a density and a specific heat; ValueError when it is too large."""
    text = f"({a})*({b})"
    problems = expressions.check(text, expressions.ALL_VARIABLES)
    if problems:
        raise ValueError(f"density * specific_heat is too large an expression ({problems[0]})")
    return Expression(text)


def thermal_properties(m: Material, dim: int) -> ThermalProperties:
    """All thermal data of a material (raises ValueError naming the key at fault)."""
    return ThermalProperties(kappa=conductivity_tensor(m, dim), rho_c=volumetric_heat_capacity(m),
                             b=m.conductivity_temperature_coefficient, t_ref=m.reference_temperature)


VARYING_KEYS = ("conductivity", "conductivity_principal", "rho_c", "density", "specific_heat")
"""The thermal keys that may be expressions (:func:`~ngs_geomech.scene.schema.material_value`)."""


def expression_keys(m: Material) -> list[str]:
    """The thermal keys of a material given as expressions (also an entry of a tensor or a list)."""
    def varies(v) -> bool:
        return is_expression(v) or isinstance(v, (list, tuple)) and any(varies(e) for e in v)
    return [k for k in VARYING_KEYS if varies(getattr(m, k))]


# -- phase change (the Stefan problem, seed (2.46)-(2.51)) -------------------------------------------------------
PHASE_CHANGE_KEYS = ("latent_heat", "latent_heat_volumetric", "rho_c_liquid", "specific_heat_liquid",
                     "conductivity_liquid", "conductivity_liquid_principal")


@dataclass(frozen=True)
class PhaseChangeProperties:
    """The phase change of one material: ``temperature`` Theta_R (degC or K), ``latent_heat`` L (volumetric,
    J/m^3), ``rho_c_solid`` and ``rho_c_liquid`` (J/(m^3 K)), ``conductivity_solid`` and ``conductivity_liquid``
    (W/(m K)): the phases' tensors are k_s K_hat and k_l K_hat with K_hat = ``anisotropy`` (None: isotropic;
    :func:`phase_conductivities`)."""

    temperature: float
    latent_heat: float
    rho_c_solid: float
    rho_c_liquid: float
    conductivity_solid: float
    conductivity_liquid: float
    anisotropy: np.ndarray | None = None


def has_phase_change(m: Material) -> bool:
    return m.phase_change_temperature is not None


def conductivity_shape(kappa: np.ndarray) -> tuple[float, np.ndarray | None]:
    """(k, K_hat) with kappa = k K_hat for a conductivity tensor of numbers (W/(m K)): k = kappa[0][0] and
    K_hat = None (the identity) when kappa is k I, else k the largest principal value and K_hat = kappa / k
    (dimensionless, largest principal value 1). The Stefan forms take k as the scalar of the Kirchhoff variable
    and K_hat as the shape of the region's stiffness."""
    k = float(kappa[0, 0])
    dim = kappa.shape[0]
    if np.allclose(kappa, k * np.eye(dim), rtol=1e-12, atol=1e-12 * abs(k)):
        return k, None
    k = float(np.linalg.eigvalsh(kappa).max())
    return k, kappa / k


def liquid_conductivity_tensor(m: Material, dim: int) -> np.ndarray:
    """The liquid phase's conductivity tensor (W/(m K)) of a phase-change material: ``conductivity_liquid`` (a
    number k_l, i.e. k_l I, or a symmetric positive definite matrix) or ``conductivity_liquid_principal`` (in the
    axes of ``conductivity_angle``, the solid's); MaterialError naming the key at fault."""
    if m.conductivity_liquid is not None and m.conductivity_liquid_principal is not None:
        raise MaterialError("conductivity_liquid_principal", "give either conductivity_liquid or "
                            "conductivity_liquid_principal, not both")
    if m.conductivity_liquid_principal is not None:
        p = [float(v) for v in m.conductivity_liquid_principal]
        if len(p) != dim:
            raise MaterialError("conductivity_liquid_principal", f"needs {dim} values, got {len(p)}")
        rot = rotation_matrix(m.conductivity_angle or 0.0, dim)
        return rot @ np.diag(p) @ rot.T
    k = m.conductivity_liquid
    if isinstance(k, (int, float)):
        return float(k) * np.eye(dim)
    try:
        kappa = _tensor(k, dim)
    except ValueError as exc:
        raise MaterialError("conductivity_liquid", str(exc).replace("'conductivity'", "the matrix")) from None
    ev = np.linalg.eigvalsh(kappa)
    if ev.min() <= 0:
        raise MaterialError("conductivity_liquid", f"{kappa.tolist()} is not positive definite (eigenvalues "
                            f"{ev.tolist()})")
    return kappa


def phase_conductivities(m: Material, dim: int) -> tuple[float, float, np.ndarray | None]:
    """(k_s, k_l, K_hat) of a phase-change material whose solid and liquid conductivity tensors are k_s K_hat and
    k_l K_hat (:func:`conductivity_shape`; K_hat None: isotropic). The Kirchhoff variable of the Stefan forms
    needs the two tensors proportional (the phases scale one anisotropy); MaterialError naming the liquid's key
    when they are not, ValueError (the solid's keys) when the solid's tensor is invalid or an expression."""
    kappa = conductivity_tensor(m, dim)
    if kappa.dtype == object:
        raise ValueError("an expression: the Stefan (phase change) solver of a scene with phase change takes "
                         "constant material data in every region (a number per phase)")
    k_s, shape = conductivity_shape(kappa)
    if shape is None and isinstance(m.conductivity_liquid, (int, float)):
        return k_s, float(m.conductivity_liquid), None
    liquid = liquid_conductivity_tensor(m, dim)
    key = "conductivity_liquid" if m.conductivity_liquid is not None else "conductivity_liquid_principal"
    ratio = float(np.trace(liquid) / np.trace(kappa))
    if not np.allclose(liquid, ratio * kappa, rtol=0, atol=1e-10 * float(np.abs(liquid).max())):
        solid_key = "conductivity_principal" if m.conductivity_principal is not None else "conductivity"
        raise MaterialError(key, f"the liquid's tensor {np.round(liquid, 12).tolist()} is not proportional to the "
                            f"solid's ({solid_key}: {np.round(kappa, 12).tolist()}): the Stefan solver takes "
                            "anisotropic conductivities when both phases scale one anisotropy (liquid = c x solid, "
                            "its Kirchhoff variable is per region); give the liquid's tensor as a multiple of the "
                            "solid's (conductivity_liquid_principal proportional to conductivity_principal, same "
                            "conductivity_angle)")
    k_l, _ = conductivity_shape(liquid)
    return k_s, k_l, shape


CONDUCTIVITY_KEYS = ("conductivity", "conductivity_principal", "conductivity_liquid", "conductivity_liquid_principal")
"""The keys of the phases' conductivity tensors (the keys that may vary in x, y, z in a Stefan scene)."""
RATIO_RTOL = 1e-9
"""Relative tolerance of a constant ratio k_l(x) / k_s(x) over a region (round-off of the two expressions)."""


@dataclass(frozen=True)
class ConductivityField:
    """A conductivity that varies in x, y, z in a region of a Stefan scene: the tensors are k_s G(x) (solid, or the
    only phase) and k_l G(x) (liquid; None without phase change), ``k_s`` the largest principal value of the solid's
    tensor over the points it was read at (W/(m K)) and ``shape`` G(x) the solid's tensor divided by it (dim x dim
    nested tuples of floats and expression strings of x, y, z, r; dimensionless)."""

    k_s: float
    k_l: float | None
    shape: tuple


def conductivity_field(m: Material, dim: int, points, where: str = "") -> ConductivityField:
    """The :class:`ConductivityField` of a material whose conductivity keys (:data:`CONDUCTIVITY_KEYS`) hold
    expressions of x, y, z, r, read at ``points`` (an iterable of (x, y, z)): each point's tensors are read as
    numbers (:func:`conductivity_tensor`, :func:`phase_conductivities`: positive definite, the liquid's
    proportional to the solid's). With a phase change the ratio k_l(x) / k_s(x) must be one constant over the points
    (the Kirchhoff variable of the Stefan forms is per region): MaterialError naming the liquid's key and the two
    points where it differs, or the key at fault at a point (``where``, e.g. " of region 'a'", follows the
    points in the messages)."""
    keys = [k for k in CONDUCTIVITY_KEYS if _holds_expression(getattr(m, k))]
    functions: dict = {}
    k_max, first = 0.0, None
    for p in points:
        values = {"x": float(p[0]), "y": float(p[1]), "z": float(p[2]), "r": float(p[0]), "T": 0.0}
        point = ", ".join(f"{n}={values[n] + 0.0:.6g}" for n in ("x", "y", "z")[:dim])
        at = point + where
        try:
            mp = material_at(m, keys, functions, values)
            kappa = conductivity_tensor(mp, dim)
            k, _ = conductivity_shape(kappa)
            ratio = None
            if has_phase_change(m):
                k_s, k_l, _ = phase_conductivities(mp, dim)
                ratio = k_l / k_s
        except MaterialError as exc:
            raise MaterialError(exc.key, f"{exc.detail.removeprefix(': ')} at {at}") from None
        except (ArithmeticError, ValueError) as exc:
            raise MaterialError(keys[0], f"{exc} at {at}") from None
        k_max = max(k_max, k)
        if first is None:
            first = (ratio, point)
        elif ratio is not None and not math.isclose(ratio, first[0], rel_tol=RATIO_RTOL):
            key = "conductivity_liquid" if m.conductivity_liquid is not None else "conductivity_liquid_principal"
            raise MaterialError(key, f"is {ratio:.12g} times the solid's conductivity at {at} but {first[0]:.12g} "
                                f"times at {first[1]}: the Stefan solver takes conductivities that vary "
                                "in x, y, z when both phases share the variation, k_l(x) = c k_s(x) with one constant "
                                "c per region (its Kirchhoff variable is per region); give the liquid's conductivity "
                                "as a constant multiple of the solid's expression")
    if first is None:
        raise ValueError("conductivity_field: no points to read the conductivity at")
    solid = conductivity_tensor(m, dim)
    shape = tuple(tuple(_scaled(v, 1.0 / k_max) for v in row) for row in np.asarray(solid, dtype=object))
    return ConductivityField(k_s=k_max, k_l=None if first[0] is None else first[0] * k_max, shape=shape)


def _holds_expression(v) -> bool:
    return is_expression(v) or isinstance(v, (list, tuple)) and any(_holds_expression(e) for e in v)


def _scaled(v, factor: float):
    """The product factor * v of a number or an expression (an expression string)."""
    return Expression(f"({v})*{factor!r}") if is_expression(v) else float(v) * factor


def phase_change_problems(m: Material) -> list[tuple[str, str]]:
    """Every problem of how a material's phase-change keys go together as (key, message); empty when they are
    consistent (also when the material has no phase change and sets none of them). The range of each key is
    declared with it (:class:`~ngs_geomech.scene.model.Material`; :func:`check_declared`)."""
    out: list[tuple[str, str]] = []
    if not has_phase_change(m):
        for key in PHASE_CHANGE_KEYS:
            if getattr(m, key) is not None:
                out.append((key, "applies to a phase-change material: set phase_change_temperature (degC or K)"))
        return out
    per_kg, per_m3 = m.latent_heat, m.latent_heat_volumetric
    if per_kg is not None and per_m3 is not None:
        out.append(("latent_heat", "give either latent_heat (J/kg, with density) or latent_heat_volumetric "
                                   "(J/m^3), not both"))
    elif per_kg is None and per_m3 is None:
        out.append(("latent_heat", "a phase change needs latent_heat (J/kg, with density) or "
                                   "latent_heat_volumetric (J/m^3)"))
    if per_kg is not None and per_m3 is None and m.density is None:
        out.append(("density", "latent_heat is per kg (J/kg): give the density (kg/m^3), or give "
                               "latent_heat_volumetric (J/m^3) instead"))
    c_l, c_l_kg = m.rho_c_liquid, m.specific_heat_liquid
    if c_l is not None and c_l_kg is not None:
        out.append(("rho_c_liquid", "give either rho_c_liquid (J/(m^3 K)) or specific_heat_liquid (J/(kg K), with "
                                    "density), not both"))
    elif c_l is None and c_l_kg is None:
        out.append(("rho_c_liquid", "a phase change needs the liquid's heat capacity: rho_c_liquid (J/(m^3 K)) or "
                                    "specific_heat_liquid (J/(kg K), with density)"))
    if c_l_kg is not None and c_l is None and m.density is None:
        out.append(("density", "specific_heat_liquid is per kg: give the density (kg/m^3), or rho_c_liquid"))
    if m.conductivity_liquid is None and m.conductivity_liquid_principal is None:
        out.append(("conductivity_liquid", "a phase change needs the liquid's conductivity (W/(m K)): "
                                           "conductivity_liquid or conductivity_liquid_principal"))
    elif m.conductivity_liquid is not None and m.conductivity_liquid_principal is not None:
        out.append(("conductivity_liquid_principal", "give either conductivity_liquid or "
                                                     "conductivity_liquid_principal, not both"))
    return out


def phase_change_properties(m: Material, dim: int, field: ConductivityField | None = None
                            ) -> PhaseChangeProperties | None:
    """The phase change of a material (None without phase_change_temperature); ValueError naming the key at
    fault when a key is outside its declared range or the keys are inconsistent (see :func:`phase_change_problems`).
    ``field``: the conductivity read at points when it varies in x, y, z (:func:`conductivity_field`; its k_s, k_l
    are taken, ``anisotropy`` is then None)."""
    if not has_phase_change(m):
        return None
    check_declared(m, ("phase_change_temperature",) + PHASE_CHANGE_KEYS)
    problems = phase_change_problems(m)
    if problems:
        raise ValueError("; ".join(f"{k}: {msg}" for k, msg in problems))
    rho_c = volumetric_heat_capacity(m)
    if rho_c is None:
        raise ValueError("rho_c: a phase change needs the solid's rho_c (or density and specific_heat)")
    latent = m.latent_heat_volumetric if m.latent_heat_volumetric is not None else m.density * m.latent_heat
    c_l = m.rho_c_liquid if m.rho_c_liquid is not None else m.density * m.specific_heat_liquid
    k_s, k_l, shape = phase_conductivities(m, dim) if field is None else (field.k_s, field.k_l, None)
    return PhaseChangeProperties(temperature=float(m.phase_change_temperature), latent_heat=float(latent),
                                 rho_c_solid=rho_c, rho_c_liquid=float(c_l), conductivity_solid=k_s,
                                 conductivity_liquid=k_l, anisotropy=shape)
