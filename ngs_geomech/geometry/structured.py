"""Structured (tensor-product) meshes of scenes made of axis-aligned blocks: rectangles (plane, axisymmetric) or
boxes (3d), built with netgen.meshing from numpy arrays instead of netgen's mesher (``mesh.structured``).

The grid. Along each axis the breakpoints are every block's lower and upper coordinates (merged within a
relative tolerance), so blocks sharing sides get common grid lines. The breakpoints cut the bounding box into
coarse cells; each is the region of the last block covering its centre (painter's order, as
:mod:`.assemble` carves blocks) or empty. Each coarse interval of axis a is cut into equal cells no larger than
h_a = min(``mesh.sizes[a]`` (default ``mesh.maxh``), the maxh of the blocks with a cell in that slab, the
``boundary_maxh`` of the boundaries running along it): a tensor grid, so a fine block or boundary refines its
whole slab. ``mesh.elements = 'tensor'`` keeps the cells (quadrilaterals / hexahedra); 'simplex' splits each
into 2 triangles (one diagonal) or 6 tetrahedra (Kuhn's, conforming between neighbours).

Bodies and names, as the netgen path (:func:`.assemble.build_geometry`) gives them. The groups of blocks joined
by glued interfaces are meshed separately, each with its own spacing (the sizes of its own blocks and
boundaries) and its own nodes: the two sides of a contact interface are independent copies, named
``<interface>__<block>``, and need not match. A side between two blocks of one group is its glued interface's
name; an outer side takes its block's boundary name (selectors in declared order, the last one applying wins),
else 'axis' on r = 0 in axisymmetric scenes, else 'default'. Boundary elements point out of the region they
bound (netgen's convention: 2D segments run with the region on their left; 3D faces have the outward normal).
"""

from __future__ import annotations

import numpy as np

from ..errors import Problem
from .assemble import AXIS, DEFAULT, GeometryModel

REL_TOL = 1e-9
"""Breakpoints closer than this times the model's extent are one grid line."""

TENSOR_CELL = {2: np.array([[0, 0], [1, 0], [1, 1], [0, 1]]),
               3: np.array([[0, 0, 0], [0, 0, 1], [0, 1, 1], [0, 1, 0], [1, 0, 0], [1, 0, 1], [1, 1, 1], [1, 1, 0]])}
"""Corner offsets of a quadrilateral (counterclockwise) and a hexahedron (netgen's ordering of
ngsolve.meshes.MakeStructured3DMesh)."""

SIMPLICES = {2: np.array([[0, 1, 2], [0, 2, 3]]),
             3: np.array([[0, 4, 5, 6], [0, 6, 7, 4], [0, 3, 7, 6], [0, 1, 6, 5], [0, 1, 2, 6], [0, 3, 6, 2]])}
"""A cell split into simplices (indices into its tensor corners): the diagonal from the lowest to the highest
corner; in 3D Kuhn's six tetrahedra around it (netgen's orientation)."""

FACET = {2: np.array([[0], [1]]), 3: np.array([[0, 0], [1, 0], [1, 1], [0, 1]])}
"""Corner offsets of a cell's side across axis a, in the in-plane axes (a+1, a+2 mod d): oriented with normal +e_a
(2D: a segment along axis a+1; 3D: a quadrilateral, or two triangles on the lowest-highest diagonal)."""

SHAPES = {2: "rectangle", 3: "box"}
PLURAL = {2: "rectangles", 3: "boxes"}


def structured_problems(scene) -> list[Problem]:
    """What a structured mesh cannot represent in ``scene``, each naming its key: blocks other than rectangles /
    boxes, cuts, adaptivity (it remeshes the OCC geometry or refines it), nested iteration (netgen's coarse
    meshes), 3D contacts on hexahedra (triangular faces assumed), a ``mesh.sizes`` of the wrong length; and
    ``mesh.elements`` / ``mesh.sizes`` without ``mesh.structured``. Distributed runs are refused where they are
    run (:mod:`ngs_geomech.validation.check_distributed`)."""
    m = scene.mesh
    if not m.structured:
        return [] if m.elements == "simplex" and m.sizes is None else [
            Problem("mesh.elements" if m.elements != "simplex" else "mesh.sizes",
                    "applies to structured meshes only: set mesh.structured = true")]
    dim = 3 if scene.scene.dimension == "3d" else 2
    problems = []
    for i, b in enumerate(scene.blocks):
        if b.shape != SHAPES[dim]:
            problems.append(Problem(f"blocks[{i}] ({b.name}).shape", f"mesh.structured = true needs axis-aligned "
                                    f"{PLURAL[dim]}; this block is a {b.shape}: set mesh.structured = false"))
    if scene.cuts:
        problems.append(Problem("cuts", "mesh.structured = true does not support cuts (planes or polylines across "
                                        "blocks): split the blocks into rectangles / boxes, or set "
                                        "mesh.structured = false"))
    if scene.adaptivity is not None:
        problems.append(Problem("adaptivity", "mesh.structured = true does not support adaptivity (it refines "
                                              "or remeshes with netgen's geometry): remove [adaptivity] or set "
                                              "mesh.structured = false"))
    if dim == 3 and m.elements == "tensor":
        problems += _hexahedral_contacts(scene)
    if scene.mechanics.nested_levels > 0:
        problems.append(Problem("mechanics.nested_levels", "nested iteration is not supported on structured meshes "
                                                           "(its coarse meshes are netgen's): set it to 0"))
    if m.sizes is not None and len(m.sizes) != dim:
        problems.append(Problem("mesh.sizes", f"needs {dim} sizes (one per axis), got {len(m.sizes)}"))
    return problems


def _hexahedral_contacts(scene) -> list[Problem]:
    """3D contacts on hexahedra: the contact forms and mortars of 3D interfaces and foundations
    (:mod:`ngs_geomech.contact.forms3d`, :mod:`ngs_geomech.fem.mortar`) clip triangular faces."""
    why = ("3D contacts need triangular faces (the mortar and contact forms clip triangles): use mesh.elements = "
           "'simplex' with mesh.structured")
    problems = [Problem(f"interfaces[{i}] ({itf.name}).type", f"a contact interface on hexahedra: {why}")
                for i, itf in enumerate(scene.interfaces) if itf.type == "contact"]
    problems += [Problem(f"boundary_conditions.{name}.foundation", f"a foundation on hexahedra: {why}")
                 for name, bc in scene.boundary_conditions.items() if bc.foundation is not None]
    return problems


class Layout:
    """The coarse grid of a geometry's blocks: breakpoints per axis, the region (block index, -1 empty) of every
    coarse cell, the glued group of every block, and the names of boundaries (codes into ``names``)."""

    def __init__(self, geo: GeometryModel):
        self.geo, self.dim = geo, geo.dim
        d = self.dim
        lo = np.array([b.origin[:d] for b in geo.blocks], float)
        hi = lo + np.array([b.size[:d] for b in geo.blocks], float)
        self.tol = REL_TOL * float(np.max(hi.max(axis=0) - lo.min(axis=0)))
        self.breaks = [_merge(np.concatenate([lo[:, a], hi[:, a]]), self.tol) for a in range(d)]
        centres = np.meshgrid(*[(x[1:] + x[:-1]) / 2 for x in self.breaks], indexing="ij")
        self.region = np.full(centres[0].shape, -1, dtype=np.int64)
        for k in range(len(geo.blocks)):
            inside = np.ones(self.region.shape, bool)
            for a in range(d):
                inside &= (centres[a] > lo[k, a]) & (centres[a] < hi[k, a])
            self.region[inside] = k
        self.group = _glued_groups(geo)
        self.names: list[str] = []
        self._codes: dict[tuple, int] = {}

    def name_code(self, name: str) -> int:
        if name not in self.names:
            self.names.append(name)
        return self.names.index(name)

    def side_name(self, r: int, other: int, axis: int, sign: int, on_axis: bool) -> str:
        """The boundary name of region ``r``'s side across ``axis`` (outward normal sign * e_axis; ``on_axis``:
        it lies on x = 0) whose other side is region ``other`` (-1: outside)."""
        geo, blocks = self.geo, self.geo.blocks
        a, b = blocks[r].name, (blocks[other].name if other >= 0 else None)
        if b is not None and self.group[r] == self.group[other]:
            return next(n for n, pair in geo.glued.items() if set(pair) == {a, b})
        if b is not None:
            cs = next(cs for cs in geo.contacts.values() if {cs.master_block, cs.minion_block} == {a, b})
            return cs.master if a == cs.master_block else cs.minion
        selector = "xyz"[axis] + ("min" if sign < 0 else "max")
        name = ""
        for n, sel in blocks[r].boundaries.items():
            if any(s in ("all", selector) for s in ([sel] if isinstance(sel, str) else sel)):
                name = n
        if not name and geo.axisymmetric and axis == 0 and on_axis:
            name = AXIS
        return name or DEFAULT

    def facets(self, region: np.ndarray, coords: list[np.ndarray], axis: int):
        """The boundary facets across ``axis`` of a grid with cells ``region`` and grid lines ``coords``: arrays
        (position (n, d): the facet's grid-line index along ``axis`` and cell indices along the others; region;
        outward sign; name code; the region on the other side, -1 outside)."""
        pad = np.pad(region, 1, constant_values=-1)
        inner = [slice(1, -1)] * self.dim
        lo_side, hi_side = list(inner), list(inner)
        lo_side[axis], hi_side[axis] = slice(0, -1), slice(1, None)
        left, right = pad[tuple(lo_side)], pad[tuple(hi_side)]
        pos = np.argwhere(left != right)
        lv, rv = left[tuple(pos.T)], right[tuple(pos.T)]
        out = []
        for r, other, sign in ((lv, rv, 1), (rv, lv, -1)):
            keep = r >= 0
            p, r, o = pos[keep], r[keep], other[keep]
            glued = (o >= 0) & (self.group[np.maximum(o, 0)] == self.group[r])
            if sign < 0:      # a glued side is one boundary element, from its lower region
                p, r, o, glued = p[~glued], r[~glued], o[~glued], glued[~glued]
            c = coords[axis][p[:, axis]]
            code = np.empty(len(r), dtype=np.int64)
            at_axis = np.abs(c) <= max(self.tol, 1e-6)
            keys = np.stack([r, o, at_axis], axis=1)
            for key in np.unique(keys, axis=0):
                mask = np.all(keys == key, axis=1)
                code[mask] = self.name_code(self.side_name(int(key[0]), int(key[1]), axis, sign, bool(key[2])))
            out.append((p, r, np.full(len(r), sign), code, np.where(glued, o, -1)))
        return tuple(np.concatenate(parts) for parts in zip(*out))


def _merge(values: np.ndarray, tol: float) -> np.ndarray:
    v = np.sort(values)
    keep = np.concatenate([[True], np.diff(v) > tol])
    return v[keep]


def _glued_groups(geo: GeometryModel) -> np.ndarray:
    """The group (a block index) of every block: blocks joined by glued interfaces share one."""
    index = {b.name: k for k, b in enumerate(geo.blocks)}
    parent = list(range(len(geo.blocks)))

    def find(k):
        while parent[k] != k:
            k = parent[k]
        return k
    for a, b in geo.glued.values():
        parent[find(index[a])] = find(index[b])
    return np.array([find(k) for k in range(len(geo.blocks))], dtype=np.int64)


def cell_counts(layout: Layout, settings) -> dict[int, list[np.ndarray]]:
    """The number of cells in each coarse interval of every axis, per glued group (module docstring)."""
    d, geo = layout.dim, layout.geo
    base = settings.sizes if settings.sizes is not None and len(settings.sizes) == d else [settings.maxh] * d
    coarse = [layout.facets(layout.region, layout.breaks, a) for a in range(d)]
    counts = {}
    for g in np.unique(layout.group):
        members = np.flatnonzero(layout.group == g)
        h = [np.full(len(layout.breaks[a]) - 1, float(base[a])) for a in range(d)]
        for k in members:
            if geo.blocks[k].maxh is not None:
                for a in range(d):
                    slab = np.any(layout.region == k, axis=tuple(b for b in range(d) if b != a))
                    h[a][slab] = np.minimum(h[a][slab], geo.blocks[k].maxh)
        for a in range(d):
            pos, reg, _, code, _ = coarse[a]
            for name, bh in settings.boundary_maxh.items():
                if name not in layout.names:
                    continue
                on = (code == layout.names.index(name)) & np.isin(reg, members)
                for b in range(d):
                    if b != a:
                        along = np.unique(pos[on, b])
                        h[b][along] = np.minimum(h[b][along], bh)
        counts[int(g)] = [np.maximum(1, np.ceil(np.diff(layout.breaks[a]) / h[a] * (1 - 1e-9))).astype(np.int64)
                          for a in range(d)]
    return counts


def element_counts(geo: GeometryModel, settings) -> dict[tuple[str, str], float]:
    """The number of elements of the structured mesh per ("region", name), exactly, without building it."""
    layout = Layout(geo)
    counts = cell_counts(layout, settings)
    per_cell = 1 if settings.elements == "tensor" else len(SIMPLICES[geo.dim])
    out: dict[tuple[str, str], float] = {}
    for g, n in counts.items():
        cells = np.ones(layout.region.shape)
        for a in range(geo.dim):
            shape = [1] * geo.dim
            shape[a] = -1
            cells = cells * n[a].reshape(shape)
        for k in np.flatnonzero(layout.group == g):
            key = ("region", geo.blocks[k].name)
            out[key] = out.get(key, 0.0) + per_cell * float(cells[layout.region == k].sum())
    return out


def structured_mesh(geo: GeometryModel, settings):
    """The structured mesh of ``geo`` (an ngsolve.Mesh; module docstring) with ``settings`` (MeshSettings:
    maxh, sizes, elements, boundary_maxh)."""
    import netgen.meshing as ngm
    import ngsolve as ngs

    d = geo.dim
    layout = Layout(geo)
    builder = _Builder(ngm.Mesh(dim=d), d, settings.elements == "tensor")
    for b in geo.blocks:
        builder.ngmesh.AddRegion(b.name, dim=d)
    for g, n in cell_counts(layout, settings).items():
        coords = [_refine(layout.breaks[a], n[a]) for a in range(d)]
        region = layout.region
        for a in range(d):
            region = np.repeat(region, n[a], axis=a)
        members = np.flatnonzero(layout.group == g)
        builder.add_group(region, members, coords, [layout.facets(region, coords, a) for a in range(d)])
    builder.finish(layout.names)
    return ngs.Mesh(builder.ngmesh)


def _refine(breaks: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The grid lines: each interval [breaks[k], breaks[k+1]] cut into n[k] equal cells."""
    parts = [np.linspace(breaks[k], breaks[k + 1], int(n[k]) + 1)[:-1] for k in range(len(n))]
    return np.concatenate(parts + [breaks[-1:]])


class _Builder:
    """Adds the groups' points, volume elements and boundary elements to a netgen mesh."""

    def __init__(self, ngmesh, dim: int, tensor: bool):
        self.ngmesh, self.dim, self.tensor = ngmesh, dim, tensor
        self.npoints = 0
        self.boundary: dict[tuple[int, int, int], list[np.ndarray]] = {}   # (name, domin, domout) -> elements

    def add_group(self, region: np.ndarray, members: np.ndarray, coords: list[np.ndarray], facets) -> None:
        d = self.dim
        shape = tuple(len(c) for c in coords)
        cells = np.argwhere(np.isin(region, members))
        flat = np.ravel_multi_index(tuple(np.moveaxis(cells[:, None, :] + TENSOR_CELL[d][None], -1, 0)), shape)
        used = np.unique(flat)
        lookup = np.full(int(np.prod(shape)), -1, dtype=np.int64)
        lookup[used] = np.arange(len(used)) + self.npoints
        idx = np.unravel_index(used, shape)
        pts = np.zeros((len(used), 3))
        for a in range(d):
            pts[:, a] = coords[a][idx[a]]
        self.ngmesh.AddPoints(pts)
        self.npoints += len(used)
        conn = lookup[flat]
        owner = region[tuple(cells.T)]
        for k in members:
            els = conn[owner == k]
            if not self.tensor:
                els = els[:, SIMPLICES[d]].reshape(-1, SIMPLICES[d].shape[1])
            if len(els):
                self.ngmesh.AddElements(dim=d, index=int(k) + 1, data=np.ascontiguousarray(els, dtype=np.int32),
                                        base=0)
        for a, (pos, reg, sign, code, other) in enumerate(facets):
            keep = np.isin(reg, members)
            self._add_facets(a, pos[keep], reg[keep], sign[keep], code[keep], other[keep], lookup, shape)

    def _add_facets(self, a, pos, reg, sign, code, other, lookup, shape) -> None:
        d = self.dim
        offsets = np.zeros((len(FACET[d]), d), dtype=np.int64)
        for j in range(d - 1):
            offsets[:, (a + 1 + j) % d] = FACET[d][:, j]
        conn = lookup[np.ravel_multi_index(tuple(np.moveaxis(pos[:, None, :] + offsets[None], -1, 0)), shape)]
        if d == 3 and not self.tensor:
            conn = conn[:, SIMPLICES[2]]
        flip = sign < 0 if (d == 3 or a == 0) else sign > 0     # 2D: the region on the segment's left
        conn[flip] = conn[flip][..., ::-1]
        for key in np.unique(np.stack([code, reg, other], axis=1), axis=0):
            mask = np.all(np.stack([code, reg, other], axis=1) == key, axis=1)
            els = conn[mask].reshape(-1, conn.shape[-1])
            self.boundary.setdefault(tuple(int(v) for v in key), []).append(els)

    def finish(self, names: list[str]) -> None:
        """Add the boundary elements: 2D one region per name; 3D one face descriptor per (name, domin, domout)."""
        import netgen.meshing as ngm

        index = {}
        for (code, reg, other), parts in sorted(self.boundary.items()):
            name = names[code]
            if self.dim == 2:
                if name not in index:
                    index[name] = self.ngmesh.AddRegion(name, dim=1)
                i = index[name]
            else:
                bc = index.setdefault(name, len(index) + 1)
                i = self.ngmesh.Add(ngm.FaceDescriptor(surfnr=bc, domin=reg + 1, domout=other + 1, bc=bc))
                self.ngmesh.SetBCName(i - 1, name)
            self.ngmesh.AddElements(dim=self.dim - 1, index=i, data=np.ascontiguousarray(np.concatenate(parts),
                                                                                         dtype=np.int32), base=0)
