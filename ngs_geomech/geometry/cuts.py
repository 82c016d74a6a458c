"""Blocks split by planes (3D) or lines (2D) of any dip and strike: ``[[cuts]]``.

Axes: x east, y north, z up (2D scenes: x east, y up). A plane through the point p with strike azimuth phi
(clockwise from north = +y) dipping by delta to the right of the strike has the upward unit normal

    n = (sin(delta) cos(phi), -sin(delta) sin(phi), cos(delta))

(strike direction (sin(phi), cos(phi), 0), dip direction (cos(phi), -sin(phi), 0)). In 2D the line through p
dipping by delta towards +x (phi = 0) or -x (phi = 180) has n = (sin(delta) cos(phi), cos(delta)). A block's
part on the side n points to is "above" (the hanging wall of a fault dipping by delta < 90), the rest "below".
The cut sides of both parts are named after the cut; when both parts are kept they become an interface
(:mod:`.assemble`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from netgen import occ

from ..errors import Problem
from ..scene.model import Cut
from .shapes import cells, sides


@dataclass
class Split:
    """The regions after the cuts: their shapes in order (a region's cells carry its name), the blocks the cuts
    replaced (block -> the cut's name and the block's kept parts), and the pairs of parts each cut face joins,
    with the name of the glued interface it becomes when the scene declares none and the scene path of the cut."""

    shapes: dict[str, object]
    replaced: dict[str, tuple[str, list[str]]] = field(default_factory=dict)
    pairs: list[tuple[str, str, str, str]] = field(default_factory=list)     # (above, below, name, path)


def cut_normal(cut: Cut, dim: int) -> np.ndarray:
    """The upward unit normal of a cut (3 components; z = 0 in 2D)."""
    d, s = math.radians(cut.dip), math.radians(cut.strike)
    if dim == 2:
        return np.array([math.sin(d) * math.cos(s), math.cos(d), 0.0])
    return np.array([math.sin(d) * math.cos(s), -math.sin(d) * math.sin(s), math.cos(d)])


def apply_cuts(cuts: list[Cut], shapes: dict[str, object], dim: int, size: float,
               problems: list[Problem]) -> Split:
    """Split the regions ``shapes`` (name -> shape, in order) by each cut in turn; ``size`` is the model's extent
    (m, for tolerances). Adds a Problem for each cut that names an unknown block, a name taken or a block it
    does not cross."""
    split = Split(dict(shapes))
    for k, cut in enumerate(cuts):
        path = f"cuts[{k}] ({cut.name})"
        if _cut_problems(cut, path, split, dim, problems):
            continue
        n = cut_normal(cut, dim)
        point = np.zeros(3)
        point[:dim] = cut.point
        for j, (block, names) in enumerate(zip(cut.blocks, cut.parts)):
            pieces = _split_one(split.shapes[block], point, n, dim, size, f"{path}.blocks[{j}] ({block})", problems)
            if pieces is None:
                continue
            for piece, name in zip(pieces, names):
                if name:
                    cells(piece, dim).name = name
                    for s in sides(piece, dim):
                        if _on_plane(s, point, n, dim, 1e-9 * size):
                            s.name = cut.name
            split.shapes = _replace(split.shapes, block, {nm: p for p, nm in zip(pieces, names) if nm})
            split.replaced[block] = (cut.name, [nm for nm in names if nm])
            if all(names):
                iname = cut.name if len(cut.blocks) == 1 else f"{cut.name}_{block}"
                split.pairs.append((names[0], names[1], iname, path))
    return split


def _cut_problems(cut: Cut, path: str, split: Split, dim: int, problems: list[Problem]) -> bool:
    """Add the Problems of a cut's own data against the regions so far; whether there are any."""
    before = len(problems)
    if len(cut.point) != dim:
        problems.append(Problem(f"{path}.point", f"needs {dim} coordinates, got {len(cut.point)}"))
    if dim == 2 and cut.strike not in (0.0, 180.0):
        problems.append(Problem(f"{path}.strike", f"a 2D cut dips towards +x (strike 0) or -x (strike 180), got "
                                f"{cut.strike:g}"))
    if len(cut.parts) != len(cut.blocks):
        problems.append(Problem(f"{path}.parts", f"gives {len(cut.parts)} pairs of part names for "
                                f"{len(cut.blocks)} block(s): one pair [above, below] per block"))
    taken = set(split.shapes)
    for j, block in enumerate(cut.blocks):
        if block not in split.shapes:
            where = (f": cut {split.replaced[block][0]!r} split it into {split.replaced[block][1]}"
                     if block in split.replaced else "")
            problems.append(Problem(f"{path}.blocks[{j}]", f"no block {block!r}{where} (blocks and parts: "
                                    f"{', '.join(split.shapes)})"))
        elif block in cut.blocks[:j]:
            problems.append(Problem(f"{path}.blocks[{j}]", f"block {block!r} is listed twice"))
    new = [nm for pair in cut.parts for nm in pair if nm]
    for j, pair in enumerate(cut.parts):
        if not any(pair):
            problems.append(Problem(f"{path}.parts[{j}]", "both parts are removed ('' names): keep one"))
        for nm in pair:
            own = j < len(cut.blocks) and nm == cut.blocks[j]     # a part may keep its block's name
            if nm and ((nm in taken and not own) or new.count(nm) > 1):
                problems.append(Problem(f"{path}.parts[{j}]", f"name {nm!r} is taken (blocks, parts and regions "
                                        "need names of their own)"))
    return len(problems) > before


def _split_one(shape, point: np.ndarray, n: np.ndarray, dim: int, size: float, path: str,
               problems: list[Problem]) -> tuple | None:
    """(part above, part below) of a shape, or None after adding a Problem: the plane misses it, or the geometry
    kernel failed."""
    whole = sum(float(c.mass) for c in cells(shape, dim))
    try:
        half = occ.HalfSpace(occ.Pnt(*point), occ.Vec(*n))       # the solid on the side -n points to
        above, below = shape - half, shape * half
        left = [sum(float(c.mass) for c in cells(p, dim)) for p in (above, below)]
    except RuntimeError as exc:
        problems.append(Problem(path, f"the geometry kernel (OCC) failed splitting it ({exc})"))
        return None
    for side, m in zip(("below", "above"), left):
        if m <= 1e-9 * whole:
            problems.append(Problem(path, f"the cut does not cross it: all of it lies {side} the "
                                    f"{'plane' if dim == 3 else 'line'}"))
            return None
    return above, below


def _on_plane(side, point: np.ndarray, n: np.ndarray, dim: int, tol: float) -> bool:
    """Whether a side (edge in 2D, face in 3D) lies on the plane (line) through ``point`` with normal ``n``."""
    pts = [side.center] + [v.p for v in side.vertices]
    return all(abs(float(np.dot(np.array([p.x, p.y, p.z]) - point, n))) <= tol for p in pts)


def _replace(shapes: dict, block: str, parts: dict) -> dict:
    """``shapes`` with ``block`` replaced by ``parts`` at its place (the order of the regions)."""
    out = {}
    for name, s in shapes.items():
        if name == block:
            out.update(parts)
        else:
            out[name] = s
    return out
