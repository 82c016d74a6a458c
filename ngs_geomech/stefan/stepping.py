"""How a scene's time step is taken by the Stefan solver: substeps of the scene step, chosen by a step control.

A scene step (a, b) (s) is divided into substeps on a ladder of levels: at level k the substep is (b - a) / 2^k,
k = 0 .. :data:`MAX_LEVEL`, so the scene's dt is the largest step, the output times (the ends of the scene steps)
are hit exactly, and a substep starts only where the coarser ones would (positions counted in units of the finest
substep, (b - a) / 2^MAX_LEVEL). Equal levels give equal substeps to the last bits (midpoints taken by repeated
bisection), so the Newton matrix's factorization is reused while the level stays
(:class:`~ngs_geomech.stefan.column_jacobian.ColumnJacobian` refactors when dt changes).

A substep whose Newton iteration fails is rewound and taken again one level finer; at :data:`MAX_LEVEL` the
failure is the run's SolverError with the solver's diagnosis. The strategies (:class:`StepControl`) differ in
the level they choose next:

- :class:`HalvingControl`: every scene step starts at the scene's dt; a failed step is split in halves
  recursively (after a finer half, the next substep is the coarsest one its position allows).
- :class:`AdaptiveControl` (the default, ``time.stefan_step_control = "adaptive"``): the level is kept from
  substep to substep and from scene step to scene step; a substep that needed many Newton iterations
  (:data:`SHRINK_ITERATIONS`) makes the next one a level finer; after a number of easy substeps in a row (few
  Newton iterations, the phase boundary crossing few element layers: :data:`GROW_ITERATIONS`,
  :data:`GROW_TRAVEL`) the level goes one coarser where the position allows. That number (the patience)
  starts at :data:`GROW_AFTER` and doubles after every rejected substep (up to :data:`MAX_PATIENCE`), so a step
  size that failed is tried again ever more rarely instead of at every scene step.

The front's travel in a substep is measured in element layers: the nodes whose branch (solid, mushy, liquid)
changed divided by the nodes mushy at its start or end (a front crossing one layer of nodes changes each node of
that layer once or twice while one or two layers are mushy, see :meth:`StepControl.travel`).

A scene whose steps all converge in fewer than SHRINK_ITERATIONS iterations is solved at its own dt by either
control, bit for bit as without substeps.

A control's state (level, patience, counters) is part of the Stefan part's state: a mark/rewind (coupling passes,
front-following repeats) and a checkpoint keep it, so a resumed run takes the substeps of an uninterrupted one.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

MAX_LEVEL = 6
"""The finest substep is the scene step / 2^MAX_LEVEL (dt / 64): a failure there stops the run."""

GROW_ITERATIONS = 2
"""Adaptive control: a substep with at most this many Newton iterations (and little travel) counts as easy.
Measured on the two-phase strip (h = 0.00625 m, dt = 0.005 s): 2 gave 174 substeps, 1 rejected, front error
1.77e-3; 3 gave 148 substeps, 3 rejected, 2.11e-3 (more returns to the step that fails)."""

SHRINK_ITERATIONS = 10
"""Adaptive control: a substep that needed at least this many Newton iterations makes the next one a level
finer (it is accepted: it converged). None of the built-in scenes' steps needs that many (at most 6), so the
control leaves them at the scene's dt unless a step fails."""

GROW_TRAVEL = 2.0
"""Adaptive control: the most element layers the front may cross in an easy substep (the next coarser one
doubles it). The travel only holds the growth back and never shrinks a step: as a shrinking criterion (more than
4 layers) it split 15 of permafrost's 70 steps that all converged in at most 6 iterations (a coarse column mesh
with few mushy nodes, where the count overestimates the layers), and changed nothing on the strip."""

GROW_AFTER = 4
"""Adaptive control: easy substeps in a row before the level goes one coarser (the initial patience)."""

MAX_PATIENCE = 64
"""Adaptive control: the patience doubles after each rejected substep up to this many substeps."""


def bisect_time(a: float, b: float, pos: int) -> float:
    """The time of position ``pos`` (units of (b - a) / 2^MAX_LEVEL) of the scene step (a, b), by repeated
    midpoints 0.5 (lo + hi): the substep ends of recursive halving to the last bit."""
    lo, hi = a, b
    for bit in range(MAX_LEVEL - 1, -1, -1):
        if pos == 1 << (bit + 1):
            return hi
        mid = 0.5 * (lo + hi)
        if pos & (1 << bit):
            lo = mid
        else:
            hi = mid
        pos &= (1 << bit) - 1
        if pos == 0:
            return lo
    return lo


def coarsest_level(pos: int) -> int:
    """The coarsest level whose substeps start at position ``pos`` (0 at the start of the scene step)."""
    if pos == 0:
        return 0
    return MAX_LEVEL - ((pos & -pos).bit_length() - 1)


class StepControl(ABC):
    """The level of the next substep of a Stefan run (module docstring) and its statistics: ``taken`` accepted
    substeps, ``rejected`` substeps taken again finer, the smallest and largest accepted substep (s)."""

    name = ""

    def __init__(self) -> None:
        self.level = 0
        self.taken = 0
        self.rejected = 0
        self.dt_min = math.inf
        self.dt_max = 0.0

    def next_level(self, pos: int) -> int:
        """The level of the substep starting at position ``pos`` of the scene step (never coarser than the
        position allows); kept as ``level``."""
        self.level = self._choose(max(self.level, coarsest_level(pos)), pos)
        return self.level

    @abstractmethod
    def _choose(self, level: int, pos: int) -> int:
        """The strategy's level at ``pos`` from ``level`` (the last substep's, or finer as ``pos`` requires)."""

    def accept(self, iterations: int, travel: float, dt: float) -> None:
        """A substep of ``dt`` (s) converged in ``iterations`` Newton iterations, the front crossing ``travel``
        element layers."""
        self.taken += 1
        self.dt_min = min(self.dt_min, dt)
        self.dt_max = max(self.dt_max, dt)

    def reject(self) -> bool:
        """The last substep failed: the next one a level finer. False when none is allowed (MAX_LEVEL)."""
        if self.level >= MAX_LEVEL:
            return False
        self.rejected += 1
        self.level += 1
        return True

    @staticmethod
    def travel(phase_changes: int, front_nodes: int) -> float:
        """Element layers the front crossed in a substep: nodes that changed branch per node mushy at its start
        or end (1 when none was: a front that jumped a whole layer without a mushy node)."""
        return phase_changes / max(front_nodes, 1)

    # -- state --------------------------------------------------------------------------------------------
    def state(self) -> np.ndarray:
        """The state as floats (checkpoints, marks)."""
        return np.array([self.level, self.taken, self.rejected, self.dt_min, self.dt_max, *self._extra()],
                        dtype=float)

    def load(self, state) -> None:
        """Back to a state of :meth:`state`."""
        s = np.asarray(state, dtype=float).ravel()
        self.level, self.taken, self.rejected = int(s[0]), int(s[1]), int(s[2])
        self.dt_min, self.dt_max = float(s[3]), float(s[4])
        self._load_extra(s[5:])

    def _extra(self) -> list:
        return []

    def _load_extra(self, values) -> None:
        return None

    def report(self) -> dict:
        """The summary's ``step_control`` block."""
        return {"strategy": self.name, "steps_taken": self.taken, "rejected_steps": self.rejected,
                "dt_min_s": self.dt_min if self.taken else None, "dt_max_s": self.dt_max if self.taken else None,
                "max_level": MAX_LEVEL}


class HalvingControl(StepControl):
    """Every scene step starts at the scene's dt; a failure splits the substep in halves, and after a finer half
    the next substep is the coarsest its position allows (recursive halving)."""

    name = "halving"

    def _choose(self, level: int, pos: int) -> int:
        return level

    def accept(self, iterations: int, travel: float, dt: float) -> None:
        super().accept(iterations, travel, dt)
        self.level = 0                      # the next substep: the coarsest its position allows


class AdaptiveControl(StepControl):
    """The level follows the Newton iterations and the front's travel (module docstring); ``easy`` counts the
    easy substeps in a row, ``patience`` how many the next coarsening needs."""

    name = "adaptive"

    def __init__(self) -> None:
        super().__init__()
        self.easy = 0
        self.patience = GROW_AFTER

    def _choose(self, level: int, pos: int) -> int:
        if self.easy >= self.patience and level > 0 and coarsest_level(pos) <= level - 1:
            self.easy = 0
            level -= 1
        return level

    def accept(self, iterations: int, travel: float, dt: float) -> None:
        super().accept(iterations, travel, dt)
        if iterations >= SHRINK_ITERATIONS:
            self.easy = 0
            self.level = min(self.level + 1, MAX_LEVEL)
        elif iterations <= GROW_ITERATIONS and travel <= GROW_TRAVEL:
            self.easy += 1
        else:
            self.easy = 0

    def reject(self) -> bool:
        self.easy = 0
        self.patience = min(2 * self.patience, MAX_PATIENCE)
        return super().reject()

    def _extra(self) -> list:
        return [self.easy, self.patience]

    def _load_extra(self, values) -> None:
        if len(values) >= 2:
            self.easy, self.patience = int(values[0]), int(values[1])


CONTROLS = {c.name: c for c in (AdaptiveControl, HalvingControl)}
"""The step controls by the name ``time.stefan_step_control`` gives."""
