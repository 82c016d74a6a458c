"""The worst-scenario (reliable solution) search over the admissible set of data.

The admissible set is the box of the parameters' intervals (unit cube ``z``). For each criterion and sense
(maximum, minimum): the best point of a space-filling design (Latin hypercube, plus the box's corners when there
are few) starts a projected-gradient ascent with finite-difference derivatives (forward, step ``fd_step`` of the
interval, backward at the upper bound; the ``d`` runs of a gradient go in parallel), and a step tried at 1, 1/2
and 1/4 of the largest move to the box's boundary (in parallel too); a gradient point that is itself better
(a non-smooth criterion) is taken instead of a step. It stops at a point where the projected
gradient vanishes (a KKT point of the box: often a corner, where every derivative points out of the box), when
no step improves the criterion, or after ``max_local_iterations``. The criterion is only as smooth as the
discretization makes it (active contact sets and phase fronts jump between nodes): the result is the best
point found, with how it was found, not a proven global extremum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from .samples import Sample, Sampler

STEPS = (1.0, 0.5, 0.25)


def design_points(d: int, samples: int, seed: int, vertices: str) -> list[np.ndarray]:
    """Latin hypercube points (``samples`` of them) and, with ``vertices`` 'yes' or 'auto' (when 2^d <=
    samples), the 2^d corners of the unit cube."""
    pts = [np.asarray(p) for p in qmc.LatinHypercube(d, seed=seed).random(samples)] if samples > 0 else []
    if vertices == "yes" or (vertices == "auto" and 2 ** d <= max(samples, 1)):
        corners = np.array(np.meshgrid(*[[0.0, 1.0]] * d, indexing="ij")).reshape(d, -1).T
        pts = [np.asarray(c) for c in corners] + pts
    return pts


def fd_points(z: np.ndarray, h: float, central: bool = False) -> tuple[list[np.ndarray], np.ndarray]:
    """Points of a finite-difference gradient at z and the signed steps (one per coordinate; central: two)."""
    pts, steps = [], []
    for i in range(len(z)):
        if central:
            for s in (h, -h):
                p = z.copy()
                p[i] = np.clip(z[i] + s, 0.0, 1.0)
                pts.append(p)
            steps.append(h)
            continue
        s = h if z[i] + h <= 1.0 + 1e-15 else -h
        p = z.copy()
        p[i] = np.clip(z[i] + s, 0.0, 1.0)
        pts.append(p)
        steps.append(p[i] - z[i])
    return pts, np.array(steps)


def fd_gradient(sampler: Sampler, z: np.ndarray, f0: dict[str, float], h: float, tag: str,
                central: bool = False) -> tuple[dict[str, np.ndarray], list[Sample]]:
    """d/dz of every criterion at z (criterion units per unit of z; NaN where a sample failed)."""
    pts, steps = fd_points(z, h, central)
    res = sampler.batch(pts, tag)
    grads = {}
    for name in sampler.criteria:
        g = np.full(len(z), np.nan)
        for i in range(len(z)):
            if central:
                a, b = res[2 * i], res[2 * i + 1]
                if a.ok and b.ok:
                    g[i] = (a.values[name] - b.values[name]) / (a.z[i] - b.z[i])
            elif res[i].ok and name in f0:
                g[i] = (res[i].values[name] - f0[name]) / steps[i]
        grads[name] = g
    return grads, res


@dataclass
class Search:
    """One criterion's search in one sense: where it started and ended, its steps and why it stopped."""

    criterion: str
    sense: str
    start: Sample
    best: Sample
    iterations: int
    stop: str                  # 'kkt' | 'no_improvement' | 'max_iterations' | 'failed_gradient' | 'off'
    gradient: list[float]      # d criterion / d parameter at the end point (criterion units per parameter unit)
    path: list[float]          # the criterion's value after each accepted step (starting value first)

    def as_dict(self, space) -> dict:
        return {"criterion": self.criterion, "sense": self.sense, "value": self.best.values[self.criterion],
                "parameters": self.best.params, "found_by": self.best.tag, "start_value":
                self.start.values[self.criterion], "start_found_by": self.start.tag, "iterations": self.iterations,
                "stop": self.stop, "path": self.path,
                "gradient": dict(zip(space.names, self.gradient)),
                "at_bounds": {n: ("lower" if z <= 1e-12 else "upper" if z >= 1 - 1e-12 else "inside")
                              for n, z in zip(space.names, self.best.z)}}


def local_search(sampler: Sampler, criterion: str, sense: str, start: Sample, *, h: float, max_iterations: int,
                 scale: float, enabled: bool = True) -> Search:
    """Projected-gradient steps from ``start`` (see the module docstring). ``scale``: the criterion's spread
    over the design; an improvement below 1e-6 of it (or of the value) ends the search."""
    sign = 1.0 if sense == "max" else -1.0
    best, path = start, [start.values[criterion]]
    widths = np.array([p.upper - p.lower for p in sampler.space.parameters])
    tol = 1e-6 * max(scale, abs(start.values[criterion]), 1e-300)
    grad = np.full(len(start.z), np.nan)
    stop = "off"
    it = 0
    if not enabled:
        return Search(criterion, sense, start, best, 0, stop, [float("nan")] * len(start.z), path)
    stop = "max_iterations"
    for it in range(1, max_iterations + 1):
        grads, fd_res = fd_gradient(sampler, best.z, best.values, h, f"{criterion}:{sense}:fd")
        grad = grads[criterion]
        if not np.all(np.isfinite(grad)):
            stop = "failed_gradient"
            break
        fd_ok = [s for s in fd_res if s.ok and criterion in s.values]
        g = sign * grad
        out = ((best.z >= 1 - 1e-12) & (g > 0)) | ((best.z <= 1e-12) & (g < 0))
        pg = np.where(out, 0.0, g)
        if np.max(np.abs(pg)) * h <= tol:     # what a finite-difference step could still gain: nothing
            better = [s for s in fd_ok if sign * (s.values[criterion] - best.values[criterion]) > tol]
            if not better:
                stop = "kkt"
                it -= 1
                break
            # a non-smooth criterion: a gradient point is better although the projected gradient vanishes
            best = max(better, key=lambda s: sign * s.values[criterion])
            path.append(best.values[criterion])
            continue
        direction = pg / np.max(np.abs(pg))
        cands = [np.clip(best.z + a * direction, 0.0, 1.0) for a in STEPS]
        # the trial steps, and the gradient's own points (with a non-smooth criterion one may be the best)
        res = [s for s in sampler.batch(cands, f"{criterion}:{sense}:step") if s.ok and criterion in s.values]
        res += fd_ok
        if not res:
            stop = "no_improvement"
            break
        new = max(res, key=lambda s: sign * s.values[criterion])
        if sign * (new.values[criterion] - best.values[criterion]) <= tol:
            stop = "no_improvement"
            break
        best = new
        path.append(best.values[criterion])
    return Search(criterion, sense, start, best, it, stop, (grad / widths).tolist(), path)
