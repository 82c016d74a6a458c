"""The units figures show their numbers in, chosen by magnitude: lengths in m or km, stresses in MPa or GPa,
displacements in m or mm. Data stay in SI units (m, Pa); a :class:`Scale` divides them for drawing and names the
unit in the axis label."""

from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np

from ..scene.units import YEAR, format_time

KM_FROM = 10e3
"""Extents (m) from which lengths are drawn in km: a 10 km domain reads 0 ... 10 km, a 9 km one 0 ... 9000 m."""

GPA_FROM = 1e9
"""Stress magnitudes (Pa) from which stresses are drawn in GPa (below: MPa, never Pa)."""

M_FROM = 1.0
"""Displacement magnitudes (m) from which displacements are drawn in m (below: mm)."""


class Scale(NamedTuple):
    """A unit to draw values in: ``unit`` its name, ``factor`` the SI value of one unit (km: 1e3)."""

    unit: str
    factor: float

    def __call__(self, values):
        """``values`` (SI) in this unit."""
        return np.asarray(values, dtype=float) / self.factor


def largest(values) -> float:
    """The largest magnitude among the finite ``values`` (0 when there are none)."""
    a = np.abs(np.asarray(values, dtype=float))
    a = a[np.isfinite(a)]
    return float(a.max()) if a.size else 0.0


def length_scale(extent: float) -> Scale:
    """Km for an extent (m) of at least :data:`KM_FROM`, else m."""
    return Scale("km", 1e3) if abs(extent) >= KM_FROM else Scale("m", 1.0)


def stress_scale(values) -> Scale:
    """GPa when the largest magnitude of ``values`` (Pa) is at least :data:`GPA_FROM`, else MPa."""
    return Scale("GPa", 1e9) if largest(values) >= GPA_FROM else Scale("MPa", 1e6)


def displacement_scale(values) -> Scale:
    """M when the largest magnitude of ``values`` (m) is at least :data:`M_FROM`, else mm."""
    return Scale("m", 1.0) if largest(values) >= M_FROM else Scale("mm", 1e-3)


SCALES = {"Pa": stress_scale, "m": displacement_scale}
"""The scale chooser of a quantity by its SI unit (probe curves: stresses, displacements)."""


def with_unit(label: str, unit: str) -> str:
    """``label`` with its trailing unit in parentheses replaced by ``unit`` ('x (m)' -> 'x (km)'); a label
    without one gets it appended."""
    return f"{without_unit(label)} ({unit})"


def without_unit(label: str) -> str:
    """``label`` without its trailing unit in parentheses."""
    return re.sub(r"\s*\([^()]*\)\s*$", "", label)


def figure_time(t: float) -> str:
    """A time (s) for a figure's title or legend: in kyr from 10 000 years, in Myr from a million years (60 000 years
    -> '60 kyr'), else as :func:`~ngs_geomech.scene.units.format_time` ('50 y', '3 d')."""
    years = abs(t) / YEAR
    if years >= 1e6:
        return f"{t / YEAR / 1e6:.4g} Myr"
    if years >= 1e4:
        return f"{t / YEAR / 1e3:.4g} kyr"
    return format_time(t)
