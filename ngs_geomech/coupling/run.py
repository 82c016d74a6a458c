"""The coupling part of a run (:class:`CouplingRun`, a :class:`~ngs_geomech.parts.Part`): the coupled time step of
problem (P_c) (:mod:`.problem`: the heat or Stefan step with the deformation heating of the last displacement
rate and the frictional heating of sliding contacts (:mod:`.frictional`), then the mechanics at the step's end;
'iterated' repeats the pair until neither changes), the mean pressure handed to the conductivities kappa(T, p)
and the contact state (nodal pressure and gap) handed to the contact conductances after each mechanics solve, its
history and figure.
Units: s, W, J (per m of depth in plane scenes), Pa.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from ..io.meshdata import vertex_average
from ..parts import Part, Step
from ..scene.model import Scene
from .frictional import FrictionalHeating, ThermalSources
from .problem import KELVIN, DeformationHeating, relative_change


class CouplingRun(Part):
    """The coupling of a thermal part (:class:`~ngs_geomech.parts.ThermalPart`: heat or Stefan) and a mechanics
    part (:class:`~ngs_geomech.mechanics.run.MechanicsPart`: static, dynamic or viscous). The run advances this
    part instead of the two: its :meth:`advance` is their coupled step; the mechanics is then kept at every
    step."""

    key = "coupling"

    def __init__(self, scene: Scene, thermal, mechanics):
        super().__init__()
        self.scene, self.thermal, self.mech = scene, thermal, mechanics
        offset = KELVIN if scene.scene.temperature_unit == "C" else 0.0
        space, v, dx, weight = thermal.heating_target()
        # the viscous dissipation of dynamic mechanics (2.6) adds to the thermoelastic source
        self.heating = DeformationHeating(mechanics.forms, space, v, dx, weight, offset,
                                          mechanics.dissipation_source())
        self.fields = {"deformation_heating": self.heating.field}
        mechanics.records_every_step = True
        self.history: dict[str, list] = {"passes": [], "deformation_heat": [], "change_T": [], "change_u": [],
                                         "conductivity_factor": []}
        # the frictional heating of sliding contacts (contacts with frictional_heating; None without)
        self.friction = FrictionalHeating.of(scene, thermal, mechanics, self.warnings)
        self.sources = self.heating if self.friction is None else ThermalSources(self.heating, self.friction)
        if self.friction is not None:
            self.history["frictional_heat"] = []
        self._warned: set[str] = set()

    # -- solving --------------------------------------------------------------------------------------------
    def start(self, t0: float, where: str) -> None:
        self.update_pressure(where)
        self.update_contact()

    def advance(self, step: Step) -> None:
        """One step of problem (P_c) (module docstring); the passes' relative changes of T and u decide the end of
        an 'iterated' step (physics.coupling_tolerance)."""
        ph = self.scene.physics
        self.heating.start_step()
        if self.friction is not None:
            self.friction.start_step(step.dt, predict=ph.coupling == "iterated")
        mark = self.thermal.mark()
        self.thermal.begin_step(step)
        passes = ph.coupling_max_iterations if ph.coupling == "iterated" else 1
        prev = None
        dT = du = 0.0
        for p in range(passes):
            if p:
                self.thermal.rewind(mark)
            info = self.thermal.solve_step(step, self.sources)
            T_now = self.thermal.temperature_values()
            self.mech.solve(step.b, f"{step.where}, coupling pass {p + 1}", record=False)
            factors = self.update_pressure(step.where)
            self.update_contact()
            self.heating.set_rate(step.dt)
            if self.friction is not None:
                self.friction.set_rate(step.dt)
            u_now = self.mech.forms.gf.vec.FV().NumPy().copy()
            if prev is not None:
                m = self.mech.forms.mesh
                dT, du = relative_change(T_now, prev[0], m), relative_change(u_now, prev[1], m)
            if ph.coupling == "staggered" or (prev is not None and dT <= ph.coupling_tolerance
                                              and du <= ph.coupling_tolerance):
                break
            prev = (T_now, u_now)
        else:
            raise SolverError(f"coupled heat-mechanics step at {step.where}: the heat and mechanics steps still differ "
                              f"after {passes} passes (relative changes between the last two: T {dT:.2e}, u {du:.2e}; "
                              f"physics.coupling_tolerance {ph.coupling_tolerance:g}). Reduce the time step, raise "
                              "physics.coupling_max_iterations, or use coupling = 'staggered'.")
        self.thermal.finish_step(info)
        for name, value in zip(self.history, (p + 1, step.dt * self.heating.power(), dT, du, factors)):
            self.history[name].append(value)
        if self.friction is not None:
            self.history["frictional_heat"].append(self.friction.finish_step())

    def update_pressure(self, where: str):
        """Give the thermal part the mean pressure of the last mechanics solve (kappa(T, p)); returns the (min,
        max) conductivity factors, or None without pressure-dependent conductivities."""
        try:
            return self.thermal.set_pressure(-self.mech.fields["mean_stress"])
        except ValueError as exc:
            raise SolverError(f"coupled step at {where}: {exc}; reduce the load or the pressure coefficient") from None

    def update_contact(self, recorded: bool = False) -> None:
        """Give the thermal part the contact state of the last mechanics solve (``recorded``: of the last recorded
        one) for its contact conductances; keep a warning (once per interface) where it closes an interface that
        carries no heat."""
        for w in self.thermal.set_contact_state(self.mech.contact_state(recorded)):
            name = w.split(":", 1)[0]
            if name not in self._warned:
                self._warned.add(name)
                self.warnings.append(w)

    def mechanics_changed(self, step: Step | None, where: str) -> None:
        """The mechanics was solved again on a new mesh (contact-zone following) at the start time (``step``
        None) or at the end of ``step``: the pressure, the contact state and the step's displacement rate from
        that solve."""
        self.update_pressure(where)
        self.update_contact()
        if step is not None:
            self.heating.set_rate(step.dt)
            if self.friction is not None:
                self.friction.set_rate(step.dt)

    # -- checkpoints ----------------------------------------------------------------------------------------
    def capture(self) -> tuple[dict, dict]:
        arrays = self.heating.capture()
        if self.friction is not None:
            arrays.update(self.friction.capture())
        return arrays, {"steps": len(self.history["passes"])}

    def meta(self, lengths: dict) -> dict:
        return {n: v[:lengths["steps"]] for n, v in self.history.items()}

    def checkpoint_spaces(self) -> dict:
        return {"coupling/rate": self.heating.rate.space}

    def partition_bound(self) -> tuple[str, ...]:
        return ("coupling/friction/",) if self.friction is not None else ()

    def restore(self, arrays: dict, meta: dict) -> None:
        self.heating.restore(arrays)
        if self.friction is not None:
            self.friction.restore(arrays)
        for n, v in meta.items():
            self.history[n][:] = v
        self.update_pressure("resume")
        self.update_contact(recorded=True)

    # -- reporting ------------------------------------------------------------------------------------------
    def summary(self) -> dict:
        c = self.history
        passes = c["passes"]
        factors = [f for f in c["conductivity_factor"] if f]
        units = {"3d": "J", "axisymmetric": "J per radian"}.get(self.scene.scene.dimension, "J per m of depth")
        friction = {} if self.friction is None else {
            "frictional_heating": self.friction.report(c["frictional_heat"], units)}
        return {"coupling": {
            "mode": self.scene.physics.coupling,
            "deformation_heating": "-Theta_0 beta : e(u_t) (2.49), W/m^3 (field deformation_heating)",
            "passes_per_step": {"mean": float(np.mean(passes)) if passes else 0.0, "max": int(max(passes, default=0))},
            "deformation_heat_total": float(np.sum(c["deformation_heat"])),
            "deformation_heat_per_step": c["deformation_heat"],
            "units": {"deformation_heat": "J per m of depth" if self.scene.scene.dimension != "3d" else "J"},
            "conductivity_pressure_factor": ({"min": min(f[0] for f in factors), "max": max(f[1] for f in factors)}
                                             if factors else None),
            "last_change_T_max": float(max(c["change_T"], default=0.0)),
            "last_change_u_max": float(max(c["change_u"], default=0.0)), **friction}}

    def figures(self, canvas) -> None:
        if canvas.arrays is None:
            return
        canvas.draw.field_figure(canvas.arrays, vertex_average(self.mech.mesh, self.heating.field),
                                 canvas.path("deformation_heating.png"),
                                 title=f"{canvas.title}: deformation heating, {canvas.when}",
                                 label="-Theta_0 beta : e(u_t) (W/m^3)", axis_labels=canvas.labels, cmap="coolwarm")
