"""Verification of heat conduction (seed (2.17), (2.19)-(2.22), (2.43)): manufactured solutions on two
anisotropic regions with glued and contact (mortar, non-matching) interfaces, theta time schemes, and the
Kirchhoff slab with k(T) = k0 (1 + b T). Prints the error tables and asserts the observed orders.

Contact interfaces are coupled by a segment-based mortar method (:mod:`ngs_geomech.fem.mortar`) with
the modified multiplier space at cross points: the patch test passes on non-matching meshes and the
contact solution converges at the glued orders.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from ngs_geomech.verification import manufactured as mms

HS = (0.2, 0.1, 0.05, 0.025)
DTS = (0.2, 0.1, 0.05, 0.025)

def rates(hs, errors) -> list[str]:
    """Observed orders between consecutive levels, as strings ('-' for the first)."""
    out = ["-"]
    for k in range(1, len(hs)):
        out.append(f"{math.log(errors[k - 1] / errors[k]) / math.log(hs[k - 1] / hs[k]):.2f}")
    return out


def print_table(title: str, hs, columns: dict[str, list], hname: str = "h") -> None:
    print(f"\n{title}")
    print(f"{hname:>8} " + " ".join(f"{name:>11} {'rate':>5}" for name in columns))
    rate = {name: rates(hs, errs) for name, errs in columns.items()}
    for k, h in enumerate(hs):
        print(f"{h:8.4g} " + " ".join(f"{errs[k]:11.3e} {rate[name][k]:>5}" for name, errs in columns.items()))


@functools.cache
def steady(order: int, interface: str) -> dict:
    return mms.steady_convergence(order, HS, interface)


def test_manufactured_solutions_satisfy_interface_conditions():
    cases = [(mms.steady_solution(), 0.0), (mms.transient_solution(), 0.0), (mms.transient_solution(), 0.7),
             (mms.patch_solution(1), 0.0), (mms.patch_solution(2), 0.0)]
    for sol, t in cases:
        jumps = mms.interface_jumps(sol, t)
        print(f"\ninterface jumps at t = {t}: {jumps}")
        assert jumps["temperature_jump"] < 1e-12
        assert jumps["flux_jump"] < 1e-12


@pytest.mark.parametrize("order, interface", [(1, "glued"), (2, "glued"), (3, "glued"),
                                              (1, "contact"),
                                              (2, "contact")])
def test_patch_test(order, interface):
    res = [mms.patch_test(order, interface, maxh=h) for h in (0.25, 0.1)]
    print(f"\npatch test P{order} {interface}: " + ", ".join(f"maxh {r['maxh']}: L2 {r['l2']:.2e} K m, "
                                                          f"H1 {r['h1']:.2e} K" for r in res))
    for r in res:
        assert r["l2"] < 1e-10 and r["h1"] < 1e-9


@pytest.mark.parametrize("order, interface, l2_min, h1_min",
                         [(1, "glued", 1.9, 0.95), (1, "contact", 1.9, 0.95), (2, "glued", 2.9, 1.9),
                          (2, "contact", 2.9, 1.9)])
def test_steady_convergence(order, interface, l2_min, h1_min):
    res = steady(order, interface)
    print_table(f"steady P{order} {interface}: L2 (K m) and H1 seminorm (K) errors, right region maxh = "
                f"{res['ratio']} h", HS, {"L2": res["l2"], "H1": res["h1"]})
    print(f"fitted orders: L2 {res['order_l2']:.3f}, H1 {res['order_h1']:.3f}; dofs {res['ndofs']}")
    assert res["order_l2"] >= l2_min
    assert res["order_h1"] >= h1_min


@pytest.mark.parametrize("order", [1, 2])
def test_contact_matches_glued(order):
    glued, contact = steady(order, "glued"), steady(order, "contact")
    ratios = {key: [c / g for c, g in zip(contact[key], glued[key])] for key in ("l2", "h1")}
    print_table(f"steady P{order}: contact / glued error ratio (same mesh sizes, non-matching at x = 0.5)",
                HS, {"L2 glued": glued["l2"], "L2 contact": contact["l2"],
                     "H1 glued": glued["h1"], "H1 contact": contact["h1"]})
    print(f"ratios L2 {[round(r, 3) for r in ratios['l2']]}, H1 {[round(r, 3) for r in ratios['h1']]}")
    assert max(ratios["l2"] + ratios["h1"]) < 1.2
    assert abs(contact["order_l2"] - glued["order_l2"]) < 0.2
    assert abs(contact["order_h1"] - glued["order_h1"]) < 0.2


@pytest.mark.parametrize("scheme, interface, order_min",
                         [("backward_euler", "glued", 0.9), ("crank_nicolson", "glued", 1.9),
                          ("backward_euler", "contact", 0.9),
                          ("crank_nicolson", "contact", 1.9)])
def test_transient_time_order(scheme, interface, order_min):
    res = mms.transient_convergence(scheme, DTS, interface=interface)
    print_table(f"transient {scheme} ({interface}, P2, maxh {res['maxh']}, {res['ndofs'][0]} dofs): "
                f"L2 error (K m) at t = {res['t_end']} s", DTS, {"L2": res["l2"]}, hname="dt")
    print(f"fitted order {res['order']:.3f}")
    assert res["order"] >= order_min


def test_crank_nicolson_startup_keeps_second_order():
    """Two backward Euler start-up steps (time.startup_steps = 2) keep Crank-Nicolson second order."""
    res = mms.transient_convergence("crank_nicolson", DTS, startup_steps=2)
    plain = mms.transient_convergence("crank_nicolson", DTS)
    print(f"CN with 2 BE start-up steps: L2 {[f'{e:.3e}' for e in res['l2']]}, order {res['order']:.3f}; "
          f"plain CN order {plain['order']:.3f}")
    assert res["order"] >= 1.9


def test_crank_nicolson_startup_damps_a_switched_on_boundary_value(tmp_path):
    """A boundary value switched on at t = 0 with steps far above the element diffusion time: plain
    Crank-Nicolson overshoots and alternates (measured: 1.61, 0.33, 1.49, ... at the first node), with two
    backward Euler steps first the nodal values stay within [0, 1] (maximum principle) and rise monotonically."""
    from ngs_geomech import api
    from ngs_geomech.scene.parse import scene_from_dict

    data = {"scene": {"name": "cn_slab", "dimension": "plane"}, "physics": {"thermal": "transient"},
            "mesh": {"maxh": 0.05, "order": 1},
            "blocks": [{"name": "slab", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 0.05],
                        "boundaries": {"left": "xmin", "right": "xmax"}}],
            "materials": {"slab": {"conductivity": 1.0, "rho_c": 1.0}},
            "boundary_conditions": {"left": {"temperature": 1.0}, "right": {"temperature": 0.0}},
            "initial": {"temperature": 0.0},
            "time": {"end": 2.0, "dt": 0.1, "scheme": "crank_nicolson"},
            "output": {"vtk": False, "figures": False,
                       "probes": [{"name": "near", "point": [0.05, 0.025]},
                                  {"name": "max", "region": "slab", "statistic": "max"}]}}
    out = {}
    for n in (0, 2):
        data["time"]["startup_steps"] = n
        r = api.run(scene_from_dict(data), None, progress=False, threads=1)
        out[n] = r.summary["probe_series"]
        print(n, [round(v, 4) for v in out[n]["near"][:8]], max(out[n]["max"]))
    assert max(out[0]["max"]) > 1.5                       # plain CN: the oscillation this guards against
    assert max(out[2]["max"]) <= 1.0 + 1e-12
    near = np.array(out[2]["near"])
    assert np.all(np.diff(near[:6]) > 0)


@pytest.mark.parametrize("order, l2_min, nodal_tol", [(1, 1.8, 1e-2), (2, 2.7, 1e-4)])
def test_kirchhoff_slab(order, l2_min, nodal_tol):
    res = mms.kirchhoff_slab(order)
    print_table(f"Kirchhoff slab P{order}, k = k0 (1 + {res['b']} T), T 0 -> 100 K "
                f"(nonlinear effect {res['nonlinear_effect']:.2f} K)", res["h"],
                {"max nodal": res["max_nodal"], "max line": res["max_sampled"], "L2": res["l2"]})
    print(f"fitted orders: max nodal {res['order_max_nodal']:.3f}, max line {res['order_max_sampled']:.3f}, "
          f"L2 {res['order_l2']:.3f}; Newton iterations {res['newton_iterations']}")
    assert res["nonlinear_effect"] > 5.0
    assert res["order_l2"] >= l2_min
    assert res["order_max_sampled"] >= l2_min
    assert res["max_nodal"][-1] < nodal_tol
    assert res["max_nodal"][-1] < res["max_nodal"][0] / 4
    assert max(res["newton_iterations"]) <= 8
