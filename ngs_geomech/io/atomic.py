"""Writing output completely or not at all.

A run writes into a staging directory beside the target; :meth:`OutputDir.commit` renames it into place
in one step, :meth:`OutputDir.abort` removes it. Single files are written to a temporary name and renamed.
"""

from __future__ import annotations

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


class OutputDir:
    """A staging directory for one run's output; ``path`` is where files go while the run lasts."""

    def __init__(self, target: Path):
        self.target = Path(target).resolve()
        self._made = [p for p in reversed(self.target.parents) if not p.exists()]  # removed again on abort
        self.target.parent.mkdir(parents=True, exist_ok=True)
        self.path = Path(tempfile.mkdtemp(dir=self.target.parent, prefix=f".{self.target.name}.partial-"))
        os.chmod(self.path, 0o777 & ~_umask())  # mkdtemp creates 0700; the output is an ordinary directory

    def commit(self) -> Path:
        """Move the staged output to the target (replacing an older output there)."""
        old = None
        if self.target.exists():
            old = self.target.parent / f".{self.target.name}.old-{os.getpid()}"
            os.replace(self.target, old)
        os.replace(self.path, self.target)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return self.target

    def abort(self) -> None:
        """Remove the staged output and any parent directories this run created."""
        shutil.rmtree(self.path, ignore_errors=True)
        for p in reversed(self._made):
            try:
                p.rmdir()
            except OSError:
                break
