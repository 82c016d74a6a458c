"""Quantities with units in scene files.

Scenes are in SI units, temperatures in degC or K (``scene.temperature_unit``). Times may also be written as
strings with a unit, e.g. ``"100 year"``, ``"10 day"``; one year is the Julian year, 365.25 days = 31 557 600 s.
"""

from __future__ import annotations

import math
import re

SECOND = 1.0
MINUTE = 60.0
HOUR = 3600.0
DAY = 86400.0
YEAR = 365.25 * DAY
KELVIN = 273.15
"""0 degC in K."""

TIME_UNITS = {
    "s": SECOND, "second": SECOND, "seconds": SECOND,
    "min": MINUTE, "minute": MINUTE, "minutes": MINUTE,
    "h": HOUR, "hour": HOUR, "hours": HOUR,
    "d": DAY, "day": DAY, "days": DAY,
    "y": YEAR, "a": YEAR, "year": YEAR, "years": YEAR,
    "ky": 1e3 * YEAR, "kyr": 1e3 * YEAR, "Ma": 1e6 * YEAR, "Myr": 1e6 * YEAR,
}

_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z]+)\s*$")


def parse_time(value: object) -> float:
    """Return a time in seconds from a number (seconds) or a string such as ``"50 year"``.

    Raises ValueError with the accepted units when the string cannot be read.
    """
    if isinstance(value, bool):
        raise ValueError(f"expected a time, got {value!r}")
    if isinstance(value, (int, float)):
        v = float(value)
    elif isinstance(value, str):
        m = _QUANTITY.match(value)
        if not m or m.group(2) not in TIME_UNITS:
            units = ", ".join(sorted(set(TIME_UNITS)))
            raise ValueError(f"cannot read time {value!r}: write a number of seconds or '<number> <unit>' "
                             f"with unit one of {units}")
        v = float(m.group(1)) * TIME_UNITS[m.group(2)]
    else:
        raise ValueError(f"expected a time (number of seconds or e.g. '10 year'), got {value!r}")
    if not math.isfinite(v):
        raise ValueError(f"time {value!r} is not finite")
    return v


def format_time(t: float) -> str:
    """Readable form of a time in seconds (for progress displays and figure labels)."""
    a = abs(t)
    if a >= YEAR:
        return f"{t / YEAR:.4g} y"
    if a >= DAY:
        return f"{t / DAY:.4g} d"
    if a >= HOUR:
        return f"{t / HOUR:.4g} h"
    return f"{t:.4g} s"
