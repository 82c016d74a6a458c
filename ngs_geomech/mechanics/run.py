"""The mechanics parts of a run (:class:`~ngs_geomech.parts.Part`): what static (:class:`StaticMechanicsRun`)
and dynamic or viscous mechanics (:class:`~ngs_geomech.dynamics.problem.DynamicsRun`) share
(:class:`MechanicsPart`: output fields, probes, the contact series and figures, the stress figures), and static
mechanics itself: problem (P) (2.17)-(2.27) solved at each mechanics time (the output times, or every step of a
coupled run), with the lambda law and contact when the scene has them. Units: m, Pa, s.
"""

from __future__ import annotations

import dataclasses
import functools

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..contact.factory import build_contact_solver
from ..contact.output import ContactOutput, contact_figures, contact_lines
from ..contact.problem import (
    check_supported,
    contact_options,
    contact_specs,
    contact_warnings,
    interface_results,
    supported_nodes,
)
from ..contact.solver import nodal_modulus, node_permutation
from ..errors import Problem, SceneError
from ..geometry.assemble import GeometryModel
from ..heat.conductance import ContactNodes
from ..io import scales, stress_figures
from ..io.meshdata import vertex_average
from ..parts import Part, Step
from ..scene.model import Scene
from .contact import ElasticContactSolver, InSituTraction
from .forms import ElasticForms, stress_measures
from .nested import NestedStart
from .problem import check_elastic_temperatures, elastic_setup, mechanics_warnings, probe_fields, watch_small_strain
from .solver import ElasticSolver, NonlinearInfo


def stress_figure_set(canvas, mesh, von_mises, sigma, sigma0=None) -> None:
    """Von Mises stress and principal stress crosses (the seed's Fig. 1) of the last mechanics state (2D); the
    von Mises stress on the canvas's plane sections (3D). Stresses in MPa, or GPa from 1 GPa on. With an initial
    stress ``sigma0`` (in-plane CF) also the crosses of the change sigma - sigma0 (what the loads add to the
    in-situ state, whose lithostatic part hides it at depth) on its largest in-plane shear stress."""
    arrays = canvas.arrays
    if arrays is None:
        canvas.section_figures(mesh, von_mises, "von_mises", title=f"{canvas.title}: von Mises stress, {canvas.when}",
                               label="von Mises stress (MPa)", cmap="viridis", scale=scales.stress_scale)
        return
    vm = vertex_average(mesh, von_mises)
    unit = scales.stress_scale(vm)
    label = f"von Mises stress ({unit.unit})"
    canvas.draw.field_figure(arrays, unit(vm), canvas.path("von_mises.png"),
                             title=f"{canvas.title}: von Mises stress, {canvas.when}",
                             label=label, axis_labels=canvas.labels, cmap="viridis")
    principal_crosses(canvas, mesh, sigma, unit(vm), label, "principal_stress", "principal stresses")
    if sigma0 is not None:
        change = ngs.CoefficientFunction(tuple(sigma[i, j] - sigma0[i, j] for i in range(2) for j in range(2)),
                                         dims=(2, 2))
        shear = ngs.sqrt(((change[0, 0] - change[1, 1]) / 2) ** 2 + change[0, 1] ** 2)
        tau = vertex_average(mesh, shear)
        tunit = scales.stress_scale(tau)
        principal_crosses(canvas, mesh, change, tunit(tau), f"largest shear stress of the change ({tunit.unit})",
                          "principal_stress_change", "principal stresses added to the initial stress")


def principal_crosses(canvas, mesh, sigma, background: np.ndarray, label: str, stem: str, what: str) -> None:
    """Principal stress crosses of the in-plane stress CF ``sigma`` on a grid over the domain (``stem``.png) and
    over the canvas's window (``stem``_zoom.png), on ``background`` (vertex values, already scaled)."""
    arrays = canvas.arrays
    windows = [(None, f"{stem}.png")]
    if canvas.window:
        windows.append((canvas.window, f"{stem}_zoom.png"))
    for window, fname in windows:
        lo, hi = arrays.points.min(axis=0), arrays.points.max(axis=0)
        if window is not None:
            lo, hi = np.maximum(lo, [window[0], window[2]]), np.minimum(hi, [window[1], window[3]])
        pts = stress_figures.grid_samples(arrays, float(np.max(hi - lo)) / 22, window).xy
        if len(pts) == 0:
            continue
        sxx, syy, sxy = parallel.point_values(mesh, ngs.CoefficientFunction((sigma[0, 0], sigma[1, 1], sigma[0, 1])),
                                              pts).T
        s1, s2, th = stress_figures.principal_2d(sxx, syy, sxy)
        canvas.draw.principal_stress_crosses(
            arrays, pts, s1, s2, th, canvas.path(fname), axis_labels=canvas.labels, window=window,
            title=f"{canvas.title}: {what}, {canvas.when}", background=background, background_label=label)


def principal_stress(values: np.ndarray, index: int) -> np.ndarray:
    """The ``index``-th smallest eigenvalue (Pa) of each 3 x 3 stress tensor in ``values`` (n x 9)."""
    t = np.asarray(values, dtype=float).reshape(-1, 3, 3)
    return np.linalg.eigvalsh(0.5 * (t + t.transpose(0, 2, 1)))[:, index]



def _in_node_order(res: dict, coords) -> dict:
    """A contact's recorded nodal results ``res`` (with the node coordinates "x", "y"[, "z"]) in the node order of
    ``coords`` (the run's operator): a checkpoint of another partition lists the nodes in its own order."""
    xyz = [res[k] for k in ("x", "y", "z")[:np.shape(coords)[1]] if k in res]
    if len(xyz) != np.shape(coords)[1]:
        return res
    perm = node_permutation(np.column_stack(xyz), coords)
    if perm is None:
        return res
    m = len(perm)
    return {k: np.asarray(v)[perm] if np.ndim(v) and np.shape(v)[0] == m else v for k, v in res.items()}

class MechanicsPart(Part):
    """What the mechanics parts share: ``forms`` (ElasticForms), ``contacts`` (ContactSpec list),
    ``contact_output`` (its ``latest`` results per contact, or None without contacts), ``sigma``, the output
    fields and probe quantities, :meth:`solve` (to a time), :meth:`dissipation_source` (a heat source of
    (2.6), None without one); ``records_every_step`` is set by a coupled run (the mechanics is solved and kept at
    every step, not only at the output times)."""

    records_every_step = False

    def __init__(self, scene: Scene, mesh):
        super().__init__()
        self.scene, self.mesh = scene, mesh
        self.contacts: list = []
        self.contact_output = None

    def output_fields(self, kinematic: dict | None = None, extra: dict | None = None) -> None:
        """The fields (displacement, ``kinematic`` ones, stress, its measures, strain energy density, ``extra``)
        and the probe quantities."""
        u = self.forms.displacement()
        self.sigma = self.forms.stress_tensor(u)
        measures = stress_measures(self.sigma)
        self.fields = {"displacement": u, **(kinematic or {}), "stress": self.sigma, **measures,
                       "strain_energy_density": self.forms.strain_energy_density(u), **(extra or {})}
        self.probe_fields = probe_fields(u, measures, self.mesh.dim)

    def solve(self, t: float, where: str, record: bool = True) -> None:
        raise NotImplementedError

    def contact_state(self, recorded: bool = False) -> dict:
        """The contact state of the interfaces (not the foundations) per interface name, as
        :class:`~ngs_geomech.heat.conductance.ContactNodes` (the nodal pressure and gap of the contact side S): of
        the last solve, or (``recorded``) of the last recorded one (a restored run); {} without interfaces."""
        if not self.contacts:
            return {}
        results = self.contact_output.latest if recorded else self.contact_results()
        return {spec.name: ContactNodes(spec.op.side, np.asarray(spec.op.nodes, dtype=int),
                                        np.asarray(res["pressure"], dtype=float), np.asarray(res["gap"], dtype=float))
                for spec, res in zip(self.contacts, results) if spec.kind == "interface"}

    def contact_results(self) -> list[dict]:
        """The nodal interface arrays (:func:`~ngs_geomech.contact.problem.interface_results`) of the last solve."""
        u = np.array(self.forms.gf.vec.FV().NumPy())
        free = np.array(list(self.forms.X.FreeDofs()), dtype=bool)[:self.forms.V.ndof]
        if parallel.distributed(self.mesh) and self.contacts:   # the operators act on the contact solver's global
            u = self.solver.displacement()                       # arrays (collective)
            free = self.solver.free[:self.contacts[0].op.Bn.shape[1]]
        out = []
        for spec, (lam_n, lam_t) in zip(self.contacts, self.contact_multipliers()):
            lam_n, lam_t, prescribed = supported_nodes(spec, free, u, np.asarray(lam_n), np.asarray(lam_t))
            out.append(interface_results(spec, u, lam_n, lam_t, prescribed))
        return out

    def derived_fields(self) -> dict:
        """The principal stresses from the stress tensor's values (numpy's symmetric eigenvalues: NGSolve's
        ``Eig`` per point costs most of an output time)."""
        return {name: ("stress", functools.partial(principal_stress, index=k))
                for k, name in enumerate(("sigma_3", "sigma_2", "sigma_1"))}

    def dissipation_source(self):
        """The heat source of (2.6) the mechanics dissipates (W/m^3), or None."""
        return None

    def contact_multipliers(self) -> list[tuple]:
        """The contact multipliers (lam_n, lam_t) (Pa; nodal, :mod:`ngs_geomech.contact.problem`) of each of
        ``contacts`` after the last solve (lam_t (m, 2) in 3D)."""
        return []

    def line_names(self, scene: Scene) -> list[str]:
        if not (scene.output.contact_vtp and self.contact_output is not None):
            return []
        return [f"contact_{c.name}" for c in self.contacts]

    def lines(self) -> dict:
        return contact_lines(self.contacts, self.contact_output.latest)

    def figures(self, canvas) -> None:
        stress_figure_set(canvas, self.mesh, self.fields["von_mises"], self.sigma, self.forms.initial_stress_tensor())
        if self.contact_output is not None and canvas.arrays is not None:
            contact_figures(canvas, self.contacts, self.contact_output.latest)

    @property
    def ndof(self) -> int:
        return self.forms.X.ndof

    @property
    def ndof_global(self) -> int:
        return self.forms.X.ndofglobal


class StaticMechanicsRun(MechanicsPart):
    """Static mechanics (module docstring): forms, solver (with contact: :class:`ElasticContactSolver`), the
    output fields and the solve history; solved at the output times (every step when coupled)."""

    key = "mechanics"

    def __init__(self, scene: Scene, geo: GeometryModel, mesh, temperature, *, interpolate=None):
        super().__init__(scene, mesh)
        self.setup = elastic_setup(scene, geo, mesh, temperature, interpolate=interpolate)
        self.forms = ElasticForms(mesh, self.setup)
        self.contacts = contact_specs(scene, geo, mesh, self.forms.V)
        self.nested = None                     # NestedStart (mechanics.nested_levels, validated: no contact)
        if self.contacts:
            self._contact_solver(scene)
        else:
            self._plain_solver(scene, geo, temperature)
        self.warnings = mechanics_warnings(scene, self.setup) + contact_warnings(self.contacts, geo)
        self.output_fields()
        self.times: list[float] = []
        self.nested_solves: list[list] = []      # per solve: the coarse solves (ndof, iterations, wall s)
        self._copy: tuple[int, dict] | None = None     # the arrays of the last capture

    def _contact_solver(self, scene: Scene) -> None:
        ms = scene.mechanics
        floating = self.forms.floating_bodies()
        check_supported(self.contacts, floating, scene.scene.name)
        csolver = build_contact_solver([(c.op, c.law) for c in self.contacts],
                                       contact_options(scene, self.contacts, self.forms),
                                       modulus=nodal_modulus(self.setup.props), floating=floating, forms=self.forms)
        relax = ms.secant_relaxation if ms.secant_relaxation is not None and ms.secant_relaxation <= 1 else None
        self.solver = ElasticContactSolver(self.forms, csolver, tol=ms.tolerance, maxit=ms.max_iterations,
                                           relaxation=relax, insitu=InSituTraction.of(self.forms, self.contacts))
        self.contact_output = ContactOutput(self.forms, self.contacts, dofs=self.solver.dofs)

    def _plain_solver(self, scene: Scene, geo: GeometryModel, temperature) -> None:
        ms, sv = scene.mechanics, scene.solver
        if parallel.distributed(self.mesh):
            check_distributed_mechanics(scene, self.forms)
        self.nested = (NestedStart(scene, geo, temperature) if ms.nested_levels > 0 and self.setup.nonlinear
                       else None)
        self.solver = ElasticSolver(self.forms, method=ms.nonlinear_solver, tol=ms.tolerance,
                                    maxit=ms.max_iterations, relaxation=ms.secant_relaxation, solver=sv.linear,
                                    linear_tol=sv.tolerance, linear_maxit=sv.max_iterations,
                                    start="linear" if self.nested is None else "current",
                                    preconditioner=sv.preconditioner)
        free = self.forms.unheld_rigid_motions()
        if free:
            raise SceneError([Problem("boundary_conditions", f"the bodies are not held against "
                                      f"{', '.join(free)}: add displacement or symmetry conditions that stop "
                                      "it, or a foundation")], source=f"scene {scene.scene.name!r}")

    # -- solving --------------------------------------------------------------------------------------------
    def solve(self, t: float, where: str, record: bool = True) -> None:
        self.forms.t.Set(t)
        if self.nested is not None:
            self.nested_solves.append(self.nested(self.forms, t, where))
        if self.forms.stiffness_uses_temperature:
            check_elastic_temperatures(self.forms, where)
        self.solver.solve(where)
        watch_small_strain(self, where)
        if record:
            self.record(t)

    def contact_multipliers(self) -> list[tuple]:
        return list(self.solver.contact.multipliers) if self.contacts else []

    def steady(self, where: str) -> None:
        self.solve(0.0, where, record=False)

    def start(self, t0: float, where: str) -> None:
        self.solve(t0, where, record=False)

    def advance(self, step: Step) -> None:
        """Static mechanics is solved at the output times only (a coupled run solves it at every step)."""
        if step.output:
            self.solve(step.b, step.where, record=False)

    def solved_at(self, step: Step) -> bool:
        """Whether :meth:`advance` (or a coupled step) solved the mechanics in ``step``."""
        return step.output or self.records_every_step

    def adopt(self, old: StaticMechanicsRun) -> None:
        """Continue the histories of ``old`` (the same scene on the previous mesh: contact-zone following): the
        times, the solves, the warnings and the contact records (the factorizations are counted by the
        follower)."""
        self.times = old.times
        self.warnings[:] = old.warnings + [w for w in self.warnings if w not in old.warnings]
        self.solver.history[:0] = old.solver.history
        if self.contact_output is not None:
            self.contact_output.history[:0] = old.contact_output.history

    def record(self, t: float) -> None:
        """Keep the solution of the last solve as the one at time t (s)."""
        self.times.append(t)
        if self.contact_output is not None:
            self.contact_output.record(t, self.solver)

    # -- checkpoints ----------------------------------------------------------------------------------------
    @property
    def factorizations(self) -> int:
        return self.solver.factorizations

    def capture(self) -> tuple[dict, dict]:
        """The state after the last solve: the displacement, the contact solver's warm start and the last contact
        results as arrays (copied once per solve, reused while no solve happens), and the series lengths."""
        if self._copy is None or self._copy[0] != len(self.times):      # solved since the last capture
            arrays = {"mechanics": np.array(self.forms.gf.vec.FV().NumPy())}
            if self.contact_output is not None:
                arrays.update({f"warm/{k}": v for k, v in self.solver.contact.capture().items()})
            self._copy = (len(self.times), arrays)
        arrays = dict(self._copy[1])
        out = self.contact_output
        for i, res in enumerate(out.latest if out is not None else []):   # replaced (not changed) by each solve
            arrays.update({f"latest/{i}/{k}": np.asarray(v) for k, v in res.items()})
        lengths = {"times": len(self.times), "history": len(self.solver.history),
                   "contact_history": len(out.history) if out is not None else 0,
                   "contact_latest": len(out.latest) if out is not None else 0}
        return arrays, lengths

    def meta(self, lengths: dict) -> dict:
        out = self.contact_output
        return {"times": self.times[:lengths["times"]],
                "history": [dataclasses.asdict(i) for i in self.solver.history[:lengths["history"]]],
                "contact_history": out.history[:lengths["contact_history"]] if out is not None else [],
                "contact_latest": lengths["contact_latest"]}

    def checkpoint_spaces(self) -> dict:
        return {"mechanics": self.forms.gf.space}

    def restore(self, arrays: dict, meta: dict) -> None:
        self.forms.gf.vec.FV().NumPy()[:] = arrays["mechanics"]
        if parallel.distributed(self.forms.mesh):               # every copy of a shared dof holds the value
            self.forms.gf.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)
        self.times[:] = meta["times"]
        self.solver.history[:] = [NonlinearInfo(**d) for d in meta["history"]]
        out = self.contact_output
        if out is not None:
            out.history[:] = meta["contact_history"]
            out.latest = [_in_node_order({k.split("/", 2)[2]: v for k, v in arrays.items()
                                          if k.startswith(f"latest/{i}/")}, spec.op.coords)
                          for i, spec in zip(range(meta["contact_latest"]), self.contacts)]
            # the contact solver's arrays are global (distributed: in the numbering of parallel.GlobalDofs)
            ndof = self.forms.X.ndofglobal if parallel.distributed(self.forms.mesh) else self.forms.X.ndof
            self.solver.contact.restore(ndof, {k.split("/", 1)[1]: v for k, v in arrays.items()
                                               if k.startswith("warm/")})

    def summary(self) -> dict:
        h = self.solver.history
        out = {"model": self.setup.model, "solver": self.solver.method if self.setup.nonlinear else "linear",
               "solves": len(h), "times_s": self.times,
               "iterations": [i.iterations for i in h], "wall_s": [i.wall_s for i in h],
               "last_changes": h[-1].changes if h else []}
        if self.nested_solves:
            out["nested_iteration"] = [[{"ndof": n, "iterations": i, "wall_s": w} for n, i, w in solves]
                                       for solves in self.nested_solves]
        if self.contact_output is not None:
            out.update(self.contact_output.summary())
        return {"mechanics": out}


def check_distributed_mechanics(scene: Scene, forms: ElasticForms) -> None:
    """What the elastic solver cannot do on a distributed mesh, as a SceneError naming the keys (before any solve:
    the mixed formulation and the primal-dual Newton tangent of softening regions are solved directly)."""
    problems = []
    if forms.mixed:
        problems.append(Problem("mechanics.formulation", f"the mixed displacement-pressure formulation (regions "
                                f"{', '.join(forms.mixed)}) is not supported in distributed runs; set "
                                "formulation = 'displacement'"))
    soft = [r for r, p in forms.setup.props.items() if p.lam < 1.0]
    if soft and scene.mechanics.nonlinear_solver == "newton":
        problems.append(Problem("mechanics.nonlinear_solver", f"Newton with softening regions ({', '.join(soft)}: "
                                "rheology_lambda < 1) uses a tangent solved directly, not available in distributed "
                                "runs; use 'secant'"))
    if problems:
        raise SceneError(problems, source=f"scene {scene.scene.name!r} (distributed run)")
