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

_ALLOWED_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Call, ast.Load,
                  ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd)


def check(text: str) -> list[str]:
    """Return the problems of an expression string (empty list: fine)."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        return [f"cannot parse expression {text!r}: {exc.msg}"]
    bad: list[str] = []       # what is not allowed, each named once
    unknown: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            if not (isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS) or node.keywords \
                    or len(node.args) != 1:
                bad.append(f"function {node.func.id!r}" if isinstance(node.func, ast.Name) else "method calls")
        elif not isinstance(node, _ALLOWED_NODES):
            bad.append(f"{type(node).__name__.lower()} syntax")
        elif isinstance(node, ast.Constant) and not isinstance(node.value, (int, float)):
            bad.append(f"the constant {node.value!r}")
        elif isinstance(node, ast.Name) and node.id not in VARIABLES and node.id not in CONSTANTS \
                and node.id not in FUNCTIONS and node.id not in unknown:
            unknown.append(node.id)
    problems = []
    if unknown:
        problems.append(f"expression {text!r}: unknown name(s) {', '.join(map(repr, unknown))} (variables "
                        f"{', '.join(VARIABLES)}; constants {', '.join(CONSTANTS)})")
    if bad:
        problems.append(f"expression {text!r}: {', '.join(dict.fromkeys(bad))} not allowed (arithmetic, "
                        f"numbers and the functions {', '.join(FUNCTIONS)} with one argument)")
    return problems


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


def evaluate(text: str, **values: float) -> float:
    """Evaluate an expression with float values (missing variables are 0)."""
    ns: dict[str, object] = {v: 0.0 for v in VARIABLES}
    ns.update(values)
    ns.update({"exp": math.exp, "log": math.log, "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos,
               "tan": math.tan, "atan": math.atan, "tanh": math.tanh, "sinh": math.sinh,
               "cosh": math.cosh, "abs": abs, "erf": math.erf})
    return float(compile_expr(text)(ns))
