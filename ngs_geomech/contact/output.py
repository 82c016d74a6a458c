"""The contact part of a mechanical run's output: nodal interface quantities at each mechanics time, the
contact resultants and the global force balance for ``summary.json``.

Force balance (per translation direction e: x and y in plane scenes, only z = y in axisymmetric ones, x, y
and z in 3D):
the applied loads L = e . f (body forces, tractions, pressures; thermal and initial stresses have no
resultant), the support reactions S = e . (K u - f - B^T lam) on the fixed dofs, and the foundation
forces F = e . B^T lam of the foundations sum to zero: imbalance = |L + S + F| / (the largest of |L|, |S|,
|F| and the contact resultants).
Interfaces between bodies are internal: the forces on their two sides must be opposite (reported as
``action_reaction``: |F_side + F_opposite| / |F_side|).

``closed_length_m``: the length of the closed part of the side, sum of int phi_j ds over the nodes in contact
(stick or slip): for a contact zone ending between two nodes, the midpoint between the last closed and the first
open node (error at most half the element size there; in 3D the area, m^2).

``initial_gap_m``: [min, max] of the nodal initial gaps g0 over the nodes whose rays meet the other side
within ``search_distance_m`` (None if none does: the contact cannot close).

Tangential force: in 2D int q ds along t (signed); in 3D the tangential part of the contact force on S's
body as a vector (``tangential_resultant_on_side``, x, y, z) and its magnitude (``tangential_force``).
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np

from ..io import scales
from ..scene.names import plain_file_name
from .problem import ContactSpec, contact_forces, interface_results, side_dofs, supported_nodes

_STATUS = ("open", "stick", "slip", "prescribed")


class ContactOutput:
    """Records the contact state of each mechanics solve (see the module docstring)."""

    def __init__(self, forms, specs: list[ContactSpec], dofs=None):
        """``dofs``: on a distributed mesh the :class:`~ngs_geomech.parallel.GlobalDofs` of the contact solve (its
        arrays are global; every rank records the same)."""
        self.forms = forms
        self.specs = specs
        V = forms.V
        axi = forms.setup.model == "axisymmetric"
        dim = forms.mesh.dim
        self.directions = ["y"] if axi else ["x", "y", "z"][:dim]
        self.units = "N/rad" if axi else ("N" if dim == 3 else "N/m")
        g = ngs.GridFunction(V)
        rows = []
        for d in self.directions:
            comps = [0.0] * dim
            comps["xyz".index(d)] = 1.0
            g.Set(ngs.CoefficientFunction(tuple(comps)))
            rows.append(np.array(g.vec.FV().NumPy()))
        mesh = forms.mesh

        def on(side):
            local = side_dofs(mesh, V, side)
            if dofs is None:
                return local
            mask = np.zeros(V.ndof)
            mask[local] = 1.0
            return np.flatnonzero(dofs.gather(mask, cumulated=False) > 0.5)     # (any rank's elements)

        self.translations = np.array(rows if dofs is None else [dofs.gather(r) for r in rows])
        self.side = [on(s.op.side) for s in specs]
        self.opposite = [on(s.op.opposite) if s.op.opposite else None for s in specs]
        self.latest: list[dict] = []
        self.history: list[dict] = []

    def record(self, t: float, solver) -> None:
        """After a solve of :class:`ElasticContactSolver`: the interface arrays and the balance at time t."""
        u = solver.displacement()                      # (global arrays on a distributed mesh)
        n = self.translations.shape[1]                 # the displacement dofs (X may add mixed pressures)
        rhs = solver.load()
        force = solver.stiffness_times_displacement() - rhs       # K u - f - B^T lam: the support reactions
        self.latest = []
        entry = {"time_s": t, "interfaces": {}}
        foundation = np.zeros(len(self.directions))
        free = solver.free
        for k, (spec, (lam_n, lam_t)) in enumerate(zip(self.specs, solver.contact.multipliers)):
            lam_n, lam_t, prescribed = supported_nodes(spec, free[:n], u, lam_n, lam_t)
            res = interface_results(spec, u, lam_n, lam_t, prescribed)
            self.latest.append(res)
            op = spec.op
            bt = contact_forces(op, lam_n, lam_t)
            force[:n] -= bt
            on_side = self._resultant(bt, self.side[k])
            status = res["status"].astype(int)
            keep = op.coverage > 1 - 1e-6
            if lam_t.ndim == 2:      # 3D: the tangential force as a vector on S's body and its magnitude
                tang = self._resultant(contact_forces(op, lam_n, lam_t, normal=False), self.side[k])
                tangential = {"tangential_force": float(np.linalg.norm(tang)),
                              "tangential_resultant_on_side": dict(zip(self.directions, tang.tolist()))}
            else:
                tangential = {"tangential_force": float(np.dot(op.weight, lam_t))}
            item = {"kind": spec.kind, "law": spec.law.kind, "normal_force": float(np.dot(op.weight, lam_n)),
                    **tangential,
                    "resultant_on_side": dict(zip(self.directions, on_side.tolist())),
                    "max_pressure_Pa": float(np.max(lam_n, initial=0.0)),
                    "closed_length_m": float(np.sum(op.length[lam_n > 0])),
                    "max_penetration_m": float(np.max(-res["gap"][keep], initial=0.0)),
                    "max_slip_m": float(np.max(np.abs(res["slip"][lam_n > 0]), initial=0.0)),
                    "max_tangential_displacement_m": float(np.max(np.abs(res["slip"][keep]), initial=0.0)),
                    "initial_gap_m": _range(op.g0[keep] / op.weight[keep]) if np.any(keep) else None,
                    "search_distance_m": op.search_distance,
                    "nodes": {s: int(np.sum(status == i)) for i, s in enumerate(_STATUS)}}
            if spec.kind == "foundation":
                foundation += on_side
            else:
                on_opp = self._resultant(bt, self.opposite[k])
                item["resultant_on_opposite"] = dict(zip(self.directions, on_opp.tolist()))
                item["action_reaction"] = float(np.linalg.norm(on_side + on_opp)
                                                / max(float(np.linalg.norm(on_side)), 1e-300))
            entry["interfaces"][spec.name] = item
        reaction = np.where(free, 0.0, force)
        load = self.translations @ rhs[:n]
        supports = self.translations @ reaction[:n]
        # relative to the largest force involved (a body squeezed between two foundations has no net load)
        side_forces = [abs(v) for item in entry["interfaces"].values() for v in item["resultant_on_side"].values()]
        scale = max(float(np.max(np.abs(np.concatenate([load, supports, foundation])), initial=0.0)),
                    max(side_forces, default=0.0), 1e-300)
        entry["force_balance"] = {"directions": self.directions, "load": load.tolist(),
                                  "support_reactions": supports.tolist(), "foundations": foundation.tolist(),
                                  "imbalance_rel": float(np.max(np.abs(load + supports + foundation)) / scale),
                                  "units": self.units}
        infos = solver.contact_infos[-1] if solver.contact_infos else []
        entry["contact_iterations"] = [i.iterations for i in infos]
        entry["linear"] = getattr(solver.contact, "linear", "direct")
        entry["gmres_max"] = max((g for i in infos for g in getattr(i, "gmres_iterations", [])), default=0)
        entry["condensed_dofs"] = max((getattr(i, "condensed_dofs", 0) for i in infos), default=0)
        entry["condensed_fallbacks"] = sum(bool(getattr(i, "condensed_fallback", False)) for i in infos)
        entry["wall_s"] = sum(i.wall_s for i in infos)
        comm = [i.communication for i in infos if getattr(i, "communication", None)]
        entry["communication"] = {k: sum(c.get(k, 0) for c in comm) for k in sorted({k for c in comm for k in c})}
        self.history.append(entry)

    def _resultant(self, bt: np.ndarray, dofs: np.ndarray) -> np.ndarray:
        return np.array([float(t[dofs] @ bt[dofs]) for t in self.translations])

    def summary(self) -> dict:
        """The last solve's interface figures (with the largest slip over all solves added: closed nodes, and
        all covered nodes including open ones, m), the force balance, and per solve a short history."""
        last = self.history[-1] if self.history else {}
        interfaces = {}
        for name, item in last.get("interfaces", {}).items():
            over = [h["interfaces"][name] for h in self.history if name in h["interfaces"]]
            interfaces[name] = {**item,
                                "max_slip_over_time_m": max(v["max_slip_m"] for v in over),
                                "max_tangential_displacement_over_time_m":
                                    max(v["max_tangential_displacement_m"] for v in over)}
        return {"contact": {"interfaces": interfaces, "force_balance": last.get("force_balance", {}),
                            "iterations_per_solve": [sum(h["contact_iterations"]) for h in self.history],
                            "wall_s_per_solve": [h["wall_s"] for h in self.history],
                            "communication_per_solve": ([h["communication"] for h in self.history]
                                                        if any(h["communication"] for h in self.history) else None),
                            "linear_solver": last.get("linear", "direct"),
                            "gmres_max_per_solve": ([h["gmres_max"] for h in self.history]
                                                    if last.get("linear") == "iterative" else None),
                            "condensed_dofs_per_solve": ([h["condensed_dofs"] for h in self.history]
                                                         if last.get("linear") == "condensed" else None),
                            "condensed_fallbacks": (sum(h["condensed_fallbacks"] for h in self.history)
                                                    if last.get("linear") == "condensed" else None),
                            "history": [{"time_s": h["time_s"], "imbalance_rel": h["force_balance"]["imbalance_rel"],
                                         **{name: {"normal_force": v["normal_force"],
                                                   "tangential_force": v["tangential_force"],
                                                   "max_slip_m": v["max_slip_m"],
                                                   "closed_length_m": v["closed_length_m"],
                                                   "max_pressure_Pa": v["max_pressure_Pa"],
                                                   "max_tangential_displacement_m":
                                                       v["max_tangential_displacement_m"],
                                                   "nodes": v["nodes"]}
                                            for name, v in h["interfaces"].items()}} for h in self.history]}}


def _range(v: np.ndarray) -> list[float]:
    return [float(np.min(v)), float(np.max(v))]


SERIES_FIELDS = ("pressure", "traction", "traction_t1", "traction_t2", "gap", "slip", "status", "bound")
"""The nodal interface quantities written to each contact's line (2D) or surface (3D) series."""


def contact_lines(specs: list[ContactSpec], latest: list[dict]) -> dict:
    """Per contact ``contact_<name>``: (points, cells, nodal data) of the last recorded state ``latest``
    (:meth:`ContactOutput.record`'s results, one dict per contact)."""
    return {f"contact_{spec.name}": (np.column_stack([res[c] for c in "xyz" if c in res]), spec.cells,
                                     {k: res[k] for k in SERIES_FIELDS if k in res})
            for spec, res in zip(specs, latest)}


def contact_figures(canvas, specs: list[ContactSpec], latest: list[dict]) -> None:
    """Pressure, traction (with the slip bound), gap and slip along each contact at the last mechanics time on
    ``canvas`` (:class:`~ngs_geomech.io.canvas.Canvas`; 2D scenes, 3D contacts are in the surface series only):
    tractions in MPa or GPa, gap and slip in mm or m, the arc length in m or km, as their magnitudes fit."""
    for spec, res in zip(specs, latest):
        o = res["order"]
        xy = np.column_stack([res["x"], res["y"]])[o]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
        forces = {"pressure p": res["pressure"][o], "traction q": res["traction"][o]}
        if spec.law.kind != "frictionless":
            forces["slip bound"] = res["bound"][o]
        motion = {"gap": res["gap"][o], "slip": res["slip"][o]}
        fu = scales.stress_scale(np.concatenate(list(forces.values())))
        mu = scales.displacement_scale(np.concatenate(list(motion.values())))
        canvas.draw.interface_profiles(
            s, [{k: fu(v) for k, v in forces.items()}, {k: mu(v) for k, v in motion.items()}],
            canvas.path(f"contact_{plain_file_name(spec.name)}.png"),
            ylabels=[f"traction ({fu.unit})", f"gap, slip ({mu.unit})"],
            title=f"{canvas.title}: contact {spec.name} ({spec.law.kind}), {canvas.when}",
            xlabel=f"arc length along {spec.op.side} (m)", start=(xy[0, 0], xy[0, 1]),
            status=res["status"][o].astype(int))
