"""Frictional heating of sliding contacts in a coupled run (problem (P_c)): the power tau_t . [du_t/dt] that
friction dissipates on a contact interface or foundation (``frictional_heating = true``) enters the heat or Stefan
step as a heat source on the contact's sides.

Work of friction. On the contact side S (the interface's master block side, or the boundary on a foundation) the
tangential traction is q = sum_j lam_t,j psi_j (dual multipliers psi_j, :mod:`ngs_geomech.contact.forms`) and the
weighted slip of node j is s_j = (Bt u)_j = int_S w psi_j [u] . t ds ([u] = u(x_o) - u(x), w = r in axisymmetric
scenes, 1 otherwise; in 3D two tangential rows Bt, Bt2 and two traction components). Over a time step from u^n to
u the work friction dissipates is

    W = -sum_j lam_t,j (s_j(u) - s_j(u^n)) = -int_S w q . ([u] - [u^n])_t ds >= 0      (J per m of depth in
                                                                                        plane scenes, J per
                                                                                        radian axisymmetric, J)

node by node, W_j = -lam_t,j . delta s_j, since the traction opposes the slip (lam_t,j s_j <= 0; the force on S's
body is -q). Static mechanics (problem (P)) applies the friction law to the total slip from the reference
configuration, so a node whose slip shrinks while its traction keeps its sign gives work back (W_j < 0); the
dynamic and viscous solvers apply it to the step's slip increment, where W_j >= 0 holds at every node. Negative
nodal work is never turned into negative heat: it is clipped to 0, counted, and reported as a warning naming the
contact.

Where the heat goes. The heat density is the piecewise linear q_f = sum_j d_j phi_j on S (phi_j the hat
function of S's vertex j, d_j = W_j / (dt weight_j) in W/m^2, weight_j = int_S w phi_j ds), shared by the side's
fraction f (``heat_partition``: a number, or 'effusivity': f = e_S / (e_S + e_O), e = sqrt(k rho c) of the
materials along each side, the split between two half-spaces in perfect thermal contact, Carslaw & Jaeger):

* S receives f W_j / dt at its vertex j: int_S w f q_f v ds by the trapezoidal rule (lumped; v the heat test
  functions, the vertex functions of the heat space);
* the opposite side O receives (1 - f) int_S w q_f v(x') ds, x' the point of O opposite x (the mortar projection
  :func:`~ngs_geomech.fem.mortar.boundary_transfer`), each row divided by its covered weight, so that the heat
  entering O from node j is exactly (1 - f) W_j / dt (a node with no partner on O gives its share to S);
* a rigid foundation is not modelled: S receives f (default 1) and the rest leaves the model.

The two sides' heat thus adds up to the dissipated work exactly (the constant temperature's coefficient vector
is 1 on the vertex functions).

Time stepping, like the deformation heating (:mod:`.problem`): 'staggered' hands the heat step of t_n -> t_n+1 the
work dissipated in the previous step (spread over the step: power W / dt_n+1); 'iterated' the work of the last
mechanics pass of the step (the first pass: the previous step's power). Per node, what the heat steps received is
subtracted from what the mechanics dissipated (the heat still owed, given with the next step), so that the heat
entering the bodies plus the heat owed at the end (the last step's work, staggered) equals the dissipated work to
round-off; this is the summary's energy balance of the frictional heat.

This module holds the source and its bookkeeping (no meshes, no files); :class:`~.run.CouplingRun` drives it.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from ..contact.problem import supported_nodes
from ..errors import Problem, SceneError
from ..fem.mortar import boundary_transfer
from ..heat.materials import conductivity_shape, conductivity_tensor, volumetric_heat_capacity

NEGATIVE_WORK_REL = 1e-6
"""Negative nodal work of friction (clipped) above this fraction of the dissipated work is reported as a warning;
below it, round-off of sticking nodes (lam_t != 0, slip change ~ 1e-16)."""


def contact_key(spec) -> str:
    """The scene key of a contact: ``interfaces.NAME`` or ``boundary_conditions.NAME.foundation``."""
    return f"interfaces.{spec.name}" if spec.kind == "interface" else f"boundary_conditions.{spec.name}.foundation"


def side_regions(mesh, boundary: str) -> set[str]:
    """The regions of the volume elements along ``boundary``."""
    out = set()
    for el in mesh.Boundaries(boundary).Elements():
        node = el.faces[0] if mesh.dim == 3 else el.edges[0]
        out.update(mesh[ei].mat for ei in mesh[node].elements)
    return out


def effusivity(material, dim: int) -> float:
    """sqrt(k rho c) (W s^(1/2) / (m^2 K)) of a material with a constant isotropic conductivity and heat capacity
    (a phase-change material: its solid phase); ValueError otherwise."""
    kappa = conductivity_tensor(material, dim)
    if kappa.dtype == object:
        raise ValueError("needs a constant conductivity (a number)")
    k, shape = conductivity_shape(kappa)
    if shape is not None:
        raise ValueError(f"conductivity {kappa.tolist()} is anisotropic")
    rho_c = volumetric_heat_capacity(material)
    if not isinstance(rho_c, float):
        raise ValueError("needs rho_c (or density and specific_heat) as numbers")
    return math.sqrt(k * rho_c)


def side_effusivity(scene, mesh, boundary: str, key: str) -> float:
    """The effusivity of the material along ``boundary`` (one value: the regions there must agree)."""
    values = {}
    for region in sorted(side_regions(mesh, boundary)):
        try:
            values[region] = effusivity(scene.materials[region], mesh.dim)
        except (ValueError, KeyError) as exc:
            raise SceneError([Problem(f"{key}.heat_partition", f"'effusivity' reads the material of region "
                                      f"{region!r} along {boundary!r}: {exc}; give heat_partition as a number")],
                             source=f"scene {scene.scene.name!r}") from None
    e = list(values.values())
    if not e or max(e) - min(e) > 1e-12 * max(e):
        raise SceneError([Problem(f"{key}.heat_partition", f"'effusivity' needs one material along {boundary!r}, "
                                  f"found {values}; give heat_partition as a number")],
                         source=f"scene {scene.scene.name!r}")
    return e[0]


def partition(scene, mesh, spec) -> tuple[float, str, tuple | None]:
    """(share of S, 'effusivity' or 'given', (e_S, e_O) or None) of a contact's heat_partition."""
    hp = spec.settings.heat_partition
    if hp is None:
        hp = "effusivity" if spec.kind == "interface" else 1.0
    if hp != "effusivity":
        return float(hp), "given", None
    key = contact_key(spec)
    e_s = side_effusivity(scene, mesh, spec.op.side, key)
    e_o = side_effusivity(scene, mesh, spec.op.opposite, key)
    return e_s / (e_s + e_o), "effusivity", (e_s, e_o)


def gap_reach(op) -> float:
    """The distance (m) across which the sides of ``op`` face each other: the largest initial gap of its covered
    nodes (0 when none is covered)."""
    seen = op.coverage > 0
    if not np.any(seen):
        return 0.0
    return 1.01 * float(np.max(np.abs(op.g0[seen]) / np.maximum(op.weight[seen], 1e-300)))


class FrictionalContact:
    """The frictional heating of one contact (module docstring): its share ``share`` of S, the heat dofs of S's
    vertices, the row-normalized transfer onto O's heat dofs, and per node the work of the last mechanics solve,
    the work handed to the current heat step and the work still owed (J per m of depth, per radian or J)."""

    def __init__(self, spec, share: float, rule: str, effusivities, V, ndof: int, axisymmetric: bool):
        op = spec.op
        self.spec, self.key = spec, contact_key(spec)
        self.share, self.rule, self.effusivities = share, rule, effusivities
        self.n, self.ndof = op.Bn.shape[1], ndof
        self.rows = [op.Bt] if op.Bt2 is None else [op.Bt, op.Bt2]
        self.side_dofs = np.array([V.GetDofNrs(ngs.NodeId(ngs.VERTEX, int(v)))[0] for v in op.nodes], dtype=int)
        m = op.size
        self.transfer, self.unpaired = None, np.ones(m, dtype=bool)
        if spec.kind == "interface" and share < 1.0:
            self._pair(V, axisymmetric)
        # the fraction of each node's heat entering S (the rest enters O; a foundation's rest leaves the model)
        self.to_side = np.where(self.unpaired & (spec.kind == "interface"), 1.0, share)
        self.start = [np.zeros(m) for _ in self.rows]
        self.work = np.zeros(m)              # W_j of the last mechanics solve, clipped at 0
        self.negative = (0.0, 0)             # the clipped negative work of that solve and its nodes
        self.estimate = np.zeros(m)          # the work the next heat solve adds to what is owed
        self.owed = np.zeros(m)              # dissipated, not yet handed to a heat step
        self.given = np.zeros(m)             # handed to the current heat step
        self.last_power = np.zeros(m)        # W_j / dt of the last mechanics solve (W per m of depth)

    def _pair(self, V, axisymmetric: bool) -> None:
        """The transfer onto O (rows in S's node order, divided by their covered weight) and the unpaired nodes."""
        op = self.spec.op
        mesh = V.mesh
        vertices, C, _, _ = boundary_transfer(mesh, V, op.side, op.opposite, axisymmetric=axisymmetric,
                                              order=V.globalorder, reach=gap_reach(op))
        index = {int(v): i for i, v in enumerate(vertices)}
        C = C[[index[int(v)] for v in op.nodes]]
        onv = sorted({v.nr for el in mesh.Boundaries(op.opposite).Elements() for v in el.vertices})
        vdofs = [V.GetDofNrs(ngs.NodeId(ngs.VERTEX, v))[0] for v in onv]
        covered = np.asarray(C[:, vdofs].sum(axis=1)).ravel()
        self.unpaired = covered <= 1e-12 * max(float(np.max(op.weight, initial=0.0)), 1e-300)
        scale = np.where(self.unpaired, 0.0, 1.0 / np.where(self.unpaired, 1.0, covered))
        self.transfer = C.multiply(scale[:, None]).tocsr()

    # -- life cycle -----------------------------------------------------------------------------------------
    def start_step(self, u: np.ndarray, dt: float, predict: bool) -> None:
        """Remember the slips of u^n; the first heat solve of the step gets what is owed plus (``predict``) the
        previous step's power over ``dt``."""
        self.start = [B @ u[:self.n] for B in self.rows]
        self.estimate = self.last_power * dt if predict else np.zeros_like(self.owed)
        self.given = np.zeros_like(self.owed)

    def set_work(self, u: np.ndarray, lam_t: np.ndarray, dt: float) -> None:
        """The work W_j of the step from u^n to ``u`` under the tangential multipliers ``lam_t`` (Pa; (m,) in 2D,
        (m, 2) in 3D; an all-zero (m,) array in 3D means no contact was solved), clipped at 0."""
        m, k = len(self.owed), len(self.rows)
        lam = np.asarray(lam_t, dtype=float)
        lam = lam.reshape(m, k) if lam.size == m * k else np.zeros((m, k))
        raw = -sum(lam[:, c] * (B @ u[:self.n] - s0) for c, (B, s0) in enumerate(zip(self.rows, self.start)))
        self.work = np.maximum(raw, 0.0)
        neg = np.minimum(raw, 0.0)
        self.negative = (float(-neg.sum()), int(np.count_nonzero(neg)))
        self.estimate = self.work
        self.last_power = self.work / dt

    def load(self, dt: float) -> np.ndarray:
        """The nodal heat load (W per m of depth, per radian, or W; a vector over the thermal space) of what is owed
        plus the estimate; remembers that work as given to this step."""
        self.given = np.maximum(self.owed + self.estimate, 0.0)
        p = self.given / dt
        out = np.zeros(self.ndof)
        np.add.at(out, self.side_dofs, self.to_side * p)
        if self.transfer is not None:
            out[:self.transfer.shape[1]] += self.transfer.T @ ((1.0 - self.to_side) * p)
        return out

    def finish_step(self) -> dict:
        """Close the step: what the heat received is no longer owed. Returns the step's figures (J per m of depth,
        per radian, or J)."""
        side = float(self.to_side @ self.given)
        rest = float((1.0 - self.to_side) @ self.given)
        opp, lost = (rest, 0.0) if self.transfer is not None else (0.0, rest)
        rec = {"dissipated": float(self.work.sum()), "entered": side + opp, "entered_side": side,
               "entered_opposite": opp, "to_foundation": lost, "negative_work": self.negative[0],
               "negative_nodes": self.negative[1]}
        self.owed = self.owed + self.work - self.given
        return rec


class FrictionalHeating:
    """The frictional heating of a coupled run's contacts with ``frictional_heating = true`` (module docstring), with
    the life cycle of :class:`~.problem.DeformationHeating`: :meth:`start_step` at the start of a step, :meth:`load`
    for each heat solve, :meth:`set_rate` after each mechanics solve, :meth:`finish_step` at the end of the step.
    ``warnings`` (a list) receives the reports of clipped negative work, once per contact."""

    def __init__(self, mechanics, items: list[FrictionalContact], warnings: list):
        self.mech = mechanics
        self.items = items
        self.warnings = warnings
        self.dt = 1.0
        self.predict = False
        n = mechanics.forms.V.ndof
        self.free = np.array(list(mechanics.forms.X.FreeDofs()), dtype=bool)[:n]
        self.warned: set[str] = set()
        self.power_given = 0.0

    @classmethod
    def of(cls, scene, thermal, mechanics, warnings: list) -> FrictionalHeating | None:
        """The frictional heating of a scene's contacts (None when no contact has frictional_heating); SceneError
        naming the key when an effusivity partition cannot read its materials."""
        specs = [s for s in mechanics.contacts if s.settings.frictional_heating]
        if not specs:
            return None
        V = thermal.forms.V
        ndof = thermal.heating_target()[0].ndof
        axi = scene.scene.dimension == "axisymmetric"
        items = [FrictionalContact(s, *partition(scene, mechanics.mesh, s), V, ndof, axi) for s in specs]
        return cls(mechanics, items, warnings)

    def _state(self) -> tuple[np.ndarray, list]:
        """The displacement vector and the multipliers (lam_n, lam_t) of the heated contacts (undetermined ones
        cleaned: :func:`~ngs_geomech.contact.problem.supported_nodes`)."""
        u = np.asarray(self.mech.forms.gf.vec.FV().NumPy())
        lams = dict(zip((s.name for s in self.mech.contacts), self.mech.contact_multipliers()))
        out = []
        for it in self.items:
            lam_n, lam_t = (np.asarray(x, dtype=float) for x in lams[it.spec.name])
            out.append(supported_nodes(it.spec, self.free, u, lam_n, lam_t)[1])
        return u, out

    def start_step(self, dt: float, predict: bool) -> None:
        """A step of length dt (s) begins at the current displacement u^n; ``predict``: the first heat solve adds
        the previous step's power ('iterated'), else only what is owed ('staggered')."""
        self.dt, self.predict = dt, predict
        u = np.asarray(self.mech.forms.gf.vec.FV().NumPy())
        for it in self.items:
            it.start_step(u, dt, predict)

    def set_rate(self, dt: float) -> None:
        """The work of the step from the current mechanics solution (after each mechanics solve)."""
        u, lams = self._state()
        for it, lam_t in zip(self.items, lams):
            it.set_work(u, lam_t, dt)

    def load(self) -> np.ndarray:
        """The nodal heat load over the thermal space (W per m of depth, per radian, or W) of the next heat solve."""
        out = sum(it.load(self.dt) for it in self.items)
        self.power_given = float(sum(it.given.sum() for it in self.items)) / self.dt
        return out

    def power(self) -> float:
        """The frictional heating power of the last :meth:`load` (W per m of depth, per radian, or W)."""
        return self.power_given

    def finish_step(self) -> dict:
        """Close the step (the heat given is no longer owed); returns per contact the step's figures."""
        rec = {}
        for it in self.items:
            rec[it.spec.name] = r = it.finish_step()
            if r["negative_work"] > NEGATIVE_WORK_REL * max(r["dissipated"], 1e-300) and it.key not in self.warned:
                self.warned.add(it.key)
                self.warnings.append(
                    f"{it.key}: friction did negative work at {r['negative_nodes']} nodes ({r['negative_work']:.3g} "
                    f"against {r['dissipated']:.3g} dissipated in the step), clipped to no heat: the slip shrank "
                    "while the traction kept its direction, which the static law (P) on the total slip allows; "
                    "dynamic or viscous mechanics apply friction to the slip increment")
        return rec

    # -- checkpoints ----------------------------------------------------------------------------------------
    def capture(self) -> dict:
        return {f"coupling/friction/{it.spec.name}/{k}": np.array(getattr(it, k))
                for it in self.items for k in ("owed", "last_power")}

    def restore(self, arrays: dict) -> None:
        for it in self.items:
            for k in ("owed", "last_power"):
                setattr(it, k, np.array(arrays[f"coupling/friction/{it.spec.name}/{k}"]))

    # -- reporting ------------------------------------------------------------------------------------------
    def report(self, history: list[dict], units: str) -> dict:
        """The summary's ``frictional_heating`` block from the per-step records ``history`` (:meth:`finish_step`):
        per contact the totals, the partition and the heat still owed; the energy balance of the frictional heat
        (dissipated = entered + owed + given to foundations)."""
        contacts = {}
        for it in self.items:
            rows = [h[it.spec.name] for h in history if it.spec.name in h]
            tot = {k: float(sum(r[k] for r in rows)) for k in ("dissipated", "entered", "entered_side",
                                                                "entered_opposite", "to_foundation", "negative_work")}
            contacts[it.spec.name] = {
                "kind": it.spec.kind, "law": it.spec.law.kind, "side": it.spec.op.side,
                "opposite": it.spec.op.opposite, "partition": it.rule, "share_side": it.share,
                "effusivity_side_opposite": list(it.effusivities) if it.effusivities else None,
                **tot, "owed": float(it.owed.sum()),
                "negative_work_steps": int(sum(r["negative_nodes"] > 0 for r in rows))}
        d = sum(c["dissipated"] for c in contacts.values())
        e = sum(c["entered"] for c in contacts.values())
        f = sum(c["to_foundation"] for c in contacts.values())
        o = sum(c["owed"] for c in contacts.values())
        return {"source": "tau_t . [du_t/dt] on the contact side, shared between the sides (docs/methods.md, "
                          "'Frictional heating')",
                "units": {"heat": units},
                "contacts": contacts,
                "heat_per_step": [float(sum(r["entered"] for r in h.values())) for h in history],
                "energy": {"dissipated": d, "entered": e, "to_foundations": f, "owed": o,
                           "imbalance_rel": abs(d - e - f - o) / max(abs(d), 1e-300)}}


class ThermalSources:
    """The deformation heating and the frictional heating as one source of a heat or Stefan step: the assembled
    vector (:meth:`vector`, heat) or the nodal load (:meth:`load`, Stefan) of both."""

    def __init__(self, deformation, friction: FrictionalHeating):
        self.deformation, self.friction = deformation, friction

    def vector(self):
        """The deformation heating's assembled vector plus the frictional loads (NGSolve vector, W)."""
        vec = self.deformation.vector()
        out = vec.CreateVector()
        out.data = vec
        out.FV().NumPy()[:] += self.friction.load()
        return out

    def load(self) -> np.ndarray:
        """The nodal loads of both (numpy, W)."""
        return self.deformation.load() + self.friction.load()
