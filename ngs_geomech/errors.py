"""Exceptions of ngs-geomech.

Every error a user can cause names the offending item (scene key, region, boundary, value).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Problem:
    """One problem found in a scene: ``item`` is a dotted path such as ``materials.granite.rho_c``."""

    item: str
    message: str

    def __str__(self) -> str:
        return f"{self.item}: {self.message}"


class GeomechError(Exception):
    """Base class of the package's errors."""


class SceneError(GeomechError):
    """A scene is invalid; ``problems`` lists every problem found, each naming its item."""

    def __init__(self, problems: list[Problem], source: str = "scene"):
        self.problems = list(problems)
        self.source = source
        lines = [f"{source}: {len(self.problems)} problem(s)"]
        lines += [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


class MaterialError(ValueError):
    """Invalid material data. ``key`` is the material key at fault (``""`` when no single key is, e.g. no elastic
    constants at all; nested keys use dots and list items brackets: ``orthotropic.E[1]``) and ``detail`` what is
    wrong with it; the message starts with the key, e.g. ``youngs_modulus must be positive, got -1e+09 Pa``, so
    that a caller can report ``materials.<region>.<key>``."""

    def __init__(self, key: str, message: str):
        self.key = key
        self.detail = message
        super().__init__(message if not key else f"{key}{'' if message.startswith(':') else ' '}{message}")


class SolverError(GeomechError):
    """A solve failed (divergence, stagnation, NaN); the message says which solve, where and what to change."""


class ResumeError(GeomechError):
    """A run cannot be resumed: no checkpoint, or the scene or mesh differs from the checkpointed run's."""


class OutputError(GeomechError):
    """The output directory cannot be used as asked (an existing file, ``/`` or a mount point, not writable, a
    directory of the user's files without ``--overwrite``), or the disk filled up while writing it."""
