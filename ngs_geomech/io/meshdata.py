"""Plain arrays of a 2D NGSolve mesh for plotting: vertices, triangles, region ids, region outlines."""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from .. import parallel


@dataclass
class MeshArrays:
    points: np.ndarray          # (nv, 2)
    triangles: np.ndarray       # (nt, 3) vertex numbers
    tri_region: np.ndarray      # (nt,) region index into ``regions``
    regions: list[str]
    outline: np.ndarray         # (nseg, 2, 2) boundary and interface segments


def mesh_arrays(mesh) -> MeshArrays:
    """Vertex triangulation of a 2D mesh (curved and higher-order elements drawn by their vertices).

    On a distributed mesh (MPI) a collective call: every rank gets the parts of all ranks joined in rank order
    (a vertex on a part boundary appears once per part holding it), matching :func:`vertex_values`."""
    if mesh.dim != 2:
        raise ValueError("mesh_arrays needs a 2D mesh")
    local = _local_arrays(mesh)
    if not parallel.distributed(mesh):
        return local
    parts = parallel.allgather(mesh, (local.points, local.triangles, local.tri_region, local.outline))
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    used = [(p, o) for p, o in zip(parts, offsets) if len(p[0])]
    return MeshArrays(points=np.concatenate([p[0] for p, _ in used]),
                      triangles=np.concatenate([p[1].reshape(-1, 3) + o for p, o in used]).astype(int),
                      tri_region=np.concatenate([p[2] for p, _ in used]).astype(int), regions=local.regions,
                      outline=np.concatenate([p[3].reshape(-1, 2, 2) for p, _ in used]))


def _local_arrays(mesh) -> MeshArrays:
    pts = np.array([v.point for v in mesh.vertices]).reshape(-1, 2)
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
    is hierarchical, so vertex dofs are vertex values at any order). Distributed meshes: collective, all parts in
    rank order (as :func:`mesh_arrays`)."""
    mesh = gf.space.mesh
    vals = np.array(gf.vec.FV().NumPy()[:mesh.nv], copy=True)
    return parallel.concat(mesh, vals) if parallel.distributed(mesh) else vals


def vertex_average(mesh, cf) -> np.ndarray:
    """Vertex values of a (possibly discontinuous) scalar CoefficientFunction for drawing: its L2 projection
    onto P1, vertex dofs (gathered like :func:`vertex_values`)."""
    g = ngs.GridFunction(ngs.H1(mesh, order=1))
    g.Set(cf)
    return vertex_values(g)


def surface_triangles(mesh) -> np.ndarray:
    """The boundary elements of a 3D mesh (outer boundaries and interfaces) as vertex triangles (n, 3, 3), m;
    quadrilaterals split in two. Distributed meshes: collective, all parts (in rank order)."""
    pts = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, 3)
    tris = []
    for el in mesh.Elements(ngs.BND):
        vs = [v.nr for v in el.vertices]
        tris += [vs] if len(vs) == 3 else [[vs[0], vs[1], vs[2]], [vs[0], vs[2], vs[3]]]
    local = pts[np.array(tris, dtype=int).reshape(-1, 3)]
    return parallel.concat(mesh, local) if parallel.distributed(mesh) else local


def bounding_box(mesh) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's bounding box (lo, hi), m, over all parts of a distributed mesh (collective)."""
    pts = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, mesh.dim)
    lo = pts.min(axis=0) if len(pts) else np.full(mesh.dim, np.inf)
    hi = pts.max(axis=0) if len(pts) else np.full(mesh.dim, -np.inf)
    if parallel.distributed(mesh):
        lo = np.array([parallel.allmin(mesh, float(x)) for x in lo])
        hi = np.array([parallel.allmax(mesh, float(x)) for x in hi])
    return lo, hi
