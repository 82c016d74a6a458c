"""Time step schedules: constant or geometrically growing steps, ending exactly at the end time."""

from __future__ import annotations

from collections.abc import Iterator


def schedule(start: float, end: float, dt: float, growth: float = 1.0,
             dt_max: float | None = None) -> Iterator[tuple[float, float]]:
    """Yield (t0, t1) pairs from ``start`` to ``end`` (s). The step grows by ``growth`` up to ``dt_max``;
    a remainder shorter than two steps is split evenly, so no sliver step appears at the end."""
    t = start
    cap = dt_max if dt_max is not None else float("inf")
    step = min(dt, cap)
    eps = 1e-9 * max(abs(end), step)
    while t < end - eps:
        if t + step >= end - eps:
            step = end - t
        elif t + 2 * step > end:
            step = (end - t) / 2
        t1 = end if abs(t + step - end) <= eps else t + step
        yield t, t1
        t = t1
        step = min(step * growth, cap)


def nominal_step(k: int, dt: float, growth: float = 1.0, dt_max: float | None = None) -> float:
    """The step :func:`schedule` takes after ``k`` steps, before any shortening at the end (s)."""
    cap = dt_max if dt_max is not None else float("inf")
    step = min(dt, cap)
    for _ in range(k):
        step = min(step * growth, cap)
    return step
