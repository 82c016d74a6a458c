"""Running a scene (:func:`run_scene`): the driver (:mod:`.driver`), the parts of a scene on one mesh
(:mod:`.model`), what a run writes (:mod:`.output`) and its checkpoints (:mod:`.checkpoint`)."""

from .driver import RunResult, run_scene

__all__ = ["RunResult", "run_scene"]
