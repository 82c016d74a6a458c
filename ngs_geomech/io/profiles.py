"""Profiles along the axis of a thin column (:class:`AxisProfile`): a field sampled along the line through the
middle of a thin domain's bounding box at a few output times spread over the run, for the profile figure
(permafrost's T(depth)) that a 20 m x 1000 m field plot cannot show."""

from __future__ import annotations

import numpy as np

from .. import parallel
from .layout import thin

POINTS = 1001
"""Samples along the axis (1 m apart on a 1000 m column)."""

CURVES = 6
"""Output times kept: the first at or after each of CURVES times spread evenly from the start to the end."""


class AxisProfile:
    """A field along the long ``axis`` (0 x, 1 y, 2 z) of the box (lo, hi) through the middle of its cross-section,
    kept at the first output time at or after each of :data:`CURVES` target times from ``t0`` to ``t1`` (s; one,
    ``t0``, for a steady scene): ``coord`` the axis coordinate of the samples (m), ``times`` the kept times,
    ``values`` the profiles (NaN outside the mesh)."""

    def __init__(self, lo, hi, axis: int, t0: float, t1: float):
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        self.axis = axis
        self.coord = np.linspace(lo[axis], hi[axis], POINTS)
        self.points = np.tile(0.5 * (lo + hi), (POINTS, 1))
        self.points[:, axis] = self.coord
        self.targets = list(np.linspace(t0, t1, CURVES)) if t1 > t0 else [t0]
        self.tol = 1e-9 * max(abs(t1 - t0), abs(t1), 1.0)
        self.times: list[float] = []
        self.values: list[list[float]] = []

    @classmethod
    def of(cls, lo, hi, t0: float, t1: float) -> AxisProfile | None:
        """The profile of a thin box (:func:`~.layout.thin`), None for another."""
        axis = thin(lo, hi)
        return None if axis is None else cls(lo, hi, axis, t0, t1)

    def passed(self, t: float) -> int:
        """How many target times t (s) has reached."""
        return sum(1 for target in self.targets if t >= target - self.tol)

    def due(self, t: float) -> bool:
        """Whether the state at t (s) is kept: t reaches a target time the last kept one had not."""
        return self.passed(t) > (self.passed(self.times[-1]) if self.times else 0)

    def record(self, mesh, t: float, cf) -> None:
        """Keep ``cf`` along the axis at t when :meth:`due` (collective on a distributed mesh)."""
        if self.due(t):
            self.times.append(float(t))
            self.values.append(parallel.point_values(mesh, cf, self.points)[:, 0].tolist())

    # -- checkpoints ----------------------------------------------------------------------------------------
    def meta(self, length: int) -> dict:
        return {"times": self.times[:length], "values": self.values[:length]}

    def restore(self, meta: dict) -> None:
        self.times[:] = meta.get("times", [])
        self.values[:] = meta.get("values", [])
