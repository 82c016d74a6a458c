"""Benchmark: the same uncertainty study run serially and on a process pool, in one run (ratios, not absolute
times: the machine is shared). The permafrost scene's worst-scenario design without the local search (13 runs of
~2 s); each variant starts from an empty output directory, so every sample is run.

Command: ``python studies/worst_scenario/parallel_benchmark.py [--workers 2] [--samples 12]``; prints the wall
times, the speedup and checks that both variants found the same range.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from ngs_geomech.uncertainty.study import run_uncertainty


def main(workers: int = 2, samples: int = 12) -> dict:
    over = ["uncertainty.mode=worst_scenario", f"uncertainty.samples={samples}", "uncertainty.vertices=no",
            "uncertainty.local_search=false"]
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for kind, w in (("serial", None), ("process", workers)):
            t0 = time.perf_counter()
            res = run_uncertainty("permafrost", Path(tmp) / kind, overrides=over, executor=kind, workers=w,
                                  threads=1, progress=False, figures=False)
            out[kind] = {"wall_s": time.perf_counter() - t0, "runs": res["samples"]["run_in_this_session"],
                         "range": res["worst_scenario"]["criteria"]["max_frozen_depth"]["range"]}
    out["speedup"] = out["serial"]["wall_s"] / out["process"]["wall_s"]
    out["same_range"] = out["serial"]["range"] == out["process"]["range"]
    return out


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--samples", type=int, default=12)
    a = p.parse_args()
    r = main(a.workers, a.samples)
    for k in ("serial", "process"):
        print(f"{k:8s} {r[k]['runs']} runs  {r[k]['wall_s']:7.1f} s  front depth range {r[k]['range']}")
    print(f"speedup {r['speedup']:.2f} with {a.workers} workers; same range: {r['same_range']}")
