"""The Neumann strip of :mod:`ngs_geomech.verification.stefan` on front-following meshes against uniform meshes:
front error (melted volume), unknowns (mean and largest over the run), wall time, Newton iterations, the
heat-content change at each mesh transfer and the energy balance. The front-following run is the strip written as
a scene (:func:`neumann_strip_scene`) with ``[adaptivity] indicators = ['phase_front']`` and run by
:func:`ngs_geomech.run.run_scene`: the implementation scene runs use
(:class:`ngs_geomech.adapt.front_following.FrontFollowing`). Returns plain dicts; prints nothing.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..run import run_scene
from ..scene.parse import scene_from_dict
from . import stefan as st
from .study import one_ngsolve_thread


def exact_temperature_expression(problem: st.NeumannProblem, t: float) -> str:
    """The closed-form T(x, t) (K) at the time t (s) as a scene expression of x: T_m + max(T_liquid - T_m, 0) +
    min(T_solid - T_m, 0), which is the liquid branch behind the front and the solid branch ahead of it (both
    branches are above T_m behind the front and below it ahead)."""
    m, lam = problem.material, problem.lam
    tm = m.melting_temperature
    liquid = (f"({problem.t_hot!r} - {problem.t_hot - tm!r} * erf(x / {2 * math.sqrt(m.diffusivity_liquid * t)!r})"
              f" / {math.erf(lam)!r} - {tm!r})")
    solid = (f"({problem.t_cold!r} + {tm - problem.t_cold!r} * (1 - erf(x / "
             f"{2 * math.sqrt(m.diffusivity_solid * t)!r})) / {math.erfc(problem.nu * lam)!r} - {tm!r})")
    return f"{tm!r} + ({liquid} + abs{liquid}) / 2 + ({solid} - abs{solid}) / 2"


def strip_scene(problem: st.NeumannProblem, length: float, height: float, h0: float, name: str = "neumann_strip"
                ) -> dict:
    """The strip [0, length] x [0, height] (m; region 'pcm', hot at x = 0, 'far' at x = length) of a two-phase
    Neumann problem as a scene dict without time, initial state or output: mesh size h0 (m)."""
    m = problem.material
    return {"scene": {"name": name, "dimension": "plane"},
            "physics": {"thermal": "transient"},
            "mesh": {"maxh": h0},
            "blocks": [{"name": "pcm", "shape": "rectangle", "origin": [0.0, 0.0], "size": [length, height],
                        "boundaries": {"hot": "xmin", "far": "xmax"}}],
            "materials": {"pcm": {"conductivity": m.conductivity_solid, "rho_c": m.rho_c_solid,
                                  "phase_change_temperature": m.melting_temperature,
                                  "latent_heat_volumetric": m.latent_heat, "rho_c_liquid": m.rho_c_liquid,
                                  "conductivity_liquid": m.conductivity_liquid}},
            "boundary_conditions": {"hot": {"temperature": problem.t_hot}, "far": {"temperature": problem.t_cold}}}


def neumann_strip_scene(problem: st.NeumannProblem, length: float, height: float, h0: float, dt: float, t0: float,
                        t1: float, levels: int, layers: int, remesh_every: int) -> dict:
    """:func:`strip_scene` from the exact state at t0 to t1 with step dt (s), on front-following meshes ``levels``,
    ``layers``, ``remesh_every`` (:class:`ngs_geomech.scene.model.Adaptivity`)."""
    return {**strip_scene(problem, length, height, h0),
            "initial": {"temperature": exact_temperature_expression(problem, t0)},
            "time": {"start": t0, "end": t1, "dt": dt},
            "adaptivity": {"indicators": ["phase_front"], "levels": levels, "layers": layers,
                           "remesh_every": remesh_every},
            "output": {"every": 10 ** 6, "probes": []}}


def neumann_adaptive(problem: st.NeumannProblem, h0: float, levels: int, dt: float, t0: float, t1: float,
                     layers: int = 2, remesh_every: int = 0, height: float = 0.1) -> dict:
    """Run the strip (length of :func:`ngs_geomech.verification.stefan.neumann_strip`) from the exact state at t0
    to t1 with step dt (s) on the scene mesh of size h0 (m) refined ``levels`` times at the front
    (:func:`neumann_strip_scene`). Returns ``front_error_volume`` (m) and ``front_rel_error``, ``ndof_mean``,
    ``ndof_max``, ``h_min`` (m, the smallest edge of the last mesh), ``wall_s`` (the whole run: meshes, steps,
    remeshes), ``newton_mean``, ``remeshes``, ``transfer_error_max`` (relative change of the heat content at a
    transfer), ``energy_imbalance_rel`` (|heat gain - boundary heat - transfer changes| / boundary heat)."""
    with one_ngsolve_thread(), st.single_threaded_blas():
        data = neumann_strip_scene(problem, problem.domain_length(t1), height, h0, dt, t0, t1, levels, layers,
                                   remesh_every)
        tic = time.perf_counter()
        res = run_scene(scene_from_dict(data), None, progress=False)
        wall = time.perf_counter() - tic
    s = res.summary
    a, energy = s["adaptivity"], s["stefan"]["energy"]
    front = s["stefan"]["melted_volume"]["pcm"][-1] / height
    exact = problem.front(t1)
    supplied = energy["heat_supplied"][-1]
    moved = energy.get("heat_transferred", [0.0])[-1]
    mesh = res.stefan.forms.mesh
    pts = np.array([v.point for v in mesh.vertices])
    h_min = min(float(np.linalg.norm(pts[el.vertices[0].nr] - pts[el.vertices[1].nr])) for el in mesh.edges)
    return {"h0": h0, "levels": levels, "layers": layers, "remesh_every": remesh_every, "dt": dt,
            "front_exact": exact, "front_volume": front, "front_error_volume": abs(front - exact),
            "front_rel_error": abs(front - exact) / exact, "ndof_mean": a["dofs"]["mean"],
            "ndof_max": a["dofs"]["max"], "h_min": h_min, "wall_s": wall,
            "newton_mean": s["stefan"]["newton_iterations"]["mean"], "remeshes": a["remesh_count"],
            "repeated_steps": a["repeated_steps"], "transfer_error_max": a["transfer_error_max"],
            "energy_imbalance_rel": abs(energy["heat_gain"][-1] - supplied - moved) / abs(supplied)}


def neumann_uniform(problem: st.NeumannProblem, h: float, dt: float, t0: float, t1: float) -> dict:
    """The same strip on a uniform mesh (wall time of the steps only)."""
    r = st.neumann_strip(problem, h, dt, t0, t1, linear_reference=False)
    return {"h": h, "dt": dt, "front_rel_error": r["front_error_volume"] / r["front_exact"],
            "front_error_volume": r["front_error_volume"], "ndof": r["ndofs"],
            "wall_s": r["time_per_step"] * r["steps"], "newton_mean": r["newton_mean"]}
