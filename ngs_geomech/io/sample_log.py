"""The sample log of an uncertainty study: one JSON line per finished sample, appended and flushed to disk as
soon as the sample ends, so a killed study keeps every finished sample and resumes from them.

Line 1 is a header (``{"kind": "header", "fingerprint": ..., "items": {...}}``): what the samples depend on
(the scene without its ``[uncertainty]`` table, the parameters' keys, intervals and scales, and the criteria's
summary paths), flattened to
dotted items so that a resume with other data can name what differs. Each further line is
``{"kind": "sample", "key": ..., ...}``. A last line cut by a kill is ignored when the log is read.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path


def flatten(data, prefix: str = "") -> dict[str, object]:
    """Dotted items of nested dicts and lists: ``{"a": {"b": [1, 2]}}`` -> ``{"a.b.0": 1, "a.b.1": 2}``."""
    out: dict[str, object] = {}
    if isinstance(data, dict):
        for k, v in data.items():
            out.update(flatten(v, f"{prefix}{k}."))
    elif isinstance(data, (list, tuple)):
        for i, v in enumerate(data):
            out.update(flatten(v, f"{prefix}{i}."))
    else:
        out[prefix[:-1]] = data
    return out


def fingerprint(items: dict[str, object]) -> str:
    return hashlib.sha256(json.dumps(items, sort_keys=True, default=str).encode()).hexdigest()[:16]


def differing_items(a: dict[str, object], b: dict[str, object], limit: int = 12) -> list[str]:
    """Items whose values differ between two flattened item dicts (missing on one side included)."""
    keys = sorted(set(a) | set(b))
    diff = [f"{k}: {a.get(k, '(absent)')!r} -> {b.get(k, '(absent)')!r}" for k in keys if a.get(k) != b.get(k)]
    return diff[:limit] + ([f"... and {len(diff) - limit} more"] if len(diff) > limit else [])


class SampleLog:
    """Append-only JSON-lines log at ``path``."""

    def __init__(self, path: Path):
        self.path = Path(path)

    def exists(self) -> bool:
        return self.path.is_file() and self.path.stat().st_size > 0

    def read(self) -> tuple[dict | None, list[dict]]:
        """The header and the sample records (a truncated or unreadable last line is skipped)."""
        header, records = None, []
        if not self.path.is_file():
            return None, []
        with open(self.path) as fh:
            lines = fh.read().split("\n")
        for i, line in enumerate(lines):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                if i >= len(lines) - 2:         # the last line, cut by a kill
                    continue
                raise ValueError(f"{self.path}: line {i + 1} is not JSON") from None
            if rec.get("kind") == "header":
                header = rec
            elif rec.get("kind") == "sample":
                records.append(rec)
        return header, records

    def start(self, header: dict) -> None:
        """Begin a new log with its header (replacing none: the caller checks that there is no log)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._append({"kind": "header", **header}, mode="w")

    def append(self, record: dict) -> None:
        self._append({"kind": "sample", **record})

    def _append(self, record: dict, mode: str = "a") -> None:
        line = json.dumps(record, allow_nan=True) + "\n"
        with open(self.path, mode) as fh:
            fh.write(line)
            fh.flush()
            os.fsync(fh.fileno())
