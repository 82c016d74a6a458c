"""Coefficient functions from scene data: region-wise values and space-time expressions."""

from __future__ import annotations

from collections.abc import Callable

import ngsolve as ngs

from ..scene import expressions

TimeFunction = Callable[[object], object]
"""A factory ``make(t) -> CoefficientFunction`` for data that may depend on time ``t`` (a Parameter).

Plain callables are treated as time dependent (their load vectors are assembled at every step). The
factories made here carry what lets the forms assemble less: :class:`Steady` (no t) and :class:`Separable`
(a fixed field times a scalar function of time, e.g. a decaying canister power).
"""


class Steady:
    """A TimeFunction that does not depend on t: its load vector is assembled once."""

    time_dependent = False

    def __init__(self, make: Callable[[object], object]):
        self.make = make

    def __call__(self, t):
        return self.make(t)


class Separable:
    """``spatial * scale(t)``: the load vector of ``spatial`` (a CF) is assembled once and scaled each step.

    ``scale(t)`` is a float function (used for the vectors), ``scale_cf(t)`` the same law for a Parameter t.
    """

    time_dependent = False

    def __init__(self, spatial, scale: Callable[[float], float], scale_cf: Callable[[object], object]):
        self.spatial = spatial
        self.scale = scale
        self.scale_cf = scale_cf

    def __call__(self, t):
        return self.spatial * self.scale_cf(t)


# tanh as 1 - 2/(exp(2v) + 1): finite for every v (exp overflows to inf, 2/inf = 0); the quotient
# (exp(2v) - 1)/(exp(2v) + 1) was inf/inf = NaN for v > ~355
_NS_FUNCS = {"exp": ngs.exp, "log": ngs.log, "sqrt": ngs.sqrt, "sin": ngs.sin, "cos": ngs.cos,
             "tan": ngs.tan, "atan": ngs.atan, "tanh": lambda v: 1 - 2 / (ngs.exp(2 * v) + 1),
             "sinh": lambda v: (ngs.exp(v) - ngs.exp(-v)) / 2, "cosh": lambda v: (ngs.exp(v) + ngs.exp(-v)) / 2,
             "abs": lambda v: ngs.IfPos(v, v, -v), "erf": ngs.erf if hasattr(ngs, "erf") else None}


def expression_function(value: float | str) -> TimeFunction:
    """A TimeFunction from a number or an expression in x, y, z, r, t (see :mod:`ngs_geomech.scene.expressions`)."""
    if isinstance(value, (int, float)):
        v = float(value)
        return Steady(lambda t: ngs.CoefficientFunction(v))
    compiled = expressions.compile_expr(value)

    def make(t):
        ns = dict(_NS_FUNCS, x=ngs.x, y=ngs.y, z=ngs.z, r=ngs.x, t=t)
        return ngs.CoefficientFunction(compiled(ns))
    return make if "t" in expressions.uses(value) else Steady(make)


def region_cf(mesh, values: dict[str, object], default: float = 0.0):
    """One CoefficientFunction that takes ``values[region]`` in each region (keys are exact region names)."""
    return mesh.MaterialCF({name: v for name, v in values.items()}, default=default)


def boundary_cf(mesh, values: dict[str, object], default: float = 0.0):
    """One CoefficientFunction that takes ``values[name]`` on each named boundary."""
    return mesh.BoundaryCF({name: v for name, v in values.items()}, default=default)


def regions_regex(names) -> str:
    """A netgen region pattern matching exactly the given names."""
    return "|".join(sorted(names))
