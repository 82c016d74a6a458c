"""What a scene solves on one mesh (:class:`Model`): its parts (:class:`~ngs_geomech.parts.Part`), built only as
the scene declares: a thermal part (the Stefan problem when a material changes phase, else heat), a mechanics
part (static, or dynamic/viscous) and their coupling; the output fields of all of them. And the mesh policy a
scene declares (:func:`mesh_policy`).

Each part's module is imported when a scene declares that part, not with this module: a heat scene does not load
the contact, Stefan or dynamics solvers (and what they import: scipy's optimizers, sparse factorizations), so every
run and every uncertainty sample starts as fast as its physics allows.
"""

from __future__ import annotations

from ..adapt.policy import FixedMesh, MeshPolicy
from ..geometry.assemble import GeometryModel
from ..parts import Step
from ..scene.model import Scene
from ..validation.validate import stefan_scene


class Model:
    """The parts of a scene on ``mesh`` (module docstring): ``thermal``, ``mechanics``, ``coupling`` (each None
    when the scene lacks it), ``parts`` (those present, in this order), ``fields`` (the region id and every part's
    fields: what the VTK holds). A coupled run advances the coupling part, which steps the other two; otherwise
    each part advances in turn."""

    def __init__(self, scene: Scene, geo: GeometryModel, mesh):
        self.scene, self.mesh = scene, mesh
        self.thermal = None
        if stefan_scene(scene):           # phase change: the enthalpy (Stefan) solver replaces the heat solver
            from ..stefan.problem import StefanRun
            self.thermal = StefanRun(scene, mesh, geo)
        elif scene.physics.thermal:
            from ..heat.run import HeatRun
            self.thermal = HeatRun(scene, geo, mesh)
        T = self.thermal.T if self.thermal is not None else None
        T0 = self.thermal.interpolate if self.thermal is not None else None
        self.mechanics = None
        if scene.physics.mechanics in ("dynamic", "viscous"):
            from ..dynamics.problem import DynamicsRun
            self.mechanics = DynamicsRun(scene, geo, mesh, T, interpolate=T0)
        elif scene.physics.mechanics:
            from ..mechanics.run import StaticMechanicsRun
            self.mechanics = StaticMechanicsRun(scene, geo, mesh, T, interpolate=T0)
        self.coupling = None
        if scene.physics.coupling != "none" and self.mechanics is not None and self.thermal is not None:
            from ..coupling.run import CouplingRun
            self.coupling = CouplingRun(scene, self.thermal, self.mechanics)
        self.parts = [p for p in (self.thermal, self.mechanics, self.coupling) if p is not None]
        self.steppers = [self.coupling] if self.coupling is not None else self.parts
        self.fields = {"region": mesh.MaterialCF({n: i for i, n in enumerate(mesh.GetMaterials())}, default=-1)}
        self.derived = {}
        for p in self.parts:
            self.fields.update(p.fields)
            self.derived.update(p.derived_fields())

    def steady(self, where: str) -> None:
        for p in self.parts:
            p.steady(where)

    def start(self, t0: float, where: str) -> None:
        for p in self.parts:
            p.start(t0, where)

    def advance(self, step: Step) -> None:
        for p in self.steppers:
            p.advance(step)

    def record(self, t: float, output: bool) -> None:
        """The parts keep the state at t (s): at the output times, and every step those that record every step.
        Without coupling the thermal part is told where the mechanics closes an interface that carries no heat."""
        for p in self.parts:
            if output or p.records_every_step:
                p.record(t)
        if output and self.coupling is None and self.thermal is not None and self.mechanics is not None:
            known = {w.split(":", 1)[0] for w in self.thermal.warnings}
            for w in self.thermal.contact_warnings(self.mechanics.contact_state(recorded=True)):
                if w.split(":", 1)[0] not in known:
                    known.add(w.split(":", 1)[0])
                    self.thermal.warnings.append(w)

    def take_state(self, old: Model, t0: float | None) -> tuple[float, float, object]:
        """The thermal state of ``old`` (the same scene on another mesh) carried over
        (:meth:`HeatRun.take_state` / :meth:`StefanRun.take_state`)."""
        return self.thermal.take_state(old.thermal, t0)

    @property
    def newton_iterations(self) -> list[int]:
        """The thermal part's Newton iterations per step (empty without one)."""
        return self.thermal.newton_iterations if self.thermal is not None else []

    @property
    def warnings(self) -> list[str]:
        return [w for p in self.parts for w in p.warnings]

    @property
    def ndof(self) -> int:
        return sum(p.ndof for p in self.parts)

    @property
    def ndof_global(self) -> int:
        """The unknowns on the whole mesh (``ndof`` on a serial one; the same on every rank)."""
        return sum(p.ndof_global for p in self.parts)

    @property
    def factorizations(self) -> int:
        return sum(p.factorizations for p in self.parts)


def mesh_policy(scene: Scene, geo: GeometryModel, build) -> MeshPolicy:
    """The mesh policy a validated scene declares (``[adaptivity]``; :mod:`ngs_geomech.adapt.policy`)."""
    ad = scene.adaptivity
    if ad is None:
        return FixedMesh()
    if scene.time is None:
        from ..adapt.stationary import StationaryAdaptive
        return StationaryAdaptive(scene, build, geo)
    if "contact_zone" in ad.indicators:       # validated: static mechanics with contact, plane or axisymmetric
        from ..adapt.contact_following import ContactFollowing
        return ContactFollowing(scene, geo, build)
    if "phase_front" in ad.indicators:        # validated: a plane Stefan problem
        from ..adapt.front_following import FrontFollowing
        return FrontFollowing(scene, geo, build)
    from ..adapt.stationary import PreAdapted
    return PreAdapted(scene, build, geo)      # transient heat without a followed feature
