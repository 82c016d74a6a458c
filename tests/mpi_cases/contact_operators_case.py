"""The contact operators (:func:`ngs_geomech.contact.forms3d.contact_operator_3d`,
:func:`ngs_geomech.contact.forms.contact_operator_2d`) of small scenes with non-matching meshes, on a netgen
distributed mesh or serially (run by tests/test_mpi_contact_operators.py):

    mpiexec -n N python tests/mpi_cases/contact_operators_case.py OUT.json     (N >= 3: distributed)
    python tests/mpi_cases/contact_operators_case.py OUT.json                  (serial)

Per case and contact, rank 0 writes the multiplier nodes' coordinates, g0, weight, length, coverage and Bn u, Bt u
(Bt2 u in 3D) for the smooth displacement fields of :func:`fields` (as dof vectors, :func:`dof_values`, gathered
to the global numbering of :class:`ngs_geomech.parallel.GlobalDofs` on a distributed mesh), and whether every rank holds
the same operator (a hash of all its arrays, compared over the ranks)."""

from __future__ import annotations

import gc
import hashlib
import json
import sys

import netgen.meshing as ngm
import ngsolve as ngs
import numpy as np
from netgen.occ import Box, Compound, OCCGeometry, Pnt, Rectangle, WorkPlane, X, Y, Z

from ngs_geomech import parallel
from ngs_geomech.contact.forms import contact_operator_2d
from ngs_geomech.contact.forms3d import contact_operator_3d


def blocks_3d() -> OCCGeometry:
    """A punch [0.2, 0.8]^2 x [0, 0.3] on a block [0, 1]^2 x [-0.5, 0], meshed independently (non-matching)."""
    lower = Box(Pnt(0, 0, -0.5), Pnt(1, 1, 0))
    upper = Box(Pnt(0.2, 0.2, 0), Pnt(0.8, 0.8, 0.3))
    lower.faces.Min(Z).name = "base"
    lower.faces.Max(Z).name = "block_top"
    upper.faces.Min(Z).name = "punch_bottom"
    upper.faces.Max(X).name = "punch_side"
    lower.solids.name, upper.solids.name = "block", "punch"
    lower.solids.maxh, upper.solids.maxh = 0.3, 0.2
    return OCCGeometry(Compound([lower, upper]))


def blocks_2d() -> OCCGeometry:
    """Two blocks [0, 1] x [0, 0.5] and [0.1, 0.9] x [0.5, 1] meshed independently."""
    lower = Rectangle(1, 0.5).Face()
    upper = Rectangle(0.8, 0.5).Face().Move((0.1, 0.5, 0))
    lower.name, upper.name = "lower", "upper"
    lower.edges.Min(Y).name = "bottom"
    lower.edges.Max(Y).name = "lower_top"
    upper.edges.Min(Y).name = "upper_bottom"
    lower.maxh, upper.maxh = 0.1, 0.07
    return OCCGeometry(Compound([lower, upper]), dim=2)


def ball_2d() -> OCCGeometry:
    """A disc of radius 0.3 touching a block [0, 1] x [0, 0.3] from above: a curved contact side."""
    block = Rectangle(1, 0.3).Face()
    ball = WorkPlane().Circle(0.5, 0.6, 0.3).Face()
    block.name, ball.name = "block", "ball"
    block.edges.Max(Y).name = "block_top"
    ball.edges.name = "ball_rim"
    block.maxh, ball.maxh = 0.08, 0.06
    return OCCGeometry(Compound([block, ball]), dim=2)


CASES = {
    "ball_p2": (ball_2d, 2, [("ball", "ball_rim", "block_top", None),
                             ("rim", "ball_rim", None, ((0, 0.295), (0, 1)))]),
    "3d_p1": (blocks_3d, 1, [("punch", "punch_bottom", "block_top", None),
                             ("base", "base", None, ((0, 0, -0.501), (0, 0, 1)))]),
    "3d_p2": (blocks_3d, 2, [("punch", "punch_bottom", "block_top", None),
                             ("base", "base", None, ((0, 0, -0.501), (0, 0, 1)))]),
    "2d_p1": (blocks_2d, 1, [("upper", "upper_bottom", "lower_top", None),
                             ("bottom", "bottom", None, ((0, -0.001), (0, 1)))]),
    "2d_p2": (blocks_2d, 2, [("upper", "upper_bottom", "lower_top", None),
                             ("bottom", "bottom", None, ((0, -0.001), (0, 1)))]),
}
"""name: (geometry, order, [(contact name, side, opposite or None, foundation (point, normal) or None)]). Only the
first mesh is curved (the disc's; the blocks are flat): with 4 workers, ``Mesh.Curve`` on a second distributed mesh
in the same processes hung (netgen 6.2)."""


def make_mesh(geometry, order: int, comm):
    """The mesh of ``geometry()``, distributed over ``comm`` (None: serial), curved to ``order`` if it has curved
    boundaries (:data:`CURVED`)."""
    geo = geometry()
    if comm is None:
        mesh = ngs.Mesh(geo.GenerateMesh(maxh=0.3))
    elif comm.rank == 0:
        mesh = ngs.Mesh(geo.GenerateMesh(maxh=0.3).Distribute(comm))
    else:
        mesh = ngs.Mesh(ngm.Mesh.Receive(comm))
    if order > 1 and geometry in CURVED:
        mesh.ngmesh.SetGeometry(geo)
        mesh.Curve(order)
    return mesh


CURVED = (ball_2d,)


def fields(dim: int) -> list:
    """Three smooth displacement fields (m): functions of the points p (n, dim) with values (n, dim)."""
    def linear(p):
        return 1e-3 + p @ np.arange(1.0, dim * dim + 1).reshape(dim, dim) / dim ** 2 - 0.3 * p[:, ::-1]

    def quadratic(p):
        return p * p[:, :1] - 0.5 * p[:, ::-1] ** 2 + 0.1

    def mixed(p):
        return np.sin(2 * p) + p[:, ::-1] * p.sum(axis=1)[:, None]
    return [linear, quadratic, mixed]


def dof_values(mesh, V, f) -> np.ndarray:
    """This part's (cumulated) dof vector of the VectorH1 space ``V`` (order <= 2) whose vertex dofs are f at the
    vertices and whose edge dofs are f at the edges' midpoints, times :data:`SIDE_FACTOR` of the body: a function
    of the space that a serial and a distributed mesh build alike (``GridFunction.Set`` on a distributed mesh left
    wrong values in some copies of shared dofs on one rank of 4)."""
    comp = V.components[0]
    pts = np.asarray(mesh.ngmesh.Coordinates(), dtype=float)[:mesh.nv, :mesh.dim]
    factor = np.ones(mesh.nv)
    for el in mesh.Elements(ngs.VOL):
        factor[[v.nr for v in el.vertices]] = SIDE_FACTOR.get(el.mat, 1.0)
    vals = np.zeros((comp.ndof, mesh.dim))
    vals[:mesh.nv] = factor[:, None] * f(pts)          # vertex v has dof v
    if comp.globalorder > 1:
        ends = np.array([[v.nr for v in e.vertices] for e in mesh.edges], dtype=int).reshape(-1, 2)
        dofs = [list(comp.GetDofNrs(ngs.NodeId(ngs.EDGE, k))) for k in range(len(ends))]
        vals[np.array(dofs, dtype=int).ravel()] = factor[ends[:, 0], None] * f(pts[ends].mean(axis=1))
    return vals.T.ravel()


SIDE_FACTOR = {"punch": -0.5, "upper": -0.5, "ball": -0.5}
"""The factor of the displacement fields on the contact sides' bodies (1 on the others)."""


def fingerprint(op) -> str:
    """A hash of every array of the operator ``op``."""
    h = hashlib.sha256()
    for arr in (op.nodes, op.coords, op.g0, op.weight, op.length, op.coverage):
        h.update(np.ascontiguousarray(arr).tobytes())
    for B in (op.Bn, op.Bt, op.Bt2):
        if B is not None:
            B = B.tocsr()
            B.sort_indices()
            for arr in (B.data, B.indices, B.indptr, np.array(B.shape)):
                h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def operators(mesh, order: int, contacts: list) -> list[dict]:
    """Per contact of ``contacts`` (:data:`CASES`): its operator's figures (module docstring)."""
    V = ngs.VectorH1(mesh, order=order)
    numbering = parallel.GlobalDofs(V)
    us = [numbering.gather(dof_values(mesh, V, f)) for f in fields(mesh.dim)]
    out = []
    for name, side, opposite, obstacle in contacts:
        if mesh.dim == 3:
            op = contact_operator_3d(mesh, V, name, side, opposite, obstacle=obstacle)
        else:
            op = contact_operator_2d(mesh, V, name, side, opposite, axisymmetric=False, obstacle=obstacle)
        rows = [B for B in (op.Bn, op.Bt, op.Bt2) if B is not None]
        prints = parallel.allgather(mesh, fingerprint(op))
        scale = [[(abs(B) @ np.abs(u)).tolist() for B in rows] for u in us]     # the size of the terms of B u
        out.append({"name": name, "coords": op.coords.tolist(), "g0": op.g0.tolist(), "weight": op.weight.tolist(),
                    "B_u_scale": scale,
                    "length": op.length.tolist(), "coverage": op.coverage.tolist(),
                    "B_u": [[(B @ u).tolist() for B in rows] for u in us], "columns": int(op.Bn.shape[1]),
                    "same_on_all_ranks": len(set(prints)) == 1, "search_distance": op.search_distance,
                    "elements_per_rank": parallel.allgather(mesh, mesh.ne)})
    return out


STACK = {"scene": {"name": "stack", "dimension": "3d"}, "physics": {"mechanics": "static"},
         "mesh": {"maxh": 0.35, "order": 2},
         "blocks": [{"name": "lower", "shape": "box", "origin": [0, 0, 0], "size": [1.0, 0.8, 0.5],
                     "boundaries": {"base": "zmin"}},
                    {"name": "upper", "shape": "box", "origin": [0, 0, 0.5], "size": [1.0, 0.8, 0.5], "maxh": 0.25}],
         "materials": {b: {"density": 2500.0, "youngs_modulus": 10e9, "poisson_ratio": 0.25}
                       for b in ("lower", "upper")},
         "interfaces": [{"name": "joint", "blocks": ["upper", "lower"], "type": "contact", "law": "tresca",
                         "slip_bound": "1e5 * (1 + x)"}],
         "mechanics": {"gravity": [0.0, 0.0, -9.81]},
         "boundary_conditions": {"base": {"foundation": {"point": [0, 0, -0.001], "normal": [0, 0, 1]}}}}
"""Box 'upper' on box 'lower' (non-matching meshes, P2), the lower one on a rigid foundation: the scene of
:func:`specs`."""


def specs(comm) -> list[dict]:
    """The contact specs (:func:`ngs_geomech.contact.problem.contact_specs`) of :data:`STACK`: per contact its kind,
    blocks, law, the cells as corner coordinates and the side's dofs (their number)."""
    from ngs_geomech.contact.problem import contact_specs, side_dofs
    from ngs_geomech.geometry.assemble import build_geometry
    from ngs_geomech.geometry.mesh import make_mesh as scene_mesh
    from ngs_geomech.scene.parse import scene_from_dict

    scene = scene_from_dict(STACK)
    geo = build_geometry(scene)
    mesh = scene_mesh(geo, scene.mesh, comm=comm)
    V = ngs.VectorH1(mesh, order=scene.mesh.order)
    numbering = parallel.GlobalDofs(V) if comm is not None else None
    out = []
    for spec in contact_specs(scene, geo, mesh, V):
        op = spec.op
        out.append({"name": spec.name, "kind": spec.kind, "blocks": [list(b) if isinstance(b, tuple) else b
                                                                     for b in spec.blocks],
                    "law": spec.law.kind, "bound": np.asarray(spec.law.slip_bound, dtype=float).tolist(),
                    "coords": op.coords.tolist(), "weight": op.weight.tolist(), "g0": op.g0.tolist(),
                    "cells": op.coords[spec.cells].tolist(), "columns": int(op.Bn.shape[1]),
                    "side_dofs": len(side_dofs(mesh, V, op.side, numbering)),
                    "same_on_all_ranks": len(set(parallel.allgather(mesh, fingerprint(op) + str(spec.cells)))) == 1})
    return out


def run(comm) -> dict:
    """Every case of :data:`CASES` on meshes distributed over ``comm`` (None: serial)."""
    ngs.SetNumThreads(1)
    out = {}
    for case, (geometry, order, contacts) in CASES.items():
        mesh = make_mesh(geometry, order, comm)
        out[case] = operators(mesh, order, contacts)
        # the last mesh's spaces go on every rank at the same point: freeing distributed objects is collective
        del mesh
        gc.collect()
    out["specs"] = specs(comm)
    return out


def main() -> None:
    comm = parallel.world()
    result = run(comm)
    if comm is None or comm.rank == 0:
        with open(sys.argv[1], "w") as fh:
            json.dump(result, fh)


if __name__ == "__main__":
    main()
