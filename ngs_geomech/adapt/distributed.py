"""Marking and refinement of distributed meshes for the adaptive loop (:func:`.loop.adaptive_solve`).

A netgen distributed mesh cannot be refined where it lies (``mesh.Refine()`` on the parts hung in NGSolve 6.2),
so rank 0 keeps the whole mesh (:class:`~ngs_geomech.geometry.mesh.SerialCopy`: the serial netgen mesh with its
geometry) and every refinement goes through it:

1. each worker has its elements' estimates eta_T (and indicator flags); the element centroids (means of the
   vertex coordinates: the parts hold copies of the whole mesh's vertices, so the centroids agree to round-off)
   name the elements across ranks;
2. rank 0 gathers (centroid, eta_T, flag) and puts them into the order of its whole mesh (nearest centroid,
   scipy's cKDTree; every element matched once, within 1e-9 of the element size), which is the element order
   of the serial run on the same mesh: the total estimate sqrt(sum eta_T^2) and the marker see the serial run's
   numbers in the serial order, so the marks are the serial ones (the etas differ by round-off only; the
   marker's own tie rule, ``eta_T >= threshold``, takes equal values together);
3. rank 0 bisects the marked elements of its whole mesh (``SetRefinementFlags`` + ``Refine``: new boundary
   vertices on the geometry, as :func:`.loop.refine_mesh` does serially) and sends a copy of the refined mesh
   out (:func:`~ngs_geomech.geometry.mesh.distribute_mesh`, curved there to the mesh order); the caller builds its
   model anew on it.

The serial mesh of the same scene passes the same meshes (the same netgen operations on the same data): the
dof counts per step are the serial run's.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np

from ..geometry.mesh import SerialCopy, distribute_mesh
from .estimators import element_vertices, vertex_coords
from .loop import Marking, decide

MATCH_TOLERANCE = 1e-9
"""Largest distance of matched centroids, relative to the mesh's bounding box diagonal."""


def centroids(nodes: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """The means of the vertex coordinates ``xyz`` (nv x dim) of the elements ``nodes`` (ne x vertices)."""
    return xyz[nodes].mean(axis=1) if len(nodes) else np.zeros((0, xyz.shape[1] if xyz.ndim == 2 else 0))


def whole_mesh_centroids(ngmesh) -> np.ndarray:
    """The element centroids of a whole netgen mesh (rank 0's serial copy), in its element order."""
    dim = ngmesh.dim
    arr = ngmesh.Elements2D() if dim == 2 else ngmesh.Elements3D()
    nodes = np.asarray(arr.NumPy()["nodes"], dtype=np.int64)
    count = (nodes > 0).sum(axis=1)
    if np.any(count != dim + 1):
        raise ValueError("distributed adaptive refinement needs a simplicial mesh (triangles or tetrahedra)")
    xyz = np.asarray(ngmesh.Coordinates(), dtype=float)[:, :dim]
    return centroids(nodes[:, :dim + 1] - 1, xyz)


class DistributedRefinement:
    """The adaptive loop's marking and refinement on a distributed mesh (module docstring): rank 0 holds the
    whole mesh in ``serial_copy``; ``geo`` and ``settings`` (the scene's geometry and mesh settings) curve the
    parts of each refined mesh. Every method is collective over ``comm``."""

    def __init__(self, serial_copy: SerialCopy, geo, settings, comm):
        self.serial_copy, self.geo, self.settings, self.comm = serial_copy, geo, settings, comm
        if comm.rank == 0 and serial_copy.ngmesh is None:
            raise ValueError("distributed adaptive refinement needs rank 0's copy of the whole mesh (make_mesh's "
                             "serial_copy)")

    def _order(self, parts: list[np.ndarray]) -> np.ndarray:
        """Rank 0: the index into the whole mesh's elements of each gathered element (parts in rank order)."""
        from scipy.spatial import cKDTree

        whole = whole_mesh_centroids(self.serial_copy.ngmesh)
        got = np.concatenate([p for p in parts if len(p)]) if any(len(p) for p in parts) else np.zeros((0, 1))
        if len(got) != len(whole):
            raise RuntimeError(f"the parts hold {len(got)} elements, the whole mesh {len(whole)}")
        dist, index = cKDTree(whole).query(got)
        size = float(np.linalg.norm(whole.max(axis=0) - whole.min(axis=0))) or 1.0
        if len(index) and (dist.max() > MATCH_TOLERANCE * size or len(np.unique(index)) != len(index)):
            raise RuntimeError("the parts' elements do not match the whole mesh's (centroids differ by "
                               f"{dist.max():.3g} m)")
        return index

    def mark(self, mesh, eta: np.ndarray, flags: np.ndarray, marker, theta: float) -> Marking:
        mine = centroids(element_vertices(mesh), vertex_coords(mesh)) if mesh.ne else np.zeros((0, mesh.dim))
        gathered = self.comm.gather((mine, np.asarray(eta, dtype=float), np.asarray(flags, dtype=bool)), root=0)
        result = None
        if self.comm.rank == 0:
            index = self._order([g[0] for g in gathered])
            whole_eta = np.zeros(len(index))
            whole_flags = np.zeros(len(index), dtype=bool)
            whole_eta[index] = np.concatenate([g[1] for g in gathered])
            whole_flags[index] = np.concatenate([g[2] for g in gathered])
            result = decide(whole_eta, whole_flags, marker, theta)
        numbers = self.comm.bcast(None if result is None else (result.total, result.elements, result.marked,
                                                               result.flagged), root=0)
        return result if result is not None else Marking(numbers[0], numbers[1], None, numbers[2], numbers[3])

    def refine(self, mesh, marks: np.ndarray | None, curve_order: int):
        """The distributed mesh of the whole mesh with the ``marks`` (rank 0's, in the whole mesh's element order)
        bisected; the old ``mesh`` is left as it is."""
        ngmesh = None
        if self.comm.rank == 0:
            whole = ngs.Mesh(self.serial_copy.ngmesh)
            marks = np.asarray(marks, dtype=bool)
            if marks.shape != (whole.ne,):
                raise ValueError(f"marks must have one entry per element of the whole mesh ({whole.ne})")
            whole.SetRefinementFlags([bool(m) for m in marks])
            whole.Refine()
            self.serial_copy.ngmesh = whole.ngmesh
            del whole                        # no ngsolve.Mesh of the mesh that is sent may live
            ngmesh = self.serial_copy.ngmesh.Copy()
        return distribute_mesh(ngmesh, self.geo, self.settings, self.comm)
