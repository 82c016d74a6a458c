"""The public entry points used by the CLI, studies and tests."""

from __future__ import annotations

from pathlib import Path

from .run import RunResult, run_scene
from .scene.model import Scene
from .scene.parse import builtin_scenes, load_scene
from .validation.validate import validate


def list_builtin() -> dict[str, Path]:
    return builtin_scenes()


def validate_scene(scene: str | Path | Scene, overrides: list[str] | None = None) -> str:
    """Validate a scene; return a one-paragraph description, or raise SceneError listing all problems."""
    sc = scene if isinstance(scene, Scene) else load_scene(scene, overrides)
    geo = validate(sc)
    return (f"scene {sc.scene.name!r} is valid: {sc.scene.dimension}, {len(sc.blocks)} block(s) "
            f"{geo.regions}, boundaries {sorted(geo.boundaries)}, glued interfaces {sorted(geo.glued)}, "
            f"contact interfaces {sorted(geo.contacts)}, physics thermal={sc.physics.thermal}, "
            f"mechanics={sc.physics.mechanics}")


def run(scene: str | Path | Scene, out: str | Path | None, *, overrides: list[str] | None = None,
        progress: bool = True, threads: int | None = None, resume: bool = False, overwrite: bool = False,
        comm=None) -> RunResult:
    """Load (if needed) and run a scene, writing into ``out`` (None: write nothing; an ``out`` holding files
    other than an earlier output needs ``overwrite=True``, see :mod:`ngs_geomech.io.outdir`). ``resume=True``
    continues the interrupted time-dependent run into ``out`` from its last checkpoint. ``comm``: an mpi4py
    communicator of several ranks that run the scene together on a distributed mesh
    (:func:`ngs_geomech.parallel.world` under ``mpiexec``); None: this process alone."""
    sc = scene if isinstance(scene, Scene) else load_scene(scene, overrides)
    return run_scene(sc, out, progress=progress, threads=threads, resume=resume, overwrite=overwrite, comm=comm)
