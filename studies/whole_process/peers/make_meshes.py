"""Write the Kratos twins' meshes (.mdpa files) from the meshes ngs-geomech makes of the same scenes.

The twins solve on the very triangles our runs solve on: each scene is meshed by ngs-geomech's own geometry
and mesher (netgen), and its vertices, triangles and boundary segments are written in Kratos's .mdpa format.

:file:`kratos_two_blocks/two_blocks.mdpa` (scene :file:`../two_blocks.toml`, maxh 0.08 m): the two blocks
keep their own nodes on the joint (netgen meshes them as two bodies with matching nodes at y = 0.5 m).
Sub-model parts: ``Lower`` and ``Upper`` (elements, properties 1 and 2), ``Base`` (nodes, u = 0),
``LeftSide`` (nodes, u_x = 0), ``Top`` (line-load conditions, 5 MPa down), ``Contact_Part`` (both joint
sides: nodes and line conditions), ``Slave_Part`` (the upper block's joint side: the mortar slave).

:file:`kratos_heat_block/heat_block.mdpa` (scene :file:`../heat_block.toml`, maxh 0.065 m): sub-model parts
``Rock`` (elements, properties 1), ``Hot`` and ``Cold`` (nodes of x = 0 and x = 1 m).

Run once with the ngs-geomech environment (the mesh file is an input stored beside the twin):
``.venv/bin/python studies/whole_process/peers/make_meshes.py``.
"""

from __future__ import annotations

from pathlib import Path

import ngsolve as ngs

from ngs_geomech.geometry.assemble import build_geometry
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.scene.parse import load_scene

HERE = Path(__file__).resolve().parent
SCENE = HERE.parent / "two_blocks.toml"
OUT = HERE / "kratos_two_blocks" / "two_blocks.mdpa"
HEAT_SCENE = HERE.parent / "heat_block.toml"
HEAT_OUT = HERE / "kratos_heat_block" / "heat_block.mdpa"


def _mesh_tables(mesh):
    """Vertices (id -> (x, y)), triangles per region, segments per boundary name; ids from 1."""
    nodes = {v.nr + 1: tuple(v.point) for v in mesh.vertices}
    tri = {name: [] for name in mesh.GetMaterials()}
    for el in mesh.Elements(ngs.VOL):
        tri[el.mat].append([v.nr + 1 for v in el.vertices])
    seg = {}
    for el in mesh.Elements(ngs.BND):
        seg.setdefault(el.mat, []).append([v.nr + 1 for v in el.vertices])
    return nodes, tri, seg


def _counter_clockwise(nodes, t):
    (x1, y1), (x2, y2), (x3, y3) = (nodes[i][:2] for i in t)
    return t if (x2 - x1) * (y3 - y1) - (x3 - x1) * (y2 - y1) > 0 else [t[0], t[2], t[1]]


def _outward(nodes, seg, centre):
    """Order a boundary segment so that its right-hand normal (Kratos's line conditions) points away from the
    body whose centre is ``centre``."""
    (x1, y1), (x2, y2) = (nodes[i][:2] for i in seg)
    nx, ny = y2 - y1, -(x2 - x1)
    mx, my = (x1 + x2) / 2 - centre[0], (y1 + y2) / 2 - centre[1]
    return seg if nx * mx + ny * my > 0 else seg[::-1]


def _submodelpart(name, node_ids, elem_ids=(), cond_ids=()):
    lines = [f"Begin SubModelPart {name}", "    Begin SubModelPartNodes"]
    lines += [f"        {i}" for i in sorted(set(node_ids))]
    lines += ["    End SubModelPartNodes", "    Begin SubModelPartElements"]
    lines += [f"        {i}" for i in elem_ids]
    lines += ["    End SubModelPartElements", "    Begin SubModelPartConditions"]
    lines += [f"        {i}" for i in cond_ids]
    lines += ["    End SubModelPartConditions", "End SubModelPart", ""]
    return lines


def write_mdpa(mesh, path: Path) -> dict:
    nodes, tri, seg = _mesh_tables(mesh)
    centres = {"lower": (0.5, 0.25), "upper": (0.5, 0.7)}
    # properties 1 and 2 are declared empty (the reader needs them); StructuralMaterials.json fills them
    out = ["Begin ModelPartData", "End ModelPartData", "", "Begin Properties 0", "End Properties",
           "Begin Properties 1", "End Properties", "Begin Properties 2", "End Properties", "", "Begin Nodes"]
    out += [f"    {i} {x:.16g} {y:.16g} 0.0" for i, (x, y, *_) in nodes.items()]
    out += ["End Nodes", ""]
    elem_ids, eid = {}, 1
    for prop, region in ((1, "lower"), (2, "upper")):
        out.append("Begin Elements SmallDisplacementElement2D3N")
        elem_ids[region] = []
        for t in tri[region]:
            out.append(f"    {eid} {prop} " + " ".join(map(str, _counter_clockwise(nodes, t))))
            elem_ids[region].append(eid)
            eid += 1
        out += ["End Elements", ""]
    cond_ids, cid = {}, 1
    for kind, prop, name, body in (("LineLoadCondition2D2N", 2, "top", "upper"),
                                   ("LineCondition2D2N", 1, "joint__lower", "lower"),
                                   ("LineCondition2D2N", 2, "joint__upper", "upper")):
        out.append(f"Begin Conditions {kind}")
        cond_ids[name] = []
        for s in seg[name]:
            out.append(f"    {cid} {prop} " + " ".join(map(str, _outward(nodes, s, centres[body]))))
            cond_ids[name].append(cid)
            cid += 1
        out += ["End Conditions", ""]
    seg_nodes = {name: [i for s in segs for i in s] for name, segs in seg.items()}
    all_lower = {i for t in tri["lower"] for i in t}
    all_upper = {i for t in tri["upper"] for i in t}
    out += _submodelpart("Lower", all_lower, elem_ids["lower"])
    out += _submodelpart("Upper", all_upper, elem_ids["upper"])
    out += _submodelpart("Base", seg_nodes["base"])
    out += _submodelpart("LeftSide", seg_nodes["left_side"])
    out += _submodelpart("Top", seg_nodes["top"], (), cond_ids["top"])
    out += _submodelpart("Contact_Part", seg_nodes["joint__lower"] + seg_nodes["joint__upper"], (),
                         cond_ids["joint__lower"] + cond_ids["joint__upper"])
    out += _submodelpart("Slave_Part", seg_nodes["joint__upper"], (), cond_ids["joint__upper"])
    path.write_text("\n".join(out) + "\n")
    return {"nodes": len(nodes), "triangles": sum(map(len, tri.values())), "dofs": 2 * len(nodes)}


def write_heat_mdpa(mesh, path: Path) -> dict:
    nodes, tri, seg = _mesh_tables(mesh)
    out = ["Begin ModelPartData", "End ModelPartData", "", "Begin Properties 0", "End Properties",
           "Begin Properties 1", "End Properties", "", "Begin Nodes"]
    out += [f"    {i} {x:.16g} {y:.16g} 0.0" for i, (x, y, *_) in nodes.items()]
    out += ["End Nodes", "", "Begin Elements Element2D3N"]
    out += [f"    {e} 1 " + " ".join(map(str, _counter_clockwise(nodes, t)))
            for e, t in enumerate(tri["rock"], start=1)]
    out += ["End Elements", ""]
    out += _submodelpart("Rock", nodes, range(1, len(tri["rock"]) + 1))
    for name in ("hot", "cold"):
        out += _submodelpart(name.capitalize(), [i for s in seg[name] for i in s])
    path.write_text("\n".join(out) + "\n")
    return {"nodes": len(nodes), "triangles": len(tri["rock"]), "dofs": len(nodes)}


def main() -> None:
    for scene_file, out, writer in ((SCENE, OUT, write_mdpa), (HEAT_SCENE, HEAT_OUT, write_heat_mdpa)):
        scene = load_scene(scene_file)
        mesh = make_mesh(build_geometry(scene), scene.mesh)
        out.parent.mkdir(exist_ok=True)
        print(out, writer(mesh, out))


if __name__ == "__main__":
    main()
