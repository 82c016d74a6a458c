"""From a scene with ``physics.mechanics = "dynamic"`` or ``"viscous"`` to the global evolutionary model of the
seed (2.6)-(2.16) (:mod:`ngs_geomech.dynamics.forms`, :mod:`ngs_geomech.dynamics.solver`), and what a run keeps
of it: the displacement, velocity, stresses, the viscous dissipation density (the heat source of (2.6)), the
energy history and the contact state at the output times, and its checkpoint state.

'dynamic': inertia rho u_tt with the generalized-alpha method (``[dynamics] rho_inf``, 1 = no numerical
damping: the contact then never adds energy), Kelvin-Voigt viscosity (material ``viscosity_time`` tau_v:
C^v = tau_v C) and Prony branches (material ``prony``: C_k = modulus_ratio C with relaxation_time tau_k; the
material's elastic C is the relaxed modulus), contact on the end-of-step displacement (the scene's contact
interfaces and foundations). 'viscous': the same without inertia (quasi-static creep and relaxation), backward
Euler. Both advance with the run's time steps (mechanics every step); thermal stress from the temperature of the
step. Units: m, s, Pa, J per metre of depth in plane scenes (per radian axisymmetric).
"""

from __future__ import annotations

import dataclasses

import ngsolve as ngs
import numpy as np

from ..contact.problem import contact_options, contact_specs, interface_results, supported_nodes
from ..errors import SolverError
from ..fem.coefficients import expression_function
from ..geometry.assemble import GeometryModel
from ..mechanics.forms import ElasticForms
from ..mechanics.materials import ElasticProperties
from ..mechanics.problem import elastic_setup, mechanics_warnings, watch_small_strain
from ..mechanics.run import MechanicsPart
from ..parts import Step
from ..scene.model import Scene
from .forms import PronyBranch, ViscoelasticForms, ViscousProperties
from .solver import DynamicSolver, EnergyRecord, StepInfo, ViscousSolver, contact_switches


def viscous_properties(scene: Scene, props: dict[str, ElasticProperties]) -> dict[str, ViscousProperties]:
    """Region -> ViscousProperties of a validated scene (only regions with rate terms)."""
    out = {}
    for name, m in scene.materials.items():
        if m.viscosity_time is None and not m.prony:
            continue
        C = np.asarray(props[name].C, dtype=float)
        visc = float(m.viscosity_time) * C if m.viscosity_time is not None else None
        branches = tuple(PronyBranch(float(b.modulus_ratio) * C, float(b.relaxation_time)) for b in m.prony)
        out[name] = ViscousProperties(viscosity=visc, branches=branches)
    return out


class DynamicsRun(MechanicsPart):
    """The dynamic or viscous mechanics of a run (module docstring), a
    :class:`~ngs_geomech.mechanics.run.MechanicsPart` advanced in every step of the run."""

    key = "dynamics"

    def __init__(self, scene: Scene, geo: GeometryModel, mesh, temperature, *, interpolate=None):
        super().__init__(scene, mesh)
        self.kind = scene.physics.mechanics
        self.setup = elastic_setup(scene, geo, mesh, temperature, interpolate=interpolate)
        self.setup.formulation = "displacement"      # the dynamic forms are built on X = V (validated)
        self.forms = ElasticForms(mesh, self.setup)
        self.contacts = contact_specs(scene, geo, mesh, self.forms.V)
        self.vforms = ViscoelasticForms(self.forms, viscous_properties(scene, self.setup.props),
                                        inertia=self.kind == "dynamic")
        items = [(c.op, c.law) for c in self.contacts]
        options = contact_options(scene, self.contacts, self.forms, dynamic=True)
        d = scene.dynamics
        if self.kind == "dynamic":
            mass = d.mass
            if mass == "auto":
                mass = "lumped" if items and self.setup.order == 1 else "consistent"
            self.solver = DynamicSolver(self.vforms, rho_inf=d.rho_inf, contact=items, contact_options=options,
                                        mass=mass, redistribute_contact_mass=(mass == "lumped" and bool(items)))
            self.mass = mass
        else:
            self.solver = ViscousSolver(self.vforms, contact=items, contact_options=options)
            self.mass = None
        self.warnings = mechanics_warnings(scene, self.setup)
        extra = {"viscous_dissipation": self.vforms.dissipation_density()}
        if self.kind == "dynamic":
            extra["kinetic_energy_density"] = self.vforms.kinetic_energy_density()
        self.output_fields({"velocity": self.vforms.velocity}, extra)
        self.times: list[float] = []
        self.latest: list[dict] = []
        self.history: list[dict] = []
        self.contact_output = self if self.contacts else None
        self._started = False

    @property
    def factorizations(self) -> int:
        return self.solver.factorizations

    def dissipation_source(self):
        """The viscous dissipation density (W/m^3) as a CoefficientFunction: a heat source of (2.6)."""
        return self.vforms.dissipation_density()

    def contact_multipliers(self) -> list[tuple]:
        """The multipliers of the last step's contact solve (zero while no contact was solved); the friction law
        acts on the slip increment of the step (:mod:`ngs_geomech.dynamics.solver`)."""
        return list(self.solver.multipliers)

    # -- stepping -------------------------------------------------------------------------------------------
    def _start(self, t: float) -> None:
        s = self.solver
        if self.kind == "dynamic":
            v0 = None
            vel = self.scene.initial.velocity
            if vel is not None:
                g = ngs.GridFunction(self.forms.V)
                tp = ngs.Parameter(t)
                g.Set(ngs.CoefficientFunction(tuple(expression_function(e)(tp) for e in vel)))
                v0 = np.zeros(self.forms.X.ndof)
                v0[:self.forms.V.ndof] = g.vec.FV().NumPy()
            s.set_initial(None, v0, t0=t)
        else:
            s.set_initial(None, t0=t)
        self._started = True

    def solve(self, t: float, where: str, record: bool = True) -> None:
        """Advance to time t (s) (the first call starts the motion at t)."""
        try:
            if not self._started:
                self._start(t)
            elif t > self.solver.t:
                self.solver.step(t - self.solver.t)
        except (SolverError, ValueError) as exc:
            raise SolverError(f"{self.kind} mechanics at {where}: {exc}") from exc
        u = self.forms.gf.vec.FV().NumPy()
        if not np.all(np.isfinite(u)):
            raise SolverError(f"{self.kind} mechanics at {where}: the displacement is not finite; reduce the time "
                              "step")
        watch_small_strain(self, where)
        if record:
            self.record(t)

    def start(self, t0: float, where: str) -> None:
        self.solve(t0, where, record=False)

    def advance(self, step: Step) -> None:
        self.solve(step.b, step.where, record=False)

    def record(self, t: float) -> None:
        self.times.append(float(t))
        u = np.array(self.forms.gf.vec.FV().NumPy())
        self.latest = []
        free = np.array(list(self.forms.X.FreeDofs()), dtype=bool)[:self.forms.V.ndof]
        for spec, (lam_n, lam_t) in zip(self.contacts, self.solver.multipliers):
            lam_n, lam_t, prescribed = supported_nodes(spec, free, u, np.asarray(lam_n), np.asarray(lam_t))
            self.latest.append(interface_results(spec, u, lam_n, lam_t, prescribed))
        entry = {"time_s": float(t)}
        if self.kind == "dynamic" and self.solver.energy_history:
            e = self.solver.energy_history[-1]
            entry.update(kinetic_J=e.kinetic, elastic_J=e.elastic, branches_J=e.branches, total_J=e.total,
                         external_work_J=e.external_work, dirichlet_work_J=e.dirichlet_work,
                         viscous_dissipation_J=e.viscous_dissipation,
                         branch_dissipation_J=e.branch_dissipation, contact_work_J=e.contact_work,
                         numerical_dissipation_J=e.numerical_dissipation)
        for spec, res in zip(self.contacts, self.latest):
            w = np.maximum(spec.op.weight, 0.0)
            entry[spec.name] = {"normal_force": float(w @ res["pressure"]),
                                "nodes_closed": int(np.count_nonzero(res["pressure"] > 0)),
                                "max_pressure_Pa": float(np.max(res["pressure"], initial=0.0))}
        self.history.append(entry)

    def summary(self) -> dict:
        return {"mechanics": self.report()}

    def report(self) -> dict:
        """The summary's ``mechanics`` block."""
        out = {"model": self.setup.model, "solver": self.kind, "steps": len(self.solver.steps),
               "times_s": self.times, "history": self.history}
        if self.kind == "dynamic":
            h = self.solver.energy_history
            e0 = h[0].total if h else 0.0
            gain = max((r.total - e0 - r.external_work - r.dirichlet_work - r.contact_work) for r in h) if h else 0.0
            scale = max([abs(r.total) for r in h] + [abs(r.external_work) + abs(r.dirichlet_work) for r in h]
                        + [1e-300])
            out.update(scheme="generalized-alpha", rho_inf=self.solver.rho_inf, mass=self.mass,
                       energy_gain_rel_max=gain / scale)
        else:
            out["viscous_dissipation_J"] = float(self.solver.dissipated)
        if self.contacts:
            out["contact_switches"] = contact_switches(self.solver.steps)
        return out

    # -- checkpoints ----------------------------------------------------------------------------------------
    def capture(self) -> tuple[dict, dict]:
        s = self.solver
        arrays = {"dyn/u": np.array(s.u)}
        if self.kind == "dynamic":
            arrays.update({"dyn/v": np.array(s.v), "dyn/a": np.array(s.a)})
            if s.f_n is not None:
                arrays["dyn/f"] = np.array(s.f_n)
        else:        # the viscous solver keeps the last step's rate in the velocity field only (dissipation)
            arrays["dyn/velocity"] = np.array(self.vforms.velocity.vec.FV().NumPy())
        for k, w in enumerate(s.w):
            arrays[f"dyn/w{k}"] = np.array(w)
        for k, act in enumerate(s.active):
            arrays[f"dyn/active{k}"] = np.array(act)
        if s.contact_solver is not None:        # its warm start: a repeated step starts where the first did
            arrays.update({f"warm/{k}": v for k, v in s.contact_solver.capture().items()})
        return arrays, {"times": len(self.times), "history": len(self.history), "steps": len(s.steps),
                        "energy": len(s.energy_history)}

    def meta(self, lengths: dict) -> dict:
        s = self.solver
        return {"t": s.t, "started": self._started, "times": self.times[:lengths["times"]],
                "history": self.history[:lengths["history"]],
                "dissipated": float(s.dissipated),
                "energy": [dataclasses.asdict(r) for r in s.energy_history[:lengths["energy"]]],
                "steps_active": [[a.tolist() for a in st.active] for st in s.steps[:lengths["steps"]]]}

    def restore(self, arrays: dict, meta: dict) -> None:
        s = self.solver
        s.u = np.array(arrays["dyn/u"])
        if self.kind == "dynamic":
            s.v, s.a = np.array(arrays["dyn/v"]), np.array(arrays["dyn/a"])
            s.f_n = np.array(arrays["dyn/f"]) if "dyn/f" in arrays else None
            s.energy_history = [EnergyRecord(**r) for r in meta["energy"]]
        else:
            s.dissipated = float(meta["dissipated"])
        s.w = [np.array(arrays[f"dyn/w{k}"]) for k in range(len(s.w))]
        s.active = [np.array(arrays[f"dyn/active{k}"], dtype=bool) for k in range(len(s.active))]
        if s.contact_solver is not None:
            s.contact_solver.restore(len(s.u), {k.split("/", 1)[1]: v for k, v in arrays.items()
                                                if k.startswith("warm/")})
        s.t = float(meta["t"])
        s.steps = [StepInfo(0.0, 0.0, active=[np.array(a, dtype=bool) for a in act]) for act in meta["steps_active"]]
        self._started = bool(meta["started"])
        self.times[:] = meta["times"]
        self.history[:] = meta["history"]
        s.sync_fields()
        if "dyn/velocity" in arrays:
            self.vforms.velocity.vec.FV().NumPy()[:] = arrays["dyn/velocity"]
