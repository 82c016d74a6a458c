"""Writing output completely or not at all.

A run writes into a staging directory ``.<target>.partial-XXXX`` beside the target; :meth:`OutputDir.commit`
renames it into place in one step, :meth:`OutputDir.abort` removes it (or keeps it, when it holds a
checkpoint a later run may resume from). While a run lives it holds an exclusive ``flock`` on the file
``.<target>.partial-XXXX.lock`` beside its staging directory (released by the kernel when the process dies,
also by SIGKILL): a staging directory whose lock can be taken belongs to no running process. Single files
are written to a temporary name and renamed.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import tempfile
from pathlib import Path


def write_text_atomic(path: Path, text: str) -> None:
    """Write a text file so that readers see the old file or the whole new one, never a truncated one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())    # mkstemp creates 0600; give the file the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_json_atomic(path: Path, data: object) -> None:
    write_text_atomic(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


def staging_dirs(target: Path) -> list[Path]:
    """The staging directories of runs into ``target`` (running, killed or failed), oldest first."""
    target = Path(target).resolve()
    if not target.parent.is_dir():
        return []
    dirs = [p for p in target.parent.glob(f".{target.name}.partial-*") if p.is_dir()]
    return sorted(dirs, key=lambda p: p.stat().st_mtime)


def _lock_path(staging: Path) -> Path:
    return staging.parent / f"{staging.name}.lock"


def _try_lock(path: Path) -> int | None:
    """An fd holding an exclusive lock on ``path`` (created if absent), or None when another holds it."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666 & ~_umask())
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def is_locked(staging: Path) -> bool:
    """Whether a running process holds the staging directory ``staging``."""
    path = _lock_path(Path(staging))
    if not path.exists():
        return False
    fd = _try_lock(path)
    if fd is None:
        return True
    os.close(fd)
    return False


def remove_stale_staging(target: Path, keep: Path | None = None) -> list[Path]:
    """Remove the staging directories of ``target`` that no running process holds (killed or failed runs),
    and their lock files; return what was removed."""
    target = Path(target).resolve()
    removed = []
    for d in staging_dirs(target):
        if keep is not None and d.resolve() == Path(keep).resolve():
            continue
        lock = _lock_path(d)
        fd = _try_lock(lock)
        if fd is None:
            continue
        try:
            shutil.rmtree(d, ignore_errors=True)
            lock.unlink(missing_ok=True)
            removed.append(d)
        finally:
            os.close(fd)
    if target.parent.is_dir():          # lock files whose directory is gone
        for lock in target.parent.glob(f".{target.name}.partial-*.lock"):
            if not lock.with_suffix("").exists():
                fd = _try_lock(lock)
                if fd is not None:
                    lock.unlink(missing_ok=True)
                    os.close(fd)
    return removed


class OutputDir:
    """A staging directory for one run's output; ``path`` is where files go while the run lasts.

    ``OutputDir(target)`` makes a new staging directory; ``OutputDir(target, resume=staging)`` takes over the
    staging directory an interrupted run left (raises ``BlockingIOError`` when a running process holds it).
    ``path / SCRATCH`` (the checkpoints) is removed before the output is committed.
    """

    SCRATCH = "checkpoint"

    def __init__(self, target: Path, resume: Path | None = None):
        self.target = Path(target).resolve()
        self._made = [p for p in reversed(self.target.parents) if not p.exists()]  # removed again on abort
        self.target.parent.mkdir(parents=True, exist_ok=True)
        if resume is None:
            self.path = Path(tempfile.mkdtemp(dir=self.target.parent, prefix=f".{self.target.name}.partial-"))
            os.chmod(self.path, 0o777 & ~_umask())  # mkdtemp creates 0700; the output is an ordinary directory
            self._lock = _try_lock(_lock_path(self.path))
        else:
            self.path = Path(resume).resolve()
            self._lock = _try_lock(_lock_path(self.path))
            if self._lock is None:
                raise BlockingIOError(f"{self.path} is held by a running process")
        for tmp in [p for p in self.path.rglob(".*") if p.is_file()]:    # temporary files of a killed run
            tmp.unlink(missing_ok=True)

    @property
    def scratch(self) -> Path:
        return self.path / self.SCRATCH

    def _release(self) -> None:
        if self._lock is not None:
            _lock_path(self.path).unlink(missing_ok=True)
            os.close(self._lock)
            self._lock = None

    def commit(self) -> Path:
        """Move the staged output to the target (replacing an older output there); remove the staging
        directories that killed or failed runs into the same target left."""
        shutil.rmtree(self.scratch, ignore_errors=True)
        old = None
        if self.target.exists():
            old = self.target.parent / f".{self.target.name}.old-{os.getpid()}"
            os.replace(self.target, old)
        staging = self.path
        os.replace(self.path, self.target)
        self.path = self.target
        lock = _lock_path(staging)
        if self._lock is not None:
            lock.unlink(missing_ok=True)
            os.close(self._lock)
            self._lock = None
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        remove_stale_staging(self.target)
        return self.target

    def abort(self, keep: bool = False) -> None:
        """Remove the staged output and any parent directories this run created; ``keep=True`` leaves the
        staging directory (it holds a checkpoint) for a later ``--resume``."""
        if keep:
            if self._lock is not None:
                os.close(self._lock)     # the lock file stays; nobody holds it now
                self._lock = None
            return
        shutil.rmtree(self.path, ignore_errors=True)
        self._release()
        for p in reversed(self._made):
            try:
                p.rmdir()
            except OSError:
                break
