"""The stochastic modes: Monte Carlo and randomized quasi-Monte Carlo samples of the data, and estimates of each
criterion's mean (with a confidence interval), spread, quantiles and probability of exceeding a limit.

Monte Carlo: ``n`` independent uniform points of the unit cube, pushed through each parameter's inverse
distribution function; the confidence interval of the mean is Student's t on the sample standard deviation,
that of a probability Wilson's score interval. Quasi-Monte Carlo: ``R`` independently scrambled Sobol point sets
of ``n / R`` points (a power of two) each; the estimate is the mean of the ``R`` replicate means and its interval
Student's t on their spread (the replicates are independent, the points within one are not).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats
from scipy.stats import qmc


def monte_carlo_points(d: int, n: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [np.asarray(p) for p in rng.random((n, d))]


def sobol_replicates(d: int, n: int, replicates: int, seed: int) -> list[list[np.ndarray]]:
    """``replicates`` scrambled Sobol sets of n / replicates points each (must be a power of two)."""
    m = n // replicates
    return [[np.asarray(p) for p in qmc.Sobol(d, scramble=True, seed=seed + r).random_base2(int(math.log2(m)))]
            for r in range(replicates)]


def t_interval(x: np.ndarray, confidence: float) -> tuple[float, float, float]:
    """Mean and the half-width of its Student-t confidence interval (NaN half-width below 2 values)."""
    x = np.asarray(x, dtype=float)
    if len(x) < 2:
        return float(np.mean(x)) if len(x) else float("nan"), float("nan"), float("nan")
    mean = float(np.mean(x))
    sem = float(np.std(x, ddof=1) / math.sqrt(len(x)))
    half = float(stats.t.ppf(0.5 + confidence / 2, len(x) - 1) * sem)
    return mean, half, sem


def wilson_interval(k: int, n: int, confidence: float) -> tuple[float, float]:
    if n == 0:
        return float("nan"), float("nan")
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def estimate(values: np.ndarray, groups: np.ndarray | None, confidence: float, limit: float | None) -> dict:
    """Figures of one criterion over the finished samples (``groups``: the QMC replicate of each value)."""
    v = np.asarray(values, dtype=float)
    out: dict = {"n": int(len(v))}
    if len(v) == 0:
        return out
    if groups is None:
        mean, half, sem = t_interval(v, confidence)
        out["method"] = "monte_carlo: Student t on the sample standard deviation"
    else:
        rep = np.array([np.mean(v[groups == g]) for g in np.unique(groups)])
        mean, half, sem = t_interval(rep, confidence)
        out["method"] = f"quasi_monte_carlo: Student t over {len(rep)} scrambled replicates"
        out["replicate_means"] = rep.tolist()
    out.update({"mean": mean, "mean_ci": [mean - half, mean + half], "standard_error": sem,
                "std": float(np.std(v, ddof=1)) if len(v) > 1 else float("nan"),
                "min": float(np.min(v)), "max": float(np.max(v)),
                "quantiles": {f"q{int(q * 100):02d}": float(np.quantile(v, q)) for q in (0.05, 0.5, 0.95)}})
    if limit is not None:
        exceed = v > limit
        k = int(np.sum(exceed))
        out["limit"] = limit
        out["exceedances"] = k
        if groups is None:
            lo, hi = wilson_interval(k, len(v), confidence)
            out["p_exceed"] = k / len(v)
            out["p_exceed_ci"] = [lo, hi]
        else:
            rep = np.array([np.mean(exceed[groups == g]) for g in np.unique(groups)])
            p, half, _ = t_interval(rep, confidence)
            out["p_exceed"] = p
            out["p_exceed_ci"] = [max(0.0, p - half), min(1.0, p + half)]
    return out


def running_mean(values: np.ndarray, confidence: float) -> dict:
    """Mean and Monte Carlo confidence half-width after each sample (for the convergence figure)."""
    v = np.asarray(values, dtype=float)
    means, halves = [], []
    for n in range(1, len(v) + 1):
        m, h, _ = t_interval(v[:n], confidence)
        means.append(m)
        halves.append(h)
    return {"n": list(range(1, len(v) + 1)), "mean": means, "half_width": halves}
