"""The Neumann strip of :mod:`ngs_geomech.verification.stefan` on front-following meshes
(:class:`ngs_geomech.adapt.stefan.FrontAdaptiveStefan`) against uniform meshes: front error (melted volume),
unknowns (mean and largest over the run), wall time, Newton iterations, the heat-content change at each mesh
transfer and the energy balance. Returns plain dicts; prints nothing.
"""

from __future__ import annotations

import time

import ngsolve as ngs
import numpy as np

from ..adapt.stefan import FrontAdaptiveStefan
from ..fem.timesteps import schedule
from ..stefan.forms import StefanSetup
from . import stefan as st
from .study import one_ngsolve_thread


def strip_mesher(length: float, height: float, h0: float):
    """The strip of :func:`ngs_geomech.verification.stefan.strip_mesh` as a mesher: restrictions [(x, y, z, h)]
    -> netgen mesh of size h0 restricted to h at those points."""
    from netgen.meshing import MeshingParameters
    from netgen.occ import OCCGeometry, Rectangle, X, Y

    face = Rectangle(length, height).Face()
    face.faces.name = "pcm"
    face.edges.Min(X).name = "hot"
    face.edges.Max(X).name = "far"
    face.edges.Min(Y).name = "bottom"
    face.edges.Max(Y).name = "top"
    geo = OCCGeometry(face, dim=2)

    def mesher(restrictions):
        mp = MeshingParameters(maxh=h0)
        for x, y, z, h in restrictions:
            mp.RestrictH(x=x, y=y, z=z, h=h)
        return ngs.Mesh(geo.GenerateMesh(mp=mp))
    return mesher


def neumann_adaptive(problem: st.NeumannProblem, h0: float, levels: int, dt: float, t0: float, t1: float,
                     layers: int = 2, remesh_every: int = 5, height: float = 0.1,
                     transfer: str = "interpolation") -> dict:
    """Run the strip (length and data of :func:`ngs_geomech.verification.stefan.neumann_strip`) from the exact
    state at t0 to t1 with step dt (s) on the base mesh of size h0 (m) refined ``levels`` times at the front.
    Returns ``front_error_volume`` (m) and ``front_rel_error``, ``ndof_mean``, ``ndof_max``, ``h_min`` (m, the
    smallest edge of the last mesh), ``wall_s`` (all steps and remeshes), ``newton_mean``, ``remeshes``,
    ``transfer_error_max`` (relative change of the heat content at a transfer), ``energy_imbalance_rel``
    (|heat gain - boundary heat - transfer changes| / boundary heat)."""
    with one_ngsolve_thread(), st.single_threaded_blas():
        mat = problem.material
        length = problem.domain_length(t1)
        setup = StefanSetup(materials={"pcm": mat}, dirichlet={"hot": problem.t_hot, "far": problem.t_cold})
        run = FrontAdaptiveStefan(strip_mesher(length, height, h0), setup, levels=levels, layers=layers,
                                  remesh_every=remesh_every, transfer=transfer)
        s0 = problem.front(t0)
        liquid = ngs.IfPos(s0 - ngs.x, 1.0, 0.0)
        enthalpy = problem.sensible_enthalpy_cf(t0) + mat.latent_heat * liquid
        tic = time.perf_counter()
        run.start(enthalpy, liquid)
        heat0 = run.forms.heat_content(run.solver.e)
        for a, b in schedule(t0, t1, dt):
            run.step(a, b)
        wall = time.perf_counter() - tic
        e = run.solver.e
        front = run.forms.melted_volume(e) / height
        exact = problem.front(t1)
        gain = run.forms.heat_content(e) - heat0
        transfers = sum(r.heat_after - r.heat_before for r in run.remeshes)
        mesh = run.forms.mesh
        pts = np.array([v.point for v in mesh.vertices])
        h_min = min(float(np.linalg.norm(pts[el.vertices[0].nr] - pts[el.vertices[1].nr]))
                    for el in mesh.edges)
        return {"h0": h0, "levels": levels, "layers": layers, "remesh_every": remesh_every, "dt": dt,
                "front_exact": exact, "front_volume": front, "front_error_volume": abs(front - exact),
                "front_rel_error": abs(front - exact) / exact, "ndof_mean": run.mean_ndof(),
                "ndof_max": int(max(run.ndofs)), "h_min": h_min, "wall_s": wall,
                "newton_mean": float(np.mean(run.iterations)), "remeshes": len(run.remeshes),
                "transfer_error_max": max(run.transfer_errors, default=0.0),
                "energy_imbalance_rel": abs(gain - run.boundary_heat - transfers) / abs(run.boundary_heat)}


def neumann_uniform(problem: st.NeumannProblem, h: float, dt: float, t0: float, t1: float) -> dict:
    """The same strip on a uniform mesh (wall time of the steps only, as for the adaptive run)."""
    r = st.neumann_strip(problem, h, dt, t0, t1, linear_reference=False)
    return {"h": h, "dt": dt, "front_rel_error": r["front_error_volume"] / r["front_exact"],
            "front_error_volume": r["front_error_volume"], "ndof": r["ndofs"],
            "wall_s": r["time_per_step"] * r["steps"], "newton_mean": r["newton_mean"]}
