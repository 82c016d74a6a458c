"""Contact on a distributed mesh (:mod:`ngs_geomech.contact.distributed`): the stacked boxes of
:mod:`ngs_geomech.verification.distributed_contact` (the upper box held by the contact alone, pressed, and pushed
sideways for the friction laws: stick and slip zones) on 3 and 5 ranks (2 and 4 workers) against the serial run in
this process: displacements, nodal contact pressures and tractions (matched by coordinates) and the contact forces
equal to 1e-8 (relative), the same Newton iterations and the same node states."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.linalg import petsc
from ngs_geomech.verification.distributed_contact import case_result, differences, stack_scene

pytestmark = [pytest.mark.usefixtures("one_thread"),
              pytest.mark.skipif(not petsc.available(), reason="petsc4py not installed (extra 'petsc')")]


def _against_serial(tmp_path, ranks: int, law: str, maxh: float, order: int, dimension: str = "3d",
                    support: str = "fixed") -> tuple[dict, dict, dict]:
    """The stack case on ``ranks`` ranks (a subprocess), the same serially in this process, and their
    :func:`differences`."""
    out = tmp_path / "case.json"
    proc = subprocess.run([mpiexec(), "-n", str(ranks), sys.executable, "-m", "ngs_geomech.verification."
                           "distributed_contact", law, str(maxh), str(order), str(out), dimension, support],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(out.read_text())
    want = case_result(stack_scene(law, maxh, order, dimension=dimension, support=support))
    return got, want, differences(got, want)


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("law,ranks,order", [("frictionless", 3, 1), ("tresca", 3, 1), ("coulomb", 3, 1),
                                             ("coulomb", 5, 1), ("tresca", 5, 2)])
def test_distributed_contact_equals_serial(tmp_path, law, ranks, order):
    maxh = 0.3 if order == 1 else 0.4
    got, want, d = _against_serial(tmp_path, ranks, law, maxh, order)
    c = got["contact"]
    print(f"\n{law} P{order}, {ranks} ranks, {got['dofs']} dofs: relative differences to serial: displacement "
          f"{d['displacement']:.1e}, pressure {d['pressure']:.1e}, traction {d['traction']:.1e}, forces "
          f"{d['forces']:.1e}; Newton iterations {c['iterations_per_solve']} (serial "
          f"{want['contact']['iterations_per_solve']}); nodes {c['interfaces']['joint']['nodes']}")
    assert got["ranks"] == ranks and got["dofs"] == want["dofs"]
    assert d["max"] < 1e-8
    assert d["same_iterations"] and d["same_states"]
    assert c["force_balance"]["imbalance_rel"] < 1e-8


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("law,dimension,support,ranks", [
    ("frictionless", "plane", "fixed", 3), ("coulomb", "plane", "fixed", 5), ("tresca", "plane", "foundation", 3),
    ("frictionless", "3d", "foundation", 3), ("coulomb", "3d", "foundation", 5)])
def test_distributed_contact_2d_and_foundations_equal_serial(tmp_path, law, dimension, support, ranks):
    """2D (plane strain) stacks and stacks on a rigid foundation (both boxes floating: held by the contacts
    alone) on 2 and 4 workers: the same agreement with the serial run as the 3D stack on a fixed base."""
    maxh = 0.05 if dimension == "plane" else 0.3
    got, want, d = _against_serial(tmp_path, ranks, law, maxh, 1, dimension, support)
    c = got["contact"]
    print(f"\n{law} {dimension} on a {support} base, {ranks} ranks, {got['dofs']} dofs: relative differences to "
          f"serial: displacement {d['displacement']:.1e}, pressure {d['pressure']:.1e}, traction "
          f"{d['traction']:.1e}, forces {d['forces']:.1e}; Newton iterations {c['iterations_per_solve']} (serial "
          f"{want['contact']['iterations_per_solve']})")
    assert got["ranks"] == ranks and got["dofs"] == want["dofs"]
    assert len(got["nodal"]) == (2 if support == "foundation" else 1)
    assert d["max"] < 1e-8
    assert d["same_iterations"] and d["same_states"]
    assert c["force_balance"]["imbalance_rel"] < 1e-8
