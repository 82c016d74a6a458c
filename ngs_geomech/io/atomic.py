"""Writing output completely or not at all, and never touching a file the program did not write.

A run writes into a staging directory ``.<target>.partial-XXXX`` beside the target (inside an existing target,
as ``.ngs-geomech.partial-XXXX``, when its parent is not writable); :meth:`OutputDir.commit` renames a new
target into place in one step, or moves the staged files into an existing target (:mod:`.outdir`: which
targets are allowed, what in them the program owns); :meth:`OutputDir.abort` removes the staging directory
(or keeps it, when it holds a checkpoint a later run may resume from). While a run lives it holds an exclusive
``flock`` on the file ``<staging>.lock`` beside its staging directory (released by the kernel when the process
dies, also by SIGKILL): a staging directory whose lock can be taken belongs to no running process. Single
files are written to a temporary name and renamed.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import shutil
import tempfile
from pathlib import Path

from .outdir import INNER_STAGING, MARKER, check_output, creating, owned_files


@contextlib.contextmanager
def replacing(path: Path, suffix: str = ".tmp"):
    """A temporary file beside ``path`` to write into: renamed to ``path`` (with the usual permissions) when the
    block ends, removed when it fails, so readers see the old file or the whole new one, never a truncated one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())    # mkstemp creates 0600
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_text_atomic(path: Path, text: str) -> None:
    """Write a text file completely or not at all (:func:`replacing`), synced to the disk before the rename."""
    with replacing(path) as tmp, open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_json_atomic(path: Path, data: object) -> None:
    write_text_atomic(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


def staging_dirs(target: Path) -> list[Path]:
    """The staging directories of runs into ``target`` (running, killed or failed), oldest first."""
    dirs = [p for d, pattern in _staging_places(target) for p in d.glob(pattern) if p.is_dir()]
    return sorted(dirs, key=lambda p: p.stat().st_mtime)


def _staging_places(target: Path) -> list[tuple[Path, str]]:
    """Where staging directories of ``target`` are: (directory, glob pattern) pairs."""
    target = Path(target).resolve()
    return [(d, pattern) for d, pattern in ((target.parent, f".{target.name}.partial-*"),
                                            (target, f"{INNER_STAGING}*")) if d.is_dir()]


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
    for d, pattern in _staging_places(target):          # lock files whose directory is gone
        for lock in d.glob(f"{pattern}.lock"):
            if not lock.with_suffix("").exists():
                fd = _try_lock(lock)
                if fd is not None:
                    lock.unlink(missing_ok=True)
                    os.close(fd)
    return removed


def write_marker(directory: Path, command: str, files, scene: str | None = None, complete: bool = True) -> None:
    """Write the marker of an output directory (:mod:`.outdir`): the program wrote ``files`` there."""
    from .. import __version__
    write_json_atomic(Path(directory) / MARKER, {"program": "ngs-geomech", "version": __version__,
                                                 "command": command, "scene": scene, "complete": complete,
                                                 "files": sorted(set(files))})


def _files(directory: Path) -> list[str]:
    """The files under ``directory`` as relative POSIX paths, the marker excluded."""
    return sorted(p.relative_to(directory).as_posix() for p in directory.rglob("*")
                  if p.is_file() and p.name != MARKER)


class OutputDir:
    """A staging directory for one run's output; ``path`` is where files go while the run lasts.

    ``OutputDir(target)`` checks ``target`` (:func:`.outdir.check_output`: :class:`OutputError` before any work
    when it may not be used; ``overwrite`` allows a directory of other files) and makes a new staging
    directory; ``OutputDir(target, resume=staging)`` takes over the staging directory an interrupted run left
    (raises ``BlockingIOError`` when a running process holds it). ``path / SCRATCH`` (the checkpoints) is
    removed before the output is committed. ``command`` and ``scene`` go into the output's marker.
    """

    SCRATCH = "checkpoint"

    def __init__(self, target: Path, resume: Path | None = None, *, overwrite: bool = False, command: str = "run",
                 scene: str | None = None):
        self.target = check_output(target, command=command, overwrite=overwrite, resume=resume is not None)
        self.command, self.scene = command, scene
        self._made = [p for p in reversed(self.target.parents) if not p.exists()]  # removed again on abort
        if resume is None:
            with creating(target):
                try:
                    self.path = self._create()
                except BaseException:
                    self._remove_made()
                    raise
            self._lock = _try_lock(_lock_path(self.path))
        else:
            self.path = Path(resume).resolve()
            self._lock = _try_lock(_lock_path(self.path))
            if self._lock is None:
                raise BlockingIOError(f"{self.path} is held by a running process")
        for tmp in [p for p in self.path.rglob(".*") if p.is_file()]:    # temporary files of a killed run
            tmp.unlink(missing_ok=True)

    def _create(self) -> Path:
        """A new staging directory: beside the target (a new target then appears in one rename), or inside
        an existing target whose parent is not writable (``--out .`` in a directory one may not write beside)."""
        self.target.parent.mkdir(parents=True, exist_ok=True)
        try:
            path = tempfile.mkdtemp(dir=self.target.parent, prefix=f".{self.target.name}.partial-")
        except OSError as exc:
            if exc.errno not in (errno.EACCES, errno.EPERM, errno.EROFS) or not self.target.is_dir():
                raise
            path = tempfile.mkdtemp(dir=self.target, prefix=INNER_STAGING)
        os.chmod(path, 0o777 & ~_umask())  # mkdtemp creates 0700; the output is an ordinary directory
        return Path(path)

    @property
    def scratch(self) -> Path:
        return self.path / self.SCRATCH

    def _release(self) -> None:
        if self._lock is not None:
            _lock_path(self.path).unlink(missing_ok=True)
            os.close(self._lock)
            self._lock = None

    def commit(self) -> Path:
        """Put the staged output in place: rename it to a new target, or move its files into an existing one
        (:meth:`_move_into`); remove the staging directories that killed or failed runs into the same target
        left."""
        files = [f for f in _files(self.path) if not f.startswith(f"{self.SCRATCH}/")]
        if self.target.exists():
            self._move_into(files)
        else:
            write_marker(self.path, self.command, files, self.scene)
            shutil.rmtree(self.scratch, ignore_errors=True)
            os.replace(self.path, self.target)
            self._lock_file_moved()
        self.path = self.target
        remove_stale_staging(self.target)
        return self.target

    def _lock_file_moved(self) -> None:
        """Release the lock of a staging directory that is now the target (its lock file stays beside)."""
        if self._lock is not None:
            lock = _lock_path(self.path)
            os.close(self._lock)
            self._lock = None
            lock.unlink(missing_ok=True)

    def _move_into(self, files: list[str]) -> None:
        """Move the staged ``files`` into the existing target: same-named files are replaced, the files an
        earlier output of the same command wrote there (its marker) and this one does not are removed, every
        other file is kept. The marker lists the old and new files (``complete: false``) while the files move
        and ``summary.json`` moves last, so a commit cut short leaves every program file listed."""
        old = owned_files(self.target, self.command)
        write_marker(self.target, self.command, old + files, self.scene, complete=False)
        shutil.rmtree(self.scratch, ignore_errors=True)
        for rel in sorted(set(old) - set(files)):
            with contextlib.suppress(IsADirectoryError, PermissionError, FileNotFoundError):
                (self.target / rel).unlink()
        for rel in sorted(files, key=lambda f: (f == "summary.json", f)):
            dest = self.target / rel
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(self.path / rel, dest)
        for d in sorted({(self.target / rel).parent for rel in old}, key=lambda p: -len(p.parts)):
            if d != self.target:
                with contextlib.suppress(OSError):
                    d.rmdir()                       # only when empty: a directory of the old output's files
        write_marker(self.target, self.command, files, self.scene)
        shutil.rmtree(self.path)                    # empty directories only
        self._release()

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
        self._remove_made()

    def _remove_made(self) -> None:
        for p in reversed(self._made):
            try:
                p.rmdir()
            except OSError:
                break
