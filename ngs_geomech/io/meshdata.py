"""Plain arrays of a 2D NGSolve mesh for plotting: vertices, triangles, region ids, region outlines."""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np


@dataclass
class MeshArrays:
    points: np.ndarray          # (nv, 2)
    triangles: np.ndarray       # (nt, 3) vertex numbers
    tri_region: np.ndarray      # (nt,) region index into ``regions``
    regions: list[str]
    outline: np.ndarray         # (nseg, 2, 2) boundary and interface segments


def mesh_arrays(mesh) -> MeshArrays:
    """Vertex triangulation of a 2D mesh (curved and higher-order elements drawn by their vertices)."""
    if mesh.dim != 2:
        raise ValueError("mesh_arrays needs a 2D mesh")
    pts = np.array([v.point for v in mesh.vertices])
    tris, reg = [], []
    for el in mesh.Elements(ngs.VOL):
        vs = [v.nr for v in el.vertices]
        idx = el.index
        if len(vs) == 3:
            tris.append(vs)
            reg.append(idx)
        else:  # quad: split
            tris += [[vs[0], vs[1], vs[2]], [vs[0], vs[2], vs[3]]]
            reg += [idx, idx]
    segs = [[pts[v.nr] for v in el.vertices] for el in mesh.Elements(ngs.BND)]
    return MeshArrays(points=pts, triangles=np.array(tris, dtype=int), tri_region=np.array(reg, dtype=int),
                      regions=list(mesh.GetMaterials()), outline=np.array(segs))


def vertex_values(gf) -> np.ndarray:
    """Values of a scalar H1 GridFunction at the mesh vertices (its first nv dofs: the H1 basis of NGSolve
    is hierarchical, so vertex dofs are vertex values at any order)."""
    nv = gf.space.mesh.nv
    return np.array(gf.vec.FV().NumPy()[:nv], copy=True)
