"""Material values that vary (expressions of x, y, z, r and T, :func:`~ngs_geomech.scene.schema.material_value`),
checked before meshing.

Each material is taken at sample points of its region (the points of :mod:`.expression_values`: vertices, points
along the edges, a grid inside) and, where a value depends on T, at the temperatures the region surely takes
(:func:`temperature_samples`); there its values are numbers, and the material is read by the same functions that
read numbers: the declared type and range of each key (:func:`~ngs_geomech.scene.schema.first_problem`) and the
rules of the physics switched on (:func:`pointwise_rules`: a symmetric positive definite conductivity, a positive
heat capacity, ...). The first point where a value is not finite or is refused is reported under the key, with the
region, the point (and T) and the expression. The cost is bounded: at most :data:`BUDGET` expression-node
evaluations per material (the points are thinned evenly beyond it).

A physics that takes material values adds its reading to :func:`pointwise_rules`; nothing else is needed for its
keys to be sampled.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable

import numpy as np

from ..errors import MaterialError, Problem
from ..geometry.assemble import GeometryModel, scene_dim
from ..heat.materials import (
    CONDUCTIVITY_KEYS,
    conductivity_field,
    conductivity_tensor,
    has_phase_change,
    volumetric_heat_capacity,
)
from ..mechanics.materials import ELASTIC_KEYS, axisymmetric, elastic_properties
from ..scene import expressions
from ..scene.model import Material, Scene
from ..scene.schema import first_problem, holds_expression
from ..scene.schema import material_at as schema_material_at
from ..scene.schema import varying_keys as schema_varying_keys
from ..scene.units import KELVIN
from .expression_values import sample_points, value_range

BUDGET = 300_000
"""Most expression-node evaluations per material (points x temperatures x nodes)."""
TEMPERATURES = 3
"""Temperatures sampled over the range a region takes (its ends and the middle)."""

Rule = tuple[tuple[str, ...], Callable[[Material, int], object]]
"""(the keys a reading depends on, the reading: raises MaterialError naming a key or ValueError)."""


def pointwise_rules(scene: Scene) -> list[Rule]:
    """The readings of a material that must succeed at every sample point, by the physics switched on."""
    rules: list[Rule] = []
    if scene.physics.thermal is not None:
        rules.append((("conductivity", "conductivity_principal", "conductivity_angle"), conductivity_tensor))
        rules.append((("rho_c", "density", "specific_heat"), lambda m, dim: volumetric_heat_capacity(m)))
    if scene.physics.mechanics is not None:
        rules.append((ELASTIC_KEYS, _elastic_reader(scene.scene.dimension == "axisymmetric")))
        rules.append((("stress_free_temperature",), _reference_temperature_reader(scene)))
    return rules


def _reference_temperature_reader(scene: Scene) -> Callable[[Material, int], object]:
    """The stress-free temperature at or above absolute zero in the scene's unit and, with physics.coupling, above
    0 K (the deformation heating is proportional to it: :mod:`ngs_geomech.coupling.problem`)."""
    kelvin = KELVIN if scene.scene.temperature_unit == "C" else 0.0
    coupled = scene.physics.coupling != "none"

    def read(m: Material, dim: int):
        t0 = float(m.stress_free_temperature)
        unit = "degC" if kelvin else "K"
        if t0 + kelvin < 0 or coupled and not t0 + kelvin > 0:
            why = (f"the deformation heating of physics.coupling = {scene.physics.coupling!r} needs an absolute "
                   "reference temperature > 0 K" if coupled else "below absolute zero")
            raise MaterialError("stress_free_temperature", f"is {t0:g} {unit} ({t0 + kelvin:g} K): {why}")
        return t0
    return read


def _elastic_reader(axisymmetric_scene: bool) -> Callable[[Material, int], object]:
    """The mechanics' reading of a material at a point: :func:`elastic_properties` (a positive definite stiffness,
    a positive bulk modulus, ...) and, in an axisymmetric scene, no coupling to the torsional shears."""
    def read(m: Material, dim: int):
        props = elastic_properties(m, dim)
        if axisymmetric_scene:
            axisymmetric(props.C, props.beta)
        return props
    return read


def varying_keys(m: Material) -> list[str]:
    """The keys of a material whose value holds an expression (also an entry of a list, a matrix or a nested
    table such as ``orthotropic``)."""
    return schema_varying_keys(m)


def material_at(m: Material, keys: list[str], functions: dict, values: dict) -> Material:
    """The material with the expressions of ``keys`` replaced by their values at ``values`` (x, y, z, r, T);
    ``functions`` caches the compiled expressions (:func:`ngs_geomech.scene.schema.material_at`)."""
    return schema_material_at(m, keys, functions, values)


def temperature_samples(scene: Scene, geo: GeometryModel, name: str) -> list[float]:
    """Temperatures region ``name`` surely takes: the range of its initial temperature (transient scenes) and of
    the prescribed temperatures on its block's boundaries, sampled at :data:`TEMPERATURES` points; without such data
    the range of every prescribed temperature of the scene; without any, the material's reference_temperature."""
    def ranges(data):
        out = []
        for value, target in data:
            r = value_range(geo, value, target)
            if r is not None:
                out += list(r)
        return out
    dirichlet = [(n, bc.temperature) for n, bc in scene.boundary_conditions.items() if bc.temperature is not None]
    own = [(v, ("boundary", (n,))) for n, v in dirichlet if n in geo.block_boundaries.get(name, ())]
    if scene.physics.thermal == "transient":
        own.append((scene.initial.regions.get(name, scene.initial.temperature), ("region", (name,))))
    found = ranges(own) or ranges([(v, ("boundary", (n,))) for n, v in dirichlet if n in geo.boundaries])
    if not found:
        return [float(scene.materials[name].reference_temperature)]
    lo, hi = min(found), max(found)
    return sorted(set(np.linspace(lo, hi, TEMPERATURES).tolist())) if hi > lo else [lo]


def check_material_values(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Append a Problem for the first sample point of each material where a varying value is not finite, is out of
    its declared range or is refused by a rule of :func:`pointwise_rules` (materials with a problem already are
    left out)."""
    dim = scene_dim(scene)
    rules = pointwise_rules(scene)
    named = {p.item for p in problems}
    for name, m in scene.materials.items():
        keys = varying_keys(m)
        if not keys or name not in geo.regions or any(i == f"materials.{name}" or i.startswith(f"materials.{name}.")
                                                         for i in named):
            continue                    # a material with a problem already is reported once
        problem = _first_failure(scene, geo, name, m, keys, rules, dim)
        if problem is not None:
            problems.append(problem)


def _first_failure(scene, geo, name: str, m: Material, keys: list[str], rules: list[Rule], dim: int):
    """The Problem at the first sample point where material ``name`` fails (None when it never does)."""
    texts = [e for k in keys for e in _expressions(getattr(m, k))]
    with_t = any(expressions.TEMPERATURE in expressions.uses(e) for e in texts)
    temps = temperature_samples(scene, geo, name) if with_t else [0.0]
    pts = sample_points(geo, ("region", (name,)))
    nodes = sum(expressions.node_count(e) for e in texts)
    step = max(1, math.ceil(len(pts) * len(temps) * nodes / BUDGET))
    functions: dict = {}
    for T in temps:
        for p in pts[::step]:
            values = {"x": float(p[0]), "y": float(p[1]), "z": float(p[2]), "r": float(p[0]), "T": float(T)}
            failure = _failure_at(m, keys, rules, functions, values, dim)
            if failure is not None:
                key, message = failure
                texts = _texts_of(m, key)
                at = ", ".join(f"{n}={values[n] + 0.0:.6g}" for n in ("x", "y", "z")[:dim])
                if any(expressions.TEMPERATURE in expressions.uses(e) for e in texts):
                    at += f" and T = {T:.6g}"
                shown = ", ".join(repr(expressions.short(e)) for e in texts)
                shown = f" (expression{'s' if len(texts) > 1 else ''} {shown})" if texts else ""
                return Problem(f"materials.{name}.{key}", f"{message} at {at} of region {name!r}{shown}")
    return None


def _failure_at(m: Material, keys: list[str], rules: list[Rule], functions: dict, values: dict, dim: int):
    """(key, message) of what fails at one point, or None."""
    for key in keys:
        try:
            material_at(m, [key], functions, values)
        except (ArithmeticError, ValueError) as exc:
            why = "division by zero" if isinstance(exc, ZeroDivisionError) else "overflow" if isinstance(
                exc, OverflowError) else "a function outside its domain" if "domain" in str(exc) else str(exc)
            return key, f"is not finite ({why})"
    mp = material_at(m, keys, functions, values)
    problem = first_problem(mp, tuple(keys))
    if problem is not None:
        return problem.item, problem.message
    for rule_keys, read in rules:
        varying = [k for k in rule_keys if k in keys]
        if not varying:
            continue
        try:
            read(mp, dim)
        except MaterialError as exc:
            return exc.key or varying[0], exc.detail.removeprefix(": ")
        except ValueError as exc:
            return varying[0], str(exc)
    return None


def _expressions(v) -> list[str]:
    if isinstance(v, str):
        return [v]
    if isinstance(v, (list, tuple)):
        return [e for x in v for e in _expressions(x)]
    if dataclasses.is_dataclass(v):
        return [e for f in dataclasses.fields(v) for e in _expressions(getattr(v, f.name))]
    return []


def _texts_of(m: Material, key: str) -> list[str]:
    """The distinct expressions of a key (a list or matrix may hold several); ``key`` may be a path into a nested
    table and carry indices (``conductivity_principal[1]``, ``orthotropic.E[2]``, ``stiffness_voigt[0][1]``: that
    entry's)."""
    value = m
    for part in key.split("."):
        name = re.match(r"\w*", part).group(0)
        value = getattr(value, name, None)
        for index in re.findall(r"\[(\d+)\]", part):
            if isinstance(value, (list, tuple)) and int(index) < len(value):
                value = value[int(index)]
    return list(dict.fromkeys(_expressions(value)))


def check_phase_conductivity_values(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Append a Problem for each phase-change material of a Stefan scene whose conductivities vary in x, y, z but
    whose liquid and solid tensors are not c and 1 times one tensor field with one constant c over its region, read
    at the region's sample points (:func:`~ngs_geomech.heat.materials.conductivity_field`; the Kirchhoff variable
    of the Stefan forms is per region): the problem names the key and the two points where the ratio differs (or
    the point where a tensor is refused). Materials with a problem already are left out."""
    if not (scene.physics.thermal == "transient" and any(has_phase_change(m) for m in scene.materials.values())):
        return
    dim = scene_dim(scene)
    named = {p.item for p in problems}
    for name, m in scene.materials.items():
        if not has_phase_change(m) or name not in geo.regions or not any(
                holds_expression(getattr(m, k)) for k in CONDUCTIVITY_KEYS):
            continue
        if any(i == f"materials.{name}" or i.startswith(f"materials.{name}.") for i in named):
            continue
        pts = sample_points(geo, ("region", (name,)))
        nodes = sum(expressions.node_count(e) for k in CONDUCTIVITY_KEYS for e in _expressions(getattr(m, k)))
        try:
            conductivity_field(m, dim, pts[::max(1, math.ceil(len(pts) * nodes / BUDGET))], f" of region {name!r}")
        except MaterialError as exc:
            problems.append(Problem(f"materials.{name}.{exc.key}", exc.detail))


CONTACT_KEYS = (("friction", "coulomb", ""), ("slip_bound", "tresca", " Pa"))
"""The contact-law keys that may be expressions of x, y, z: (key, the law it belongs to, unit)."""


def check_contact_values(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Append a Problem for the first sample point of a contact side (the two sides of a contact interface, the
    boundary of a foundation) where an expression friction coefficient or Tresca slip bound is negative (values
    that are not finite are reported by :mod:`.expression_values`)."""
    if scene.physics.mechanics is None:
        return
    items = []
    for i, itf in enumerate(scene.interfaces):
        cs = geo.contacts.get(itf.name)
        if itf.type == "contact" and cs is not None:
            items.append((f"interfaces[{i}] ({itf.name})", itf, (cs.master, cs.minion), f"interface {itf.name!r}"))
    for name, bc in scene.boundary_conditions.items():
        if bc.foundation is not None and name in geo.boundaries:
            items.append((f"boundary_conditions.{name}.foundation", bc.foundation, (name,), f"boundary {name!r}"))
    for path, c, sides, where in items:
        for key, law, unit in CONTACT_KEYS:
            text = getattr(c, key)
            if isinstance(text, str) and c.law == law:
                at = _first_negative(text, sample_points(geo, ("boundary", sides)), geo.dim)
                if at:
                    problems.append(Problem(f"{path}.{key}", f"must be >= 0{unit}, got {at[0]:g}{unit} at {at[1]} of "
                                            f"{where} (expression {expressions.short(text)!r})"))


def _first_negative(text: str, pts: np.ndarray, dim: int) -> tuple[float, str] | None:
    """(value, 'x=.., y=..') at the first sample point where the expression is negative; None when it never is."""
    f = expressions.float_function(text)
    step = max(1, math.ceil(len(pts) * expressions.node_count(text) / BUDGET))
    for p in pts[::step]:
        values = {"x": float(p[0]), "y": float(p[1]), "z": float(p[2]), "r": float(p[0])}
        try:
            v = f(**values)
        except (ArithmeticError, ValueError):
            continue
        if math.isfinite(v) and v < 0:
            return v, ", ".join(f"{n}={values[n] + 0.0:.6g}" for n in ("x", "y", "z")[:dim])
    return None
