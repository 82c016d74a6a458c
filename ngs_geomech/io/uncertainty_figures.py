"""Figures of an uncertainty study (plain data in, PNG out): criteria ranges over the admissible set, each
criterion against each parameter, and the distribution and convergence of the stochastic estimates."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .figures import new_figure, save_figure


def ranges_figure(rows: list[dict], path: Path, *, title: str) -> None:
    """One panel per criterion: every sample's value (dots), the nominal value, the worst-scenario range
    (bar from min to max) and the limit. ``rows``: name, unit, values, nominal, min, max, limit."""
    fig, axes = new_figure((7.5, 1.3 + 1.1 * len(rows)), len(rows), 1, squeeze=False)
    for ax, r in zip(axes[:, 0], rows):
        v = np.asarray(r["values"], dtype=float)
        jitter = 0.12 * (np.linspace(-1, 1, len(v)) if len(v) > 1 else np.zeros(1))
        ax.plot(v, jitter, "o", ms=3, color="0.55", label="samples")
        if r.get("min") is not None and r.get("max") is not None:
            ax.plot([r["min"], r["max"]], [0, 0], "-", lw=6, color="tab:red", alpha=0.45, label="range found")
            ax.plot([r["min"], r["max"]], [0, 0], "|", ms=18, color="tab:red")
        if r.get("nominal") is not None:
            ax.plot([r["nominal"]], [0], "D", color="k", ms=6, label="nominal")
        if r.get("limit") is not None:
            ax.axvline(r["limit"], color="tab:blue", ls="--", label="limit")
        ax.set_yticks([])
        ax.set_ylim(-0.5, 0.5)
        ax.set_xlabel(f"{r['name']} ({r['unit']})" if r.get("unit") else r["name"])
        ax.grid(True, axis="x", alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=7, ncol=4, framealpha=0.8)
    axes[0, 0].set_title(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


def scatter_figure(params: dict[str, np.ndarray], values: np.ndarray, tags: list[str], path: Path, *,
                   criterion: str, marks: dict[str, dict] | None = None) -> None:
    """The criterion against each parameter over all samples, coloured by how each sample arose (design,
    finite difference, line search); ``marks``: label -> parameter values of highlighted points (the extrema)."""
    names = list(params)
    fig, axes = new_figure((3.2 * len(names) + 0.6, 3.4), 1, len(names), squeeze=False)
    kinds = ["design" if t in ("design", "nominal") else ("derivative" if t.endswith(":fd") or t == "fd_check"
                                                          else "search step") for t in tags]
    colours = {"design": "tab:gray", "derivative": "tab:orange", "search step": "tab:green"}
    for ax, n in zip(axes[0], names):
        x = np.asarray(params[n], dtype=float)
        for kind, col in colours.items():
            sel = np.array([k == kind for k in kinds])
            if sel.any():
                ax.plot(x[sel], np.asarray(values)[sel], "o", ms=3.5, color=col, label=kind, alpha=0.8)
        for label, m in (marks or {}).items():
            ax.plot([m["parameters"][n]], [m["value"]], "*", ms=13, label=label,
                    color="tab:red" if "max" in label else "tab:blue")
        ax.set_xlabel(n)
        ax.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel(criterion)
    axes[0, -1].legend(fontsize=7, loc="best")
    fig.tight_layout()
    save_figure(fig, path)


def distribution_figure(values: np.ndarray, running: dict, path: Path, *, criterion: str, unit: str,
                        mean_ci: list[float] | None, limit: float | None) -> None:
    """Histogram of a criterion over the samples and its running mean with the confidence band."""
    fig, (a1, a2) = new_figure((10, 3.8), 1, 2)
    label = f"{criterion} ({unit})" if unit else criterion
    a1.hist(values, bins=max(5, min(30, len(values) // 3)), color="tab:gray", alpha=0.8)
    if mean_ci:
        a1.axvspan(mean_ci[0], mean_ci[1], color="tab:red", alpha=0.3, label="confidence interval of the mean")
    if limit is not None:
        a1.axvline(limit, color="tab:blue", ls="--", label="limit")
    a1.set_xlabel(label)
    a1.set_ylabel("samples")
    a1.legend(fontsize=7)
    n = np.asarray(running["n"])
    m = np.asarray(running["mean"])
    h = np.asarray(running["half_width"])
    a2.plot(n, m, color="tab:red", label="running mean")
    ok = np.isfinite(h)
    a2.fill_between(n[ok], (m - h)[ok], (m + h)[ok], color="tab:red", alpha=0.25, label="confidence band (MC)")
    a2.set_xlabel("samples")
    a2.set_ylabel(label)
    a2.grid(True, alpha=0.3)
    a2.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
