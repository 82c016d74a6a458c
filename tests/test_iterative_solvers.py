"""Preconditioned CG (issue 10): iterative equals direct to the solver tolerance on heat (steady, transient) and
thermo-elasticity in 2D and 3D, P1 and P2; iteration counts bounded under refinement; failures stop with a
SolverError naming the solve; the automatic choice; 2 MPI ranks against the serial solution (when mpiexec and
mpi4py are there)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import ngsolve as ngs
import numpy as np
import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.heat.forms import HeatForms
from ngs_geomech.heat.problem import heat_setup
from ngs_geomech.heat.solver import HeatSolver
from ngs_geomech.linalg.iterative import AUTO_DOFS, PCG, choose_solver
from ngs_geomech.mechanics.forms import ElasticForms
from ngs_geomech.mechanics.problem import elastic_setup
from ngs_geomech.mechanics.solver import ElasticSolver
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification.scaling import box_scene, make_box_mesh, max_rel_difference, thermoelastic_box

pytestmark = pytest.mark.usefixtures("one_thread")

ROOT = Path(__file__).resolve().parents[1]
CASES = [(2, 1, 0.05, 0), (2, 2, 0.1, 2), (3, 1, 0.15, 2), (3, 2, 0.3, 0)]
"""(dim, order, maxh, transient steps) of the comparisons."""


@pytest.mark.parametrize("dim,order,maxh,steps", CASES)
def test_iterative_equals_direct(dim, order, maxh, steps):
    mesh = make_box_mesh(maxh, order, dim)
    d = thermoelastic_box(maxh, order, "direct", dim=dim, steps=steps, mesh=mesh)
    it = thermoelastic_box(maxh, order, "iterative", dim=dim, steps=steps, mesh=mesh)
    dT, du = max_rel_difference(it["T"], d["T"]), max_rel_difference(it["u"], d["u"])
    print(f"\n{dim}D P{order} ({'transient, ' + str(steps) + ' steps' if steps else 'steady'}): dofs "
          f"{it['dofs_heat']} + {it['dofs_elastic']}, CG heat {it['cg_heat']}, elastic {it['cg_elastic']}; "
          f"max rel. difference T {dT:.1e}, u {du:.1e}")
    assert d["solver_heat"] == d["solver_elastic"] == "direct"
    assert it["solver_heat"] == it["solver_elastic"] == "iterative"
    assert len(it["cg_heat"]) == max(steps, 1) and all(0 < k < 200 for k in it["cg_heat"] + it["cg_elastic"])
    assert dT < 1e-8 and du < 1e-8
    assert d["u_max"] > 1e-4          # the thermal stress deforms the box (u ~ alpha dT L = 1e-3 m)


@pytest.mark.parametrize("order", [1, 2])
def test_iterations_bounded_under_refinement(order):
    """One uniform halving of h in 3D: the CG counts grow by at most 40 % (BDDC for P2, AMG for P1 heat,
    the displacement decomposition for P1 elasticity)."""
    coarse, fine = (thermoelastic_box(h, order, "iterative") for h in (0.3, 0.15))
    print(f"\nP{order}: dofs {coarse['dofs']} -> {fine['dofs']}; CG heat {coarse['cg_heat']} -> {fine['cg_heat']}, "
          f"elastic {coarse['cg_elastic']} -> {fine['cg_elastic']}")
    assert fine["dofs"] > 4 * coarse["dofs"]
    for key in ("cg_heat", "cg_elastic"):
        assert fine[key][0] <= 1.4 * coarse[key][0] + 2


def _unsupported_forms(dim=2):
    """The box with its base condition removed after validation (a rigid motion: a singular stiffness)."""
    scene = scene_from_dict(box_scene(0.2, 2, dim), source="unsupported_box")
    geo = validate(scene)
    mesh = make_box_mesh(0.2, 2, dim)
    heat = HeatForms(mesh, heat_setup(scene, geo, mesh))
    heat.t_new.Set(0.0)
    HeatSolver(heat).solve("steady")
    setup = elastic_setup(scene, geo, mesh, heat.temperature())
    setup.dirichlet = {}
    return ElasticForms(mesh, setup)


def test_singular_system_stops_with_a_named_error():
    forms = _unsupported_forms()
    with pytest.raises(SolverError, match="elastic solve at unsupported box") as err:
        ElasticSolver(forms, solver="iterative").solve("unsupported box")
    print(f"\n{err.value}")


def test_iteration_limit_and_stagnation_name_the_solve():
    mesh = make_box_mesh(0.1, 2, 2)
    scene = scene_from_dict(box_scene(0.1, 2, 2), source="box")
    heat = HeatForms(mesh, heat_setup(scene, validate(scene), mesh))
    heat.t_new.Set(0.0)
    with pytest.raises(SolverError, match=r"heat solve at the limit test: CG did not converge in 3 iterations"):
        HeatSolver(heat, solver="iterative", maxit=3).solve("the limit test")
    # stagnation: CG on an inconsistent singular system (a 2x2 matrix [[1, 1], [1, 1]] and b = (1, -1)), the
    # residual cannot fall below |b| / sqrt(2)
    mat = ngs.la.SparseMatrixd.CreateFromCOO([0, 0, 1, 1], [0, 1, 0, 1], [1.0, 1.0, 1.0, 1.0], 2, 2)
    ident = ngs.la.SparseMatrixd.CreateFromCOO([0, 1], [0, 1], [1.0, 1.0], 2, 2)
    b = mat.CreateColVector()
    b.FV().NumPy()[:] = [1.0, -1.0]
    x = mat.CreateColVector()
    x[:] = 0.0
    with pytest.raises(SolverError, match="toy solve: CG"):
        PCG(tol=1e-10, maxit=50, stall=5).solve(mat, ident, b, x, "toy solve")


def test_newton_and_secant_with_cg():
    """The lambda law (hardening, lam = 1.5) under the thermal stress: Newton (exact Hessian) and the secant
    method with CG reach the direct solution."""
    data = box_scene(0.1, 1, 2)
    data["materials"]["rock"]["rheology_lambda"] = 1.5
    scene = scene_from_dict(data, source="lambda_box")
    geo = validate(scene)
    mesh = make_box_mesh(0.1, 1, 2)
    heat = HeatForms(mesh, heat_setup(scene, geo, mesh))
    heat.t_new.Set(0.0)
    HeatSolver(heat).solve("steady")
    out = {}
    for method in ("newton", "secant"):
        for solver in ("direct", "iterative"):
            forms = ElasticForms(mesh, elastic_setup(scene, geo, mesh, heat.temperature()))
            es = ElasticSolver(forms, method=method, solver=solver, tol=1e-10)
            info = es.solve("lambda box")
            out[method, solver] = (forms.gf.vec.FV().NumPy().copy(), info.iterations, list(es.cg_iterations))
    for method in ("newton", "secant"):
        (ud, nd, _), (ui, ni, cg) = out[method, "direct"], out[method, "iterative"]
        diff = max_rel_difference(ui, ud)
        print(f"\n{method}: {nd} / {ni} iterations (direct / CG), CG per linear solve {cg}, difference {diff:.1e}")
        assert diff < 1e-7 and abs(ni - nd) <= 1 and cg
    assert max_rel_difference(out["newton", "iterative"][0], out["secant", "iterative"][0]) < 1e-6


def test_automatic_choice():
    assert choose_solver("auto", AUTO_DOFS[3] - 1, 3) == "direct"
    assert choose_solver("auto", AUTO_DOFS[3] + 1, 3) == "iterative"
    assert choose_solver("auto", AUTO_DOFS[3] + 1, 2) == "direct"
    assert choose_solver("iterative", 10, 3, spd=False) == "direct"      # saddle points stay direct
    with pytest.raises(ValueError, match="solver must be one of"):
        choose_solver("cg", 10, 3)
    small = thermoelastic_box(0.3, 1)
    assert small["solver_heat"] == small["solver_elastic"] == "direct"


@needs_mpi
@one_mpi_job
def test_two_workers_equal_serial(tmp_path):
    """netgen's distributed mesh keeps no elements on rank 0: 3 ranks = 2 workers. The distributed heat and
    thermal-stress solutions equal the serial ones at the sample points to the CG tolerance."""
    out = tmp_path / "mpi.json"
    proc = subprocess.run([mpiexec(), "-n", "3", sys.executable, str(ROOT / "studies" / "scaling" / "mpi_box.py"),
                           "0.3", "2", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    data = json.loads(out.read_text())
    assert data["elements_per_rank"][0] == 0 and all(n > 0 for n in data["elements_per_rank"][1:])
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location("mpi_box", ROOT / "studies" / "scaling" / "mpi_box.py")
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    serial = thermoelastic_box(0.3, 2, "iterative", keep=True)
    ref = mod.sample(serial["mesh"], serial["heat"].temperature(), serial["elastic"].displacement())
    assert set(map(int, data["points"])) == set(ref)
    got = np.array([data["points"][str(k)] for k in sorted(ref)])
    want = np.array([ref[k] for k in sorted(ref)])
    dT = max_rel_difference(got[:, 0], want[:, 0])
    du = max_rel_difference(got[:, 1:], want[:, 1:])
    print(f"\n2 MPI workers: CG heat {data['cg_heat']} (serial {serial['cg_heat']}), elastic {data['cg_elastic']} "
          f"(serial {serial['cg_elastic']}); max rel. difference T {dT:.1e}, u {du:.1e}")
    assert dT < 1e-8 and du < 1e-8


def test_two_level_preconditioner_componentwise_supports_and_secant():
    """3D P2 elasticity takes the two-level AMG preconditioner (the P1 part with each component's own Dirichlet
    boundaries): a box held by symmetry planes (u_x = 0 on xmin, u_y = 0 on ymin) and u_z = 0 on its base, under
    the lambda law (lam = 1.5, secant method: the preconditioner's Jacobi part is rebuilt after every assembly),
    reaches the direct solution; the heat solve takes BDDC with the AMG vertex problem."""
    data = box_scene(0.3, 2, 3)
    block = data["blocks"][0]
    block["boundaries"].update({"xsym": "xmin", "ysym": "ymin"})
    block["boundaries"]["hot"] = "xmax"
    block["boundaries"].pop("cold")
    data["boundary_conditions"] = {"hot": {"temperature": 100.0}, "base": {"displacement": ["free", "free", 0.0]},
                                   "xsym": {"symmetry": True}, "ysym": {"symmetry": True}}
    data["materials"]["rock"]["rheology_lambda"] = 1.5
    scene = scene_from_dict(data, source="two_level_box")
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    heat = HeatForms(mesh, heat_setup(scene, geo, mesh))
    out = {}
    for solver in ("direct", "iterative"):
        heat.t_new.Set(0.0)
        heat.gf.vec[:] = 0.0
        hs = HeatSolver(heat, solver=solver, tol=1e-12)
        hs.solve("steady")
        T = heat.gf.vec.FV().NumPy().copy()
        forms = ElasticForms(mesh, elastic_setup(scene, geo, mesh, heat.temperature()))
        es = ElasticSolver(forms, method="secant", solver=solver, tol=1e-10, linear_tol=1e-12)
        info = es.solve("two-level box")
        out[solver] = (T, forms.gf.vec.FV().NumPy().copy(), info.iterations, list(es.cg_iterations),
                       [p.kind for p in es._pre.values()], getattr(hs._pre, "kind", None))
    (Td, ud, nd, _, _, _), (Ti, ui, ni, cg, kinds, heat_kind) = out["direct"], out["iterative"]
    print(f"\nsecant iterations {nd} / {ni}, CG per solve {cg}, T diff {max_rel_difference(Ti, Td):.1e}, "
          f"u diff {max_rel_difference(ui, ud):.1e}")
    assert kinds == ["two_level_amg"] and heat_kind == "bddc_h1amg"
    assert max_rel_difference(Ti, Td) < 1e-9 and max_rel_difference(ui, ud) < 1e-8
    assert abs(ni - nd) <= 1 and len(cg) >= 3 and all(0 < k < 200 for k in cg)
    assert np.max(np.abs(ud)) > 1e-5


def test_preconditioner_choice_bddc_against_default():
    """solver.preconditioner = "bddc" (BDDC with the vertex problem factored directly, what distributed meshes use)
    gives the default's solution to the solver tolerance with its own CG counts; with P1 elements the scene is
    refused naming the key."""
    mesh = make_box_mesh(0.3, 2, 3)
    auto = thermoelastic_box(0.3, 2, "iterative", mesh=mesh)
    bddc = thermoelastic_box(0.3, 2, "iterative", mesh=mesh, preconditioner="bddc")
    dT, du = max_rel_difference(bddc["T"], auto["T"]), max_rel_difference(bddc["u"], auto["u"])
    print(f"\nCG heat {auto['cg_heat']} / {bddc['cg_heat']}, elasticity {auto['cg_elastic']} / {bddc['cg_elastic']} "
          f"(auto / bddc), differences {dT:.1e} {du:.1e}")
    assert dT < 1e-8 and du < 1e-8
    assert bddc["cg_elastic"] != auto["cg_elastic"]          # another preconditioner really ran
    data = box_scene(0.3, 1, 3)
    data["solver"] = {"linear": "iterative", "preconditioner": "bddc"}
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data, source="p1_bddc"))
    assert "solver.preconditioner" in str(info.value)
