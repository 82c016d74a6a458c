"""A numbering of the dofs of a run's finite element spaces that does not depend on how the mesh is split over
the ranks: the checkpoints of distributed runs hold their vectors in it, so that a run on any rank count (or a
serial one) resumes them.

A dof is named by its node and component: (component, node type (vertex, edge, face, cell), the sorted vertex
numbers of the node in the *whole* mesh, its index among the node's dofs). The whole mesh's vertex numbers are the
serial mesh's (netgen's point order, as a serial run numbers its vertices): rank 0 keeps the element table and
coordinates of the whole mesh before it is sent out (:class:`WholeMesh`); each worker matches its elements to the
whole mesh's by their centroids (the parts hold copies of the whole mesh's vertices) and its vertices by their
coordinates within each element (two copies of a vertex on a contact interface lie in different elements), so
every local vertex learns its whole-mesh number. The canonical order of the dofs is the lexicographic order of the
names: for an order-1 space (one dof per vertex) that is the serial numbering itself (component major), so a
serial run's vectors of such spaces are already in canonical order.

The higher-order dofs of a node keep NGSolve's order within the node; NGSolve orients edges and faces by the
vertex numbers, and the parts number their vertices in the whole mesh's order (checked:
:attr:`Numbering.monotone`), so the dofs of a node mean the same in every partition.
"""

from __future__ import annotations

import hashlib

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..adapt.estimators import element_vertices, vertex_coords

KEY_WIDTH = 7
"""Columns of a dof's name: component, node type, four vertex numbers (-1 padded), index within the node."""

NODE_TYPES = (ngs.VERTEX, ngs.EDGE, ngs.FACE, ngs.CELL)


class WholeMesh:
    """Rank 0's tables of the whole (serial) mesh of a distributed run: ``nodes`` (ne x vertices, 0-based vertex
    numbers per volume element, netgen's element order) and ``xyz`` (nv x dim), taken from the serial netgen mesh
    before it is sent out; ``coordinates_sha256`` the hash a serial run's checkpoint keeps of the same mesh."""

    def __init__(self, ngmesh):
        dim = ngmesh.dim
        arr = ngmesh.Elements2D() if dim == 2 else ngmesh.Elements3D()
        nodes = np.array(arr.NumPy()["nodes"], dtype=np.int64)        # copies: the netgen mesh may go
        if np.any((nodes > 0).sum(axis=1) != dim + 1):
            raise ValueError("checkpoints of distributed runs need a simplicial mesh (triangles or tetrahedra)")
        self.nodes = nodes[:, :dim + 1] - 1
        coords = np.array(ngmesh.Coordinates(), dtype=float)
        self.xyz = np.ascontiguousarray(coords[:, :dim])
        self.coordinates_sha256 = hashlib.sha256(np.round(coords, 9).tobytes()).hexdigest()


def _centroids(nodes: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    return xyz[nodes].mean(axis=1) if len(nodes) else np.zeros((0, xyz.shape[1]))


def whole_vertex_numbers(mesh, whole: WholeMesh | None) -> np.ndarray:
    """The whole mesh's number of each vertex of this rank's part (collective; ``whole`` given on rank 0). On a
    serial mesh the vertices' own numbers."""
    if not parallel.distributed(mesh):
        return np.arange(mesh.nv, dtype=np.int64)
    comm = parallel.comm(mesh)
    nodes = element_vertices(mesh) if mesh.ne else np.zeros((0, mesh.dim + 1), dtype=np.int64)
    xyz = vertex_coords(mesh) if mesh.nv else np.zeros((0, mesh.dim))
    parts = comm.gather(_centroids(nodes, xyz), root=0)
    matched = None
    if comm.rank == 0:
        try:
            matched = _match(parts, whole)
        except Exception as exc:              # noqa: BLE001 - said on every rank (the others wait in the scatter)
            matched = [str(exc)] * comm.size
    mine = comm.scatter(matched, root=0)
    if isinstance(mine, str):
        raise RuntimeError(mine)
    vmap = np.full(mesh.nv, -1, dtype=np.int64)
    if len(nodes):
        ids, their = mine
        local = xyz[nodes]                                        # ne x k x dim
        dist = np.linalg.norm(local[:, :, None, :] - their[:, None, :, :], axis=3)
        which = np.argmin(dist, axis=2)                           # local vertex j is the whole mesh's which[j]
        vmap[nodes] = np.take_along_axis(ids, which, axis=1)
    if parallel.anyof(mesh, bool(len(nodes)) and bool(np.any(vmap[nodes] < 0))):
        raise RuntimeError("checkpoint numbering: a vertex of a part was not matched to the whole mesh")
    return vmap


def _match(parts: list[np.ndarray], whole: WholeMesh) -> list:
    """Rank 0: per rank, the whole mesh's vertex numbers and coordinates of each of its elements (matched by
    centroid)."""
    from scipy.spatial import cKDTree

    cent = _centroids(whole.nodes, whole.xyz)
    tree = cKDTree(cent)
    size = float(np.linalg.norm(whole.xyz.max(axis=0) - whole.xyz.min(axis=0))) or 1.0
    out = []
    for p in parts:
        if not len(p):
            out.append(None)
            continue
        dist, index = tree.query(p)
        if dist.max() > 1e-9 * size:
            raise RuntimeError(f"checkpoint numbering: the parts' elements do not match the whole mesh's "
                               f"(centroids differ by {dist.max():.3g} m)")
        ids = whole.nodes[index]
        out.append((ids, whole.xyz[ids]))
    return out


def _node_vertices(mesh, nt, i: int) -> list[int]:
    if nt == ngs.VERTEX:
        return [i]
    if nt == ngs.CELL:
        return [v.nr for v in mesh[ngs.ElementId(ngs.VOL, i)].vertices]
    return [v.nr for v in mesh[ngs.NodeId(nt, i)].vertices]


def _node_counts(mesh) -> dict:
    return {ngs.VERTEX: mesh.nv, ngs.EDGE: mesh.nedge, ngs.FACE: mesh.nface,
            ngs.CELL: mesh.ne if mesh.dim == 3 else 0}


def _scalar_keys(space, vmap: np.ndarray, component: int) -> tuple[np.ndarray, bool]:
    """The names (ndof x KEY_WIDTH; rows of -1 for dofs no node carries) of a scalar space's dofs, and whether
    some node other than a vertex carries several dofs (their meaning then depends on the node's orientation)."""
    mesh = space.mesh
    keys = np.full((space.ndof, KEY_WIDTH), -1, dtype=np.int64)
    seen = np.zeros(space.ndof, dtype=bool)
    oriented = False
    for t, nt in enumerate(NODE_TYPES):
        if seen.all():
            break
        for i in range(_node_counts(mesh)[nt]):
            dofs = [d for d in space.GetDofNrs(ngs.NodeId(nt, i)) if d >= 0]
            if not dofs:
                continue
            verts = sorted(int(vmap[v]) for v in _node_vertices(mesh, nt, i))
            oriented |= t > 0 and len(dofs) > 1
            for j, d in enumerate(dofs):
                keys[d, :2] = component, t
                keys[d, 2:2 + len(verts)] = verts
                keys[d, 6] = j
                seen[d] = True
    return keys, oriented


def dof_keys(space, vmap: np.ndarray) -> tuple[np.ndarray, bool]:
    """The names of the dofs of ``space`` (an H1 space or a product of such spaces; module docstring)."""
    comps = list(space.components) if isinstance(space, ngs.comp.ProductSpace) else []
    if not comps:
        return _scalar_keys(space, vmap, 0)
    keys = np.full((space.ndof, KEY_WIDTH), -1, dtype=np.int64)
    oriented = False
    for c, comp in enumerate(comps):
        sub, o = _scalar_keys(comp, vmap, c)
        rng = space.Range(c)
        keys[rng.start:rng.stop] = sub
        oriented |= o
    return keys, oriented


class Numbering:
    """The canonical numbering of one space's dofs on this rank (collective to build): ``position[i]`` the
    canonical number of local dof i (-1: a dof no node carries, e.g. outside a ``definedon`` region; it holds 0),
    ``size`` the number of canonical dofs. ``vertex_only``: every dof sits on a vertex, one per vertex and
    component on the whole mesh (``nv_whole`` vertices), so the serial numbering is the canonical one."""

    def __init__(self, space, vmap: np.ndarray, nv_whole: int):
        self.space = space
        self.mesh = space.mesh
        keys, oriented = dof_keys(space, vmap)
        ok = keys[:, 1] >= 0
        self.distributed = parallel.distributed(self.mesh)
        if self.distributed:
            comm = parallel.comm(self.mesh)
            gathered = comm.gather(keys[ok], root=0)
            result = None
            if comm.rank == 0:
                allkeys = np.concatenate(gathered)
                uniq, inverse = np.unique(allkeys, axis=0, return_inverse=True)
                counts = np.cumsum([0] + [len(g) for g in gathered])
                result = [(len(uniq), _vertex_only(uniq, nv_whole), inverse.ravel()[a:b])
                          for a, b in zip(counts[:-1], counts[1:])]
            self.size, self.vertex_only, mine = comm.scatter(result, root=0)
            self.owned = parallel.owned(space) & ok
            oriented = parallel.anyof(self.mesh, oriented)
        else:
            uniq, mine = np.unique(keys[ok], axis=0, return_inverse=True)
            self.size, self.vertex_only = len(uniq), _vertex_only(uniq, nv_whole)
            self.owned = ok
        self.oriented = oriented
        self.position = np.full(space.ndof, -1, dtype=np.int64)
        self.position[ok] = np.ravel(mine)

    def gather(self, local: np.ndarray) -> np.ndarray | None:
        """The canonical array of a cumulated local vector (collective): on rank 0 (serially: here), None on the
        other ranks."""
        local = np.asarray(local)
        own = self.owned
        if not self.distributed:
            out = np.zeros(self.size, dtype=local.dtype)
            out[self.position[own]] = local[own]
            return out
        comm = parallel.comm(self.mesh)
        parts = comm.gather((self.position[own], local[own]), root=0)
        if comm.rank != 0:
            return None
        out = np.zeros(self.size, dtype=local.dtype)
        for pos, val in parts:
            out[pos] = val
        return out

    def local(self, canonical: np.ndarray) -> np.ndarray:
        """This rank's local vector of a canonical array (every copy of a shared dof holds the value)."""
        canonical = np.asarray(canonical)
        if canonical.shape[0] != self.size:
            raise ValueError(f"a canonical array of {canonical.shape[0]} entries for {self.size} dofs")
        out = np.zeros(self.space.ndof, dtype=canonical.dtype)
        ok = self.position >= 0
        out[ok] = canonical[self.position[ok]]
        return out


def _vertex_only(uniq: np.ndarray, nv_whole: int) -> bool:
    ncomp = int(uniq[:, 0].max()) + 1 if len(uniq) else 1
    return bool(len(uniq) == ncomp * nv_whole and np.all(uniq[:, 1] == 0) and np.all(uniq[:, 6] == 0))


class RunNumbering:
    """The canonical numberings of a run's spaces on one mesh (collective to build, as each :meth:`of` the first
    time for a space): the whole mesh's vertex numbers of this rank's vertices (``whole`` on rank 0 of a
    distributed run), ``nv`` the whole mesh's vertices, ``vertex_order_kept`` whether every part numbers its
    vertices in the whole mesh's order (then the dofs of oriented nodes mean the same as in a serial run)."""

    def __init__(self, mesh, whole: WholeMesh | None = None):
        self.mesh = mesh
        self.vmap = whole_vertex_numbers(mesh, whole)
        if parallel.distributed(mesh):
            comm = parallel.comm(mesh)
            self.nv = int(comm.bcast(len(whole.xyz) if comm.rank == 0 else None, root=0))
        else:
            self.nv = mesh.nv
        used = self.vmap[self.vmap >= 0]
        self.vertex_order_kept = not parallel.anyof(mesh, bool(np.any(np.diff(used) <= 0)))
        self._spaces: dict[int, Numbering] = {}

    def of(self, space) -> Numbering:
        key = id(space)
        if key not in self._spaces:
            self._spaces[key] = Numbering(space, self.vmap, self.nv)
        return self._spaces[key]
