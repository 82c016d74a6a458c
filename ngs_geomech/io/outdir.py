"""Which directory ``--out DIR`` may write into, and which files in it belong to the program.

Every output directory holds the marker file ``ngs-geomech-output.json`` (:data:`MARKER`; JSON: program,
version, command, scene, ``complete`` and ``files``, the files the program wrote there as relative paths).
The rules, checked by :func:`check_output` before any meshing or solving (one :class:`OutputError` line that
names DIR and what to do):

- DIR is resolved first: a symbolic link names its target directory (the link stays a link); a link to
  nothing is refused;
- ``/``, a mount point, an existing file, or a parent that is a file or not writable: refused;
- DIR absent: the run creates it (with missing parents) when it commits;
- DIR empty, or the output of an earlier run of the same command (its marker): used; the files that earlier
  run wrote (its marker's list) are replaced or removed, every other file in DIR is kept;
- DIR a non-empty directory of other files: refused unless ``overwrite``; with it the outputs are written into
  DIR, files of the same names replaced, nothing else removed.

So the program never removes or replaces a file it did not write, except a same-named file under
``overwrite``, and never replaces an existing directory (``--out .`` stays the directory it is).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
from pathlib import Path, PurePosixPath

from ..errors import OutputError

MARKER = "ngs-geomech-output.json"
INNER_STAGING = ".ngs-geomech.partial-"     # a staging directory inside an existing DIR (see OutputDir)
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)


def read_marker(directory: Path) -> dict | None:
    """The marker of ``directory`` when it is one the program wrote, else None."""
    try:
        data = json.loads((Path(directory) / MARKER).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("program") != "ngs-geomech" or not isinstance(data.get("files"), list):
        return None
    return data


def owned_files(directory: Path, command: str) -> list[str]:
    """The files an earlier run of ``command`` wrote into ``directory`` (its marker's list); paths that would
    leave the directory (absolute, ``..``) are dropped, so a hand-edited marker reaches nothing outside."""
    marker = read_marker(directory)
    if marker is None or marker.get("command") != command:
        return []
    return [f for f in marker["files"] if isinstance(f, str) and _inside(f)]


def _inside(rel: str) -> bool:
    p = PurePosixPath(rel)
    return bool(rel) and not p.is_absolute() and ".." not in p.parts and rel not in (".", MARKER)


def others(directory: Path, command: str) -> list[str]:
    """The entries of the existing directory ``directory`` that make it someone else's: none when it is the
    output of an earlier ``command`` run (its marker), else every entry except staging directories of runs."""
    marker = read_marker(directory)
    if marker is not None and marker.get("command") == command:
        return []
    return sorted(n for n in os.listdir(directory) if n != MARKER and not n.startswith(INNER_STAGING))


def check_output(out: str | Path, *, command: str, overwrite: bool = False, resume: bool = False) -> Path:
    """Check ``--out`` by the rules of the module docstring (``resume``: the directory of an interrupted run,
    used as it is); return its real path, or raise :class:`OutputError`."""
    given = Path(out).expanduser()
    real = Path(os.path.realpath(given))
    if given.is_symlink() and not real.exists():
        raise OutputError(f"--out {given} is a symbolic link to {real}, which does not exist: create that directory "
                          "or give another --out")
    if real == Path(real.anchor) or os.path.ismount(real):
        what = "the root directory" if real == Path(real.anchor) else f"a mount point ({real})"
        raise OutputError(f"--out {given} is {what}: an output needs a directory of its own; give a new directory "
                          f"inside it, e.g. --out {real / 'out'}")
    if real.exists() and not real.is_dir():
        raise OutputError(f"--out {given} is an existing file, not a directory: give another --out (the file is "
                          "left as it is)")
    if real.is_dir():
        try:
            found = [] if resume or overwrite else others(real, command)
        except PermissionError:
            raise OutputError(f"--out {given}: {real} is not readable: give another --out") from None
        if found:
            shown = ", ".join(found[:3]) + (f" and {len(found) - 3} more" if len(found) > 3 else "")
            raise OutputError(f"--out {given} is a directory of other files ({shown}), not an output of "
                              f"'ngs-geomech {command}': give a new or empty directory, or add --overwrite to write "
                              "into it (files of the same names are replaced, no other file is touched)")
        where = real
    else:
        where = next(p for p in real.parents if p.exists())
        if not where.is_dir():
            raise OutputError(f"--out {given}: {where} is a file, not a directory: give another --out")
    if not os.access(where, os.W_OK | os.X_OK):
        raise OutputError(f"--out {given}: {where} is not writable: give another --out")
    return real


@contextlib.contextmanager
def creating(out: str | Path):
    """Turn the failure to create the output's directories (no permission, read-only file system, a file in
    the way, disk full) into one :class:`OutputError` line naming the path."""
    try:
        yield
    except OSError as exc:
        if exc.errno not in (errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOTDIR, errno.EEXIST, *DISK_FULL):
            raise
        raise OutputError(f"--out {out}: cannot create {exc.filename or 'the output directory'}: "
                          f"{exc.strerror or exc}; give another --out") from None


def disk_full(exc: BaseException) -> bool:
    return isinstance(exc, OSError) and exc.errno in DISK_FULL
