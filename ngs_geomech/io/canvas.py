"""Where and how a run draws its figures (:class:`Canvas`): the directory, the 2D mesh arrays fields are drawn
on, the plane sections of a 3D mesh, the axis labels and units of the scene, and the drawing functions
(:mod:`.figures`, the principal-stress crosses of :mod:`.stress_figures`), which do nothing on the ranks of a
distributed run that do not draw."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import parallel
from . import figures, stress_figures
from .meshdata import MeshArrays, surface_triangles
from .scales import Scale, with_unit
from .sections import SectionPlane


class Drawing:
    """The drawing functions, or, with ``draw`` False, functions that do nothing."""

    def __init__(self, draw: bool):
        self.draw = draw

    def __getattr__(self, name):
        if not self.draw:
            return lambda *args, **kwargs: None
        return stress_figures.principal_stress_crosses if name == "principal_stress_crosses" else \
            getattr(figures, name)


@dataclass
class Canvas:
    """The figures of one run: ``title`` (the scene name) heads each figure; ``arrays`` the 2D mesh (None in 3D:
    fields are drawn on the ``sections``); ``labels`` the axis labels, ``t_unit`` the temperature unit ('degC' or
    'K'), ``when`` the time the figures show ('t = ...' or 'steady state'), ``window`` the scene's near-field
    window (or None); ``bounds`` the mesh's bounding box (lo, hi), m; ``sections`` the planes 3D fields are drawn
    on (:class:`~.sections.SectionPlane`)."""

    directory: Path
    title: str
    arrays: MeshArrays | None
    labels: tuple[str, str]
    t_unit: str
    when: str
    window: list | None
    draw: Drawing
    bounds: tuple | None = None
    sections: list[SectionPlane] = field(default_factory=list)
    surface: np.ndarray | None = field(default=None, repr=False)

    def path(self, name: str) -> Path:
        """The file ``name`` in the figure directory (created with the first figure drawn)."""
        if self.draw.draw:
            self.directory.mkdir(parents=True, exist_ok=True)
        return self.directory / name

    def section_figures(self, mesh, cf, stem: str, *, title: str, label: str, cmap: str = "inferno",
                        scale: Callable[[np.ndarray], Scale] | None = None) -> None:
        """The scalar ``cf`` on each section plane of a 3D mesh, sampled on the plane's grid (points outside the
        mesh left blank), with the cut of the region boundaries and interfaces: ``<stem>_section_<name>.png``.
        ``scale`` chooses the unit from the values (e.g. :func:`~.scales.stress_scale`; it replaces the unit of
        ``label``). Collective on a distributed mesh (every rank evaluates, the drawing one draws)."""
        if not self.sections or self.bounds is None:
            return
        if self.surface is None:
            self.surface = surface_triangles(mesh)
        lo, hi = self.bounds
        for plane in self.sections:
            a, b, points = plane.grid(lo, hi)
            values = parallel.point_values(mesh, cf, points)[:, 0].reshape(len(b), len(a))
            unit = scale(values) if scale is not None else None
            self.draw.section_figure(a, b, values if unit is None else unit(values),
                                     self.path(f"{stem}_section_{plane.name}.png"),
                                     title=f"{title}\nsection {plane.heading}",
                                     label=label if unit is None else with_unit(label, unit.unit),
                                     axis_labels=plane.labels, outline=plane.cut(self.surface), cmap=cmap)
