"""Adaptive refinement of a static contact scene in distributed runs: the stacked boxes of
:mod:`ngs_geomech.verification.distributed_contact` (3D; the upper box held by the contact alone, pressed and pushed
sideways: stick and slip zones on the contact) with an ``[adaptivity]`` table, on 3 and 5 ranks (2 and 4 workers)
against the serial run in this process (:mod:`mpi_cases.adaptive_contact_case`).

The contact-zone indicator is evaluated on rank 0's whole mesh (the contact operators' nodes matched to its vertices
by coordinates, :mod:`ngs_geomech.adapt.distributed`), the estimators on the parts; the distributed loop must take
the serial steps: the same stop reason, the same dofs, elements, marked and flagged elements per step, the estimates
equal to the solver tolerance, and on the final mesh the displacements, nodal contact pressures and tractions and
the contact forces within 1e-8 (relative), the same Newton iterations and node states."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mpi_cases.adaptive_contact_case import adaptive_result, adaptive_scene
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.linalg import petsc
from ngs_geomech.verification.distributed_contact import differences

pytestmark = [pytest.mark.usefixtures("one_thread"),
              pytest.mark.skipif(not petsc.available(), reason="petsc4py not installed (extra 'petsc')")]

CASE = Path(__file__).resolve().parent / "mpi_cases" / "adaptive_contact_case.py"
TOLERANCE = 1e-8
INDICATOR = {"indicators": ["contact_zone"], "marker": "maximum", "theta": 1.0, "max_refinements": 1}
"""The indicator drives the refinement: the marker takes only the elements of the largest estimate."""
ESTIMATOR_AND_INDICATOR = {"estimator": "zz", "indicators": ["contact_zone"], "theta": 0.5, "max_refinements": 1}
ESTIMATOR = {"estimator": "residual", "theta": 0.5, "max_refinements": 1}


def _run(law: str, maxh: float, adaptivity: dict, ranks: int, out: Path) -> dict:
    proc = subprocess.run([mpiexec(), "-n", str(ranks), sys.executable, str(CASE), law, str(maxh),
                           json.dumps(adaptivity), str(out)], capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("law,adaptivity,ranks", [
    ("coulomb", INDICATOR, 3), ("coulomb", INDICATOR, 5), ("tresca", ESTIMATOR_AND_INDICATOR, 3),
    ("coulomb", ESTIMATOR_AND_INDICATOR, 5), ("coulomb", ESTIMATOR, 3)],
    ids=["indicator-3", "indicator-5", "zz+indicator-3", "zz+indicator-5", "residual-3"])
def test_adaptive_contact_distributed_takes_the_serial_steps(tmp_path, law, adaptivity, ranks):
    maxh = 0.3
    got = _run(law, maxh, adaptivity, ranks, tmp_path / "case.json")
    want = adaptive_result(adaptive_scene(law, maxh, adaptivity))
    mine, theirs = got["adaptivity"]["steps"], want["adaptivity"]["steps"]
    est = max(abs(a["estimate"] - b["estimate"]) / b["estimate"] for a, b in zip(mine, theirs))
    d = differences(got, want)
    print(f"\n{law} {adaptivity} on {ranks} ranks: {len(mine)} steps, dofs {[s['ndof'] for s in mine]} (serial "
          f"{[s['ndof'] for s in theirs]}), marked {[s['marked'] for s in mine]} (serial "
          f"{[s['marked'] for s in theirs]}), flagged {[s['flagged'] for s in mine]} (serial "
          f"{[s['flagged'] for s in theirs]}); max rel. difference to serial: estimates {est:.1e}, displacement "
          f"{d['displacement']:.1e}, pressure {d['pressure']:.1e}, traction {d['traction']:.1e}, forces "
          f"{d['forces']:.1e}; Newton iterations {got['contact']['iterations_per_solve']} (serial "
          f"{want['contact']['iterations_per_solve']})")
    assert got["mesh"]["ranks"] == ranks and got["mesh"]["elements_per_rank"][0] == 0
    assert got["adaptivity"]["stop_reason"] == want["adaptivity"]["stop_reason"]
    assert len(mine) == len(theirs) == adaptivity["max_refinements"] + 1
    for key in ("ndof", "elements", "marked", "flagged"):
        assert [s[key] for s in mine] == [s[key] for s in theirs], key
    for key in ("dofs", "elements", "vertices"):
        assert got["mesh"][key] == want["mesh"][key], key
    if "contact_zone" in adaptivity.get("indicators", []):
        assert sum(s["flagged"] for s in theirs) > 0         # the indicator refined elements the marker did not
    assert est < TOLERANCE
    assert d["max"] < TOLERANCE
    assert d["same_iterations"] and d["same_states"]


def test_stationary_contact_zone_indicator_is_not_refused():
    """A stationary contact scene with the contact-zone indicator passes the distributed checks' adaptivity part
    (checked in-process, no MPI needed; the contact part needs petsc4py, as the module does)."""
    from ngs_geomech.scene.parse import scene_from_dict
    from ngs_geomech.validation.validate import distributed_problems

    scene = scene_from_dict(adaptive_scene("coulomb", 0.3, ESTIMATOR_AND_INDICATOR), source="adaptive_contact")
    assert distributed_problems(scene) == []
