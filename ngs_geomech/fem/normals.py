"""Outward normals on the boundaries of a mesh.

NGSolve's ``specialcf.normal`` on a boundary element follows the element's orientation (in 2D the segment's
direction), which need not point out of the body: on the two copied sides of a non-matching contact interface it
points into one of the two blocks. :func:`outward_normal` corrects it per element.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np


def outward_normal(mesh, boundary: str):
    """The unit normal CF on ``boundary``'s elements that points out of the volume element behind each one (an
    element between two volume elements takes the first one's side)."""
    dim = mesh.dim
    region = mesh.Boundaries(boundary)
    S = ngs.SurfaceL2(mesh, order=0, definedon=region)
    n = ngs.specialcf.normal(dim)
    v = S.TestFunction()
    area_n = []
    for k in range(dim):
        lf = ngs.LinearForm(S)
        lf += n[k] * v * ngs.ds(definedon=region)
        lf.Assemble()
        area_n.append(np.array(lf.vec.FV().NumPy()))
    area_n = np.stack(area_n, axis=1)
    pts = np.asarray(mesh.ngmesh.Coordinates(), dtype=float)[:mesh.nv, :dim]
    sign = ngs.GridFunction(S)
    values = sign.vec.FV().NumPy()
    for el in region.Elements():
        facet = mesh[el.faces[0]] if dim == 3 else mesh[el.edges[0]]
        behind = mesh[facet.elements[0]]
        out = pts[[v.nr for v in el.vertices]].mean(axis=0) - pts[[v.nr for v in behind.vertices]].mean(axis=0)
        dof = S.GetDofNrs(el)[0]
        values[dof] = 1.0 if float(np.dot(area_n[dof], out)) > 0 else -1.0
    return sign * n
