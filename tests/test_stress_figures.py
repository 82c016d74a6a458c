"""Principal stress crosses: principal values and directions, sample grids inside a triangulation (also
with a hole), barycentric interpolation, and the figure itself. Meshes are built directly as arrays."""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.path import Path as MplPath

from ngs_geomech.io.meshdata import MeshArrays
from ngs_geomech.io.stress_figures import (
    Samples,
    cross_segments,
    find_triangles,
    grid_samples,
    interpolate,
    principal_2d,
    principal_stress_crosses,
)


def square_mesh(n=12, size=2.0, hole=None) -> MeshArrays:
    """A structured triangulation of [0, size]^2 (each square cut in two); ``hole`` = (cx, cy, r) drops the
    triangles whose centroid lies in the circle, leaving a (polygonal) hole. Outline = boundary edges."""
    x = np.linspace(0.0, size, n + 1)
    gx, gy = np.meshgrid(x, x)
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    tris = []
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, j * (n + 1) + i + 1
            c, d = a + n + 1, b + n + 1
            tris += [[a, b, d], [a, d, c]]
    tris = np.array(tris)
    if hole is not None:
        cx, cy, r = hole
        cen = pts[tris].mean(axis=1)
        tris = tris[np.hypot(cen[:, 0] - cx, cen[:, 1] - cy) > r]
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    outline = pts[uniq[count == 1]]
    return MeshArrays(points=pts, triangles=tris, tri_region=np.zeros(len(tris), dtype=int), regions=["plate"],
                      outline=outline)


def test_principal_2d_matches_eigh():
    rng = np.random.default_rng(1)
    sxx, syy, sxy = rng.normal(scale=1e7, size=(3, 500))
    s1, s2, th = principal_2d(sxx, syy, sxy)
    tensors = np.stack([np.stack([sxx, sxy], -1), np.stack([sxy, syy], -1)], -2)
    w, v = np.linalg.eigh(tensors)             # ascending eigenvalues
    np.testing.assert_allclose(s1, w[:, 1], rtol=0, atol=1e-8 * 1e7)
    np.testing.assert_allclose(s2, w[:, 0], rtol=0, atol=1e-8 * 1e7)
    assert np.all(s1 >= s2)
    assert np.all((th > -np.pi / 2) & (th <= np.pi / 2))
    d1 = np.column_stack([np.cos(th), np.sin(th)])
    d2 = np.column_stack([-np.sin(th), np.cos(th)])
    np.testing.assert_allclose(np.abs(np.sum(d1 * v[:, :, 1], axis=1)), 1.0, atol=1e-9)  # same up to sign
    np.testing.assert_allclose(np.abs(np.sum(d2 * v[:, :, 0], axis=1)), 1.0, atol=1e-9)
    # the tensor rebuilt from (s1, s2, theta1)
    rebuilt = s1[:, None, None] * d1[:, :, None] * d1[:, None, :] + s2[:, None, None] * d2[:, :, None] * d2[:, None, :]
    np.testing.assert_allclose(rebuilt, tensors, rtol=0, atol=1e-8 * 1e7)


def test_principal_2d_shapes_and_special_states():
    tau = 3e6
    s1, s2, th = principal_2d(0.0, 0.0, tau)          # pure shear: s1 = tau at 45 degrees
    assert s1 == pytest.approx(tau) and s2 == pytest.approx(-tau)
    assert math.degrees(th) == pytest.approx(45.0)
    _, _, th = principal_2d(0.0, 0.0, -tau)
    assert math.degrees(th) == pytest.approx(-45.0)
    _, _, th = principal_2d(-1.0, 2.0, 0.0)            # s1 along y
    assert th == pytest.approx(np.pi / 2)
    p = np.array([-7.3e6, 0.0, 1.1, -0.0, 5e300])        # isotropic: exact
    s1, s2, th = principal_2d(p, p, np.zeros_like(p))
    assert np.array_equal(s1, p) and np.array_equal(s2, p) and np.all(np.isfinite(th))
    s1, s2, th = principal_2d(np.ones((2, 3)), 0.0, np.zeros(3))   # broadcasting
    assert s1.shape == s2.shape == th.shape == (2, 3)


@pytest.mark.parametrize("hole", [None, (1.0, 1.0, 0.45)])
def test_grid_samples_lie_inside(hole):
    m = square_mesh(hole=hole)
    smp = grid_samples(m, 0.1)
    assert isinstance(smp, Samples) and smp.spacing == 0.1
    assert len(smp.xy) > 100 and smp.xy.shape == (len(smp.triangle), 2)
    # each sample lies in its triangle (barycentric coordinates >= 0)
    tri = m.points[m.triangles[smp.triangle]]
    for k in range(len(smp.xy)):
        assert MplPath(tri[k]).contains_point(smp.xy[k], radius=1e-9) or MplPath(tri[k][::-1]).contains_point(
            smp.xy[k], radius=1e-9)
    # grid: cell centres, at least spacing / 2 from the box edges
    assert smp.xy.min() >= 0.05 - 1e-12 and smp.xy.max() <= 2.0 - 0.05 + 1e-12
    if hole is not None:
        cx, cy, r = hole
        dist = np.hypot(smp.xy[:, 0] - cx, smp.xy[:, 1] - cy)
        polygon_inradius = r - 2.0 / 12 * math.sqrt(2)     # the jagged hole holds at least this disc
        assert np.all(dist > polygon_inradius)
        assert np.sum(dist < r + 0.1) > 0                   # samples come close to the hole
        full = grid_samples(square_mesh(hole=None), 0.1)
        assert len(full.xy) - len(smp.xy) >= math.pi * polygon_inradius**2 / 0.1**2 * 0.9
    # a window
    win = grid_samples(m, 0.1, window=[0.5, 1.5, -1.0, 0.55])
    assert np.all((win.xy[:, 0] >= 0.55 - 1e-12) & (win.xy[:, 0] <= 1.45 + 1e-12))
    assert np.all((win.xy[:, 1] >= 0.05 - 1e-12) & (win.xy[:, 1] <= 0.5 + 1e-12))
    assert len(grid_samples(m, 0.1, window=[3, 4, 3, 4]).xy) == 0
    assert find_triangles(m, [[-1.0, 0.5], [5.0, 5.0]]).tolist() == [-1, -1]


def test_interpolation_exact_for_linear_fields():
    m = square_mesh(n=7, hole=(0.8, 1.1, 0.4))
    lin = lambda p: 3.0 - 2.0 * p[:, 0] + 0.5 * p[:, 1]   # noqa: E731
    values = np.column_stack([lin(m.points), 2 * lin(m.points)])
    smp = grid_samples(m, 0.07)
    got = interpolate(m, values, smp)
    np.testing.assert_allclose(got[:, 0], lin(smp.xy), rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[:, 1], 2 * lin(smp.xy), rtol=0, atol=1e-12)
    rng = np.random.default_rng(0)
    xy = rng.uniform(-0.2, 2.2, size=(200, 2))            # located by the function; outside -> nan
    got = interpolate(m, values[:, 0], xy)
    inside = find_triangles(m, xy) >= 0
    assert inside.sum() > 50 and np.all(np.isnan(got[~inside]))
    np.testing.assert_allclose(got[inside], lin(xy[inside]), rtol=0, atol=1e-12)
    with pytest.raises(ValueError):
        interpolate(m, values[:-1], smp)


def test_cross_segments():
    segs, s = cross_segments([[1.0, 2.0]], [4.0], [-2.0], [np.pi / 2], scale=0.5)
    assert s.tolist() == [4.0, -2.0]
    np.testing.assert_allclose(segs[0], [[1.0, 1.0], [1.0, 3.0]], atol=1e-15)    # s1 along y, length 2
    np.testing.assert_allclose(segs[1], [[1.5, 2.0], [0.5, 2.0]], atol=1e-15)    # s2 along -x, length 1


def test_crosses_figure_is_written(tmp_path):
    m = square_mesh(n=10, hole=(1.0, 1.0, 0.35))
    # a linear field with compression and extension: sxx = -10 MPa + 8 MPa x, syy = 4 MPa y, sxy = 2 MPa
    smp = grid_samples(m, 0.2)
    x, y = smp.xy.T
    s1, s2, th = principal_2d(-10e6 + 8e6 * x, 4e6 * y, 2e6 * np.ones_like(x))
    assert (s1 > 0).any() and (s2 < 0).any()
    vm = np.hypot(m.points[:, 0], m.points[:, 1])
    out = tmp_path / "crosses.png"
    principal_stress_crosses(m, smp, s1, s2, th, out, title="linear field", background=vm,
                             background_label="von Mises (MPa)")
    data = out.read_bytes()
    assert len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]   # no temporary file left
    # plain arrays, a window, an explicit scale, no background; an all-zero field draws no bars
    out2 = tmp_path / "plain.png"
    principal_stress_crosses(m, smp.xy, s1, s2, th, out2, title="window", window=[0.0, 1.0, 0.0, 1.0],
                             scale=1e-8)
    assert out2.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    zero = np.zeros(len(smp.xy))
    principal_stress_crosses(m, smp, zero, zero, zero, tmp_path / "zero.png", title="zero")
    assert (tmp_path / "zero.png").stat().st_size > 0
    with pytest.raises(ValueError):
        principal_stress_crosses(m, smp, s1[:-1], s2, th, tmp_path / "bad.png", title="bad")
