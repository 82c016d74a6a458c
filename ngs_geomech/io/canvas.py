"""Where and how a run draws its figures (:class:`Canvas`): the directory, the 2D mesh arrays fields are drawn
on, the axis labels and units of the scene, and the drawing functions (:mod:`.figures`, the principal-stress
crosses of :mod:`.stress_figures`), which do nothing on the ranks of a distributed run that do not draw."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from . import figures, stress_figures
from .meshdata import MeshArrays


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
    no field figures); ``labels`` the axis labels, ``t_unit`` the temperature unit ('degC' or 'K'), ``when`` the
    time the figures show ('t = ...' or 'steady state'), ``window`` the scene's near-field window (or None)."""

    directory: Path
    title: str
    arrays: MeshArrays | None
    labels: tuple[str, str]
    t_unit: str
    when: str
    window: list | None
    draw: Drawing

    def path(self, name: str) -> Path:
        """The file ``name`` in the figure directory (created with the first figure drawn)."""
        if self.draw.draw:
            self.directory.mkdir(parents=True, exist_ok=True)
        return self.directory / name
