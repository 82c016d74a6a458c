"""The run summary (``summary.json``): scene, versions, wall times, mesh size, probe values."""

from __future__ import annotations

import math
import platform
import sys
from importlib import metadata


def versions() -> dict[str, str]:
    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for pkg in ("ngs-geomech", "ngsolve", "netgen-mesher", "numpy", "scipy", "matplotlib"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


def probe_statistics(times: list[float], values: list[float | None]) -> dict[str, float | None]:
    """Final, maximal and minimal value of a probe series and when they occur (s). Missing values (None: e.g.
    a front probe while there is no front) are skipped; ``final`` is the last value, None when it is missing."""
    if not values:
        return {}
    have = [i for i, v in enumerate(values) if v is not None]
    if not have:
        return {"final": None}
    i_max = max(have, key=values.__getitem__)
    i_min = min(have, key=values.__getitem__)
    return {"final": values[-1], "max": values[i_max], "time_of_max": times[i_max],
            "min": values[i_min], "time_of_min": times[i_min]}


def json_safe(x):
    """A JSON-safe copy where a non-finite float becomes None (studies: an undefined figure is written as null;
    summaries refuse it, see :func:`finite`)."""
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def finite(x):
    """JSON-safe copy: raises on NaN/Inf so no non-finite number is ever written as a result."""
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        raise ValueError("non-finite value in summary")
    return x
