"""A small typed-schema reader: dicts (from TOML or Python) to frozen dataclasses.

Each dataclass field declares its converter in ``metadata["conv"]``. Reading collects every problem
(unknown key with a suggestion, missing key, wrong type, bad value), each named by its dotted path,
instead of stopping at the first.
"""

from __future__ import annotations

import contextvars
import dataclasses
import difflib
import math
from collections.abc import Callable
from typing import Any

from ..errors import Problem
from . import expressions
from .units import parse_time

MISSING = dataclasses.MISSING


class Invalid(ValueError):
    """A value that cannot be converted; the message says why."""


class OutOfRange(Invalid):
    """A value of the right type outside the range declared with its key (:func:`bounded`)."""


_RANGES = contextvars.ContextVar("ranges", default=True)
"""Whether converters check the declared ranges: reading a scene (:func:`read`) converts the types only and keeps
values out of range, so that validation (:func:`recheck`) reports them together with every other problem."""


Conv = Callable[[Any, str, list], Any]


def _label(conv: Conv, what: str, schema: type | None = None, item: Conv | None = None) -> Conv:
    """Attach what a converter accepts (``what``, for the generated key reference), and the schema class
    (``schema``) or item converter (``item``) it reads, so the reference can walk nested tables."""
    conv.what, conv.schema, conv.item = what, schema, item
    return conv


def field(conv: Conv, default: Any = MISSING, doc: str = "") -> Any:
    """A dataclass field with a converter and a docstring (units belong in ``doc``)."""
    md = {"conv": conv, "doc": doc}
    if default is MISSING:
        return dataclasses.field(metadata=md)
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda d=default: type(d)(d), metadata=md)
    if dataclasses.is_dataclass(default):
        return dataclasses.field(default_factory=lambda d=default: dataclasses.replace(d), metadata=md)
    return dataclasses.field(default=default, metadata=md)


# -- leaf converters: raise Invalid ------------------------------------------------------------------

LARGEST = 1e30
"""Largest magnitude of a number in a scene (SI units): well above any physical datum (moduli ~1e12 Pa, a
billion years ~3e16 s), and far enough below the double-precision limit 1e308 that products of data in the forms
(e.g. modulus * expansion * temperature, squared residual norms) stay finite."""

SMALLEST = 1.0 / LARGEST
"""Smallest magnitude of a nonzero number in a scene: a value such as 1e-300 (an element size, a modulus, a time
step) underflows to zero in the products and reciprocals of the forms (h^3, 1/E) and ends in a division by zero
or an overflow; no datum in SI units is that small. Zero itself is allowed where the key allows it."""


def _show(v) -> str:
    """The repr of a value, shortened (a 400-digit integer is not echoed whole)."""
    r = repr(v)
    return r if len(r) <= 40 else f"{r[:24]}... ({len(r)} characters)"


def number(v, path, problems):
    """A finite number of magnitude at most :data:`LARGEST` (integers of any size are compared exactly, before
    a conversion to float could overflow), zero or at least :data:`SMALLEST` in magnitude."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise Invalid(f"expected a number, got {_show(v)}")
    if isinstance(v, float) and not math.isfinite(v):
        raise Invalid(f"value {v!r} is not finite")
    if abs(v) > LARGEST:
        raise Invalid(f"value {_show(v)} is too large (at most {LARGEST:g} in magnitude)")
    if 0 < abs(v) < SMALLEST:
        raise Invalid(f"value {v!r} is too small (a nonzero number is at least {SMALLEST:g} in magnitude; write 0 "
                      "for zero)")
    return float(v)


def at_most(limit: float, unit: str = "") -> Conv:
    """A number of magnitude at most ``limit`` (a physical bound declared with the key; ``unit`` '' for a
    dimensionless number)."""
    u = f" {unit}" if unit else ""

    def conv(v, path, problems):
        if isinstance(v, (int, float)) and not isinstance(v, bool) and not v != v and abs(v) > limit:
            raise Invalid(f"{float(min(abs(v), 1e308)) * (1 if v > 0 else -1):g}{u} is beyond the physical "
                          f"range (magnitude at most {limit:g}{u})")
        return number(v, path, problems)
    return _label(conv, f"number, magnitude at most {limit:g}{u}")


def bounded(conv: Conv, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
            hi_open: bool = False, unit: str = "", note: str = "") -> Conv:
    """``conv`` (a number, integer or time) restricted to a range declared with the key: at least ``lo`` (above it
    when ``lo_open``), at most ``hi`` (below it when ``hi_open``), in ``unit`` ('' dimensionless; the message gives
    the value and the bounds in it); ``note`` says why, after the range."""
    u = f" {unit}" if unit else ""
    if lo is not None and hi is not None:
        rule = f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}{u}"
    elif lo is not None:
        rule = "positive" if lo == 0 and lo_open else f"{'>' if lo_open else '>='} {lo:g}{u}"
    else:
        rule = f"{'<' if hi_open else '<='} {hi:g}{u}"
    suffix = f" {note}" if note else ""

    def c(v, path, problems):
        x = conv(v, path, problems)
        low = lo is not None and (x <= lo if lo_open else x < lo)
        high = hi is not None and (x >= hi if hi_open else x > hi)
        if (low or high) and _RANGES.get():
            raise OutOfRange(f"must be {rule}{suffix}, got {x:g}{u}")
        return x
    return _label(c, f"{conv.what}, {f'> 0{u}' if rule == 'positive' and unit else rule}")


def positive(conv: Conv, unit: str = "") -> Conv:
    """``conv`` above zero (in ``unit``, for the message)."""
    return bounded(conv, 0, lo_open=True, unit=unit)


RELATIVE_TOLERANCE = {"lo": 0, "hi": 1, "lo_open": True, "hi_open": True,
                      "note": "(a relative tolerance: at 1 or above the first iterate already meets it)"}


def integer(v, path, problems):
    if isinstance(v, bool) or not isinstance(v, int):
        raise Invalid(f"expected an integer, got {_show(v)}")
    if abs(v) > 2 ** 53:
        raise Invalid(f"value {_show(v)} is too large (at most 2^53 in magnitude)")
    return int(v)


def string(v, path, problems):
    if not isinstance(v, str):
        raise Invalid(f"expected a string, got {_show(v)}")
    return v


def boolean(v, path, problems):
    if not isinstance(v, bool):
        raise Invalid(f"expected true or false, got {_show(v)}")
    return v


def time(v, path, problems):
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        number(v, path, problems)
    try:
        t = parse_time(v)
    except ValueError as exc:
        raise Invalid(str(exc)) from None
    if abs(t) > LARGEST:
        raise Invalid(f"time {_show(v)} is too large (at most {LARGEST:g} s)")
    if 0 < abs(t) < SMALLEST:
        raise Invalid(f"time {_show(v)} is too small (a nonzero time is at least {SMALLEST:g} s; write 0 for zero)")
    return t


_label(number, "number")
_label(integer, "integer")
_label(string, "string")
_label(boolean, "true or false")
_label(time, "time: s, or a string such as `'10 year'`")


class Expression(str):
    """An expression string read by :func:`expr` (marks it for the value checks of validation)."""


def expr(v, path, problems):
    """A number or an expression string (see :mod:`ngs_geomech.scene.expressions`)."""
    if isinstance(v, bool):
        raise Invalid(f"expected a number or an expression string, got {_show(v)}")
    if isinstance(v, (int, float)):
        return number(v, path, problems)
    if isinstance(v, str):
        msgs = expressions.check(v)
        if msgs:
            raise Invalid("; ".join(msgs))
        return Expression(v)
    raise Invalid(f"expected a number or an expression string, got {_show(v)}")


_label(expr, "number or expression")


MATERIAL_VARIABLES = ("x", "y", "z", "r")
"""The variables of a material value: the coordinates (m; r = x in axisymmetric scenes)."""


def material_value(conv: Conv, *, temperature: bool = False) -> Conv:
    """A material value: a number that ``conv`` accepts (with the range declared there), or an expression string
    of x, y, z, r and, with ``temperature``, of the temperature T (degC or K, the scene's unit), read as
    :class:`Expression`. The number path is the number path (nothing changes for a scene of numbers); an expression
    becomes a CoefficientFunction per region (:func:`ngs_geomech.fem.coefficients.material_cf`) and validation
    samples it over its region (and T over the temperatures the region takes) against the same declared range
    (:mod:`ngs_geomech.validation.material_values`)."""
    variables = MATERIAL_VARIABLES + ((expressions.TEMPERATURE,) if temperature else ())

    def c(v, path, problems):
        if isinstance(v, str):
            msgs = expressions.check(v, variables)
            if msgs:
                raise Invalid("; ".join(msgs))
            return Expression(v)
        return conv(v, path, problems)
    c.variables = variables
    return _label(c, f"{conv.what}; or an expression of {', '.join(variables)}")


def constant(conv: Conv, why: str) -> Conv:
    """``conv`` (a number converter) for a key that takes no expression: a string is refused saying ``why``."""
    def c(v, path, problems):
        if isinstance(v, str):
            raise Invalid(f"takes a number, not the expression {expressions.short(v)!r}: {why}")
        return conv(v, path, problems)
    return _label(c, conv.what)


def holds_expression(v) -> bool:
    """Whether a value is an expression (an :class:`Expression`, or a string in an object built in Python) or a
    list (matrix) holding one."""
    return isinstance(v, str) or isinstance(v, (list, tuple)) and any(holds_expression(e) for e in v)


def varying_keys(obj: Any, keys: tuple[str, ...] | None = None) -> list[str]:
    """The fields of a schema object (among ``keys``; default all) whose value holds an expression, in the order
    of the fields; a nested table (e.g. ``orthotropic``) counts as its key."""
    out = []
    for f in dataclasses.fields(obj):
        if keys is not None and f.name not in keys:
            continue
        v = getattr(obj, f.name)
        if holds_expression(v) or dataclasses.is_dataclass(v) and varying_keys(v):
            out.append(f.name)
    return out


def material_at(obj: Any, keys, functions: dict, values: dict) -> Any:
    """The schema object with the expressions of ``keys`` replaced by their values at ``values`` (x, y, z, r, T),
    also inside lists and nested tables; ``functions`` caches the compiled expressions. Raises ArithmeticError /
    ValueError where one has no (finite) value."""
    def sub(v):
        if isinstance(v, str):
            f = functions.get(v)
            if f is None:
                f = functions[v] = expressions.float_function(v, expressions.ALL_VARIABLES)
            r = f(**values)
            if not math.isfinite(r):
                raise ArithmeticError(f"value {r}")
            return r
        if isinstance(v, (list, tuple)):
            return [sub(e) for e in v]
        if dataclasses.is_dataclass(v):
            return material_at(v, varying_keys(v), functions, values)
        return v
    return dataclasses.replace(obj, **{k: sub(getattr(obj, k)) for k in keys})


def one_of(*choices: str) -> Conv:
    def conv(v, path, problems):
        if v not in choices:
            hint = difflib.get_close_matches(str(v), choices, n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise Invalid(f"{_show(v)} is not one of {', '.join(map(repr, choices))}{extra}")
        return v
    return _label(conv, "one of " + ", ".join(f"`{c!r}`" for c in choices))


def optional(conv: Conv) -> Conv:
    def c(v, path, problems):
        return None if v is None else conv(v, path, problems)
    if hasattr(conv, "variables"):
        c.variables = conv.variables
    return _label(c, getattr(conv, "what", "?"), getattr(conv, "schema", None), getattr(conv, "item", None))


def list_of(conv: Conv, length: int | None = None) -> Conv:
    def c(v, path, problems):
        if not isinstance(v, (list, tuple)):
            raise Invalid(f"expected a list, got {_show(v)}")
        if length is not None and len(v) != length:
            raise Invalid(f"expected a list of {length} items, got {len(v)}")
        out = []
        for i, item in enumerate(v):
            r = convert(conv, item, f"{path}[{i}]", problems)
            out.append(r)
        return out
    n = f" {length}" if length is not None else ""
    return _label(c, f"list of{n} {_plural(conv)}", item=conv)


def dict_of(conv: Conv) -> Conv:
    def c(v, path, problems):
        if not isinstance(v, dict):
            raise Invalid(f"expected a table, got {_show(v)}")
        return {str(k): convert(conv, item, f"{path}.{k}", problems) for k, item in v.items()}
    return _label(c, f"table of {_plural(conv)} by name", item=conv)


def either(*convs: Conv, what: str) -> Conv:
    def c(v, path, problems):
        why = []          # messages other than a type mismatch: the value has the right type but is refused
        for conv in convs:
            try:
                sub: list = []
                r = conv(v, path, sub)
                if not sub:
                    return r
            except Invalid as exc:
                if not str(exc).startswith("expected "):
                    why.append(str(exc))
                continue
        raise Invalid(why[0] if why else f"expected {what}, got {_show(v)}")
    return _label(c, what)


def nested(cls: type) -> Conv:
    def c(v, path, problems):
        return read(cls, v, path, problems)
    return _label(c, "table", schema=cls)


def _plural(conv: Conv) -> str:
    what = getattr(conv, "what", "?")
    return {"number": "numbers", "integer": "integers", "string": "strings", "table": "tables"}.get(what, what)


def convert(conv: Conv, value: Any, path: str, problems: list) -> Any:
    """Apply a converter; on failure record a Problem and return None."""
    try:
        return conv(value, path, problems)
    except Invalid as exc:
        problems.append(Problem(path, str(exc)))
        return None


def read(cls: type, data: Any, path: str, problems: list[Problem]) -> Any:
    """Build ``cls`` from ``data`` (a dict), appending problems; returns None when not a table. The declared
    ranges are not checked here but by :func:`recheck` (validation), with every other problem of the scene."""
    token = _RANGES.set(False)
    try:
        return _read(cls, data, path, problems)
    finally:
        _RANGES.reset(token)


def _read(cls: type, data: Any, path: str, problems: list[Problem]) -> Any:
    if dataclasses.is_dataclass(data) and isinstance(data, cls):
        return data
    if not isinstance(data, dict):
        problems.append(Problem(path or "scene", f"expected a table, got {data!r}"))
        return None
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for key in data:
        if key not in fields:
            hint = difflib.get_close_matches(key, list(fields), n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else f" (known keys: {', '.join(fields)})"
            problems.append(Problem(_join(path, key), f"unknown key{extra}"))
    for name, f in fields.items():
        p = _join(path, name)
        if name in data:
            kwargs[name] = convert(f.metadata["conv"], data[name], p, problems)
            if kwargs[name] is None and f.default is not MISSING:
                kwargs[name] = f.default
            elif kwargs[name] is None and f.default_factory is not MISSING:
                kwargs[name] = f.default_factory()
        elif f.default is MISSING and f.default_factory is MISSING:
            problems.append(Problem(p, "required key is missing"))
            kwargs[name] = None
    return cls(**kwargs)


def recheck(obj: Any, path: str, problems: list[Problem]) -> None:
    """Apply the declared converters again to the values of a schema object, appending problems: a scene built
    in Python from the dataclasses (not read from TOML by :func:`read`) meets the same declared types and ranges."""
    for f in dataclasses.fields(obj):
        _recheck_field(obj, f, path, problems)


def first_problem(obj: Any, names: tuple[str, ...]) -> Problem | None:
    """The first problem of :func:`recheck` among the fields ``names`` of a schema object, its item relative to
    the object (e.g. ``youngs_modulus``, ``orthotropic.E[1]``); None when their values meet their declarations. The
    physics reads a schema object through it, so that data given in Python meets the declared types and ranges."""
    problems: list[Problem] = []
    fields = {f.name: f for f in dataclasses.fields(obj)}
    for name in names:
        _recheck_field(obj, fields[name], "", problems)
        if problems:
            return problems[0]
    return None


def _recheck_field(obj: Any, f: dataclasses.Field, path: str, problems: list[Problem]) -> None:
    value, p = getattr(obj, f.name), _join(path, f.name)
    if value is None:
        return
    if dataclasses.is_dataclass(value):
        recheck(value, p, problems)
    elif isinstance(value, list) and value and all(dataclasses.is_dataclass(v) for v in value):
        for i, v in enumerate(value):
            recheck(v, f"{p}[{i}]", problems)
    elif isinstance(value, dict) and value and all(dataclasses.is_dataclass(v) for v in value.values()):
        for k, v in value.items():
            recheck(v, f"{p}.{k}", problems)
    else:
        convert(f.metadata["conv"], value, p, problems)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def to_dict(obj: Any) -> Any:
    """Plain-data form of a schema object (for summaries), omitting None values."""
    if dataclasses.is_dataclass(obj):
        return {f.name: to_dict(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                if getattr(obj, f.name) is not None}
    if isinstance(obj, dict):
        return {k: to_dict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_dict(v) for v in obj]
    return obj
