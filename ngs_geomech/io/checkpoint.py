"""Checkpoint files of time-dependent runs: writing them atomically, finding and loading them, and comparing
the scene of a checkpoint with the scene of a resumed run (no physics here).

A checkpoint is one ``.npz`` file: the state vectors as arrays and everything else (step, time, schedule,
probe series, VTK entries, solver histories, the scene) as JSON in the array ``meta`` (bytes). It lives in
``checkpoint/`` inside a run's staging directory (``.DIR.partial-*``, see :class:`~.atomic.OutputDir`) as
``checkpoint.npz`` and, one generation older, ``previous.npz``. Writing goes to a temporary file (fsync), then
``checkpoint.npz`` is renamed to ``previous.npz`` and the temporary file to ``checkpoint.npz``: a run killed
at any moment leaves at least one complete checkpoint (a truncated temporary file is ignored; a damaged
``checkpoint.npz`` - the zip's CRC checks fail - falls back to ``previous.npz``).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ResumeError
from .atomic import OutputDir, is_locked, staging_dirs

FORMAT = "ngs-geomech checkpoint 2"
DIRNAME = OutputDir.SCRATCH
CURRENT = "checkpoint.npz"
PREVIOUS = "previous.npz"

# Scene keys that may differ between a checkpointed run and its resumption (the fixes a failed run needs:
# smaller or other time steps, solver limits, output frequency); every other key must be equal.
RESUMABLE_KEYS = ("scene.description", "time.end", "time.dt", "time.dt_growth", "time.dt_max", "time.scheme",
                  "mechanics.tolerance", "mechanics.max_iterations", "mechanics.nonlinear_solver",
                  "mechanics.secant_relaxation", "output.every", "output.figures", "output.figure_window",
                  "output.sections", "output.checkpoint_every")


@dataclass
class Checkpoint:
    """A loaded checkpoint: ``meta`` (JSON data), ``arrays`` (name -> numpy array), the file it came from."""

    meta: dict
    arrays: dict
    path: Path

    @property
    def staging(self) -> Path:
        """The staging directory holding this checkpoint."""
        return self.path.parent.parent


def write_checkpoint(directory: Path, meta: dict, arrays: dict[str, np.ndarray]) -> Path:
    """Write a checkpoint into ``directory`` atomically, keeping the one before as ``previous.npz``."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for stale in directory.glob(f".{CURRENT}.*.tmp"):     # left by a run killed while writing
        stale.unlink(missing_ok=True)
    payload = {f"a/{k}": np.ascontiguousarray(v) for k, v in arrays.items()}
    payload["meta"] = np.frombuffer(json.dumps({"format": FORMAT, **meta}).encode(), dtype=np.uint8)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{CURRENT}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **payload)
            fh.flush()
            os.fsync(fh.fileno())
        current = directory / CURRENT
        if current.exists():
            os.replace(current, directory / PREVIOUS)
        os.replace(tmp, current)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    _fsync_dir(directory)
    return current


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def read_checkpoint_file(path: Path) -> Checkpoint:
    """Load one checkpoint file completely (every array is read, so the zip's CRC checks run)."""
    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(bytes(data["meta"]).decode())
        arrays = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("a/")}
    if meta.get("format") != FORMAT:
        raise ValueError(f"not a checkpoint of this format ({meta.get('format')!r})")
    return Checkpoint(meta, arrays, Path(path))


def load_checkpoint(directory: Path) -> Checkpoint:
    """The newest complete checkpoint in ``directory`` (``checkpoint.npz``, else ``previous.npz``)."""
    directory = Path(directory)
    reasons = []
    for name in (CURRENT, PREVIOUS):
        path = directory / name
        if not path.exists():
            continue
        try:
            return read_checkpoint_file(path)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            reasons.append(f"{path.name}: {exc}")
    detail = f" ({'; '.join(reasons)})" if reasons else ""
    raise ResumeError(f"no readable checkpoint in {directory}{detail}")


def has_checkpoint(staging: Path) -> bool:
    d = Path(staging) / DIRNAME
    return (d / CURRENT).exists() or (d / PREVIOUS).exists()


def find_resumable(target: Path) -> list[Checkpoint]:
    """The checkpoints interrupted runs into ``target`` left, newest first: the readable ones in the staging
    directories ``.<target>.partial-*`` beside it that no running process holds (ResumeError if none)."""
    target = Path(target).resolve()
    found, busy, broken = [], [], []
    for d in staging_dirs(target):
        if not has_checkpoint(d):
            continue
        if is_locked(d):
            busy.append(d.name)
            continue
        try:
            found.append(load_checkpoint(d / DIRNAME))
        except ResumeError as exc:
            broken.append(str(exc))
    if found:
        return sorted(found, key=lambda c: (c.meta.get("written", 0.0), c.meta.get("step", 0)), reverse=True)
    msg = (f"nothing to resume for {target}: no interrupted run left a checkpoint in "
           f"{target.parent}/.{target.name}.partial-*")
    if busy:
        msg += f"; {', '.join(busy)} belong(s) to a run that is still running"
    if broken:
        msg += "; " + "; ".join(broken)
    raise ResumeError(msg + ". Run without --resume to start anew.")


def checkpoint_meta_base(scene_dict: dict) -> dict:
    """The scene part of a checkpoint's meta: the scene and the hash of its non-resumable part."""
    return {"scene": scene_dict, "scene_hash": scene_hash(scene_dict), "written": time.time()}


def _reduced(scene_dict: dict) -> dict:
    out = json.loads(json.dumps(scene_dict))
    for key in RESUMABLE_KEYS:
        *path, last = key.split(".")
        node = out
        for p in path:
            node = node.get(p) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(last, None)
    return out


def scene_hash(scene_dict: dict) -> str:
    """sha256 of the scene without the keys that may change on resume (:data:`RESUMABLE_KEYS`)."""
    return hashlib.sha256(json.dumps(_reduced(scene_dict), sort_keys=True).encode()).hexdigest()


def scene_differences(old: dict, new: dict) -> list[str]:
    """Where two scenes differ outside :data:`RESUMABLE_KEYS`, one line per item (``materials.rock.rho_c:
    2200000.0 in the checkpoint, 2300000.0 now``); list items of named tables by name."""
    out: list[str] = []
    _diff(_reduced(old), _reduced(new), "", out)
    return out


def _named(items: list) -> bool:
    names = [i.get("name") for i in items if isinstance(i, dict)]
    return len(names) == len(items) and all(names) and len(set(names)) == len(names)


def _diff(a, b, path: str, out: list[str]) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            p = f"{path}.{k}" if path else k
            if k not in b:
                out.append(f"{p}: {_show(a[k])} in the checkpoint, not set now")
            elif k not in a:
                out.append(f"{p}: not set in the checkpoint, {_show(b[k])} now")
            else:
                _diff(a[k], b[k], p, out)
    elif isinstance(a, list) and isinstance(b, list) and _named(a) and _named(b):
        na, nb = [i["name"] for i in a], [i["name"] for i in b]
        if na != nb:
            out.append(f"{path}: {na} in the checkpoint, {nb} now")
            return
        for x, y in zip(a, b):
            _diff(x, y, f"{path}.{x['name']}", out)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b) and \
            any(isinstance(x, (dict, list)) for x in a):
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{path}.{i}", out)
    elif a != b:
        out.append(f"{path}: {_show(a)} in the checkpoint, {_show(b)} now")


def _show(v) -> str:
    text = json.dumps(v)
    return text if len(text) <= 60 else text[:57] + "..."
