"""Heat crossing contact interfaces on a distributed mesh (:mod:`ngs_geomech.heat.distributed`): the cases of
:mod:`mpi_cases.heat_contact_case` (3D perfect contact P1 and P2, a constant conductance, the power law of the
mechanics' contact pressure, k(T) with a conductance; 2D perfect contact with cross points P1 and P2, k(T), a
conductance with linearized and exact radiation)
on 3 and 5 ranks (2 and 4 workers) against the serial run in this process: the temperatures at points of both bodies
and the interface heat flow of every step equal to 1e-8 (relative to the largest value)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi_cases.heat_contact_case import case_result
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.linalg import petsc
from ngs_geomech.parallel import launch_environment

pytestmark = pytest.mark.usefixtures("one_thread")
CASE = Path(__file__).resolve().parent / "mpi_cases" / "heat_contact_case.py"


def _distributed(tmp_path, case: str, ranks: int) -> dict:
    out = tmp_path / f"{case}_{ranks}.json"
    proc = subprocess.run([mpiexec(), "-n", str(ranks), sys.executable, str(CASE), case, str(out)], capture_output=True,
                          text=True, timeout=900, env=launch_environment())
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())


def differences(got: dict, want: dict) -> dict:
    """The largest differences of the temperatures and flows, each relative to the largest serial value."""
    def rel(a, b) -> float:
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        return float(np.max(np.abs(a - b), initial=0.0) / max(float(np.max(np.abs(b), initial=0.0)), 1e-300))
    flows = [rel(got["flows"][k], v) for k, v in want["flows"].items()]
    return {"temperature": rel(got["T"], want["T"]), "flow": max(flows, default=0.0)}


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("case,ranks", [("3d_perfect_p1", 3), ("3d_perfect_p1", 5), ("3d_perfect_p2", 3),
                                        ("3d_conductance", 3), ("3d_conductance", 5), ("3d_pressure_law", 3),
                                        ("3d_pressure_law", 5), ("2d_perfect_p1", 3), ("2d_perfect_p2", 5),
                                        ("2d_radiation", 3), ("2d_exact_radiation", 3), ("2d_kT_perfect", 3),
                                        ("3d_kT_conductance", 5)])
def test_distributed_heat_across_contacts_equals_serial(tmp_path, case, ranks):
    if case == "3d_pressure_law" and not petsc.available():
        pytest.skip("distributed contact needs petsc4py (extra 'petsc')")
    want = case_result(case)
    got = _distributed(tmp_path, case, ranks)
    d = differences(got, want)
    print(f"\n{case}, {ranks} ranks, {got['dofs']} dofs, elements per rank {got['elements_per_rank']}: relative "
          f"differences to serial: temperature "
          f"{d['temperature']:.1e}, interface flows {d['flow']:.1e} (serial T max {max(np.abs(want['T'])):.4g}, "
          f"flows {({k: v[-1] for k, v in want['flows'].items()})})")
    assert got["ranks"] == ranks and got["dofs"] == want["dofs"]
    assert set(got["flows"]) == set(want["flows"]) and all(len(got["flows"][k]) == len(v)
                                                           for k, v in want["flows"].items())
    assert max(np.abs(want["T"])) > 1.0 and all(abs(v[-1]) > 0 for v in want["flows"].values())
    assert d["temperature"] < 1e-8 and d["flow"] < 1e-8
    if want["conductance"] is not None:
        assert got["conductance"]["joint"]["state"] == want["conductance"]["joint"]["state"]


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("scene,overrides", [
    ("block3d", ["output.vtk=false", "output.figures=false"]),                                # 3D steady, P1
    ("canister", ["time.end=5 year", "output.vtk=false", "output.figures=false"]),           # axisymmetric, P2, CN
    ("repository_fracture_3d", ["mesh.maxh=200", "mesh.order=1", "blocks.buffer.maxh=0.3", "blocks.canister.maxh=0.3",
                                "blocks.tunnel.maxh=2", "time.end=30 year", "time.dt_max=5 year", "output.every=5",
                                "output.vtk=false", "output.figures=false", "solver.tolerance=1e-12"])])
# (repository_fracture_3d: 3D P1, CN, with the fracture's Coulomb contact in the mechanics; its probes include the
# stresses and the uplift, equal to the solver tolerance)
def test_a_builtin_contact_scene_runs_distributed_as_serially(tmp_path, scene, overrides):
    """Built-in scenes with heat crossing a contact interface (perfect contact) through the command line on 3 ranks:
    their probes (at the last time) and interface heat flows (every step) equal the serial run's."""
    from ngs_geomech.api import run

    if scene == "repository_fracture_3d" and not petsc.available():
        pytest.skip("its fracture's contact mechanics needs petsc4py in distributed runs (extra 'petsc')")
    out = tmp_path / "mpi"
    cmd = [mpiexec(), "-n", "3", sys.executable, "-m", "ngs_geomech.cli", "run", scene, "--out", str(out), "--quiet",
           "--threads", "1"]
    for o in overrides:
        cmd += ["--set", o]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=launch_environment())
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads((out / "summary.json").read_text())
    want = run(scene, None, overrides=overrides, progress=False).summary
    assert got["mesh"]["ranks"] == 3 and got["mesh"]["dofs"] == want["mesh"]["dofs"]
    probes = {k: v for k, v in want["probe_series"].items() if k not in ("time_s", "times_s")}
    d = differences({"T": [got["probe_series"][k][-1] for k in probes], "flows": got["interface_heat_flow_W"]},
                    {"T": [v[-1] for v in probes.values()], "flows": want["interface_heat_flow_W"]})
    print(f"\n{scene}, 3 ranks, {got['mesh']['dofs']} dofs: relative differences to serial: probes "
          f"{d['temperature']:.1e}, interface flows {d['flow']:.1e}")
    assert want["interface_heat_flow_W"] and d["temperature"] < 1e-8 and d["flow"] < 1e-8
