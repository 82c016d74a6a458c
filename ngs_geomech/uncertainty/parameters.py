"""The admissible set of uncertain data: parameters known in intervals, mapped from the unit cube.

A point of the unit cube ``z`` in [0, 1]^d is the common coordinate of every method: the worst-scenario search
works on the box itself (value = lower + z (upper - lower)); the stochastic modes read ``z`` as the uniform
variates of the inverse-CDF transform of each parameter's distribution (truncated to its interval). A parameter
sets one or more scene items (``--set`` paths); with ``scale = "factor"`` each item becomes its own scene value
times the parameter (an expression item ``e`` becomes ``(e)*factor``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..errors import Problem, SceneError
from ..scene.model import UncertainParameter, Uncertainty
from ..scene.parse import child_table


@dataclass(frozen=True)
class Parameter:
    """One uncertain parameter with its items' scene values and its distribution (a frozen scipy law whose
    support is the interval)."""

    spec: UncertainParameter
    item_values: tuple                    # the scene's values of spec.keys (factor scale: numbers or expressions)
    nominal: float
    law: object                           # frozen scipy.stats distribution on [lower, upper]

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def lower(self) -> float:
        return float(self.spec.interval[0])

    @property
    def upper(self) -> float:
        return float(self.spec.interval[1])

    def box_value(self, z: float) -> float:
        return self.lower + float(z) * (self.upper - self.lower)

    def box_coordinate(self, value: float) -> float:
        return (float(value) - self.lower) / (self.upper - self.lower)

    def random_value(self, u: float) -> float:
        """The value whose distribution function is ``u`` (u in [0, 1])."""
        return float(np.clip(self.law.ppf(np.clip(u, 0.0, 1.0)), self.lower, self.upper))

    def overrides(self, value: float) -> list[str]:
        """``--set`` strings that put the value into the scene."""
        if self.spec.scale == "factor":
            return [f"{k}={json.dumps(f'({v})*{float(value)!r}')}" if isinstance(v, str)
                    else f"{k}={float(v * value)!r}" for k, v in zip(self.spec.keys, self.item_values)]
        return [f"{k}={float(value)!r}" for k in self.spec.keys]


class ParameterSpace:
    """The parameters of ``[uncertainty]`` resolved against the scene's data (before any meshing or solving):
    every item named must exist in the scene (or be a key the scene may hold) and be a number, intervals must be
    finite and ordered, distributions complete. Raises :class:`SceneError` naming each offending item."""

    def __init__(self, unc: Uncertainty, raw: dict):
        problems: list[Problem] = []
        self.parameters: list[Parameter] = []
        names = set()
        for i, spec in enumerate(unc.parameters):
            where = f"uncertainty.parameters.{spec.name or i}"
            if spec.name in names:
                problems.append(Problem(where, "duplicate parameter name"))
            names.add(spec.name)
            p = _resolve(spec, raw, where, problems)
            if p is not None:
                self.parameters.append(p)
        if not unc.parameters:
            problems.append(Problem("uncertainty.parameters", "no parameters given"))
        claimed: dict[str, str] = {}
        for spec in unc.parameters:
            for k in spec.keys:
                if k in claimed:
                    problems.append(Problem(f"uncertainty.parameters.{spec.name}.keys",
                                            f"item {k!r} is set by parameter {claimed[k]!r} too"))
                claimed[k] = spec.name
        if problems:
            raise SceneError(problems, source="uncertainty")

    @property
    def dimension(self) -> int:
        return len(self.parameters)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    def nominal_coordinates(self) -> np.ndarray:
        return np.array([p.box_coordinate(p.nominal) for p in self.parameters])

    def nominal_probabilities(self) -> np.ndarray:
        """The nominal values as points of the stochastic map (their distribution function values)."""
        return np.array([float(np.clip(p.law.cdf(p.nominal), 0.0, 1.0)) for p in self.parameters])

    def box_values(self, z: np.ndarray) -> list[float]:
        return [p.box_value(zi) for p, zi in zip(self.parameters, z)]

    def random_values(self, u: np.ndarray) -> list[float]:
        return [p.random_value(ui) for p, ui in zip(self.parameters, u)]

    def overrides(self, values: list[float]) -> list[str]:
        return [o for p, v in zip(self.parameters, values) for o in p.overrides(v)]

    def describe(self) -> dict:
        """Plain data of the parameters (for the sample log's fingerprint and the results)."""
        return {p.name: {"keys": list(p.spec.keys), "interval": [p.lower, p.upper], "scale": p.spec.scale,
                         "nominal": p.nominal, "distribution": p.spec.distribution, "unit": p.spec.unit}
                for p in self.parameters}


def _resolve(spec: UncertainParameter, raw: dict, where: str, problems: list[Problem]) -> Parameter | None:
    lo, hi = (float(v) for v in spec.interval)
    n0 = len(problems)
    if not (math.isfinite(lo) and math.isfinite(hi)) or not lo < hi:
        problems.append(Problem(f"{where}.interval", f"needs finite lower < upper, got [{lo}, {hi}]"))
    if not spec.keys:
        problems.append(Problem(f"{where}.keys", "no scene items given"))
    values = []
    for k in spec.keys:
        if k.split(".")[0] == "uncertainty":
            problems.append(Problem(f"{where}.keys", f"{k!r}: the uncertainty table itself cannot be uncertain"))
            continue
        found, v = _lookup(raw, k)
        if spec.scale == "factor":
            if not found:
                problems.append(Problem(f"{where}.keys", f"{k!r} is not in the scene (a factor needs its value)"))
            elif isinstance(v, bool) or not isinstance(v, (int, float, str)):
                problems.append(Problem(f"{where}.keys", f"{k!r} is {v!r}, not a number or an expression (a "
                                                         "factor multiplies one)"))
            else:
                values.append(v if isinstance(v, str) else float(v))
        elif found and (isinstance(v, bool) or not isinstance(v, (int, float, str))):
            problems.append(Problem(f"{where}.keys", f"{k!r} holds {v!r}, not a number"))
        elif found:
            values.append(v)
        elif not _parent_exists(raw, k):
            problems.append(Problem(f"{where}.keys", f"{k!r}: the scene has no {k.rsplit('.', 1)[0]!r}"))
    if len(problems) > n0:
        return None
    if spec.nominal is not None:
        nominal = float(spec.nominal)
    elif spec.scale == "factor":
        nominal = 1.0
    elif values and isinstance(values[0], (int, float)):
        nominal = float(values[0])
    else:
        nominal = 0.5 * (lo + hi)
    if not lo <= nominal <= hi:
        item = f"{where}.nominal" if spec.nominal is not None else f"{where}.interval"
        problems.append(Problem(item, f"the nominal value {nominal:g} (the scene's) lies outside [{lo:g}, {hi:g}]"))
        return None
    law = _law(spec, lo, hi, where, problems)
    if law is None:
        return None
    return Parameter(spec, tuple(values) if spec.scale == "factor" else (), nominal, law)


def _law(spec: UncertainParameter, lo: float, hi: float, where: str, problems: list[Problem]):
    d = spec.distribution
    if d == "uniform":
        return stats.uniform(loc=lo, scale=hi - lo)
    if d == "normal":
        mean = 0.5 * (lo + hi) if spec.mean is None else float(spec.mean)
        if spec.std is None or not spec.std > 0:
            problems.append(Problem(f"{where}.std", "a normal distribution needs std > 0"))
            return None
        return stats.truncnorm((lo - mean) / spec.std, (hi - mean) / spec.std, loc=mean, scale=spec.std)
    if d == "lognormal":
        if lo <= 0:
            problems.append(Problem(f"{where}.interval", "a lognormal distribution needs a positive interval"))
            return None
        if spec.sigma is None or not spec.sigma > 0:
            problems.append(Problem(f"{where}.sigma", "a lognormal distribution needs sigma > 0 (of ln value)"))
            return None
        mu = math.log(math.sqrt(lo * hi) if spec.median is None else float(spec.median))
        a, b = (math.log(lo) - mu) / spec.sigma, (math.log(hi) - mu) / spec.sigma
        return _LogTruncNorm(stats.truncnorm(a, b, loc=mu, scale=spec.sigma))
    # triangular
    mode = 0.5 * (lo + hi) if spec.mode is None else float(spec.mode)
    if not lo <= mode <= hi:
        problems.append(Problem(f"{where}.mode", f"the mode {mode:g} lies outside [{lo:g}, {hi:g}]"))
        return None
    return stats.triang((mode - lo) / (hi - lo), loc=lo, scale=hi - lo)


class _LogTruncNorm:
    """exp of a truncated normal: a lognormal law truncated to the interval."""

    def __init__(self, normal):
        self.normal = normal

    def ppf(self, u):
        return np.exp(self.normal.ppf(u))

    def cdf(self, x):
        return self.normal.cdf(np.log(x))

    def mean(self):
        return float(self.normal.expect(np.exp))


def _lookup(raw: dict, key: str) -> tuple[bool, object]:
    node: object = raw
    for part in key.split("."):
        node = child_table(node, part)
        if node is None:
            return False, None
    return True, node


def _parent_exists(raw: dict, key: str) -> bool:
    parts = key.split(".")
    return len(parts) == 1 or _lookup(raw, ".".join(parts[:-1]))[0]
