"""Frictional heating (:mod:`ngs_geomech.coupling.frictional`) against the closed forms of verification.md
section 8, run through scenes (scene dict -> :func:`ngs_geomech.run.run_scene`, coupled static mechanics and heat
or Stefan).

The scene (:func:`sliding_strip_scene`): a slider block [0, W] x [0, D] on a base block [0, W] x [-D, 0] (plane
strain, nu = 0, no thermal expansion: the mechanics does not see the temperature), Coulomb contact (F_c = mu) with
frictional heating between them. The slider's top is moved by u = (V (t + t_s), -d), d = p (2 D) / E, the base's
bottom is fixed, and the four lateral sides carry the shear traction of the uniform state, (0, -+ mu p): the
displacement is then linear, the stress uniform (sigma_yy = -p, sigma_xy = mu p), so P1 reproduces it exactly and
every node of the interface slides at the rate V (t_s: the slider slides from the start) under p with the
traction mu p. The interface dissipates q = mu p V (W/m^2) uniformly; with every outer side insulated the heat
problem is one-dimensional, and for times with sqrt(alpha t) well below D each block is a half-space heated at its
surface by its share q_i (Carslaw & Jaeger 2.9):

    T(0, t) - T_0 = (2 q_i / k_i) sqrt(alpha_i t / pi).

Cases (:func:`sliding_strip`):

* 'interface' (heat solver): the blocks in perfect thermal contact (the mortar of the heat forms), split by
  effusivity; both sides reach T(0, t) = 2 q sqrt(t / pi) / (e_1 + e_2), e_i = sqrt(k_i rho_i c_i);
* 'gap' (heat solver): the same with the slider GAP above the base, the sides named (an interface with an initial
  gap, closed by the load): the heat forms pass no heat across it, so each block heats only by its own share
  (the mortar projection onto O), and the effusivity split again gives both sides the temperature of perfect
  contact (it is the split at which no heat crosses);
* 'foundation' (heat solver): the slider alone on a rigid foundation (y = 0), the whole q entering it
  (heat_partition 1): T(0, t) = (2 q / k_1) sqrt(alpha_1 t / pi). The slider slides at V / 20 from 0.2 mm to
  0.7 mm here: from a slide of about 1 mm (a tenth of its width) on, the static contact solver settles on this
  Coulomb foundation in a tilted state with one node in contact;
* 'stefan' (Stefan solver, the base a phase-change material whose melting point is never reached): the interface
  passes heat by the Stefan scenes' penalty, set nearly insulating (thermal_penalty 1e-9), and a given partition
  f = 0.7: each side heats by its own share, T_S from f q and T_O from (1 - f) q (the mortar projection onto O).

Figures: the surface temperature (mean over the side's nodes at the end time) against the closed form, the nodal
heat density q_j = W_j / (dt weight_j) against mu p V, the slip rate and the traction (mu p) at the nodes, and the
energies: the heat entering the bodies (the summary's ``coupling.frictional_heating``) against the dissipated work,
against mu p V W t, and against the bodies' heat content gain.

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import math
import time

import ngsolve as ngs
import numpy as np

from ..run import run_scene
from ..scene.parse import scene_from_dict
from .geometry import observed_orders

WIDTH, DEPTH = 0.01, 0.05                 # m
SPEED, PRESSURE, FRICTION, MODULUS = 1e-4, 1e7, 0.5, 1e10      # m/s, Pa, -, Pa
SLIDER = {"conductivity": 2.0, "rho_c": 2.0e6}                 # W/(m K), J/(m^3 K): alpha 1e-6 m^2/s
BASE = {"conductivity": 4.0, "rho_c": 2.5e6}                   # alpha 1.6e-6 m^2/s
END = 100.0                               # s: sqrt(alpha t) <= 0.0126 m, a quarter of DEPTH
HEAD_START = 20.0                         # s: t_s, the slide before t = 0 (the elastic shear is 0.1 mm)
STEFAN_SHARE = 0.7                        # the slider's share of the heat in the 'stefan' case
GAP = 1e-5                                # m: the initial gap of the 'gap' case, closed by the load
CASES = ("interface", "gap", "foundation", "stefan")


def _speed(case: str) -> float:
    """The sliding speed V (m/s) of a case (module docstring)."""
    return SPEED / 20 if case == "foundation" else SPEED


def _head_start(case: str) -> float:
    """t_s (s): the slide before t = 0 is V t_s, four times the elastic shear displacement or more."""
    return 2 * HEAD_START if case == "foundation" else HEAD_START


def _box(name: str, bottom: float, h: float, dim3: bool, names: dict) -> dict:
    """A block [0, W] x [bottom, bottom + D] (3D: [0, W] x [0, W] x [bottom, bottom + D]) with its sides named."""
    if dim3:
        names = {k: v.replace("ymin", "zmin").replace("ymax", "zmax") for k, v in names.items()}
        return {"name": name, "shape": "box", "origin": [0.0, 0.0, bottom], "size": [WIDTH, WIDTH, DEPTH],
                "maxh": h, "boundaries": names}
    return {"name": name, "shape": "rectangle", "origin": [0.0, bottom], "size": [WIDTH, DEPTH], "maxh": h,
            "boundaries": names}


def sliding_strip_scene(*, h: float, steps: int, case: str = "interface", coupling: str = "iterated",
                        dim3: bool = False) -> dict:
    """The scene dict of the sliding strip (module docstring) with element size ``h`` (m) and ``steps`` equal time
    steps to END (Crank-Nicolson after two backward Euler steps for the heat solver; backward Euler for Stefan);
    ``dim3``: the same in 3D (blocks W x W x D, sliding along x, z vertical)."""
    V, tau = _speed(case), FRICTION * PRESSURE
    vec = (lambda x, z: [x, 0.0, z]) if dim3 else (lambda x, z: [x, z])
    elastic = {"youngs_modulus": MODULUS, "poisson_ratio": 0.0}
    law = {"law": "coulomb", "friction": FRICTION, "frictional_heating": True}
    sides = {"left": "xmin", "right": "xmax"}
    lift = GAP if case == "gap" else 0.0
    slider = _box("slider", lift, h, dim3, {"slider_top": "ymax", "slider_bottom": "ymin",
                                            **{f"slider_{k}": v for k, v in sides.items()}})
    shear = {"left": vec(0.0, -tau), "right": vec(0.0, tau)}
    bcs = {f"slider_{k}": {"traction": v} for k, v in shear.items()}
    depth = DEPTH if case == "foundation" else 2 * DEPTH
    bcs["slider_top"] = {"displacement": vec(f"{V!r}*(t+{_head_start(case)!r})",
                                             -PRESSURE * depth / MODULUS - lift)}
    scheme = {"scheme": "backward_euler"} if case == "stefan" else {"scheme": "crank_nicolson", "startup_steps": 2}
    scene = {"scene": {"name": f"frictional_strip_{case}", "temperature_unit": "C",
                       "dimension": "3d" if dim3 else "plane"},
             "physics": {"thermal": "transient", "mechanics": "static", "coupling": coupling,
                         "coupling_tolerance": 1e-10},
             "mesh": {"maxh": h}, "time": {"end": END, "dt": END / steps, **scheme},
             "blocks": [slider], "materials": {"slider": {**SLIDER, **elastic}}, "boundary_conditions": bcs,
             "initial": {"temperature": 0.0}, "mechanics": {"tolerance": 1e-12},
             "output": {"vtk": False, "figures": False}}
    if case == "foundation":
        bcs["slider_bottom"] = {"foundation": {"point": vec(0.0, 0.0), "normal": vec(0.0, 1.0), **law}}
        return scene
    top = {"base_top": "ymax"} if case == "gap" else {}
    scene["blocks"].append(_box("base", -DEPTH, h, dim3, {"base_bottom": "ymin", **top,
                                                          **{f"base_{k}": v for k, v in sides.items()}}))
    base = {**BASE, **elastic}
    interface = {"name": "sliding", "blocks": ["slider", "base"], "type": "contact", **law}
    if case == "gap":
        interface["sides"] = ["slider_bottom", "base_top"]
    if case == "stefan":
        base.update(phase_change_temperature=1e3, latent_heat_volumetric=1e8, rho_c_liquid=BASE["rho_c"],
                    conductivity_liquid=BASE["conductivity"])
        interface.update(heat_partition=STEFAN_SHARE, thermal_penalty=1e-9)
    scene["materials"]["base"] = base
    scene["interfaces"] = [interface]
    bcs.update({f"base_{k}": {"traction": v} for k, v in shear.items()})
    bcs["base_bottom"] = {"displacement": vec(0.0, 0.0)}
    return scene


def half_space_rise(flux: float, material: dict, t: float) -> float:
    """T(0, t) - T_0 (K) of a half-space heated at its surface by ``flux`` (W/m^2) from t = 0 (C & J 2.9)."""
    k, rho_c = material["conductivity"], material["rho_c"]
    return 2 * flux / k * math.sqrt(k / rho_c * t / math.pi)


def exact_rises(case: str) -> dict:
    """The closed-form surface temperature rises (K) at END on the slider's side and the base's."""
    q = FRICTION * PRESSURE * _speed(case)
    if case == "foundation":
        return {"side": half_space_rise(q, SLIDER, END)}
    if case == "stefan":
        return {"side": half_space_rise(STEFAN_SHARE * q, SLIDER, END),
                "opposite": half_space_rise((1 - STEFAN_SHARE) * q, BASE, END)}
    e1, e2 = (math.sqrt(m["conductivity"] * m["rho_c"]) for m in (SLIDER, BASE))
    rise = half_space_rise(q * e1 / (e1 + e2), SLIDER, END)
    return {"side": rise, "opposite": rise}


def _side_temperatures(model, it) -> dict:
    """The temperature (mean over the nodes, K) of the interface's sides at the end."""
    T = model.thermal.T.vec.FV().NumPy()
    op = it.spec.op
    out = {"side": float(np.mean(T[op.nodes]))}
    if op.opposite:
        nodes = sorted({v.nr for el in model.mesh.Boundaries(op.opposite).Elements() for v in el.vertices})
        out["opposite"] = float(np.mean(T[nodes]))
    return out


def _interface_rates(model, it, case: str) -> dict:
    """Relative errors of the nodal heat density, slip rate and traction of the last step against mu p V, V and
    mu p (max over the interface's nodes)."""
    op = it.spec.op
    V = _speed(case)
    dt = END / len(model.coupling.history["passes"])
    lam_n, lam_t = (np.asarray(x) for x in model.mechanics.contact_multipliers()[0])
    u = np.asarray(model.mechanics.forms.gf.vec.FV().NumPy())[:op.Bt.shape[1]]
    rate = np.linalg.norm([B @ u - s0 for B, s0 in zip(it.rows, it.start)], axis=0) / op.weight / dt
    traction = np.linalg.norm(lam_t.reshape(len(lam_n), -1), axis=1)
    q = it.last_power / op.weight
    return {"heat_density_rel_error": float(np.max(np.abs(q / (FRICTION * PRESSURE * V) - 1))),
            "slip_rate_rel_error": float(np.max(np.abs(rate / V - 1))),
            "traction_rel_error": float(np.max(np.abs(traction / (FRICTION * PRESSURE) - 1))),
            "pressure_rel_error": float(np.max(np.abs(lam_n / PRESSURE - 1)))}


def sliding_strip(*, h: float, steps: int, case: str = "interface", coupling: str = "iterated",
                  dim3: bool = False) -> dict:
    """Run :func:`sliding_strip_scene`; the surface temperatures against the closed forms, the interface's rates
    and tractions, and the energies (module docstring). Keys: ``rel_error`` (the largest over the sides),
    ``T``, ``T_exact`` (per side, K), the rates' errors, ``energy_rel_error`` (|entered + owed - dissipated| /
    dissipated; owed: the last step's work with 'staggered' coupling),
    ``work_rel_error`` (dissipated against mu p V W END), ``gain_rel_error`` (the bodies' heat content gain against
    the heat entered), ``share_side`` (entered on S / entered), ``imbalance_rel`` (the summary's), ``ndof``,
    ``wall_s``."""
    tic = time.perf_counter()
    scene = sliding_strip_scene(h=h, steps=steps, case=case, coupling=coupling, dim3=dim3)
    res = run_scene(scene_from_dict(scene), None, progress=False)
    wall = time.perf_counter() - tic
    model = res.model
    it = model.coupling.friction.items[0]
    fh = res.summary["coupling"]["frictional_heating"]
    c = fh["contacts"][it.spec.name]
    T, exact = _side_temperatures(model, it), exact_rises(case)
    errors = {k: T[k] / exact[k] - 1 for k in exact}
    if res.stefan is not None:
        gain = res.summary["stefan"]["energy"]["heat_gain"][-1]
    else:
        gain = float(ngs.Integrate(model.thermal.forms.rho_c * model.thermal.T, model.mesh))
    work = FRICTION * PRESSURE * _speed(case) * WIDTH * (WIDTH if dim3 else 1.0) * END
    return {"case": case, "h": h, "steps": steps, "T": T, "T_exact": exact, "errors": errors,
            "rel_error": max(abs(e) for e in errors.values()), **_interface_rates(model, it, case),
            "dissipated": c["dissipated"], "entered": c["entered"],
            "owed": c["owed"], "energy_rel_error": abs(c["entered"] + c["owed"] - c["dissipated"]) / c["dissipated"],
            "work_rel_error": abs(c["dissipated"] / work - 1), "gain_rel_error": abs(gain / c["entered"] - 1),
            "share_side": c["entered_side"] / c["entered"], "imbalance_rel": fh["energy"]["imbalance_rel"],
            "passes_mean": res.summary["coupling"]["passes_per_step"]["mean"], "ndof": model.thermal.ndof,
            "wall_s": wall}


def frictional_heating(*, levels: int = 3, cases: tuple = CASES, coarse: int = 20, steps: int = 10) -> dict:
    """:func:`sliding_strip` of each case on ``levels`` meshes and time steps, h = DEPTH / (coarse 2^k), steps
    2^k ``steps``; returns per case the errors, their observed orders (in h, dt halved together), and the summary
    metrics: ``frictional_heating_rel_error`` (the largest surface-temperature error of the finest level over the
    cases), ``frictional_heating_energy_rel_error`` (the largest of energy_rel_error, gain_rel_error and
    imbalance_rel over all runs), ``frictional_heating_rate_rel_error`` (the largest heat density, slip rate
    and traction error), ``wall_s``."""
    out = {"cases": {}}
    for case in cases:
        runs = [sliding_strip(h=DEPTH / (coarse * 2 ** k), steps=steps * 2 ** k, case=case) for k in range(levels)]
        errs = [r["rel_error"] for r in runs]
        out["cases"][case] = {"h": [r["h"] for r in runs], "steps": [r["steps"] for r in runs], "rel_error": errs,
                              "orders": observed_orders([r["h"] for r in runs], errs) if min(errs) > 0 else [],
                              "runs": runs}
    runs = [r for c in out["cases"].values() for r in c["runs"]]
    out["frictional_heating_rel_error"] = max(c["rel_error"][-1] for c in out["cases"].values())
    out["frictional_heating_energy_rel_error"] = max(max(r["energy_rel_error"], r["gain_rel_error"],
                                                         r["imbalance_rel"]) for r in runs)
    out["frictional_heating_rate_rel_error"] = max(max(r["heat_density_rel_error"], r["slip_rate_rel_error"],
                                                       r["traction_rel_error"]) for r in runs)
    out["wall_s"] = sum(r["wall_s"] for r in runs)
    return out
