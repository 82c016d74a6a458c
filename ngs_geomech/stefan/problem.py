"""From a scene with phase change to the Stefan problem (seed (2.46)-(2.51), (2.55)), and what a run keeps of
it: the enthalpy solver, the output fields, the phase boundary, the melted volume and the latent heat stored per
phase-change region at the output times, the energy balance, the Newton iterations, and its checkpoint state.

A scene is solved as a Stefan problem when a material has ``phase_change_temperature`` and physics.thermal is
'transient' (:func:`ngs_geomech.validation.validate.stefan_scene`): then :class:`StefanSolver` (nodal enthalpy,
lumped P1, backward Euler, semi-smooth Newton) replaces the heat solver. Boundary data: temperature and flux
conditions, sources; unnamed boundaries are insulated; contact interfaces between touching blocks pass heat by a
penalty on the temperature jump (``thermal_penalty``; :mod:`ngs_geomech.stefan.forms`). A material's
``conductivity_temperature_coefficient`` b and ``reference_temperature`` give k(T) = k (1 + b (T - T_ref)) in
both phases (``conductivity`` and ``conductivity_liquid`` are the values at T_ref); a run stops with an error
naming that key when k is not positive at a temperature reached. Heat transfer (Robin) conditions
(``heat_transfer_coefficient``, ``ambient_temperature``) exchange h (T_amb - T) with the nodal T; anisotropic
conductivities are taken as k_phase K_hat per phase (the liquid's tensor proportional to the solid's); axisymmetric
scenes weight every integral by r. Conductivities may be expressions of x, y, z when the phases share the
variation (k_l(x) = c k_s(x), c constant per region: ``variation`` G(x), read at the region's vertices). Validation
refuses conductivities of T (the linear law above carries the T dependence), heat capacities given as expressions,
liquid tensors not proportional to the solid's, a ratio k_l / k_s that changes over a region, and P2.

Volumes are m^2 per metre of depth in plane scenes (m^3 in 3D and axisymmetric: the whole body, 2 pi times the
forms' per-radian integrals), heats J per metre of depth (J in 3D and axisymmetric).

Distributed meshes (MPI, :mod:`ngs_geomech.parallel`): every rank holds the nodal state of its part, the solver
takes its distributed Newton path (:mod:`ngs_geomech.stefan.solver`), and the figures of :meth:`StefanRun.record`
and :meth:`StefanRun.summary` (volumes, melted volumes, heats, energy balance, iterations) are global, the same on
every rank (each vertex counted once). :meth:`StefanRun.phase_boundary` gives the iso-line of all parts on every
rank (a collective call, on the gathered vertex arrays of :mod:`ngs_geomech.io.meshdata`). Contact interfaces are
refused there (not supported under MPI). :meth:`StefanRun.capture` and :meth:`StefanRun.restore` work on this
rank's local arrays (valid only for the same partition) and the front-following meshes
(:mod:`ngs_geomech.adapt.front_following`) are serial.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import Problem, SceneError, SolverError
from ..fem.coefficients import Steady, expression_function
from ..geometry.assemble import GeometryModel
from ..geometry.isolines import IsoLines, iso_segments
from ..heat.conductance import heatless_closed, unfollowed_closed
from ..heat.materials import (
    CONDUCTIVITY_KEYS,
    conductivity_field,
    conductivity_shape,
    conductivity_tensor,
    has_phase_change,
    phase_change_properties,
    volumetric_heat_capacity,
)
from ..heat.problem import (
    initial_temperature,
    interface_conductances,
    pressure_coefficients,
    region_measure,
    source_function,
)
from ..heat.run import temperature_figures
from ..io.meshdata import mesh_arrays, vertex_values
from ..linalg.iterative import choose_solver
from ..parts import Step, ThermalPart
from ..scene.expressions import short
from ..scene.model import Scene
from ..scene.schema import holds_expression
from ..scene.units import YEAR
from .forms import DEFAULT_INTERFACE_PENALTY, StefanForms, StefanSetup, shape_cf
from .materials import ConductivityRangeError, PhaseChangeMaterial, PlainThermalMaterial
from .solver import StefanSolver
from .stepping import CONTROLS, MAX_LEVEL, StepControl, bisect_time

AUTO_NODES = {2: 1_000_000, 3: 5_000}
"""Nodes above which ``solver.linear = "auto"`` solves the serial Stefan Newton steps by GMRES with h1amg instead of
SuperLU with low-rank updates (per mesh dimension). Measured on one thread, ``melting_block`` made 3D
(6 x 2 x 4 m, the lens 1.25 x 1 x 0.4 m, 20 days in 15 steps, whole runs): direct / GMRES 2.7 / 4.7 s at 2k nodes,
67 / 17.6 s at 7k (SuperLU factors the 3D Newton matrix 14 times, 3.9 s each), > 420 s (stopped) / 38 s at 13k;
GMRES 234 s at 46k. GMRES iterations per solve, max: 13 / 18 / 19 / 24 at 2k / 7k / 13k / 46k nodes. In 2D SuperLU
stays far ahead (13 x faster at 12k nodes on the Neumann strip, :mod:`ngs_geomech.stefan.krylov_jacobian`): the 2D
value keeps the direct path (not measured up to it)."""

LEVEL = 0.5
"""The phase boundary is the iso-line liquid_fraction = LEVEL."""

TRANSFER_ORDER = 4
"""Extra quadrature order of the lumped projection of an enthalpy onto another mesh (the old P1 field is
piecewise linear on the old mesh)."""


VARIATION_POINTS = 2000
"""Most mesh vertices of a region at which a conductivity varying in x, y, z is read for its scale k_s (the largest
principal value there) and its ratio k_l / k_s (:func:`~ngs_geomech.heat.materials.conductivity_field`)."""


def stefan_materials(scene: Scene, mesh=None) -> dict:
    """Region name -> :class:`PhaseChangeMaterial` or :class:`PlainThermalMaterial` of a validated scene; a
    conductivity that varies in x, y, z becomes k_s G(x) (``variation``), read at the region's vertices of ``mesh``
    (needed then)."""
    dim = 3 if scene.scene.dimension == "3d" else 2
    out = {}
    for name, m in scene.materials.items():
        law = {"conductivity_temperature_coefficient": m.conductivity_temperature_coefficient,
               "reference_temperature": m.reference_temperature}
        if any(holds_expression(getattr(m, k)) for k in CONDUCTIVITY_KEYS):
            out[name] = _varying_material(m, name, dim, mesh, law)
            continue
        pc = phase_change_properties(m, dim)
        if pc is not None:
            out[name] = PhaseChangeMaterial(melting_temperature=pc.temperature, latent_heat=pc.latent_heat,
                                            rho_c_solid=pc.rho_c_solid, rho_c_liquid=pc.rho_c_liquid,
                                            conductivity_solid=pc.conductivity_solid,
                                            conductivity_liquid=pc.conductivity_liquid,
                                            anisotropy=_shape(pc.anisotropy), **law)
        else:
            k, shape = conductivity_shape(conductivity_tensor(m, dim))
            out[name] = PlainThermalMaterial(rho_c=volumetric_heat_capacity(m), conductivity=k,
                                             anisotropy=_shape(shape), **law)
    return out


def _varying_material(m, name: str, dim: int, mesh, law: dict):
    """The Stefan material of a region whose conductivity varies in x, y, z (read at its vertices)."""
    if mesh is None:
        raise ValueError(f"stefan_materials: region {name!r} has a conductivity of x, y, z: the mesh is needed")
    pts = np.array([mesh[ngs.NodeId(ngs.VERTEX, int(i))].point for i in _region_vertices(mesh, name)],
                   dtype=float).reshape(-1, mesh.dim)
    pts = np.pad(pts, ((0, 0), (0, 3 - mesh.dim)))
    pts = pts[::max(1, -(-len(pts) // VARIATION_POINTS))]
    if parallel.distributed(mesh):          # every rank reads the same points: one k_s, k_l on all of them
        pts = parallel.concat(mesh, pts)
    field = conductivity_field(m, dim, pts)
    if field.k_l is None:
        return PlainThermalMaterial(rho_c=volumetric_heat_capacity(m), conductivity=field.k_s,
                                    variation=field.shape, **law)
    pc = phase_change_properties(m, dim, field)
    return PhaseChangeMaterial(melting_temperature=pc.temperature, latent_heat=pc.latent_heat,
                               rho_c_solid=pc.rho_c_solid, rho_c_liquid=pc.rho_c_liquid,
                               conductivity_solid=field.k_s, conductivity_liquid=field.k_l,
                               variation=field.shape, **law)


def _shape(shape) -> tuple | None:
    """K_hat as nested tuples (hashable: regions with equal materials share a stiffness matrix), or None."""
    return None if shape is None else tuple(tuple(float(c) for c in row) for row in np.asarray(shape))


def _summed(functions: list):
    """One TimeFunction for the sum of a region's sources: Steady when all are (the Stefan forms assemble
    the load once then), otherwise a plain time-dependent function."""
    if all(isinstance(f, Steady) for f in functions):
        return Steady(lambda t: sum((f(t) for f in functions[1:]), functions[0](t)))
    return lambda t: sum((f(t) for f in functions[1:]), functions[0](t))


def stefan_setup(scene: Scene, mesh, geo: GeometryModel | None = None) -> StefanSetup:
    """The StefanSetup of a validated scene on its mesh; ``geo`` (the scene's geometry model) gives the contact
    interfaces heat passes through (touching blocks; the jump penalty of :mod:`ngs_geomech.stefan.forms`)."""
    axi = scene.scene.dimension == "axisymmetric"
    setup = StefanSetup(materials=stefan_materials(scene, mesh), pressure_coefficients=pressure_coefficients(scene),
                        axisymmetric=axi)
    if geo is not None:
        conducting = interface_conductances(scene, geo, mesh, radiation="linearized")   # instead of the penalty
        setup.conductances = list(conducting.values())
        penalty = {itf.name: itf.thermal_penalty for itf in scene.interfaces}
        setup.interfaces = [(cs.master, cs.minion, penalty.get(cs.name) or DEFAULT_INTERFACE_PENALTY)
                            for cs in geo.contacts.values() if not cs.initial_gap and cs.name not in conducting]
    for name, bc in scene.boundary_conditions.items():
        if bc.temperature is not None:
            setup.dirichlet[name] = expression_function(bc.temperature)
        elif bc.flux is not None:
            setup.flux[name] = expression_function(bc.flux)
        elif bc.heat_transfer_coefficient is not None:
            setup.robin[name] = (bc.heat_transfer_coefficient, expression_function(bc.ambient_temperature))
    by_region: dict[str, list] = {}
    for src in scene.sources:
        by_region.setdefault(src.region, []).append(source_function(src, region_measure(mesh, src.region, axi)))
    setup.sources = {r: _summed(fs) for r, fs in by_region.items()}
    return setup


def _heat_flux(mesh, materials: dict, T):
    """The heat flux -k(T) K_hat grad T (W/m^2) of the nodal temperature T: per region the conductivity of the
    phase at T (k_l above, k_s below Theta_R) times f(T) = 1 + b (T - T_ref), times K_hat when anisotropic, G(x)
    when it varies in x, y, z."""
    def k(m):
        base = (ngs.IfPos(T - m.melting_temperature, m.conductivity_liquid, m.conductivity_solid)
                if isinstance(m, PhaseChangeMaterial) else m.conductivity)
        return base * (1 + m.conductivity_temperature_coefficient * (T - m.reference_temperature)
                       if m.temperature_dependent else 1)
    if all(m.anisotropy is None and m.variation is None for m in materials.values()):
        return -mesh.MaterialCF({n: k(m) for n, m in materials.items()}, default=0.0) * ngs.grad(T)
    d = mesh.dim
    eye = ngs.CoefficientFunction(tuple(float(i == j) for i in range(d) for j in range(d)), dims=(d, d))
    tensors = {n: k(m) * (shape_cf(m, d) if shape_cf(m, d) is not None else eye) for n, m in materials.items()}
    zero = ngs.CoefficientFunction((0.0,) * d * d, dims=(d, d))
    return -(mesh.MaterialCF(tensors, default=zero) * ngs.grad(T))


def _region_vertices(mesh, name: str) -> np.ndarray:
    """The vertex numbers of a region's elements."""
    return np.unique([v.nr for el in mesh.Materials(f"^{name}$").Elements() for v in el.vertices]).astype(int)


def _nodal(mesh, cf) -> np.ndarray:
    """A CoefficientFunction at the mesh vertices (this rank's vertices on a distributed mesh)."""
    if mesh.nv == 0:                                  # rank 0 of a distributed mesh holds no vertices
        return np.zeros(0)
    pts = np.array([v.point for v in mesh.vertices])
    mips = mesh(*pts.T) if pts.shape[1] == 3 else mesh(pts[:, 0], pts[:, 1])
    return np.asarray(cf(mips), dtype=float).ravel()


class StefanRun(ThermalPart):
    """The Stefan problem of a run (a :class:`~ngs_geomech.parts.Part`): forms, solver, output fields and the
    histories a summary and a checkpoint need. ``regions`` are the phase-change regions (scene order). The Newton
    steps are solved by GMRES on a distributed mesh and, serially, when ``solver.linear`` chooses "iterative"
    (above :data:`AUTO_NODES` nodes for "auto"); ``krylov_preconditioner`` ("bddc", "h1amg" or "jacobi", None:
    BDDC distributed, h1amg serial) is then their preconditioner (:mod:`ngs_geomech.stefan.krylov_jacobian`)."""

    key = "stefan"

    def __init__(self, scene: Scene, mesh, geo: GeometryModel | None = None, krylov_preconditioner: str | None = None):
        super().__init__()
        self.scene = scene
        self.mesh = mesh
        self.forms = f = StefanForms(mesh, stefan_setup(scene, mesh, geo))
        linear = choose_solver(scene.solver.linear, f.n, mesh.dim, distributed=f.distributed, auto_dofs=AUTO_NODES)
        self.solver = StefanSolver(f, krylov_preconditioner=krylov_preconditioner, linear=linear)
        self.regions = [n for n, m in scene.materials.items() if has_phase_change(m)]
        self.latent = {r: f.setup.materials[r].latent_heat for r in self.regions}
        self.group = {r: next(g for g, names in enumerate(f.group_regions) if r in names) for r in self.regions}
        _, v = f.V.TnT()
        self.mass = {}
        for r in self.regions:
            lf = ngs.LinearForm(f.V)
            lf += f.lumped(v, mesh.Materials(r))
            lf.Assemble()
            self.mass[r] = lf.vec.FV().NumPy().copy()      # distributed on a distributed mesh: sums add over ranks
        self.volume = {r: float(parallel.allsum(mesh, float(self.mass[r].sum()))) for r in self.regions}
        T = f.gf_temperature
        self.fields = {"temperature": T, "enthalpy": f.gf_enthalpy, "liquid_fraction": f.gf_liquid_fraction,
                       "heat_flux": _heat_flux(mesh, f.setup.materials, T)}
        self.T = T
        phi = f.gf_liquid_fraction
        self.probe_fields = {"temperature": T, "liquid_fraction": phi, "front": phi}
        self.iterations: list[int] = []                  # per (sub)step
        self.control: StepControl = CONTROLS[scene.time.stefan_step_control if scene.time is not None
                                             else "adaptive"]()
        """The substeps of the scene steps (:mod:`ngs_geomech.stefan.stepping`)."""
        self.dirichlet_heat: list[float] = []            # per step: heat in through the Dirichlet nodes
        self.source_heat: list[float] = []               # per step: sources and fluxes
        self.robin_heat: list[float] = []                # per step: heat transfer (Robin) conditions
        self.interface_heat: list[dict] = []             # per step: heat across each conductance interface (J)
        self.records: dict = {"time_s": [], "melted_volume": {r: [] for r in self.regions},
                              "latent_heat_stored": {r: [] for r in self.regions}, "heat_content": []}
        self._steps_at_record: list[int] = []            # steps completed at each record
        self.transfers: list[tuple[int, float]] = []     # front-following meshes: (records before, heat change J)
        self.initial_heat = 0.0
        self._arrays = mesh_arrays(mesh) if mesh.dim == 2 else None

    # -- the part of a run (:class:`~ngs_geomech.parts.Part`) ----------------------------------------------
    def start(self, t0: float, where: str) -> None:
        self.set_initial(t0)

    def solve_step(self, step: Step, heating=None):
        """One step (:meth:`step`) with the nodal load of ``heating`` (a :class:`DeformationHeating`) when given."""
        if heating is None:
            return self.step(step.a, step.b, step.where)
        return self.step(step.a, step.b, step.where, heating.load())

    def heating_target(self) -> tuple:
        """(space, test function, volume measure, weight) a deformation-heating source is assembled against: the
        nodal (vertex-rule) measure of the lumped P1 enthalpy forms, weighted by r in axisymmetric scenes."""
        f = self.forms
        return f.V, f.V.TestFunction(), f.dx_lumped, 1.0 if f.weight is None else f.weight

    def take_state(self, old: StefanRun, t0: float | None) -> tuple[float, float, object]:
        """Carry the nodal enthalpy of ``old`` (the same scene on another mesh) over by the lumped L2 projection
        (:meth:`StefanForms.project_enthalpy`, which keeps the heat content up to quadrature). ``t0`` (s; a
        remesh at the start time): the scene's initial state set instead (a projection would smear a geotherm
        and unbalance an initial stress that cancels its thermal stress). Returns the heat content before and
        after (J per m of depth in plane scenes, J in 3D) and a callable that continues ``old``'s histories here
        with the change counted in the energy balance (None at the start time), to call once this mesh is kept."""
        e_old = old.solver.e
        before = old.forms.heat_content(e_old)
        old.forms.store(e_old)
        if t0 is not None:
            self.set_initial(t0)
            return before, self.forms.heat_content(self.solver.e), None
        e = self.forms.project_enthalpy(old.forms.gf_enthalpy, order=TRANSFER_ORDER)
        self.solver.set_initial_enthalpy(e)
        after = self.forms.heat_content(e)
        return before, after, lambda: self.adopt(old, after - before)

    @property
    def factorizations(self) -> int:
        return self.solver.factorizations

    @property
    def ndof(self) -> int:
        return self.forms.n

    @property
    def ndof_global(self) -> int:
        return self.forms.V.ndofglobal

    def summary(self) -> dict:
        return {"stefan": self.report()}

    def line_names(self, scene: Scene) -> list[str]:
        """The phase boundary as a line series (2D scenes writing VTK)."""
        return ["phase_boundary"] if scene.output.vtk and self.mesh.dim == 2 else []

    def lines(self) -> dict:
        """The phase boundary's points, segments and temperatures (collective on a distributed mesh)."""
        iso = self.phase_boundary()
        return {"phase_boundary": (iso.points, iso.segments,
                                   {"temperature": iso.interpolate(vertex_values(self.forms.gf_temperature))})}

    def figures(self, canvas) -> None:
        """The temperature (:func:`temperature_figures`), the temperature with the phase boundary at the last
        time, and the melted volume fraction of each phase-change region over the output times (2D)."""
        temperature_figures(canvas, self.T)
        if canvas.arrays is None:
            return
        iso = self.phase_boundary()
        canvas.draw.field_figure(canvas.arrays, vertex_values(self.T), canvas.path("phase_boundary.png"),
                                 title=f"{canvas.title}: temperature and phase boundary, {canvas.when}",
                                 label=f"T ({canvas.t_unit})", axis_labels=canvas.labels, lines=iso.as_segments(),
                                 lines_label="phase boundary (liquid fraction 1/2)")
        rec = self.records
        if len(rec["time_s"]) > 1:
            times = np.array(rec["time_s"])
            unit, label = (YEAR, "t (years)") if times[-1] - times[0] >= 2 * YEAR else (1.0, "t (s)")
            canvas.draw.time_curves(times, {r: np.array(v) / self.volume[r] for r, v in rec["melted_volume"].items()},
                                    canvas.path("melted_fraction.png"), title=f"{canvas.title}: melted volume fraction",
                                    ylabel="liquid volume / region volume (-)", time_unit=unit, time_label=label)

    # -- stepping -----------------------------------------------------------------------------------------
    def set_initial(self, t0: float) -> None:
        """The scene's initial temperature at the nodes (nodes at a phase-change temperature: solid).

        The Dirichlet nodes keep it too (the heat solver puts them at their boundary temperature at t0): they take
        the boundary temperature in the first step, so the heat that takes (latent heat included) is counted as
        heat that entered through the boundary. Measured on the two-phase Neumann scene started from the cold
        strip (h = 0.025 m): the heat that entered is 0.2 % below the closed form's, against 2.7 % with the
        boundary nodes already at T_L at t0 (their latent heat then appears from nowhere); the later states are
        the same."""
        T = _nodal(self.mesh, initial_temperature(self.scene, self.mesh, ngs.Parameter(t0)))
        if sum(parallel.allgather(self.mesh, int(np.count_nonzero(~np.isfinite(T))))):
            raise SceneError([Problem(*self._not_finite_initial(t0))], source=f"scene {self.scene.scene.name!r}")
        try:
            self.solver.set_initial(T)
        except ConductivityRangeError as exc:
            raise SolverError("; ".join(f"materials.{r}.conductivity_temperature_coefficient" for r in exc.regions)
                              + f": {exc}") from None
        self.initial_heat = self.forms.heat_content(self.solver.e)

    def interpolate(self, cf):
        """``cf`` at the nodes in the temperature's (P1) space, as the initial temperature is set."""
        g = ngs.GridFunction(self.T.space)
        g.vec.FV().NumPy()[:] = _nodal(self.mesh, cf)
        return g

    def _not_finite_initial(self, t0: float) -> tuple[str, str]:
        """(key, message) of the initial temperature that is not finite at a vertex (collective)."""
        ini = self.scene.initial
        key, value = "initial.temperature", ini.temperature
        for name, v in ini.regions.items():
            values = _nodal(self.mesh, expression_function(v)(ngs.Parameter(t0)))
            local = len(values) and not np.all(np.isfinite(values[_region_vertices(self.mesh, name)]))
            if any(parallel.allgather(self.mesh, bool(local))):
                key, value = f"initial.regions.{name}", v
                break
        return key, (f"{short(str(value))!r} is not finite at some vertices of the mesh (between the points "
                     "validation samples): a singularity or a function outside its domain")

    @property
    def halvings(self) -> int:
        """Substeps taken again finer because their Newton iteration failed."""
        return self.control.rejected

    def step(self, a: float, b: float, where: str, extra_load: np.ndarray | None = None):
        """One scene step from a to b (s) in substeps chosen by ``control`` (:mod:`ngs_geomech.stefan.stepping`);
        ``extra_load``: a nodal source vector (e.g. deformation heating, W: the same power over the step). A
        substep whose Newton iteration fails is rewound and taken again a level finer, down to (b - a) /
        2^MAX_LEVEL, where the failure is a SolverError with the solver's diagnosis. Returns the last substep's
        info."""
        ctl, units, pos, info = self.control, 1 << MAX_LEVEL, 0, None
        while pos < units:
            level = ctl.next_level(pos)
            end = pos + (units >> level)
            s0, s1 = bisect_time(a, b, pos), bisect_time(a, b, end)
            mark = self.mark()
            try:
                info = self._substep(s0, s1, where, extra_load)
            except SolverError as exc:
                self.rewind(mark)
                if not ctl.reject():
                    raise SolverError(f"{where}: {exc} (at the smallest step the step control allows, dt = "
                                      f"{s1 - s0:.4g} s = the scene step / {units})") from exc
                continue
            ctl.accept(info.iterations, ctl.travel(info.phase_changes, info.front_nodes), s1 - s0)
            pos = end
        return info

    def _substep(self, a: float, b: float, where: str, extra_load: np.ndarray | None):
        """One Stefan solve from a to b (s), its heats appended to the histories."""
        if self.forms.conductances is not None:           # linearized radiation: h_rad at the start of the step
            self.forms.lag_radiation(self.forms.nodal_state(self.solver.e).T)
        try:
            info = self.solver.step(a, b) if extra_load is None else self.solver.step(a, b, extra_load)
        except ConductivityRangeError as exc:       # the temperatures reached: a shorter step does not help
            raise SolverError(f"{where}: " + "; ".join(f"materials.{r}.conductivity_temperature_coefficient"
                                                       for r in exc.regions) + f": {exc}") from None
        self.iterations.append(int(info.iterations))
        self.dirichlet_heat.append(float(info.boundary_heat))
        self.source_heat.append(float(info.source_heat))
        self.robin_heat.append(float(info.robin_heat))
        if self.forms.conductances is not None:
            T = self.forms.nodal_state(self.solver.e).T
            self.interface_heat.append({n: (b - a) * q for n, q in self.forms.conductances.flows(T).items()})
        return info

    def set_contact_state(self, states) -> list[str]:
        """The mechanics' contact state per interface (:class:`~ngs_geomech.heat.conductance.ContactNodes`) for the
        contact-conductance interfaces; returns the interfaces closed in it that carry no heat."""
        self.forms.set_contact_state(states)
        s = self.forms.setup
        return heatless_closed(states, s.conductances, {m for m, _, _ in s.interfaces})

    def contact_warnings(self, states) -> list[str]:
        """The interfaces ``states`` closes that carry no heat, this part keeping the geometry's state."""
        s = self.forms.setup
        return (heatless_closed(states, s.conductances, {m for m, _, _ in s.interfaces})
                + unfollowed_closed(states, s.conductances))

    def mark(self) -> tuple:
        """The state before a step, to repeat the step with :meth:`rewind` (coupling iterations)."""
        return self.solver.mark(), len(self.iterations), self.control.state()

    def rewind(self, mark: tuple) -> None:
        """Back to the state of :meth:`mark` (the step's histories dropped, the step control as it was)."""
        self.solver.rewind(mark[0])
        self.control.load(mark[2])
        n = mark[1]
        del self.iterations[n:], self.dirichlet_heat[n:], self.source_heat[n:], self.robin_heat[n:]
        del self.interface_heat[n:]

    def record(self, t: float) -> None:
        """The melted volume and latent heat per region and the heat content at an output time (after the
        steps taken so far)."""
        e = self.solver.e
        self._steps_at_record.append(len(self.iterations))
        frac = self.forms.liquid_fractions(e)
        rec = self.records
        rec["time_s"].append(float(t))
        for r in self.regions:
            melted = float(parallel.allsum(self.mesh, float(self.mass[r] @ frac[:, self.group[r]])))
            rec["melted_volume"][r].append(melted)
            rec["latent_heat_stored"][r].append(self.latent[r] * melted)
        rec["heat_content"].append(self.forms.heat_content(e))

    # -- output -------------------------------------------------------------------------------------------
    def phase_boundary(self) -> IsoLines | None:
        """The liquid_fraction = 1/2 iso-line on the triangles of the phase-change regions (2D), with the
        temperature at its points available through :meth:`IsoLines.interpolate`; None in 3D. On a distributed
        mesh a collective call: the vertices and triangles of all parts joined in rank order
        (:func:`~ngs_geomech.io.meshdata.mesh_arrays`, :func:`~ngs_geomech.io.meshdata.vertex_values`), the
        same lines on every rank; interpolate takes ``vertex_values`` of a field (gathered the same way)."""
        m = self._arrays
        if m is None:
            return None
        ids = [i for i, n in enumerate(m.regions) if n in self.regions]
        tris = m.triangles[np.isin(m.tri_region, ids)]
        return iso_segments(m.points, tris, vertex_values(self.forms.gf_liquid_fraction), LEVEL)

    def report(self) -> dict:
        """The summary's ``stefan`` block. Axisymmetric scenes: volumes and heats of the whole body (2 pi times
        the per-radian integrals of the forms), as the heat run's interface flows."""
        rec = self.records
        plane = self.mesh.dim == 2 and not self.forms.axisymmetric
        c = 2 * np.pi if self.forms.axisymmetric else 1.0

        def whole(values: list) -> list:
            return [c * v for v in values] if self.forms.axisymmetric else values
        melted = {r: whole(v) for r, v in rec["melted_volume"].items()}
        latent = {r: whole(v) for r, v in rec["latent_heat_stored"].items()}
        total_latent = [sum(latent[r][i] for r in self.regions) for i in range(len(rec["heat_content"]))]
        its = self.iterations
        return {
            "solver": "enthalpy form (2.55): nodal enthalpy, lumped P1, backward Euler, semi-smooth Newton",
            "units": {"volume": "m^2 per m of depth" if plane else "m^3",
                      "heat": "J per m of depth" if plane else "J"},
            "phase_change_regions": {r: {"phase_change_temperature": self.forms.setup.materials[r].melting_temperature,
                                         "latent_heat_J_per_m3": self.latent[r], "volume": c * self.volume[r]}
                                     for r in self.regions},
            "output_times_s": rec["time_s"],
            "melted_volume": melted,
            "melted_fraction": {r: [v / self.volume[r] for v in rec["melted_volume"][r]] for r in self.regions},
            "latent_heat_stored": latent,
            "latent_heat_stored_total": total_latent,
            "energy": self._energy(total_latent, whole),
            "newton_iterations": {"mean": float(np.mean(its)) if its else 0.0, "max": int(max(its, default=0)),
                                  "steps": len(its)},
            "step_halvings": self.halvings,
            "step_control": self.control.report(),
            **self._conductance_report(),
        }

    def _energy(self, total_latent: list, whole) -> dict:
        """The energy balance of :meth:`report` (``whole``: per-radian values to the whole body, axisymmetric)."""
        rec = self.records
        robin = bool(self.forms.setup.robin)
        per_step = np.array(self.dirichlet_heat) + np.array(self.source_heat)
        if robin:
            per_step = per_step + np.array(self.robin_heat)
        step_of_record = self._steps_at_record          # cumulative supply at each output time

        def cumulated(values) -> list:
            total = np.cumsum(values)
            return whole([float(total[k - 1]) if k > 0 else 0.0 for k in step_of_record])
        heat_in = cumulated(per_step)
        heat_in_dirichlet = cumulated(self.dirichlet_heat)
        heat_in_robin = cumulated(self.robin_heat) if robin else [0.0] * len(heat_in)
        gain = whole([h - self.initial_heat for h in rec["heat_content"]])
        # heat changed by the state transfers between meshes (front-following meshes) before each record
        moved = whole([sum(dq for n, dq in self.transfers if n <= i) for i in range(len(gain))])
        latent_gain = [v - total_latent[0] for v in total_latent] if total_latent else []
        scale = max([abs(v) for v in heat_in + gain] + [1e-300])
        imbalance = [abs(g - q - m) / scale for g, q, m in zip(gain, heat_in, moved)]
        return {"heat_gain": gain, "latent_heat_gain": latent_gain,
                "sensible_heat_gain": [g - lg for g, lg in zip(gain, latent_gain)],
                "heat_supplied": heat_in, "heat_supplied_dirichlet": heat_in_dirichlet,
                "heat_supplied_sources_fluxes": [q - d - rb for q, d, rb in zip(heat_in, heat_in_dirichlet,
                                                                                 heat_in_robin)],
                **({"heat_supplied_robin": heat_in_robin} if robin else {}),
                "imbalance_rel": imbalance[-1] if imbalance else 0.0,
                "imbalance_rel_max": max(imbalance) if imbalance else 0.0,
                **({"heat_transferred": moved,
                    "transfer_note": "heat content changed by the enthalpy transfers between meshes "
                                     "(front-following); imbalance_rel counts it: |gain - supplied - "
                                     "transferred| / scale"} if self.transfers else {})}

    def _conductance_report(self) -> dict:
        """The contact-conductance interfaces: the heat across each (master -> minion, J per m of depth or J) and
        their last conductances ({} without)."""
        c = self.forms.conductances
        if c is None:
            return {}
        ranges = c.ranges()
        return {"interface_heat": {it.spec.name: float(sum(h.get(it.spec.name, 0.0) for h in self.interface_heat))
                                   for it in c.items},
                "interface_conductance": {it.spec.name: {"state": it.source, "conductance_min": ranges[it.spec.name][0],
                                                         "conductance_max": ranges[it.spec.name][1],
                                                         "units": "W/(m^2 K)"} for it in c.items}}

    def adopt(self, old: StefanRun, heat_change: float) -> None:
        """Continue the histories of ``old`` (the same scene on the previous mesh) after the state was carried
        over to this mesh with the heat content changed by ``heat_change`` (J per m of depth, or J)."""
        self.initial_heat = old.initial_heat
        self.control = old.control
        for name in ("iterations", "newton_iterations", "dirichlet_heat", "source_heat", "robin_heat",
                     "interface_heat", "_steps_at_record", "transfers"):
            setattr(self, name, getattr(old, name))
        self.records = old.records
        self.transfers.append((len(self.records["time_s"]), float(heat_change)))

    # -- checkpoints --------------------------------------------------------------------------------------
    def capture(self) -> tuple[dict, dict]:
        """The solver's state (:meth:`StefanSolver.capture`: the nodal enthalpy, the predictor rate, the Newton
        matrix's reuse state) as ``stefan/...`` arrays and the lengths of the histories."""
        arrays = {f"stefan/{k}": v for k, v in self.solver.capture().items()}
        arrays["stefan/step_control"] = self.control.state()
        return arrays, {"steps": len(self.iterations), "records": len(self.records["time_s"]),
                        "newton": len(self.newton_iterations)}

    def meta(self, lengths: dict) -> dict:
        n, k = lengths["steps"], lengths["records"]
        rec = self.records
        return {"initial_heat": self.initial_heat, "iterations": self.iterations[:n],
                "interface_heat": self.interface_heat[:n],
                "newton_iterations": self.newton_iterations[:lengths["newton"]],
                "dirichlet_heat": self.dirichlet_heat[:n], "source_heat": self.source_heat[:n],
                "robin_heat": self.robin_heat[:n], "steps_at_record": self._steps_at_record[:k],
                "records": {"time_s": rec["time_s"][:k], "heat_content": rec["heat_content"][:k],
                            "melted_volume": {r: v[:k] for r, v in rec["melted_volume"].items()},
                            "latent_heat_stored": {r: v[:k] for r, v in rec["latent_heat_stored"].items()}}}

    def checkpoint_spaces(self) -> dict:
        """The nodal enthalpy and its predictor rate (the nodes of the P1 space). The Newton matrix's reuse state
        is a serial run's only (a distributed run's Krylov Jacobian keeps none and ignores it; a serial run resumed
        from a distributed run's checkpoint factors anew)."""
        V = self.solver.f.V
        return {"stefan/enthalpy": V, "stefan/rate": V}

    def restore(self, arrays: dict, meta: dict) -> None:
        self.solver.restore({k.split("/", 1)[1]: v for k, v in arrays.items()
                             if k.startswith("stefan/") and k != "stefan/step_control"})
        if "stefan/step_control" in arrays:
            self.control.load(arrays["stefan/step_control"])
        self.initial_heat = float(meta["initial_heat"])
        self.iterations[:] = [int(i) for i in meta["iterations"]]
        self.newton_iterations[:] = [int(i) for i in meta["newton_iterations"]]
        self.dirichlet_heat[:] = [float(v) for v in meta["dirichlet_heat"]]
        self.source_heat[:] = [float(v) for v in meta["source_heat"]]
        self.robin_heat[:] = [float(v) for v in meta.get("robin_heat", [0.0] * len(self.source_heat))]
        self.interface_heat[:] = meta.get("interface_heat", [])
        self._steps_at_record[:] = [int(v) for v in meta["steps_at_record"]]
        r = meta["records"]
        self.records["time_s"][:] = r["time_s"]
        self.records["heat_content"][:] = r["heat_content"]
        for name in self.regions:
            self.records["melted_volume"][name][:] = r["melted_volume"][name]
            self.records["latent_heat_stored"][name][:] = r["latent_heat_stored"][name]
