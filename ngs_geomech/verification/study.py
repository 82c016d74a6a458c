"""The studies contract in one place (``studies/<name>/run.py``): convergence entries, ``results.json``,
the plain-text report and the command line ``--level N --out DIR``.

A study module defines ``run(level) -> (result, tables)`` and ``report(result) -> str`` (usually
:func:`report` plus its own tables) and gets ``main`` and the command line from :func:`study_main` and
:func:`study_cli`.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..io.atomic import write_json_atomic
from ..io.summary import json_safe


@contextmanager
def one_ngsolve_thread():
    """Run a block on one NGSolve thread (restored afterwards): studies that compare wall times run on one
    thread, since idle worker threads spin and make small problems several times slower on a shared machine."""
    import ngsolve as ngs

    threads = ngs.GetNumThreads()
    ngs.SetNumThreads(1)
    try:
        yield
    finally:
        ngs.SetNumThreads(threads)


def observed_order(hs, errors) -> float:
    """Least-squares slope of log(error) against log(h) (np.polyfit); NaN with fewer than two points."""
    if len(hs) < 2:
        return math.nan
    return float(np.polyfit(np.log(np.asarray(hs, float)), np.log(np.asarray(errors, float)), 1)[0])


def convergence_entry(quantity: str, hs, dofs, errors, expected, **extra) -> dict:
    """One ``convergence`` item: the fitted order is None unless every error is positive and finite."""
    vals = [float(v) for v in errors]
    ok = len(vals) >= 2 and all(v > 0 and math.isfinite(v) for v in vals)
    return {"quantity": quantity, "h": [float(h) for h in hs], "dofs": [int(d) for d in dofs], "errors": vals,
            "observed_order": observed_order(hs, vals) if ok else None, "expected_order": expected,
            **json_safe(extra)}


def _rates(hs, errors) -> list[str]:
    out = ["-"]
    for k in range(1, len(hs)):
        try:
            out.append(f"{math.log(errors[k - 1] / errors[k]) / math.log(hs[k - 1] / hs[k]):5.2f}")
        except (ValueError, ZeroDivisionError):
            out.append("-")
    return out


def convergence_tables(result: dict, hname: str = "h") -> list[str]:
    """One table per convergence entry: h, dofs, error, rate between levels."""
    lines = []
    for c in result["convergence"]:
        order = c["observed_order"]
        lines.append("")
        lines.append(f"{c['quantity']}: observed order {'-' if order is None else f'{order:.2f}'} "
                     f"(expected {c['expected_order']})")
        lines.append(f"{hname:>10} {'dofs':>7} {'error':>11} {'rate':>5}")
        for h, d, e, r in zip(c["h"], c["dofs"], c["errors"], _rates(c["h"], c["errors"])):
            lines.append(f"{h:10.4g} {d:7d} {e:11.3e} {r:>5}")
    return lines


def metrics_lines(result: dict, width: int = 50) -> list[str]:
    lines = ["", "metrics:"]
    lines += [f"  {k:{width}} {v:.4g}" for k, v in result["metrics"].items()]
    lines.append("timing (s): " + ", ".join(f"{k} {v:.1f}" for k, v in result["timing_s"].items()))
    return lines


def report(result: dict, hname: str = "h") -> str:
    """The default report: a header, the convergence tables, the metrics and the timings."""
    return "\n".join([f"study {result['study']}, level {result['level']}"] + convergence_tables(result, hname)
                     + metrics_lines(result))


def study_main(run: Callable[[int], tuple], level: int, out,
               write: Callable[[object, Path], None] | None = None) -> dict:
    """Run a study at ``level``; write ``out/results.json`` (atomically) if ``out`` is given, and the study's
    own files by ``write(tables, out)`` (``tables``: the second item ``run`` returns), e.g. its figures."""
    result, tables = run(level)
    if out is not None:
        write_json_atomic(Path(out) / "results.json", result)
        if write is not None:
            write(tables, Path(out))
    return result


def study_cli(doc: str, run: Callable[[int], tuple], report_fn: Callable[[dict], str],
              write: Callable[[object, Path], None] | None = None) -> None:
    """The command line of a study: ``--level N --out DIR``; prints the report (``write``: see
    :func:`study_main`)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--level", type=int, default=0, help="0 quick, 1 and 2 finer")
    parser.add_argument("--out", default=None, help="directory for results.json")
    args = parser.parse_args()
    result = study_main(run, args.level, args.out, write)
    print(report_fn(result))
