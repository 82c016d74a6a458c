"""PETSc's CG with GAMG (:mod:`ngs_geomech.linalg.petsc`): the thermo-elastic box solved with ``preconditioner =
"gamg"`` equals the direct solve (2D and 3D, P1 and P2, transient heat reusing the matrix), serially and on a
distributed mesh (3 ranks = 2 workers) with the iteration counts of the serial run; a body without supports stops
with a SolverError; a scene asking for "gamg" without petsc4py is refused naming the key."""

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
from ngs_geomech.linalg import petsc
from ngs_geomech.verification.scaling import box_scene, make_box_mesh, max_rel_difference, thermoelastic_box

pytestmark = pytest.mark.usefixtures("one_thread")
needs_petsc = pytest.mark.skipif(not petsc.available(), reason="petsc4py not installed (extra 'petsc')")
ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "tests" / "mpi_cases" / "gamg_case.py"


def _case():
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location("gamg_case", CASE)
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@needs_petsc
@pytest.mark.parametrize("dim,order,maxh,steps", [(2, 1, 0.1, 0), (2, 2, 0.15, 2), (3, 1, 0.25, 0), (3, 2, 0.3, 2)])
def test_gamg_equals_the_direct_solve(dim, order, maxh, steps):
    mesh = make_box_mesh(maxh, order, dim)
    ref = thermoelastic_box(maxh, order, "direct", dim=dim, steps=steps, mesh=mesh)
    got = thermoelastic_box(maxh, order, "iterative", dim=dim, steps=steps, mesh=mesh, preconditioner="gamg",
                            tol=1e-12)
    dT, du = max_rel_difference(got["T"], ref["T"]), max_rel_difference(got["u"], ref["u"])
    print(f"dim {dim} P{order} {got['dofs']} dofs: CG heat {got['cg_heat']}, elastic {got['cg_elastic']}; "
          f"relative difference to direct T {dT:.1e}, u {du:.1e}")
    assert dT < 1e-9 and du < 1e-9
    assert max(got["cg_heat"]) < 80 and max(got["cg_elastic"]) < 200


@needs_petsc
def test_a_body_without_supports_stops_with_a_solver_error():
    mesh = make_box_mesh(0.3, 1, 3)
    V = ngs.VectorH1(mesh, order=1)
    u, v = V.TnT()
    a = ngs.BilinearForm(V, symmetric=True)
    a += ngs.InnerProduct(ngs.Sym(ngs.Grad(u)), ngs.Sym(ngs.Grad(v))) * ngs.dx
    f = ngs.LinearForm(V)
    f += ngs.CF((0, 0, -1.0)) * v * ngs.dx
    a.Assemble()
    f.Assemble()
    x = ngs.GridFunction(V)
    with pytest.raises(SolverError, match="PETSc CG with GAMG"):
        petsc.GamgCG(V, True, 1e-10, 300).solve(a.mat, f.vec, x.vec, "free block")


def test_gamg_without_petsc4py_is_refused_naming_the_key(monkeypatch):
    from ngs_geomech.scene.parse import scene_from_dict
    from ngs_geomech.validation.validate import validate

    monkeypatch.setattr(petsc, "available", lambda: False)
    data = box_scene(0.3, 2, 3)
    data["solver"] = {"linear": "iterative", "preconditioner": "gamg"}
    with pytest.raises(SceneError, match=r"solver\.preconditioner.*petsc4py"):
        validate(scene_from_dict(data, source="gamg_box"))


@needs_petsc
@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("dim,order,maxh", [(3, 2, 0.25), (2, 2, 0.1)])
def test_two_workers_equal_the_serial_gamg_solve(tmp_path, dim, order, maxh):
    out = tmp_path / "gamg.json"
    proc = subprocess.run([mpiexec(), "-n", "3", sys.executable, str(CASE), str(maxh), str(order), str(dim),
                           str(out)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    dist = json.loads(out.read_text())
    case = _case()
    mesh = make_box_mesh(maxh, order, dim)
    serial = thermoelastic_box(maxh, order, "iterative", dim=dim, mesh=mesh, keep=True, preconditioner="gamg",
                               tol=1e-12)
    vals = case.sample(serial["mesh"], serial, dim)
    got = np.array(dist["values"])
    diff = max_rel_difference(got, vals)
    print(f"dim {dim} P{order} {dist['dofs']} dofs: CG heat {dist['cg_heat']} (serial {serial['cg_heat']}), elastic "
          f"{dist['cg_elastic']} (serial {serial['cg_elastic']}); relative difference {diff:.1e}")
    assert np.isfinite(got).all() and diff < 1e-8
    for d, s in ((dist["cg_heat"], serial["cg_heat"]), (dist["cg_elastic"], serial["cg_elastic"])):
        assert abs(d[0] - s[0]) <= max(3, 0.15 * s[0])
