"""Safe arithmetic expressions for space- and time-dependent scene data.

A scene may give a value as a number or as a string such as ``"10 + 0.03*(-y)"`` or
``"1700*exp(-t/(50*year))"``. Allowed names: the coordinates ``x, y, z`` (m), ``r`` (= x in axisymmetric
scenes), the time ``t`` (s), the constants ``pi``, ``year``, ``day``, ``hour`` and the functions listed in
``FUNCTIONS``; material values (:func:`ngs_geomech.scene.schema.material_value`) take ``x, y, z, r`` and, where
the key allows it, the temperature ``T`` (the scene's temperature unit) instead of ``t``. Anything else is refused
with a message naming it. The expression is parsed once with :mod:`ast`; no Python code is evaluated.

Functions of one argument: ``exp, log, sqrt, sin, cos, tan, atan, tanh, sinh, cosh, abs, erf, erfc``. Of several:
``min(a, b, ...)``, ``max(a, b, ...)`` (two or more arguments); the conditional ``if(cond, a, b)`` (``a`` where
``cond`` holds, else ``b``; ``cond`` is one comparison ``p < q``, ``p <= q``, ``p > q`` or ``p >= q``); the
piecewise-linear table ``interp(v, [x0, x1, ...], [y0, y1, ...])`` (abscissae strictly increasing, at most
:data:`MAX_TABLE` points, entries constant; ``y0`` below ``x0``, the last ``y`` above the last ``x``), e.g. a
depth profile ``interp(-y, [0, 1000, 5000], [2.0e3, 2.5e3, 3.0e3])``. Comparisons appear only as the condition of
``if`` and lists only as the tables of ``interp``.

This module has no NGSolve dependency: :func:`check` validates, :func:`compile_expr` turns the tree into
a callable that builds objects from a small namespace (NGSolve coefficient functions or floats).
"""

from __future__ import annotations

import ast
import bisect
import math
import re
from collections.abc import Callable, Mapping, Sequence

from .units import DAY, HOUR, YEAR

VARIABLES = ("x", "y", "z", "r", "t")
"""The variables of scene data (boundary values, sources, initial values): coordinates (m) and time (s)."""
TEMPERATURE = "T"
"""The temperature variable of the material values that may depend on it (degC or K, the scene's unit)."""
ALL_VARIABLES = VARIABLES + (TEMPERATURE,)
CONSTANTS = {"pi": math.pi, "year": YEAR, "day": DAY, "hour": HOUR}
FUNCTIONS = ("exp", "log", "sqrt", "sin", "cos", "tan", "atan", "tanh", "sinh", "cosh", "abs", "erf", "erfc",
             "min", "max", "if", "interp")
ARITY = {"min": (2, None), "max": (2, None), "if": (3, 3), "interp": (3, 3)}
"""(fewest, most) arguments of the functions of several arguments (None: no limit but the expression's size);
the others take one."""
USAGE = {"min": "min(a, b, ...)", "max": "max(a, b, ...)", "if": "if(p < q, a, b) (comparisons <, <=, >, >=)",
         "interp": "interp(v, [x0, x1, ...], [y0, y1, ...])"}
MAX_TABLE = 256
"""Most points of an ``interp`` table."""

_IF = "if_"
"""The internal name of ``if`` (a Python keyword, so ``if(`` is renamed before parsing)."""
_IF_CALL = re.compile(r"(?<![\w.])if(?=\s*\()")
_IF_NAME = re.compile(r"(?<![\w.])if_(?!\w)")
_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}


def _fname(node: ast.Call) -> str:
    """The function name of a call as the user wrote it (``if``, not its internal name)."""
    name = node.func.id if isinstance(node.func, ast.Name) else ""
    return "if" if name == _IF else name


def compare(op: str, a: float, b: float) -> bool:
    """The comparison ``a op b`` of floats (op one of <, <=, >, >=)."""
    return a < b if op == "<" else a <= b if op == "<=" else a > b if op == ">" else a >= b


def interp(v: float, xs: Sequence[float], ys: Sequence[float]) -> float:
    """Piecewise-linear interpolation of the table (xs, ys) at v (xs strictly increasing), ``ys[0]`` for
    ``v <= xs[0]`` and ``ys[-1]`` for ``v > xs[-1]``; on xs[i] < v <= xs[i+1] the value is
    ys[i] + s_i (v - xs[i]) with s_i = (ys[i+1] - ys[i]) / (xs[i+1] - xs[i]) (the arithmetic of the
    CoefficientFunction of :mod:`ngs_geomech.fem.coefficients`)."""
    if not v > xs[0]:
        return ys[0] if v == v else v
    if v > xs[-1]:
        return ys[-1]
    i = bisect.bisect_left(xs, v) - 1
    return ys[i] + (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i]) * (v - xs[i])


def _if(op: str, a: float, b: float, then: Callable[[], float], other: Callable[[], float]) -> float:
    """``if(a op b, then, other)`` with float values: only the branch taken is evaluated (a CoefficientFunction
    selects point by point, so the other branch's value does not matter there)."""
    return then() if compare(op, a, b) else other()


_MATH = {"exp": math.exp, "log": math.log, "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan,
         "atan": math.atan, "tanh": math.tanh, "sinh": math.sinh, "cosh": math.cosh, "abs": abs, "erf": math.erf,
         "erfc": math.erfc, "min": min, "max": max, _IF: _if, "interp": interp}



def _ieee(fn: Callable[[float], float], sign: bool = False) -> Callable[[float], float]:
    """``fn`` returning +-inf where math raises OverflowError (as NGSolve's functions do: 1/(1 + exp(1000)) is
    0 there, a logistic window)."""
    def g(v: float) -> float:
        try:
            return fn(v)
        except OverflowError:
            return math.copysign(math.inf, v) if sign else math.inf
    return g


_IEEE_MATH = dict(_MATH, exp=_ieee(math.exp), sinh=_ieee(math.sinh, sign=True), cosh=_ieee(math.cosh))

_ALLOWED_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Call, ast.Load,
                  ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd, ast.Compare, ast.List,
                  *_COMPARE)


MAX_LENGTH = 10_000
"""Longest expression text, characters."""
MAX_NODES = 2_000
"""Most syntax-tree nodes (numbers, names, operations) of one expression."""
MAX_DEPTH = 200
"""Deepest nesting of operations (the compiled tree is evaluated recursively); a sum of n terms is n
levels deep."""
MAX_EXPONENT = 64
"""Largest |n| of an integer power ``base ** n`` of a non-constant base: NGSolve multiplies ``n`` times."""
LARGEST = 1e308
"""Largest magnitude of a constant (double precision)."""


class _Refused(Exception):
    """A constant sub-expression that has no finite double value; the message says why."""


def short(text: str, n: int = 60) -> str:
    """The text, cut after n characters (messages do not echo a long expression whole)."""
    return text if len(text) <= n else text[:n] + "..."


def parse(text: str) -> ast.Expression:
    """The syntax tree of an expression (``if(`` renamed to its internal name; raises as :func:`ast.parse`)."""
    return ast.parse(_IF_CALL.sub(_IF, text), mode="eval")


def unparse(node: ast.AST) -> str:
    """The text of a sub-expression as the user wrote it (``if``, not its internal name)."""
    return ast.unparse(node).replace(f"{_IF}(", "if(")


def check(text: str, variables: Sequence[str] = VARIABLES) -> list[str]:
    """Return the problems of an expression string (empty list: fine); ``variables``: the names it may use
    (default :data:`VARIABLES`; material values: x, y, z, r and where allowed T).

    The cost is bounded: the text length, the number of tree nodes and the nesting depth are limited before
    anything else is done, and constant sub-expressions are folded with bounded arithmetic (a constant power
    is refused from its logarithm before it is computed; a table of ``interp`` is checked once).
    """
    what = f"expression {short(text)!r}"
    if len(text) > MAX_LENGTH:
        return [f"{what} is {len(text)} characters long (at most {MAX_LENGTH})"]
    try:
        tree = parse(text)
    except SyntaxError as exc:
        return [f"cannot parse {what}: {exc.msg}"]
    except (RecursionError, MemoryError):
        return [f"{what} is too deeply nested (at most {MAX_DEPTH} levels)"]
    except ValueError as exc:       # e.g. a NUL character
        return [f"cannot parse {what}: {exc}"]
    size = _size_problem(tree)
    if size:
        return [f"{what} {size}"]
    problems = _name_problems(tree, what, tuple(variables), bool(_IF_NAME.search(text)))
    if not problems:
        try:
            _fold(tree.body, text)
        except _Refused as exc:
            problems.append(f"{what}: {exc}")
    return problems


def _size_problem(tree: ast.AST) -> str:
    """Why a tree is too large or too deep ('' when it is not); iterative, so any depth is safe."""
    stack, count = [(tree, 0)], 0
    while stack:
        node, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            return f"has more than {MAX_NODES} terms (numbers, names and operations)"
        if depth > MAX_DEPTH:
            return f"is too deeply nested (at most {MAX_DEPTH} levels)"
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return ""


def _name_problems(tree: ast.AST, what: str, variables: tuple, typed_if: bool) -> list[str]:
    """Names and syntax that are not allowed (``typed_if``: the text names the internal ``if_`` itself)."""
    bad: list[str] = []       # what is not allowed, each named once
    misuse: list[str] = []    # allowed functions and comparisons used wrongly (whole sentences)
    unknown: list[str] = ["if_"] if typed_if else []
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    placed = _placed_nodes(tree)      # comparisons and lists where if() and interp() take them
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in FUNCTIONS + (_IF,) and id(node) not in called:
            bad.append(f"function {'if' if node.id == _IF else node.id!r} without an argument")
        elif isinstance(node, ast.Call):
            known = isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS + (_IF,) and node.func.id != "if"
            if known:
                misuse.extend(_call_problems(node))
            else:
                bad.append(f"function {node.func.id!r}" if isinstance(node.func, ast.Name) else "method calls")
        elif isinstance(node, ast.Compare):
            misuse.extend(_compare_problems(node, id(node) in placed))
        elif isinstance(node, ast.List) and id(node) not in placed:
            misuse.append("a list is allowed only as a table of interp(v, [x0, x1, ...], [y0, y1, ...])")
        elif not isinstance(node, (*_ALLOWED_NODES, ast.cmpop)):
            bad.append(f"{type(node).__name__.lower()} syntax")
        elif isinstance(node, ast.Constant) and (isinstance(node.value, bool)
                                                 or not isinstance(node.value, (int, float))):
            bad.append(f"the constant {short(repr(node.value))}")
        elif isinstance(node, ast.Name) and node.id not in variables and node.id not in CONSTANTS \
                and node.id not in FUNCTIONS + (_IF,) and node.id not in unknown:
            unknown.append(node.id)
    problems = []
    if unknown:
        problems.append(f"{what}: unknown name(s) {', '.join(map(repr, unknown))} (variables "
                        f"{', '.join(variables)}; constants {', '.join(CONSTANTS)})")
    if bad:
        problems.append(f"{what}: {', '.join(dict.fromkeys(bad))} not allowed (arithmetic, numbers, the "
                        f"functions {', '.join(f for f in FUNCTIONS if f not in ARITY)} of one argument and "
                        f"{', '.join(USAGE.values())})")
    problems += [f"{what}: {m}" for m in dict.fromkeys(misuse)]
    return problems


def _placed_nodes(tree: ast.AST) -> set[int]:
    """Ids of the comparisons that are the condition of an if() and the lists that are the tables of an
    interp()."""
    placed: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and len(node.args) == 3:
            if node.func.id == _IF:
                placed.add(id(node.args[0]))
            elif node.func.id == "interp":
                placed.update(id(a) for a in node.args[1:] if isinstance(a, ast.List))
    return placed


def _call_problems(node: ast.Call) -> list[str]:
    """What is wrong with a call of a known function: keywords, the number of arguments, a condition that is not
    a comparison, a table that is not a list."""
    name, n = _fname(node), len(node.args)
    usage = USAGE.get(name, name + "(v)")
    if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
        return [f"{name}() takes no keyword or starred arguments: {usage}"]
    lo, hi = ARITY.get(name, (1, 1))
    if n < lo or hi is not None and n > hi:
        count = f"{lo}" if lo == hi else f"at least {lo}"
        return [f"{name}() takes {count} argument{'s' if lo > 1 else ''}, got {n}: {usage}"]
    if name == "if" and not isinstance(node.args[0], ast.Compare):
        return ["the condition of if() must be a comparison: if(p < q, a, b) (<, <=, >, >=)"]
    if name == "interp" and not all(isinstance(a, ast.List) for a in node.args[1:]):
        return ["the tables of interp() must be lists: interp(v, [x0, x1, ...], [y0, y1, ...])"]
    return []


def _compare_problems(node: ast.Compare, placed: bool) -> list[str]:
    if not placed:
        return ["a comparison is allowed only as the condition of if(p < q, a, b)"]
    if len(node.ops) != 1:
        return ["the condition of if() is one comparison (nest if() for more): if(p < q, a, b)"]
    if type(node.ops[0]) not in _COMPARE:
        return ["the condition of if() compares with <, <=, > or >= (==, != and others are not allowed)"]
    return []


def _fold(node: ast.AST, src: str) -> float | None:
    """The value of a constant sub-expression (None when it depends on a variable); raises _Refused for a
    constant without a finite double value (division by zero, overflow, a function outside its domain) and for
    an integer power of a non-constant base above MAX_EXPONENT. Recursive: the depth is bounded by
    :data:`MAX_DEPTH`."""
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, int) and abs(v) > LARGEST or isinstance(v, float) and not math.isfinite(v):
            number = short(ast.get_source_segment(src, node) or str(v), 24)
            raise _Refused(f"the number {number} is too large (at most {LARGEST:g} in magnitude)")
        return float(v)
    if isinstance(node, ast.Name):
        return CONSTANTS.get(node.id)
    if isinstance(node, ast.UnaryOp):
        v = _fold(node.operand, src)
        return None if v is None else -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.Call):
        return _fold_call(node, src)
    a, b = _fold(node.left, src), _fold(node.right, src)
    op = node.op
    if isinstance(op, ast.Div) and b == 0:
        raise _Refused(f"division by zero in {short(unparse(node), 40)!r}")
    if isinstance(op, ast.Pow) and b is not None:
        if a is None:
            if b.is_integer() and abs(b) > MAX_EXPONENT:
                raise _Refused(f"the exponent {b:.10g} in {short(unparse(node), 40)!r} is too large (an "
                               f"integer power of a variable base is at most {MAX_EXPONENT})")
            return None
        return _power(a, b, node)
    if a is None or b is None:
        return None
    v = a + b if isinstance(op, ast.Add) else a - b if isinstance(op, ast.Sub) else \
        a * b if isinstance(op, ast.Mult) else a / b
    if not math.isfinite(v):
        raise _Refused(f"{short(unparse(node), 40)!r} overflows (above {LARGEST:g})")
    return v


def _power(a: float, b: float, node: ast.AST) -> float:
    """The power a ** b of constants, refused before it is computed when it has no finite real value."""
    text = short(unparse(node), 40)
    if a == 0 and b < 0:
        raise _Refused(f"division by zero in {text!r} (0 to a negative power)")
    if a < 0 and not b.is_integer():
        raise _Refused(f"{text!r} is a negative number to a fractional power")
    if a != 0 and b * math.log10(abs(a)) > math.log10(LARGEST):
        raise _Refused(f"{text!r} is too large (about 10^{b * math.log10(abs(a)):.4g}, at most {LARGEST:g})")
    return float(a ** b)


def _fold_call(node: ast.Call, src: str) -> float | None:
    """The value of a constant call (None when an argument depends on a variable); an interp() table is checked
    and an if() condition folded."""
    name = _fname(node)
    if name == "interp":
        xs, ys = table(node, src)
        v = _fold(node.args[0], src)
        return None if v is None else interp(v, xs, ys)
    if name == "if":
        cond = node.args[0]
        a, b = _fold(cond.left, src), _fold(cond.comparators[0], src)
        then, other = _fold(node.args[1], src), _fold(node.args[2], src)
        if a is None or b is None:
            return None
        return then if compare(_COMPARE[type(cond.ops[0])], a, b) else other
    args = [_fold(a, src) for a in node.args]
    return None if any(a is None for a in args) else _call(name, args)


def table(node: ast.Call, src: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The (abscissae, values) of an interp() call, constants; raises _Refused for entries that are not constant,
    tables of different or too small or large sizes, abscissae not strictly increasing."""
    text = short(unparse(node), 40)
    cols = []
    for which, lst in zip(("abscissae", "values"), node.args[1:]):
        vals = [_fold(e, src) for e in lst.elts]
        if any(v is None for v in vals):
            raise _Refused(f"the {which} of {text!r} must be numbers (constants), not expressions of the variables")
        cols.append(tuple(vals))
    xs, ys = cols
    if len(xs) != len(ys):
        raise _Refused(f"the tables of {text!r} have {len(xs)} abscissae and {len(ys)} values (the same number)")
    if not 2 <= len(xs) <= MAX_TABLE:
        raise _Refused(f"the tables of {text!r} have {len(xs)} points (from 2 to {MAX_TABLE})")
    for i in range(1, len(xs)):
        if not xs[i] > xs[i - 1]:
            raise _Refused(f"the abscissae of {text!r} are not strictly increasing ({xs[i - 1]:g} then {xs[i]:g} "
                           f"at positions {i - 1} and {i})")
    for i in range(1, len(xs)):
        if not math.isfinite((ys[i] - ys[i - 1]) / (xs[i] - xs[i - 1])):
            raise _Refused(f"the slope of {text!r} between positions {i - 1} and {i} overflows")
    return xs, ys


def _call(name: str, args: list[float]) -> float:
    """A function of constants, refused where it has no finite value."""
    try:
        r = float(_MATH[name](*args))
    except (ValueError, OverflowError, ZeroDivisionError):
        r = math.nan
    if not math.isfinite(r):
        raise _Refused(f"{name}({', '.join(f'{v:g}' for v in args)}) has no finite value")
    return r


def node_count(text: str) -> int:
    """Syntax-tree nodes of a checked expression (a measure of its evaluation cost)."""
    return sum(1 for _ in ast.walk(parse(text)))


def uses(text: str) -> set[str]:
    """Variables (x, y, z, r, t, T) an expression uses."""
    return {n.id for n in ast.walk(parse(text)) if isinstance(n, ast.Name) and n.id in ALL_VARIABLES}


def compile_expr(text: str, variables: Sequence[str] = VARIABLES) -> Callable[[Mapping[str, object]], object]:
    """Compile a checked expression (its variables among ``variables``) into ``f(namespace)``.

    ``namespace`` maps the variables and function names to objects (floats and math functions, or NGSolve
    CoefficientFunctions and their functions); constants are filled in here. ``if`` is called as
    ``namespace["if_"](op, p, q, then, other)`` with ``op`` one of <, <=, >, >= and the branches as functions of no
    argument; ``interp`` as ``namespace["interp"](v, xs, ys)`` with the tables as tuples of floats.
    """
    problems = check(text, variables)
    if problems:
        raise ValueError("; ".join(problems))
    tree = parse(text)
    tables = {id(n): table(n, text) for n in ast.walk(tree) if isinstance(n, ast.Call) and _fname(n) == "interp"}

    def ev(node, ns):
        if isinstance(node, ast.Expression):
            return ev(node.body, ns)
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            return ns[node.id]
        if isinstance(node, ast.UnaryOp):
            v = ev(node.operand, ns)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.BinOp):
            return _binop(node.op, ev(node.left, ns), ev(node.right, ns))
        if isinstance(node, ast.Call):
            return _call_ns(node, ns)
        raise ValueError(f"unsupported node {node!r}")  # unreachable after check()

    def _call_ns(node, ns):
        name = node.func.id
        if name == _IF:
            c, (_, then, other) = node.args[0], node.args
            return ns[_IF](_COMPARE[type(c.ops[0])], ev(c.left, ns), ev(c.comparators[0], ns),
                           lambda: ev(then, ns), lambda: ev(other, ns))
        if name == "interp":
            return ns["interp"](ev(node.args[0], ns), *tables[id(node)])
        return ns[name](*(ev(a, ns) for a in node.args))

    return lambda ns: ev(tree, ns)


def _binop(op: ast.operator, a, b):
    if isinstance(op, ast.Add):
        return a + b
    if isinstance(op, ast.Sub):
        return a - b
    if isinstance(op, ast.Mult):
        return a * b
    if isinstance(op, ast.Div):
        return a / b
    if isinstance(b, float) and b.is_integer():
        b = int(b)  # NGSolve integrates CF ** 2.0 to NaN where the base is <= 0; CF ** 2 is exact
    return a ** b


def float_function(text: str, variables: Sequence[str] = VARIABLES) -> Callable[..., float]:
    """A checked expression compiled once into ``f(**values) -> float`` (missing variables are 0). Raises
    ValueError (outside a function's domain, or a negative number to a fractional power), ZeroDivisionError or
    OverflowError where the expression has no finite value."""
    compiled = compile_expr(text, variables)

    def f(**values: float) -> float:
        ns: dict[str, object] = {v: 0.0 for v in ALL_VARIABLES}
        ns.update(values)
        ns.update(_IEEE_MATH)
        v = compiled(ns)
        if isinstance(v, complex):
            raise ValueError("a negative number to a fractional power")
        return float(v)
    return f


def evaluate(text: str, variables: Sequence[str] = VARIABLES, **values: float) -> float:
    """Evaluate an expression with float values (missing variables are 0)."""
    return float_function(text, variables)(**values)
