"""Samples of an uncertainty study: each point ``z`` of the unit cube is run once, whatever asks for it (the
design, a finite difference, a line search, another criterion's search, a resumed study); every finished
sample goes to the :class:`~ngs_geomech.io.sample_log.SampleLog` at once."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..io.progress import Progress
from ..io.sample_log import SampleLog
from .evaluate import evaluate
from .executors import Runner
from .parameters import ParameterSpace


def point_key(z: np.ndarray) -> str:
    return ",".join(f"{float(v):.12f}" for v in np.asarray(z, dtype=float))


@dataclass
class Sample:
    key: str
    z: np.ndarray
    params: dict[str, float]
    status: str
    values: dict[str, float]
    wall_s: float
    tag: str
    message: str = ""
    criteria_problems: list = field(default_factory=list)   # criteria missing from (or not finite in) the summary

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def as_record(self) -> dict:
        rec = {"key": self.key, "z": [float(v) for v in self.z], "params": self.params, "status": self.status,
               "values": self.values, "wall_s": self.wall_s, "tag": self.tag}
        if self.message:
            rec["message"] = self.message
        return rec

    @classmethod
    def from_record(cls, rec: dict) -> Sample:
        return cls(rec["key"], np.array(rec["z"], dtype=float), rec["params"], rec["status"], rec["values"],
                   float(rec["wall_s"]), rec.get("tag", ""), rec.get("message", ""))


@dataclass
class Sampler:
    """Runs points of the unit cube through the scene. ``values_of(z)`` maps a point to the parameter values
    (the box for the worst-scenario search, the inverse distribution functions for the stochastic modes)."""

    space: ParameterSpace
    raw: dict
    criteria: dict[str, str]
    runner: Runner
    log: SampleLog
    values_of: Callable[[np.ndarray], list[float]]
    progress: bool = True
    done: dict[str, Sample] = field(default_factory=dict)
    runs: int = 0                 # samples run by this process (not read from the log)
    run_wall_s: float = 0.0       # their summed wall times

    def preload(self, records: list[dict]) -> None:
        for rec in records:
            s = Sample.from_record(rec)
            self.done[s.key] = s

    def batch(self, points: list[np.ndarray], tag: str) -> list[Sample]:
        """The samples at ``points`` (run in parallel where not done yet), in the order of ``points``."""
        keys = [point_key(z) for z in points]
        todo: dict[str, np.ndarray] = {}
        for k, z in zip(keys, points):
            if k not in self.done and k not in todo:
                todo[k] = np.asarray(z, dtype=float)
        self._reused.update(k for k in keys if k in self.done and k not in self._mine)
        if todo:
            tasks = []
            for k, z in todo.items():
                values = self.values_of(z)
                tasks.append({"key": k, "z": [float(v) for v in z], "tag": tag,
                              "params": dict(zip(self.space.names, values)),
                              "raw": self.raw, "overrides": self.space.overrides(values),
                              "criteria": self.criteria, "threads": self.runner.threads_per_task})
            bar = Progress(len(tasks), f"{tag:>14s}", enabled=self.progress)
            t0 = time.perf_counter()
            for i, res in enumerate(self.runner.as_completed(evaluate, tasks), 1):
                s = Sample(res["key"], np.array(res["z"]), res["params"], res["status"], res["values"],
                           res["wall_s"], res["tag"], res.get("message", ""), res.get("criteria_problems", []))
                self.done[s.key] = s
                self._mine.add(s.key)
                self.log.append(s.as_record())
                self.runs += 1
                self.run_wall_s += s.wall_s
                shown = ", ".join(f"{n} {v:.6g}" for n, v in s.values.items()) if s.ok else "FAILED"
                bar.update(i, f"{shown} ({time.perf_counter() - t0:.0f} s)")
            bar.close()
        return [self.done[k] for k in keys]

    def __post_init__(self):
        self._mine: set[str] = set()
        self._reused: set[str] = set()

    @property
    def reused(self) -> int:
        """Points answered from the log of an earlier (killed) study."""
        return len(self._reused)
