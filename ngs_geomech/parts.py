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

import numpy as np


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

    def checkpoint_spaces(self) -> dict:
        """The arrays of :meth:`capture` that are vectors of a finite element space (name -> space): on a
        distributed mesh this rank's (cumulated) part of the vector, which a checkpoint holds in a numbering of
        the whole mesh (:mod:`ngs_geomech.run.numbering`). The other arrays are the same on every rank."""
        return {}

    def partition_bound(self) -> tuple[str, ...]:
        """Prefixes of the names of :meth:`capture`'s arrays whose order follows how the mesh is split over the
        ranks (a checkpoint holding them resumes on the same number of ranks only)."""
        return ()

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

    def derived_fields(self) -> dict:
        """Output fields the VTK computes from another field's values (name -> (source field, function of its
        values, n x components)) instead of evaluating their CoefficientFunctions point by point."""
        return {}

    def figures(self, canvas) -> None:
        """Draw the part's figures of the last state on ``canvas`` (:class:`~ngs_geomech.io.canvas.Canvas`)."""
        return None


class ThermalPart(Part):
    """A part that carries the temperature (heat or Stefan): ``T`` (its temperature field), ``forms`` (with
    ``gf_pressure`` None or a field of the mean pressure and ``set_pressure``). A coupled step
    (:class:`~ngs_geomech.coupling.run.CouplingRun`) drives it through :meth:`begin_step`, :meth:`solve_step`
    (with the deformation heating), :meth:`finish_step` and, between the passes of an iterated step,
    :meth:`mark` / :meth:`rewind`."""

    probes_every_step = True

    def advance(self, step: Step) -> None:
        self.begin_step(step)
        self.finish_step(self.solve_step(step))

    def begin_step(self, step: Step) -> None:
        """Set the step up (the old state and the times)."""
        return None

    @abc.abstractmethod
    def solve_step(self, step: Step, heating=None):
        """Solve the step, with the source of ``heating`` (a DeformationHeating) added; returns the step's info
        (its ``iterations``)."""

    @abc.abstractmethod
    def interpolate(self, cf):
        """A field in the temperature's space holding the CoefficientFunction ``cf`` the way this part sets its
        initial temperature: a stress-free temperature T0(x) so interpolated (the seed's T0 in H1) gives
        T - T0 = 0 exactly at t = 0 where T0 is the initial temperature."""

    def finish_step(self, info) -> None:
        """Keep what a solved step reports (its Newton iterations)."""
        self.newton_iterations.append(info.iterations)

    def mark(self):
        """What :meth:`rewind` needs to repeat the step (None: nothing, the step starts from the last pass)."""
        return None

    def rewind(self, mark) -> None:
        """Back to the state of :meth:`mark`."""
        return None

    def temperature_values(self) -> np.ndarray:
        """The temperature's coefficient vector (a copy)."""
        return self.T.vec.FV().NumPy().copy()

    def set_pressure(self, pressure):
        """Give the conductivities kappa(T, p) the mean pressure ``pressure`` (Pa); returns the (min, max)
        conductivity factors, or None without pressure-dependent conductivities."""
        if self.forms.gf_pressure is None:
            return None
        return self.forms.set_pressure(pressure)

    def set_contact_state(self, states: dict) -> list[str]:
        """Give the contact conductances the mechanics' contact state per interface name (nodal pressure and gap,
        :class:`~ngs_geomech.heat.conductance.ContactNodes`); returns warnings for the interfaces closed in it that
        carry no heat."""
        return []

    def contact_warnings(self, states: dict) -> list[str]:
        """Warnings for the interfaces ``states`` closes that carry no heat, the thermal part not following the
        mechanics (an uncoupled run)."""
        return []

    @abc.abstractmethod
    def heating_target(self) -> tuple:
        """(space, test function, volume measure, weight) a deformation-heating source is assembled against."""

    @abc.abstractmethod
    def take_state(self, old, t0: float | None) -> tuple:
        """Carry the state of ``old`` (the same part on another mesh) over, or set the initial state at ``t0``;
        returns the heat content before and after and a callable to run once the new mesh is kept (or None)."""
