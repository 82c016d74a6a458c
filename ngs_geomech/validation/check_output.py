"""Validation of the output's figure settings against the geometry: the plane sections of a 3D scene
(``output.sections``): a 3D scene, a nonzero normal, a point in the geometry's bounding box, a window with
min < max, names that can be part of a file name and are used once."""

from __future__ import annotations

import numpy as np

from ..errors import Problem
from ..geometry.assemble import GeometryModel
from ..scene.model import Scene
from ..scene.names import name_problem


def check_sections(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """The plane sections of ``output.sections`` (module docstring)."""
    sections = scene.output.sections
    if not sections:
        return
    if geo.dim != 3:
        problems.append(Problem("output.sections", "plane sections need a 3d scene (a 2D scene's figures show "
                                                   "the whole plane; output.figure_window zooms in)"))
        return
    lo, hi = (np.asarray(a, dtype=float)[:3] for a in geo.bounding_box)
    tol = 1e-9 * max(float(np.max(hi - lo)), 1e-30)
    seen: set[str] = set()
    for i, sec in enumerate(sections):
        item = f"output.sections[{i}] ({sec.name})"
        why = name_problem(sec.name)
        if why is not None:
            problems.append(Problem(f"output.sections[{i}].name", why))
        elif sec.name in seen:
            problems.append(Problem(f"output.sections[{i}].name", f"section name {sec.name!r} is used twice"))
        seen.add(sec.name)
        if not float(np.linalg.norm(sec.normal)) > 0:
            problems.append(Problem(f"{item}.normal", "the normal must not be zero"))
        if np.any(np.asarray(sec.point) < lo - tol) or np.any(np.asarray(sec.point) > hi + tol):
            problems.append(Problem(f"{item}.point", f"{sec.point} lies outside the geometry's bounding box "
                                                     f"{lo.tolist()} ... {hi.tolist()} m: the plane may miss it"))
        w = sec.window
        if w is not None and not (w[0] < w[1] and w[2] < w[3]):
            problems.append(Problem(f"{item}.window", f"{w} needs umin < umax and vmin < vmax"))
