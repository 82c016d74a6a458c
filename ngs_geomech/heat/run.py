"""The heat part of a run (:class:`HeatRun`, a :class:`~ngs_geomech.parts.Part`): the heat problem of a scene
without phase change (steady, or transient with theta-scheme steps), its output fields, the heat flow through
each contact interface, its figures and its checkpoint state. Units: m, s, K (or degC), W.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..geometry.assemble import GeometryModel
from ..io.meshdata import vertex_values
from ..io.summary import finite
from ..parts import Step, ThermalPart
from ..scene.model import Scene
from .balance import HeatBalance
from .conductance import heatless_closed, unfollowed_closed
from .forms import HeatForms
from .problem import heat_setup, set_initial_temperature
from .solver import HeatSolver


def temperature_figures(canvas, T) -> None:
    """The temperature at the last time, and in the scene's near-field window when it has one (2D); on the
    canvas's plane sections (3D)."""
    if canvas.arrays is None:
        canvas.section_figures(T.space.mesh, T, "temperature", title=f"{canvas.title}: temperature, {canvas.when}",
                               label=f"T ({canvas.t_unit})")
        return
    vals = vertex_values(T)
    canvas.draw.field_figure(canvas.arrays, vals, canvas.path("temperature.png"),
                             title=f"{canvas.title}: temperature, {canvas.when}", label=f"T ({canvas.t_unit})",
                             axis_labels=canvas.labels)
    if canvas.window:
        canvas.draw.field_figure(canvas.arrays, vals, canvas.path("temperature_zoom.png"),
                                 title=f"{canvas.title}: temperature, {canvas.when} (near field)",
                                 label=f"T ({canvas.t_unit})", axis_labels=canvas.labels, window=canvas.window)


class HeatRun(ThermalPart):
    """The heat problem of a run (module docstring): ``forms`` (:class:`HeatForms`), ``solver``
    (:class:`HeatSolver`), ``T`` the temperature; ``flows`` the heat flow through each contact interface per
    step (W; W per m of depth in plane scenes), master -> minion."""

    key = "heat"

    def __init__(self, scene: Scene, geo: GeometryModel, mesh):
        super().__init__()
        self.scene, self.mesh = scene, mesh
        self.axisymmetric = scene.scene.dimension == "axisymmetric"
        setup = heat_setup(scene, geo, mesh)
        self.forms = HeatForms(mesh, setup)
        sv = scene.solver
        self.solver = HeatSolver(self.forms, solver=sv.linear, tol=sv.tolerance, maxit=sv.max_iterations,
                                 preconditioner=sv.preconditioner)
        self.T = self.forms.temperature()
        self.fields = {"temperature": self.T, "heat_flux": self.forms.heat_flux(self.T)}
        if any(p.b != 0.0 for p in setup.props.values()):
            self.fields["kirchhoff_theta"] = self.forms.kirchhoff(self.T)
        self.probe_fields = {"temperature": self.T}
        self.flows: dict[str, list[float]] = {}
        self.balance = HeatBalance(self.forms) if setup.conductances and mesh.comm.size == 1 else None
        """The energy balance per body (:mod:`.balance`), kept with contact-conductance interfaces (serial runs:
        it sums over the bodies' dofs of one process)."""
        self._solved = None                      # (the conductance flows, the balance terms) of the last solve

    # -- solving --------------------------------------------------------------------------------------------
    def steady(self, where: str) -> None:
        self.forms.t_new.Set(0.0)
        info = self.solver.solve(where)
        self._measure(None)
        self.finish_step(info)

    def steady_at(self, t: float, where: str) -> None:
        """The steady problem with the data at time t (s) of a transient scene (the step operator with
        1/dt = 0 and theta = 1): what a mesh pre-adapted to the start time is adapted to."""
        h = self.forms
        h.t_new.Set(t)
        h.t_old.Set(t)
        h.inv_dt.Set(0.0)
        h.theta.Set(1.0)
        h.gf_old.vec[:] = 0.0
        self.solver.solve_steady(where)

    def start(self, t0: float, where: str) -> None:
        self.forms.t_new.Set(t0)
        set_initial_temperature(self.T, self.scene, self.mesh, self.forms.t_new)
        self.solver.set_dirichlet()

    def interpolate(self, cf):
        """``cf`` set into the temperature's space as the initial temperature is (``Set``)."""
        g = ngs.GridFunction(self.T.space)
        g.Set(cf)
        return g

    def begin_step(self, step: Step) -> None:
        """Set the step from a to b up: the old state and the times."""
        h = self.forms
        h.gf_old.vec.data = h.gf.vec
        h.t_old.Set(step.a)
        h.t_new.Set(step.b)
        h.inv_dt.Set(1.0 / step.dt)

    def solve_step(self, step: Step, heating=None):
        """Solve the step set up by :meth:`begin_step`; ``heating`` (a :class:`DeformationHeating`): its
        assembled source is added to the load. Returns the solver's step info."""
        if heating is not None:
            self.forms.extra_load = heating.vector()
        info = self.solver.solve(step.where)
        self._measure(step.dt)
        return info

    def _measure(self, dt: float | None) -> None:
        """The contact-conductance flows (theta average over the step, W per m of depth or per radian) and the
        balance terms of the solve just done, kept until :meth:`finish_step` (a coupled step may solve again)."""
        terms = self.forms.interface_terms
        if terms is None:
            return
        dofs = self.forms.interface_dofs
        flows = terms.flows(dofs.temperatures(self.forms.gf.vec))
        th = self.forms.theta.Get()
        if dt is not None and th < 1:
            old = terms.flows(dofs.temperatures(self.forms.gf_old.vec))
            flows = {n: th * q + (1 - th) * old[n] for n, q in flows.items()}
        sides = {c.name: (c.master, c.minion) for c in self.forms.setup.conductances}
        items = {n: (*sides[n], q) for n, q in flows.items()}
        for (master, minion), q in zip(self.forms.setup.contacts, self._mortar_flows()):
            items[master] = (master, minion, q)
        self._solved = (items, self.balance.measure(dt, items) if self.balance is not None else None)

    def _mortar_flows(self) -> list[float]:
        """The flows int w lambda ds over each mortar interface (W per m of depth or per radian)."""
        return self.forms.interface_dofs.mortar_flows(self.forms, total=False)

    def set_contact_state(self, states) -> list[str]:
        """The mechanics' contact state per interface (:class:`~.conductance.ContactNodes`; None: the geometry's)
        for the contact-conductance interfaces; returns the interfaces closed in it that carry no heat."""
        self.forms.set_contact_state(states)
        return heatless_closed(states, self.forms.setup.conductances, {m for m, _ in self.forms.setup.contacts})

    def contact_warnings(self, states) -> list[str]:
        """The interfaces ``states`` closes that carry no heat, this part keeping the geometry's state."""
        s = self.forms.setup
        return (heatless_closed(states, s.conductances, {m for m, _ in s.contacts})
                + unfollowed_closed(states, s.conductances))

    def finish_step(self, info) -> None:
        """Keep a solved step's Newton iterations and interface heat flows."""
        super().finish_step(info)
        flows = self.forms.interface_dofs.mortar_flows(self.forms, total=True)
        for (master, _), q in zip(self.forms.setup.contacts, flows):
            self.flows.setdefault(master, []).append(q)
        if self._solved is not None:
            items, terms = self._solved
            scale = 2 * math.pi if self.axisymmetric else 1.0
            for c in self.forms.setup.conductances:
                self.flows.setdefault(c.master, []).append(scale * items[c.name][2])
            if self.balance is not None:
                self.balance.record(terms)
            self._solved = None

    def heating_target(self) -> tuple:
        """(space, test function, volume measure, weight) a deformation-heating source is assembled against."""
        tests = self.forms.X.TestFunction()
        v = tests[0] if self.forms.setup.contacts else tests
        return self.forms.X, v, self.forms.volume_measure(), self.forms.weight

    # -- meshes ---------------------------------------------------------------------------------------------
    def take_state(self, old: HeatRun, t0: float | None) -> tuple[float, float, None]:
        """Carry the temperature of ``old`` (the same scene on another mesh) over: interpolated (NGSolve's
        ``Set``), the next step backward Euler (a Crank-Nicolson step would need the old interface multipliers).
        ``t0`` (s; a remesh at the start time): the scene's initial temperature set instead. Returns the heat
        content int rho c T dx before and after (J per m of depth in plane scenes) and None (nothing to commit)."""
        if t0 is None:
            self.T.Set(old.T)
        else:
            self.start(t0, "remesh")
        self.solver.backward_euler_steps = 1      # (the next heat step copies the state into gf_old)
        w = 2 * np.pi * ngs.x if self.axisymmetric else 1.0
        before = float(ngs.Integrate(w * old.forms.rho_c * old.T, old.mesh))
        after = float(ngs.Integrate(w * self.forms.rho_c * self.T, self.mesh))
        if self.balance is None or old.balance is None or t0 is not None:
            return before, after, None
        moved = self.balance.contents(self.T) - old.balance.contents(old.T)
        return before, after, lambda: self._adopt(old, moved)

    def _adopt(self, old: HeatRun, moved: np.ndarray) -> None:
        """Continue ``old``'s flows and energy balance here (contact-conductance runs), the heat content the
        transfer changed per body (``moved``, J) counted in the balance."""
        self.flows = old.flows
        self.balance.steps = old.balance.steps
        self.balance.record_transfer(moved)

    # -- checkpoints ----------------------------------------------------------------------------------------
    def capture(self) -> tuple[dict, dict]:
        return ({"heat": np.array(self.forms.gf.vec.FV().NumPy())},
                {"steps": len(self.newton_iterations), "flows": {n: len(v) for n, v in self.flows.items()},
                 "balance": len(self.balance.steps) if self.balance is not None else 0})

    def meta(self, lengths: dict) -> dict:
        out = {"newton_iterations": self.newton_iterations[:lengths["steps"]],
               "flows": {n: v[:lengths["flows"].get(n, 0)] for n, v in self.flows.items()}}
        if self.balance is not None:
            out["balance"] = self.balance.as_data(lengths["balance"])
        return out

    def checkpoint_spaces(self) -> dict:
        return {"heat": self.forms.gf.space}

    def restore(self, arrays: dict, meta: dict) -> None:
        self.forms.gf.vec.FV().NumPy()[:] = arrays["heat"]
        if parallel.distributed(self.forms.gf.space.mesh):     # every copy of a shared dof holds the value
            self.forms.gf.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)
        self.forms.gf_old.vec.data = self.forms.gf.vec
        self.newton_iterations[:] = meta["newton_iterations"]
        self.flows.clear()
        self.flows.update(meta["flows"])
        if self.balance is not None:
            self.balance.from_data(meta.get("balance", []))

    # -- reporting ------------------------------------------------------------------------------------------
    @property
    def factorizations(self) -> int:
        return self.solver.factorizations

    @property
    def ndof(self) -> int:
        return self.forms.X.ndof

    @property
    def ndof_global(self) -> int:
        return self.forms.X.ndofglobal

    def summary(self) -> dict:
        out = {"interface_heat_flow_W": {k: finite(v) for k, v in self.flows.items()}}
        terms = self.forms.interface_terms
        if terms is not None:
            ranges = terms.ranges()
            out["interface_conductance"] = {
                t.spec.name: {"law": t.spec.law.describe() if t.spec.law is not None else None,
                              "gap_conductivity": t.spec.gap_conductivity, "emissivity": t.spec.emissivity,
                              "radiation": t.spec.radiation if t.spec.emissivity is not None else None,
                              "state": t.source, "conductance_min": ranges[t.spec.name][0],
                              "conductance_max": ranges[t.spec.name][1], "units": "W/(m^2 K)"}
                for t in terms.terms}
            if self.balance is not None:
                out["heat_balance"] = self.balance.report()
        return out

    def figures(self, canvas) -> None:
        temperature_figures(canvas, self.T)
