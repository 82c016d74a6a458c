"""Geometry and meshes: every block shape, named sides, glued and contact interfaces, painter's order,
local mesh sizes and curved elements.

Scenes are built from plain dicts (the same data a TOML file holds) and assembled with
:func:`build_geometry`; meshes with :func:`make_mesh` (the code path of ``ngs-geomech run``).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech.geometry.assemble import build_geometry
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.scene.parse import scene_from_dict

pytestmark = pytest.mark.usefixtures("one_thread")


def make_scene(blocks, *, dimension="plane", interfaces=(), mesh=None):
    data = {"scene": {"name": "geometry_test", "dimension": dimension},
            "physics": {"thermal": "steady"},
            "mesh": mesh or {"maxh": 0.5},
            "blocks": list(blocks),
            "interfaces": list(interfaces),
            "materials": {b["name"]: {"conductivity": 1.0} for b in blocks}}
    return scene_from_dict(data)


def build(blocks, **kw):
    sc = make_scene(blocks, **kw)
    geo = build_geometry(sc)
    return sc, geo, make_mesh(geo, sc.mesh)


def area(mesh, region=None):
    """Area (2D) or volume (3D) of the mesh or of one region."""
    if region is None:
        return ngs.Integrate(ngs.CoefficientFunction(1.0), mesh)
    return ngs.Integrate(ngs.CoefficientFunction(1.0), mesh, definedon=mesh.Materials(region))


def boundary_measure(mesh, name):
    """Length (2D) or area (3D) of the named boundary."""
    return ngs.Integrate(ngs.CoefficientFunction(1.0), mesh, ngs.BND, definedon=mesh.Boundaries(name))


def boundary_vertices(mesh, name) -> set[int]:
    return {v.nr for el in mesh.Boundaries(name).Elements() for v in el.vertices}


def region_vertices(mesh, region) -> set[int]:
    return {v.nr for el in mesh.Materials(region).Elements() for v in el.vertices}


def region_elements(mesh, region) -> int:
    return sum(1 for _ in mesh.Materials(region).Elements())


def boundary_elements(mesh, name) -> int:
    return sum(1 for _ in mesh.Boundaries(name).Elements())


def vertex_coords(mesh, nrs) -> np.ndarray:
    pts = mesh.ngmesh.Points()
    return np.array([pts[i + 1].p for i in sorted(nrs)])  # netgen point index is 1-based


# -- 2D shapes --------------------------------------------------------------------------------------

def test_rectangle_selectors_name_each_side():
    _, geo, mesh = build([{"name": "rock", "shape": "rectangle", "origin": [1.0, -2.0], "size": [3.0, 2.0],
                           "boundaries": {"west": "xmin", "east": "xmax", "south": "ymin", "north": "ymax"}}])
    assert geo.regions == ["rock"] and geo.dim == 2
    assert geo.boundaries == {"west", "east", "south", "north"}
    assert set(mesh.GetMaterials()) == {"rock"}
    assert area(mesh) == pytest.approx(6.0, rel=1e-12)
    for name, length in (("west", 2.0), ("east", 2.0), ("south", 3.0), ("north", 3.0)):
        assert boundary_measure(mesh, name) == pytest.approx(length, rel=1e-12), name
    # the sides are where the selectors say
    xs = vertex_coords(mesh, boundary_vertices(mesh, "west"))[:, 0]
    assert np.allclose(xs, 1.0)
    ys = vertex_coords(mesh, boundary_vertices(mesh, "north"))[:, 1]
    assert np.allclose(ys, 0.0)


def test_rectangle_list_of_selectors_and_default_name():
    _, geo, mesh = build([{"name": "rock", "shape": "rectangle", "origin": [0.0, 0.0], "size": [2.0, 1.0],
                           "boundaries": {"far": ["xmax", "ymin", "ymax"]}}])
    assert geo.boundaries == {"far", "default"}
    assert boundary_measure(mesh, "far") == pytest.approx(5.0, rel=1e-12)
    assert boundary_measure(mesh, "default") == pytest.approx(1.0, rel=1e-12)


def test_polygon_with_per_edge_names():
    # an L-shaped body: side i runs from point i to point i+1
    pts = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]
    edges = ["floor", "right", "step", "step", "top", "wall"]
    _, geo, mesh = build([{"name": "ell", "shape": "polygon", "points": pts, "edges": edges}], mesh={"maxh": 0.3})
    assert geo.boundaries == {"floor", "right", "step", "top", "wall"}
    assert area(mesh) == pytest.approx(3.0, rel=1e-12)
    expected = {"floor": 2.0, "right": 1.0, "step": 2.0, "top": 1.0, "wall": 2.0}
    for name, length in expected.items():
        assert boundary_measure(mesh, name) == pytest.approx(length, rel=1e-12), name
    # 'floor' is the side y = 0, 'wall' the side x = 0
    assert np.allclose(vertex_coords(mesh, boundary_vertices(mesh, "floor"))[:, 1], 0.0)
    assert np.allclose(vertex_coords(mesh, boundary_vertices(mesh, "wall"))[:, 0], 0.0)


def test_circle():
    _, geo, mesh = build([{"name": "disc", "shape": "circle", "center": [1.0, 2.0], "radius": 0.5,
                           "boundaries": {"rim": "all"}}], mesh={"maxh": 0.05})
    assert geo.boundaries == {"rim"}
    assert area(mesh) == pytest.approx(math.pi * 0.25, rel=5e-3)
    assert boundary_measure(mesh, "rim") == pytest.approx(math.pi, rel=5e-3)
    r = np.linalg.norm(vertex_coords(mesh, boundary_vertices(mesh, "rim")) [:, :2] - [1.0, 2.0], axis=1)
    assert np.allclose(r, 0.5, atol=1e-9)


def test_profile_with_spline_segment_curved_fault():
    """A profile block whose east side is a spline through three points (a curved fault)."""
    fault = [[1.2, 0.5], [1.0, 1.0]]
    block = {"name": "west", "shape": "profile", "start": [0.0, 0.0],
             "segments": [{"line": [1.0, 0.0], "name": "base"},
                          {"spline": fault, "name": "fault"},
                          {"line": [0.0, 1.0], "name": "surface"},
                          {"line": [0.0, 0.0], "name": "axis"}]}
    _, geo, mesh = build([block], mesh={"maxh": 0.1, "order": 2})
    assert geo.boundaries == {"base", "fault", "surface", "axis"}
    # the spline bulges towards +x: the body is larger than the unit square, the fault longer than its chord
    assert area(mesh) > 1.05
    assert boundary_measure(mesh, "fault") > 1.02
    fault_pts = vertex_coords(mesh, boundary_vertices(mesh, "fault"))
    assert fault_pts[:, 0].max() == pytest.approx(1.2, abs=0.02)     # passes near its middle point
    mid = fault_pts[np.argmin(np.abs(fault_pts[:, 1] - 0.5))]
    assert mid[0] == pytest.approx(1.2, abs=0.02)
    for name in ("base", "surface", "axis"):
        assert boundary_measure(mesh, name) == pytest.approx(1.0, rel=1e-9), name


def test_profile_not_closed_is_an_error_naming_the_block():
    from ngs_geomech.errors import SceneError
    block = {"name": "open", "shape": "profile", "start": [0.0, 0.0],
             "segments": [{"line": [1.0, 0.0]}, {"line": [1.0, 1.0]}]}
    with pytest.raises(SceneError) as info:
        build_geometry(make_scene([block]))
    assert "blocks[0] (open)" in str(info.value) and "not closed" in str(info.value)


# -- 3D shapes --------------------------------------------------------------------------------------

def test_box_selectors_xmin_to_zmax():
    names = {"x0": "xmin", "x1": "xmax", "y0": "ymin", "y1": "ymax", "z0": "zmin", "z1": "zmax"}
    _, geo, mesh = build([{"name": "cube", "shape": "box", "origin": [0.0, 0.0, 0.0], "size": [1.0, 2.0, 3.0],
                           "boundaries": names}], dimension="3d", mesh={"maxh": 1.0})
    assert geo.dim == 3 and mesh.dim == 3
    assert geo.boundaries == set(names)
    assert area(mesh) == pytest.approx(6.0, rel=1e-12)
    expected = {"x0": 6.0, "x1": 6.0, "y0": 3.0, "y1": 3.0, "z0": 2.0, "z1": 2.0}
    for name, a in expected.items():
        assert boundary_measure(mesh, name) == pytest.approx(a, rel=1e-12), name
    for name, (axis, value) in {"x0": (0, 0.0), "x1": (0, 1.0), "y1": (1, 2.0), "z1": (2, 3.0)}.items():
        assert np.allclose(vertex_coords(mesh, boundary_vertices(mesh, name))[:, axis], value), name


def test_cylinder_top_bottom_lateral():
    _, geo, mesh = build([{"name": "plug", "shape": "cylinder", "center": [0.0, 0.0, -1.0], "radius": 0.5,
                           "height": 2.0, "boundaries": {"lid": "top", "sole": "bottom", "mantle": "lateral"}}],
                         dimension="3d", mesh={"maxh": 0.4, "order": 2})
    assert geo.boundaries == {"lid", "sole", "mantle"}
    assert boundary_measure(mesh, "lid") == pytest.approx(math.pi * 0.25, rel=1e-3)
    assert boundary_measure(mesh, "sole") == pytest.approx(math.pi * 0.25, rel=1e-3)
    assert boundary_measure(mesh, "mantle") == pytest.approx(2 * math.pi * 0.5 * 2.0, rel=1e-3)
    assert area(mesh) == pytest.approx(math.pi * 0.25 * 2.0, rel=1e-3)
    assert np.allclose(vertex_coords(mesh, boundary_vertices(mesh, "lid"))[:, 2], 1.0)
    assert np.allclose(vertex_coords(mesh, boundary_vertices(mesh, "sole"))[:, 2], -1.0)


def test_cylinder_accepts_zmin_zmax_along_z_axis():
    geo = build_geometry(make_scene([{"name": "plug", "shape": "cylinder", "center": [0.0, 0.0, 0.0],
                                      "radius": 1.0, "height": 1.0, "boundaries": {"lid": "zmax", "sole": "zmin"}}],
                                    dimension="3d"))
    assert geo.boundaries == {"lid", "sole", "default"}


# -- interfaces -------------------------------------------------------------------------------------

TWO_BLOCKS = [
    {"name": "left", "shape": "rectangle", "origin": [0.0, 0.0], "size": [1.0, 1.0],
     "boundaries": {"west": "xmin"}},
    {"name": "right", "shape": "rectangle", "origin": [1.0, 0.0], "size": [1.0, 1.0],
     "boundaries": {"east": "xmax"}},
]


def test_glued_interface_shares_nodes():
    _, geo, mesh = build(TWO_BLOCKS, interfaces=[{"name": "joint", "blocks": ["left", "right"], "type": "glued"}],
                         mesh={"maxh": 0.2})
    assert geo.glued == {"joint": ("left", "right")} and not geo.contacts
    assert "joint" in geo.boundaries
    on_joint = boundary_vertices(mesh, "joint")
    from_left = region_vertices(mesh, "left") & on_joint
    from_right = region_vertices(mesh, "right") & on_joint
    assert len(on_joint) >= 6
    # the same nodes seen from both regions: the meshes are conforming
    assert from_left == from_right == on_joint
    assert region_vertices(mesh, "left") & region_vertices(mesh, "right") == on_joint
    assert np.allclose(vertex_coords(mesh, on_joint)[:, 0], 1.0)
    assert boundary_measure(mesh, "joint") == pytest.approx(1.0, rel=1e-12)


def test_contact_interface_duplicates_nodes_and_allows_non_matching_meshes():
    blocks = [dict(TWO_BLOCKS[0], maxh=0.1), dict(TWO_BLOCKS[1], maxh=0.3)]
    _, geo, mesh = build(blocks, interfaces=[{"name": "slip", "blocks": ["left", "right"], "type": "contact"}],
                         mesh={"maxh": 0.5})
    cs = geo.contacts["slip"]
    assert (cs.master, cs.minion) == ("slip__left", "slip__right")
    assert {"slip__left", "slip__right"} <= geo.boundaries and "slip" not in geo.boundaries
    assert not geo.glued
    # both sides are boundaries of the mesh, each belonging to its own block
    side_l, side_r = boundary_vertices(mesh, "slip__left"), boundary_vertices(mesh, "slip__right")
    assert side_l <= region_vertices(mesh, "left") and side_r <= region_vertices(mesh, "right")
    # duplicated nodes: no node is shared by the two blocks, not even the end points
    assert not region_vertices(mesh, "left") & region_vertices(mesh, "right")
    assert not side_l & side_r
    for side in (side_l, side_r):
        assert np.allclose(vertex_coords(mesh, side)[:, 0], 1.0)
    assert boundary_measure(mesh, "slip__left") == pytest.approx(1.0, rel=1e-12)
    assert boundary_measure(mesh, "slip__right") == pytest.approx(1.0, rel=1e-12)
    # non-matching: the fine side has more nodes and nodes where the coarse side has none
    assert len(side_l) > 2 * len(side_r) - 1
    y_l = np.sort(vertex_coords(mesh, side_l)[:, 1])
    y_r = np.sort(vertex_coords(mesh, side_r)[:, 1])
    assert len(y_l) != len(y_r)
    assert any(np.min(np.abs(y_r - y)) > 1e-3 for y in y_l)


def test_contact_interface_master_and_3d_sides():
    blocks = [{"name": "lower", "shape": "box", "origin": [0.0, 0.0, 0.0], "size": [1.0, 1.0, 0.5], "maxh": 0.25},
              {"name": "upper", "shape": "box", "origin": [0.0, 0.0, 0.5], "size": [1.0, 1.0, 0.5], "maxh": 0.5}]
    _, geo, mesh = build(blocks, dimension="3d",
                         interfaces=[{"name": "seam", "blocks": ["lower", "upper"], "type": "contact",
                                      "master": "upper"}], mesh={"maxh": 0.5})
    cs = geo.contacts["seam"]
    assert (cs.master, cs.minion) == ("seam__upper", "seam__lower")
    a, b = boundary_vertices(mesh, "seam__lower"), boundary_vertices(mesh, "seam__upper")
    assert not a & b and len(a) > len(b)
    assert boundary_measure(mesh, "seam__lower") == pytest.approx(1.0, rel=1e-12)
    assert boundary_measure(mesh, "seam__upper") == pytest.approx(1.0, rel=1e-12)
    assert np.allclose(vertex_coords(mesh, a)[:, 2], 0.5) and np.allclose(vertex_coords(mesh, b)[:, 2], 0.5)
    # the block maxh acts in its own block only (the contact side of 'upper' stays coarse)
    assert region_elements(mesh, "lower") > 2 * region_elements(mesh, "upper")


def test_glued_interface_3d_shares_nodes():
    blocks = [{"name": "host", "shape": "box", "origin": [0.0, 0.0, 0.0], "size": [2.0, 1.0, 1.0]},
              {"name": "core", "shape": "box", "origin": [0.5, 0.25, 0.25], "size": [0.5, 0.5, 0.5]}]
    _, geo, mesh = build(blocks, dimension="3d", interfaces=[{"name": "shell", "blocks": ["host", "core"]}],
                         mesh={"maxh": 0.4})
    on = boundary_vertices(mesh, "shell")
    assert region_vertices(mesh, "host") & on == region_vertices(mesh, "core") & on == on
    assert boundary_measure(mesh, "shell") == pytest.approx(6 * 0.25, rel=1e-12)
    assert area(mesh, "core") == pytest.approx(0.125, rel=1e-12)
    assert area(mesh, "host") == pytest.approx(2.0 - 0.125, rel=1e-12)


# -- painter's order --------------------------------------------------------------------------------

def test_painters_order_cuts_inclusion_out_of_host():
    blocks = [{"name": "host", "shape": "rectangle", "origin": [0.0, 0.0], "size": [4.0, 2.0],
               "boundaries": {"outer": "all"}},
              {"name": "lens", "shape": "circle", "center": [1.0, 1.0], "radius": 0.5},
              {"name": "vein", "shape": "rectangle", "origin": [2.5, 0.0], "size": [0.5, 2.0]}]
    _, geo, mesh = build(blocks, interfaces=[{"name": "lens_rim", "blocks": ["host", "lens"]},
                                             {"name": "vein_sides", "blocks": ["vein", "host"]}],
                         mesh={"maxh": 0.2})
    assert set(mesh.GetMaterials()) == {"host", "lens", "vein"}
    a_host, a_lens, a_vein = area(mesh, "host"), area(mesh, "lens"), area(mesh, "vein")
    # the regions add up to the whole rectangle, exactly (its outline is straight)
    assert a_host + a_lens + a_vein == pytest.approx(8.0, rel=1e-12)
    assert a_vein == pytest.approx(1.0, rel=1e-12)
    assert a_lens == pytest.approx(math.pi * 0.25, rel=4e-2)    # an inscribed polygon (order 1)
    assert a_host == pytest.approx(8.0 - 1.0 - a_lens, rel=1e-12)
    # no host element inside the inclusion
    for el in mesh.Materials("host").Elements():
        c = np.mean([mesh.ngmesh.Points()[v.nr + 1].p[:2] for v in el.vertices], axis=0)
        assert np.hypot(c[0] - 1.0, c[1] - 1.0) > 0.45
    # the vein cut the outer boundary of the host in two: the outer length is still 12
    assert boundary_measure(mesh, "outer") == pytest.approx(12.0 - 2 * 0.5, rel=1e-12)


def test_painters_order_later_block_wins():
    """The same two overlapping rectangles in the two orders: the later one keeps the overlap."""
    a = {"name": "a", "shape": "rectangle", "origin": [0.0, 0.0], "size": [2.0, 1.0]}
    b = {"name": "b", "shape": "rectangle", "origin": [1.5, 0.0], "size": [1.0, 1.0]}
    itf = [{"name": "ab", "blocks": ["a", "b"]}]
    _, _, m1 = build([a, b], interfaces=itf)
    _, _, m2 = build([b, a], interfaces=itf)
    assert (area(m1, "a"), area(m1, "b")) == (pytest.approx(1.5), pytest.approx(1.0))
    assert (area(m2, "a"), area(m2, "b")) == (pytest.approx(2.0), pytest.approx(0.5))


# -- local mesh sizes -------------------------------------------------------------------------------

def test_block_maxh_refines_that_region_only():
    blocks = [dict(TWO_BLOCKS[0]), dict(TWO_BLOCKS[1])]
    itf = [{"name": "joint", "blocks": ["left", "right"]}]
    _, _, coarse = build(blocks, interfaces=itf, mesh={"maxh": 0.25})
    blocks[1]["maxh"] = 0.05
    _, _, fine = build(blocks, interfaces=itf, mesh={"maxh": 0.25})
    n_right = region_elements(fine, "right")
    assert n_right > 10 * region_elements(coarse, "right")
    # about (1 / 0.05)^2 * 2 / sqrt(3) ... triangles: at least 1/h^2
    assert n_right > 1 / 0.05**2
    # mean element size in the refined block is below its maxh, the other block stays coarse
    assert math.sqrt(area(fine, "right") / n_right) < 0.05
    assert region_elements(fine, "left") < region_elements(fine, "right") / 4


def test_boundary_maxh_refines_along_that_boundary():
    block = {"name": "rock", "shape": "rectangle", "origin": [0.0, 0.0], "size": [2.0, 1.0],
             "boundaries": {"west": "xmin", "east": "xmax"}}
    _, _, mesh = build([block], mesh={"maxh": 0.5, "boundary_maxh": {"west": 0.02}})
    n_west, n_east = boundary_elements(mesh, "west"), boundary_elements(mesh, "east")
    assert n_west >= 0.8 / 0.02      # edge length about 0.02 (netgen's target size) on a side of length 1
    assert n_east <= 4
    # the refinement is local: elements near the east side are much larger than near the west side
    sizes = {"west": [], "east": []}
    pts = mesh.ngmesh.Points()
    for el in mesh.Elements(ngs.VOL):
        xy = np.array([pts[v.nr + 1].p[:2] for v in el.vertices])
        h = max(np.linalg.norm(xy[i] - xy[j]) for i in range(3) for j in range(i))
        c = xy.mean(axis=0)
        if c[0] < 0.05:
            sizes["west"].append(h)
        elif c[0] > 1.8:
            sizes["east"].append(h)
    assert np.mean(sizes["west"]) < 0.04 and max(sizes["west"]) < 0.08
    assert np.mean(sizes["east"]) > 0.2


# -- curved elements --------------------------------------------------------------------------------

def test_order_2_curves_a_circle():
    block = {"name": "disc", "shape": "circle", "center": [0.0, 0.0], "radius": 1.0}
    errors = {}
    for order in (1, 2):
        _, _, mesh = build([block], mesh={"maxh": 0.3, "order": order})
        errors[order] = abs(area(mesh) - math.pi)
    # P1: the inscribed polygon, error ~ h^2; P2: curved edges, error ~ h^4 or better
    assert errors[1] > 1e-3
    assert errors[2] < errors[1] / 100


def test_clockwise_polygon_is_taken_counterclockwise_with_its_edge_names():
    """A clockwise polygon was refused as 'entirely covered by blocks declared after it' (its face had negative
    area); it is now the same polygon counterclockwise, each edge keeping its name."""
    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.scene.parse import scene_from_dict
    from ngs_geomech.validation.validate import validate

    def scene(points, edges):
        return scene_from_dict({"scene": {"name": "cw"}, "physics": {"thermal": "steady"}, "mesh": {"maxh": 0.25},
                                "blocks": [{"name": "a", "shape": "polygon", "points": points, "edges": edges}],
                                "materials": {"a": {"conductivity": 1.0}},
                                "boundary_conditions": {"bottom": {"temperature": 0.0}, "right": {"temperature": 1.0}}})
    ccw = scene([[0, 0], [1, 0], [1, 1], [0, 1]], ["bottom", "right", "top", "left"])
    cw = scene([[0, 0], [0, 1], [1, 1], [1, 0]], ["left", "top", "right", "bottom"])
    meshes = [make_mesh(validate(s), s.mesh) for s in (ccw, cw)]
    for m in meshes:
        assert set(m.GetBoundaries()) == {"bottom", "right", "top", "left"}
        pts = {name: sorted({tuple(np.round(m[v].point, 9)) for el in m.Boundaries(name).Elements()
                             for v in el.vertices}) for name in ("bottom", "right")}
        assert all(p[1] == 0.0 for p in pts["bottom"]) and all(p[0] == 1.0 for p in pts["right"])


def test_tanh_expression_is_finite_for_large_arguments():
    """tanh in scene expressions: finite and +-1 far out (was (exp(2v) - 1)/(exp(2v) + 1): NaN for v > ~355)."""
    from ngs_geomech.fem.coefficients import expression_function

    mesh = ngs.Mesh(ngs.unit_square.GenerateMesh(maxh=0.5))
    f = expression_function("tanh(1000*(x - 0.5))")(0.0)
    for xv, expected in ((0.0, -1.0), (1.0, 1.0), (0.5, 0.0), (0.5 + 1e-4, math.tanh(0.1))):
        val = f(mesh(xv, 0.5))
        assert math.isfinite(val) and abs(val - expected) < 1e-12, (xv, val)
    assert abs(ngs.Integrate(f, mesh)) < 1e-2
