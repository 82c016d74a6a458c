"""Tresca and Coulomb friction in 3D (ContactSolver with two tangential directions, lam_t of shape (m, 2)):
a block on a rigid plane foundation under a top pressure, pushed in an oblique direction (30 degrees from
x): held by a traction at half the capacity (the friction force balances the push), sliding under a
prescribed displacement (a manufactured uniform shear state: the friction force is the capacity against the
slip; a push on one side: every node at its bound against its own slip), beyond the capacity (the error
names the body and the motion), and a scene. Figures are printed (pytest -s)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import ngsolve as ngs
import numpy as np
import pytest
from netgen.occ import Box, OCCGeometry, Pnt, X, Y, Z

from ngs_geomech.contact.forms3d import contact_operator_3d
from ngs_geomech.contact.solver import ContactLaw, ContactSolver, nodal_modulus
from ngs_geomech.errors import SolverError
from ngs_geomech.fem.coefficients import expression_function
from ngs_geomech.mechanics.forms import ElasticForms, ElasticSetup
from ngs_geomech.mechanics.materials import ElasticProperties, isotropic
from ngs_geomech.mechanics.solver import ElasticSolver
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict

pytestmark = pytest.mark.usefixtures("one_thread")

E, L, W, H = 10e9, 1.0, 0.8, 0.5           # Pa, block [0, L] x [0, W] x [0, H] (m)
P, G_C, F_C = 5e6, 1e6, 0.3                 # top pressure (Pa), Tresca slip bound (Pa), Coulomb coefficient
ANGLE = np.radians(30.0)
DIR = np.array([np.cos(ANGLE), np.sin(ANGLE), 0.0])       # the push, 30 degrees between x (t1) and y


def _system(mesh, setup):
    forms = ElasticForms(mesh, setup)
    ElasticSolver(forms).set_dirichlet()
    forms.u_frozen.vec[:] = 0.0
    forms.secant_form.Assemble()
    forms.secant_rhs.Assemble()
    free = np.array(list(forms.X.FreeDofs()), dtype=bool)
    return (forms, forms.secant_form.mat, np.array(forms.secant_rhs.vec.FV().NumPy()), free,
            np.array(forms.gf.vec.FV().NumPy()))


def _const(v: float):
    return expression_function(float(v))


def block_on_plane(push: str, law: str, *, ratio: float = 0.5, nu: float = 0.25, maxh: float = 0.2) -> dict:
    """The block on the plane z = 0 (multipliers on its bottom, t1 = e_x, t2 = n x t1 = -e_y) under the top
    pressure P. ``push``: "traction" (a uniform traction on x = 0 along DIR with the resultant ratio x
    capacity; no support: the contact alone holds the block), "top" (the same as a shear traction on the
    top), "side" (u_x, u_y = 1 mm along DIR on x = 0), "shear" (u_x, u_y = 1 mm along DIR on the top and on
    the sides the vertical tractions tau (DIR . n) of the uniform state sigma_xz, sigma_yz = tau DIR,
    sigma_zz = -P with tau = capacity / area: with nu = 0 the exact solution, sliding uniformly along DIR)."""
    box = Box(Pnt(0, 0, 0), Pnt(L, W, H))
    for face, name in ((box.faces.Min(Z), "bottom"), (box.faces.Max(Z), "top"), (box.faces.Min(X), "left"),
                       (box.faces.Max(X), "right"), (box.faces.Min(Y), "front"), (box.faces.Max(Y), "back")):
        face.name = name
    box.solids.name = "block"
    mesh = ngs.Mesh(OCCGeometry(box).GenerateMesh(maxh=maxh))
    props = {"block": ElasticProperties(C=isotropic(E, nu), alpha=np.zeros((3, 3)), beta=np.zeros((3, 3)))}
    setup = ElasticSetup(props=props, model="3d", order=1)
    setup.pressure["top"] = _const(P)
    capacity = {"tresca": G_C, "coulomb": F_C * P}[law] * L * W
    applied = ratio * capacity * DIR
    if push == "traction":
        setup.traction["left"] = [_const(c / (W * H)) for c in applied]
    elif push == "top":
        setup.pressure.pop("top")
        setup.traction["top"] = [_const(applied[0] / (L * W)), _const(applied[1] / (L * W)), _const(-P)]
    elif push == "side":
        setup.dirichlet["left"] = [_const(1e-3 * DIR[0]), _const(1e-3 * DIR[1]), None]
    elif push == "shear":
        tau = capacity / (L * W)
        setup.dirichlet["top"] = [_const(1e-3 * DIR[0]), _const(1e-3 * DIR[1]), None]
        for name, normal in (("left", (-1, 0, 0)), ("right", (1, 0, 0)), ("front", (0, -1, 0)), ("back", (0, 1, 0))):
            setup.traction[name] = [_const(0.0), _const(0.0), _const(tau * float(np.dot(DIR, normal)))]
    forms, K, f, free, x0 = _system(mesh, setup)
    op = contact_operator_3d(mesh, forms.V, "foundation", "bottom", None, obstacle=((0, 0, 0), (0, 0, 1)))
    claw = ContactLaw("tresca", slip_bound=G_C) if law == "tresca" else ContactLaw("coulomb", friction=F_C)
    solver = ContactSolver([(op, claw)], modulus=nodal_modulus(props), floating=forms.floating_bodies())
    u, info = solver.solve(K, f, free, x0, f"3D {law} block, push {push}")
    lam_n, lam_t = solver.multipliers[0]
    n = op.Bn.shape[1]
    # the friction force on the block (N) in x, y, z: the translations applied to Bt^T lam_t1 + Bt2^T lam_t2
    ft = op.Bt.T @ lam_t[:, 0] + op.Bt2.T @ lam_t[:, 1]
    g = ngs.GridFunction(forms.V)
    friction = []
    for d in np.eye(3):
        g.Set(ngs.CoefficientFunction(tuple(d)))
        friction.append(float(g.vec.FV().NumPy() @ ft))
    slip = np.column_stack([op.Bt @ u[:n], op.Bt2 @ u[:n]]) / op.weight[:, None]
    bound = np.full(op.size, G_C) if law == "tresca" else F_C * lam_n
    return {"op": op, "info": info, "lam_n": lam_n, "lam_t": lam_t, "slip": slip, "bound": bound,
            "friction": np.array(friction), "applied": applied, "capacity": capacity,
            "normal_force": float(op.weight @ lam_n), "load": P * L * W, "mu": E / (2 * (1 + nu))}


def _its(info) -> str:
    return (f"{info.iterations} iterations ({info.penalty_iterations} penalty), {info.factorizations} "
            f"factorizations, slip-row residuals " + ", ".join(f"{r:.0e}" for r in info.newton_residual[-4:]))


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_block_sticks_below_capacity(law):
    """Pushed at half the capacity along DIR by a traction on x = 0, held by the foundation alone: the
    friction force on the block balances the push (a vector), the normal force the pressure. nu = 0: with
    nu = 0.25 the Poisson spreading of the bottom under P alone needs more shear than g_c = P / 5 (33 of the 35
    nodes slip, outwards; the balance holds all the same, and the scene test below has that partial slip)."""
    r = block_on_plane("traction", law, nu=0.0)
    info, Q = r["info"], np.linalg.norm(r["applied"])
    err = float(np.linalg.norm(r["friction"] + r["applied"])) / Q
    print(f"\n3D {law} block at half capacity: friction force {r['friction']} N (push {r['applied']}), "
          f"|error| / |push| {err:.1e}; {info.stick[-1]} stick, {info.slip[-1]} slip nodes; {_its(info)}")
    assert err < 1e-8
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)
    assert info.stick[-1] > 0
    assert np.all(np.linalg.norm(r["lam_t"], axis=1) <= r["bound"] * (1 + 1e-9) + 1e-12 * np.max(r["bound"]))
    assert info.iterations < 15


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_block_slides_at_capacity_uniform_shear(law):
    """The manufactured uniform shear state (nu = 0, top displaced along DIR): every node slips by
    1 mm - tau H / mu along DIR, the friction force on the block is the capacity g_c A or F P A against the
    slip."""
    r = block_on_plane("shear", law, nu=0.0)
    info, cap = r["info"], r["capacity"]
    err = float(np.linalg.norm(r["friction"] + cap * DIR)) / cap
    s = np.linalg.norm(r["slip"], axis=1)
    s_exact = 1e-3 - cap / (L * W) * H / r["mu"]
    cosine = np.einsum("ij,ij->i", r["lam_t"], r["slip"]) / (np.linalg.norm(r["lam_t"], axis=1) * s)
    print(f"\n3D {law} block in uniform shear: friction force {r['friction']} N, capacity {cap:.6e} N along "
          f"-DIR: |error| / capacity {err:.1e}; slip {s.min():.12e} .. {s.max():.12e} m (exact {s_exact:.12e}); "
          f"{_its(info)}")
    assert info.stick[-1] == 0 and info.slip[-1] == r["op"].size
    assert err < 1e-8
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-8)
    assert np.max(np.abs(s - s_exact)) < 1e-8 * s_exact
    assert np.max(cosine) < -1 + 1e-8                  # lam_t opposes the slip at every node
    assert info.iterations < 15


@pytest.mark.parametrize("law", ["tresca", "coulomb"])
def test_block_pushed_on_a_side_slides(law):
    """u_x, u_y = 1 mm along DIR on x = 0: every node slips, each at its bound against its own slip (the
    directions differ from node to node by the elastic deformation, so the resultant is a little below the
    capacity), and the magnitudes integrate to the capacity."""
    r = block_on_plane("side", law)
    info, cap, b = r["info"], r["capacity"], r["bound"]
    q = np.linalg.norm(r["lam_t"], axis=1)
    s = np.linalg.norm(r["slip"], axis=1)
    cosine = np.einsum("ij,ij->i", r["lam_t"], r["slip"]) / (q * s)
    total = float(r["op"].weight @ q)
    spread = np.degrees(np.ptp(np.arctan2(r["slip"][:, 1], r["slip"][:, 0])))
    print(f"\n3D {law} block pushed on a side: int |q| dA / capacity - 1 = {total / cap - 1:.1e}, max ||q| - b| / b "
          f"{np.max(np.abs(q - b)) / np.max(b):.1e}, max cos(q, s) {np.max(cosine):.12f}, slip directions spread "
          f"{spread:.1f} deg, |resultant| / capacity {np.linalg.norm(r['friction']) / cap:.6f}; {_its(info)}")
    assert info.stick[-1] == 0 and info.slip[-1] == r["op"].size
    assert np.max(np.abs(q - b)) < 1e-8 * np.max(b)
    assert np.max(cosine) < -1 + 1e-8
    assert total == pytest.approx(cap, rel=1e-8)
    assert 0.99 < np.linalg.norm(r["friction"]) / cap < 1.0
    assert info.iterations < 15


@pytest.mark.parametrize("law,ratio", [("tresca", 1.1), ("coulomb", 1.5)])
def test_floating_block_beyond_capacity_names_body_and_motion(law, ratio):
    with pytest.raises(SolverError, match=r"body block: translation along x is not held"):
        block_on_plane("traction", law, ratio=ratio)


def test_solvable_load_near_capacity_is_not_refused():
    """The solvability check uses a polygon around the friction disc (a relaxation): a load just below the
    capacity, in a direction between two of its normals, is solved."""
    r = block_on_plane("top", "tresca", ratio=0.99, maxh=0.25)
    err = float(np.linalg.norm(r["friction"] + r["applied"])) / np.linalg.norm(r["applied"])
    print(f"\n3D Tresca block at 99 % of the capacity: friction balances the push to {err:.1e}; {_its(r['info'])}")
    assert err < 1e-8
    assert r["info"].iterations < 15


def test_coulomb_foundation_scene(tmp_path):
    """A scene: the box held by a Coulomb foundation alone, pushed along DIR at half the capacity by a
    traction on its left side: the summary's tangential resultant balances the push, the global balance
    closes, the boundary VTK carries the traction magnitude and its two components."""
    p, mu = P, F_C
    q = 0.5 * mu * p * L * W / (W * H)
    scene = {"scene": {"name": "box3d", "dimension": "3d"}, "physics": {"mechanics": "static"},
             "mesh": {"maxh": 0.25, "order": 1},
             "blocks": [{"name": "box", "shape": "box", "origin": [0, 0, 0], "size": [L, W, H],
                         "boundaries": {"base": "zmin", "top": "zmax", "left": "xmin"}}],
             "materials": {"box": {"youngs_modulus": E, "poisson_ratio": 0.25}},
             "boundary_conditions": {
                 "base": {"foundation": {"point": [0, 0, 0], "normal": [0, 0, 1], "law": "coulomb", "friction": mu}},
                 "top": {"pressure": p},
                 "left": {"traction": [q * DIR[0], q * DIR[1], 0.0]}}}
    out = tmp_path / "box3d"
    res = run_scene(scene_from_dict(scene), out, progress=False)
    c = res.summary["mechanics"]["contact"]
    base = c["interfaces"]["base"]
    push = q * W * H * DIR
    tang = np.array([base["tangential_resultant_on_side"][d] for d in "xyz"])
    print(f"\n3D Coulomb scene: tangential resultant {tang} N (push {push}), normal force {base['normal_force']:.9e} "
          f"N, imbalance {c['force_balance']['imbalance_rel']:.1e}, nodes {base['nodes']}, active-set steps "
          f"{c['iterations_per_solve']}")
    assert np.linalg.norm(tang + push) < 1e-8 * np.linalg.norm(push)
    assert base["tangential_force"] == pytest.approx(np.linalg.norm(push), rel=1e-8)
    assert base["normal_force"] == pytest.approx(p * L * W, rel=1e-8)
    assert c["force_balance"]["imbalance_rel"] < 1e-8
    assert base["nodes"]["stick"] > 0 and base["nodes"]["open"] == 0
    assert max(c["iterations_per_solve"]) < 15
    piece = next(ET.parse(out / "box3d_contact_base_step00000.vtp").getroot().iter("Piece"))
    arrays = {a.get("Name"): np.array(a.text.split(), dtype=float) for a in piece.find("PointData")}
    assert set(arrays) == {"pressure", "traction", "traction_t1", "traction_t2", "gap", "slip", "status", "bound"}
    assert np.allclose(arrays["traction"], np.hypot(arrays["traction_t1"], arrays["traction_t2"]), rtol=1e-6)
    assert np.all(arrays["traction"] <= arrays["bound"] * (1 + 1e-6))
