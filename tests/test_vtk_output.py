"""The VTK writer: every field evaluated at the vertices of every element (discontinuous, binary VTU), read back
with meshio equal to the fields themselves; 2D vectors and tensors padded for ParaView; element-wise fields keep
their jumps."""

from __future__ import annotations

import meshio
import ngsolve as ngs
import numpy as np
import pytest
from netgen.geom2d import unit_square
from netgen.occ import Box, OCCGeometry

from ngs_geomech.io.vtk import VtkSeries


def fields(mesh):
    dim = mesh.dim
    xyz = (ngs.x, ngs.y, ngs.z)[:dim]
    T = ngs.GridFunction(ngs.H1(mesh, order=2))
    T.Set(1 + ngs.x * ngs.x + 2 * ngs.y)
    u = ngs.GridFunction(ngs.VectorH1(mesh, order=1))
    u.Set(ngs.CoefficientFunction(tuple(0.1 * c for c in xyz)))
    jump = ngs.GridFunction(ngs.L2(mesh, order=0))
    jump.vec.FV().NumPy()[:] = np.arange(mesh.ne, dtype=float)
    grad = ngs.Grad(u)
    return {"temperature": T, "displacement": u, "jump": jump, "grad_u": grad, "sum": T + jump}


@pytest.mark.parametrize("dim", [2, 3])
def test_written_fields_equal_the_fields_at_every_element_vertex(tmp_path, dim):
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.3)) if dim == 2 else \
        ngs.Mesh(OCCGeometry(Box((0, 0, 0), (1, 1, 1)), dim=3).GenerateMesh(maxh=0.4))
    f = fields(mesh)
    series = VtkSeries(mesh, f, tmp_path, "case")
    series.write(0.0)
    series.write(1.0)
    assert [name for _, name in series.entries] == ["case.vtu", "case_step00001.vtu"]
    data = meshio.read(tmp_path / "case_step00001.vtu")
    nv = dim + 1
    assert len(data.points) == mesh.ne * nv
    assert sum(len(c.data) for c in data.cells) == mesh.ne
    pts = data.points[:, :dim]
    T = data.point_data["temperature"]
    exact = 1 + pts[:, 0] ** 2 + 2 * pts[:, 1]
    assert np.allclose(T, exact, rtol=1e-6, atol=0)    # P2 is exact for the quadratic (single precision)
    u = data.point_data["displacement"]
    assert u.shape == (len(pts), 3)
    assert np.max(np.abs(u[:, :dim] - 0.1 * pts)) < 1e-6 and not np.any(u[:, dim:])
    jump = data.point_data["jump"].reshape(mesh.ne, nv)
    assert np.array_equal(jump, np.repeat(np.arange(mesh.ne, dtype=np.float32)[:, None], nv, axis=1))
    grad = data.point_data["grad_u"].reshape(-1, 3, 3)
    assert np.max(np.abs(grad[:, :dim, :dim] - 0.1 * np.eye(dim))) < 1e-6
    assert np.allclose(data.point_data["sum"], T + data.point_data["jump"], rtol=1e-6, atol=0)


def test_subdivision_keeps_ngsolves_writer(tmp_path):
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.5))
    series = VtkSeries(mesh, {"x": ngs.x}, tmp_path, "sub", subdivision=1)
    series.write(0.0)
    text = (tmp_path / "sub.vtu").read_text(errors="ignore")
    assert 'Name="x"' in text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sub.pvd", "sub.vtu"]


def test_principal_stresses_from_the_stress_values_equal_ngsolves_eig(tmp_path):
    """The VTK computes the principal stresses from the evaluated stress tensor (numpy), as NGSolve's Eig."""
    import functools

    from ngs_geomech.mechanics.forms import stress_measures
    from ngs_geomech.mechanics.run import principal_stress

    mesh = ngs.Mesh(OCCGeometry(Box((0, 0, 0), (1, 1, 1)), dim=3).GenerateMesh(maxh=0.5))
    x, y, z = ngs.x, ngs.y, ngs.z
    s = ngs.CoefficientFunction((1e6 * x, 2e5 * y, 3e5 * z, 2e5 * y, -4e6, 1e5, 3e5 * z, 1e5, 5e5 * x * y), dims=(3, 3))
    m = stress_measures(s)
    f = {"stress": s, "sigma_1": m["sigma_1"], "sigma_2": m["sigma_2"], "sigma_3": m["sigma_3"]}
    derived = {n: ("stress", functools.partial(principal_stress, index=k))
               for k, n in enumerate(("sigma_3", "sigma_2", "sigma_1"))}
    VtkSeries(mesh, f, tmp_path, "eig").write(0.0)
    VtkSeries(mesh, f, tmp_path, "numpy", derived=derived).write(0.0)
    a, b = meshio.read(tmp_path / "eig.vtu"), meshio.read(tmp_path / "numpy.vtu")
    for n in ("sigma_1", "sigma_2", "sigma_3"):
        assert np.allclose(a.point_data[n], b.point_data[n], rtol=1e-6, atol=1e-6 * 4e6), n
    assert np.all(b.point_data["sigma_1"] >= b.point_data["sigma_2"])


def test_principal_stresses_are_ordered_where_ngsolves_eig_is_not():
    """At a nearly diagonal stress NGSolve's Eig returns its eigenvalues out of order; the principal stresses
    sigma_1 >= sigma_2 >= sigma_3 are sorted (numpy's eigenvalues as reference)."""
    from ngs_geomech.mechanics.forms import stress_measures

    mesh = ngs.Mesh(OCCGeometry(Box((0, 0, 0), (1, 1, 1)), dim=3).GenerateMesh(maxh=0.5))
    x, y, z = ngs.x, ngs.y, ngs.z
    s = ngs.CoefficientFunction((1e6 * x, 2e5 * y, 3e5 * z, 2e5 * y, -4e6, 1e5, 3e5 * z, 1e5, 5e5 * x * y), dims=(3, 3))
    m = stress_measures(s)
    for p in [(0.0025, 0.0, 0.0), (0.5, 0.5, 0.5), (0.0, 0.3, 0.9)]:
        mp = mesh(*p)
        ref = np.linalg.eigvalsh(np.array(s(mp)).reshape(3, 3))
        got = [m[n](mp) for n in ("sigma_3", "sigma_2", "sigma_1")]
        assert np.allclose(got, ref, rtol=1e-12, atol=1e-6), (p, got, ref)
