"""3D contact operators (ngs_geomech.contact.forms3d): segment-based dual mortar on non-matching tetrahedral
meshes, solved by ContactSolver. The patch test (two stacked boxes meshed independently, uniform pressure:
the nodal contact pressures must equal p), a floating block held only by a rigid plane foundation across an
initial gap, the clipping geometry (covered area, gaps, rigid translations) and bad input. Figures are
printed (pytest -s)."""

from __future__ import annotations

import time

import ngsolve as ngs
import numpy as np
import pytest
from netgen.occ import Axis, Box, Compound, Dir, OCCGeometry, Pnt, X, Y, Z

from ngs_geomech.contact.forms3d import contact_operator_3d
from ngs_geomech.contact.solver import ContactLaw, ContactSolver, nodal_modulus
from ngs_geomech.fem.coefficients import expression_function
from ngs_geomech.mechanics.forms import ElasticForms, ElasticSetup
from ngs_geomech.mechanics.materials import ElasticProperties, isotropic
from ngs_geomech.mechanics.solver import ElasticSolver

pytestmark = pytest.mark.usefixtures("one_thread")

E, NU, P = 10e9, 0.25, 1e6


def _props(regions):
    return {r: ElasticProperties(C=isotropic(E, NU), alpha=np.zeros((3, 3)), beta=np.zeros((3, 3))) for r in regions}


def _system(mesh, setup):
    """Forms, bulk matrix, load, free-dof mask and Dirichlet vector of the linear problem."""
    forms = ElasticForms(mesh, setup)
    ElasticSolver(forms).set_dirichlet()
    forms.u_frozen.vec[:] = 0.0
    forms.secant_form.Assemble()
    forms.secant_rhs.Assemble()
    free = np.array(list(forms.X.FreeDofs()), dtype=bool)
    return (forms, forms.secant_form.mat, np.array(forms.secant_rhs.vec.FV().NumPy()), free,
            np.array(forms.gf.vec.FV().NumPy()))


def _translation(V, direction) -> np.ndarray:
    g = ngs.GridFunction(V)
    g.Set(ngs.CoefficientFunction(tuple(float(c) for c in direction)))
    return np.array(g.vec.FV().NumPy())


def _name_box(box, prefix):
    box.faces.Min(X).name = "xsym"
    box.faces.Min(Y).name = "ysym"
    box.faces.Min(Z).name = f"{prefix}_bottom"
    box.faces.Max(Z).name = f"{prefix}_top"
    box.faces.Max(X).name = "xfree"
    box.faces.Max(Y).name = "yfree"


def _stacked_boxes(h_lower, h_upper, shift=(0.0, 0.0, 0.0)):
    lower = Box(Pnt(0, 0, 0), Pnt(1, 1, 0.5))
    s = shift
    upper = Box(Pnt(s[0], s[1], 0.5 + s[2]), Pnt(1 + s[0], 1 + s[1], 1 + s[2]))
    _name_box(lower, "lower")
    _name_box(upper, "upper")
    lower.solids.name, upper.solids.name = "lower", "upper"
    lower.solids.maxh, upper.solids.maxh = h_lower, h_upper
    return ngs.Mesh(OCCGeometry(Compound([lower, upper])).GenerateMesh(maxh=max(h_lower, h_upper)))


def patch_test_3d(order, h_lower=0.35, h_upper=0.25):
    """Two boxes [0,1]^2 x [0,0.5] and [0,1]^2 x [0.5,1] meshed independently, symmetry on x = 0, y = 0 (both)
    and z = 0 (lower), frictionless contact (multipliers on the upper box's bottom), pressure P on top."""
    mesh = _stacked_boxes(h_lower, h_upper)
    props = _props(["lower", "upper"])
    setup = ElasticSetup(props=props, model="3d", order=order, symmetry=["xsym", "ysym", "lower_bottom"])
    setup.pressure["upper_top"] = expression_function(P)
    forms, K, f, free, x0 = _system(mesh, setup)
    tic = time.perf_counter()
    op = contact_operator_3d(mesh, forms.V, "patch", "upper_bottom", "lower_top")
    assembly = time.perf_counter() - tic
    floating = forms.floating_bodies()
    solver = ContactSolver([(op, ContactLaw())], modulus=nodal_modulus(props), floating=floating)
    u, info = solver.solve(K, f, free, x0, "3D patch test")
    lam_n, _ = solver.multipliers[0]
    keep = op.coverage > 1 - 1e-6
    # the contact force on the upper box (its free z translation): -int p n dA = +P
    upper = np.abs(floating[0].modes[:op.Bn.shape[1], 0]) > 0
    force = float((_translation(forms.V, (0, 0, 1)) * upper) @ (op.Bn.T @ lam_n))
    return {"max_deviation": float(np.max(np.abs(lam_n[keep] - P)) / P),
            "force_balance": abs(float(np.dot(op.weight, lam_n)) - P) / P, "force_bn": abs(force - P) / P,
            "max_penetration": info.max_penetration, "iterations": info.iterations, "nodes": int(keep.sum()),
            "floating": [n for b in floating for n in b.names], "assembly_s": assembly, "ndof": forms.X.ndof,
            "wall_s": info.wall_s}


@pytest.mark.parametrize("order", [1, 2])
def test_patch_test_3d_non_matching(order):
    r = patch_test_3d(order)
    print(f"\n3D patch test P{order}: max |lam_n - p|/p = {r['max_deviation']:.2e}, force balance "
          f"{r['force_balance']:.1e} (Bn^T lam {r['force_bn']:.1e}), penetration {r['max_penetration']:.1e} m, "
          f"{r['iterations']} iterations, {r['nodes']} nodes, {r['ndof']} dofs, operator {r['assembly_s']:.3f} s, "
          f"solve {r['wall_s']:.2f} s")
    assert r["floating"] == ["translation along z"]
    assert r["nodes"] >= 10
    assert r["max_deviation"] < 1e-8
    assert r["force_balance"] < 1e-8
    assert r["force_bn"] < 1e-8
    assert r["max_penetration"] < 1e-14


def test_floating_block_on_rigid_plane_across_a_gap():
    """A block with no support but a rigid plane z = 0 below it (initial gap 1 mm, uniform top pressure):
    all six rigid motions are free; the contact holds the translation along z and the rotations about x and y,
    the sideways motions are unloaded. The gap closes (the bottom moves down by the gap), the nodal pressures
    are p and the contact forces balance the load."""
    gap = 1e-3
    box = Box(Pnt(0, 0, gap), Pnt(1, 0.8, 0.4 + gap))
    box.faces.Min(Z).name = "bottom"
    box.faces.Max(Z).name = "top"
    box.solids.name = "block"
    mesh = ngs.Mesh(OCCGeometry(box).GenerateMesh(maxh=0.3))
    props = _props(["block"])
    setup = ElasticSetup(props=props, model="3d", order=1)
    setup.pressure["top"] = expression_function(P)
    forms, K, f, free, x0 = _system(mesh, setup)
    floating = forms.floating_bodies()
    assert len(floating) == 1 and len(floating[0].names) == 6
    op = contact_operator_3d(mesh, forms.V, "foundation", "bottom", None, obstacle=((0, 0, 0), (0, 0, 1)))
    assert np.allclose(op.g0 / op.weight, gap, rtol=1e-12) and np.all(op.coverage > 1 - 1e-12)
    solver = ContactSolver([(op, ContactLaw())], modulus=nodal_modulus(props), floating=floating)
    u, info = solver.solve(K, f, free, x0, "3D floating block")
    lam_n, _ = solver.multipliers[0]
    load = P * 0.8
    normal_force = float(np.dot(op.weight, lam_n))
    fz = float(_translation(forms.V, (0, 0, 1)) @ (op.Bn.T @ lam_n))
    uz = u[2 * (forms.V.ndof // 3) + op.nodes]       # z displacement of the bottom vertices (P1: vertex dofs)
    print(f"\n3D floating block on a plane: normal force {normal_force:.10e} N (load {load:.10e}), max |lam - p|/p "
          f"{np.max(np.abs(lam_n - P)) / P:.1e}, bottom u_z + gap {np.max(np.abs(uz + gap)):.1e} m, "
          f"{info.iterations} iterations")
    assert normal_force == pytest.approx(load, rel=1e-8)
    assert fz == pytest.approx(load, rel=1e-8)
    assert np.max(np.abs(lam_n - P)) < 1e-8 * P
    assert np.max(np.abs(uz + gap)) < 1e-10


@pytest.mark.parametrize("order", [1, 2])
def test_rotated_stack_on_tilted_foundation(order):
    """The two stacked boxes (independent meshes) rotated by 25 degrees about (1, 2, 3), with no support but
    a rigid plane under the lower box (normal R e_z): two frictionless interfaces, both bodies floating (12
    rigid motions, 6 of them unloaded). Oblique normals and tangents; the exact pressure is p on both."""
    lower = Box(Pnt(0, 0, 0), Pnt(1, 1, 0.5))
    upper = Box(Pnt(0, 0, 0.5), Pnt(1, 1, 1))
    _name_box(lower, "lower")
    _name_box(upper, "upper")
    lower.solids.name, upper.solids.name = "lower", "upper"
    lower.solids.maxh, upper.solids.maxh = 0.35, 0.25
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    angle = 25.0
    shape = Compound([lower, upper]).Rotate(Axis(Pnt(0, 0, 0), Dir(*axis)), angle)
    mesh = ngs.Mesh(OCCGeometry(shape).GenerateMesh(maxh=0.35))
    th = np.radians(angle)
    Kx = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    normal = (np.eye(3) + np.sin(th) * Kx + (1 - np.cos(th)) * Kx @ Kx) @ np.array([0.0, 0.0, 1.0])
    props = _props(["lower", "upper"])
    setup = ElasticSetup(props=props, model="3d", order=order)
    setup.pressure["upper_top"] = expression_function(P)
    forms, K, f, free, x0 = _system(mesh, setup)
    floating = forms.floating_bodies()
    assert [len(b.names) for b in floating] == [6, 6]
    found = contact_operator_3d(mesh, forms.V, "foundation", "lower_bottom", None, obstacle=((0, 0, 0), normal))
    pair = contact_operator_3d(mesh, forms.V, "pair", "upper_bottom", "lower_top")
    solver = ContactSolver([(found, ContactLaw()), (pair, ContactLaw())], modulus=nodal_modulus(props),
                           floating=floating)
    u, info = solver.solve(K, f, free, x0, "rotated stack")
    for op, (lam_n, _) in zip((found, pair), solver.multipliers):
        keep = op.coverage > 1 - 1e-6
        dev = float(np.max(np.abs(lam_n[keep] - P)) / P)
        bal = abs(float(np.dot(op.weight, lam_n)) - P) / P
        print(f"\nrotated stack P{order}, {op.name}: {keep.sum()} nodes, max |lam_n - p|/p = {dev:.1e}, force "
              f"balance {bal:.1e}, {info.iterations} iterations")
        assert keep.sum() >= 10
        assert dev < 1e-8
        assert bal < 1e-8
    assert info.max_penetration < 1e-14


@pytest.mark.parametrize("order", [1, 2])
def test_clipping_covers_the_overlap(order):
    """Upper box shifted by (0.3, 0.2) and lifted by a gap: the covered area is the overlap 0.7 x 0.8, the
    nodal gaps of the covered nodes are the gap, and rigid translations produce no gap or slip."""
    gap = 0.01
    mesh = _stacked_boxes(0.3, 0.2, shift=(0.3, 0.2, gap))
    V = ngs.VectorH1(mesh, order=order)
    tic = time.perf_counter()
    op = contact_operator_3d(mesh, V, "shifted", "upper_bottom", "lower_top")
    wall = time.perf_counter() - tic
    full = op.coverage > 1 - 1e-12
    print(f"\nclipping P{order}: {op.size} nodes ({full.sum()} covered), covered area "
          f"{np.dot(op.coverage, op.weight):.15f}, operator {wall:.3f} s")
    assert np.dot(op.coverage, op.weight) == pytest.approx(0.7 * 0.8, rel=1e-12)
    assert np.sum(op.weight) == pytest.approx(1.0, rel=1e-12)
    assert np.max(op.coverage) < 1 + 1e-12 and np.min(op.coverage) == 0.0
    assert np.allclose(op.g0[full] / op.weight[full], gap, rtol=1e-10)
    for d in np.eye(3):
        t = _translation(V, d)
        for B in (op.Bn, op.Bt, op.Bt2):
            assert np.max(np.abs(B @ t)) < 1e-14
    # u = (0, 0, z): the rays go down by the gap, so (u(x_o) - u(x)).n = gap on the covered part
    g = ngs.GridFunction(V)
    g.Set(ngs.CoefficientFunction((0.0, 0.0, ngs.z)))
    assert np.allclose((op.Bn @ g.vec.FV().NumPy())[full], gap * op.weight[full], rtol=1e-10)


@pytest.mark.parametrize("side,opposite,match", [
    ("", "lower_top", "contact side boundary name '' is empty"),
    ("upper_bottom", " ", "opposite boundary name ' ' is empty"),
    ("nothing_here", "lower_top", "contact side boundary 'nothing_here' has no boundary elements"),
    ("upper_bottom", "no_such_face", "opposite boundary 'no_such_face' has no boundary elements"),
])
def test_bad_boundary_names_raise(side, opposite, match):
    mesh = _stacked_boxes(0.6, 0.6)
    V = ngs.VectorH1(mesh, order=1)
    with pytest.raises(ValueError, match=match):
        contact_operator_3d(mesh, V, "bad", side, opposite)
