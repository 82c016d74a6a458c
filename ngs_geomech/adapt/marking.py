"""Marking strategies and stopping rules of the adaptive loop (plain numpy; no NGSolve).

Markers take the element estimates eta_T (any units, one per volume element) and a parameter theta in (0, 1]
and return a boolean array of the elements to refine:

* ``doerfler`` (bulk chasing, Doerfler 1996): the smallest set M of the largest eta_T with
  sum_M eta_T^2 >= theta sum_T eta_T^2 (ties at the threshold included);
* ``maximum``: every element with eta_T >= theta max eta_T;
* ``uniform``: every element (uniform refinement through the same loop, for comparisons).

They are chosen by name from :data:`MARKERS` (:func:`get_marker`). :class:`StopRule` stops the loop at a
tolerance on the estimated error, at a dof budget or after a number of refinements.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

MARKERS: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {}
"""The registry: name -> marker(eta, theta) -> bool array (filled by :func:`register_marker`)."""


def register_marker(name: str):
    """Decorator: register a marker under ``name``."""
    def wrap(fn):
        MARKERS[name] = fn
        return fn
    return wrap


def get_marker(name: str) -> Callable[[np.ndarray, float], np.ndarray]:
    """The registered marker ``name``; a ValueError naming the known ones (and the closest) otherwise."""
    if name in MARKERS:
        return MARKERS[name]
    close = difflib.get_close_matches(name, list(MARKERS), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise ValueError(f"unknown marker {name!r}{hint}; known: {', '.join(sorted(MARKERS))}")


def _check_theta(theta: float) -> float:
    theta = float(theta)
    if not 0.0 < theta <= 1.0:
        raise ValueError(f"the marking parameter theta must lie in (0, 1], got {theta}")
    return theta


@register_marker("doerfler")
def doerfler(eta: np.ndarray, theta: float = 0.5) -> np.ndarray:
    """Bulk (Doerfler) marking: the fewest largest elements carrying the fraction ``theta`` of sum eta_T^2."""
    theta = _check_theta(theta)
    e2 = np.asarray(eta, dtype=float) ** 2
    marks = np.zeros(e2.shape, dtype=bool)
    total = float(e2.sum())
    if total <= 0.0:
        return marks
    order = np.argsort(-e2, kind="stable")
    cum = np.cumsum(e2[order])
    k = int(np.searchsorted(cum, theta * total * (1 - 1e-12))) + 1
    threshold = e2[order[min(k, len(order)) - 1]]
    marks[e2 >= threshold] = True
    return marks


@register_marker("maximum")
def maximum(eta: np.ndarray, theta: float = 0.5) -> np.ndarray:
    """Maximum strategy: the elements with eta_T >= theta max eta_T."""
    theta = _check_theta(theta)
    eta = np.asarray(eta, dtype=float)
    top = float(eta.max()) if eta.size else 0.0
    if top <= 0.0:
        return np.zeros(eta.shape, dtype=bool)
    return eta >= theta * top


@register_marker("uniform")
def uniform(eta: np.ndarray, theta: float = 1.0) -> np.ndarray:
    """Every element (uniform refinement)."""
    return np.ones(np.asarray(eta).shape, dtype=bool)


@dataclass(frozen=True)
class StopRule:
    """When the adaptive loop stops: at ``tolerance`` (the estimated error, in the estimator's units, e.g. an
    absolute energy-norm error), when the next mesh would exceed ``max_dofs`` (a dof budget: the loop stops
    before refining once ndof x ``growth`` > max_dofs, growth being the last step's dof ratio), or after
    ``max_refinements`` refinements. None switches a rule off."""

    tolerance: float | None = None
    max_dofs: int | None = None
    max_refinements: int | None = 20

    def reason(self, estimate: float, ndof: int, refinements: int, growth: float = 1.0) -> str | None:
        """Why the loop stops now ("tolerance", "dof budget", "refinements"), or None to go on."""
        if self.tolerance is not None and estimate <= self.tolerance:
            return "tolerance"
        if self.max_dofs is not None and (ndof >= self.max_dofs or ndof * max(growth, 1.0) > self.max_dofs):
            return "dof budget"
        if self.max_refinements is not None and refinements >= self.max_refinements:
            return "refinements"
        return None
