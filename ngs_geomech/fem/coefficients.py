"""Coefficient functions from scene data: region-wise values and space-time expressions."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache, reduce

import ngsolve as ngs
import numpy as np

from ..scene import expressions

MATERIAL_VARIABLES = ("x", "y", "z", "r", expressions.TEMPERATURE)
"""What a material value may depend on (:func:`ngs_geomech.scene.schema.material_value`)."""

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


def _cf(v):
    """A CoefficientFunction of a float or a CoefficientFunction (IfPos takes a CF condition)."""
    return v if isinstance(v, ngs.CoefficientFunction) else ngs.CoefficientFunction(float(v))


def cf_min(*args):
    """The smallest of two or more CFs (pairwise IfPos: the derivative is that of the smaller argument)."""
    return reduce(lambda p, q: ngs.IfPos(_cf(p) - q, q, p), args)


def cf_max(*args):
    """The largest of two or more CFs."""
    return reduce(lambda p, q: ngs.IfPos(_cf(p) - q, p, q), args)


def cf_if(op: str, p, q, then: Callable[[], object], other: Callable[[], object]):
    """``if(p op q, then, other)`` as one IfPos, exact at p = q: p < q holds where q - p > 0, p <= q fails where
    p - q > 0 (op one of <, <=, >, >=; ``then``, ``other`` make the branches)."""
    if op == "<":
        return ngs.IfPos(_cf(q) - p, then(), other())
    if op == ">":
        return ngs.IfPos(_cf(p) - q, then(), other())
    if op == "<=":
        return ngs.IfPos(_cf(p) - q, other(), then())
    return ngs.IfPos(_cf(q) - p, other(), then())


def cf_interp(v, xs: Sequence[float], ys: Sequence[float]):
    """Piecewise-linear interpolation of the table (xs, ys) at the CF v, constant beyond the ends, as nested
    IfPos pieces ys[i] + s_i (v - xs[i]) (the arithmetic of :func:`ngs_geomech.scene.expressions.interp`);
    its derivative in v is the slope s_i of the piece (0 beyond the ends)."""
    v = _cf(v)
    out = _cf(ys[-1])
    for i in range(len(xs) - 2, -1, -1):
        slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])
        out = ngs.IfPos(v - xs[i + 1], out, ys[i] + slope * (v - xs[i]))
    return ngs.IfPos(v - xs[0], out, ys[0])


# tanh as 1 - 2/(exp(2v) + 1): finite for every v (exp overflows to inf, 2/inf = 0); the quotient
# (exp(2v) - 1)/(exp(2v) + 1) was inf/inf = NaN for v > ~355
_NS_FUNCS = {"exp": ngs.exp, "log": ngs.log, "sqrt": ngs.sqrt, "sin": ngs.sin, "cos": ngs.cos,
             "tan": ngs.tan, "atan": ngs.atan, "tanh": lambda v: 1 - 2 / (ngs.exp(2 * v) + 1),
             "sinh": lambda v: (ngs.exp(v) - ngs.exp(-v)) / 2, "cosh": lambda v: (ngs.exp(v) + ngs.exp(-v)) / 2,
             "abs": lambda v: ngs.IfPos(v, v, -v), "erf": ngs.erf, "erfc": lambda v: 1 - ngs.erf(v),
             "min": cf_min, "max": cf_max, "if_": cf_if, "interp": cf_interp}
"""NGSolve forms of the expression functions (:data:`ngs_geomech.scene.expressions.FUNCTIONS`). erfc is 1 - erf:
accurate to about 1e-16 absolutely (relatively worse where erfc is below ~1e-5, x > 3)."""


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


@lru_cache(maxsize=256)
def _material_expression(text: str):
    return expressions.compile_expr(text, MATERIAL_VARIABLES)


def material_cf(value, T=None):
    """A material value (:func:`ngs_geomech.scene.schema.material_value`) as a CoefficientFunction: a number, or an
    expression of x, y, z, r (= x) and T; ``T`` is what stands for the temperature (a GridFunction, a trial
    function, any CF of it). ValueError for an expression of T without ``T``."""
    if not isinstance(value, str):
        return ngs.CoefficientFunction(float(value))
    compiled = _material_expression(str(value))
    if T is None and expressions.TEMPERATURE in expressions.uses(value):
        raise ValueError(f"the material value {expressions.short(value)!r} depends on T: the temperature is needed")
    ns = dict(_NS_FUNCS, x=ngs.x, y=ngs.y, z=ngs.z, r=ngs.x, T=T if T is not None else ngs.CoefficientFunction(0.0))
    return _cf(compiled(ns))


def tensor_cf(entries, T=None):
    """A square matrix of material values (a float array: one constant CF as before; an object array of floats and
    expressions: a CF of its entries' CFs)."""
    dim = len(entries)
    if getattr(entries, "dtype", None) is not np.dtype(object):
        return ngs.CoefficientFunction(tuple(entries.flatten()), dims=(dim, dim))
    return ngs.CoefficientFunction(tuple(material_cf(e, T) for e in entries.flat), dims=(dim, dim))


def region_cf(mesh, values: dict[str, object], default: float = 0.0):
    """One CoefficientFunction that takes ``values[region]`` in each region (keys are exact region names)."""
    return mesh.MaterialCF({name: v for name, v in values.items()}, default=default)


def boundary_cf(mesh, values: dict[str, object], default: float = 0.0):
    """One CoefficientFunction that takes ``values[name]`` on each named boundary."""
    return mesh.BoundaryCF({name: v for name, v in values.items()}, default=default)


def regions_regex(names) -> str:
    """A netgen region pattern matching exactly the given names."""
    return "|".join(sorted(names))
