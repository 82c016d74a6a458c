"""Structured meshes (mesh.structured): names and measures as netgen's meshes, refusals by key, convergence orders
of heat and elasticity on triangles / quadrilaterals, the Stefan strip against its closed form, contacts, probes
and output on quadrilaterals."""

from __future__ import annotations

import copy
import dataclasses

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech.errors import SceneError
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.geometry.structured import element_counts, structured_mesh
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.check_distributed import distributed_problems
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import contact_scenes, thermal_contact
from ngs_geomech.verification import structured as vs


def three_blocks(dimension: str) -> dict:
    """Block a with a glued inclusion b and a block c on top in contact (touching): plane, axisymmetric or 3d."""
    box = dimension == "3d"
    shape = "box" if box else "rectangle"
    fine = 0.2 if box else 0.1

    def blk(name, origin, size, **bnd):
        return {"name": name, "shape": shape, "origin": origin if box else origin[:2],
                "size": size if box else size[:2], "boundaries": bnd}
    up = "zmax" if box else "ymax"
    return {"scene": {"name": "three", "dimension": dimension}, "physics": {"thermal": "steady"},
            "mesh": {"maxh": 0.25, "boundary_maxh": {"top": fine}},
            "blocks": [blk("a", [0, 0, 0], [2, 1, 1], bottom="zmin" if box else "ymin", left="xmin",
                           walls=["ymin", "ymax"] if box else "xmax"),
                       {**blk("b", [0.5, 0.25, 0.25], [0.5, 0.5, 0.5]), "maxh": fine},
                       blk("c", [0, 0, 1], [1.5, 0.5, 0.5], top=up)] if box else
                      [blk("a", [1, 0, 0], [2, 1, 1], bottom="ymin", left="xmin", walls="xmax"),
                       {**blk("b", [1.5, 0.25, 0], [0.5, 0.5, 1]), "maxh": fine},
                       blk("c", [0, 1, 0], [1.5, 0.5, 1], top=up)],
            "interfaces": [{"name": "ab", "type": "glued", "blocks": ["a", "b"]},
                           {"name": "ac", "type": "contact", "blocks": ["a", "c"]}],
            "materials": {k: {"conductivity": 1.0} for k in "abc"},
            "boundary_conditions": {"bottom": {"temperature": 1.0}, "top": {"temperature": 0.0}}}


def measures(mesh) -> dict:
    """Every region's and boundary's measure."""
    one = ngs.CoefficientFunction(1.0)
    out = {("region", r): ngs.Integrate(one, mesh, definedon=mesh.Materials(r)) for r in set(mesh.GetMaterials())}
    out.update({("boundary", b): ngs.Integrate(one, mesh, definedon=mesh.Boundaries(b))
                for b in set(mesh.GetBoundaries())})
    return out


def longest_edge(mesh, boundary: str | None = None) -> float:
    pts = np.array([v.point for v in mesh.vertices])
    edges = (mesh.edges if boundary is None else
             [mesh[e] for el in mesh.Boundaries(boundary).Elements() for e in el.edges])
    return max(float(np.linalg.norm(pts[e.vertices[0].nr] - pts[e.vertices[1].nr])) for e in edges)


@pytest.mark.parametrize("dimension", ["plane", "axisymmetric", "3d"])
@pytest.mark.parametrize("elements", ["simplex", "tensor"])
def test_names_and_measures_as_netgen(dimension, elements):
    """Regions, boundaries (outer names, 'default', 'axis', the glued interface, both contact sides) with the
    measures of netgen's mesh; the contact sides have separate nodes; block and boundary maxh cap the cells."""
    data = three_blocks(dimension)
    data["mesh"].update(structured=True)
    scene = scene_from_dict(data)
    geo = validate(scene)                   # (3D contacts on hexahedra are refused for the physics only)
    ref = measures(make_mesh(geo, dataclasses.replace(scene.mesh, structured=False)))
    settings = dataclasses.replace(scene.mesh, elements=elements)
    mesh = make_mesh(geo, settings)
    got = measures(mesh)
    assert set(got) == set(ref)
    for key, value in ref.items():
        assert got[key] == pytest.approx(value, rel=1e-9), key
    assert (("boundary", "axis") in got) == (dimension == "axisymmetric")
    per = 1 if elements == "tensor" else (2 if dimension != "3d" else 6)
    assert mesh.ne == sum(element_counts(geo, settings).values())
    assert mesh.ne % per == 0
    fine = data["mesh"]["boundary_maxh"]["top"] * (1 + 1e-9)
    assert longest_edge(mesh, "top") <= fine * (1 if dimension != "3d" or elements == "tensor" else np.sqrt(2))
    region_b = [el for el in mesh.Elements(ngs.VOL) if el.mat == "b"]
    pts = np.array([v.point for v in mesh.vertices])
    assert max(np.ptp(pts[[v.nr for v in el.vertices]], axis=0).max() for el in region_b) <= fine
    vb = {v.nr for el in mesh.Boundaries("ac__a").Elements() for v in el.vertices}
    vc = {v.nr for el in mesh.Boundaries("ac__c").Elements() for v in el.vertices}
    assert not vb & vc


def test_sizes_per_axis():
    """mesh.sizes: one cell row across a 0.1 m strip, fine cells along x."""
    data = vs.strip_data(0.0125, "tensor", sizes=[0.0125, 0.1])
    scene = scene_from_dict(data)
    mesh = structured_mesh(validate(scene), scene.mesh)
    ys = np.unique(np.round([v.point[1] for v in mesh.vertices], 12))
    assert len(ys) == 2
    assert mesh.ne == len(np.unique(np.round([v.point[0] for v in mesh.vertices], 12))) - 1


REFUSED = [
    (lambda d: d["blocks"].append({"name": "disc", "shape": "circle", "center": [0.5, 0.5], "radius": 0.1}),
     "blocks[3] (disc).shape"),
    (lambda d: d.update(cuts=[{"name": "cut", "point": [1.5, 0.5], "dip": 0, "blocks": ["a"],
                                "parts": [["a_up", "a_down"]]}]), "cuts"),
    (lambda d: d.update(adaptivity={"max_refinements": 1}), "adaptivity"),
    (lambda d: d["mesh"].update(sizes=[0.1, 0.1, 0.1]), "mesh.sizes"),
    (lambda d: d["mesh"].update(structured=False, elements="tensor"), "mesh.elements"),
]


@pytest.mark.parametrize("change, item", REFUSED)
def test_refused_before_meshing(change, item):
    data = three_blocks("plane")
    data["mesh"]["structured"] = True
    change(data)
    with pytest.raises(SceneError) as err:
        validate(scene_from_dict(data))
    print(err.value)
    assert item in [p.item for p in err.value.problems]


def test_refused_3d_contact_on_hexahedra_and_distributed():
    data = three_blocks("3d")
    data["mesh"].update(structured=True, elements="tensor")
    with pytest.raises(SceneError) as err:
        validate(scene_from_dict(data))
    assert "interfaces[1] (ac).type" in [p.item for p in err.value.problems]
    data["mesh"]["elements"] = "simplex"
    assert "mesh.structured" in [p.item for p in distributed_problems(scene_from_dict(data))]


@pytest.mark.parametrize("elements", ["simplex", "tensor"])
@pytest.mark.parametrize("order, l2, h1", [(1, 2, 1), (2, 3, 2)])
def test_heat_orders(elements, order, l2, h1):
    out = vs.heat_convergence(elements, order, [0.25, 0.125, 0.0625])
    print(elements, order, out["l2"], out["order_l2"], out["order_h1"])
    assert out["order_l2"] == pytest.approx(l2, abs=0.15)
    assert out["order_h1"] == pytest.approx(h1, abs=0.15)


@pytest.mark.parametrize("elements", ["simplex", "tensor"])
@pytest.mark.parametrize("model", ["plane_strain", "axisymmetric"])
def test_elastic_orders(elements, model):
    out = vs.elastic_convergence(elements, model, 2, [0.25, 0.125])
    print(elements, model, out["l2"], out["order_l2"], out["order_h1"], out["order_stress"])
    assert out["order_l2"] == pytest.approx(3, abs=0.2)
    assert out["order_h1"] == pytest.approx(2, abs=0.2)
    assert out["order_stress"] == pytest.approx(2, abs=0.2)


def test_stefan_strip_front():
    """The Neumann strip: the anisotropic one-row strip (quadrilaterals, triangles) has the isotropic structured
    mesh's front (one-dimensional physics) and a smaller error than netgen's mesh of about as many dofs."""
    out = vs.anisotropic_strip(0.0125)
    iso = vs.strip_front(0.0125, "tensor")
    for k, v in {**out, "tensor_isotropic": iso}.items():
        print(k, v["dofs"], v["front_rel_error"])
    aniso = out["tensor_anisotropic"]
    assert aniso["front_rel_error"] < 5e-3
    assert out["simplex_anisotropic"]["front"] == pytest.approx(aniso["front"], rel=1e-9)
    assert iso["front"] == pytest.approx(aniso["front"], rel=1e-6)
    assert aniso["front_rel_error"] < out["netgen_equal_dofs"]["front_rel_error"]
    assert aniso["dofs"] <= 1.2 * out["netgen_equal_dofs"]["dofs"]


def test_stefan_on_hexahedra():
    """The strip as a 3D slab of hexahedra (one cell across y and z) has the 2D strip's front."""
    data = vs.strip_data(0.025, "tensor", sizes=[0.025, 0.1])
    flat = run_scene(scene_from_dict(copy.deepcopy(data)), None, progress=False).summary
    data["scene"]["dimension"] = "3d"
    data["blocks"][0].update(shape="box", origin=[0, 0, 0], size=data["blocks"][0]["size"] + [0.1])
    data["mesh"]["sizes"] = [0.025, 0.1, 0.1]
    slab = run_scene(scene_from_dict(data), None, progress=False).summary
    f2, f3 = (s["stefan"]["melted_volume"]["pcm"][-1] for s in (flat, slab))
    print(f2 / 0.1, f3 / 0.01)
    assert f3 / 0.01 == pytest.approx(f2 / 0.1, rel=1e-6)


@pytest.mark.parametrize("elements", ["simplex", "tensor"])
def test_contact_foundation_2d(elements):
    """The heated bar between two foundations (2D contact) on structured meshes: the closed-form pressure."""
    data = contact_scenes.heated_bar_scene()
    data["mesh"].update(structured=True, elements=elements)
    p_ref, _ = contact_scenes.heated_bar_pressure(lam=1.0, gap=1e-4, dT=60.0, L=1.0, E=20e9, nu=0.25, alpha=1e-5)
    res = run_scene(scene_from_dict(data), None, progress=False)
    for spec, out in zip(res.mechanics.contacts, res.mechanics.contact_output.latest):
        p = out["pressure"][spec.op.coverage > 1 - 1e-6]
        print(elements, spec.name, p.min(), p.max(), p_ref)
        assert np.max(np.abs(p - p_ref)) <= 1e-6 * p_ref


@pytest.mark.parametrize("dimension, elements", [("plane", "simplex"), ("plane", "tensor"), ("3d", "simplex")])
def test_contact_conductance(dimension, elements):
    """Two slabs in contact with a conductance (mortar coupling, non-matching sides): the closed-form flow."""
    data = thermal_contact.two_slabs_scene(dimension=dimension, maxh=0.1 if dimension == "plane" else 0.2)
    data["mesh"].update(structured=True, elements=elements)
    res = run_scene(scene_from_dict(data), None, progress=False)
    s = thermal_contact.SLABS
    q_ref = thermal_contact.slab_flux(50.0, s["L1"], s["L2"], s["k1"], s["k2"], s["T_a"], s["T_b"])
    flows = res.summary["heat"]["boundary_heat_flow"] if "heat" in res.summary else None
    print(dimension, elements, q_ref, flows)
    T = res.model.thermal.forms.temperature()
    mesh = T.space.mesh
    jump = (ngs.Integrate(T, mesh, definedon=mesh.Boundaries("joint__left"))
            - ngs.Integrate(T, mesh, definedon=mesh.Boundaries("joint__right")))
    area = ngs.Integrate(1, mesh, definedon=mesh.Boundaries("joint__left"))
    assert jump / area == pytest.approx(q_ref / 50.0, rel=1e-6)


def test_output_on_quadrilaterals(tmp_path):
    """VTK, figures, probes (region max, a point, the front) of a Stefan strip on quadrilaterals."""
    data = vs.strip_data(0.025, "tensor", t1=0.1)
    data["output"] = {"vtk": True, "figures": True, "every": 1,
                      "probes": [{"name": "tmax", "quantity": "temperature", "statistic": "max", "region": "pcm"},
                                 {"name": "mid", "quantity": "temperature", "point": [0.1, 0.05]},
                                 {"name": "front", "quantity": "front", "line": [[0.0, 0.05], [1.0, 0.05]]}]}
    res = run_scene(scene_from_dict(data), tmp_path / "out", progress=False)
    files = sorted(p.name for p in (tmp_path / "out").rglob("*"))
    print(files)
    assert any(f.endswith(".vtu") for f in files) and any(f.endswith(".png") for f in files)
    probes = res.summary["probes"]
    print(probes)
    assert probes["tmax"]["max"] == pytest.approx(vs.st.TWO_PHASE.t_hot, rel=1e-9)
    assert probes["mid"]["max"] < vs.st.TWO_PHASE.t_hot
    front = vs.st.TWO_PHASE.front(0.1)
    assert probes["front"]["max"] == pytest.approx(front, rel=0.1)
