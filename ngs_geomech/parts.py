"""The interface every part of a run speaks (:class:`Part`): heat (:class:`~ngs_geomech.heat.run.HeatRun`), the
Stefan problem (:class:`~ngs_geomech.stefan.problem.StefanRun`), static mechanics
(:class:`~ngs_geomech.mechanics.run.StaticMechanicsRun`), dynamic or viscous mechanics
(:class:`~ngs_geomech.dynamics.problem.DynamicsRun`) and the coupling of heat and mechanics
(:class:`~ngs_geomech.coupling.run.CouplingRun`). The driver (:mod:`ngs_geomech.run`) holds the parts of a scene
on one mesh and calls, in this order: :meth:`Part.steady` (a stationary scene) or :meth:`Part.start` (a
time-dependent one), then per time step :meth:`Part.advance` and, at the output times, :meth:`Part.record`; a
checkpoint holds what :meth:`Part.capture` copies, :meth:`Part.restore` puts it back; the output is the
parts' ``fields`` (VTK), :meth:`Part.lines` and :meth:`Part.figures`; the run's summary gathers
:meth:`Part.summary`. A part that takes no part in a phase inherits the method that does nothing.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass


@dataclass(frozen=True)
class Step:
    """One time step from ``a`` to ``b`` (s), number ``k`` (from 0) of the run's ``total``; ``output``: an
    output time (the parts record, the VTK is written)."""

    a: float
    b: float
    k: int
    output: bool
    where: str

    @property
    def dt(self) -> float:
        return self.b - self.a


class Part(abc.ABC):
    """One physics of a run on one mesh (module docstring).

    ``key`` names the part's block in the summary and in checkpoints; ``fields`` are its output fields (name ->
    CoefficientFunction, written to VTK); ``probe_fields`` the quantities probes read from it, recorded at every
    step when ``probes_every_step`` (thermal fields), at the output times otherwise; ``newton_iterations`` the
    Newton iterations of its steps (thermal parts; the summary's maximum); ``warnings`` what its solves found
    doubtful; ``records_every_step``: :meth:`record` is called after every step, not only at the output
    times."""

    key: str = ""
    probes_every_step: bool = False
    records_every_step: bool = False

    def __init__(self) -> None:
        self.fields: dict = {}
        self.probe_fields: dict = {}
        self.newton_iterations: list[int] = []
        self.warnings: list[str] = []

    # -- solving --------------------------------------------------------------------------------------------
    def steady(self, where: str) -> None:
        """Solve the stationary problem (a scene without time)."""
        return None

    def start(self, t0: float, where: str) -> None:
        """Set the initial state at the start time t0 (s) of a time-dependent scene."""
        return None

    @abc.abstractmethod
    def advance(self, step: Step) -> None:
        """Advance over ``step`` (a part solved only at output times solves when ``step.output``)."""

    def record(self, t: float) -> None:
        """Keep what the summary reports of the state at the output time t (s)."""
        return None

    # -- checkpoints ----------------------------------------------------------------------------------------
    def capture(self) -> tuple[dict, dict]:
        """The state after the last step: (arrays, lengths of the append-only histories)."""
        return {}, {}

    def meta(self, lengths: dict) -> dict:
        """The histories up to ``lengths`` (from :meth:`capture`) as JSON data."""
        return {}

    def restore(self, arrays: dict, meta: dict) -> None:
        """Put the state of :meth:`capture` / :meth:`meta` back."""
        return None

    # -- reporting ------------------------------------------------------------------------------------------
    @property
    def factorizations(self) -> int:
        """Matrix factorizations so far."""
        return 0

    @property
    def ndof(self) -> int:
        """Unknowns of the part on its mesh."""
        return 0

    @property
    def ndof_global(self) -> int:
        """Unknowns of the part on the whole (distributed) mesh."""
        return self.ndof

    def summary(self) -> dict:
        """The run summary's entries of this part (top-level keys -> values)."""
        return {}

    # -- output ---------------------------------------------------------------------------------------------
    def line_names(self, scene) -> list[str]:
        """The line (2D) or surface (3D) series the part writes for ``scene`` besides the VTK of its fields,
        as suffixes of ``<scene>_<suffix>.pvd``."""
        return []

    def lines(self) -> dict:
        """Per name of :meth:`line_names`: (points, cells, point data) of the current state (a collective call
        on a distributed mesh)."""
        return {}

    def figures(self, canvas) -> None:
        """Draw the part's figures of the last state on ``canvas`` (:class:`~ngs_geomech.io.canvas.Canvas`)."""
        return None
