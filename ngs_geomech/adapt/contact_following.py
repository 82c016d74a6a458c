"""Meshes that follow the contact zones of a time-dependent scene (``[adaptivity]`` with
``indicators = ['contact_zone']`` in a transient plane or axisymmetric scene with static mechanics and a contact
interface or foundation, with or without a phase change and deformation heating).

What is followed: the boundary of the active set and the stick/slip transitions of every contact
(:func:`transition_elements`) at each mechanics solve (the output steps; every step in a coupled scene). The mesh
is the
scene's geometry meshed anew by :func:`ngs_geomech.geometry.mesh.make_mesh` (regions and boundaries keep their
names; the physics, contact pairs and mortar couplings are rebuilt on each mesh by the run's ``build`` callable)
with the local size restricted to h_zone = h_base / 2^levels (h_base: the median longest edge of the scene's own
mesh at the contact sides) at the vertices of the flagged elements and ``layers`` rings around them. Resolution is
added where a transition goes and given back where it left by remeshing from the geometry with the flags
recomputed (the seed's problem (P) is static at each time: the slip is the total slip, so nothing but the start of
the solve depends on the previous mesh's mechanical state).

With ``indicators = ['contact_zone', 'phase_front']`` (a phase change) the elements the liquid fraction 1/2 crosses
are followed as well, at h_front = h_base,pc / 2^levels (h_base,pc: the median longest edge in the phase-change
regions), checked at the same mechanics solves (every step in a coupled scene; the output steps otherwise: unlike
:mod:`ngs_geomech.adapt.front_following`, no step is repeated, so with output.every > 1 the front may cross
coarse elements between checks).

When: ``remesh_every = 0`` (default): after a mechanics solve whose transitions lie in elements 1.25 times coarser
than the band's own (the largest ratio element size / h_zone flagged right after the last remesh; 1.5 before the
first one):
the mesh is refined at the transitions, the state carried over and the mechanics solved again at the same time, up
to ``levels + 2`` meshings per time until the transitions lie in elements of at most 1.5 h_zone.
``remesh_every = k > 0``: after every k-th mechanics solve as well. When no contact has a transition (all open,
or all closed in one state) the mesh goes back to the scene's own mesh.

Transfer (each measured and recorded in ``remeshes``; a remesh at the start time sets the scene's initial state
on the new mesh instead of carrying the old one). Fields are set by NGSolve's ``Set`` of the old field
(element-wise projection from interior quadrature points, then averaging). ``Set(..., dual = True)`` (point values
at vertices and on edges) was tried and is worse here: points on a contact side are located in the other body's
element (the heat content change of the fault test went from 9e-4 to 2e-2, Hertz's strain norm from 3e-4 to 11).

* temperature: interpolated (NGSolve's ``Set`` of the old field evaluated on the new mesh, per body); the change
  of the heat content int rho c T dx (J per m of depth in plane scenes) and the relative L2 difference
  ||T_new - T_old|| / ||T_old|| (old field integrated on the new mesh). The next heat step after a remesh is a
  backward Euler step (a Crank-Nicolson step would need the old interface multipliers of the mortar coupling,
  which are not carried over; as the start-up steps after t = 0, it damps the transfer's high frequencies).
* enthalpy (a phase change): the lumped L2 projection of front-following meshes (the heat content kept up to
  quadrature), the change counted in the Stefan energy balance; the temperature's L2 change as above.
* deformation heating: the displacement at the start of the step (for the rate u_t) interpolated; the rate of the
  step is set again from the solve on the new mesh.
* displacement: interpolated the same way; the strain norm ||eps(u)|| (L2) before and after (relative change) and
  the relative H1 difference between the transferred field and the solution re-solved on the new mesh (the
  mesh's effect, not a transfer error).
* multipliers (nodal contact pressure and tangential traction): interpolated along the contact sides
  (piecewise linear on the old side's segments); the normal resultant sum_j w_j lam_n,j before and after
  (relative change). They start the contact solve on the new mesh (``ContactSolver.warm_start`` with the nodal
  sets of the transferred multipliers: open, stick, slip).

A remesh whose contact solve fails on the new mesh (also from the penalty start) is rejected: the run goes on on
the current mesh, whose solve at that time stands, and the rejection is listed (``rejected_remeshes``; seen on
plate_collision's coarse test mesh at levels = 2, t = 0: the slab held by nothing but its foundations under a
near-zero load).

No checkpoints: such a run is not resumable (``--resume`` is refused, as for front-following meshes).
Units: m, s, K, Pa, J.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ..errors import SolverError
from ..geometry.assemble import GeometryModel
from ..geometry.mesh import make_mesh
from ..scene.model import Scene
from .estimators import (
    contact_status,
    contact_zone,
    element_sizes,
    element_vertices,
    phase_front,
    side_edges,
    vertex_coords,
)
from .front_following import phase_change_size
from .policy import MeshPolicy

log = logging.getLogger(__name__)

BAND_FACTOR = 1.25
"""remesh_every = 0: remesh when a transition lies in elements this much larger than the band's."""

RESOLVED = 1.5
"""A transition is resolved when the elements it lies in are at most this many times h_zone."""


@dataclass
class ContactRemesh:
    """One remeshing at a mechanics time (s): unknowns before/after, elements after, the meshings it took, and
    the transfer figures of the module docstring (None where a scene has no such field)."""

    t: float
    ndof_before: int
    ndof_after: int
    elements_after: int
    heat_content_change_rel: float | None
    temperature_l2_change_rel: float | None
    strain_before: float
    strain_after_transfer: float
    normal_force_before: float
    normal_force_after_transfer: float
    resolve_h1_difference_rel: float = float("nan")
    wall_s: float = 0.0
    reason: str = "transition"

    @property
    def strain_change_rel(self) -> float:
        return abs(self.strain_after_transfer - self.strain_before) / max(abs(self.strain_before), 1e-300)

    @property
    def normal_force_change_rel(self) -> float:
        return (abs(self.normal_force_after_transfer - self.normal_force_before)
                / max(abs(self.normal_force_before), 1e-300))

    def as_dict(self) -> dict:
        return {"t_s": self.t, "reason": self.reason, "ndof_before": self.ndof_before, "ndof_after": self.ndof_after,
                "elements_after": self.elements_after, "heat_content_change_rel": self.heat_content_change_rel,
                "temperature_l2_change_rel": self.temperature_l2_change_rel,
                "strain_norm_before": self.strain_before,
                "strain_norm_after_transfer": self.strain_after_transfer,
                "strain_norm_change_rel": self.strain_change_rel,
                "normal_force_before": self.normal_force_before,
                "normal_force_after_transfer": self.normal_force_after_transfer,
                "normal_force_change_rel": self.normal_force_change_rel,
                "resolve_h1_difference_rel": self.resolve_h1_difference_rel, "wall_s": self.wall_s}


def interpolate_on_side(xy_old: np.ndarray, values: np.ndarray, segments: np.ndarray, xy_new: np.ndarray):
    """Values at the points ``xy_new`` (k x 2) of the piecewise linear field given by nodal ``values`` (m, or
    m x c) at ``xy_old`` (m x 2) on the polyline ``segments`` (s x 2 node indices): each point takes the
    interpolant at its closest point on the closest segment."""
    values = np.asarray(values, dtype=float)
    if len(segments) == 0:
        return np.zeros((len(xy_new),) + values.shape[1:])
    p0, p1 = xy_old[segments[:, 0]], xy_old[segments[:, 1]]
    d = p1 - p0
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    q = xy_new[:, None, :] - p0[None, :, :]                          # k x s x 2
    s = np.clip(np.einsum("ksj,sj->ks", q, d) / dd[None, :], 0.0, 1.0)
    dist = np.linalg.norm(q - s[:, :, None] * d[None, :, :], axis=2)
    best = np.argmin(dist, axis=1)
    sb = s[np.arange(len(xy_new)), best]
    a, b = values[segments[best, 0]], values[segments[best, 1]]
    if values.ndim == 1:
        return (1 - sb) * a + sb * b
    return (1 - sb)[:, None] * a + sb[:, None] * b


def transition_elements(mesh, contacts: list, layers: int = 0) -> np.ndarray:
    """Flags (per element) of the elements at the contact transitions (``contacts``: [(ContactOperator, nodal
    status)]), ``layers`` rings around: :func:`ngs_geomech.adapt.estimators.contact_zone` with the opposite side
    searched within the local segment length."""
    return contact_zone((mesh, contacts), layers=layers, local_reach=True).eta > 0


def _segments(mesh, op) -> np.ndarray:
    """The side's boundary segments as pairs of multiplier-node indices (the end vertices of each segment)."""
    index = {int(v): j for j, v in enumerate(op.nodes)}
    out = [(index[e[0]], index[e[1]]) for e in side_edges(mesh, op.side) if e[0] in index and e[1] in index]
    return np.array(out, dtype=int).reshape(-1, 2)


def law_status(law, lam_n: np.ndarray, lam_t: np.ndarray) -> np.ndarray:
    """Nodal status (0 open, 1 stick, 2 slip) of multipliers under a contact law
    (:func:`ngs_geomech.adapt.estimators.contact_status` with the law's slip bound or friction coefficient)."""
    return contact_status(law.kind, lam_n, lam_t, law.slip_bound if law.kind == "tresca" else law.friction)


def contact_statuses(mech) -> list:
    """[(ContactOperator, nodal status)] of a mechanics run's last solve (``mech``: with ``contacts`` and a
    contact ``solver``)."""
    return [(spec.op, law_status(spec.law, lam_n, lam_t))
            for spec, (lam_n, lam_t) in zip(mech.contacts, mech.solver.contact.multipliers)]


def _strain_norm(mech) -> float:
    """||eps(u)|| = sqrt(int eps(u) : eps(u) dx) of the in-plane strain (m^(1/2) per m of depth in plane scenes):
    the displacement alone (an energy would mix in the thermal and initial stresses, whose balance a transferred
    temperature changes)."""
    f = mech.forms
    u = f.displacement()
    e = ngs.Sym(ngs.Grad(u))
    w = 2 * np.pi * ngs.x if f.setup.model == "axisymmetric" else 1.0
    return float(ngs.Integrate(w * ngs.InnerProduct(e, e), f.mesh)) ** 0.5


def _normal_force(mech, lams=None) -> float:
    lams = lams if lams is not None else [n for n, _ in mech.solver.contact.multipliers]
    return float(sum(np.dot(spec.op.weight, lam_n) for spec, lam_n in zip(mech.contacts, lams)))


class _Rejected(Exception):
    """A remesh whose contact solve failed (the run goes on on the old mesh)."""


class ContactFollowing(MeshPolicy):
    """A time-dependent run on meshes that follow the contact zones (module docstring), a
    :class:`~.policy.MeshPolicy`. ``build(mesh)`` returns the run's model on a mesh (``mechanics``: static
    mechanics with contacts; ``thermal``, ``coupling`` or None); ``phys`` is the current one, replaced at each
    remesh. The mechanics is checked after each of its solves (the output steps; every step when coupled)."""

    checkpoints = False

    def __init__(self, scene: Scene, geo: GeometryModel, build: Callable):
        super().__init__()
        a = scene.adaptivity
        self.scene, self.geo, self.build = scene, geo, build
        self.levels, self.layers, self.remesh_every = a.levels, a.layers, a.remesh_every
        self.front = "phase_front" in a.indicators      # validated: a scene with a phase change
        self.phys = None
        self.h_base = self.h_zone = 0.0
        self.h_front = None
        self.remeshes: list[ContactRemesh] = []
        self.ndofs: list[int] = []                # unknowns of each mechanics solve's (final) mesh
        self.solves = 0
        self._on_base = True
        self._band = 0.0                          # the coarseness right after the last remesh
        self.rejected: list[dict] = []            # remeshes whose contact solve failed (the run kept its mesh)

    def prepare(self, model, t0: float | None):
        """The scene's own mesh; the base size h_base: the median longest edge of its elements at the contact
        sides."""
        self.phys = model
        mesh = model.mesh
        near = np.zeros(mesh.ne, dtype=bool)
        ev = element_vertices(mesh)
        for spec in model.mechanics.contacts:
            for side in (spec.op.side, spec.op.opposite):
                if side:
                    verts = np.unique(np.array(side_edges(mesh, side), dtype=int).ravel())
                    near |= np.isin(ev, verts).any(axis=1)
        sizes = element_sizes(mesh)
        self.h_base = float(np.median(sizes[near] if near.any() else sizes))
        self.h_zone = self.h_base * 0.5 ** self.levels
        if self.front:
            self.h_front = phase_change_size(mesh, model.thermal.regions) * 0.5 ** self.levels
        return model

    def started(self, model, t0: float, where: str):
        return self._follow(model, t0, where, None)

    def advance(self, model, step):
        model.advance(step)
        if not model.mechanics.solved_at(step):
            return model
        return self._follow(model, step.b, step.where, step)

    def _follow(self, model, t: float, where: str, step):
        """The check after a mechanics solve at t; a coupled model on a new mesh takes the pressure and the step's
        displacement rate from the solve there."""
        new = self.check(t, where)
        if new is not model and new.coupling is not None:
            new.coupling.mechanics_changed(step, where)
        return new

    @property
    def mesh(self):
        return self.phys.mesh

    # -- meshes ---------------------------------------------------------------------------------------------
    def _features(self, layers: int) -> list:
        """[(element flags, target size h)]: the contact transitions at h_zone and, with 'phase_front', the
        elements the liquid fraction 1/2 crosses at h_front, each with ``layers`` rings."""
        out = [(transition_elements(self.mesh, contact_statuses(self.phys.mechanics), layers), self.h_zone)]
        if self.front:
            st = self.phys.thermal
            st.forms.store(st.solver.e)
            out.append((phase_front(st.forms.gf_liquid_fraction, layers=layers).eta > 0, self.h_front))
        return out

    def _coarseness(self) -> float:
        """The largest ratio (element size / its target h) over the elements at a transition or the front on the
        current mesh (0: none)."""
        sizes = element_sizes(self.mesh)
        return max((float(sizes[f].max()) / h for f, h in self._features(0) if f.any()), default=0.0)

    def _restrictions(self) -> list:
        xy = vertex_coords(self.mesh)
        ev = element_vertices(self.mesh)
        out = []
        for flags, h in self._features(self.layers):
            out += [(float(xy[v, 0]), float(xy[v, 1]), 0.0, h) for v in np.unique(ev[flags])]
        return out

    # -- the run --------------------------------------------------------------------------------------------
    def check(self, t: float, where: str):
        """After a mechanics solve at t on the current mesh: remesh and solve again where the module docstring
        says; returns the model."""
        self.solves += 1
        periodic = self.remesh_every > 0 and self.solves % self.remesh_every == 0
        ratio = self._coarseness()
        if ratio == 0.0:
            if not self._on_base:                      # no transition left: back to the scene's own mesh
                try:
                    self._remesh(t, where, [], "no transition")
                except _Rejected:
                    pass
        else:
            ref = BAND_FACTOR * self._band if self._band > 0 else RESOLVED
            meshings = 0
            reason = "periodic" if periodic and ratio <= ref else "transition"
            while (ratio > ref or periodic) and meshings < self.levels + 2:
                try:
                    self._remesh(t, where, self._restrictions(), reason)
                except _Rejected:
                    break
                meshings += 1
                periodic = False
                ratio = self._coarseness()
                ref = RESOLVED
                if ratio == 0.0:
                    break
            if meshings:
                self._band = ratio
        self.ndofs.append(self.phys.mechanics.forms.X.ndof)
        return self.phys

    def _remesh(self, t: float, where: str, restrictions: list, reason: str) -> None:
        """A new mesh with the local size restricted at ``restrictions`` (none: the scene's own mesh), the state
        carried over and the mechanics solved again at t."""
        tic = time.perf_counter()
        old = self.phys
        mesh = make_mesh(self.geo, self.scene.mesh, restrictions)
        new = self.build(mesh)
        heat_change, l2_change, commit = self._transfer_thermal(old, new, t)
        om, nm = old.mechanics, new.mechanics
        if old.coupling is not None and new.coupling is not None:
            new.coupling.heating.u_prev.Set(old.coupling.heating.u_prev)   # u^n of the step (the rate: after the solve)
        strain_before = _strain_norm(om)
        force_before = _normal_force(om)
        nm.forms.displacement().Set(om.forms.displacement())
        strain_after = _strain_norm(nm)
        lams = _transfer_multipliers(om, nm)
        force_after = _normal_force(nm, [n for n, _ in lams])
        warm = nm.solver.contact.warm_starts
        if warm:
            status = [law_status(spec.law, lam_n, lam_t) for spec, (lam_n, lam_t) in zip(nm.contacts, lams)]
            nm.solver.contact.warm_start(nm.forms.X.ndof, [(st > 0, st == 1, st == 2) for st in status])
        moved = ngs.GridFunction(nm.forms.displacement().space)
        moved.vec.data = nm.forms.displacement().vec
        try:
            try:
                nm.solve(t, f"{where} (on the remeshed mesh)", record=False)
            except SolverError:
                if not warm:
                    raise
                # the transferred sets did not hold the bodies (seen on plate_collision at t = 0, where the
                # interpolated statuses of a foundation left the slab free): the solve from the penalty start
                nm.solver.contact.cold_start()
                nm.solve(t, f"{where} (on the remeshed mesh, cold start)", record=False)
        except SolverError as exc:
            # the run goes on on the old mesh (its solve at t stands); the remesh is counted as rejected
            self.rejected.append({"t_s": t, "reason": str(exc)})
            log.warning("contact-zone following: remesh at t = %.6g s rejected (the contact solve on the new mesh "
                        "failed: %s); going on on the current mesh", t, exc)
            raise _Rejected from None
        if commit is not None:
            commit()
        nm.adopt(om)
        u = nm.forms.displacement()
        w = 2 * np.pi * ngs.x if nm.forms.setup.model == "axisymmetric" else 1.0

        def h1(v, g) -> float:
            return float(ngs.Integrate(w * (ngs.InnerProduct(v, v) + ngs.InnerProduct(g, g)), mesh)) ** 0.5

        diff = h1(u - moved, ngs.Grad(u) - ngs.Grad(moved))
        norm = h1(u, ngs.Grad(u))
        self.factorizations_before += old.factorizations
        self._on_base = not restrictions
        self.phys = new
        rec = ContactRemesh(t, old.mechanics.forms.X.ndof, nm.forms.X.ndof, mesh.ne, heat_change, l2_change,
                            strain_before, strain_after, force_before, force_after,
                            resolve_h1_difference_rel=diff / max(norm, 1e-300),
                            wall_s=time.perf_counter() - tic, reason=reason)
        self.remeshes.append(rec)
        log.info("contact-zone following: remesh at t = %.6g s (%s): %d -> %d dofs; transfer: strain norm %.1e, "
                 "normal force %.1e%s", t, reason, rec.ndof_before, rec.ndof_after, rec.strain_change_rel,
                 rec.normal_force_change_rel, f", heat content {heat_change:.1e}" if heat_change is not None else "")

    def _transfer_thermal(self, old, new, t: float) -> tuple:
        """The thermal state of ``old`` carried to ``new`` (:meth:`HeatRun.take_state`: interpolated;
        :meth:`StefanRun.take_state`: the enthalpy by the lumped L2 projection, its heat-content change counted in
        the Stefan energy balance once the mesh is kept); at the start time the scene's initial state is set
        instead (no transfer error need spoil the initial condition; a projected geotherm would unbalance the
        initial stress that cancels its thermal stress). Returns (relative heat-content change or None,
        relative L2 difference of T or None, a callable to run once the new mesh is kept, or None)."""
        if old.thermal is None:
            return None, None, None
        t0 = self.scene.time.start
        initial = abs(t - t0) <= 1e-12 * max(abs(t0), 1.0)
        before, after, commit = new.take_state(old, t0 if initial else None)
        T_old, T_new = old.thermal.T, new.thermal.T
        w = 2 * np.pi * ngs.x if self.scene.scene.dimension == "axisymmetric" else 1.0
        l2 = float(ngs.Integrate(w * (T_new - T_old) ** 2, new.mesh, order=2 * self.scene.mesh.order + 2)) ** 0.5
        norm = float(ngs.Integrate(w * T_old ** 2, old.mesh)) ** 0.5
        change = abs(after - before) / abs(before) if before != 0.0 else None
        return change, l2 / max(norm, 1e-300), commit

    def summary(self) -> dict:
        n = np.array(self.ndofs, dtype=float)
        recs = self.remeshes

        def largest(key):
            vals = [getattr(r, key) for r in recs if getattr(r, key) is not None]
            return max(vals, default=0.0)

        return {"mode": "contact_zone_following",
                "indicators": ["contact_zone"] + (["phase_front"] if self.front else []), "levels": self.levels,
                "layers": self.layers, "remesh_every": self.remesh_every, "h_base_m": self.h_base,
                "h_zone_m": self.h_zone, "h_front_m": self.h_front, "remesh_count": len(recs),
                "mechanics_solves": self.solves,
                "rejected_remeshes": self.rejected,
                "transfer": {"strain_norm_change_rel_max": largest("strain_change_rel"),
                             "normal_force_change_rel_max": largest("normal_force_change_rel"),
                             "heat_content_change_rel_max": largest("heat_content_change_rel"),
                             "temperature_l2_change_rel_max": largest("temperature_l2_change_rel")},
                "dofs": {"mean": float(n.mean()) if len(n) else float(self.phys.mechanics.forms.X.ndof),
                         "max": int(n.max()) if len(n) else self.phys.mechanics.forms.X.ndof,
                         "min": int(n.min()) if len(n) else self.phys.mechanics.forms.X.ndof,
                         "final": self.phys.mechanics.forms.X.ndof, "per_solve": [int(v) for v in self.ndofs]},
                "remesh_wall_s": float(sum(r.wall_s for r in recs)),
                "remeshes": [r.as_dict() for r in recs]}


def _transfer_multipliers(old, new) -> list:
    """The nodal multipliers (lam_n, lam_t) of each contact of ``old`` interpolated to the nodes of ``new``'s
    (same contacts, same order)."""
    out = []
    for so, sn, (lam_n, lam_t) in zip(old.contacts, new.contacts, old.solver.contact.multipliers):
        seg = _segments(old.forms.mesh, so.op)
        xy_o, xy_n = so.op.coords[:, :2], sn.op.coords[:, :2]
        out.append((interpolate_on_side(xy_o, lam_n, seg, xy_n), interpolate_on_side(xy_o, lam_t, seg, xy_n)))
    return out
