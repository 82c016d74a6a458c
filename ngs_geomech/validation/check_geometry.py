"""Validation of what a scene names in its geometry: every region has a material and every named region,
boundary and interface exists; conditions sit on outer boundaries (a symmetry on a straight or planar one); a steady
heat problem has a fixed temperature on every body; probes lie in the geometry and sample a field the scene
computes; the mesh is not larger than ``mesh.max_elements``. The geometry is built (OCC shapes, no mesh) before."""

from __future__ import annotations

import math

import numpy as np
from netgen import occ

from ..errors import Problem
from ..geometry.assemble import GeometryModel
from ..geometry.mesh import element_estimate
from ..geometry.shapes import cells, sides
from ..heat.materials import has_phase_change
from ..scene.model import PROBE_PHASE, PROBE_THERMAL, Probe, Scene
from .check_materials import stefan_scene


def check_references(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """The regions, boundaries, interfaces and probes the scene names, against its geometry ``geo``."""
    _check_regions(scene, geo, problems)
    _check_condition_boundaries(scene, geo, problems)
    _check_named_items(scene, geo, problems)
    if scene.physics.thermal == "steady":
        _check_steady_heat(scene, geo, problems)
    _check_interface_keys(scene, geo, problems)
    check_probes(scene, geo, problems)


def _check_regions(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Every region has a material and every material a region."""
    for r in geo.regions:
        if r not in scene.materials:
            problems.append(Problem(f"materials.{r}", f"region {r!r} has no material"))
    for name in scene.materials:
        if name not in geo.regions:
            problems.append(Problem(f"materials.{name}", f"no region {name!r} in the geometry "
                                                         f"(regions: {', '.join(geo.regions)})"))


def _sides(geo: GeometryModel) -> tuple[set[str], dict[str, str], set[str]]:
    """The boundary names of the geometry by kind: interface sides (glued, and contact sides between touching
    blocks), the sides of contacts with an initial gap (-> their interface), and the outer boundaries (the gap
    sides among them: heat cannot cross a gap)."""
    interface_sides = set(geo.glued)
    gap_sides: dict[str, str] = {}
    for cs in geo.contacts.values():
        if cs.initial_gap:
            gap_sides.update({cs.master: cs.name, cs.minion: cs.name})
        else:
            interface_sides |= {cs.master, cs.minion}
    return interface_sides, gap_sides, geo.boundaries - interface_sides


def _mechanical_kinds(bc) -> list[str]:
    kinds = [k for k, v in (("displacement", bc.displacement), ("traction", bc.traction), ("pressure", bc.pressure),
                            ("foundation", bc.foundation)) if v is not None]
    return kinds + (["symmetry"] if bc.symmetry else [])


def _check_condition_boundaries(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Boundary conditions sit on outer boundaries (mechanical ones not on the sides of a gap), a symmetry
    condition on a straight (planar) one."""
    interface_sides, gap_sides, outer = _sides(geo)
    for name, bc in scene.boundary_conditions.items():
        if name in gap_sides and _mechanical_kinds(bc):
            problems.append(Problem(f"boundary_conditions.{name}", f"{name!r} is a side of contact interface "
                                    f"{gap_sides[name]!r}: mechanical conditions ({_mechanical_kinds(bc)[0]}) are "
                                    "not allowed there (thermal ones are: the gap carries no heat)"))
    for name in scene.boundary_conditions:
        if name in interface_sides:
            problems.append(Problem(f"boundary_conditions.{name}", f"{name!r} is an interface, not an outer "
                                                                   "boundary"))
        elif name in geo.contacts:
            cs = geo.contacts[name]
            problems.append(Problem(f"boundary_conditions.{name}", f"{name!r} is a contact interface (sides "
                                    f"{cs.master!r}, {cs.minion!r}), not an outer boundary"))
        elif name not in outer:
            problems.append(Problem(f"boundary_conditions.{name}", f"no boundary {name!r} in the geometry "
                                    f"(boundaries: {', '.join(sorted(outer))})"))
    for name, bc in scene.boundary_conditions.items():
        if bc.symmetry and name in outer and not _flat(geo, name):
            problems.append(Problem(f"boundary_conditions.{name}.symmetry", f"boundary {name!r} is not "
                                    f"{'straight' if geo.dim == 2 else 'planar'}: the symmetry condition u_n = 0 "
                                    "(2.16) needs one normal direction"))


def _check_named_items(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """The boundaries of mesh.boundary_maxh and the regions of sources and initial.regions exist."""
    for name in scene.mesh.boundary_maxh:
        if name not in geo.boundaries:
            problems.append(Problem(f"mesh.boundary_maxh.{name}", f"no boundary {name!r} in the geometry"))
    for i, s in enumerate(scene.sources):
        if s.region not in geo.regions:
            problems.append(Problem(f"sources[{i}].region", f"no region {s.region!r} in the geometry"))
    for name in scene.initial.regions:
        if name not in geo.regions:
            problems.append(Problem(f"initial.regions.{name}", f"no region {name!r} in the geometry"))


def _check_steady_heat(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """A steady heat problem has a temperature or heat transfer condition on every body heat cannot leave
    otherwise (else its solution is not unique)."""
    fixes = [n for n, bc in scene.boundary_conditions.items()
             if bc.temperature is not None or bc.heat_transfer_coefficient is not None]
    if not fixes:
        problems.append(Problem("boundary_conditions", "a steady heat problem needs a temperature or a "
                                "heat_transfer_coefficient condition somewhere, or its solution is not unique"))
        return
    # an initial gap with a gap conductivity or radiation carries heat whatever the mechanics does
    across = {i.name for i in scene.interfaces if i.gap_conductivity is not None or i.emissivities is not None}
    for members in _thermal_bodies(geo, across):
        if not any(n in fixes for b in members for n in geo.block_boundaries.get(b, ())):
            gaps = sorted(cs.name for cs in geo.contacts.values() if cs.initial_gap and cs.name not in across
                          and {cs.master_block, cs.minion_block} & set(members))
            why = (f" (interface(s) {gaps} have an initial gap and carry no heat)" if gaps else "")
            problems.append(Problem("boundary_conditions", f"a steady heat problem needs a temperature or "
                                    f"heat_transfer_coefficient condition on every body heat cannot leave "
                                    f"otherwise: block(s) {members} have none{why}"))


def _check_interface_keys(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """thermal_penalty on contacts between touching blocks of Stefan scenes; a search distance that reaches over
    an initial gap."""
    for i, itf in enumerate(scene.interfaces):
        if itf.thermal_penalty is None:
            continue
        p = f"interfaces[{i}] ({itf.name}).thermal_penalty"
        cs = geo.contacts.get(itf.name)
        if not stefan_scene(scene):
            problems.append(Problem(p, "applies to phase-change (Stefan) scenes only: other scenes couple the "
                                    "temperature across contact interfaces exactly (mortar)"))
        elif cs is None or cs.initial_gap:
            problems.append(Problem(p, "applies to contact interfaces between touching blocks (heat passes there); "
                                    + ("a glued interface shares its nodes" if cs is None
                                       else "an interface with an initial gap carries no heat")))
        elif not (math.isfinite(itf.thermal_penalty) and itf.thermal_penalty > 0):
            problems.append(Problem(p, f"must be > 0, got {itf.thermal_penalty}"))
    if scene.physics.mechanics is None:
        return
    for i, itf in enumerate(scene.interfaces):
        cs = geo.contacts.get(itf.name)
        sd = itf.search_distance
        if cs is not None and cs.initial_gap and sd is not None and sd < cs.gap:
            problems.append(Problem(f"interfaces[{i}] ({itf.name}).search_distance", f"{sd:g} m is smaller than "
                                    f"the initial gap {cs.gap:.6g} m between {cs.master!r} and {cs.minion!r}: "
                                    "the sides could never come into contact"))


def check_probes(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """Each probe has one target in the geometry and samples a field the scene computes; names are unique."""
    for i, pr in enumerate(scene.output.probes):
        _check_probe(scene, geo, pr, f"output.probes[{i}] ({pr.name})", problems)
    names = [pr.name for pr in scene.output.probes]
    for n in set(names):
        if names.count(n) > 1:
            problems.append(Problem("output.probes", f"probe name {n!r} is used twice"))


def _check_probe(scene: Scene, geo: GeometryModel, pr: Probe, p: str, problems: list[Problem]) -> None:
    targets = [k for k in ("point", "region", "boundary", "line") if getattr(pr, k) is not None]
    if len(targets) != 1:
        problems.append(Problem(p, "give exactly one of point, region, boundary, line"))
        return
    if pr.quantity in PROBE_PHASE and not stefan_scene(scene):
        if not any(has_phase_change(m) for m in scene.materials.values()):   # else: reported there
            problems.append(Problem(f"{p}.quantity", f"{pr.quantity!r} needs a phase change (a material with "
                                    "phase_change_temperature and physics.thermal = 'transient')"))
        return
    if (pr.quantity == "front") != (pr.line is not None):
        problems.append(Problem(f"{p}.line" if pr.line is not None else f"{p}.quantity",
                                "a line goes with quantity = 'front' (and a front probe needs a line)"))
        return
    if pr.line is not None:
        _check_front_probe(geo, pr, p, problems)
        return
    needs = "thermal" if pr.quantity in PROBE_THERMAL else "mechanics"
    if getattr(scene.physics, needs) is None:
        problems.append(Problem(f"{p}.quantity", f"{pr.quantity!r} needs physics.{needs}"))
    if pr.quantity == "displacement_z" and geo.dim != 3:
        problems.append(Problem(f"{p}.quantity", "displacement_z needs a 3d scene"))
    if pr.point is not None:
        if pr.statistic != "value":
            problems.append(Problem(f"{p}.statistic", "a point probe has statistic 'value'"))
        if len(pr.point) != geo.dim:
            problems.append(Problem(f"{p}.point", f"needs {geo.dim} coordinates"))
        elif not _inside(geo, pr.point):
            problems.append(Problem(f"{p}.point", f"{pr.point} lies outside the geometry"))
        return
    if pr.statistic == "value":
        problems.append(Problem(f"{p}.statistic", "use max, min or mean over a region or boundary"))
    if pr.region is not None and pr.region not in geo.regions:
        problems.append(Problem(f"{p}.region", f"no region {pr.region!r}"))
    if pr.boundary is not None and pr.boundary not in geo.boundaries:
        problems.append(Problem(f"{p}.boundary", f"no boundary {pr.boundary!r}"))


def _check_front_probe(geo: GeometryModel, pr: Probe, p: str, problems: list[Problem]) -> None:
    """A front probe: statistic 'value' along a line of two distinct points, the first inside the geometry."""
    a, b = (np.asarray(q, dtype=float) for q in pr.line)
    if pr.statistic != "value":
        problems.append(Problem(f"{p}.statistic", "a front probe has statistic 'value'"))
    if len(a) != geo.dim or len(b) != geo.dim:
        problems.append(Problem(f"{p}.line", f"needs two points of {geo.dim} coordinates"))
    elif not float(np.linalg.norm(b - a)) > 0:
        problems.append(Problem(f"{p}.line", "the two points must differ"))
    elif not _inside(geo, pr.line[0]):
        problems.append(Problem(f"{p}.line", f"the first point {pr.line[0]} lies outside the geometry"))


def check_mesh_size(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """The mesh is not larger than ``mesh.max_elements``, from the geometry's estimate before meshing (meshing
    runs until memory is exhausted otherwise)."""
    m = scene.mesh
    if not m.maxh > 0 or any(not h > 0 for h in m.boundary_maxh.values()) or any(
            b.maxh is not None and not b.maxh > 0 for b in scene.blocks):
        return                              # reported by the declared ranges (recheck)
    counts = element_estimate(geo, m)
    n = sum(counts.values())
    if n <= m.max_elements:
        return
    (kind, name), most = max(counts.items(), key=lambda kv: kv[1])
    item, h = "mesh.maxh", m.maxh
    i = next((i for i, b in enumerate(scene.blocks) if b.name == name), None)
    if kind == "boundary":
        item, h = f"mesh.boundary_maxh.{name}", m.boundary_maxh.get(name, m.maxh)
    elif i is not None and scene.blocks[i].maxh is not None and scene.blocks[i].maxh < m.maxh:
        item, h = f"blocks[{i}].maxh", scene.blocks[i].maxh
    where = f"{'region' if kind == 'region' else 'boundary'} {name!r}"
    problems.append(Problem(item, f"{h:g} m: the mesh would have at least {n:.3g} elements ({most:.3g} in {where}; "
                            f"estimated from the {'areas' if geo.dim == 2 else 'volumes'} and the element sizes "
                            f"before meshing), more than mesh.max_elements = {m.max_elements}: use larger elements, "
                            "or raise mesh.max_elements if the machine can take it"))


def _thermal_bodies(geo: GeometryModel, across: set[str] = frozenset()) -> list[list[str]]:
    """The blocks heat can pass between (joined by glued interfaces, contact interfaces without a gap and the
    interfaces ``across`` an initial gap), as sorted lists of block names."""
    parent = {b: b for b in geo.regions}

    def find(b):
        while parent[b] != b:
            b = parent[b]
        return b
    pairs = list(geo.glued.values()) + [(cs.master_block, cs.minion_block) for cs in geo.contacts.values()
                                        if not cs.initial_gap or cs.name in across]
    for a, b in pairs:
        parent[find(a)] = find(b)
    groups: dict[str, list[str]] = {}
    for b in geo.regions:
        groups.setdefault(find(b), []).append(b)
    return [sorted(g) for g in groups.values()]


def _flat(geo: GeometryModel, name: str) -> bool:
    """Whether all sides called ``name`` are straight (2D) or planar (3D) with one normal direction (parallel
    sides, e.g. both ends of a column, are fine: u_n = 0 is then one component)."""
    normals = []
    for side in sides(geo.shape, geo.dim):
        if side.name != name:
            continue
        if geo.dim == 2:
            a, b = np.array([side.start.x, side.start.y]), np.array([side.end.x, side.end.y])
            if abs(np.linalg.norm(b - a) - side.mass) > 1e-9 * side.mass:
                return False
            t = (b - a) / np.linalg.norm(b - a)
            normals.append(np.array([t[1], -t[0]]))
        else:
            inertia = np.array([[side.inertia[i, j] for j in range(3)] for i in range(3)])
            ev, vec = np.linalg.eigh(0.5 * (inertia + inertia.T))
            if abs(ev[2] - ev[0] - ev[1]) > 1e-9 * ev[2]:
                return False
            normals.append(vec[:, 2])
    return all(abs(abs(float(np.dot(n, normals[0]))) - 1) < 1e-9 for n in normals)


def _inside(geo: GeometryModel, point: list) -> bool:
    """Whether a point lies in (or on the boundary of) one of the geometry's cells, up to a relative
    tolerance. The bounding box alone is not enough (concave blocks, holes)."""
    lo, hi = geo.bounding_box
    tol = 1e-9 * max(float(np.max(hi - lo)), 1e-30)
    pt = np.zeros(3)
    pt[:geo.dim] = point
    if np.any(pt < lo - tol) or np.any(pt > hi + tol):
        return False
    vertex = occ.Vertex(occ.Pnt(*pt))
    return any(vertex.Distance(c) <= tol for c in cells(geo.shape, geo.dim))
