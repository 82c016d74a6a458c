"""Verification problems of frictional contact (seed (2.23)-(2.27)) with closed-form or exact answers, solved
by :class:`ngs_geomech.solvers.contact.ContactSolver` on the operators of :mod:`ngs_geomech.physics.contact`.

* :func:`hertz`: Hertz line contact (verification.md section 2), a quarter cylinder (symmetry on x = 0)
  pressed on a rigid flat by P per unit length, plane strain, frictionless: p0, the contact half width a and
  the pressure profile against the closed form. R = 1 m, E = 200 GPa, nu = 0.3 and P chosen so that
  a = R/50 (the note's R/a >~ 50); the contact arc is meshed with size ``h_contact``.
* :func:`friction_block`: a block (L x H) on a rigid foundation under a top pressure, pushed sideways: by a
  traction below the friction capacity (Tresca g_c L, Coulomb F_c P) it sticks (the friction force balances
  the push), by a displacement it slides (the friction force is the capacity).
* :func:`patch_test`: two blocks with non-matching meshes, frictionless, under a uniform top pressure p: the
  exact solution is a uniform stress, so the contact pressure must be p at every node.

The problems build their geometry with netgen.occ (test problems, not scenes). Every function returns a plain
dict and prints nothing. Units: m, Pa, N/m.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
from netgen.occ import ArcOfCircle, Compound, Face, OCCGeometry, Pnt, Rectangle, Segment, Wire, X, Y

from ..elastic_materials import ElasticProperties, isotropic
from ..physics.coefficients import expression_function
from ..physics.contact import contact_operator_2d
from ..physics.elasticity import ElasticForms, ElasticSetup
from ..solvers.contact import ContactLaw, ContactSolver, nodal_modulus
from ..solvers.elastic import ElasticSolver
from . import contact_closed_forms as cc

E_HERTZ, NU_HERTZ, R_HERTZ = 200e9, 0.3, 1.0


def _props(E: float, nu: float, regions) -> dict:
    return {r: ElasticProperties(C=isotropic(E, nu), alpha=np.zeros((3, 3)), beta=np.zeros((3, 3))) for r in regions}


def _system(mesh, setup: ElasticSetup):
    """Forms, assembled bulk matrix, load vector, free-dof mask and Dirichlet vector of a linear problem."""
    forms = ElasticForms(mesh, setup)
    ElasticSolver(forms).set_dirichlet()
    forms.u_frozen.vec[:] = 0.0
    forms.secant_form.Assemble()
    forms.secant_rhs.Assemble()
    free = np.array(list(forms.X.FreeDofs()), dtype=bool)
    return (forms, forms.secant_form.mat, np.array(forms.secant_rhs.vec.FV().NumPy()), free,
            np.array(forms.gf.vec.FV().NumPy()))


def _translation(forms, direction) -> np.ndarray:
    """Coefficient vector (X) of the unit rigid translation along ``direction``."""
    g = ngs.GridFunction(forms.V)
    g.Set(ngs.CoefficientFunction(tuple(float(c) for c in direction)))
    out = np.zeros(forms.X.ndof)
    out[:forms.V.ndof] = g.vec.FV().NumPy()
    return out


def hertz(h_contact: float, order: int = 1, *, method: str = "ssn", maxh: float | None = None) -> dict:
    """Hertz line contact of a quarter cylinder on a rigid flat (module docstring); ``h_contact`` (m) is the
    element size along the contact arc (the arc up to 4a from the axis), ``maxh`` (m) the size elsewhere
    (default R/4).

    Returns {"a", "p0" (closed form), "p0_num" (nodal pressure on the axis), "p0_rel_error", "a_num" (the last
    node in contact), "a_next" (the first open node), "a_error" (|a_num - a|), "h" (node spacing at a),
    "profile_max_error" (max |p - p_ref| / p0 over the nodes with x < 0.9 a), "pressure_l2_error" (the
    same region: sqrt(int (p - p_ref)^2 dx / a) / p0, trapezoidal over the nodes), "force_balance" (|int p - P/2| /
    (P/2)), "max_penetration" (m), "iterations", "penalty_iterations", "ndof", "wall_s" (contact solve),
    "x", "p", "p_ref" (nodal profile)}."""
    R, E, nu = R_HERTZ, E_HERTZ, NU_HERTZ
    E_star = cc.effective_modulus(E, nu)
    a_ref = R / 50
    P = math.pi * E_star * a_ref ** 2 / (4 * R)
    ref = cc.hertz_line(P, R, E_star)
    th = 4 * a_ref / R

    def on_circle(t):
        return Pnt(R * math.sin(t), R - R * math.cos(t), 0)

    e1 = ArcOfCircle(on_circle(0.0), on_circle(th / 2), on_circle(th))
    e2 = ArcOfCircle(on_circle(th), on_circle((th + math.pi / 2) / 2), on_circle(math.pi / 2))
    face = Face(Wire([e1, e2, Segment(Pnt(R, R, 0), Pnt(0, R, 0)), Segment(Pnt(0, R, 0), Pnt(0, 0, 0))]))
    for k, name in enumerate(("contact", "contact", "top", "sym")):
        face.edges[k].name = name
    face.edges[0].maxh = h_contact
    face.name = "cylinder"
    mesh = ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=maxh or R / 4, grading=0.25))
    mesh.Curve(max(order, 2))
    props = _props(E, nu, ["cylinder"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order, symmetry=["sym"])
    setup.traction["top"] = [expression_function(0.0), expression_function(-P / (2 * R))]
    forms, K, f, free, x0 = _system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "hertz", "contact", None, axisymmetric=False,
                             obstacle=((0.0, 0.0), (0.0, 1.0)))
    solver = ContactSolver([(op, ContactLaw())], modulus=nodal_modulus(props), method=method,
                           floating=forms.floating_bodies())
    u, info = solver.solve(K, f, free, x0, "hertz")
    lam_n, _ = solver.multipliers[0]
    x = op.coords[:, 0]
    o = np.argsort(x)
    xs, ps = x[o], lam_n[o]
    last = int(np.max(np.where(ps > 0)[0]))
    pref = cc.hertz_pressure(xs, ref.a, ref.p0)
    inner = xs < 0.9 * ref.a
    # discrete L2 error of the pressure inside the contact zone, relative: sqrt(int (p - p_ref)^2 dx / a) / p0
    l2 = math.sqrt(float(np.trapezoid((ps[inner] - pref[inner]) ** 2, xs[inner])) / ref.a) / ref.p0
    # the vertical resultant of the discrete contact forces Bn^T lam_n (on the cylinder: -int p n ds)
    force = float(_translation(forms, (0.0, 1.0))[:op.Bn.shape[1]] @ (op.Bn.T @ lam_n))
    return {"a": ref.a, "p0": ref.p0, "P": P, "p0_num": float(ps[0]), "p0_rel_error": float(ps[0] / ref.p0 - 1),
            "a_num": float(xs[last]), "a_next": float(xs[min(last + 1, len(xs) - 1)]),
            "a_error": abs(float(xs[last]) - ref.a), "h": float(xs[min(last + 1, len(xs) - 1)] - xs[last]),
            "profile_max_error": float(np.max(np.abs(ps[inner] - pref[inner])) / ref.p0), "pressure_l2_error": l2,
            "force_balance": abs(force - P / 2) / (P / 2), "max_penetration": info.max_penetration,
            "iterations": info.iterations, "penalty_iterations": info.penalty_iterations,
            "ndof": int(forms.X.ndof), "wall_s": info.wall_s,
            "x": xs.tolist(), "p": ps.tolist(), "p_ref": np.asarray(pref).tolist()}


def _foundation_block(L: float, H: float, h: float, order: int):
    face = Rectangle(L, H).Face()
    face.edges.Min(Y).name = "bottom"
    face.edges.Max(Y).name = "top"
    face.edges.Min(X).name = "left"
    face.edges.Max(X).name = "right"
    face.name = "block"
    mesh = ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=h))
    mesh.Curve(order)
    return mesh


def friction_block(push: str, *, law: str = "tresca", g_c: float = 1e6, friction: float = 0.3,
                   p_top: float = 5e6, ratio: float = 0.5, L: float = 1.0, H: float = 0.5, h: float = 0.1,
                   order: int = 1, E: float = 10e9, nu: float = 0.25) -> dict:
    """A block on a rigid foundation under the top pressure ``p_top`` with Tresca (slip bound ``g_c``, Pa)
    or Coulomb (coefficient ``friction``) friction; the capacity is g_c L or F_c p_top L. ``push`` =
    "traction": a left-side traction with the resultant ``ratio`` x capacity (it sticks, at least in part);
    "displacement": u_x = 1e-3 L on the left side (it slides); "none": only the top pressure. Without a
    displacement the block is held by the contact alone (semi-coercive). Returns {"friction_force" (int q ds, N/m),
    "capacity", "applied" (traction resultant, traction case), "normal_force" (int p ds), "stick", "slip"
    (node counts), "iterations", "max_penetration"}."""
    mesh = _foundation_block(L, H, h, order)
    props = _props(E, nu, ["block"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order)
    setup.pressure["top"] = expression_function(p_top)
    applied = None
    capacity = {"tresca": g_c * L, "coulomb": friction * p_top * L, "frictionless": 0.0}[law]
    if push == "traction":
        applied = ratio * capacity
        setup.traction["left"] = [expression_function(applied / H), expression_function(0.0)]
    elif push == "displacement":
        setup.dirichlet["left"] = [expression_function(1e-3 * L), None]
    elif push != "none":
        raise ValueError(f"push must be 'traction' or 'displacement', got {push!r}")
    forms, K, f, free, x0 = _system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "foundation", "bottom", None, axisymmetric=False,
                             obstacle=((0.0, 0.0), (0.0, 1.0)))
    claw = {"tresca": lambda: ContactLaw("tresca", slip_bound=g_c),
            "coulomb": lambda: ContactLaw("coulomb", friction=friction),
            "frictionless": ContactLaw}[law]()
    solver = ContactSolver([(op, claw)], modulus=nodal_modulus(props), floating=forms.floating_bodies())
    u, info = solver.solve(K, f, free, x0, f"{law} block")
    lam_n, lam_t = solver.multipliers[0]
    return {"friction_force": float(np.dot(op.weight, lam_t)), "capacity": capacity, "applied": applied,
            "normal_force": float(np.dot(op.weight, lam_n)), "load": p_top * L, "stick": info.stick[-1],
            "slip": info.slip[-1], "iterations": info.iterations, "max_penetration": info.max_penetration}


def patch_test(p: float = 1e6, *, h_lower: float = 0.1, h_upper: float = 0.07, order: int = 1,
               E: float = 10e9, nu: float = 0.25) -> dict:
    """Two blocks [0, 1] x [0, 0.5] and [0, 1] x [0.5, 1] meshed independently (sizes ``h_lower``,
    ``h_upper``), frictionless contact (multipliers on the upper block's bottom), u_x = 0 on x = 0, u_y = 0 on
    y = 0, pressure ``p`` on top. Returns {"max_deviation" (max |lam_n - p| / p), "force_balance",
    "max_penetration", "iterations", "nodes"}."""
    lower = Rectangle(1.0, 0.5).Face()
    upper = Rectangle(1.0, 0.5).Face().Move((0, 0.5, 0))
    lower.name, upper.name = "lower", "upper"
    lower.edges.Min(Y).name = "bottom"
    lower.edges.Max(Y).name = "lower_top"
    upper.edges.Min(Y).name = "upper_bottom"
    upper.edges.Max(Y).name = "top"
    lower.edges.Min(X).name = "left"
    upper.edges.Min(X).name = "left"
    lower.maxh, upper.maxh = h_lower, h_upper
    shape = Compound([lower, upper])     # not glued: independent meshes on the two sides
    mesh = ngs.Mesh(OCCGeometry(shape, dim=2).GenerateMesh(maxh=max(h_lower, h_upper)))
    mesh.Curve(order)
    props = _props(E, nu, ["lower", "upper"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order, symmetry=["left", "bottom"])
    setup.pressure["top"] = expression_function(p)
    forms, K, f, free, x0 = _system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "patch", "upper_bottom", "lower_top", axisymmetric=False)
    solver = ContactSolver([(op, ContactLaw())], modulus=nodal_modulus(props), floating=forms.floating_bodies())
    u, info = solver.solve(K, f, free, x0, "patch test")
    lam_n, _ = solver.multipliers[0]
    keep = op.coverage > 1 - 1e-6
    return {"max_deviation": float(np.max(np.abs(lam_n[keep] - p)) / p),
            "force_balance": abs(float(np.dot(op.weight, lam_n)) - p) / p,
            "max_penetration": info.max_penetration, "iterations": info.iterations, "nodes": int(keep.sum())}
