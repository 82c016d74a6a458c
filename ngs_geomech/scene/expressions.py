"""Safe arithmetic expressions for space- and time-dependent scene data.

A scene may give a value as a number or as a string such as ``"10 + 0.03*(-y)"`` or
``"1700*exp(-t/(50*year))"``. Allowed names: the coordinates ``x, y, z`` (m), ``r`` (= x in axisymmetric
scenes), the time ``t`` (s), the constants ``pi``, ``year``, ``day``, ``hour`` and the functions listed in
``FUNCTIONS``. Anything else is refused with a message naming it. The expression is parsed once with
:mod:`ast`; no Python code is evaluated.

This module has no NGSolve dependency: :func:`check` validates, :func:`compile_expr` turns the tree into
a callable that builds objects from a small namespace (NGSolve coefficient functions or floats).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping

from .units import DAY, HOUR, YEAR

VARIABLES = ("x", "y", "z", "r", "t")
CONSTANTS = {"pi": math.pi, "year": YEAR, "day": DAY, "hour": HOUR}
FUNCTIONS = ("exp", "log", "sqrt", "sin", "cos", "tan", "atan", "tanh", "sinh", "cosh", "abs", "erf")

_MATH = {"exp": math.exp, "log": math.log, "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan,
         "atan": math.atan, "tanh": math.tanh, "sinh": math.sinh, "cosh": math.cosh, "abs": abs, "erf": math.erf}



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
                  ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd)


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


def check(text: str) -> list[str]:
    """Return the problems of an expression string (empty list: fine).

    The cost is bounded: the text length, the number of tree nodes and the nesting depth are limited before
    anything else is done, and constant sub-expressions are folded with bounded arithmetic (a constant power
    is refused from its logarithm before it is computed).
    """
    what = f"expression {short(text)!r}"
    if len(text) > MAX_LENGTH:
        return [f"{what} is {len(text)} characters long (at most {MAX_LENGTH})"]
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        return [f"cannot parse {what}: {exc.msg}"]
    except (RecursionError, MemoryError):
        return [f"{what} is too deeply nested (at most {MAX_DEPTH} levels)"]
    except ValueError as exc:       # e.g. a NUL character
        return [f"cannot parse {what}: {exc}"]
    size = _size_problem(tree)
    if size:
        return [f"{what} {size}"]
    problems = _name_problems(tree, what)
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


def _name_problems(tree: ast.AST, what: str) -> list[str]:
    """Names and syntax that are not allowed."""
    bad: list[str] = []       # what is not allowed, each named once
    unknown: list[str] = []
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in FUNCTIONS and id(node) not in called:
            bad.append(f"function {node.id!r} without an argument")
        elif isinstance(node, ast.Call):
            if not (isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS) or node.keywords \
                    or len(node.args) != 1:
                bad.append(f"function {node.func.id!r}" if isinstance(node.func, ast.Name) else "method calls")
        elif not isinstance(node, _ALLOWED_NODES):
            bad.append(f"{type(node).__name__.lower()} syntax")
        elif isinstance(node, ast.Constant) and (isinstance(node.value, bool)
                                                 or not isinstance(node.value, (int, float))):
            bad.append(f"the constant {short(repr(node.value))}")
        elif isinstance(node, ast.Name) and node.id not in VARIABLES and node.id not in CONSTANTS \
                and node.id not in FUNCTIONS and node.id not in unknown:
            unknown.append(node.id)
    problems = []
    if unknown:
        problems.append(f"{what}: unknown name(s) {', '.join(map(repr, unknown))} (variables "
                        f"{', '.join(VARIABLES)}; constants {', '.join(CONSTANTS)})")
    if bad:
        problems.append(f"{what}: {', '.join(dict.fromkeys(bad))} not allowed (arithmetic, "
                        f"numbers and the functions {', '.join(FUNCTIONS)} with one argument)")
    return problems


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
        v = _fold(node.args[0], src)
        return None if v is None else _call(node.func.id, v)
    a, b = _fold(node.left, src), _fold(node.right, src)
    op = node.op
    if isinstance(op, ast.Div) and b == 0:
        raise _Refused(f"division by zero in {short(ast.unparse(node), 40)!r}")
    if isinstance(op, ast.Pow) and b is not None:
        if a is None:
            if b.is_integer() and abs(b) > MAX_EXPONENT:
                raise _Refused(f"the exponent {b:.10g} in {short(ast.unparse(node), 40)!r} is too large (an "
                               f"integer power of a variable base is at most {MAX_EXPONENT})")
            return None
        return _power(a, b, node)
    if a is None or b is None:
        return None
    v = a + b if isinstance(op, ast.Add) else a - b if isinstance(op, ast.Sub) else \
        a * b if isinstance(op, ast.Mult) else a / b
    if not math.isfinite(v):
        raise _Refused(f"{short(ast.unparse(node), 40)!r} overflows (above {LARGEST:g})")
    return v


def _power(a: float, b: float, node: ast.AST) -> float:
    """The power a ** b of constants, refused before it is computed when it has no finite real value."""
    text = short(ast.unparse(node), 40)
    if a == 0 and b < 0:
        raise _Refused(f"division by zero in {text!r} (0 to a negative power)")
    if a < 0 and not b.is_integer():
        raise _Refused(f"{text!r} is a negative number to a fractional power")
    if a != 0 and b * math.log10(abs(a)) > math.log10(LARGEST):
        raise _Refused(f"{text!r} is too large (about 10^{b * math.log10(abs(a)):.4g}, at most {LARGEST:g})")
    return float(a ** b)


def _call(name: str, v: float) -> float:
    """A function of a constant, refused where it has no finite value."""
    try:
        r = float(_MATH[name](v))
    except (ValueError, OverflowError, ZeroDivisionError):
        r = math.nan
    if not math.isfinite(r):
        raise _Refused(f"{name}({v:g}) has no finite value")
    return r


def node_count(text: str) -> int:
    """Syntax-tree nodes of a checked expression (a measure of its evaluation cost)."""
    return sum(1 for _ in ast.walk(ast.parse(text, mode="eval")))


def uses(text: str) -> set[str]:
    """Variables (x, y, z, r, t) an expression uses."""
    tree = ast.parse(text, mode="eval")
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id in VARIABLES}


def compile_expr(text: str) -> Callable[[Mapping[str, object]], object]:
    """Compile a checked expression into ``f(namespace)``.

    ``namespace`` maps the variables and function names to objects (floats and math functions, or NGSolve
    CoefficientFunctions and ngsolve functions); constants are filled in here.
    """
    problems = check(text)
    if problems:
        raise ValueError("; ".join(problems))
    tree = ast.parse(text, mode="eval")

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
            a, b = ev(node.left, ns), ev(node.right, ns)
            op = node.op
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
        if isinstance(node, ast.Call):
            return ns[node.func.id](ev(node.args[0], ns))
        raise ValueError(f"unsupported node {node!r}")  # unreachable after check()

    return lambda ns: ev(tree, ns)


def float_function(text: str) -> Callable[..., float]:
    """A checked expression compiled once into ``f(**values) -> float`` (missing variables are 0). Raises
    ValueError (outside a function's domain, or a negative number to a fractional power), ZeroDivisionError or
    OverflowError where the expression has no finite value."""
    compiled = compile_expr(text)

    def f(**values: float) -> float:
        ns: dict[str, object] = {v: 0.0 for v in VARIABLES}
        ns.update(values)
        ns.update(_IEEE_MATH)
        v = compiled(ns)
        if isinstance(v, complex):
            raise ValueError("a negative number to a fractional power")
        return float(v)
    return f


def evaluate(text: str, **values: float) -> float:
    """Evaluate an expression with float values (missing variables are 0)."""
    return float_function(text)(**values)
