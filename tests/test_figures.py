"""Figures a reader can use: lengths in km on large domains, colour bars no taller (or wider) than their axes,
legends outside the data, stresses in MPa or GPa, a thin column's axis profile and tick labels that do not
overlap, plane sections of 3D scenes (the plane's grid and the cut of the mesh surface, the figures a 3D run
writes). Small synthetic meshes as arrays; the figures are laid out with the Agg renderer and measured."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from test_stress_figures import square_mesh

from ngs_geomech import api
from ngs_geomech.errors import SceneError
from ngs_geomech.io import figures, layout, scales
from ngs_geomech.io.meshdata import MeshArrays
from ngs_geomech.io.profiles import AxisProfile
from ngs_geomech.io.sections import SectionPlane
from ngs_geomech.io.stress_figures import grid_samples, principal_2d, principal_stress_crosses
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.scene.units import YEAR
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

SHAPES = {"column 20 m x 1000 m": (20.0, 1000.0), "plate 400 km x 150 km": (400e3, 150e3),
          "strip 1000 km x 10 km": (1000e3, 10e3), "square 1 m": (1.0, 1.0), "tall 1 m x 30 m": (1.0, 30.0),
          "domain 100 km": (100e3, 40e3)}


def box_mesh(width: float, height: float, n: int = 10) -> MeshArrays:
    """A structured triangulation of [0, width] x [-height, 0]."""
    m = square_mesh(n=n, size=1.0)
    s = np.array([width, height])
    return MeshArrays(m.points * s - [0.0, height], m.triangles, m.tri_region, m.regions,
                      m.outline * s - [0.0, height])


def boxes(fig, *artists) -> list:
    """The artists' window extents (display pixels) after the figure is drawn."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    return [a.get_window_extent(r) for a in artists]


def tick_label_boxes(fig, axis) -> list:
    """The extents of an axis's visible, non-empty tick labels inside its view."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    lo, hi = sorted(axis.get_view_interval())
    tol = 1e-9 * (hi - lo)
    return [lab.get_window_extent(r) for t in axis.get_major_ticks() if lo - tol <= t.get_loc() <= hi + tol
            for lab in (t.label1, t.label2) if lab.get_visible() and lab.get_text()]


def overlapping(bbs) -> list:
    return [(a, b) for a, b in itertools.combinations(bbs, 2) if a.overlaps(b)]


def field(tmp_path, width, height, **kw):
    m = box_mesh(width, height)
    return figures.field_figure(m, m.points[:, 1], tmp_path / "f.png", title="a field", label="T (degC)", **kw), m


# -- units -----------------------------------------------------------------------------------------------------
def test_stresses_in_mpa_or_gpa_by_magnitude():
    assert scales.stress_scale([3e5, -2e8]) == ("MPa", 1e6)          # never Pa, even for kPa stresses
    assert scales.stress_scale([0.999e9]).unit == "MPa"
    assert scales.stress_scale([1e9]).unit == "GPa"
    assert scales.stress_scale([np.nan, -1.4e10, 2.0]).unit == "GPa"   # NaN (e.g. open contact) ignored
    assert scales.stress_scale([]).unit == "MPa"
    assert scales.stress_scale([-1.4e10])([-1.4e10]).tolist() == [-14.0]
    assert scales.displacement_scale([0.004, -0.2]) == ("mm", 1e-3)
    assert scales.displacement_scale([5.7e3]).unit == "m"
    assert scales.length_scale(9999.0).unit == "m" and scales.length_scale(10e3).unit == "km"
    assert scales.with_unit("von Mises stress (MPa)", "GPa") == "von Mises stress (GPa)"
    assert scales.with_unit("x (m)", "km") == "x (km)" and scales.with_unit("depth", "m") == "depth (m)"
    assert scales.figure_time(6e4 * YEAR) == "60 kyr" and scales.figure_time(2.5e6 * YEAR) == "2.5 Myr"
    assert scales.figure_time(50 * YEAR) == "50 y"


def test_a_100_km_domain_has_km_axes(tmp_path):
    fig, _ = field(tmp_path, 100e3, 40e3)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x (km)" and ax.get_ylabel() == "y (km)"
    fig.canvas.draw()
    xt = [float(t.get_text().replace("−", "-")) for t in ax.get_xticklabels() if t.get_text()]
    print(f"\n100 km domain: x tick labels {xt}")
    assert max(xt) == pytest.approx(100.0) and min(xt) == pytest.approx(0.0)
    fig, _ = field(tmp_path, 5e3, 2e3)                       # a 5 km domain stays in m
    assert fig.axes[0].get_xlabel() == "x (m)"


def test_crosses_state_gpa_and_km(tmp_path):
    m = box_mesh(400e3, 150e3)
    smp = grid_samples(m, 20e3)
    x, y = smp.xy.T
    s1, s2, th = principal_2d(-3e9 + 0 * x, 1e8 * (y / 150e3), 0 * x)
    fig = principal_stress_crosses(m, smp, s1, s2, th, tmp_path / "c.png", title="crosses",
                                   background=np.hypot(*m.points.T), background_label="von Mises stress (GPa)")
    texts = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]
    assert any("GPa" in t and "bar length" in t for t in texts), texts
    assert fig.axes[0].get_xlabel() == "x (km)"


# -- colour bars -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("shape", list(SHAPES))
def test_colour_bar_no_taller_than_the_axes(tmp_path, shape):
    fig, _ = field(tmp_path, *SHAPES[shape])
    ax, cax = fig.axes[0], fig.axes[1]
    a, c = boxes(fig, ax, cax)
    vertical = c.height > c.width
    print(f"\n{shape}: axes {a.width:.0f} x {a.height:.0f} px, colour bar {c.width:.0f} x {c.height:.0f} px "
          f"({'beside' if vertical else 'below'})")
    assert c.height <= a.height + 0.5 and c.width <= a.width + 0.5
    if vertical:
        assert c.height == pytest.approx(a.height, abs=1.0)       # as tall as the axes
        assert c.x0 >= a.x1 - 0.5                                  # beside them
    else:
        assert c.width == pytest.approx(a.width, abs=1.0)
        assert c.y1 <= a.y0 + 0.5
    assert a.height >= 40 and a.width >= 40                        # the domain itself stays readable


def test_colour_bars_of_crosses_and_sections_fit_their_axes(tmp_path):
    m = box_mesh(2.0, 1.0)
    smp = grid_samples(m, 0.1)
    s1, s2, th = principal_2d(*np.ones((3, len(smp.xy))) * [[1e6], [-2e6], [0.5e6]])
    fig = principal_stress_crosses(m, smp, s1, s2, th, tmp_path / "c.png", title="crosses",
                                   background=m.points[:, 0], background_label="x")
    a, c = boxes(fig, fig.axes[0], fig.axes[1])
    assert c.height <= a.height + 0.5
    u, v = np.linspace(-20, 20, 50), np.linspace(-1500, 0, 300)
    fig = figures.section_figure(u, v, np.add.outer(v, u), tmp_path / "s.png", title="a section", label="T",
                                 axis_labels=("y (m)", "z (m)"))
    a, c = boxes(fig, fig.axes[0], fig.axes[1])
    assert c.height <= a.height + 0.5 and c.width <= a.width + 0.5


# -- legends -----------------------------------------------------------------------------------------------------
def test_legends_cover_no_data(tmp_path):
    t = np.linspace(0.0, 10.0, 200)
    curves = {f"probe_{k}": np.sin(t + k) + 0.1 * k for k in range(9)}       # dense: no empty corner
    fig = figures.time_curves(t, curves, tmp_path / "t.png", title="probes", ylabel="T (degC)",
                              hlines={"limit": 1.0})
    ax = fig.axes[0]
    a, lg = boxes(fig, ax, ax.get_legend())
    assert not a.overlaps(lg) and lg.x0 >= a.x1
    fig = figures.interface_profiles(np.linspace(0, 120e3, 30), [{"p": np.ones(30), "q": np.zeros(30)},
                                                                 {"gap": np.ones(30)}], tmp_path / "i.png",
                                     title="contact", ylabels=["MPa", "mm"], status=np.arange(30) % 3,
                                     xlabel="arc length along the side (m)", start=(100e3, 0.0))
    for ax in fig.axes:
        a, lg = boxes(fig, ax, ax.get_legend())
        assert not a.overlaps(lg)
    assert fig.axes[-1].get_xlabel() == "arc length along the side from (100, 0) (km)"
    fig = figures.convergence_figure([10, 100, 1000], {"estimate": [1, 0.3, 0.1]}, tmp_path / "c.png",
                                     title="adaptivity", ylabel="error")
    a, lg = boxes(fig, fig.axes[0], fig.axes[0].get_legend())
    assert not a.overlaps(lg)


def test_field_and_crosses_legends_lie_below_the_axes_and_their_labels(tmp_path):
    m = box_mesh(6.0, 4.0)
    iso = np.array([[[0.0, -2.0], [6.0, -2.0]]])
    fig = figures.field_figure(m, m.points[:, 1], tmp_path / "f.png", title="phase boundary", label="T",
                               lines=iso, lines_label="phase boundary (liquid fraction 1/2)")
    ax = fig.axes[0]
    a, lg, xl, cb = boxes(fig, ax, fig.legends[0], ax.xaxis.label, fig.axes[1])
    assert lg.y1 <= min(a.y0, xl.y0, cb.y0) + 0.5
    smp = grid_samples(m, 0.5)
    s1, s2, th = principal_2d(-1e7 + 0 * smp.xy[:, 0], 2e6 + 0 * smp.xy[:, 0], 0 * smp.xy[:, 0])
    fig = principal_stress_crosses(m, smp, s1, s2, th, tmp_path / "c.png", title="crosses")
    ax = fig.axes[0]
    a, lg, xl = boxes(fig, ax, fig.legends[0], ax.xaxis.label)
    assert lg.y1 <= min(a.y0, xl.y0) + 0.5


# -- thin columns ------------------------------------------------------------------------------------------------
def test_thin_column_is_stretched_and_its_tick_labels_do_not_overlap(tmp_path):
    fig, _ = field(tmp_path, 20.0, 1000.0)
    ax = fig.axes[0]
    assert "stretched 12.5x" in ax.get_xlabel()
    for axis in (ax.xaxis, ax.yaxis, fig.axes[1].yaxis):
        bbs = tick_label_boxes(fig, axis)
        assert len(bbs) >= 2 and overlapping(bbs) == []
    a, = boxes(fig, ax)
    print(f"\npermafrost-like column: axes {a.width:.0f} x {a.height:.0f} px")
    assert a.height / a.width == pytest.approx(layout.MAX_DISPLAY_ASPECT, rel=0.02)


@pytest.mark.parametrize("shape", list(SHAPES))
def test_no_overlapping_tick_labels(tmp_path, shape):
    fig, _ = field(tmp_path, *SHAPES[shape])
    for axis in (fig.axes[0].xaxis, fig.axes[0].yaxis):
        assert overlapping(tick_label_boxes(fig, axis)) == []


def test_profile_figure(tmp_path):
    z = np.linspace(-1000.0, 0.0, 101)
    profiles = {f"t = {k} kyr": 4 - 0.015 * z - k for k in range(6)}
    fig = figures.profile_figure(z, profiles, tmp_path / "p.png", title="T along the axis", value_label="T (degC)",
                                 coord_label="y (m)")
    ax = fig.axes[0]
    assert ax.get_ylabel() == "y (m)" and ax.get_xlabel() == "T (degC)"
    a, lg = boxes(fig, ax, ax.get_legend())
    assert not a.overlaps(lg)
    assert overlapping(tick_label_boxes(fig, ax.yaxis)) == []
    fig = figures.profile_figure(np.linspace(0, 50e3, 11), {"T": np.ones(11)}, tmp_path / "q.png", title="strip",
                                 value_label="T", coord_label="x (m)", vertical=False)
    assert fig.axes[0].get_xlabel() == "x (km)"


def test_thin_boxes_and_the_profile_times():
    assert layout.thin([0, -1000], [20, 0]) == 1
    assert layout.thin([-3, -20, -1500], [3, 20, 0]) == 2
    assert layout.thin([0, 0], [400e3, 150e3]) is None and layout.thin([0, 0, 0], [1, 8, 8]) is None
    assert AxisProfile.of([0, 0], [1, 1], 0.0, 1.0) is None
    pr = AxisProfile.of([0, -1000], [20, 0], 0.0, 100.0)
    assert pr.axis == 1 and np.allclose(pr.points[:, 0], 10.0) and pr.coord[0] == -1000 and pr.coord[-1] == 0
    kept = [t for t in [0, 7, 15, 19, 20.5, 33, 41, 47, 55, 80, 99.9999999999, 100.0] if pr.due(t) and
            not pr.times.append(t)]
    assert kept == [0, 20.5, 41, 80, 99.9999999999]      # the first at or after 0, 20, 40, 60 (80), 80, 100
    pr.values[:] = [[float(t)] * 3 for t in pr.times]
    again = AxisProfile.of([0, -1000], [20, 0], 0.0, 100.0)      # a resumed run: the kept profiles come back
    again.restore(pr.meta(3))
    assert again.times == [0, 20.5, 41] and again.values[2] == [41.0] * 3
    assert not again.due(59.0) and again.due(60.0)
    steady = AxisProfile.of([0, -1000], [20, 0], 0.0, 0.0)
    assert steady.targets == [0.0] and steady.due(0.0)


# -- sections ----------------------------------------------------------------------------------------------------
def cube_surface() -> np.ndarray:
    """The 12 surface triangles of the unit cube [0, 1]^3."""
    tris = []
    for axis in range(3):
        for side in (0.0, 1.0):
            i, j = (k for k in range(3) if k != axis)
            quad = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = np.zeros(3)
                p[axis], p[i], p[j] = side, a, b
                quad.append(p)
            tris += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    return np.array(tris)


def test_section_planes_cut_the_surface_and_sample_the_plane():
    plane = SectionPlane.through("y_mid", [0.5, 0.5, 0.5], [0.0, 2.0, 0.0])
    assert plane.labels == ("x (m)", "z (m)") and plane.description == "y = 0.5 m"
    segs = plane.cut(cube_surface())
    # the square's four sides (each face's two triangles give one piece each): length 4 in all
    assert segs.shape[1:] == (2, 2)
    assert np.sum(np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)) == pytest.approx(4.0, rel=1e-12)
    assert segs.min() == pytest.approx(0.0) and segs.max() == pytest.approx(1.0)
    a, b, pts = plane.grid([0, 0, 0], [1, 1, 1], n=20)
    assert len(a) == len(b) == 20 and pts.shape == (400, 3) and np.allclose(pts[:, 1], 0.5)
    assert np.allclose(pts[:20, 0], a) and np.allclose(pts[::20, 2], b)
    tilted = SectionPlane.through("dip", [0.5, 0.5, 0.5], [0.0, -1.0, 1.0])   # dips 45 degrees
    u, v, n = (np.array(x) for x in (tilted.u, tilted.v, tilted.normal))
    assert abs(u @ v) < 1e-14 and abs(u @ n) < 1e-14 and abs(v @ n) < 1e-14 and abs(u[2]) < 1e-14 and v[2] > 0
    segs = tilted.cut(cube_surface())
    length = np.sum(np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1))
    assert length == pytest.approx(2 + 2 * math.sqrt(2), rel=1e-12)    # a 1 x sqrt(2) rectangle
    np.testing.assert_allclose(tilted.extent([0, 0, 0], [1, 1, 1]), [0, 1, 0, math.sqrt(2)], atol=1e-14)
    column = tilted.extent([0, 0, -10], [1, 1, 10])          # the plane's cut of a tall box, not its shadow
    assert column[3] - column[2] == pytest.approx(math.sqrt(2), rel=1e-12)
    mids = SectionPlane.mid_planes([0, 0, -10], [2, 4, 0])
    assert [p.name for p in mids] == ["x", "y", "z"] and mids[2].point == (1.0, 2.0, -5.0)
    win = SectionPlane.through("w", [0, 0, 0], [1, 0, 0], window=[-1, 1, -2, 2])
    assert win.extent([0, 0, 0], [9, 9, 9]) == (-1.0, 1.0, -2.0, 2.0)


def column_scene(sections=None, mechanics=True) -> dict:
    """A 3D column 1 m x 1 m x 10 m (thin: a profile along z) with a warm inclusion, steady heat, static
    mechanics with the base held."""
    rock = {"conductivity": 3.0, "youngs_modulus": 5e10, "poisson_ratio": 0.25, "thermal_expansion": 1e-5,
            "stress_free_temperature": 0.0}
    d = {"scene": {"name": "column3d", "dimension": "3d"},
         "physics": {"thermal": "steady", **({"mechanics": "static"} if mechanics else {})},
         "mesh": {"maxh": 0.5, "order": 1},
         "blocks": [{"name": "rock", "shape": "box", "origin": [0, 0, -10], "size": [1, 1, 10],
                     "boundaries": {"top": "zmax", "base": "zmin"}},
                    {"name": "core", "shape": "box", "origin": [0.3, 0.3, -6], "size": [0.4, 0.4, 2]}],
         "interfaces": [{"name": "core_wall", "blocks": ["rock", "core"], "type": "glued"}],
         "materials": {"rock": rock, "core": dict(rock, conductivity=10.0)},
         "sources": [{"region": "core", "power": 30.0}],
         "boundary_conditions": {"top": {"temperature": 5.0},
                                 "base": {"temperature": 20.0, **({"displacement": [0, 0, 0]} if mechanics else {})}},
         "output": {"vtk": False}}
    if sections is not None:
        d["output"]["sections"] = sections
    return d


def test_a_3d_run_writes_section_figures_and_a_profile(tmp_path):
    out = tmp_path / "column"
    api.run(scene_from_dict(column_scene()), out, progress=False)
    names = {p.name for p in (out / "figures").glob("*.png")}
    print(f"\n3D column figures: {sorted(names)}")
    assert {f"{q}_section_{k}.png" for q in ("temperature", "von_mises") for k in "xyz"} <= names
    assert "temperature_profile.png" in names
    for n in names:
        assert (out / "figures" / n).stat().st_size > 5000
    out2 = tmp_path / "declared"
    api.run(scene_from_dict(column_scene([{"name": "core", "point": [0.5, 0.5, -5], "normal": [1, 0, 0],
                                           "window": [0, 1, -7, -3]},
                                          {"name": "dipping", "point": [0.5, 0.5, -5], "normal": [0, -1, 1]}],
                                         mechanics=False)), out2, progress=False)
    names = {p.name for p in (out2 / "figures").glob("*.png")}
    assert {"temperature_section_core.png", "temperature_section_dipping.png"} <= names
    assert not any(n.startswith("von_mises") or n.endswith("_section_x.png") for n in names)


@pytest.mark.parametrize("section, item, words", [
    ({"name": "a", "point": [0.5, 0.5, -5], "normal": [0, 0, 0]}, "output.sections[0] (a).normal", "zero"),
    ({"name": "a", "point": [0.5, 0.5, 5], "normal": [0, 0, 1]}, "output.sections[0] (a).point", "outside"),
    ({"name": "a", "point": [0.5, 0.5, -5], "normal": [1, 0, 0], "window": [1, 0, -7, -3]},
     "output.sections[0] (a).window", "umin < umax"),
    ({"name": "../a", "point": [0.5, 0.5, -5], "normal": [1, 0, 0]}, "output.sections[0].name", "not allowed"),
])
def test_bad_sections_are_refused_naming_the_key(section, item, words):
    with pytest.raises(SceneError) as err:
        validate(scene_from_dict(column_scene([section])))
    assert item in str(err.value) and words in str(err.value)


def test_sections_need_a_3d_scene_and_distinct_names():
    d = column_scene([{"name": "a", "point": [0.5, 0.5, -5], "normal": [1, 0, 0]}] * 2)
    with pytest.raises(SceneError, match="'a' is used twice"):
        validate(scene_from_dict(d))
    plane = {"scene": {"name": "p"}, "physics": {"thermal": "steady"},
             "blocks": [{"name": "rock", "shape": "rectangle", "origin": [0, 0], "size": [1, 1],
                         "boundaries": {"left": "xmin"}}],
             "materials": {"rock": {"conductivity": 1.0}}, "boundary_conditions": {"left": {"temperature": 0.0}},
             "output": {"sections": [{"name": "a", "point": [0, 0, 0], "normal": [1, 0, 0]}]}}
    with pytest.raises(SceneError, match="output.sections.*need a 3d scene"):
        validate(scene_from_dict(plane))


def test_permafrost_writes_its_temperature_profile(tmp_path):
    out = tmp_path / "permafrost"
    api.run("permafrost", out, progress=False, overrides=["output.vtk=false", "time.end=20000 year",
                                                          "mesh.maxh=10"])
    assert (out / "figures" / "temperature_profile.png").stat().st_size > 10000


def test_colour_bar_labels_carry_their_own_digits(tmp_path):
    """No offset or power-of-ten text above a colour bar (it would sit on the title): a field of 3e-5 W/m^3 or
    of 11.5253 ... 11.5256 degC reads off its tick labels."""
    for offset, spread in ((0.0, 3e-5), (11.5253, 3e-4)):
        m = box_mesh(2.0, 1.0)
        fig = figures.field_figure(m, offset + spread * m.points[:, 0] / 2, tmp_path / "f.png", title="small",
                                   label="q")
        fig.canvas.draw()
        cax = fig.axes[1]
        assert cax.yaxis.get_offset_text().get_text() == ""
        labels = [t.get_text() for t in cax.get_yticklabels() if t.get_text()]
        assert len(set(labels)) == len(labels) >= 2, labels
