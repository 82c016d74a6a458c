"""General geometry through scenes, against closed forms: a dipping fault made by a cut (contact patch test),
a STEP round trip, circular arcs in profiles, extruded profiles (prisms).

:func:`inclined_fault_patch` : the unit cube cut through its centre by a plane of dip delta and strike phi into
a hanging wall and a footwall held together by a frictionless contact interface (independent, non-matching
meshes: the hanging wall's contact side is meshed finer); symmetry u_n = 0 on x = 0, y = 0, z = 0 and the
pressure p on x = 1, y = 1, z = 1. The exact state is hydrostatic, sigma = -p I, u = -p x / (3 K)
(K = E / (3 (1 - 2 nu))): linear, so in the P1 space, and its traction on the fault is -p n, normal, so the
frictionless contact transmits it and every nodal contact pressure is p. The same with the parts glued, and
with the cut through the origin and the part below it removed, u_n = 0 on the inclined cut face (u = c x
satisfies it on a plane through the origin); in 2D the unit square in plane strain, u = -p x / (2 (lambda +
mu)).

:func:`step_round_trip` : two boxes with named solids and faces written by netgen.occ to a STEP file, read
back by a scene's ``import`` block: the same volumes and names.

:func:`arc_profile` : a profile of a straight floor, two walls and a semicircular arc roof (a tunnel section of
width 2 r, wall height w): area 2 r w + pi r^2 / 2, roof length pi r; meshed at the field order k (curved to
order k), the area and the roof length converge at the geometric order (printed, observed orders fitted).

:func:`arc_prism` : the same outline extruded (along its plane's normal or obliquely): volume = area x the
extrusion length x (a . n), from the OCC solid and the curved mesh.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import ngsolve as ngs
import numpy as np

from ..geometry.assemble import build_geometry
from ..geometry.mesh import make_mesh
from ..geometry.shapes import cells
from ..run import run_scene
from ..scene.parse import scene_from_dict


def inclined_fault_scene(*, dim: int = 3, mode: str = "contact", dip: float = 50.0, strike: float = 30.0,
                         p: float = 1e6, E: float = 10e9, nu: float = 0.25, maxh: float = 0.3, fine: float = 0.17,
                         order: int = 1) -> dict:
    """The scene dict of :func:`inclined_fault_patch`: the unit cube (2D: square, plane strain) cut by the fault.
    ``mode`` 'contact' (frictionless; the hanging wall's contact side meshed at ``fine``, m) or 'glued': the cut
    through the centre, both parts kept; 'symmetry': the cut through the origin, the part below it removed and
    u_n = 0 on the cut face."""
    rock = {"youngs_modulus": E, "poisson_ratio": nu}
    names = ("west", "south", "east", "north") if dim == 2 else ("west", "south", "bottom", "east", "north", "top")
    sel = ("xmin", "ymin", "xmax", "ymax") if dim == 2 else ("xmin", "ymin", "zmin", "xmax", "ymax", "zmax")
    block = {"name": "rock", "shape": "rectangle" if dim == 2 else "box", "origin": [0.0] * dim,
             "size": [1.0] * dim, "boundaries": dict(zip(names, sel))}
    fixed, loaded = names[:dim], names[dim:]
    scene = {
        "scene": {"name": f"inclined_fault_{mode}", "dimension": "plane" if dim == 2 else "3d"},
        "physics": {"mechanics": "static"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [block],
        "cuts": [{"name": "fault", "point": [0.5] * dim, "dip": dip, "strike": strike, "blocks": ["rock"],
                  "parts": [["hanging_wall", "footwall"]]}],
        "materials": {"hanging_wall": rock, "footwall": rock},
        "mechanics": {"tolerance": 1e-12},
        "boundary_conditions": {**{s: {"symmetry": True} for s in fixed}, **{s: {"pressure": p} for s in loaded}},
        "output": {"vtk": False, "figures": False},
    }
    if mode == "contact":
        scene["mesh"]["boundary_maxh"] = {"fault__hanging_wall": fine}
        scene["interfaces"] = [{"name": "fault", "blocks": ["hanging_wall", "footwall"], "type": "contact",
                                "law": "frictionless"}]
    elif mode == "symmetry":
        scene["cuts"][0].update(point=[0.0] * dim, parts=[["rock", ""]])
        scene["materials"] = {"rock": rock}
        scene["boundary_conditions"]["fault"] = {"symmetry": True}
        if dim == 2:            # the part above a line through the origin and the square has no side on y = 0
            del scene["boundary_conditions"]["south"]
    return scene


def hydrostatic_strain(dim: int, E: float, nu: float, p: float) -> float:
    """The uniform strain c of the state sigma = -p I (u = c x): -p / (3 K) in 3D, -p / (2 (lambda + mu)) in
    plane strain (sigma_xx = sigma_yy = -p in the plane)."""
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    return -p / (3 * lam + 2 * mu) if dim == 3 else -p / (2 * (lam + mu))


def inclined_fault_patch(**kw) -> dict:
    """Run :func:`inclined_fault_scene` and compare with the hydrostatic state: {"u_error" (max nodal
    |u - u_exact| / max |u_exact|), "ndof", "normal" (the fault's unit normal from the mesh, upward)} and, for a
    contact, {"max_deviation" (max over the fully covered contact nodes of |lam_n - p| / p), "nodes",
    "imbalance_rel", "side_vertices" (vertices of the two contact sides: different counts, non-matching meshes),
    "matching_vertices" (vertices of the finer side that are also vertices of the other), "iterations"}."""
    scene = inclined_fault_scene(**kw)
    dim = 2 if scene["scene"]["dimension"] == "plane" else 3
    p = float(scene["boundary_conditions"]["east"]["pressure"])
    rock = next(iter(scene["materials"].values()))
    c = hydrostatic_strain(dim, rock["youngs_modulus"], rock["poisson_ratio"], p)
    result = run_scene(scene_from_dict(scene), None, progress=False)
    mech, mesh = result.mechanics, result.mesh
    u = mech.forms.displacement()
    pts = np.array([v.point for v in mesh.vertices])
    u_h = np.array([u(mesh(*q)) for q in pts]).reshape(len(pts), dim)
    out = {"u_error": float(np.max(np.abs(u_h - c * pts)) / np.max(np.abs(c * pts))), "ndof": int(mech.forms.X.ndof)}
    side = "fault__footwall" if mech.contacts else "fault"
    el = next(iter(mesh.Boundaries(side).Elements()))
    q = np.array([mesh[v].point for v in el.vertices])
    n = np.cross(q[1] - q[0], q[2] - q[0]) if dim == 3 else np.array([q[1][1] - q[0][1], q[0][0] - q[1][0]])
    out["normal"] = (n / np.linalg.norm(n) * np.sign(n[-1])).tolist()
    if mech.contacts:
        out.update(_contact_figures(result, p))
    return out


def _contact_figures(result, p: float) -> dict:
    """The contact pressures against p and the two contact sides' vertices of a fault patch run."""
    mech, mesh = result.mechanics, result.mesh
    devs, nodes = [], 0
    for spec, res in zip(mech.contacts, mech.contact_output.latest):
        keep = spec.op.coverage > 1 - 1e-6
        devs.append(float(np.max(np.abs(res["pressure"][keep] - p))) / p)
        nodes += int(keep.sum())
    pts = np.array([v.point for v in mesh.vertices])
    sides = [np.array(sorted({v.nr for el in mesh.Boundaries(name).Elements() for v in el.vertices}))
             for name in ("fault__hanging_wall", "fault__footwall")]
    fine, coarse = pts[sides[0]], pts[sides[1]]
    dist = np.min(np.linalg.norm(fine[:, None] - coarse[None], axis=2), axis=1)
    summ = result.summary["mechanics"]["contact"]
    return {"max_deviation": max(devs), "nodes": nodes, "imbalance_rel": summ["force_balance"]["imbalance_rel"],
            "side_vertices": [len(v) for v in sides], "matching_vertices": int(np.sum(dist < 1e-9)),
            "iterations": summ["iterations_per_solve"][-1]}


def write_two_boxes(path: Path) -> dict:
    """Write two touching boxes [0, 1] x [0, 1] x [0, 0.5] ('lower') and [0, 1] x [0, 1] x [0.5, 1.2] ('upper')
    with named faces to a STEP file by netgen.occ (numbers in m, labelled mm by its writer); returns their
    volumes by solid name, m^3."""
    from netgen import occ

    lower = occ.Box(occ.Pnt(0, 0, 0), occ.Pnt(1, 1, 0.5))
    upper = occ.Box(occ.Pnt(0, 0, 0.5), occ.Pnt(1, 1, 1.2))
    lower.solids.name, upper.solids.name = "lower", "upper"
    lower.faces.Min(occ.Z).name = "base"
    upper.faces.Max(occ.Z).name = "surface"
    lower.faces.Min(occ.X).name = "west_low"
    upper.faces.Min(occ.X).name = "west_up"
    occ.Compound([lower, upper]).WriteStep(str(path))
    return {"lower": float(lower.mass), "upper": float(upper.mass)}


def step_import_scene(file: str, *, length_unit: str = "m") -> dict:
    """A heat scene on the two boxes of :func:`write_two_boxes`, read by an ``import`` block: the solids become
    regions 'clay' and 'granite', the faces 'base' and 'surface' boundaries 'bottom' and 'top'; the two 'west'
    faces keep their names."""
    return {
        "scene": {"name": "step_round_trip", "dimension": "3d"},
        "physics": {"thermal": "steady"},
        "mesh": {"maxh": 0.4},
        "blocks": [{"name": "model", "shape": "import", "file": file, "length_unit": length_unit,
                    "solids": {"lower": "clay", "upper": "granite"},
                    "faces": {"base": "bottom", "surface": "top"}}],
        "interfaces": [{"name": "layering", "blocks": ["clay", "granite"]}],
        "materials": {"clay": {"conductivity": 1.5}, "granite": {"conductivity": 3.0}},
        "boundary_conditions": {"bottom": {"temperature": 10.0}, "top": {"temperature": 0.0}},
        "output": {"vtk": False, "figures": False},
    }


def step_round_trip() -> dict:
    """Write :func:`write_two_boxes` to a temporary STEP file, build and mesh :func:`step_import_scene` and run
    it: {"volumes" (written, by region), "occ_volumes" (of the geometry read back), "mesh_volumes", "regions",
    "boundaries", "volume_error" (max relative, OCC), "mesh_volume_error", "flux_error" (the mean vertical heat
    flux in the upper layer against the series resistance q = dT / (0.5/1.5 + 0.7/3), a check that the layers
    are glued)}."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "two_boxes.step"
        written = write_two_boxes(path)
        scene = scene_from_dict(step_import_scene(str(path)))
        geo = build_geometry(scene)
        mesh = make_mesh(geo, scene.mesh)
        result = run_scene(scene, None, progress=False, geometry=geo)
    volumes = {"clay": written["lower"], "granite": written["upper"]}
    occ_vol = {r: float(sum(c.mass for c in cells(geo.shape, 3) if c.name == r)) for r in geo.regions}
    mesh_vol = {r: float(ngs.Integrate(ngs.CF(1.0), mesh, definedon=mesh.Materials(r))) for r in geo.regions}
    T = result.forms.temperature()
    q = 10.0 / (0.5 / 1.5 + 0.7 / 3.0)          # the flux up through both layers in series, W/m^2
    flux = float(ngs.Integrate(-3.0 * ngs.grad(T)[2], result.mesh,
                               definedon=result.mesh.Materials("granite"))) / volumes["granite"]
    return {"volumes": volumes, "occ_volumes": occ_vol, "mesh_volumes": mesh_vol, "regions": list(geo.regions),
            "boundaries": sorted(geo.boundaries),
            "volume_error": max(abs(occ_vol[r] / volumes[r] - 1) for r in volumes),
            "mesh_volume_error": max(abs(mesh_vol[r] / volumes[r] - 1) for r in volumes),
            "flux_error": abs(flux / q - 1)}


def tunnel_outline(r: float = 1.0, w: float = 0.6) -> dict:
    """The block keys of a tunnel section: floor [-r, r] at y = 0, walls to y = w, a semicircular arc roof of
    radius r through (0, w + r); segment names 'floor', 'right_wall', 'roof', 'left_wall'."""
    return {"start": [-r, 0.0], "segments": [
        {"line": [r, 0.0], "name": "floor"}, {"line": [r, w], "name": "right_wall"},
        {"arc": [[0.0, w + r], [-r, w]], "name": "roof"}, {"line": [-r, 0.0], "name": "left_wall"}]}


def tunnel_area(r: float = 1.0, w: float = 0.6) -> float:
    """Area of :func:`tunnel_outline`, m^2."""
    return 2 * r * w + math.pi * r * r / 2


def arc_profile_scene(*, r: float = 1.0, w: float = 0.6, maxh: float = 0.5, order: int = 2) -> dict:
    """A steady heat scene on :func:`tunnel_outline` (T = 1 on the roof, 0 on the floor)."""
    return {
        "scene": {"name": "arc_profile"},
        "physics": {"thermal": "steady"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [{"name": "rock", "shape": "profile", **tunnel_outline(r, w)}],
        "materials": {"rock": {"conductivity": 2.0}},
        "boundary_conditions": {"roof": {"temperature": 1.0}, "floor": {"temperature": 0.0}},
        "output": {"vtk": False, "figures": False},
    }


def observed_orders(h: list[float], err: list[float]) -> list[float]:
    """log(e_k / e_k+1) / log(h_k / h_k+1) between consecutive meshes."""
    return [math.log(err[k] / err[k + 1]) / math.log(h[k] / h[k + 1]) for k in range(len(h) - 1)]


def arc_profile(*, order: int = 2, sizes: tuple = (0.8, 0.4, 0.2, 0.1), r: float = 1.0, w: float = 0.6) -> dict:
    """The meshed area and roof length of :func:`arc_profile_scene` against the closed forms per mesh size:
    {"h", "area_error", "length_error" (relative), "area_orders", "length_orders", "occ_area_error" (the OCC
    face's area against the closed form), "dofs" (of P``order``)}."""
    exact_area, exact_len = tunnel_area(r, w), math.pi * r
    out = {"h": list(sizes), "area_error": [], "length_error": [], "dofs": []}
    for h in sizes:
        scene = scene_from_dict(arc_profile_scene(r=r, w=w, maxh=h, order=order))
        geo = build_geometry(scene)
        mesh = make_mesh(geo, scene.mesh)
        area = ngs.Integrate(ngs.CF(1.0), mesh)
        length = ngs.Integrate(ngs.CF(1.0), mesh, definedon=mesh.Boundaries("roof"))
        out["dofs"].append(ngs.H1(mesh, order=order).ndof)
        out["area_error"].append(abs(area / exact_area - 1))
        out["length_error"].append(abs(length / exact_len - 1))
        out["occ_area_error"] = abs(float(sum(c.mass for c in cells(geo.shape, 2))) / exact_area - 1)
    out["area_orders"] = observed_orders(out["h"], out["area_error"])
    out["length_orders"] = observed_orders(out["h"], out["length_error"])
    return out


def arc_prism_scene(*, length: float = 2.0, axis: list | None = None, maxh: float = 0.5, order: int = 2,
                    r: float = 1.0, w: float = 0.6) -> dict:
    """A steady heat scene on :func:`tunnel_outline` drawn in the x-z plane (u = x, v = z) and extruded along y
    (or ``axis``) by ``length``: a tunnel with an arc roof; end faces 'portal' (y = 0) and 'face' (the far end)."""
    block = {"name": "rock", "shape": "prism", "origin": [0.0, 0.0, 0.0], "directions": [[1, 0, 0], [0, 0, 1]],
             "axis": axis or [0, 1, 0], "length": length, "boundaries": {"portal": "bottom", "face": "top"},
             **tunnel_outline(r, w)}
    return {
        "scene": {"name": "arc_prism", "dimension": "3d"},
        "physics": {"thermal": "steady"},
        "mesh": {"maxh": maxh, "order": order},
        "blocks": [block],
        "materials": {"rock": {"conductivity": 2.0}},
        "boundary_conditions": {"roof": {"temperature": 1.0}, "floor": {"temperature": 0.0}},
        "output": {"vtk": False, "figures": False},
    }


def arc_prism(*, length: float = 2.0, axis: list | None = None, sizes: tuple = (0.8, 0.4, 0.2), order: int = 2,
              r: float = 1.0, w: float = 0.6) -> dict:
    """The volume of :func:`arc_prism_scene` against area x length x |a . n| (n = -y, the x-z plane's normal):
    {"exact", "occ_error" (the OCC solid), "h", "mesh_error" (relative, per size), "orders", "boundaries",
    "dofs" (of P``order``)}."""
    a = np.array(axis or [0, 1, 0], float)
    exact = tunnel_area(r, w) * length * abs(a[1]) / np.linalg.norm(a)
    out = {"exact": exact, "h": list(sizes), "mesh_error": [], "dofs": []}
    for h in sizes:
        scene = scene_from_dict(arc_prism_scene(length=length, axis=axis, maxh=h, order=order, r=r, w=w))
        geo = build_geometry(scene)
        out["occ_error"] = abs(float(sum(c.mass for c in cells(geo.shape, 3))) / exact - 1)
        out["boundaries"] = sorted(geo.boundaries)
        mesh = make_mesh(geo, scene.mesh)
        out["mesh_error"].append(abs(ngs.Integrate(ngs.CF(1.0), mesh) / exact - 1))
        out["dofs"].append(ngs.H1(mesh, order=order).ndof)
    out["orders"] = observed_orders(out["h"], out["mesh_error"])
    return out
