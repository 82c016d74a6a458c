"""One sample of an uncertainty study: the scene with the sample's values, run without output, and the
criteria read from its summary. Runs in a worker process (or MPI rank); everything it takes and returns is
plain data."""

from __future__ import annotations

import math
import time
import traceback

from ..errors import GeomechError


def summary_value(summary: dict, path: str) -> tuple[bool, object, str]:
    """The item at a dotted ``path`` of a summary: (found, value, the path's deepest existing part and its
    keys when not found)."""
    node: object = summary
    done = []
    for part in path.split("."):
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.lstrip("-").isdigit() and -len(node) <= int(part) < len(node):
            node = node[int(part)]
        else:
            keys = list(node)[:30] if isinstance(node, dict) else (f"a list of {len(node)}" if isinstance(node, list)
                                                                   else repr(node))
            return False, None, f"{'.'.join(done) or 'summary'} has no {part!r} (it has: {keys})"
        done.append(part)
    return True, node, ""


def evaluate(task: dict) -> dict:
    """Run one sample. ``task``: ``raw`` (the scene's data), ``overrides`` (``--set`` strings), ``criteria``
    (name -> summary path), ``threads``, plus ``key`` and whatever the caller wants echoed back. Returns the
    task's echo items with ``status`` ("ok" | "failed"), ``values`` (name -> float), ``wall_s`` and, when the
    run failed or a criterion is missing or not finite, ``message``."""
    from ..run import run_scene
    from ..scene.parse import apply_overrides, scene_from_dict

    t0 = time.perf_counter()
    echo = {k: v for k, v in task.items() if k not in ("raw", "overrides", "criteria", "threads")}
    try:
        scene = scene_from_dict(apply_overrides(task["raw"], task["overrides"]), source="sample")
        result = run_scene(scene, None, progress=False, threads=task.get("threads"))
    except GeomechError as exc:
        return {**echo, "status": "failed", "values": {}, "wall_s": time.perf_counter() - t0,
                "message": f"{type(exc).__name__}: {exc}"}
    except Exception as exc:   # noqa: BLE001 -- a crash of one sample is reported with the sample, not lost
        return {**echo, "status": "failed", "values": {}, "wall_s": time.perf_counter() - t0,
                "message": f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}"}
    values, messages = {}, []
    for name, path in task["criteria"].items():
        found, v, why = summary_value(result.summary, path)
        if not found:
            messages.append(f"criterion {name!r}: summary path {path!r} not found: {why}")
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            messages.append(f"criterion {name!r}: summary item {path!r} is {v!r}, not a finite number")
        else:
            values[name] = float(v)
    out = {**echo, "status": "failed" if messages else "ok", "values": values,
           "wall_s": time.perf_counter() - t0}
    if messages:
        out["message"] = "; ".join(messages)
        out["criteria_problems"] = messages
    return out
