"""Frictional contact of problem (P), (2.23)-(2.27): the dual mortar operators and the primal-dual active set
solver against exact answers (ngs_geomech.verification.contact_problems): the patch test on non-matching
meshes, Hertz line contact (verification.md section 2), and Tresca/Coulomb friction on a block that sticks
below and slides at its capacity. Errors are printed (pytest -s)."""

from __future__ import annotations

import pytest

from ngs_geomech.verification import contact_problems as cp


@pytest.mark.parametrize("order", [1, 2])
def test_patch_test_non_matching(one_thread, order):
    r = cp.patch_test(order=order)
    print(f"\npatch test P{order}: max |lam_n - p|/p = {r['max_deviation']:.2e}, force balance "
          f"{r['force_balance']:.1e}, penetration {r['max_penetration']:.1e} m, {r['iterations']} iterations")
    assert r["nodes"] >= 10
    assert r["max_deviation"] < 1e-8
    assert r["force_balance"] < 1e-8
    assert r["max_penetration"] < 1e-14


@pytest.mark.parametrize("order,h_over_a", [(2, 0.1), (1, 0.025)])
def test_hertz_line_contact(one_thread, order, h_over_a):
    r = cp.hertz(h_over_a * cp.R_HERTZ / 50, order)
    print(f"\nHertz P{order}, h = {h_over_a} a: p0 error {r['p0_rel_error']:+.2%}, a_num {r['a_num']:.5f} "
          f"(a {r['a']:.5f}, h {r['h']:.1e}), profile error {r['profile_max_error']:.2%} of p0 (x < 0.9 a), "
          f"force balance {r['force_balance']:.1e}, {r['iterations']} iterations ({r['penalty_iterations']} "
          f"penalty), {r['ndof']} dofs")
    assert abs(r["p0_rel_error"]) < 0.03
    assert r["a_error"] <= 1.01 * r["h"]
    assert r["profile_max_error"] < 0.05
    assert r["force_balance"] < 1e-8
    assert r["max_penetration"] < 1e-12
    assert r["iterations"] <= 15


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_friction_block_sticks_below_capacity(one_thread, law):
    r = cp.friction_block("traction", law=law, ratio=0.5)
    print(f"\n{law} block pushed at half capacity: friction {r['friction_force']:.6e} N/m = applied "
          f"{r['applied']:.6e}; {r['stick']} stick, {r['slip']} slip nodes, {r['iterations']} iterations")
    assert r["friction_force"] == pytest.approx(r["applied"], rel=1e-8)
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)
    assert r["stick"] > 0
    assert abs(r["friction_force"]) < r["capacity"]


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_friction_block_slides_at_capacity(one_thread, law):
    r = cp.friction_block("displacement", law=law)
    print(f"\n{law} block pushed by a displacement: friction {r['friction_force']:.6e} N/m, capacity "
          f"{r['capacity']:.6e}; {r['slip']} slip nodes, {r['iterations']} iterations")
    assert r["stick"] == 0 and r["slip"] > 0
    assert r["friction_force"] == pytest.approx(r["capacity"], rel=1e-8)
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)


def test_floating_block_held_by_contact_alone(one_thread):
    """No displacement condition: the frictionless block is held by the foundation (its sideways translation
    is free but unloaded, fixed at the regularization's minimum value)."""
    r = cp.friction_block("none", law="frictionless")
    print(f"\nfloating frictionless block: normal force {r['normal_force']:.6e} N/m (load {r['load']:.6e}), "
          f"{r['iterations']} iterations")
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)


@pytest.mark.parametrize("kw,expect", [
    (dict(push="none", law="frictionless", p_top=-1e6), "translation along y is not held"),
    (dict(push="traction", law="coulomb", ratio=1.5), "translation along x is not held"),
    (dict(push="traction", law="tresca", ratio=1.1), "translation along x is not held"),
])
def test_unsolvable_floating_block_names_body_and_motion(one_thread, kw, expect):
    from ngs_geomech.errors import SolverError
    with pytest.raises(SolverError, match="body block: " + expect):
        cp.friction_block(**kw)


@pytest.mark.parametrize("order,fractions,scale_far,min_order", [
    (1, (0.2, 0.1, 0.05, 0.025), True, 0.6),
    (2, (0.4, 0.2, 0.1, 0.05), False, 0.8),
])
def test_hertz_pressure_converges(one_thread, order, fractions, scale_far, min_order):
    """The pressure inside the contact zone (x < 0.9 a) converges; the square-root edge of the Hertz pressure
    (p in H^(1/2 - eps)) limits the order to about 1 (measured 0.74 for P1, 0.94 for P2). With ``scale_far``
    the mesh away from the contact is refined too (its finer levels once tripped the solvability check,
    see ContactSolver._check_solvable)."""
    from ngs_geomech.verification.study import observed_order
    a = cp.R_HERTZ / 50
    hs, errors, iterations = [], [], []
    for f in fractions:
        r = cp.hertz(f * a, order, maxh=0.25 * f / fractions[0] if scale_far else None)
        hs.append(f * a)
        errors.append(r["pressure_l2_error"])
        iterations.append(r["iterations"])
    rate = observed_order(hs, errors)
    print(f"\nHertz P{order} pressure L2 error (x < 0.9 a) at h/a = {fractions}: "
          + ", ".join(f"{e:.2e}" for e in errors) + f"; order {rate:.2f}; iterations {iterations}")
    assert rate >= min_order
    assert errors[-1] < errors[0]
    assert max(iterations) <= 15


@pytest.mark.parametrize("kw,match", [
    (dict(kind="sticky"), "unknown contact law 'sticky'"),
    (dict(kind="tresca"), "needs a slip bound"),
    (dict(kind="tresca", slip_bound=-1.0), "slip bound g_c must be finite and >= 0"),
    (dict(kind="coulomb", friction=0.0), "positive coefficient"),
    (dict(kind="frictionless", augmentation=-5.0), "augmentation c must be positive"),
])
def test_contact_law_rejects_bad_values(kw, match):
    from ngs_geomech.solvers.contact import ContactLaw
    with pytest.raises(ValueError, match=match):
        ContactLaw(**kw)
