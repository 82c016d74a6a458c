"""Problem (P_c) through scenes (:mod:`ngs_geomech.coupling.problem`): the deformation heating against a closed
form, and the coupled contact-Stefan case of problem (P_c).

:func:`adiabatic_compression` : a square block 1 m x 1 m (plane strain) squeezed at a constant strain rate r in
both directions (rollers on the left and bottom sides, u_x = -r t x on the right side, u_y = -r t y on the top)
with all sides insulated. The strain is uniform, e_xx = e_yy = -r t, so are the temperature and the thermal
stress, and the prescribed normal displacements hold the block whatever the stress: the heat equation reduces
to d e / dt = -Theta_0 beta (e_xx + e_yy)_t = 2 Theta_0 beta r (beta = E alpha / (1 - 2 nu), plane strain), so
the enthalpy grows linearly, e(t) = e(0) + 2 Theta_0 beta r t (J/m^3), through the latent heat of a phase change
as well. 'iterated' coupling reproduces it to round-off; 'staggered' lags the rate by one step (the first step
gets none): the error is one step's heating, 2 Theta_0 beta r dt, first order in dt.

:func:`contact_melting_scene` : two blocks in frictional (Coulomb) contact, the lower one of a phase-change
material (a rock-salt-like PCM, illustrative data) partly melting under a heat source, the upper one of rock,
squeezed by a prescribed plate motion u0(t) on its top: the deformation heating adds heat where the blocks are
compressed. Run with coupling 'none', 'staggered' and 'iterated' to measure the effect of the term
(:func:`contact_melting`).

Nothing here prints or writes files; the functions return plain dicts.
"""

from __future__ import annotations

import time

import numpy as np

from ..run import run_scene
from ..scene.parse import scene_from_dict

E, NU, ALPHA = 50e9, 0.25, 1e-5
BETA = E * ALPHA / (1 - 2 * NU)                     # Pa/K, the plane-strain thermal stress coefficient
RHO_C = 2e6                                         # J/(m^3 K)


def adiabatic_compression_scene(*, coupling: str, dt: float, end: float = 60.0, rate: float = 1e-4,
                                phase_change: bool = False, T0: float = 20.0, maxh: float = 0.5) -> dict:
    """The scene dict of :func:`adiabatic_compression` (degC; stress-free and initial temperature T0)."""
    mat = {"conductivity": 3.0, "rho_c": RHO_C, "youngs_modulus": E, "poisson_ratio": NU,
           "thermal_expansion": ALPHA, "stress_free_temperature": T0}
    if phase_change:
        mat.update(phase_change_temperature=T0 + 1.0, latent_heat_volumetric=4e6, rho_c_liquid=2.5e6,
                   conductivity_liquid=2.0)
    return {
        "scene": {"name": "adiabatic_compression", "temperature_unit": "C"},
        "physics": {"thermal": "transient", "mechanics": "static", "coupling": coupling,
                    "coupling_tolerance": 1e-10},
        "mesh": {"maxh": maxh},
        "time": {"end": end, "dt": dt},
        "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 0], "size": [1.0, 1.0],
                    "boundaries": {"left": "xmin", "right": "xmax", "bottom": "ymin", "top": "ymax"}}],
        "materials": {"block": mat},
        "initial": {"temperature": T0},
        "mechanics": {"tolerance": 1e-12},
        "boundary_conditions": {"left": {"symmetry": True}, "bottom": {"symmetry": True},
                                "right": {"displacement": [f"-{rate!r}*t*x", "free"]},
                                "top": {"displacement": ["free", f"-{rate!r}*t*y"]}},
        "output": {"vtk": False, "figures": False},
    }


def adiabatic_compression(*, coupling: str, dt: float, end: float = 60.0, rate: float = 1e-4,
                          phase_change: bool = False, T0: float = 20.0) -> dict:
    """Run :func:`adiabatic_compression_scene`; compare the heat content per volume with the closed form.

    Returns the enthalpy gain (J/m^3: mean over the block, and its spread between nodes), the closed form
    2 Theta_0 beta r t, their relative difference, the final temperature, the coupling passes and the deformation
    heat the run reports."""
    scene = scene_from_dict(adiabatic_compression_scene(coupling=coupling, dt=dt, end=end, rate=rate,
                                                        phase_change=phase_change, T0=T0))
    tic = time.perf_counter()
    res = run_scene(scene, None, progress=False)
    wall = time.perf_counter() - tic
    theta0 = T0 + 273.15
    exact = 2 * theta0 * BETA * rate * end
    if res.stefan is not None:
        f = res.stefan.forms
        e = res.stefan.solver.e
        e0 = f.enthalpy_of(np.full(f.n, T0))
        gain = e - e0
        T = f.nodal_state(e).T
        melted = f.melted_volume(e)
    else:
        T = res.forms.temperature().vec.FV().NumPy().copy()
        gain = RHO_C * (T - T0)
        melted = 0.0
    c = res.summary["coupling"]
    return {"coupling": coupling, "dt": dt, "steps": res.summary["steps"], "gain_mean": float(np.mean(gain)),
            "gain_spread": float(np.ptp(gain)), "exact": exact,
            "rel_error": abs(float(np.mean(gain)) - exact) / exact, "T_end": float(np.mean(T)),
            "melted_fraction": melted, "passes_mean": c["passes_per_step"]["mean"],
            "passes_max": c["passes_per_step"]["max"], "deformation_heat_reported": c["deformation_heat_total"],
            "wall_s": wall}


def contact_melting_scene(*, coupling: str, end: str = "2 year", dt: str = "5 day", maxh: float = 0.125,
                          squeeze: float = 1e-2, law: str = "coulomb", power: float = 50.0) -> dict:
    """The scene dict of the coupled contact-Stefan case (module docstring): a PCM block [0, 2] x [0, 1] m under a
    rock block [0, 2] x [1, 1.8] m, Coulomb contact (F_c = 0.6) between them, a heat source in the lower block's
    core (``power`` W per m of depth over its 0.12 m^2: 417 W/m^3 at the default 50), the top of the rock pushed
    down and sideways by ``squeeze`` m over the run (u0(t) linear in t)."""
    law_keys = {"law": law}
    if law == "coulomb":
        law_keys["friction"] = 0.6
    return {
        "scene": {"name": "contact_melting", "temperature_unit": "C",
                  "description": "Two blocks in frictional contact, the lower one partly melting under a heat "
                                 "source, squeezed by a plate motion: problem (P_c)"},
        "physics": {"thermal": "transient", "mechanics": "static", "coupling": coupling},
        "mesh": {"maxh": maxh},
        "time": {"end": end, "dt": dt},
        "blocks": [{"name": "salt", "shape": "rectangle", "origin": [0, 0], "size": [2.0, 1.0],
                    "boundaries": {"salt_base": "ymin", "salt_left": "xmin", "salt_right": "xmax"}},
                   {"name": "core", "shape": "rectangle", "origin": [0.8, 0.3], "size": [0.4, 0.3]},
                   {"name": "rock", "shape": "rectangle", "origin": [0, 1.0], "size": [2.0, 0.8],
                    "boundaries": {"rock_top": "ymax", "rock_left": "xmin"}}],
        "interfaces": [{"name": "core_wall", "blocks": ["salt", "core"], "type": "glued"},
                       {"name": "bedding", "blocks": ["salt", "rock"], "type": "contact", **law_keys}],
        "materials": {
            "salt": {"phase_change_temperature": 30.0, "latent_heat_volumetric": 1.5e8, "rho_c": 1.9e6,
                     "rho_c_liquid": 2.4e6, "conductivity": 4.0, "conductivity_liquid": 1.5,
                     "youngs_modulus": 25e9, "poisson_ratio": 0.3, "thermal_expansion": 4e-5,
                     "stress_free_temperature": 20.0},
            "core": {"phase_change_temperature": 30.0, "latent_heat_volumetric": 1.5e8, "rho_c": 1.9e6,
                     "rho_c_liquid": 2.4e6, "conductivity": 4.0, "conductivity_liquid": 1.5,
                     "youngs_modulus": 25e9, "poisson_ratio": 0.3, "thermal_expansion": 4e-5,
                     "stress_free_temperature": 20.0},
            "rock": {"conductivity": 3.0, "rho_c": 2.2e6, "youngs_modulus": 60e9, "poisson_ratio": 0.25,
                     "thermal_expansion": 8e-6, "stress_free_temperature": 20.0},
        },
        "initial": {"temperature": 20.0},
        "sources": [{"region": "core", "power": power}],
        "mechanics": {"tolerance": 1e-8},
        "boundary_conditions": {
            "salt_base": {"displacement": [0.0, 0.0]},
            "salt_left": {"symmetry": True},
            "rock_left": {"symmetry": True},
            "rock_top": {"displacement": ["free", f"-{squeeze!r}*t/({_seconds(end)!r})"], "temperature": 20.0},
            "salt_right": {"displacement": [f"-{squeeze / 2!r}*t/({_seconds(end)!r})", "free"]},
        },
        "output": {"vtk": False, "figures": False, "every": 1000000},
    }


def _seconds(value: str) -> float:
    from ..scene.units import parse_time
    return float(parse_time(value))


def contact_melting(*, end: str = "2 year", dt: str = "5 day", maxh: float = 0.125) -> dict:
    """Run :func:`contact_melting_scene` with coupling 'none', 'staggered' and 'iterated': melted fraction,
    peak temperature, deformation heat, contact forces and wall time of each; the effect of the deformation
    heating as the differences against 'none'."""
    out = {}
    for mode in ("none", "staggered", "iterated"):
        scene = scene_from_dict(contact_melting_scene(coupling=mode, end=end, dt=dt, maxh=maxh))
        tic = time.perf_counter()
        res = run_scene(scene, None, progress=False)
        wall = time.perf_counter() - tic
        st = res.summary["stefan"]
        melted = {r: v[-1] for r, v in st["melted_fraction"].items()}
        T = res.stefan.forms.nodal_state(res.stefan.solver.e).T
        mech = res.summary["mechanics"]
        contact = mech["contact"]
        row = {"melted_fraction": melted, "T_max": float(T.max()), "T_mean": float(T.mean()),
               "imbalance": st["energy"]["imbalance_rel"], "heat_supplied": st["energy"]["heat_supplied"][-1],
               "source_heat": st["energy"]["heat_supplied_sources_fluxes"][-1],
               "newton_mean": st["newton_iterations"]["mean"], "mechanics_solves": mech["solves"],
               "contact": contact, "wall_s": wall, "steps": res.summary["steps"]}
        if mode != "none":
            c = res.summary["coupling"]
            row.update(deformation_heat=c["deformation_heat_total"], passes_mean=c["passes_per_step"]["mean"],
                       passes_max=c["passes_per_step"]["max"])
        out[mode] = row
    return out
