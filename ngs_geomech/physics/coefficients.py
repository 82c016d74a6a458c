"""Coefficient functions from scene data: region-wise values and space-time expressions."""

from __future__ import annotations

from collections.abc import Callable

import ngsolve as ngs

from .. import expressions

TimeFunction = Callable[[object], object]
"""A factory ``make(t) -> CoefficientFunction`` for data that may depend on time ``t`` (a Parameter)."""

_NS_FUNCS = {"exp": ngs.exp, "log": ngs.log, "sqrt": ngs.sqrt, "sin": ngs.sin, "cos": ngs.cos,
             "tan": ngs.tan, "atan": ngs.atan, "tanh": lambda v: (ngs.exp(2 * v) - 1) / (ngs.exp(2 * v) + 1),
             "sinh": lambda v: (ngs.exp(v) - ngs.exp(-v)) / 2, "cosh": lambda v: (ngs.exp(v) + ngs.exp(-v)) / 2,
             "abs": lambda v: ngs.IfPos(v, v, -v), "erf": ngs.erf if hasattr(ngs, "erf") else None}


def expression_function(value: float | str) -> TimeFunction:
    """A TimeFunction from a number or an expression in x, y, z, r, t (see :mod:`ngs_geomech.expressions`)."""
    if isinstance(value, (int, float)):
        v = float(value)
        return lambda t: ngs.CoefficientFunction(v)
    compiled = expressions.compile_expr(value)
    if "erf" in value and _NS_FUNCS["erf"] is None:
        raise ValueError(f"expression {value!r}: erf is not available in this NGSolve")

    def make(t):
        ns = dict(_NS_FUNCS, x=ngs.x, y=ngs.y, z=ngs.z, r=ngs.x, t=t)
        return ngs.CoefficientFunction(compiled(ns))
    return make


def region_cf(mesh, values: dict[str, object], default: float = 0.0):
    """One CoefficientFunction that takes ``values[region]`` in each region (keys are exact region names)."""
    return mesh.MaterialCF({name: v for name, v in values.items()}, default=default)


def boundary_cf(mesh, values: dict[str, object], default: float = 0.0):
    """One CoefficientFunction that takes ``values[name]`` on each named boundary."""
    return mesh.BoundaryCF({name: v for name, v in values.items()}, default=default)


def regions_regex(names) -> str:
    """A netgen region pattern matching exactly the given names."""
    return "|".join(sorted(names))
