"""Heat passes a contact interface as it passes a glued one (seed (2.22)): curved interfaces (a circular
inclusion with independent, non-matching meshes) and axisymmetric scenes (weight r in the mortar integrals).
Errors and orders are printed; contact must converge at the glued orders within a small factor.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech.fem.coefficients import expression_function
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.heat.forms import HeatForms
from ngs_geomech.heat.problem import heat_setup
from ngs_geomech.heat.solver import HeatSolver
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate


def solve(scene_dict, exact: str, q: str | None):
    scene = scene_from_dict(scene_dict)
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    setup = heat_setup(scene, geo, mesh)
    if q is not None:
        setup.sources = {r: expression_function(q) for r in geo.regions}
    forms = HeatForms(mesh, setup)
    HeatSolver(forms).solve("steady")
    T = forms.temperature()
    ex = expression_function(exact)(0)
    gex = ngs.CoefficientFunction((ex.Diff(ngs.x), ex.Diff(ngs.y)))
    w = ngs.x if scene.scene.dimension == "axisymmetric" else 1
    order = 2 * scene.mesh.order + 4
    l2 = math.sqrt(ngs.Integrate(w * (T - ex) ** 2, mesh, order=order))
    h1 = math.sqrt(ngs.Integrate(w * ngs.InnerProduct(ngs.grad(T) - gex, ngs.grad(T) - gex), mesh, order=order))
    return l2, h1, forms.X.ndof


def inclusion_scene(h, order, kind):
    return {"scene": {"name": "incl"}, "physics": {"thermal": "steady"},
            "mesh": {"maxh": h, "order": order},
            "blocks": [{"name": "host", "shape": "rectangle", "origin": [-1, -1], "size": [2, 2],
                        "boundaries": {"outer": "all"}},
                       {"name": "incl", "shape": "circle", "center": [0.1, 0.05], "radius": 0.5, "maxh": 0.6 * h}],
            "interfaces": [{"name": "ring", "blocks": ["host", "incl"], "type": kind}],
            "materials": {"host": {"conductivity": 1.0}, "incl": {"conductivity": 1.0}},
            "boundary_conditions": {"outer": {"temperature": "sin(x)*exp(y)"}}}


def rates(hs, errs):
    return [math.log(errs[i - 1] / errs[i]) / math.log(hs[i - 1] / hs[i]) for i in range(1, len(hs))]


@pytest.mark.parametrize("order", [1, 2])
def test_curved_contact_converges_like_glued(order):
    hs = (0.4, 0.2, 0.1)
    res = {k: [solve(inclusion_scene(h, order, k), "sin(x)*exp(y)", "0") for h in hs] for k in ("glued", "contact")}
    print(f"\ncircular inclusion, P{order}, T = sin(x) exp(y) (harmonic)")
    for k, rows in res.items():
        l2, h1 = [r[0] for r in rows], [r[1] for r in rows]
        r2 = " ".join(f"{r:.2f}" for r in rates(hs, l2))
        r1 = " ".join(f"{r:.2f}" for r in rates(hs, h1))
        print(f"  {k:8s} L2 {' '.join(f'{e:.2e}' for e in l2)}  rates {r2}"
              f"  H1 {' '.join(f'{e:.2e}' for e in h1)}  rates {r1}")
    gl2, gh1 = [r[0] for r in res["glued"]], [r[1] for r in res["glued"]]
    cl2, ch1 = [r[0] for r in res["contact"]], [r[1] for r in res["contact"]]
    assert rates(hs, ch1)[-1] >= order - 0.15
    assert rates(hs, cl2)[-1] >= order + 1 - 0.3
    assert ch1[-1] <= 1.5 * gh1[-1] and cl2[-1] <= 2.0 * gl2[-1]


@pytest.mark.parametrize("order,exact", [(1, "1 + 2*x + 3*y"), (2, "x*x + 3*y*y - 2*x*y + x")])
def test_axisymmetric_contact_patch_test(order, exact):
    """A polynomial of degree p is reproduced exactly across a non-matching contact interface (weight r)."""
    # -1/r d/dr(r dT/dr) - d2T/dz2 for the two exact solutions
    q = {1: "-2/x", 2: "-(4*x - 2*y + 1)/x - 6"}[order]
    d = {"scene": {"name": "axi", "dimension": "axisymmetric"}, "physics": {"thermal": "steady"},
         "mesh": {"maxh": 0.3, "order": order},
         "blocks": [{"name": "a", "shape": "rectangle", "origin": [0.5, 0], "size": [0.5, 1],
                     "boundaries": {"oa": ["xmin", "ymin", "ymax"]}},
                    {"name": "b", "shape": "rectangle", "origin": [1.0, 0], "size": [0.5, 1], "maxh": 0.17,
                     "boundaries": {"ob": ["xmax", "ymin", "ymax"]}}],
         "interfaces": [{"name": "i", "blocks": ["a", "b"], "type": "contact"}],
         "materials": {"a": {"conductivity": 1.0}, "b": {"conductivity": 1.0}},
         "boundary_conditions": {"oa": {"temperature": exact}, "ob": {"temperature": exact}}}
    l2, h1, ndof = solve(d, exact, q)
    print(f"\naxisymmetric patch test P{order}: L2 {l2:.2e}, H1 {h1:.2e} ({ndof} dofs)")
    assert l2 < 1e-10 and h1 < 1e-9


def test_contact_meshes_do_not_match():
    scene = scene_from_dict(inclusion_scene(0.2, 1, "contact"))
    mesh = make_mesh(validate(scene), scene.mesh)
    sides = {}
    for name in ("ring__host", "ring__incl"):
        sides[name] = np.sort([round(math.atan2(mesh[v].point[1] - 0.05, mesh[v].point[0] - 0.1), 9)
                               for el in mesh.Boundaries(name).Elements() for v in el.vertices])
    a, b = (np.unique(v) for v in sides.values())
    assert len(a) != len(b) or not np.allclose(a, b)


def box_pair_scene(h, order, kind):
    ex = "sin(x)*exp(y)*cos(z*0.5)"
    return {"scene": {"name": "c3", "dimension": "3d"}, "physics": {"thermal": "steady"},
            "mesh": {"maxh": h, "order": order},
            "blocks": [{"name": "a", "shape": "box", "origin": [0, 0, 0], "size": [0.5, 1, 1],
                        "boundaries": {"oa": "xmin"}},
                       {"name": "b", "shape": "box", "origin": [0.5, 0, 0], "size": [0.5, 1, 1], "maxh": 0.7 * h,
                        "boundaries": {"ob": "xmax"}}],
            "interfaces": [{"name": "i", "blocks": ["a", "b"], "type": kind}],
            "materials": {"a": {"conductivity": 1.0}, "b": {"conductivity": 1.0}},
            "boundary_conditions": {"oa": {"temperature": ex}, "ob": {"temperature": ex}}}, ex


def solve_3d(h, order, kind, dirichlet_sides=False):
    d, ex = box_pair_scene(h, order, kind)
    if dirichlet_sides:   # the interface then meets Dirichlet boundaries along a closed cross curve
        d["blocks"][0]["boundaries"] = {"oa": "all"}
        d["blocks"][1]["boundaries"] = {"ob": "all"}
    scene = scene_from_dict(d)
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    setup = heat_setup(scene, geo, mesh)
    T = expression_function(ex)(0)
    g = ngs.CoefficientFunction((T.Diff(ngs.x), T.Diff(ngs.y), T.Diff(ngs.z)))
    q = -(g[0].Diff(ngs.x) + g[1].Diff(ngs.y) + g[2].Diff(ngs.z))
    n = ngs.specialcf.normal(3)
    setup.sources = {"a": lambda t: q, "b": lambda t: q}
    if not dirichlet_sides:
        setup.flux = {"default": lambda t: g * n}   # exact flux on the four sides (no Dirichlet cross points)
    forms = HeatForms(mesh, setup)
    HeatSolver(forms).solve("steady")
    Th = forms.temperature()
    h1 = math.sqrt(ngs.Integrate(ngs.InnerProduct(ngs.grad(Th) - g, ngs.grad(Th) - g), mesh, order=8))
    return h1, forms.X.ndof


def test_3d_contact_p2_converges_like_glued():
    """3D, P2, non-matching meshes on the two sides of a planar contact interface: the segment-based mortar
    (triangles clipped against each other) keeps the glued order."""
    hs = (0.4, 0.2)
    glued = [solve_3d(h, 2, "glued")[0] for h in hs]
    contact = [solve_3d(h, 2, "contact")[0] for h in hs]
    print(f"\n3D P2 H1 errors: glued {glued[0]:.2e} {glued[1]:.2e} (rate {rates(hs, glued)[0]:.2f}), "
          f"contact {contact[0]:.2e} {contact[1]:.2e} (rate {rates(hs, contact)[0]:.2f})")
    assert rates(hs, contact)[0] >= 1.6
    assert contact[1] <= 1.6 * glued[1]


def test_3d_contact_p2_with_dirichlet_cross_curve():
    """The same with Dirichlet data on every outer face: the interface meets them along its whole rim, where
    the multiplier space is reduced to degree p - 1; P2 keeps its order."""
    hs = (0.4, 0.2)
    glued = [solve_3d(h, 2, "glued", True)[0] for h in hs]
    contact = [solve_3d(h, 2, "contact", True)[0] for h in hs]
    print(f"\n3D P2, Dirichlet cross curve, H1 errors: glued {glued[0]:.2e} {glued[1]:.2e}, contact "
          f"{contact[0]:.2e} {contact[1]:.2e} (rate {rates(hs, contact)[0]:.2f})")
    assert rates(hs, contact)[0] >= 1.6
    assert contact[1] <= 1.6 * glued[1]
