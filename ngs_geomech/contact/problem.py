"""From a scene to the contact operators and laws of its interfaces and foundations, and from a contact
solution to the interface quantities of the output (pressure, traction, gap, slip, status, resultants).

Sign conventions (see :mod:`ngs_geomech.contact.forms`): on the contact side S (an interface's master
block side, or a boundary with a foundation) p = lam_n >= 0 is the normal pressure (compression, Pa), q =
lam_t the tangential traction along t = (-n_y, n_x) (n the outward normal of S's body); the force on S's
body is -p n - q t per unit area. The gap (m) and slip (m) are nodal: weighted values over the nodal
weights. Forces are N per m of depth (plane), N per radian (axisymmetric, weight r) or N (3D).

3D scenes (:func:`ngs_geomech.contact.forms3d.contact_operator_3d`): the tangential traction is a vector
q = q1 t1 + q2 t2 (t1 the projection of e_x onto the side, e_y where the side faces x; t2 = n x t1; the
solver's lam_t has the shape (m, 2)); the output ``traction`` is its magnitude |q| >= 0, with the components
``traction_t1``, ``traction_t2`` for friction laws; the slip is the length of the tangential relative
displacement (both tangential directions), >= 0. The output cells are the side's boundary triangles (node
index triples, ordered so that their right-hand normal points out of S's body) instead of segments.
"""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import Problem, SceneError
from ..geometry.assemble import GeometryModel
from ..linalg.iterative import choose_solver
from ..scene import expressions
from ..scene.model import ContactMechanics, Scene
from .choices import AUTO_DOFS, MethodChoice, contact_methods
from .forms import ContactOperator, contact_operator_2d
from .forms3d import contact_operator_3d
from .laws import ContactLaw, ContactOptions, slip_bound

STATUS_OPEN, STATUS_STICK, STATUS_SLIP, STATUS_PRESCRIBED = 0, 1, 2, 3
"""Nodal contact states of the output; 'prescribed': every displacement its constraint involves is given
(:func:`supported_nodes`), so the support, not the contact, carries the force and the multiplier is undetermined."""


@dataclass
class ContactSpec:
    """One mechanical contact of a scene: its operator, law, scene settings and the blocks involved
    (``blocks``: the side's block, then the opposite block or None for a foundation)."""

    name: str
    kind: str                       # "interface" | "foundation"
    op: ContactOperator
    law: ContactLaw
    settings: ContactMechanics
    blocks: tuple
    cells: np.ndarray               # S's boundary cells as node indices (output): (k, 2) segments, 3D (k, 3) triangles


def nodal_values(value, coords: np.ndarray):
    """A number as a float, an expression of x, y (z), r as its values at the nodes ``coords`` (m x dim, m)."""
    if not isinstance(value, str):
        return float(value)
    names = "xyz"
    return np.array([expressions.evaluate(value, **{names[k]: float(p[k]) for k in range(len(p))}, r=float(p[0]))
                     for p in coords])


def contact_law(c: ContactMechanics, coords: np.ndarray, penalty: bool) -> ContactLaw:
    """The solver's law from the scene keys; an expression slip bound or friction coefficient is evaluated at the
    nodes (m x dim: one value per node); ``penalty``: the contact keeps its penalty rows
    (:func:`.choices.contact_methods`)."""
    g = nodal_values(c.slip_bound, coords) if c.law == "tresca" else None
    friction = nodal_values(c.friction, coords) if c.law == "coulomb" and c.friction is not None else 0.0
    kind = "frictionless" if c.law == "coulomb" and np.all(np.asarray(friction) == 0) else c.law   # F_c = 0
    return ContactLaw(kind, slip_bound=g, friction=friction, augmentation=c.augmentation, penalty=penalty)


def method_choice(settings: list[ContactMechanics], names: list[str], dim: int, mechanics: str) -> MethodChoice:
    """The contact methods of a scene's contacts (their keys ``settings``): :func:`.choices.contact_methods`."""
    return contact_methods([c.method for c in settings], names, dim=dim, mechanics=mechanics)


def contact_options(scene: Scene, specs: list[ContactSpec], forms, *, dynamic: bool = False) -> ContactOptions:
    """The solver options of a scene's contacts (the one reading of its contact keys; the solver itself comes from
    :func:`.factory.build_contact_solver`). The solver's method is that of :func:`.choices.contact_methods`: Uzawa's
    solver with the contacts' ``uzawa_step`` and ``mechanics.uzawa_max_steps``, or the semi-smooth Newton (penalty)
    solver, whose Newton steps in static mechanics follow ``solver.linear`` (GMRES above
    :data:`.choices.AUTO_DOFS` with 'auto'; a direct solve is condensed onto the contact surface where that applies;
    the mixed formulation, X not V, stays direct) and in dynamic and viscous mechanics (``dynamic``) take the
    default linear algebra."""
    mechanics = scene.physics.mechanics if dynamic else "static"
    method = method_choice([c.settings for c in specs], [c.name for c in specs], forms.mesh.dim, mechanics).solver
    if dynamic:
        return ContactOptions(method=method)
    if method == "uzawa":
        keys = [f"interfaces.{c.name}" if c.kind == "interface" else f"boundary_conditions.{c.name}.foundation"
                for c in specs]
        return ContactOptions(method="uzawa", uzawa_step=[c.settings.uzawa_step for c in specs],
                              uzawa_max_steps=scene.mechanics.uzawa_max_steps,
                              uzawa_settings=(" / ".join(f"{k}.uzawa_step" for k in keys), "mechanics.uzawa_max_steps"))
    sv = scene.solver
    spd = forms.X is forms.V
    linear = choose_solver(sv.linear, forms.X.ndof, forms.mesh.dim, spd=spd, auto_dofs=AUTO_DOFS,
                           distributed=forms.mesh.comm.size > 1)
    if linear == "direct" and spd:
        linear = "auto"        # a direct solve: condensed onto the contact surface where it applies
    return ContactOptions(method=method, linear=linear, linear_tol=sv.tolerance, linear_maxit=sv.max_iterations)


def _cells(mesh, side: str, op: ContactOperator, numbering=None) -> np.ndarray:
    """The boundary elements of ``side`` as indices into op's nodes: 2D (k, 2) segments; 3D (k, 3) triangles
    whose right-hand normal points out of the body (away from the volume element behind the face, which lies on
    the face's part of a distributed mesh). On a distributed mesh (``numbering`` its
    :class:`.parallel.GlobalDofs` of V) every part's cells, gathered in rank order onto every rank."""
    index = {int(v): j for j, v in enumerate(op.nodes)}
    els = list(mesh.Boundaries(side).Elements())
    if mesh.dim == 2:
        cells = np.array([[el.vertices[0].nr, el.vertices[1].nr] for el in els], dtype=int).reshape(-1, 2)
    else:
        pts = np.asarray(mesh.ngmesh.Coordinates(), dtype=float)[:mesh.nv]
        tris = []
        for el in els:
            vs = [v.nr for v in el.vertices]
            p = pts[vs]
            inner = pts[[v.nr for v in mesh[mesh[el.faces[0]].elements[0]].vertices]].mean(axis=0)
            if float(np.dot(np.cross(p[1] - p[0], p[2] - p[0]), p.mean(axis=0) - inner)) < 0:
                vs = [vs[0], vs[2], vs[1]]
            tris.append(vs)
        cells = np.array(tris, dtype=int).reshape(-1, 3)
    if numbering is not None:       # global vertex numbers (a vertex's scalar dof), each cell once
        cells = parallel.concat(mesh, numbering.scalar[cells].reshape(cells.shape))
        cells = cells[np.sort(np.unique(np.sort(cells, axis=1), axis=0, return_index=True)[1])]
    return np.array([[index[int(v)] for v in c] for c in cells], dtype=int).reshape(-1, mesh.dim)


def contact_specs(scene: Scene, geo: GeometryModel, mesh, V) -> list[ContactSpec]:
    """The mechanical contacts of a validated scene on its mesh (``V`` the displacement space): 2D (plane,
    axisymmetric) operators of :func:`contact_operator_2d`, 3D ones of :func:`contact_operator_3d`. On a
    distributed mesh (collective) every rank gets the same specs of the whole mesh: operators in the global
    numbering of :class:`.parallel.GlobalDofs` ``(V)``, cells and blocks gathered from the parts."""
    axi = scene.scene.dimension == "axisymmetric"

    def operator(name, side, opposite, obstacle, search_distance):
        if mesh.dim == 3:
            return contact_operator_3d(mesh, V, name, side, opposite, obstacle=obstacle,
                                       search_distance=search_distance)
        return contact_operator_2d(mesh, V, name, side, opposite, axisymmetric=axi, obstacle=obstacle,
                                   search_distance=search_distance)

    numbering = parallel.GlobalDofs(V) if parallel.distributed(mesh) else None
    byname = {i.name: i for i in scene.interfaces}
    foundations = {n: bc.foundation for n, bc in scene.boundary_conditions.items() if bc.foundation is not None}
    settings = [byname[name] for name in geo.contacts] + list(foundations.values())
    penalty = iter(method_choice(settings, [*geo.contacts, *foundations], mesh.dim, scene.physics.mechanics).penalty)
    out = []
    for name, cs in geo.contacts.items():
        itf = byname[name]
        op = operator(name, cs.master, cs.minion, None, itf.search_distance)
        out.append(ContactSpec(name, "interface", op, contact_law(itf, op.coords, next(penalty)), itf,
                               (cs.master_block, cs.minion_block), _cells(mesh, cs.master, op, numbering)))
    for bname, fd in foundations.items():
        op = operator(bname, bname, None, (tuple(fd.point), tuple(fd.normal)), fd.search_distance)
        blocks = sorted(set().union(*parallel.allgather(mesh, {el.mat for el in _volume_neighbours(mesh, bname)})))
        out.append(ContactSpec(bname, "foundation", op, contact_law(fd, op.coords, next(penalty)), fd,
                               (tuple(blocks), None), _cells(mesh, bname, op, numbering)))
    return out


def contact_warnings(specs: list[ContactSpec], geo: GeometryModel) -> list[str]:
    """Contacts that can never close: no ray from the contact side meets the other side (or the foundation)
    within the search distance, e.g. an initial gap wider than the default search distance (a quarter of the
    side's extent)."""
    out = []
    for s in specs:
        if s.op.size and float(np.max(s.op.coverage, initial=0.0)) <= 1e-9:
            cs = geo.contacts.get(s.name) if s.kind == "interface" else None
            what = f"interfaces ({s.name})" if s.kind == "interface" else f"boundary_conditions.{s.name}.foundation"
            other = f"side {s.op.opposite!r}" if s.op.opposite else "the foundation"
            gap = f" (the sides are {cs.gap:.4g} m apart)" if cs is not None and cs.initial_gap else ""
            out.append(f"{what}: no point of {s.op.side!r} sees {other} along its normal within search_distance "
                       f"{s.op.search_distance:.4g} m{gap}: this contact can never close; raise search_distance")
    return out


def _volume_neighbours(mesh, boundary: str):
    """The volume elements having a vertex on the boundary (to name the blocks a foundation supports)."""
    verts = {v.nr for el in mesh.Boundaries(boundary).Elements() for v in el.vertices}
    return [el for el in mesh.Elements(ngs.VOL) if any(v.nr in verts for v in el.vertices)]


def check_supported(specs: list[ContactSpec], floating, scene_name: str) -> None:
    """A floating body (no displacement/symmetry holds it) must touch some contact, or nothing can hold it:
    stop with the body and its free motions named."""
    touched = set()
    for s in specs:
        for b in s.blocks:
            if isinstance(b, tuple):
                touched |= set(b)
            elif b is not None:
                touched.add(b)
    bad = [fb for fb in floating if not touched & set(fb.regions)]
    if bad:
        raise SceneError([Problem("boundary_conditions", f"body {'+'.join(fb.regions)} is not held against "
                                  f"{', '.join(fb.names)}: add a displacement or symmetry condition, a "
                                  "foundation, or a contact interface to a held body") for fb in bad],
                         source=f"scene {scene_name!r}")


def _only_prescribed(B, free: np.ndarray) -> np.ndarray:
    """Rows of B (nodes x dofs) whose entries sit on prescribed dofs only (the rule of the solver's
    ``_drop_prescribed_nodes``)."""
    absB = abs(B[:, :len(free)])
    return (absB @ free.astype(float)) <= 1e-10 * (absB @ np.ones(len(free)))


def supported_nodes(spec: ContactSpec, free: np.ndarray, u: np.ndarray, lam_n: np.ndarray,
                    lam_t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The multipliers with the undetermined ones set to zero, and the mask of the nodes they belong to
    (:data:`STATUS_PRESCRIBED`). A node's normal multiplier is undetermined when its normal constraint involves
    prescribed dofs only (the solver drops the node, p = 0); its tangential one when the tangential rows do and
    the given displacements do not slip there (e.g. a corner on two symmetry planes: both sides' tangential
    displacements zero, so any |q| <= the slip bound balances the support's reaction and the solver's value is
    arbitrary; a given slip instead fixes q at the bound). ``free``: the free dofs of V (bool), ``u`` the
    displacement vector. The support reactions computed from the cleaned multipliers take up what they held."""
    op = spec.op
    free = np.asarray(free, dtype=bool)
    n = len(free)
    normal = _only_prescribed(op.Bn, free)
    tangential = _only_prescribed(op.Bt, free)
    rows = [op.Bt] if op.Bt2 is None else [op.Bt, op.Bt2]
    if op.Bt2 is not None:
        tangential &= _only_prescribed(op.Bt2, free)
    # no slip: below round-off of the displacements the rows combine
    scale = max(float(np.max(np.abs(u[:n]), initial=0.0)), 1e-300)
    still = np.all([np.abs(B[:, :n] @ u[:n]) <= 1e-10 * scale * np.asarray(abs(B[:, :n]).sum(axis=1)).ravel()
                    for B in rows], axis=0)
    mask = normal | (tangential & still & (lam_n > 0) & (spec.law.kind != "frictionless"))
    lam_n = np.where(normal, 0.0, lam_n)
    lam_t = np.where(mask[:, None] if lam_t.ndim == 2 else mask, 0.0, lam_t)
    return lam_n, lam_t, mask


def interface_results(spec: ContactSpec, u: np.ndarray, lam_n: np.ndarray, lam_t: np.ndarray,
                      prescribed: np.ndarray | None = None) -> dict:
    """Nodal arrays of one contact at a solution u (vector of X): x, y (and z in 3D) (m), pressure p (Pa),
    traction q (Pa; 3D: the magnitude |q|, and for friction laws the components ``traction_t1``,
    ``traction_t2`` along t1, t2), gap (m), slip (m; signed along t in 2D, the tangential length in 3D), status
    (0 open, 1 stick, 2 slip, 3 prescribed: the nodes of the mask ``prescribed`` from :func:`supported_nodes`,
    whose multipliers are given cleaned), bound (the slip bound, Pa) and the node order along the side
    (``order``, by arc length from one end; 3D: by x, y, z)."""
    op = spec.op
    n = op.Bn.shape[1]
    w = np.maximum(op.weight, 1e-300)
    gap = (op.g0 + op.Bn @ u[:n]) / w
    slip = (op.Bt @ u[:n]) / w
    if op.Bt2 is not None:
        slip = np.hypot(slip, (op.Bt2 @ u[:n]) / w)
    law = spec.law
    if law.kind == "tresca":
        bound = np.broadcast_to(np.asarray(law.slip_bound, dtype=float), lam_n.shape).copy()
    elif law.kind == "coulomb":
        bound = slip_bound(law.friction, lam_n)
    else:
        bound = np.zeros_like(lam_n)
    status = np.where(lam_n > 0, STATUS_STICK, STATUS_OPEN)
    q = np.linalg.norm(lam_t, axis=1) if lam_t.ndim == 2 else lam_t
    if law.kind == "frictionless":
        status = np.where(lam_n > 0, STATUS_SLIP, STATUS_OPEN)
    else:
        sliding = (lam_n > 0) & (np.abs(q) >= bound * (1 - 1e-9))
        status = np.where(sliding, STATUS_SLIP, status)
    if prescribed is not None:
        status = np.where(prescribed, STATUS_PRESCRIBED, status)
    out = {"x": op.coords[:, 0], "y": op.coords[:, 1]}
    if op.coords.shape[1] == 3:
        out["z"] = op.coords[:, 2]
    if lam_t.ndim == 2 and law.kind != "frictionless":
        out["traction_t1"], out["traction_t2"] = lam_t[:, 0], lam_t[:, 1]
    return {**out, "pressure": lam_n, "traction": q, "gap": gap, "slip": slip, "status": status.astype(float),
            "bound": bound, "order": _arc_order(spec)}


def _arc_order(spec: ContactSpec) -> np.ndarray:
    """Node indices in order along the side (a chain through the segments from an end; by x if it branches;
    surfaces (3D) by x, then y, then z)."""
    m = spec.op.size
    c = spec.op.coords
    if spec.cells.shape[1] != 2:
        return np.lexsort(tuple(c[:, k] for k in reversed(range(c.shape[1]))))
    nb: dict[int, list[int]] = {j: [] for j in range(m)}
    for a, b in spec.cells:
        nb[int(a)].append(int(b))
        nb[int(b)].append(int(a))
    ends = [j for j, k in nb.items() if len(k) == 1]
    if len(ends) != 2 or any(len(k) > 2 for k in nb.values()):
        return np.lexsort((spec.op.coords[:, 1], spec.op.coords[:, 0]))
    start = min(ends, key=lambda j: tuple(spec.op.coords[j]))
    order, prev = [start], None
    while len(order) < m:
        nxt = [k for k in nb[order[-1]] if k != prev]
        if not nxt:
            break
        prev = order[-1]
        order.append(nxt[0])
    return np.array(order, dtype=int)


def contact_forces(op: ContactOperator, lam_n: np.ndarray, lam_t: np.ndarray, *,
                   normal: bool = True) -> np.ndarray:
    """The nodal contact forces Bn^T lam_n + Bt^T lam_t (3D: + Bt^T lam_t[:, 0] + Bt2^T lam_t[:, 1]) on the
    dofs of the displacement space; ``normal`` False: the tangential part only."""
    if lam_t.ndim == 2:
        f = op.Bt.T @ lam_t[:, 0] + op.Bt2.T @ lam_t[:, 1]
    else:
        f = op.Bt.T @ lam_t
    return op.Bn.T @ lam_n + f if normal else f


def resultant(op: ContactOperator, translations: np.ndarray, lam_n: np.ndarray, lam_t: np.ndarray,
              side_dofs: np.ndarray) -> np.ndarray:
    """The contact force on S's body (N/m plane, N/rad axisymmetric, N 3D) per coordinate direction: the
    translations' coefficient vectors (rows) applied to Bn^T lam_n + Bt^T lam_t on S's dofs."""
    n = op.Bn.shape[1]
    f = contact_forces(op, lam_n, lam_t)
    return np.array([float(t[:n][side_dofs] @ f[side_dofs]) for t in translations])


def side_dofs(mesh, V, side: str, numbering=None) -> np.ndarray:
    """The dofs of the vector space V on the boundary ``side`` (all components); on a distributed mesh with
    ``numbering`` (its :class:`.parallel.GlobalDofs` of V, collective) their global numbers from all parts."""
    dofs = set()
    for el in mesh.Boundaries(side).Elements():
        dofs.update(d for d in V.GetDofNrs(el) if d >= 0)
    local = np.array(sorted(dofs), dtype=int)
    if numbering is None:
        return local
    return np.unique(parallel.concat(mesh, numbering.vector[local].astype(int)))
