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
