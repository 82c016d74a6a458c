"""An equilibrated in-situ stress across a dipping non-matching contact interface (the transfer of
:class:`ngs_geomech.mechanics.contact.InSituTraction`), against its closed form.

:func:`lithostatic_fault_scene`: a block of rock 1 km deep (z up, the surface z = 0; 2D: plane strain, y up)
under gravity, cut by a plane of dip delta and strike phi into a hanging wall and a footwall that touch along a
Coulomb contact interface (friction 0.6; independent meshes, the hanging wall's side finer), rollers u_n = 0 on
the sides and the base, the surface free. The initial stress sigma_zz = rho g z, sigma_xx = sigma_yy = K0 rho g z
(K0 = 0.8) balances gravity with these supports, so the exact solution is u = 0: the fault carries sigma0's
traction, normal stress rho g depth (K0 sin^2 delta + cos^2 delta) and shear (1 - K0) rho g depth sin delta cos
delta, within the friction cone for K0 = 0.8 (ratio 0.14 at delta = 50 degrees).

:func:`lithostatic_fault`: max |u| at t = 0 with the in-situ traction transferred exactly and with the plain mortar
transfer (whose O(h^2) consistency load for a traction that grows with depth moves the rock), and the resultant of
the fault's multipliers against the integral of the exact normal stress.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SolverError
from ..geometry.assemble import build_geometry
from ..geometry.mesh import make_mesh
from ..mechanics.run import StaticMechanicsRun
from ..scene.parse import scene_from_dict

RHO, G, K0, DEPTH = 2600.0, 9.81, 0.8, 1000.0


def lithostatic_fault_scene(*, dim: int = 3, dip: float = 50.0, strike: float = 30.0, maxh: float = 300.0,
                            fine: float = 170.0, order: int = 1, friction: float = 0.6) -> dict:
    """The scene dict of :func:`lithostatic_fault` (sizes in m)."""
    z = "z" if dim == 3 else "y"
    rock = {"youngs_modulus": 30e9, "poisson_ratio": 0.25, "density": RHO}
    names = ("west", "east", "base", "surface") if dim == 2 else ("west", "east", "south", "north", "base",
                                                                  "surface")
    sel = ("xmin", "xmax", "ymin", "ymax") if dim == 2 else ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
    sv = f"{RHO * G}*{z}"
    s0 = ([[f"{K0}*{sv}", "0"], ["0", sv]] if dim == 2 else
          [[f"{K0}*{sv}", "0", "0"], ["0", f"{K0}*{sv}", "0"], ["0", "0", sv]])
    return {
        "scene": {"name": "lithostatic_fault", "dimension": "plane" if dim == 2 else "3d"},
        "physics": {"mechanics": "static"},
        "mesh": {"maxh": maxh, "order": order, "boundary_maxh": {"fault__hanging_wall": fine}},
        "blocks": [{"name": "rock", "shape": "rectangle" if dim == 2 else "box",
                    "origin": [0.0] * (dim - 1) + [-DEPTH], "size": [DEPTH] * dim,
                    "boundaries": dict(zip(names, sel))}],
        "cuts": [{"name": "fault", "point": [DEPTH / 2] * (dim - 1) + [-DEPTH / 2], "dip": dip, "strike": strike,
                  "blocks": ["rock"], "parts": [["hanging_wall", "footwall"]]}],
        "interfaces": [{"name": "fault", "blocks": ["hanging_wall", "footwall"], "type": "contact",
                        "law": "coulomb", "friction": friction}],
        "materials": {"hanging_wall": rock, "footwall": rock},
        "mechanics": {"gravity": [0.0] * (dim - 1) + [-G], "initial_stress": s0, "tolerance": 1e-12},
        "boundary_conditions": {s: {"symmetry": True} for s in names[:-1]},
        "output": {"vtk": False, "figures": False},
    }


def _max_u(part) -> float:
    """Max over the vertices of |u| (m)."""
    mesh = part.forms.mesh
    u = part.forms.displacement()
    return max(float(np.linalg.norm(u(mesh(*v.point)))) for v in mesh.vertices)


def lithostatic_fault(**kw) -> dict:
    """{"exact": max |u| with the exact in-situ transfer (m), "mortar": with the mortar's transfer (m), "ndof",
    "resultant_error": |sum_j w_j lam_n,j - int sigma_n ds| / int sigma_n ds of the exact run, "min_pressure"
    (Pa, the smallest nodal lam_n: >= 0)}."""
    scene = scene_from_dict(lithostatic_fault_scene(**kw))
    geo = build_geometry(scene)
    mesh = make_mesh(geo, scene.mesh)
    out = {}
    for mode in ("mortar", "exact"):
        part = StaticMechanicsRun(scene, geo, mesh, None)
        if mode == "mortar":
            part.solver.insitu = None
        try:
            part.start(0.0, f"t = 0 ({mode} transfer)")
            out[mode] = _max_u(part)
        except SolverError as exc:          # the mortar's consistency load can leave no converging contact state
            out[mode], out[f"{mode}_failure"] = math.nan, str(exc)
    out["ndof"] = int(part.ndof)
    op = part.contacts[0].op
    keep = op.constrained
    lam_n = part.solver.contact.multipliers[0][0][keep]
    dip = math.radians(kw.get("dip", 50.0))
    sigma_n = RHO * G * (-op.coords[keep, -1]) * (K0 * math.sin(dip) ** 2 + math.cos(dip) ** 2)
    out["pressure_deviation"] = float(np.max(np.abs(lam_n - sigma_n)) / np.max(sigma_n))
    out["min_pressure"] = float(lam_n.min())
    return out
