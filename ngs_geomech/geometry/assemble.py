"""Assemble the blocks of a scene into one netgen.occ geometry.

Rules:
- painter's order: every block is cut by the blocks declared after it, so inclusions follow their host;
- blocks that touch must have a declared interface; ``glued`` ones share their mesh nodes (netgen ``Glue``),
  ``contact`` ones get independent copies of the common side (non-matching meshes allowed), named
  ``<interface>__<block>`` on each side;
- a ``contact`` interface between blocks that do not touch (an initial gap) names its two sides with
  ``sides = [name on the first block, name on the second block]``: boundary names of the blocks' own sides
  (selectors, polygon/profile edge names), each only on its block; they keep their names;
- sides without a name are called ``default`` by netgen; they are insulated / traction free;
- the regions are the blocks, an imported block's regions (its file's solids) and the parts ``[[cuts]]`` split
  blocks into (:mod:`.cuts`), in the blocks' order; a cut face between two parts without a declared interface is
  a glued interface named after the cut.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from netgen import occ

from ..errors import Problem, SceneError
from ..scene.model import Interface, Scene
from .cuts import Split, apply_cuts
from .shapes import cells, declared_extent, make_block, sides

DEFAULT = "default"
MIN_SIZE = 1e-6
"""Smallest thickness of a block, m: OCC's absolute precision is 1e-7 m; a 1 um square in a 1 m model builds
and meshes, a 0.3 um one vanishes in the Boolean cut and a 0.1 um one fails (StdFail_NotDone)."""
MIN_RELATIVE_SIZE = 1e-10
"""Smallest thickness of a block relative to the model's extent: a 0.1 mm square in a 1000 km model (1e-10)
meshes, with a 10 um one (1e-11) netgen reports a surface meshing error; the built-in scenes go down to 7e-4."""
AXIS = "axis"


@dataclass
class ContactSide:
    """The two sides of a contact interface: boundary names and blocks.

    Blocks that touch: the shared side's two copies ``<interface>__<block>``. Blocks with an initial gap
    (``Interface.sides``): ``side_names`` = (the master block's side, the minion block's side), the scene's
    own boundary names, and ``gap`` the smallest distance between them (m)."""

    name: str
    master_block: str
    minion_block: str
    side_names: tuple[str, str] | None = None
    gap: float = 0.0

    @property
    def initial_gap(self) -> bool:
        """Whether the blocks do not touch (sides named by the scene; no heat crosses the gap)."""
        return self.side_names is not None

    @property
    def master(self) -> str:
        return self.side_names[0] if self.side_names else f"{self.name}__{self.master_block}"

    @property
    def minion(self) -> str:
        return self.side_names[1] if self.side_names else f"{self.name}__{self.minion_block}"


@dataclass
class GeometryModel:
    """The assembled geometry with what the scene can refer to."""

    shape: object
    dim: int
    regions: list[str]
    boundaries: set[str]
    glued: dict[str, tuple[str, str]] = field(default_factory=dict)
    contacts: dict[str, ContactSide] = field(default_factory=dict)
    bounding_box: tuple = ()
    block_boundaries: dict[str, set[str]] = field(default_factory=dict)   # block -> names of its outer sides
    split: dict[str, tuple[str, list[str]]] = field(default_factory=dict)  # block -> (cut, its parts) (.cuts)
    blocks: list = field(default_factory=list)       # the scene's blocks (structured meshes are built from them)
    axisymmetric: bool = False

    def occ_geometry(self):
        return occ.OCCGeometry(self.shape, dim=self.dim)

    def element_estimate(self, maxh: float) -> dict[tuple[str, str], float]:
        """An estimate of the number of elements netgen makes with global size ``maxh`` (m) and the blocks' and
        boundaries' own maxh, per ("region", name) and ("boundary", name): each cell's area (volume) over that of
        an equilateral triangle sqrt(3)/4 h^2 (regular tetrahedron h^3 / (6 sqrt(2))) of its size h, and a strip
        one element wide along each side finer than every cell. From the OCC shape only (cheap, no meshing).
        Measured on the built-in scenes, netgen made 0.5 to 2.9 times as many: fewer in boxes (its tetrahedra
        are larger on average than the regular one of edge maxh), more near small features and curved sides."""
        def per_element(h: float) -> float:
            return math.sqrt(3) / 4 * h ** 2 if self.dim == 2 else h ** 3 / (6 * math.sqrt(2))

        counts: dict[tuple[str, str], float] = {}
        coarse = float("inf")
        for cell in cells(self.shape, self.dim):
            h = min(maxh, float(cell.maxh))
            coarse = min(coarse, h)
            key = ("region", cell.name)
            counts[key] = counts.get(key, 0.0) + float(cell.mass) / per_element(h)
        for side in sides(self.shape, self.dim):
            h = min(maxh, float(side.maxh))
            if h < coarse:
                key = ("boundary", side.name or DEFAULT)
                counts[key] = counts.get(key, 0.0) + float(side.mass) * h / per_element(h)
        return counts


def scene_dim(scene: Scene) -> int:
    return 3 if scene.scene.dimension == "3d" else 2


def _key(side) -> tuple:
    c = side.center
    return (c.x, c.y, c.z, side.mass)


def _same(a: tuple, b: tuple, tol: float) -> bool:
    return all(abs(u - v) <= tol for u, v in zip(a, b))


def build_geometry(scene: Scene) -> GeometryModel:
    """Build the geometry of a scene. Raises SceneError listing every geometric problem: blocks that cannot be
    built or are covered, blocks across the axis, interfaces between blocks that do not touch (or touching blocks
    without one), contacts between blocks also glued together."""
    dim = scene_dim(scene)
    raw = _raw_blocks(scene, dim)
    split = _regions(scene, _carve_all(raw, [b.name for b in scene.blocks], dim), dim)
    names = list(split.shapes)
    parts = _Parts.glue(split.shapes, names, dim, split.replaced)
    problems = _axis_problems(scene, raw, parts)
    found = _Interfaces()
    for k, itf in enumerate(scene.interfaces):
        found.declare(itf, f"interfaces[{k}] ({itf.name})", parts, problems)
    _declare_cut_faces(split, found, parts, problems)
    for pair in parts.touching:
        if pair not in found.declared:
            a, b = sorted(pair)
            problems.append(Problem("interfaces", f"blocks {a!r} and {b!r} touch but no interface is declared "
                                                  "for them (add [[interfaces]] with type 'glued' or 'contact')"))
    if problems:
        raise SceneError(problems, source="geometry")
    groups = _glued_groups(names, found)
    model = GeometryModel(shape=None, dim=dim, regions=names, boundaries=set(), bounding_box=(parts.lo, parts.hi),
                          split=split.replaced, blocks=list(scene.blocks),
                          axisymmetric=scene.scene.dimension == "axisymmetric")
    contact_keys = _contact_sides(model, found, parts)
    final = _group_shapes(model, groups, contact_keys, parts)
    _finish(scene, model, final, parts.tol, _region_maxh(scene, split))
    return model


def _regions(scene: Scene, carved: dict, dim: int) -> Split:
    """The regions of the carved blocks (an import's by its cells' names) split by the scene's cuts; raises
    SceneError for a region name two blocks give and for the cuts' problems."""
    shapes: dict[str, object] = {}
    problems: list[Problem] = []
    for i, b in enumerate(scene.blocks):
        own = [b.name] if b.shape != "import" else list(dict.fromkeys(c.name for c in cells(carved[b.name], dim)))
        for r in own:
            if r in shapes:
                problems.append(Problem(f"blocks[{i}] ({b.name})", f"region {r!r} is also another block's region: "
                                        "give it a name of its own"))
            elif b.shape != "import":
                shapes[r] = carved[b.name]
            else:
                mine = list(cells(carved[b.name], dim)[r])
                shapes[r] = mine[0] if len(mine) == 1 else occ.Compound(mine)
    if problems:
        raise SceneError(problems, source="geometry")
    if not scene.cuts:
        return Split(shapes)
    lo = np.min([[c.bounding_box[0].x, c.bounding_box[0].y, c.bounding_box[0].z] for c in shapes.values()], axis=0)
    hi = np.max([[c.bounding_box[1].x, c.bounding_box[1].y, c.bounding_box[1].z] for c in shapes.values()], axis=0)
    split = apply_cuts(scene.cuts, shapes, dim, float(np.max(hi - lo)), problems)
    if problems:
        raise SceneError(problems, source="geometry")
    return split


def _region_maxh(scene: Scene, split: Split) -> dict[str, float | None]:
    """The element size of each region, m: its block's maxh (parts of a cut block inherit it)."""
    maxh: dict[str, float | None] = {b.name: b.maxh for b in scene.blocks}
    for b in scene.blocks:
        if b.shape == "import":
            maxh.update({r: b.maxh for r in b.solids.values()})
    for block, (_, parts) in split.replaced.items():
        maxh.update({p: maxh.get(block) for p in parts})
    return maxh


def _declare_cut_faces(split: Split, found: _Interfaces, parts: _Parts, problems: list[Problem]) -> None:
    """A glued interface named after the cut for each cut face between two parts the scene declares no
    interface for."""
    for a, b, name, path in split.pairs:
        pair = frozenset((a, b))
        if pair in found.declared or pair not in parts.touching:
            continue
        if name in found.paths:
            problems.append(Problem(path, f"the cut face between {a!r} and {b!r} would be the glued interface "
                                    f"{name!r}, but {found.paths[name]} has that name: declare the interface "
                                    f"between {a!r} and {b!r} in [[interfaces]]"))
            continue
        found.declare(Interface(name=name, blocks=[a, b]), path, parts, problems)


def _raw_blocks(scene: Scene, dim: int) -> dict:
    """The OCC shape of every block by name (:func:`make_block`); raises SceneError for blocks too thin for the
    geometry kernel or that cannot be built."""
    problems: list[Problem] = []
    small = _too_small(scene, dim, problems)
    raw = {}
    for i, b in enumerate(scene.blocks):
        if b.name in small:
            continue
        try:
            raw[b.name] = make_block(b, dim)
        except ValueError as exc:
            problems.append(Problem(f"blocks[{i}] ({b.name})", str(exc)))
        except (RuntimeError, TypeError) as exc:
            problems.append(Problem(f"blocks[{i}] ({b.name})", f"the geometry kernel (OCC) could not build this "
                                    f"block ({exc}): check its data"))
    if problems:
        raise SceneError(problems, source="geometry")
    return raw


def _carve_all(raw: dict, names: list[str], dim: int) -> dict:
    """Every block with the blocks declared after it cut out (:func:`_carve`); raises SceneError when one is
    covered or the geometry kernel failed."""
    problems: list[Problem] = []
    carved = {}
    for i, name in enumerate(names):
        shape = _carve(raw, names, i, dim, problems)
        if shape is not None:
            carved[name] = shape
    if problems:
        raise SceneError(problems, source="geometry")
    return carved


@dataclass
class _Parts:
    """The carved blocks glued into one shape: each block's cells, the sides blocks share (by pair of blocks),
    the bounding box (lo, hi), the tolerance of coordinate comparisons (m) and the keys (:func:`_key`) of all shared
    sides."""

    dim: int
    names: list[str]
    block_cells: dict[str, list]
    touching: dict[frozenset, list]
    lo: np.ndarray
    hi: np.ndarray
    tol: float
    replaced: dict = field(default_factory=dict)       # block -> (cut, its parts): for messages
    shared_keys: list = field(default_factory=list)

    def __post_init__(self):
        self.shared_keys = [_key(s) for shared in self.touching.values() for s in shared]

    @classmethod
    def glue(cls, carved: dict, names: list[str], dim: int, replaced: dict | None = None) -> _Parts:
        try:
            glued_all = occ.Glue([carved[n] for n in names]) if len(names) > 1 else carved[names[0]]
        except RuntimeError as exc:
            raise SceneError([Problem("blocks", f"the geometry kernel (OCC) could not join the blocks ({exc})")],
                             source="geometry") from None
        bb = glued_all.bounding_box
        lo, hi = np.array([bb[0].x, bb[0].y, bb[0].z]), np.array([bb[1].x, bb[1].y, bb[1].z])
        size = float(np.max(hi - lo))
        block_cells = {n: list(cells(glued_all, dim)[n]) for n in names}
        touching: dict[frozenset, list] = {}       # which blocks touch, and along which sides
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                shared = []
                for ca in block_cells[a]:
                    for cb in block_cells[b]:
                        shared += list(sides(ca, dim) * sides(cb, dim))
                if shared:
                    touching[frozenset((a, b))] = shared
        return cls(dim, names, block_cells, touching, lo, hi, 1e-8 * max(size, 1e-30), dict(replaced or {}))

    def outer_sides(self, block: str, name: str | None) -> list:
        """The sides of ``block`` called ``name`` (any name: None) that it shares with no other block."""
        return [s for c in self.block_cells[block] for s in sides(c, self.dim)
                if (name is None or s.name == name) and not any(_same(_key(s), k, self.tol)
                                                                for k in self.shared_keys)]


def _axis_problems(scene: Scene, raw: dict, parts: _Parts) -> list[Problem]:
    """Blocks of an axisymmetric scene that reach x = r < 0."""
    # OCC pads bounding boxes by its absolute precision (1e-7 m): allow for that on the axis
    axis_tol = max(parts.tol, 1e-6)
    problems = []
    if scene.scene.dimension == "axisymmetric" and parts.lo[0] < -axis_tol:
        for i, b in enumerate(scene.blocks):
            xmin = raw[b.name].bounding_box[0].x
            if xmin < -axis_tol:
                problems.append(Problem(f"blocks[{i}] ({b.name})", f"axisymmetric scenes need r = x >= 0; this "
                                                                   f"block reaches x = {xmin:.6g}"))
    return problems


@dataclass
class _Interfaces:
    """The interfaces declared so far: by pair of blocks, the scene path of each (by name), the sides of each
    contact with an initial gap (by name) and the interface whose master side each named side is."""

    declared: dict[frozenset, object] = field(default_factory=dict)
    paths: dict[str, str] = field(default_factory=dict)
    gap_sides: dict[str, tuple[list, list]] = field(default_factory=dict)
    masters_taken: dict[str, str] = field(default_factory=dict)

    def declare(self, itf, path: str, parts: _Parts, problems: list[Problem]) -> None:
        """Declare interface ``itf`` (scene path ``path``) between two blocks that touch, or across an initial
        gap (``sides``), or add the Problems why it cannot be."""
        names = parts.names
        unknown = [b for b in itf.blocks if b not in names]
        if unknown:
            cut = "".join(f" (cut {parts.replaced[b][0]!r} split {b!r} into {parts.replaced[b][1]}: name the parts)"
                          for b in unknown if b in parts.replaced)
            problems.append(Problem(path, f"unknown block(s) {unknown}; blocks are {names}{cut}"))
            return
        if itf.blocks[0] == itf.blocks[1]:
            problems.append(Problem(path, "an interface needs two different blocks"))
            return
        pair = frozenset(itf.blocks)
        if pair in self.declared:
            problems.append(Problem(path, f"blocks {itf.blocks} already have interface {self.declared[pair].name!r}"))
            return
        if itf.master is not None and itf.master not in itf.blocks:
            problems.append(Problem(f"{path}.master", f"{itf.master!r} is not one of {itf.blocks}"))
            return
        if itf.sides is not None:
            if not self._across_gap(itf, path, pair, parts, problems):
                return
        elif pair not in parts.touching:
            hint = (f" (for a contact with an initial gap name the two sides: sides = [boundary on "
                    f"{itf.blocks[0]!r}, boundary on {itf.blocks[1]!r}])" if itf.type == "contact" else "")
            problems.append(Problem(path, f"blocks {itf.blocks[0]!r} and {itf.blocks[1]!r} do not touch{hint}"))
            return
        self.declared[pair] = itf
        self.paths[itf.name] = path

    def _across_gap(self, itf, path: str, pair: frozenset, parts: _Parts, problems: list[Problem]) -> bool:
        """A contact across an initial gap between the sides ``itf.sides`` names; whether it is declared so."""
        if itf.type != "contact":
            problems.append(Problem(f"{path}.sides", "applies to type = 'contact' only (a contact with an "
                                                     "initial gap between blocks that do not touch)"))
        elif pair in parts.touching:
            problems.append(Problem(f"{path}.sides", f"blocks {itf.blocks[0]!r} and {itf.blocks[1]!r} touch: "
                                    "their shared side is the contact side (found automatically); 'sides' "
                                    "is for blocks that do not touch (an initial gap): remove it"))
        if itf.type != "contact" or pair in parts.touching:
            if pair in parts.touching:      # declared all the same (no second 'touch but no interface' problem)
                self.declared[pair], self.paths[itf.name] = itf, path
            return False
        found = _gap_sides(itf, path, parts.names, parts.outer_sides, problems)
        if found is None:
            return False
        master = itf.master or itf.blocks[0]
        mside = itf.sides[itf.blocks.index(master)]
        if mside in self.masters_taken:
            problems.append(Problem(f"{path}.sides", f"{mside!r} is already the contact side (master) of "
                                    f"interface {self.masters_taken[mside]!r}: a side carries one interface's "
                                    "multipliers; name another side or swap master"))
            return False
        self.masters_taken[mside] = itf.name
        self.gap_sides[itf.name] = found
        return True


def _glued_groups(names: list[str], found: _Interfaces) -> list[list[str]]:
    """The groups of blocks joined by glued interfaces (one mesh each); raises SceneError for a contact interface
    inside a group."""
    parent = {n: n for n in names}

    def find(n):
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n
    for pair, itf in found.declared.items():
        if itf.type == "glued":
            a, b = tuple(pair)
            parent[find(a)] = find(b)
    problems = [Problem(found.paths[itf.name], "a contact interface between blocks that are also joined through "
                        "glued interfaces is not supported")
                for itf in found.declared.values()
                if itf.type == "contact" and find(itf.blocks[0]) == find(itf.blocks[1])]
    if problems:
        raise SceneError(problems, source="geometry")
    groups: dict[str, list[str]] = {}
    for n in names:
        groups.setdefault(find(n), []).append(n)
    return list(groups.values())


def _contact_sides(model: GeometryModel, found: _Interfaces, parts: _Parts) -> dict[str, list]:
    """Name the glued interfaces' shared sides and enter every interface into ``model``; returns the keys
    (:func:`_key`) of the shared sides of each contact between touching blocks."""
    contact_keys = {}
    for pair, itf in found.declared.items():
        shared = parts.touching.get(pair, [])
        if itf.type == "glued":
            for s in shared:
                s.name = itf.name
            model.glued[itf.name] = tuple(itf.blocks)
            continue
        master = itf.master or itf.blocks[0]
        minion = [b for b in itf.blocks if b != master][0]
        if itf.name in found.gap_sides:
            by_block = dict(zip(itf.blocks, itf.sides))
            a, b = found.gap_sides[itf.name]
            gap = min(float(sa.Distance(sb)) for sa in a for sb in b)
            model.contacts[itf.name] = ContactSide(itf.name, master, minion, (by_block[master], by_block[minion]),
                                                   gap)
        else:
            model.contacts[itf.name] = ContactSide(itf.name, master, minion)
            contact_keys[itf.name] = [_key(s) for s in shared]
    return contact_keys


def _group_shapes(model: GeometryModel, groups: list[list[str]], contact_keys: dict[str, list], parts: _Parts):
    """One shape of all groups of glued blocks: each group after the first an independent copy on its own
    mesh-size layer, the two copies of each contact side named ``<interface>__<block>``."""
    dim = parts.dim
    group_shapes = []
    for gi, members in enumerate(groups):
        gshape = occ.Compound([c for m in members for c in parts.block_cells[m]])
        if gi > 0:
            gshape = gshape.Move((0, 0, 0))  # an independent copy: its sides are not shared with others
            # its own mesh-size layer: netgen's size field is otherwise global, so a finer maxh on one side
            # of a contact interface would refine the other side too (and the meshes would match)
            for kind in ("solids", "faces", "edges", "vertices"):
                for sub in getattr(gshape, kind):
                    sub.layer = gi + 1
        group_shapes.append((members, gshape))
    for members, gshape in group_shapes:
        for cs in model.contacts.values():
            if cs.initial_gap:       # the scene's own names stay
                continue
            for block, bname in ((cs.master_block, cs.master), (cs.minion_block, cs.minion)):
                if block not in members:
                    continue
                for c in cells(gshape, dim)[block]:
                    for s in sides(c, dim):
                        if any(_same(_key(s), k, parts.tol) for k in contact_keys[cs.name]):
                            s.name = bname
    return group_shapes[0][1] if len(group_shapes) == 1 else occ.Compound([g for _, g in group_shapes])


def _finish(scene: Scene, model: GeometryModel, final, tol: float, region_maxh: dict) -> None:
    """The mesh sizes of regions (``region_maxh``, m) and boundaries on the final shape, the sides on the axis of an
    axisymmetric scene named :data:`AXIS`, and the model's shape and boundary names."""
    dim = model.dim
    for cell in cells(final, dim):
        h = region_maxh.get(cell.name)
        if h is not None:
            cell.maxh = h
    for s in sides(final, dim):
        h = scene.mesh.boundary_maxh.get(s.name)
        if h is not None:
            s.maxh = h
    if scene.scene.dimension == "axisymmetric":
        # unnamed sides on the axis r = 0 are called 'axis' (u_r = 0 there; insulated for heat)
        for s in sides(final, dim):
            if not s.name:
                lo_s, hi_s = s.bounding_box
                if abs(lo_s.x) <= max(tol, 1e-6) and abs(hi_s.x) <= max(tol, 1e-6):
                    s.name = AXIS
    model.shape = final
    model.boundaries = {s.name or DEFAULT for s in sides(final, dim)}
    for cell in cells(final, dim):
        model.block_boundaries.setdefault(cell.name, set()).update(s.name or DEFAULT for s in sides(cell, dim))


def _too_small(scene: Scene, dim: int, problems: list[Problem]) -> set[str]:
    """The blocks thinner than the geometry can resolve (:data:`MIN_SIZE`, :data:`MIN_RELATIVE_SIZE` of the
    model's extent), found from the blocks' data before any OCC operation (which may fail or crash on them);
    adds a Problem for each."""
    boxes = {i: declared_extent(b, dim) for i, b in enumerate(scene.blocks)}
    known = [e for e in boxes.values() if e is not None]
    if not known:
        return set()
    model = float(np.max(np.max([e[1] for e in known], axis=0) - np.min([e[0] for e in known], axis=0)))
    limit = max(MIN_SIZE, MIN_RELATIVE_SIZE * model)
    small = set()
    for i, e in boxes.items():
        if e is not None and 0 < e[2] < limit:   # 0: a degenerate block, make_block says why
            b = scene.blocks[i]
            small.add(b.name)
            problems.append(Problem(f"blocks[{i}] ({b.name})", f"is {e[2]:.3g} m thick (its smallest extent) in a "
                                    f"model {model:.3g} m across: blocks thinner than {limit:.3g} m ("
                                    f"{MIN_RELATIVE_SIZE:g} of the model's extent, at least {MIN_SIZE:g} m) are "
                                    "beyond the geometry kernel's precision; make it larger or leave it out"))
    return small


def _carve(raw: dict, names: list[str], i: int, dim: int, problems: list[Problem]):
    """Block ``names[i]`` with the blocks declared after it cut out (painter's order), or None after adding a
    Problem: it is entirely covered by them, or the geometry kernel failed."""
    name = names[i]
    shape = raw[name]
    later = [raw[n] for n in names[i + 1:]]
    if not later:
        return shape
    try:
        cover = later[0] if len(later) == 1 else occ.Fuse(later)
        shape = shape - cover
        left = sum(c.mass for c in cells(shape, dim))
        whole = sum(c.mass for c in cells(raw[name], dim))
        if left > 1e-12 * max(1.0, whole):
            return shape
        covered = sum(c.mass for c in cells(raw[name] * cover, dim))
    except RuntimeError as exc:
        problems.append(Problem(f"blocks[{i}] ({name})", f"the geometry kernel (OCC) failed cutting the blocks "
                                f"declared after it out of this block ({exc})"))
        return None
    if covered >= (1 - 1e-6) * whole:
        problems.append(Problem(f"blocks.{name}", "is entirely covered by blocks declared after it"))
    else:
        problems.append(Problem(f"blocks[{i}] ({name})", f"the geometry kernel (OCC) returned nothing cutting the "
                                f"blocks declared after it out of this block, though they cover only "
                                f"{100 * covered / whole:.3g} % of it: check the blocks' data"))
    return None


def _gap_sides(itf, path: str, names: list[str], outer_sides, problems: list[Problem]):
    """The sides ``itf.sides`` names on its two blocks (lists of OCC sides), or None after adding Problems:
    each name must be a side of its block that no other block has (and no block shares)."""
    if itf.sides[0] == itf.sides[1]:
        problems.append(Problem(f"{path}.sides", f"both sides are called {itf.sides[0]!r}: give the side on each "
                                                 "block a name of its own"))
        return None
    found, bad = [], False
    for block, name in zip(itf.blocks, itf.sides):
        own = outer_sides(block, name)
        others = [b for b in names if b != block and outer_sides(b, name)]
        if not own:
            known = sorted({s.name for s in outer_sides(block, None)} - {"", None})
            where = f"it is on block(s) {others}" if others else (
                f"the named sides of {block!r} are {known}" if known else f"block {block!r} has no named sides "
                "(name them with 'boundaries' selectors or polygon/profile edge names)")
            problems.append(Problem(f"{path}.sides", f"no boundary {name!r} on block {block!r}: {where}"))
            bad = True
        elif others:
            problems.append(Problem(f"{path}.sides", f"boundary {name!r} is also on block(s) {others}: the contact "
                                    f"side needs a name of its own on block {block!r}"))
            bad = True
        found.append(own)
    return None if bad else tuple(found)
