"""Adaptivity (issue 6): estimators and markers by name, effectivity indices on manufactured solutions, the
re-entrant corner (uniform dofs^(-1/3) against adaptive dofs^(-1/2)), curved boundaries after refinement, and
Hertz contact refined adaptively against uniformly."""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech.adapt import estimators as est
from ngs_geomech.adapt.loop import StationaryHeat, Transfer, adaptive_solve, refine_mesh, transfer_contact_sets
from ngs_geomech.adapt.marking import MARKERS, StopRule, doerfler, get_marker, maximum
from ngs_geomech.verification import adaptivity as ad
from ngs_geomech.verification import contact_problems as cp

pytestmark = pytest.mark.usefixtures("one_thread")


# -- registries and markers --------------------------------------------------------------------------------

def test_registries_by_name():
    assert {"zz", "residual", "contact_zone", "phase_front"} <= set(est.ESTIMATORS)
    assert {"doerfler", "maximum", "uniform"} <= set(MARKERS)
    assert est.get_estimator("zz").kind == "estimator"
    assert est.get_estimator("contact_zone").kind == "indicator"
    with pytest.raises(ValueError, match="did you mean 'residual'"):
        est.get_estimator("residul")
    with pytest.raises(ValueError, match="did you mean 'doerfler'"):
        get_marker("dorfler")


def test_markers_and_stop_rule():
    eta = np.array([4.0, 3.0, 2.0, 1.0, 0.5])
    # eta^2 = 16, 9, 4, 1, 0.25 (sum 30.25): half needs 16 (0.53), 0.8 needs 16 + 9 (0.83)
    assert doerfler(eta, 0.5).tolist() == [True, False, False, False, False]
    assert doerfler(eta, 0.8).tolist() == [True, True, False, False, False]
    assert doerfler(eta, 1.0).all()
    assert maximum(eta, 0.5).tolist() == [True, True, True, False, False]
    assert not doerfler(np.zeros(3), 0.5).any()
    with pytest.raises(ValueError, match="theta"):
        doerfler(eta, 0.0)
    rule = StopRule(tolerance=1e-2, max_dofs=1000, max_refinements=5)
    assert rule.reason(5e-3, 10, 0) == "tolerance"
    assert rule.reason(1.0, 400, 1, growth=3.0) == "dof budget"
    assert rule.reason(1.0, 100, 5) == "refinements"
    assert rule.reason(1.0, 100, 1, growth=2.0) is None


@pytest.mark.parametrize("name", sorted(est.ESTIMATORS))
def test_every_registered_estimator_runs(name):
    """Each registered estimator or indicator, on the input it declares, gives one finite value per element."""
    entry = est.get_estimator(name)
    if entry.needs == "forms":
        problem = ad.corner_problem(maxh=0.5)
        problem.solve()
        source = problem.estimator_input("forms")
    elif entry.needs == "contact":
        problem = ad.HertzAdaptive(cp.R_HERTZ / 50, order=1)
        problem.solve()
        source = problem.estimator_input("contact")
    else:
        mesh = ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.2))
        source = ngs.GridFunction(ngs.H1(mesh, order=1))
        source.Set(ngs.x)
    out = entry.function(source)
    assert out.kind == entry.kind and out.eta.shape == (problem.mesh.ne if entry.needs != "phase" else
                                                        source.space.mesh.ne,)
    assert np.all(np.isfinite(out.eta)) and out.total > 0


# -- effectivity indices -------------------------------------------------------------------------------------

def test_effectivity_indices_p1():
    res = ad.effectivities(order=1, hs=(0.2, 0.1, 0.05))
    for physics in ("heat", "elastic"):
        r = res[physics]
        for name in ("zz", "residual"):
            print(f"\n{physics} P1 {name}: effectivity " + ", ".join(f"{v:.3f}" for v in r[name])
                  + " at dofs " + ", ".join(str(d) for d in r["ndof"]))
            assert all(0.5 <= v <= 3.0 for v in r[name]), (physics, name, r[name])
        # the energy errors converge at order 1 in h
        assert 0.9 < math.log(r["error"][0] / r["error"][-1]) / math.log(4.0) < 1.15


@pytest.mark.parametrize("order", [2, 3])
def test_effectivity_indices_higher_order(order):
    """P2 and P3: both estimators in [0.5, 3]; ZZ (superconvergent patch recovery, the default for p >= 2)
    measured 1.017, 1.012, 1.025 heat and 1.018, 1.013, 1.019 elastic for P2 at h = 0.2, 0.1, 0.05 (the
    averaging recovery: 0.63, 0.50, 0.43 and 0.70, 0.63, 0.56, falling with h); P3 1.34, 1.21, 1.05 heat and
    1.06, 1.08, 1.02 elastic. The residual estimator: P2 1.64-1.73, P3 1.73-1.96."""
    res = ad.effectivities(order=order, hs=(0.2, 0.1, 0.05))
    for physics in ("heat", "elastic"):
        r = res[physics]
        print(f"\n{physics} P{order}: zz " + ", ".join(f"{v:.3f}" for v in r["zz"]) + "; residual "
              + ", ".join(f"{v:.3f}" for v in r["residual"]))
        assert all(0.5 <= v <= 3.0 for v in r["residual"]), (physics, r["residual"])
        assert all(0.5 <= v <= 3.0 for v in r["zz"]), (physics, r["zz"])
        if order == 2:                                   # no drift with h, close to 1
            assert all(0.9 <= v <= 1.2 for v in r["zz"]), (physics, r["zz"])


@pytest.mark.parametrize("dim", [2, 3])
def test_spr_recovery_reproduces_polynomials(dim):
    """The patch recovery of degree p is exact for fields of degree p (eta = 0 up to round-off), on the inner
    and the widened boundary patches, in 2D and 3D; a smooth field's estimate falls with p."""
    from netgen.occ import Box, OCCGeometry, Pnt
    mesh = ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.25)) if dim == 2 else \
        ngs.Mesh(OCCGeometry(Box(Pnt(0, 0, 0), Pnt(1, 1, 1))).GenerateMesh(maxh=0.4))
    X = (ngs.x, ngs.y, ngs.z)[:dim]
    one, metric = ngs.CoefficientFunction(1.0), np.eye(dim)
    smooth = ngs.CoefficientFunction(tuple(ngs.sin(3 * X[0]) * ngs.exp((k + 1) * X[1]) for k in range(dim)))
    region = mesh.Materials(".*")
    last = math.inf
    for p in (1, 2, 3):
        poly = ngs.CoefficientFunction(tuple((X[0] + 2 * X[1] - 0.5) ** p + (k + 1) * X[-1] ** p for k in range(dim)))
        assert math.sqrt(est._spr_eta2(mesh, poly, region, p, one, metric).sum()) < 1e-11
        eta = math.sqrt(est._spr_eta2(mesh, smooth, region, p, one, metric).sum())
        assert 0 < eta < 0.5 * last
        last = eta
    with pytest.raises(ValueError, match="recovery"):
        est._recovery_kind(2, "patch")


# -- re-entrant corner ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("estimator", ["zz", "residual"])
def test_corner_adaptive_reaches_optimal_order(estimator):
    r = ad.corner_convergence(estimator=estimator, uniform_levels=4, max_dofs=8000)
    for kind in ("uniform", "adaptive"):
        s = r[kind]
        print(f"\ncorner {estimator} {kind}: order {s['fitted_order']:.3f}; dofs "
              + ", ".join(str(d) for d in s["ndof"]) + "; errors " + ", ".join(f"{e:.3e}" for e in s["error"]))
    assert 0.28 < r["order_uniform"] < 0.40          # h^(2/3) = dofs^(-1/3)
    assert 0.45 < r["order_adaptive"] < 0.60         # optimal P1: dofs^(-1/2)
    eff = r["adaptive"]["effectivity"] + r["uniform"]["effectivity"]
    assert all(0.5 <= e <= 3.0 for e in eff), eff
    # the adaptive mesh beats the finest uniform one with fewer dofs
    a, u = r["adaptive"], r["uniform"]
    k = next(i for i, e in enumerate(a["error"]) if e <= u["error"][-1])
    assert a["ndof"][k] < 0.5 * u["ndof"][-1]


def test_corner_energy_error_by_orthogonality_matches_quadrature():
    problem = ad.corner_problem(maxh=0.25)
    problem.solve()
    _, g = ad.corner_exact()
    e = ngs.grad(problem.forms.temperature()) - g
    direct = math.sqrt(float(ngs.Integrate(e * e, problem.mesh, order=12)))
    assert abs(ad.corner_energy_error(problem) / direct - 1) < 0.02


# -- refinement: curved boundaries, transfer ---------------------------------------------------------------

def test_curved_boundary_exact_after_refinement():
    R, a = cp.R_HERTZ, cp.R_HERTZ / 50
    mesh = cp.hertz_mesh(a, order=1)
    area = math.pi * R ** 2 / 4     # the quarter disc
    marks = np.zeros(mesh.ne, dtype=bool)
    marks[::2] = True
    for _ in range(2):
        refine_mesh(mesh, marks if len(marks) == mesh.ne else np.ones(mesh.ne, bool), curve_order=2)
    radii = [math.hypot(mesh[v].point[0], mesh[v].point[1] - R)
             for el in mesh.Boundaries("contact").Elements() for v in el.vertices]
    assert max(abs(r - R) for r in radii) < 1e-12
    assert abs(float(ngs.Integrate(ngs.CoefficientFunction(1.0), mesh)) / area - 1) < 1e-6
    # without curving again the refined mesh has straight boundary elements: a worse area
    plain = cp.hertz_mesh(a, order=1)
    refine_mesh(plain, np.ones(plain.ne, bool), curve_order=0)
    err_plain = abs(float(ngs.Integrate(ngs.CoefficientFunction(1.0), plain)) / area - 1)
    assert err_plain > 10 * abs(float(ngs.Integrate(ngs.CoefficientFunction(1.0), mesh)) / area - 1)


def test_transfer_keeps_p2_field_and_start():
    mesh = ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.3))
    g = ngs.GridFunction(ngs.H1(mesh, order=2))
    g.Set(ngs.x * ngs.x + ngs.x * ngs.y)
    keep = Transfer(mesh, 2, g.vec.FV().NumPy())
    refine_mesh(mesh, np.arange(mesh.ne) % 3 == 0)
    h = ngs.GridFunction(ngs.H1(mesh, order=2))
    h.vec.FV().NumPy()[:] = keep.vector(mesh)
    assert math.sqrt(float(ngs.Integrate((h - ngs.x * ngs.x - ngs.x * ngs.y) ** 2, mesh))) < 1e-12
    old = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    sets = (np.array([True, True, False]), np.zeros(3, bool), np.array([False, True, False]))
    new = transfer_contact_sets(old, sets, np.array([[0.1, 0.0], [0.9, 0.0], [1.8, 0.0]]))
    assert new[0].tolist() == [True, True, False] and new[2].tolist() == [False, True, False]


def test_stationary_heat_loop_stops_at_tolerance():
    problem = ad.corner_problem(maxh=0.5)
    run = adaptive_solve(problem, estimator="zz", marker="maximum", theta=0.5, stop=StopRule(tolerance=0.05))
    assert run.stop == "tolerance" and run.steps[-1].estimate <= 0.05 < run.steps[-2].estimate
    assert all(s.ndof < t.ndof for s, t in zip(run.steps, run.steps[1:]))
    with pytest.raises(ValueError, match="indicator"):
        adaptive_solve(problem, estimator="contact_zone")
    assert isinstance(problem, StationaryHeat)


def test_adaptive_heat_across_a_mortar_contact_interface():
    """The loop rebuilds the mortar coupling on each refined mesh (independent meshes on the two sides)."""
    from ngs_geomech.verification import manufactured as mms
    sol = mms.steady_solution()
    mesh, forms, _ = mms.prepare_two_region(mms.two_region_scene(sol, 0.2, 1, "contact", 0.7), sol)
    problem = StationaryHeat(mesh, forms.setup)
    errors = []

    def record(step, prob):
        grads = {r: sol.gradient(r, prob.forms.t_new) for r in mms.REGIONS}
        errors.append((step.ndof, est.heat_energy_error(prob.forms, grads), step.estimate))
    adaptive_solve(problem, estimator="residual", stop=StopRule(max_refinements=3), callback=record)
    print("\nmortar interface, adaptive: " + ", ".join(f"{n} dofs {e:.3e} (eff {s / e:.2f})" for n, e, s in errors))
    assert errors[-1][1] < 0.6 * errors[0][1]
    assert all(0.5 <= s / e <= 3.0 for _, e, s in errors)


# -- indicators ----------------------------------------------------------------------------------------------

def test_phase_front_indicator():
    mesh = ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.1))
    lf = ngs.GridFunction(ngs.H1(mesh, order=1))
    lf.Set(ngs.x)
    flags = est.phase_front(lf, layers=0).eta > 0
    xy = np.array([[mesh[v].point for v in el.vertices] for el in mesh.Elements(ngs.VOL)])
    crosses = (xy[:, :, 0].min(axis=1) < 0.5) & (xy[:, :, 0].max(axis=1) > 0.5)
    assert np.array_equal(flags, crosses)
    wider = est.phase_front(lf, layers=1).eta > 0
    assert wider.sum() > flags.sum() and np.all(wider[flags])


def test_contact_zone_indicator_flags_the_edge_of_contact():
    problem = ad.HertzAdaptive(cp.R_HERTZ / 50 / 8, order=1)
    problem.solve()
    mesh, pairs = problem.estimator_input("contact")
    op, status = pairs[0]
    edge = est.contact_zone((mesh, pairs)).eta > 0
    zone = est.contact_zone((mesh, pairs), active=True).eta > 0
    assert 0 < edge.sum() < zone.sum() and np.all(zone[edge])
    centres = np.array([np.mean([mesh[v].point for v in el.vertices], axis=0) for el in mesh.Elements(ngs.VOL)])
    a_num = problem.result["a_num"]
    assert np.all(np.abs(centres[edge, 0] - a_num) < 3 * problem.result["h"])


def test_contact_zone_indicator_on_the_whole_mesh_numbers_nodes_by_coordinates():
    """The distributed run's path (:mod:`ngs_geomech.adapt.distributed`) on one process: operators whose nodes
    are numbered otherwise (as the gathered sides of a distributed mesh are) are renumbered to the mesh's vertices
    by their coordinates, and the indicator then flags what it flags on the mesh itself; a node off the side
    stops it."""
    import dataclasses

    from ngs_geomech.adapt.distributed import whole_mesh_contacts

    problem = ad.HertzAdaptive(cp.R_HERTZ / 50 / 8, order=1)
    problem.solve()
    mesh, pairs = problem.estimator_input("contact")
    op, status = pairs[0]
    order = np.random.default_rng(1).permutation(op.size)       # another numbering and order of the nodes
    moved = dataclasses.replace(op, nodes=10 ** 6 + np.arange(op.size), coords=op.coords[order])
    renumbered = whole_mesh_contacts(mesh, [(moved, status[order])])
    assert np.array_equal(renumbered[0][0].nodes, op.nodes[order])
    for options in ({}, {"active": True, "layers": 1}):
        want = est.contact_zone((mesh, pairs), **options)
        got = est.contact_zone(est.WholeMesh(mesh, renumbered), **options)
        assert got.whole and not want.whole and np.array_equal(got.eta, want.eta)
    assert est.contact_zone(est.WholeMesh(None, []), layers=1).eta.shape == (0,)
    off = op.coords.copy()
    off[0] += 1e-3
    with pytest.raises(RuntimeError, match="do not match"):
        whole_mesh_contacts(mesh, [(dataclasses.replace(op, coords=off), status)])


# -- Hertz: adaptive against uniform ----------------------------------------------------------------------

def test_hertz_adaptive_against_uniform():
    r = ad.hertz_convergence(order=1, h_contact_over_a=0.5, uniform_levels=4, max_dofs=6000, reference_dofs=25000,
                             options={"contact_zone": {"active": True}})
    u, a = r["uniform"], r["adaptive"]
    for kind, s in (("uniform", u), ("adaptive", a)):
        print(f"\nHertz {kind}: dofs " + ", ".join(str(d) for d in s["ndof"]) + "; p0 error (reference) "
              + ", ".join(f"{e:.2e}" for e in s["p0_ref_error"]) + "; half width " +
              ", ".join(f"{e:.2e}" for e in s["a_error"]))
    hit = ad.reach_ratios(u, a, "p0_ref_error")
    print(f"adaptive reaches the finest uniform p0 error with {hit['dof_ratio']:.3f} of its dofs, "
          f"{hit['time_ratio']:.2f} of its solve time")
    assert hit["dof_ratio"] <= 0.2
    assert abs(r["p0_ref"] / r["p0"] - 1) < 5e-3        # the finite cylinder against the half space: ~2-3e-3
    assert max(a["iterations"][1:]) <= 3                  # warm starts from the coarser active set
    assert a["a_error"][-1] < 0.02
