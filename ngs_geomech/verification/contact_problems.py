"""Verification problems of frictional contact (seed (2.23)-(2.27)) with closed-form or exact answers, solved
by :class:`ngs_geomech.contact.solver.ContactSolver` on the operators of :mod:`ngs_geomech.contact.forms`.

* :func:`hertz`: Hertz line contact (verification.md section 2), a quarter cylinder (symmetry on x = 0)
  pressed on a rigid flat by P per unit length, plane strain, frictionless: p0, the contact half width a and
  the pressure profile against the closed form. R = 1 m, E = 200 GPa, nu = 0.3 and P chosen so that
  a = R/50 (the note's R/a >~ 50); the contact arc is meshed with size ``h_contact``.
* :func:`friction_block`: a block (L x H) on a rigid foundation under a top pressure, pushed sideways: by a
  traction below the friction capacity (Tresca g_c L, Coulomb F_c P) it sticks (the friction force balances
  the push), by a displacement it slides (the friction force is the capacity).
* :func:`patch_test`: two blocks with non-matching meshes, frictionless, under a uniform top pressure p: the
  exact solution is a uniform stress, so the contact pressure must be p at every node.
* :func:`two_blocks_coulomb`: two elastic blocks (non-matching meshes, the upper one held by the contact alone)
  with Coulomb friction under a top pressure and a side push below the friction capacity: a slip zone
  between stick zones (a benchmark problem, no closed form).
* :func:`punch_3d`: a 3D elastic punch (its own non-matching mesh, held by the contact alone) pressed on a
  block and pushed sideways below the friction capacity: stick and slip zones in 3D, for the direct and the
  iterative (GMRES) Newton steps of the contact solver (no closed form; force balances and the agreement of
  the two solvers are checked).
* :func:`cattaneo`: Cattaneo-Mindlin partial slip (verification.md section 3): an elastic half cylinder
  pressed on an elastic block of the same material (non-matching meshes, Coulomb friction mu) by P and pushed
  sideways by Q < mu P in one static step: the stick-zone half width c against c/a = sqrt(1 - Q/(mu P)) and
  the tangential traction against the closed form.

The problems build their geometry with netgen.occ (test problems, not scenes). Every function returns a plain
dict and prints nothing. Units: m, Pa, N/m.
"""

from __future__ import annotations

import functools
import math

import ngsolve as ngs
import numpy as np
from netgen.occ import ArcOfCircle, Compound, Face, OCCGeometry, Pnt, Rectangle, Segment, Wire, X, Y

from ..contact.forms import contact_operator_2d
from ..contact.solver import ContactLaw, ContactSolver, nodal_modulus
from ..fem.coefficients import expression_function
from ..mechanics.forms import ElasticForms, ElasticSetup
from ..mechanics.materials import ElasticProperties, isotropic
from ..mechanics.solver import ElasticSolver
from . import contact_closed_forms as cc

E_HERTZ, NU_HERTZ, R_HERTZ = 200e9, 0.3, 1.0


def elastic_props(E: float, nu: float, regions) -> dict:
    """Isotropic elastic properties E (Pa), nu of each region, without thermal expansion."""
    return {r: ElasticProperties(C=isotropic(E, nu), alpha=np.zeros((3, 3)), beta=np.zeros((3, 3))) for r in regions}


def linear_system(mesh, setup: ElasticSetup):
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


def hertz_mesh(h_contact: float, order: int = 1, maxh: float | None = None):
    """The mesh of :func:`hertz`'s quarter cylinder (boundaries "contact", "top", "sym"; region "cylinder"):
    ``h_contact`` (m) along the contact arc (up to 4a from the axis), ``maxh`` (m, default R/4) elsewhere,
    curved to order max(order, 2)."""
    R = R_HERTZ
    th = 4 * (R / 50) / R

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
    return mesh


def hertz(h_contact: float, order: int = 1, *, method: str = "ssn", maxh: float | None = None,
          solver_factory=None, return_system: bool = False, mesh=None, initial_sets=None,
          return_state: bool = False) -> dict:
    """Hertz line contact of a quarter cylinder on a rigid flat (module docstring); ``h_contact`` (m) is the
    element size along the contact arc (the arc up to 4a from the axis), ``maxh`` (m) the size elsewhere
    (default R/4).

    Returns {"a", "p0" (closed form), "p0_num" (nodal pressure on the axis), "p0_rel_error", "a_num" (the last
    node in contact), "a_next" (the first open node), "a_error" (|a_num - a|), "h" (node spacing at a),
    "profile_max_error" (max |p - p_ref| / p0 over the nodes with x < 0.9 a), "pressure_l2_error" (the
    same region: sqrt(int (p - p_ref)^2 dx / a) / p0, trapezoidal over the nodes), "force_balance" (|int p - P/2| /
    (P/2)), "max_penetration" (m), "iterations", "penalty_iterations", "factorizations", "ndof", "wall_s"
    (contact solve), "x", "p", "p_ref" (nodal profile)}; with ``return_system`` also "system" (the assembled
    problem the contact solver got: :func:`_system_dict`). ``solver_factory(interfaces, modulus=, floating=)``
    builds the solver as in :func:`friction_block` (default :class:`ContactSolver` with ``method``).

    ``mesh``: solve on this mesh (e.g. an adaptively refined :func:`hertz_mesh`; ``h_contact`` and ``maxh`` are
    then unused): the forms and the contact operators are built on it. ``initial_sets``: the solver's
    starting nodal sets [(active, stick, slip)] on that mesh (:meth:`ContactSolver.warm_start`; ignored by a solver
    without it), or a function of the contact operator returning them. With
    ``return_state`` also "state": {"mesh", "forms", "op", "solver", "law", "u"} (what an adaptive loop
    estimates on)."""
    R, E, nu = R_HERTZ, E_HERTZ, NU_HERTZ
    E_star = cc.effective_modulus(E, nu)
    a_ref = R / 50
    P = math.pi * E_star * a_ref ** 2 / (4 * R)
    ref = cc.hertz_line(P, R, E_star)
    if mesh is None:
        mesh = hertz_mesh(h_contact, order, maxh)
    props = elastic_props(E, nu, ["cylinder"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order, symmetry=["sym"])
    setup.traction["top"] = [expression_function(0.0), expression_function(-P / (2 * R))]
    forms, K, f, free, x0 = linear_system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "hertz", "contact", None, axisymmetric=False,
                             obstacle=((0.0, 0.0), (0.0, 1.0)))
    floating = forms.floating_bodies()
    factory = solver_factory or functools.partial(ContactSolver, method=method)
    law = ContactLaw()
    solver = factory([(op, law)], modulus=nodal_modulus(props), floating=floating)
    if initial_sets is not None and hasattr(solver, "warm_start"):
        solver.warm_start(forms.X.ndof, initial_sets(op) if callable(initial_sets) else initial_sets)
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
    out = {"a": ref.a, "p0": ref.p0, "P": P, "p0_num": float(ps[0]), "p0_rel_error": float(ps[0] / ref.p0 - 1),
           "a_num": float(xs[last]), "a_next": float(xs[min(last + 1, len(xs) - 1)]),
           "a_error": abs(float(xs[last]) - ref.a), "h": float(xs[min(last + 1, len(xs) - 1)] - xs[last]),
           "profile_max_error": float(np.max(np.abs(ps[inner] - pref[inner])) / ref.p0), "pressure_l2_error": l2,
           "force_balance": abs(force - P / 2) / (P / 2), "max_penetration": info.max_penetration,
           "iterations": info.iterations, "penalty_iterations": info.penalty_iterations,
           "factorizations": info.factorizations, "ndof": int(forms.X.ndof), "wall_s": info.wall_s,
           "x": xs.tolist(), "p": ps.tolist(), "p_ref": np.asarray(pref).tolist()}
    if return_system:
        out["system"] = _system_dict(K, f, free, x0, floating)
    if return_state:
        out["state"] = {"mesh": mesh, "forms": forms, "op": op, "solver": solver, "law": law, "u": u}
    return out


def _system_dict(K, f, free, x0, floating) -> dict:
    """The assembled linear elastic problem a contact solve got (for timing a plain linear solve on the same
    mesh): {"matrix" (the NGSolve bulk matrix K), "rhs", "free" (bool mask), "x0" (Dirichlet values),
    "floating" (the semi-coercive bodies, :meth:`ElasticForms.floating_bodies`)}."""
    return {"matrix": K, "rhs": f, "free": free, "x0": x0, "floating": floating}


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
                   order: int = 1, E: float = 10e9, nu: float = 0.25, solver_factory=None) -> dict:
    """A block on a rigid foundation under the top pressure ``p_top`` with Tresca (slip bound ``g_c``, Pa)
    or Coulomb (coefficient ``friction``) friction; the capacity is g_c L or F_c p_top L. ``push`` =
    "traction": a left-side traction with the resultant ``ratio`` x capacity (it sticks, at least in part);
    "displacement": u_x = 1e-3 L on the left side (it slides); "none": only the top pressure. Without a
    displacement the block is held by the contact alone (semi-coercive). Returns {"friction_force" (int q ds, N/m),
    "capacity", "applied" (traction resultant, traction case), "normal_force" (int p ds), "stick", "slip"
    (node counts), "iterations", "max_penetration", "lam_n", "lam_t" (nodal multipliers, Pa), "u" (the solution
    vector), "info" (the solver's history)}. ``solver_factory(interfaces, modulus=, floating=)`` builds the solver
    (default :class:`ContactSolver`; e.g. :class:`ngs_geomech.contact.uzawa.UzawaSolver`)."""
    mesh = _foundation_block(L, H, h, order)
    props = elastic_props(E, nu, ["block"])
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
    forms, K, f, free, x0 = linear_system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "foundation", "bottom", None, axisymmetric=False,
                             obstacle=((0.0, 0.0), (0.0, 1.0)))
    claw = {"tresca": lambda: ContactLaw("tresca", slip_bound=g_c),
            "coulomb": lambda: ContactLaw("coulomb", friction=friction),
            "frictionless": ContactLaw}[law]()
    solver = (solver_factory or ContactSolver)([(op, claw)], modulus=nodal_modulus(props),
                                               floating=forms.floating_bodies())
    u, info = solver.solve(K, f, free, x0, f"{law} block")
    lam_n, lam_t = solver.multipliers[0]
    return {"friction_force": float(np.dot(op.weight, lam_t)), "capacity": capacity, "applied": applied,
            "normal_force": float(np.dot(op.weight, lam_n)), "load": p_top * L, "stick": info.stick[-1],
            "slip": info.slip[-1], "iterations": info.iterations, "max_penetration": info.max_penetration,
            "lam_n": lam_n, "lam_t": lam_t, "u": u, "info": info}


def _stacked_blocks(L: float, H: float, y0: float, h_lower: float, h_upper: float, order: int, sides: dict):
    """The mesh of two blocks [0, L] x [y0, y0 + H] ("lower") and [0, L] x [y0 + H, y0 + 2H] ("upper"), meshed
    independently (a Compound, not glued: non-matching meshes of sizes ``h_lower``, ``h_upper``); boundaries
    "bottom", "lower_top", "upper_bottom", "top" and the vertical sides named by ``sides`` = {block: (left
    name, right name or None)}."""
    lower = Rectangle(L, H).Face().Move((0, y0, 0))
    upper = Rectangle(L, H).Face().Move((0, y0 + H, 0))
    lower.name, upper.name = "lower", "upper"
    lower.edges.Min(Y).name = "bottom"
    lower.edges.Max(Y).name = "lower_top"
    upper.edges.Min(Y).name = "upper_bottom"
    upper.edges.Max(Y).name = "top"
    for face, (left, right) in ((lower, sides["lower"]), (upper, sides["upper"])):
        face.edges.Min(X).name = left
        if right is not None:
            face.edges.Max(X).name = right
    lower.maxh, upper.maxh = h_lower, h_upper
    shape = Compound([lower, upper])     # not glued: independent meshes on the two sides
    mesh = ngs.Mesh(OCCGeometry(shape, dim=2).GenerateMesh(maxh=max(h_lower, h_upper)))
    mesh.Curve(order)
    return mesh


def patch_test(p: float = 1e6, *, h_lower: float = 0.1, h_upper: float = 0.07, order: int = 1,
               E: float = 10e9, nu: float = 0.25) -> dict:
    """Two blocks [0, 1] x [0, 0.5] and [0, 1] x [0.5, 1] meshed independently (sizes ``h_lower``,
    ``h_upper``), frictionless contact (multipliers on the upper block's bottom), u_x = 0 on x = 0, u_y = 0 on
    y = 0, pressure ``p`` on top. Returns {"max_deviation" (max |lam_n - p| / p), "force_balance",
    "max_penetration", "iterations", "nodes"}."""
    mesh = _stacked_blocks(1.0, 0.5, 0.0, h_lower, h_upper, order, {"lower": ("left", None), "upper": ("left", None)})
    props = elastic_props(E, nu, ["lower", "upper"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order, symmetry=["left", "bottom"])
    setup.pressure["top"] = expression_function(p)
    forms, K, f, free, x0 = linear_system(mesh, setup)
    op = contact_operator_2d(mesh, forms.V, "patch", "upper_bottom", "lower_top", axisymmetric=False)
    solver = ContactSolver([(op, ContactLaw())], modulus=nodal_modulus(props), floating=forms.floating_bodies())
    u, info = solver.solve(K, f, free, x0, "patch test")
    lam_n, _ = solver.multipliers[0]
    keep = op.coverage > 1 - 1e-6
    return {"max_deviation": float(np.max(np.abs(lam_n[keep] - p)) / p),
            "force_balance": abs(float(np.dot(op.weight, lam_n)) - p) / p,
            "max_penetration": info.max_penetration, "iterations": info.iterations, "nodes": int(keep.sum())}


def two_blocks_coulomb(h: float, order: int = 2, *, friction: float = 0.3, ratio: float = 0.7,
                       p_top: float = 5e6, L: float = 1.0, H: float = 0.5, h_ratio: float = 0.7,
                       E: float = 10e9, nu: float = 0.25, solver_factory=None,
                       return_system: bool = False, linear: str = "auto") -> dict:
    """Two elastic blocks with Coulomb friction, plane strain: a lower block [0, L] x [-H, 0] fixed at its base
    (u = 0 on y = -H) and an upper block [0, L] x [0, H] on it, meshed independently (non-matching meshes,
    sizes ``h`` below and ``h_ratio`` x ``h`` above, as :func:`patch_test`). The upper block is held by the
    contact alone (semi-coercive, ``floating``): the pressure ``p_top`` on its top and on its left side a
    uniform traction with the resultant Q = ``ratio`` x F_c p_top L (F_c = ``friction``), i.e. at ``ratio``
    of the friction capacity. The moment Q H / 2 of the push tilts the pressure (0.67 p_top at the left end,
    1.22 p_top at the right one, h = 0.05). The shear vanishes at both ends of the interface (the blocks'
    traction-free sides meet it there; the push is normal to the left side), so slip starts inside, under the
    push: with the default ``ratio`` 0.7 a slip zone x ~ 0.1 L ... 0.45 L lies between a stick zone at the left
    end and one over the right half (measured at P2, h = 0.05; both zones present at h = 0.16 ... 0.01); at
    ratio 0.5 every node sticks (max |lam_t| / (F_c lam_n) = 0.71), at 0.8 the left 70 % slips. Multipliers
    on the upper block's bottom.

    Returns (no assertion) {"ndof", "iterations", "factorizations", "penalty_iterations", "wall_s" (contact
    solve), "stick", "slip", "active" (solver's node counts at the end), "friction_force" (int lam_t ds),
    "normal_force" (int lam_n ds), "applied" (Q), "load" (p_top L), "force_balance_n" (|int lam_n - p_top L| /
    (p_top L)), "force_balance_t" (|int lam_t - Q| / Q), "max_penetration", "info" (the solver's history)};
    with ``return_system`` also "system" (:func:`_system_dict`). ``solver_factory(interfaces, modulus=,
    floating=)`` builds the solver (default :class:`ContactSolver`; e.g.
    :class:`ngs_geomech.contact.uzawa.UzawaSolver`: then "iterations" counts its outer steps and
    "inner_iterations" the active set iterations of its frictionless subproblems, 0 for ContactSolver).
    ``linear``: the default solver's Newton-step solver (ContactSolver(linear=): "auto", "direct", "condensed" or
    "iterative": GMRES, then the result also has "gmres", the iterations per Newton-step solve, and "u", "lam_n",
    "lam_t")."""
    mesh = _stacked_blocks(L, H, -H, h, h_ratio * h, order,
                           {"lower": ("lower_side", "lower_side"), "upper": ("left", "right")})
    props = elastic_props(E, nu, ["lower", "upper"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order)
    setup.dirichlet["bottom"] = [expression_function(0.0), expression_function(0.0)]
    setup.pressure["top"] = expression_function(p_top)
    applied = ratio * friction * p_top * L
    setup.traction["left"] = [expression_function(applied / H), expression_function(0.0)]
    forms, K, f, free, x0 = linear_system(mesh, setup)
    floating = forms.floating_bodies()
    op = contact_operator_2d(mesh, forms.V, "blocks", "upper_bottom", "lower_top", axisymmetric=False)
    items = [(op, ContactLaw("coulomb", friction=friction))]
    if solver_factory is None:
        solver = ContactSolver(items, modulus=nodal_modulus(props), floating=floating, linear=linear, forms=forms)
    else:
        solver = solver_factory(items, modulus=nodal_modulus(props), floating=floating)
    u, info = solver.solve(K, f, free, x0, "two blocks")
    lam_n, lam_t = solver.multipliers[0]
    normal, tangential = float(np.dot(op.weight, lam_n)), float(np.dot(op.weight, lam_t))
    out = {"ndof": int(forms.X.ndof), "iterations": info.iterations, "factorizations": info.factorizations,
           "penalty_iterations": getattr(info, "penalty_iterations", 0),
           "inner_iterations": getattr(info, "inner_iterations", 0), "wall_s": info.wall_s,
           "stick": info.stick[-1], "slip": info.slip[-1], "active": info.active[-1],
           "friction_force": tangential, "normal_force": normal, "applied": applied, "load": p_top * L,
           "force_balance_n": abs(normal - p_top * L) / (p_top * L),
           "force_balance_t": abs(abs(tangential) - applied) / applied,
           "max_penetration": info.max_penetration, "info": info,
           "gmres": list(getattr(info, "gmres_iterations", [])), "u": u, "lam_n": lam_n, "lam_t": lam_t}
    if return_system:
        out["system"] = _system_dict(K, f, free, x0, floating)
    return out


def punch_3d(h: float, order: int = 1, *, law: str = "coulomb", friction: float = 0.3, g_c: float = 1e6,
             ratio: float = 0.7, p_top: float = 5e6, E: float = 10e9, nu: float = 0.25, h_ratio: float = 0.7,
             linear: str = "auto", linear_tol: float | None = None, linear_maxit: int = 3000) -> dict:
    """A punch [0.2, 0.8]^2 x [0, 0.3] (m) on a block [0, 1]^2 x [-0.5, 0] fixed at its base (u = 0 on z = -0.5),
    meshed independently (sizes ``h`` and ``h_ratio`` x ``h``: non-matching), contact on the punch's bottom
    (its multipliers) against the block's top. The punch is held by the contact alone: the pressure ``p_top`` on
    its top and, on its x = 0.2 side, a uniform traction along x with the resultant Q = ``ratio`` x the friction
    capacity (Coulomb F_c p_top A, Tresca g_c A, A = 0.36 m^2; frictionless: no push, so the punch's horizontal
    translations and rotation about z are held by nothing and fixed by the solver's shift). The push and its
    moment give a slip zone under the pushed side and a stick zone behind it. ``linear``: the contact solver's
    Newton-step solver ("auto": direct in 3D, "direct" or "iterative").

    Returns {"ndof", "nodes" (multiplier nodes), "iterations", "factorizations", "gmres" (GMRES iterations per
    Newton-step solve), "wall_s", "active", "stick", "slip", "normal_force" (int lam_n dA, N), "load"
    (p_top A), "friction_force" (x component of the friction force on the punch, N), "applied" (Q),
    "force_balance_n", "force_balance_t" (relative), "max_penetration", "u", "lam_n", "lam_t", "info"}."""
    from netgen.occ import Box, Z

    from ..contact.forms3d import contact_operator_3d

    lower = Box(Pnt(0, 0, -0.5), Pnt(1, 1, 0))
    upper = Box(Pnt(0.2, 0.2, 0), Pnt(0.8, 0.8, 0.3))
    lower.faces.Min(Z).name = "base"
    lower.faces.Max(Z).name = "block_top"
    upper.faces.Min(Z).name = "punch_bottom"
    upper.faces.Max(Z).name = "punch_top"
    upper.faces.Min(X).name = "punch_left"
    lower.solids.name, upper.solids.name = "block", "punch"
    lower.solids.maxh, upper.solids.maxh = h, h_ratio * h
    mesh = ngs.Mesh(OCCGeometry(Compound([lower, upper])).GenerateMesh(maxh=h))
    mesh.Curve(order)
    props = elastic_props(E, nu, ["block", "punch"])
    setup = ElasticSetup(props=props, model="3d", order=order)
    setup.dirichlet["base"] = [expression_function(0.0)] * 3
    setup.pressure["punch_top"] = expression_function(p_top)
    area = 0.36
    capacity = {"coulomb": friction * p_top * area, "tresca": g_c * area, "frictionless": 0.0}[law]
    applied = ratio * capacity
    if applied:
        setup.traction["punch_left"] = [expression_function(applied / (0.6 * 0.3)), expression_function(0.0),
                                        expression_function(0.0)]
    forms, K, f, free, x0 = linear_system(mesh, setup)
    floating = forms.floating_bodies()
    op = contact_operator_3d(mesh, forms.V, "punch", "punch_bottom", "block_top")
    claw = {"coulomb": lambda: ContactLaw("coulomb", friction=friction),
            "tresca": lambda: ContactLaw("tresca", slip_bound=g_c), "frictionless": ContactLaw}[law]()
    solver = ContactSolver([(op, claw)], modulus=nodal_modulus(props), floating=floating, linear=linear,
                           forms=forms, linear_tol=linear_tol, linear_maxit=linear_maxit)
    u, info = solver.solve(K, f, free, x0, "3D punch")
    lam_n, lam_t = solver.multipliers[0]
    n = op.Bn.shape[1]
    normal = float(np.dot(op.weight, lam_n))
    # the friction force on the punch along x: Bt^T lam_t1 + Bt2^T lam_t2 on the punch's x translation
    ex = _translation(forms, (1.0, 0.0, 0.0))[:n]
    punch = np.abs(floating[0].modes[:n, 0]) > 0 if floating else np.ones(n, dtype=bool)
    ft = op.Bt.T @ lam_t[:, 0] + op.Bt2.T @ lam_t[:, 1]
    fx = float((ex * punch) @ ft)
    return {"ndof": int(forms.X.ndof), "nodes": int(op.size), "iterations": info.iterations,
            "factorizations": info.factorizations, "gmres": list(info.gmres_iterations), "wall_s": info.wall_s,
            "active": info.active[-1], "stick": info.stick[-1], "slip": info.slip[-1], "normal_force": normal,
            "load": p_top * area, "friction_force": fx, "applied": applied,
            "force_balance_n": abs(normal - p_top * area) / (p_top * area),
            "force_balance_t": abs(abs(fx) - applied) / applied if applied else 0.0,
            "max_penetration": info.max_penetration, "u": u, "lam_n": lam_n, "lam_t": lam_t, "info": info}


def cattaneo(h_contact: float, order: int = 1, *, Q_ratio: float = 0.5, friction: float = 0.3,
             maxh: float | None = None, grading: float = 0.3) -> dict:
    """Cattaneo-Mindlin partial slip of a line contact (verification.md section 3), plane strain.

    A half cylinder (|x| <= R, flat top y = R through its centre, lowest point at the origin) rests on a
    block [-R, R] x [-R, 0] of the same material (E, nu of :func:`hertz`, so E* = E/(2 (1 - nu^2))); the two
    are meshed independently (not glued) and touch with Coulomb friction ``friction`` (mu). The block's bottom
    is fixed; the cylinder is held by the contact alone (semi-coercive). A traction on the cylinder's top
    applies the normal load P (N/m, chosen so that the Hertz half width is a = R/50) and the tangential load
    Q = ``Q_ratio`` mu P (+x) in one static step: for elastically identical bodies the normal load causes no
    relative tangential displacement, so the one-step solution is that of the Cattaneo loading path (P,
    then Q). The top traction is (Q, -P)/(2R) plus a linear normal part 3 Q x/(2 R^2) whose moment cancels
    that of Q about the contact point (Q R): without it the pressure would have to balance the moment Q R
    (7.5 P a at Q_ratio 0.5, mu 0.3), far more than an elliptical pressure of half width a can: the cylinder
    would roll instead of sticking (Cattaneo's loads have no moment about the contact).

    The multipliers live on the block's top (flat: p and q are exactly the vertical and horizontal
    tractions); its contact edge |x| <= 3a and the cylinder's arc |x| <= 4a are meshed with size
    ``h_contact`` (m), the rest with ``maxh`` (default R/4) and netgen's ``grading``. Coarse contact meshes
    can stop the solver: with order 2 and h_contact = a/5 or a/3.3 its first active set is the single node at
    x = 0, which does not hold the cylinder's rotation, and ContactSolver raises SolverError ("not held by
    the active contact set"; its retry handles only sets with slipping nodes); a/10 and finer solve.

    Measured: the contact half width (nodes with p > 0), the stick zone (nodes in contact with |q| < mu p,
    cross-checked against the solver's stick set) and its half width c_num, the midpoint between the last
    stick and the first slip node on each side (so |c_num - c| <= h/2 when the discrete transition is at the
    right element); its centre ``stick_shift`` (m, exact 0); the traction profile against
    :func:`.contact_closed_forms.cattaneo_traction`.

    Returns {"a", "p0", "P", "Q", "c" (closed forms), "c_over_a" (sqrt(1 - Q/(mu P))), "c_num", "c_num_over_a",
    "c_stick" (half extent of the stick nodes), "c_slip" (of the innermost slip nodes), "c_error" (|c_num -
    c|), "h" (node spacing at the stick/slip transition), "stick_shift", "stick_contiguous", "a_num" (half
    extent of the nodes in contact), "a_next" (of the first open nodes), "a_error", "a_fit" (half width of the
    ellipse fitted to p^2 over |x| < 0.8 a), "p0_num" (nodal pressure at the node nearest x = 0),
    "p0_rel_error", "p0_fit_rel_error" (peak of the fitted ellipse), "q_stick_max_error" (max |q - q_ref| /
    (mu p0) over the stick nodes), "q_stick_max_error_shifted" (the same with the closed form's stick term
    centred at ``stick_shift``), "q_max_error" (over |x| < 0.9 a), "q_l2_error" (the same region:
    sqrt(int (q - q_ref)^2 dx / a) / (mu p0), trapezoidal over the nodes), "slip_law_error" (max | |q|/(mu p) - 1 |
    over the slip nodes), "force_balance_n" (|int p - P| / P), "force_balance_t" (|int q - Q| / Q),
    "transfer_error" (the contact resultant on the cylinder, through the mortar operators, against (-Q, P),
    relative to P), "stick", "slip" (node counts), "solver_stick", "solver_slip" (ContactInfo), "iterations",
    "penalty_iterations", "max_penetration", "ndof", "wall_s" (contact solve), "x", "p", "q", "q_ref"
    (nodal profiles, q in the direction of Q)}."""
    if not 0.0 < Q_ratio < 1.0:
        raise ValueError(f"Q_ratio = Q/(mu P) must lie in (0, 1) (partial slip), got {Q_ratio!r}")
    R, E, nu, mu = R_HERTZ, E_HERTZ, NU_HERTZ, float(friction)
    E_star = cc.effective_modulus(E, nu, E, nu)
    a_ref = R / 50
    P = math.pi * E_star * a_ref ** 2 / (4 * R)
    Q = Q_ratio * mu * P
    ref = cc.hertz_line(P, R, E_star)
    c_ref = cc.cattaneo_stick_half_width(Q, P, mu, ref.a)
    mesh = cattaneo_mesh(a_ref, h_contact, order, maxh, grading)
    props = elastic_props(E, nu, ["cylinder", "block"])
    setup = ElasticSetup(props=props, model="plane_strain", order=order)
    setup.dirichlet["bottom"] = [expression_function(0.0), expression_function(0.0)]
    setup.traction["top"] = [expression_function(Q / (2 * R)),
                             expression_function(f"{-P / (2 * R)!r} + {3 * Q / (2 * R ** 2)!r} * x")]
    forms, K, f, free, x0 = linear_system(mesh, setup)
    floating = forms.floating_bodies()
    op = contact_operator_2d(mesh, forms.V, "cattaneo", "block_contact", "cylinder_contact", axisymmetric=False,
                             search_distance=a_ref / 2)
    solver = ContactSolver([(op, ContactLaw("coulomb", friction=mu))], modulus=nodal_modulus(props),
                           floating=floating)
    u, info = solver.solve(K, f, free, x0, "cattaneo")
    lam_n, lam_t = solver.multipliers[0]
    fx, fy = _cylinder_resultant(floating, op, lam_n, lam_t)
    measures, prof = _cattaneo_measures(op.coords[:, 0], lam_n, lam_t, mu, ref, c_ref)
    return {"a": ref.a, "p0": ref.p0, "P": P, "Q": Q, "c": c_ref, "c_over_a": c_ref / ref.a, **measures,
            "force_balance_n": abs(float(np.dot(op.weight, lam_n)) - P) / P,
            "force_balance_t": abs(float(np.dot(op.weight, lam_t)) - Q) / Q,
            "transfer_error": math.hypot(fx + Q, fy - P) / P,
            "stick": int(prof["stick"].sum()), "slip": int(prof["slip"].sum()), "solver_stick": info.stick[-1],
            "solver_slip": info.slip[-1], "iterations": info.iterations,
            "penalty_iterations": info.penalty_iterations, "max_penetration": info.max_penetration,
            "ndof": int(forms.X.ndof), "wall_s": info.wall_s,
            "x": prof["x"].tolist(), "p": prof["p"].tolist(), "q": prof["q"].tolist(), "q_ref": prof["q_ref"].tolist()}


def _cylinder_resultant(floating: list, op, lam_n: np.ndarray, lam_t: np.ndarray) -> tuple[float, float]:
    """The contact resultant (N/m) on :func:`cattaneo`'s cylinder through the mortar operators (O side):
    (-int q, int p)."""
    body = next(b for b in floating if "cylinder" in b.regions)
    nv = op.Bn.shape[1]
    force = op.Bn.T @ lam_n + op.Bt.T @ lam_t
    fx = float(body.modes[:nv, body.names.index("translation along x")] @ force)
    fy = float(body.modes[:nv, body.names.index("translation along y")] @ force)
    return fx, fy


def cattaneo_mesh(a_ref: float, h_contact: float, order: int, maxh: float | None, grading: float):
    """The mesh of :func:`cattaneo`: the half cylinder (fine arc |x| <= ~4a) and the block (contact edge
    |x| <= 3a) meshed independently, curved to order max(order, 2)."""
    R = R_HERTZ
    th = 4 * a_ref / R                  # the cylinder's fine arc |x| <= ~4a
    L = 3 * a_ref                       # the block's contact edge |x| <= 3a (the multiplier side)

    def on_circle(t):
        return Pnt(R * math.sin(t), R - R * math.cos(t), 0)

    q1 = (math.pi / 2 + th) / 2
    cyl = Face(Wire([ArcOfCircle(on_circle(-math.pi / 2), on_circle(-q1), on_circle(-th)),
                     ArcOfCircle(on_circle(-th), on_circle(0.0), on_circle(th)),
                     ArcOfCircle(on_circle(th), on_circle(q1), on_circle(math.pi / 2)),
                     Segment(Pnt(R, R, 0), Pnt(-R, R, 0))]))
    for k, name in enumerate(("cylinder_free", "cylinder_contact", "cylinder_free", "top")):
        cyl.edges[k].name = name
    cyl.edges[1].maxh = h_contact
    cyl.name = "cylinder"
    corners = [(-R, -R), (R, -R), (R, 0.0), (L, 0.0), (-L, 0.0), (-R, 0.0)]
    block = Face(Wire([Segment(Pnt(*corners[k], 0), Pnt(*corners[(k + 1) % 6], 0)) for k in range(6)]))
    for k, name in enumerate(("bottom", "block_side", "block_top", "block_contact", "block_top", "block_side")):
        block.edges[k].name = name
    block.edges[3].maxh = h_contact
    block.name = "block"
    shape = Compound([cyl, block])      # not glued: independent meshes on the two sides
    mesh = ngs.Mesh(OCCGeometry(shape, dim=2).GenerateMesh(maxh=maxh or R / 4, grading=grading))
    mesh.Curve(max(order, 2))
    return mesh


def _stick_zone(xs: np.ndarray, ps: np.ndarray, qs: np.ndarray, mu: float) -> dict:
    """The contact and stick zones of the sorted nodal profile (x, p, q) of :func:`cattaneo`: the node sets
    ``contact``, ``stick``, ``slip``, the extents of the contact nodes (cl, cr), of the stick nodes (kl, kr) and
    of the innermost slip nodes (sl, sr), and the half widths ``a_num``, ``a_next`` (the first open nodes)."""
    contact = ps > 0
    stick = contact & (np.abs(qs) < mu * ps * (1 - 1e-10))
    slip = contact & ~stick
    xc, xk = xs[contact], xs[stick]
    cl, cr = float(xc.min()), float(xc.max())
    open_l, open_r = xs[xs < cl], xs[xs > cr]
    a_next = (float(open_r.min() if len(open_r) else cr) - float(open_l.max() if len(open_l) else cl)) / 2
    kl, kr = (float(xk.min()), float(xk.max())) if len(xk) else (0.0, 0.0)   # no stick node: c_num 0
    sl_l, sl_r = xs[slip & (xs < kl)], xs[slip & (xs > kr)]
    sl, sr = (float(sl_l.max()) if len(sl_l) else cl), (float(sl_r.min()) if len(sl_r) else cr)
    return {"contact": contact, "stick": stick, "slip": slip, "a_num": (cr - cl) / 2, "a_next": a_next,
            "kl": kl, "kr": kr, "sl": sl, "sr": sr}


def _cattaneo_measures(x: np.ndarray, lam_n: np.ndarray, lam_t: np.ndarray, mu: float, ref, c_ref: float):
    """The measures of :func:`cattaneo`'s nodal profile (its docstring, from "c_num" to "slip_law_error") and the
    profile sorted by x: {"x", "p", "q", "q_ref", "stick", "slip"}."""
    o = np.argsort(x)
    xs, ps, qs = x[o], lam_n[o], lam_t[o]       # q > 0: the friction on the cylinder opposes Q (+x)
    z = _stick_zone(xs, ps, qs, mu)
    contact, stick, slip = z["contact"], z["stick"], z["slip"]
    kl, kr, sl, sr, a_num = z["kl"], z["kr"], z["sl"], z["sr"], z["a_num"]
    left, right = (kl + sl) / 2, (kr + sr) / 2
    c_num, shift = (right - left) / 2, (right + left) / 2
    # elliptical fit p^2 = p0'^2 (1 - x^2/a'^2) over |x| < 0.8 a
    fit = (np.abs(xs) < 0.8 * ref.a) & contact
    k0, k1 = np.linalg.lstsq(np.vstack([np.ones(fit.sum()), xs[fit] ** 2]).T, ps[fit] ** 2, rcond=None)[0]
    qref = np.asarray(cc.cattaneo_traction(xs, ref.a, c_ref, ref.p0, mu))
    qref_shifted = mu * np.asarray(cc.hertz_pressure(xs, ref.a, ref.p0)) \
        - mu * ref.p0 * (c_ref / ref.a) * np.sqrt(np.clip(1.0 - ((xs - shift) / c_ref) ** 2, 0.0, None))
    inner = np.abs(xs) < 0.9 * ref.a
    scale = mu * ref.p0
    measures = {
        "c_num": c_num, "c_num_over_a": c_num / ref.a, "c_stick": (kr - kl) / 2, "c_slip": (sr - sl) / 2,
        "c_error": abs(c_num - c_ref), "h": ((sr - kr) + (kl - sl)) / 2, "stick_shift": shift,
        "stick_contiguous": bool(np.all(stick[(xs >= kl) & (xs <= kr)])),
        "a_num": a_num, "a_next": z["a_next"], "a_error": abs(a_num - ref.a),
        "a_fit": math.sqrt(-k0 / k1) if k0 > 0 > k1 else float("nan"),
        "p0_num": float(ps[np.argmin(np.abs(xs))]), "p0_rel_error": float(ps[np.argmin(np.abs(xs))] / ref.p0 - 1),
        "p0_fit_rel_error": math.sqrt(max(k0, 0.0)) / ref.p0 - 1,
        "q_stick_max_error": float(np.max(np.abs(qs[stick] - qref[stick]), initial=0.0)) / scale,
        "q_stick_max_error_shifted": float(np.max(np.abs(qs[stick] - qref_shifted[stick]), initial=0.0)) / scale,
        "q_max_error": float(np.max(np.abs(qs[inner] - qref[inner]))) / scale,
        "q_l2_error": math.sqrt(float(np.trapezoid((qs[inner] - qref[inner]) ** 2, xs[inner])) / ref.a) / scale,
        "slip_law_error": float(np.max(np.abs(np.abs(qs[slip]) / (mu * ps[slip]) - 1), initial=0.0))}
    return measures, {"x": xs, "p": ps, "q": qs, "q_ref": qref, "stick": stick, "slip": slip}
