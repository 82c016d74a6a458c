"""Structured meshes (``mesh.structured``, :mod:`ngs_geomech.geometry.structured`) verified through the package's
own path, and the meshing share of a fine Stefan strip run.

- :func:`heat_convergence`: the steady manufactured heat problem of :mod:`.varying_heat` (kappa(x, y) on the unit
  square) on structured triangles or quadrilaterals: L2 and H1 errors and observed orders (P1: 2, 1; P2: 3, 2).
- :func:`elastic_convergence`: the manufactured thermo-elastic problem of :mod:`.varying_elastic` (plane strain or
  axisymmetric, varying moduli) on structured meshes: displacement L2 / H1 and stress errors and orders.
- :func:`strip_front`: the two-phase Neumann strip (:func:`.stefan_adaptive.strip_scene`, closed form
  :mod:`.stefan`) run as a scene on a netgen mesh, a structured isotropic mesh or a structured anisotropic strip
  (one cell row: the physics is one-dimensional): front error against the closed form and dofs.
- :func:`strip_meshing_share`: meshing time and its share of the run (``wall_time_s`` of the run's summary) on
  the 37k-dof strip for netgen's mesh and the structured ones.

Nothing here prints or writes files; every function returns a plain dict.
"""

from __future__ import annotations

import dataclasses
import math

import ngsolve as ngs

from ..fem.coefficients import expression_function
from ..run import run_scene
from ..scene.parse import scene_from_dict
from . import stefan as st
from . import varying_elastic, varying_heat
from .stefan_adaptive import exact_temperature_expression, strip_scene
from .study import observed_order, one_ngsolve_thread

MESHES = {"netgen": {},
          "simplex": {"structured": True, "elements": "simplex"},
          "tensor": {"structured": True, "elements": "tensor"}}
"""The ``[mesh]`` keys of each compared mesh kind."""


def _structured(scene, elements: str):
    return dataclasses.replace(scene, mesh=dataclasses.replace(scene.mesh, structured=True, elements=elements))


def heat_convergence(elements: str, order: int, hs) -> dict:
    """The steady manufactured heat problem (kappa(x, y), :func:`.varying_heat.steady_convergence`) on structured
    ``elements`` ('simplex' | 'tensor') of field ``order`` for the cell sizes ``hs`` (m): ``h``, ``ndofs``,
    ``l2`` (K m), ``h1`` (K) errors and the fitted ``order_l2``, ``order_h1``."""
    kappa, exact = varying_heat.KAPPA_X, varying_heat.T_STEADY
    out = {"elements": elements, "order": order, "h": [], "ndofs": [], "l2": [], "h1": []}
    for h in hs:
        scene = _structured(varying_heat.square_scene(h, order, kappa, exact), elements)
        mesh, forms, solver = varying_heat.prepare(scene, exact, kappa, None)
        forms.t_new.Set(0.0)
        solver.solve("steady manufactured solution, structured mesh")
        T = expression_function(exact)(forms.t_new)
        Th = forms.temperature()
        dT, dG = Th - T, ngs.grad(Th) - ngs.CoefficientFunction((T.Diff(ngs.x), T.Diff(ngs.y)))
        out["h"].append(float(h))
        out["ndofs"].append(int(forms.X.ndof))
        out["l2"].append(math.sqrt(float(ngs.Integrate(dT * dT, mesh, order=2 * order + 6))))
        out["h1"].append(math.sqrt(float(ngs.Integrate(ngs.InnerProduct(dG, dG), mesh, order=2 * order + 6))))
    out["order_l2"] = observed_order(out["h"], out["l2"])
    out["order_h1"] = observed_order(out["h"], out["h1"])
    return out


def elastic_convergence(elements: str, model: str, order: int, hs) -> dict:
    """The manufactured thermo-elastic problem of ``model`` ('plane_strain' | 'axisymmetric',
    :func:`.varying_elastic.convergence`) on structured ``elements``: its dict (errors ``l2``, ``h1``, ``stress``,
    orders ``order_l2``, ``order_h1``, ``order_stress``) with ``elements``."""
    out = varying_elastic.convergence(model, order, hs, mesh_keys={"structured": True, "elements": elements})
    return {**out, "elements": elements}


def strip_data(h: float, mesh: str, *, height: float = 0.1, t0: float = 0.05, t1: float = 0.5,
               dt_over_h: float = 0.2, sizes=None) -> dict:
    """The scene dict of the two-phase Neumann strip (:data:`.stefan.TWO_PHASE`, length
    ``domain_length(t1)``, ``height`` m) from the exact state at t0 to t1 (s) with dt = dt_over_h * h (s / m),
    mesh size h (m) on mesh kind ``mesh`` (:data:`MESHES`); ``sizes`` the structured cell sizes per axis (m)."""
    problem = st.TWO_PHASE
    data = strip_scene(problem, problem.domain_length(t1), height, h)
    data["mesh"] = {**data["mesh"], **MESHES[mesh], **({"sizes": list(sizes)} if sizes is not None else {})}
    return {**data, "initial": {"temperature": exact_temperature_expression(problem, t0)},
            "time": {"start": t0, "end": t1, "dt": dt_over_h * h}, "output": {"every": 10 ** 6, "probes": []}}


def strip_front(h: float, mesh: str, *, height: float = 0.1, t1: float = 0.5, sizes=None, **kw) -> dict:
    """Run the strip of :func:`strip_data` (one NGSolve and one BLAS thread): ``dofs``, the front (m, the melted
    area over the height) against the closed form (``front_rel_error``), the run's ``mesh_s``, ``total_s`` (s,
    ``wall_time_s`` of its summary) and ``mesh_share`` = mesh_s / total_s."""
    data = strip_data(h, mesh, height=height, t1=t1, sizes=sizes, **kw)
    with one_ngsolve_thread(), st.single_threaded_blas():
        res = run_scene(scene_from_dict(data), None, progress=False)
    s = res.summary
    front = s["stefan"]["melted_volume"]["pcm"][-1] / height
    exact = st.TWO_PHASE.front(t1)
    wall = s["wall_time_s"]
    return {"mesh": mesh, "h": h, "sizes": sizes, "dofs": int(s["mesh"]["dofs"]), "elements": s["mesh"]["elements"],
            "front": front, "front_exact": exact, "front_rel_error": abs(front - exact) / exact,
            "mesh_s": wall["mesh_s"], "total_s": wall["total_s"], "mesh_share": wall["mesh_s"] / wall["total_s"]}


def strip_meshing_share(h: float = 0.003125, repeats: int = 1, kinds=("netgen", "simplex", "tensor")) -> dict:
    """The meshing share of the strip run at mesh size h (m; 0.003125: the 37k-dof strip) on each mesh kind,
    the kinds alternated ``repeats`` times, the best (smallest total) run of each kept: {kind: :func:`strip_front`
    dict}, and ``share_before`` (netgen) / ``share_after`` (the structured kinds' largest share)."""
    best: dict[str, dict] = {}
    for _ in range(repeats):
        for kind in kinds:
            run = strip_front(h, kind)
            if kind not in best or run["total_s"] < best[kind]["total_s"]:
                best[kind] = run
    out = {"h": h, "repeats": repeats, **best}
    if "netgen" in best:
        out["share_before"] = best["netgen"]["mesh_share"]
    after = [best[k]["mesh_share"] for k in kinds if k != "netgen"]
    if after:
        out["share_after"] = max(after)
    return out


def anisotropic_strip(h: float, *, height: float = 0.1, netgen_h: float | None = None) -> dict:
    """The strip's front error on the structured anisotropic strip (cells h x height: one row, quadrilaterals
    and triangles) and on netgen's mesh of about as many dofs (size ``netgen_h``, m; default the size whose
    isotropic mesh has the anisotropic one's dofs): {kind: :func:`strip_front` dict}."""
    length = st.TWO_PHASE.domain_length(0.5)
    if netgen_h is None:        # an isotropic mesh of size H has about 1.15 L height / H^2 vertices
        netgen_h = math.sqrt(1.15 * length * height / (2 * (length / h + 1)))
    return {"tensor_anisotropic": strip_front(h, "tensor", sizes=[h, height]),
            "simplex_anisotropic": strip_front(h, "simplex", sizes=[h, height]),
            "netgen_equal_dofs": strip_front(netgen_h, "netgen", dt_over_h=0.2 * h / netgen_h)}
