"""A thermo-elastic box for solver comparisons and scaling: heat conduction, then the thermal stress,
built from a scene dict through the package's path (:func:`scene_from_dict` -> :func:`validate` ->
:func:`make_mesh` -> :func:`heat_setup` / :class:`HeatForms` / :class:`HeatSolver` -> :func:`elastic_setup` /
:class:`ElasticForms` / :class:`ElasticSolver`), with the linear solver chosen by name.

The box (3D) is 2 x 1 x 1 m (2D: the 2 x 1 m rectangle, plane strain) of granite-like rock: conductivity
3 W/(m K), rho c 2.2e6 J/(m^3 K), E 60 GPa, nu 0.25, alpha 8e-6 1/K, stress free at 0 K. Heat: T = 100 K on
x = 0, T = 0 on x = 2, a source Q = 1e3 W/m^3 in the whole box, other sides insulated; steady, or transient from
T = 0 with backward Euler steps of 1e5 s. Mechanics: the base (z = 0, in 2D y = 0) fixed, the other sides free,
loaded by the thermal stress -beta (T - T0) alone.

Nothing here prints or writes files; :func:`thermoelastic_box` returns a plain dict.
"""

from __future__ import annotations

import time

import ngsolve as ngs
import numpy as np

from ..geometry.mesh import make_mesh
from ..heat.forms import HeatForms
from ..heat.problem import heat_setup
from ..heat.solver import HeatSolver
from ..mechanics.forms import ElasticForms
from ..mechanics.problem import elastic_setup
from ..mechanics.solver import ElasticSolver
from ..scene.parse import scene_from_dict
from ..validation.validate import validate

ROCK = {"conductivity": 3.0, "rho_c": 2.2e6, "youngs_modulus": 60e9, "poisson_ratio": 0.25,
        "thermal_expansion": 8e-6, "stress_free_temperature": 0.0}
"""The box's material (SI units)."""
TRANSIENT_DT = 1e5
"""Time step of the transient runs, s."""


def box_scene(maxh: float, order: int, dim: int = 3, steps: int = 0) -> dict:
    """The scene dict of the box (module docstring) with mesh size ``maxh`` (m), elements of ``order``, in
    ``dim`` = 2 or 3 dimensions; ``steps`` > 0: transient heat with that many steps of :data:`TRANSIENT_DT`."""
    if dim == 3:
        block = {"name": "rock", "shape": "box", "origin": [0, 0, 0], "size": [2, 1, 1],
                 "boundaries": {"hot": "xmin", "cold": "xmax", "base": "zmin"}}
        fixed = [0.0, 0.0, 0.0]
    else:
        block = {"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [2, 1],
                 "boundaries": {"hot": "xmin", "cold": "xmax", "base": "ymin"}}
        fixed = [0.0, 0.0]
    data = {"scene": {"name": "scaling_box", "dimension": "3d" if dim == 3 else "plane", "temperature_unit": "K"},
            "physics": {"thermal": "transient" if steps else "steady", "mechanics": "static"},
            "mesh": {"maxh": maxh, "order": order}, "blocks": [block], "materials": {"rock": dict(ROCK)},
            "boundary_conditions": {"hot": {"temperature": 100.0}, "cold": {"temperature": 0.0},
                                    "base": {"displacement": fixed}},
            "sources": [{"region": "rock", "density": 1e3}],
            "output": {"vtk": False, "figures": False}}
    if dim == 2:
        data["physics"]["plane_model"] = "plane_strain"
    if steps:
        data["time"] = {"end": steps * TRANSIENT_DT, "dt": TRANSIENT_DT}
    return data


def thermoelastic_box(maxh: float, order: int, solver: str = "auto", *, dim: int = 3, steps: int = 0,
                      tol: float = 1e-10, mesh=None, keep: bool = False, preconditioner: str = "auto") -> dict:
    """Solve the box's heat problem, then its thermal stress, with ``solver`` ("auto", "direct", "iterative")
    and CG tolerance ``tol`` for both, CG preconditioned by ``preconditioner`` ("auto", "bddc"). ``mesh``: reuse a
    mesh made before (same maxh, order, dim).

    Returns ``dofs_heat``, ``dofs_elastic``, ``dofs`` (their sum), ``solver_heat``, ``solver_elastic`` (what
    "auto" chose), ``mesh_s``, ``heat_s``, ``elastic_s`` (wall times, s: set-up, assembly and solves),
    ``cg_heat`` (CG iterations per heat solve), ``cg_elastic``, ``T`` and ``u`` (the solution vectors as numpy
    arrays), ``T_max`` (K), ``u_max`` (largest displacement component, m); with ``keep`` also ``mesh``,
    ``heat`` (HeatForms) and ``elastic`` (ElasticForms)."""
    data = box_scene(maxh, order, dim, steps)
    scene = scene_from_dict(data, source="scaling_box")
    geo = validate(scene)
    tic = time.perf_counter()
    if mesh is None:
        mesh = make_mesh(geo, scene.mesh)
    mesh_s = time.perf_counter() - tic
    tic = time.perf_counter()
    heat = HeatForms(mesh, heat_setup(scene, geo, mesh))
    hs = HeatSolver(heat, solver=solver, tol=tol, preconditioner=preconditioner)
    if steps:
        heat.temperature().vec[:] = 0.0
        t = 0.0
        for _ in range(steps):
            heat.gf_old.vec.data = heat.gf.vec
            heat.t_old.Set(t)
            heat.t_new.Set(t + TRANSIENT_DT)
            heat.inv_dt.Set(1.0 / TRANSIENT_DT)
            t += TRANSIENT_DT
            hs.solve(f"box step to t = {t:g} s")
    else:
        heat.t_new.Set(0.0)
        hs.solve("steady box")
    heat_s = time.perf_counter() - tic
    tic = time.perf_counter()
    forms = ElasticForms(mesh, elastic_setup(scene, geo, mesh, heat.temperature()))
    es = ElasticSolver(forms, solver=solver, linear_tol=tol, preconditioner=preconditioner)
    es.solve("thermal stress of the box")
    elastic_s = time.perf_counter() - tic
    T = heat.gf.vec.FV().NumPy().copy()
    u = forms.gf.vec.FV().NumPy().copy()
    out = {"maxh": maxh, "order": order, "dim": dim, "steps": steps, "dofs_heat": int(heat.X.ndof),
           "dofs_elastic": int(forms.X.ndof), "dofs": int(heat.X.ndof + forms.X.ndof),
           "solver_heat": hs.solver, "solver_elastic": es.solver, "mesh_s": mesh_s, "heat_s": heat_s,
           "elastic_s": elastic_s, "cg_heat": list(hs.cg_iterations), "cg_elastic": list(es.cg_iterations),
           "T": T, "u": u, "T_max": float(np.max(T)) if T.size else 0.0,
           "u_max": float(np.max(np.abs(u))) if u.size else 0.0}
    if keep:
        out.update(mesh=mesh, heat=heat, elastic=forms)
    return out


def max_rel_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Max |a - b| / max |b| (0 when b vanishes and a equals it)."""
    scale = float(np.max(np.abs(b))) if b.size else 0.0
    diff = float(np.max(np.abs(a - b))) if a.size else 0.0
    return diff / scale if scale > 0 else diff


def make_box_mesh(maxh: float, order: int, dim: int = 3):
    """The box's mesh alone (for reuse across solvers)."""
    scene = scene_from_dict(box_scene(maxh, order, dim), source="scaling_box")
    return make_mesh(validate(scene), scene.mesh)


__all__ = ["ROCK", "TRANSIENT_DT", "box_scene", "thermoelastic_box", "max_rel_difference", "make_box_mesh", "ngs"]
