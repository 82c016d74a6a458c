"""Heat across contact interfaces with a contact conductance (:mod:`ngs_geomech.heat.conductance`) against closed
forms (verification.md section 8).

:func:`two_slabs` : two slabs (lengths L1, L2, conductivities k1, k2; insulated sides) pressed together, their
outer faces at T_a and T_b, joined by a contact interface of conductance h with non-matching meshes on its two
sides. The steady flux is q = (T_a - T_b) / (L1/k1 + 1/h + L2/k2) and the temperature jumps by q / h across the
interface. The temperature is linear in each slab (in the P1 space), so the discrete solution is exact up to
round-off: the jump at every quadrature point of the interface and the heat flow are compared. In a heat scene
(steady; plane, axisymmetric with the slabs stacked along the axis, or 3D) and in a Stefan scene (both slabs of
a phase-change material that stays solid, stepped to the steady state).

:func:`hertz_conductance` : heat across a Hertz line contact (verification.md sections 2 and 8): an elastic half
cylinder pressed on an elastic block of the same material (:func:`.contact_problems.cattaneo_mesh`, frictionless,
non-matching meshes, E* = E/(2 (1 - nu^2)), load P with a = R/50), conductance h = C p^m from the mechanics'
nodal pressure. With conductivities large against the contact's conductance both bodies are isothermal (at the
temperatures T_1, T_2 of their outer faces), and the heat flow is

    Q = (T_1 - T_2) int_{-a}^{a} C p(x)^m dx = (T_1 - T_2) C p0^m a sqrt(pi) Gamma(m/2 + 1) / Gamma(m/2 + 3/2),

p(x) = p0 sqrt(1 - x^2/a^2). The heat problem is solved (steady, the forms of :mod:`ngs_geomech.heat.forms`) with
the contact state of the contact solve; the error holds the discrete pressure's (its half width within a node
spacing) and the bodies' finite conductivity (spreading resistance, about Q ln(R/a)/(pi k) relative).

:func:`gap_closing` : a coupled scene (transient heat, static mechanics, staggered or iterated coupling): a
hot block and a cold block, both fixed at their outer faces, start a gap g0 apart (``sides``). The hot block
expands and closes the gap; from then on the interface conducts with its conductance (here a number h; no gap
conductance, so nothing crosses while open). Checked: no heat crosses before the closure, heat crosses after
it, the steady flow once closed against the two-slab closed form (the small-strain contact geometry is the
reference one: the slabs keep their lengths), the energy balance of each body (``heat_balance`` of the
summary), and that the same scene without conductance keys warns that the closed interface carries no heat.

Nothing here prints or writes files; the functions return plain dicts of floats (and short lists).
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..contact.forms import contact_operator_2d
from ..contact.solver import ContactLaw, ContactSolver, nodal_modulus
from ..fem.coefficients import expression_function
from ..heat.conductance import ContactNodes, InterfaceConductance, PowerLawConductance
from ..heat.forms import HeatForms, HeatSetup
from ..heat.materials import ThermalProperties
from ..heat.solver import HeatSolver
from ..mechanics.forms import ElasticSetup
from ..run import run_scene
from ..scene.parse import scene_from_dict
from . import contact_closed_forms as cc
from .contact_problems import E_HERTZ, NU_HERTZ, R_HERTZ, cattaneo_mesh, elastic_props, linear_system

SLABS = {"L1": 1.0, "L2": 0.5, "k1": 2.0, "k2": 1.0, "T_a": 100.0, "T_b": 0.0, "H": 0.4}
"""The two slabs (m, W/(m K), degC) of :func:`two_slabs` and :func:`gap_closing`."""


def slab_flux(h: float, L1: float, L2: float, k1: float, k2: float, T_a: float, T_b: float) -> float:
    """The flux q = (T_a - T_b) / (L1/k1 + 1/h + L2/k2), W/m^2 (verification.md section 8)."""
    return (T_a - T_b) / (L1 / k1 + 1.0 / h + L2 / k2)


def _slab_blocks(dimension: str, s: dict, maxh: float, gap: float = 0.0) -> list[dict]:
    """Two slabs along x (plane, 3D) or along the axis z (axisymmetric), the second ``gap`` (m) beyond the first,
    meshed with sizes maxh and 0.7 maxh (non-matching sides)."""
    L1, L2, H = s["L1"], s["L2"], s["H"]
    if dimension == "axisymmetric":
        return [{"name": "left", "shape": "rectangle", "origin": [0, 0], "size": [H, L1], "maxh": maxh,
                 "boundaries": {"hot": "ymin", "ls": "ymax"}},
                {"name": "right", "shape": "rectangle", "origin": [0, L1 + gap], "size": [H, L2], "maxh": 0.7 * maxh,
                 "boundaries": {"cold": "ymax", "rs": "ymin"}}]
    if dimension == "3d":
        return [{"name": "left", "shape": "box", "origin": [0, 0, 0], "size": [L1, H, H], "maxh": maxh,
                 "boundaries": {"hot": "xmin", "ls": "xmax"}},
                {"name": "right", "shape": "box", "origin": [L1 + gap, 0, 0], "size": [L2, H, H], "maxh": 0.7 * maxh,
                 "boundaries": {"cold": "xmax", "rs": "xmin"}}]
    return [{"name": "left", "shape": "rectangle", "origin": [0, 0], "size": [L1, H], "maxh": maxh,
             "boundaries": {"hot": "xmin", "ls": "xmax"}},
            {"name": "right", "shape": "rectangle", "origin": [L1 + gap, 0], "size": [L2, H], "maxh": 0.7 * maxh,
             "boundaries": {"cold": "xmax", "rs": "xmin"}}]


def two_slabs_scene(*, h: float = 50.0, dimension: str = "plane", stefan: bool = False, order: int = 1,
                    maxh: float = 0.1) -> dict:
    """The scene dict of :func:`two_slabs`: steady heat, or (``stefan``) a Stefan scene of two solid PCM slabs
    stepped to the steady state (ten backward Euler steps of 100 diffusion times)."""
    s = SLABS
    mats = {"left": {"conductivity": s["k1"], "rho_c": 2e6}, "right": {"conductivity": s["k2"], "rho_c": 1e6}}
    d = {"scene": {"name": "two_slabs", "dimension": dimension},
         "physics": {"thermal": "transient" if stefan else "steady"},
         "mesh": {"maxh": maxh, "order": order},
         "blocks": _slab_blocks(dimension, s, maxh),
         "interfaces": [{"name": "joint", "blocks": ["left", "right"], "type": "contact", "conductance": h}],
         "materials": mats,
         "boundary_conditions": {"hot": {"temperature": s["T_a"]}, "cold": {"temperature": s["T_b"]}},
         "output": {"vtk": False, "figures": False}}
    if stefan:
        for m in mats.values():          # a phase change far above the temperatures reached: solid throughout
            m.update(phase_change_temperature=1000.0, latent_heat_volumetric=1e8, rho_c_liquid=m["rho_c"],
                     conductivity_liquid=m["conductivity"])
        d["initial"] = {"temperature": 0.5 * (s["T_a"] + s["T_b"])}
        d["time"] = {"end": 1e9, "dt": 1e8}
    return d


def _interface_area(dimension: str, H: float) -> float:
    """The interface's measure in the units of the flows: m (plane, per m of depth), m^2 (3D), m^2 per radian
    (axisymmetric: int r dr)."""
    return {"plane": H, "3d": H * H, "axisymmetric": H * H / 2}[dimension]


def two_slabs(*, h: float = 50.0, dimension: str = "plane", stefan: bool = False, order: int = 1,
              maxh: float = 0.1) -> dict:
    """Run :func:`two_slabs_scene` and compare with the closed form (module docstring).

    Returns {"q_ref" (W/m^2), "jump_ref" (K), "q_num" (the interface flow over its area), "jump_max_error" (max
    |jump - q/h| / (q/h) over the quadrature points (heat) or the master nodes (Stefan)), "flow_rel_error",
    "conductance_rel_error" (the larger of the two), "ndof", "wall_s"}."""
    s = SLABS
    q_ref = slab_flux(h, s["L1"], s["L2"], s["k1"], s["k2"], s["T_a"], s["T_b"])
    tic = time.perf_counter()
    result = run_scene(scene_from_dict(two_slabs_scene(h=h, dimension=dimension, stefan=stefan, order=order,
                                                       maxh=maxh)), None, progress=False)
    wall = time.perf_counter() - tic
    thermal = result.model.thermal
    if stefan:
        item = thermal.forms.conductances.items[0]
        T = thermal.forms.nodal_state(thermal.solver.e).T
        jump = (item.B @ T) / item.D
        flow = thermal.forms.conductances.flows(T)["joint"]
    else:
        term = thermal.forms.interface_terms.terms[0]
        T = thermal.forms.gf.vec.FV().NumPy()[:thermal.forms.V.ndof]
        jump = term.jump @ T
        flow = term.flow(T)
    q_num = flow / _interface_area(dimension, s["H"])
    jump_err = float(np.max(np.abs(jump - q_ref / h))) / (q_ref / h)
    flow_err = abs(q_num - q_ref) / q_ref
    return {"q_ref": q_ref, "jump_ref": q_ref / h, "q_num": q_num, "jump_max_error": jump_err,
            "flow_rel_error": flow_err, "conductance_rel_error": max(jump_err, flow_err),
            "ndof": int(thermal.ndof), "wall_s": wall}


def hertz_flow(C: float, m: float, a: float, p0: float, dT: float) -> float:
    """(T_1 - T_2) int_{-a}^{a} C p(x)^m dx for the Hertz pressure p = p0 sqrt(1 - x^2/a^2), W per m of depth."""
    return dT * C * p0 ** m * a * math.sqrt(math.pi) * math.gamma(m / 2 + 1) / math.gamma(m / 2 + 1.5)


def _hertz_contact(h_contact: float, order: int):
    """The frictionless Hertz contact of a half cylinder on a block (:func:`hertz_conductance`): (mesh, closed
    form, the contact operator, the nodal pressure and gap, the contact solve's force balance)."""
    R, E, nu = R_HERTZ, E_HERTZ, NU_HERTZ
    E_star = cc.effective_modulus(E, nu, E, nu)
    a_ref = R / 50
    P = math.pi * E_star * a_ref ** 2 / (4 * R)
    ref = cc.hertz_line(P, R, E_star)
    mesh = cattaneo_mesh(a_ref, h_contact, order, None, 0.3)
    props = elastic_props(E, nu, ("cylinder", "block"))
    setup = ElasticSetup(props=props, model="plane_strain", order=order)
    setup.dirichlet["bottom"] = [expression_function(0.0), expression_function(0.0)]
    setup.traction["top"] = [expression_function(0.0), expression_function(-P / (2 * R))]
    forms, K, f, free, x0 = linear_system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "hertz", "block_contact", "cylinder_contact", axisymmetric=False,
                             search_distance=a_ref / 2)
    solver = ContactSolver([(op, ContactLaw())], modulus=nodal_modulus(props), floating=forms.floating_bodies())
    u, _ = solver.solve(K, f, free, x0, "hertz")
    lam_n = np.asarray(solver.multipliers[0][0])
    gap = (op.g0 + op.Bn @ u[:op.Bn.shape[1]]) / np.maximum(op.weight, 1e-300)
    return mesh, ref, op, lam_n, gap, abs(float(np.dot(op.weight, lam_n)) - P) / P


def hertz_conductance(*, h_contact: float = None, exponent: float = 0.95, C: float = None, order: int = 2,
                      conductivity: float = 1e7, dT: float = 10.0) -> dict:
    """The heat flow across the Hertz contact (module docstring) with h = C p^m, m = ``exponent`` (``C``
    default: h = 1e4 W/(m^2 K) at p0), ``h_contact`` (m; default a/20) the element size along the contact,
    ``conductivity`` (W/(m K)) of both bodies, ``dT`` (K) between the outer faces.

    Returns {"a", "p0", "Q_ref" (W per m of depth), "Q_num", "pressure_conductance_rel_error", "a_num" (the last
    node with pressure), "force_balance", "h_contact", "nodes" (interface nodes), "wall_s"}."""
    tic = time.perf_counter()
    a_ref = R_HERTZ / 50
    mesh, ref, op, lam_n, gap, balance = _hertz_contact(h_contact or a_ref / 20, order)
    C = C if C is not None else 1e4 / ref.p0 ** exponent
    props = {r: ThermalProperties(kappa=conductivity * np.eye(2), rho_c=None) for r in ("cylinder", "block")}
    spec = InterfaceConductance("hertz", "block_contact", "cylinder_contact",
                                law=PowerLawConductance(C, exponent), reach=a_ref / 2)
    setup = HeatSetup(props=props, order=order, steady=True, conductances=[spec],
                      dirichlet={"top": expression_function(dT), "bottom": expression_function(0.0)})
    forms = HeatForms(mesh, setup)
    solver = HeatSolver(forms)
    forms.set_contact_state({"hertz": ContactNodes("block_contact", np.asarray(op.nodes), lam_n, gap)})
    forms.t_new.Set(0.0)
    solver.solve("hertz conductance")
    T = forms.gf.vec.FV().NumPy()[:forms.V.ndof]
    Q_num = -forms.interface_terms.flows(T)["hertz"]           # master (the block, cold) -> minion
    Q_ref = hertz_flow(C, exponent, ref.a, ref.p0, dT)
    x = op.coords[:, 0]
    return {"a": ref.a, "p0": ref.p0, "Q_ref": Q_ref, "Q_num": Q_num,
            "pressure_conductance_rel_error": abs(Q_num - Q_ref) / Q_ref,
            "a_num": float(np.max(np.abs(x[lam_n > 0]))), "force_balance": balance,
            "h_contact": h_contact or a_ref / 20, "nodes": int(len(x)), "wall_s": time.perf_counter() - tic}


def gap_closing_scene(*, h: float | None = 50.0, gap: float = 5e-4, coupling: str = "staggered",
                      maxh: float = 0.1, dt: float = 2e4, end: float = 1e9, stefan: bool = False) -> dict:
    """The scene dict of :func:`gap_closing` (degC; ``h`` None: the interface without conductance keys). The slabs
    of :data:`SLABS` ``gap`` (m) apart, held by rollers (u_x = 0 on the outer faces, u_y = 0 on the bottoms), so
    the contact closes uniformly; E = 10 GPa, nu = 0.25, alpha = 1e-5 1/K, stress-free and initial temperature
    T_b. Steps from ``dt`` (s) growing by 1.5 up to 1e8 s (the steady state by the end). ``stefan``: both slabs of a
    phase-change material that stays solid (the Stefan solver)."""
    s = SLABS
    blocks = _slab_blocks("plane", s, maxh, gap)
    blocks[0]["boundaries"]["b1"] = "ymin"
    blocks[1]["boundaries"]["b2"] = "ymin"
    mech = {"youngs_modulus": 1e10, "poisson_ratio": 0.25, "thermal_expansion": 1e-5,
            "stress_free_temperature": s["T_b"]}
    itf = {"name": "joint", "blocks": ["left", "right"], "type": "contact", "sides": ["ls", "rs"]}
    if h is not None:
        itf["conductance"] = h
    mats = {"left": {"conductivity": s["k1"], "rho_c": 2e6, **mech},
            "right": {"conductivity": s["k2"], "rho_c": 1e6, **mech}}
    if stefan:
        for m in mats.values():
            m.update(phase_change_temperature=1000.0, latent_heat_volumetric=1e8, rho_c_liquid=m["rho_c"],
                     conductivity_liquid=m["conductivity"])
    return {"scene": {"name": "gap_closing", "temperature_unit": "C"},
            "physics": {"thermal": "transient", "mechanics": "static", "coupling": coupling},
            "mesh": {"maxh": maxh},
            "time": {"end": end, "dt": dt, "dt_growth": 1.5, "dt_max": 1e8},
            "blocks": blocks, "interfaces": [itf],
            "materials": mats,
            "initial": {"temperature": s["T_b"]},
            "mechanics": {"tolerance": 1e-10},
            "boundary_conditions": {"hot": {"temperature": s["T_a"], "symmetry": True},
                                    "cold": {"temperature": s["T_b"], "symmetry": True},
                                    "b1": {"symmetry": True}, "b2": {"symmetry": True}},
            "output": {"vtk": False, "figures": False}}


def gap_closing(*, h: float = 50.0, gap: float = 5e-4, coupling: str = "staggered", maxh: float = 0.1) -> dict:
    """Run :func:`gap_closing_scene` with the conductance h and without conductance keys (module docstring).

    Returns {"closing_step" (the first mechanics solve with contact pressure, 0 the start's), "flow_while_open" (the
    largest |flow| of the heat steps that saw the interface open, W per m of depth), "flow_after_closing" (the flow
    of the first heat step that saw it closed), "flow_final", "flow_ref" (the two-slab closed form times the
    height), "steady_flow_rel_error", "max_pressure_Pa", "energy_imbalance_rel" (the largest of the bodies',
    ``heat_balance``), "warned_without_keys" (the run without conductance keys warns that the closed interface
    carries no heat), "warned_with_keys" (the run with them does not), "wall_s" (the run with the conductance),
    "wall_without_s", "steps"}."""
    s = SLABS
    tic = time.perf_counter()
    res = run_scene(scene_from_dict(gap_closing_scene(h=h, gap=gap, coupling=coupling, maxh=maxh)), None,
                    progress=False)
    wall = time.perf_counter() - tic
    tic = time.perf_counter()
    bare = run_scene(scene_from_dict(gap_closing_scene(h=None, gap=gap, coupling=coupling, maxh=maxh)), None,
                     progress=False)
    wall_bare = time.perf_counter() - tic
    summ = res.summary
    history = summ["mechanics"]["contact"]["history"]
    pressures = [e["joint"]["max_pressure_Pa"] for e in history]
    closing = next((k for k, p in enumerate(pressures) if p > 0), None)
    flows = summ["interface_heat_flow_W"]["ls"]
    # history[0] is the start's solve: heat step k saw the mechanics of solve k (the previous step's end;
    # staggered) or k + 1 (its own end, the iterated step's last pass)
    first = None if closing is None else closing - (0 if coupling == "staggered" else 1)
    open_steps = flows[:first] if first is not None else flows
    q_ref = slab_flux(h, s["L1"], s["L2"], s["k1"], s["k2"], s["T_a"], s["T_b"]) * s["H"]
    warn = "the mechanics closes it"
    return {"closing_step": closing, "flow_while_open": float(np.max(np.abs(open_steps), initial=0.0)),
            "flow_after_closing": float(flows[first]) if first is not None and first < len(flows) else None,
            "flow_final": float(flows[-1]), "flow_ref": q_ref, "steady_flow_rel_error": abs(flows[-1] - q_ref) / q_ref,
            "max_pressure_Pa": float(max(pressures)),
            "energy_imbalance_rel": float(summ["heat_balance"]["imbalance_rel"]),
            "interface_heat_J": float(summ["heat_balance"]["interface_heat"]["joint"]),
            "warned_without_keys": any(warn in w for w in bare.summary["warnings"]),
            "warned_with_keys": any(warn in w for w in summ["warnings"]),
            "wall_s": wall, "wall_without_s": wall_bare, "steps": len(flows)}


def gap_flux(k_gap: float | None, gap: float, eps: float | None, s: dict = SLABS, kelvin: float = 273.15) -> float:
    """The steady flux (W/m^2) across two slabs (:data:`SLABS`) ``gap`` (m) apart that exchange heat by gas
    conduction (k_gap / gap) and radiation (sigma eps (T_m^4 - T_s^4), absolute T): the root q of
    q = h_g (T_m - T_s) + sigma eps (T_m^4 - T_s^4) with T_m = T_a - q L1/k1, T_s = T_b + q L2/k2."""
    from scipy.optimize import brentq

    from ..heat.conductance import STEFAN_BOLTZMANN
    hg = k_gap / gap if k_gap else 0.0
    se = STEFAN_BOLTZMANN * (eps or 0.0)

    def f(q):
        Tm = s["T_a"] - q * s["L1"] / s["k1"] + kelvin
        Ts = s["T_b"] + q * s["L2"] / s["k2"] + kelvin
        return hg * (Tm - Ts) + se * (Tm ** 4 - Ts ** 4) - q
    top = (s["T_a"] - s["T_b"]) / (s["L1"] / s["k1"] + s["L2"] / s["k2"])
    return brentq(f, 0.0, top, xtol=1e-14, rtol=1e-15)


def gap_slabs_scene(*, gap: float = 1e-3, gap_conductivity: float | None = 0.03, emissivities=(0.8, 0.6),
                    radiation: str = "exact", stefan: bool = False, maxh: float = 0.1) -> dict:
    """Two slabs ``gap`` (m) apart (``sides``) exchanging heat across the open gap (no mechanics): steady heat, or
    stepped to the steady state (linearized radiation, Stefan scenes)."""
    s = SLABS
    d = two_slabs_scene(stefan=stefan, maxh=maxh)
    d["blocks"] = _slab_blocks("plane", s, maxh, gap)
    itf = {"name": "joint", "blocks": ["left", "right"], "type": "contact", "sides": ["ls", "rs"]}
    if gap_conductivity is not None:
        itf["gap_conductivity"] = gap_conductivity
    if emissivities is not None:
        itf["emissivities"] = list(emissivities)
        itf["radiation"] = radiation
    d["interfaces"] = [itf]
    d["scene"]["temperature_unit"] = "C"
    if radiation == "linearized" and not stefan:
        d["physics"]["thermal"] = "transient"
        d["initial"] = {"temperature": 0.5 * (s["T_a"] + s["T_b"])}
        d["time"] = {"end": 3e9, "dt": 1e8}
    return d


def gap_slabs(*, gap: float = 1e-3, gap_conductivity: float | None = 0.03, emissivities=(0.8, 0.6),
              radiation: str = "exact", stefan: bool = False, maxh: float = 0.1) -> dict:
    """Run :func:`gap_slabs_scene` and compare the flux across the gap with :func:`gap_flux`: {"q_ref", "q_num",
    "gap_flux_rel_error", "newton_iterations_max", "wall_s"}."""
    from ..heat.conductance import effective_emissivity
    tic = time.perf_counter()
    res = run_scene(scene_from_dict(gap_slabs_scene(gap=gap, gap_conductivity=gap_conductivity,
                                                    emissivities=emissivities, radiation=radiation, stefan=stefan,
                                                    maxh=maxh)), None, progress=False)
    eps = effective_emissivity(*emissivities) if emissivities is not None else None
    q_ref = gap_flux(gap_conductivity, gap, eps)
    if stefan:
        thermal = res.model.thermal
        flow = thermal.forms.conductances.flows(thermal.forms.nodal_state(thermal.solver.e).T)["joint"]
    else:
        flow = res.summary["interface_heat_flow_W"]["ls"][-1]
    q_num = flow / SLABS["H"]
    return {"q_ref": q_ref, "q_num": q_num, "gap_flux_rel_error": abs(q_num - q_ref) / q_ref,
            "newton_iterations_max": res.summary.get("newton_iterations_max"), "wall_s": time.perf_counter() - tic}


def hertz_conductance_convergence(*, exponent: float = 0.95, order: int = 2, divisions=(10, 20)) -> dict:
    """:func:`hertz_conductance` with the contact element size a/n for n in ``divisions``: {"h_contact" (m),
    "errors" (pressure_conductance_rel_error per mesh), "observed_order" (log-log slope between the last two),
    "pressure_conductance_rel_error" (the finest)}."""
    a = R_HERTZ / 50
    runs = [hertz_conductance(exponent=exponent, h_contact=a / n, order=order) for n in divisions]
    errs = [r["pressure_conductance_rel_error"] for r in runs]
    hs = [r["h_contact"] for r in runs]
    slope = math.log(errs[-2] / errs[-1]) / math.log(hs[-2] / hs[-1]) if len(errs) > 1 else float("nan")
    return {"h_contact": hs, "errors": errs, "observed_order": slope, "pressure_conductance_rel_error": errs[-1]}


def figures() -> dict:
    """The issue's figures of this module in one dict: ``conductance_rel_error`` (the largest of the two-slab
    runs: heat plane P1 and P2, axisymmetric, 3D, Stefan plane and 3D), ``pressure_conductance_rel_error`` (the
    Hertz contact, h = C p^0.95, P2, a/20) with its ``pressure_conductance_observed_order``, the gap closing's
    ``energy_imbalance_rel`` and ``gap_closing_steady_flow_rel_error``, and ``gap_flux_rel_error`` (gas
    conduction and exact radiation across an open gap)."""
    slabs = [two_slabs(), two_slabs(order=2), two_slabs(dimension="axisymmetric"),
             two_slabs(dimension="3d", maxh=0.2), two_slabs(stefan=True), two_slabs(stefan=True, dimension="3d",
                                                                                   maxh=0.2)]
    hertz = hertz_conductance_convergence()
    gap = gap_closing()
    return {"conductance_rel_error": max(r["conductance_rel_error"] for r in slabs),
            "conductance_rel_error_stefan": max(r["conductance_rel_error"] for r in slabs[4:]),
            "pressure_conductance_rel_error": hertz["pressure_conductance_rel_error"],
            "pressure_conductance_observed_order": hertz["observed_order"],
            "energy_imbalance_rel": gap["energy_imbalance_rel"],
            "gap_closing_steady_flow_rel_error": gap["steady_flow_rel_error"],
            "gap_closing_flow_while_open": gap["flow_while_open"],
            "gap_closing_warned_without_keys": gap["warned_without_keys"],
            "gap_flux_rel_error": gap_slabs()["gap_flux_rel_error"]}
