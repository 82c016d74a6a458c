"""Where the expressions of a scene have no finite value, found before meshing.

Each expression is evaluated with floats at points of the part of the geometry it applies to (a boundary
condition on its boundary, a region's initial temperature or source density in that region, other
expressions in the whole domain) and, when it depends on t, at times over [time.start, time.end]. The points
are the vertices of the OCC cells or sides and a small grid over their bounding box, kept where it lies in
the cell or on the side (concave blocks, holes). The first point without a finite value is reported, naming
the scene key.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator

import numpy as np
from netgen import occ

from ..errors import Problem
from ..geometry.assemble import GeometryModel
from ..geometry.shapes import cells, sides
from ..scene import expressions
from ..scene.schema import Expression

GRID = {2: 9, 3: 5}
"""Grid points per axis over a target's bounding box (2D, 3D)."""
TIMES = 5
"""Sampled times over [start, end] of an expression of t."""
BUDGET = 300_000
"""Most tree-node evaluations per expression (points x times x nodes): the cost stays well below a second."""


def expression_items(obj, path: str = "") -> Iterator[tuple[str, Expression]]:
    """(scene key, expression) of every expression string in a scene object."""
    if isinstance(obj, Expression):
        yield path, obj
    elif dataclasses.is_dataclass(obj):
        for f in dataclasses.fields(obj):
            yield from expression_items(getattr(obj, f.name), f"{path}.{f.name}" if path else f.name)
    elif isinstance(obj, dict):
        for k, v in obj.items():
            yield from expression_items(v, f"{path}.{k}")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            yield from expression_items(v, f"{path}[{i}]")


def check_expression_values(scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Append a Problem for every expression of the scene that is not finite somewhere it applies."""
    points: dict[tuple, np.ndarray] = {}
    t = scene.time
    named = {p.item for p in problems}
    for key, text in expression_items(scene):
        target = None if key in named else _target(scene, geo, key)
        if target is None:
            continue
        used = expressions.uses(text)
        if not used - {"t"}:
            target = ("time only",)
        if target not in points:
            points[target] = _points(geo, target)
        times = [0.0] if t is None else [t.start]
        if "t" in used and t is not None and not key.startswith("initial.") and t.end > t.start:
            times = list(np.linspace(t.start, t.end, TIMES))
        where = _first_not_finite(text, points[target], times, geo.dim, "t" in used)
        if where:
            problems.append(Problem(key, f"expression {expressions.short(text)!r} is not finite {where}"))


def _target(scene, geo: GeometryModel, key: str) -> tuple | None:
    """What an expression applies to: ('boundary', names), ('region', names) or ('all',); None: not sampled."""
    parts = key.split(".")
    if parts[0] == "materials":
        return None                     # material values: validation.material_values
    if parts[0] == "boundary_conditions":
        return ("boundary", (parts[1],)) if parts[1] in geo.boundaries else None
    if key.startswith("initial.regions."):
        return ("region", (parts[2],)) if parts[2] in geo.regions else None
    if key.startswith("sources["):
        i = int(key[len("sources["):key.index("]")])
        region = scene.sources[i].region
        return ("region", (region,)) if region in geo.regions else None
    if key.startswith("interfaces["):
        i = int(key[len("interfaces["):key.index("]")])
        cs = geo.contacts.get(scene.interfaces[i].name)
        return None if cs is None else ("boundary", (cs.master, cs.minion))
    return ("all",)


def sample_points(geo: GeometryModel, target: tuple) -> np.ndarray:
    """Sample points (n x 3) of a target ('region', names), ('boundary', names) or ('all',): vertices, points along
    edges and grid points inside (:data:`GRID` per axis of the bounding box)."""
    return _points(geo, target)


def _points(geo: GeometryModel, target: tuple) -> np.ndarray:
    """Sample points (n x 3) of a target: vertices, points along edges and grid points inside."""
    if target[0] == "time only":
        return np.zeros((1, 3))
    if target[0] == "boundary":
        shapes = [s for s in sides(geo.shape, geo.dim) if s.name in target[1]]
    else:
        shapes = [c for c in cells(geo.shape, geo.dim) if target[0] == "all" or c.name in target[1]]
    pts = [np.array([v.p.x, v.p.y, v.p.z]) for s in shapes for v in s.vertices]
    for s in shapes:
        for e in (s.edges if geo.dim == 3 or target[0] != "boundary" else [s]):
            a, b = e.parameter_interval
            pts += [np.array([q.x, q.y, q.z]) for q in (e.Value(u) for u in np.linspace(a, b, GRID[geo.dim]))]
        if geo.dim == 2 and target[0] == "boundary":
            continue
        lo, hi = s.bounding_box
        lo, hi = np.array([lo.x, lo.y, lo.z]), np.array([hi.x, hi.y, hi.z])
        tol = 1e-9 * max(float(np.max(hi - lo)), 1e-30)
        axes = [np.linspace(lo[k], hi[k], GRID[geo.dim]) if k < geo.dim else [0.0] for k in range(3)]
        for p in np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T:
            if occ.Vertex(occ.Pnt(*p)).Distance(s) <= tol:
                pts.append(p)
    return np.unique(np.round(np.array(pts), 12), axis=0) if pts else np.zeros((0, 3))


def _first_not_finite(text: str, pts: np.ndarray, times: list, dim: int, with_t: bool) -> str:
    """'at x=.., y=.. (why)' for the first sample without a finite value; '' when there is none."""
    f = expressions.float_function(text)
    nodes = expressions.node_count(text)
    step = max(1, math.ceil(len(pts) * len(times) * nodes / BUDGET))
    names = ("x", "y", "z")[:dim]
    for t in times:
        for p in pts[::step]:
            values = dict(zip(("x", "y", "z"), (float(c) for c in p)), r=float(p[0]), t=float(t))
            try:
                v = f(**values)
                why = "" if math.isfinite(v) else f"(value {v})"
            except ZeroDivisionError:
                why = "(division by zero)"
            except OverflowError:
                why = "(overflow)"
            except ValueError as exc:
                why = "(a function outside its domain, e.g. sqrt or log of a negative number)" \
                    if "domain" in str(exc) else f"({exc})"
            if why:
                at = ", ".join(f"{n}={values[n] + 0.0:.6g}" for n in names) + (f", t={t:.6g} s" if with_t else "")
                return f"at {at} {why}"
    return ""


def value_range(geo: GeometryModel, value, target: tuple) -> tuple[float, float] | None:
    """(min, max) of a number or an expression at the sample points of a target at t = 0 (finite values only;
    None when there is none)."""
    if isinstance(value, (int, float)):
        return float(value), float(value)
    f = expressions.float_function(value)
    vals = []
    for p in _points(geo, target):
        try:
            v = f(x=float(p[0]), y=float(p[1]), z=float(p[2]), r=float(p[0]))
        except (ValueError, ZeroDivisionError, OverflowError):
            continue
        if math.isfinite(v):
            vals.append(v)
    return (min(vals), max(vals)) if vals else None
