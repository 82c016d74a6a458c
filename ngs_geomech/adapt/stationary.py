"""Mesh policies built on the adaptive loop (:func:`.loop.adaptive_solve`: SOLVE -> ESTIMATE -> MARK -> REFINE,
:class:`.loop.AdaptiveProblem`): :class:`StationaryAdaptive` (a stationary scene: each step solves its heat
problem and then its mechanics) and :class:`PreAdapted` (a transient scene on a mesh adapted once to the steady
heat problem with the data at the start time). Interface: :mod:`.policy`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from .. import parallel
from ..geometry.mesh import SerialCopy
from ..parallel import comm, distributed
from ..scene.model import Scene
from .contact_following import contact_statuses
from .distributed import DistributedRefinement
from .loop import AdaptiveRun, SerialRefinement, adaptive_solve
from .marking import StopRule
from .policy import MeshPolicy

log = logging.getLogger(__name__)


class _Adaptive(MeshPolicy):
    """A scene on a mesh refined by the adaptive loop: an :class:`~.loop.AdaptiveProblem` whose solve is the
    scene's heat problem (and, stationary, its mechanics) on the current mesh; refining bisects the marked
    elements (curved again to the mesh order) and builds the model anew on the refined mesh. On a distributed
    mesh rank 0 refines its copy of the whole mesh (``serial_copy``, filled by
    :func:`~ngs_geomech.geometry.mesh.make_mesh`; the scene's geometry ``geo`` curves the parts) and sends the
    refined mesh out (:class:`.distributed.DistributedRefinement`)."""

    adapts_first = True

    def __init__(self, scene: Scene, build: Callable, geo=None):
        super().__init__()
        self.scene, self.build, self.geo = scene, build, geo
        self.serial_copy = SerialCopy()
        self.refinement = SerialRefinement()
        self.model = None
        self.result: AdaptiveRun | None = None
        self.refinements = 0
        a = scene.adaptivity
        self.estimator = a.estimator
        self.target = a.target or "heat"

    @property
    def mesh(self):
        return self.model.mesh

    @property
    def ndof(self) -> int:
        """The unknowns on the whole mesh (every rank of a distributed run: the stop rule's dof budget)."""
        return self.model.ndof_global

    def prepare(self, model, t0: float | None):
        self.model = model
        if distributed(model.mesh):
            self.refinement = DistributedRefinement(self.serial_copy, self.geo, self.scene.mesh, comm(model.mesh))
        a = self.scene.adaptivity
        self.result = adaptive_solve(self, estimator=a.estimator, indicators=tuple(a.indicators), marker=a.marker,
                                     theta=a.theta, stop=StopRule(tolerance=a.tolerance, max_dofs=a.max_dofs,
                                                                  max_refinements=a.max_refinements))
        return self.model

    def solve(self) -> dict:
        raise NotImplementedError

    def estimator_input(self, needs: str):
        m = self.model
        if needs == "forms":
            return m.mechanics.forms if self.target == "mechanics" else m.thermal.forms
        if needs == "contact":
            return self.mesh, contact_statuses(m.mechanics)
        raise ValueError(f"a scene has no {needs!r} input for an estimator")

    def refine(self, marks) -> None:
        order = self.scene.mesh.order
        mesh = self.refinement.refine(self.mesh, marks, order if order >= 2 else 0)
        self.refinements += 1
        self.model = self.build(mesh)

    def summary(self) -> dict:
        r = self.result
        a = self.scene.adaptivity
        return {"estimator": self.estimator, "target": self.target, "marker": a.marker, "theta": a.theta,
                "stop_reason": r.stop,
                "steps": [{"refinement": s.refinement, "ndof": s.ndof, "elements": s.elements,
                           "estimate": s.estimate, "marked": s.marked, "flagged": s.flagged,
                           "solve_s": s.solve_s, "estimate_s": s.estimate_s} for s in r.steps]}


class StationaryAdaptive(_Adaptive):
    """A stationary scene solved by the adaptive loop: each step solves the steady heat problem and then the
    mechanics; the scene's estimator measures the target problem's error (default: the mechanics when the
    scene has it)."""

    def __init__(self, scene: Scene, build: Callable, geo=None):
        super().__init__(scene, build, geo)
        self.target = scene.adaptivity.target or ("mechanics" if scene.physics.mechanics else "heat")

    def solve(self) -> dict:
        where = f"adaptive step {self.refinements} (steady state)"
        self.model.steady(where)
        log.info("adaptivity: step %d: %d dofs, %d elements", self.refinements, self.ndof,
                 parallel.allsum(self.mesh, self.mesh.ne))
        return {}

    def steady(self, model, where: str):
        return model                       # solved by the adaptive loop on the final mesh

    def figures(self, canvas) -> None:
        steps = self.result.steps
        canvas.draw.convergence_figure([s.ndof for s in steps], {f"estimate ({self.estimator})":
                                                                [s.estimate for s in steps]},
                                       canvas.path("adaptivity.png"),
                                       title=f"{canvas.title}: adaptive refinement ({self.target})",
                                       ylabel="estimated error (energy norm)")


class PreAdapted(_Adaptive):
    """A transient scene on a mesh adapted once to the steady heat problem with the data at the start time (the
    step operator with 1/dt = 0 and theta = 1), the mechanics not solved while adapting."""

    def prepare(self, model, t0: float | None):
        self.t0 = t0
        return super().prepare(model, t0)

    def solve(self) -> dict:
        where = f"adaptive step {self.refinements} (steady state)"
        self.model.thermal.steady_at(self.t0, where)
        log.info("adaptivity: step %d: %d dofs, %d elements", self.refinements, self.ndof,
                 parallel.allsum(self.mesh, self.mesh.ne))
        return {}

    def summary(self) -> dict:
        return {"mode": "pre_adapted", "adapted_at_s": self.t0, **super().summary()}
