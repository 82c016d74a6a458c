"""Adaptive refinement in distributed runs: ``mpiexec -n N ngs-geomech run SCENE`` with an ``[adaptivity]`` block
against the serial run of the same scene in this process. Rank 0 refines its copy of the whole mesh with the marks
of the whole mesh and sends the refined mesh out again (:mod:`ngs_geomech.adapt.distributed`), so the distributed
loop takes the serial steps: the same number of refinements, the same dofs, elements and marked elements per step,
the estimates per step and the final probes equal to the solver tolerance (relative 1e-8; CG with GAMG stops at a
relative residual of 1e-10 where the serial run factors).

* a steady heat scene with a curved inclusion (P2: the ZZ estimator with patch recovery gathered to rank 0; the
  residual estimator with the cumulated facet jumps), 2 workers;
* ``heated_rock`` (steady heat + thermal stresses, plane strain, P2; the ZZ stress recovery of the mechanics), 2
  workers;
* with 4 workers (-n 5): expected to fail today: on small meshes the distributed solves themselves (without
  adaptivity; NGSolve's own CG with BDDC as well as PETSc's GAMG) give wrong temperatures or crash on this machine
  with 3 or 4 workers (measured: the warm lens without [adaptivity], maxh 0.2, 3 workers: centre temperature
  17.240 against 17.400 serially; maxh 0.07, 4 workers: 16.834 against 17.404), so the comparison fails before
  the refinement does anything.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.api import run

pytestmark = pytest.mark.usefixtures("one_thread")

LENS = """
[scene]
name = "warm_lens"
dimension = "plane"

[physics]
thermal = "steady"

[mesh]
maxh = 0.3
order = 2

[[blocks]]
name = "rock"
shape = "rectangle"
origin = [0.0, 0.0]
size = [2.0, 1.0]
boundaries = { left = "xmin", right = "xmax", bottom = "ymin", top = "ymax" }

[[blocks]]
name = "lens"                  # curved: the parts of every refined mesh are curved with the geometry
shape = "circle"
center = [0.7, 0.45]
radius = 0.2

[[interfaces]]
name = "lens_wall"
blocks = ["rock", "lens"]
type = "glued"

[materials.rock]
conductivity = 2.5

[materials.lens]
conductivity = 12.0

[[sources]]
region = "lens"
density = 400.0

[boundary_conditions.top]
temperature = 10.0

[adaptivity]
max_refinements = 3

[[output.probes]]
name = "centre_T"
quantity = "temperature"
point = [0.7, 0.45]

[[output.probes]]
name = "mean_T"
quantity = "temperature"
region = "rock"
statistic = "mean"
"""

TOLERANCE = 1e-8


def _distributed(scene: str, out: Path, overrides: list[str], ranks: int) -> subprocess.CompletedProcess:
    cmd = [mpiexec(), "-n", str(ranks), sys.executable, "-m", "ngs_geomech.cli", "run", scene, "--out", str(out),
           "--quiet", "--threads", "1"]
    for o in overrides:
        cmd += ["--set", o]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def _compare(scene: str, tmp_path: Path, overrides: list[str], ranks: int = 3) -> dict:
    """Run ``scene`` distributed and serially; assert the serial steps; return the distributed summary."""
    out = tmp_path / f"mpi{ranks}"
    proc = _distributed(scene, out, overrides, ranks)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads((out / "summary.json").read_text())
    want = run(scene, None, overrides=overrides, progress=False).summary
    assert got["mesh"]["ranks"] == ranks and got["mesh"]["elements_per_rank"][0] == 0
    mine, theirs = got["adaptivity"]["steps"], want["adaptivity"]["steps"]
    assert got["adaptivity"]["stop_reason"] == want["adaptivity"]["stop_reason"]
    assert len(mine) == len(theirs) >= 3
    for key in ("ndof", "elements", "marked", "flagged"):
        assert [s[key] for s in mine] == [s[key] for s in theirs], key
    est = max(abs(a["estimate"] - b["estimate"]) / b["estimate"] for a, b in zip(mine, theirs))
    probes = max(abs(got["probes"][n]["final"] - p["final"]) / abs(p["final"]) for n, p in want["probes"].items())
    for key in ("vertices", "elements", "dofs"):
        assert got["mesh"][key] == want["mesh"][key], key
    print(f"\n{Path(scene).stem} {overrides} on {ranks} ranks: {len(mine)} steps, dofs {[s['ndof'] for s in mine]}, "
          f"marked {[s['marked'] for s in mine]}; max rel. difference to serial: estimates {est:.1e}, final probes "
          f"{probes:.1e}")
    assert est < TOLERANCE and probes < TOLERANCE
    return got


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("estimator", ["zz", "residual"])
def test_adaptive_heat_scene_distributed_takes_the_serial_steps(tmp_path, estimator):
    scene = tmp_path / "warm_lens.toml"
    scene.write_text(LENS)
    got = _compare(str(scene), tmp_path, [f"adaptivity.estimator={estimator}"])
    assert got["adaptivity"]["target"] == "heat" and got["adaptivity"]["estimator"] == estimator


@needs_mpi
@one_mpi_job
def test_adaptive_thermoelastic_scene_distributed_takes_the_serial_steps(tmp_path):
    got = _compare("heated_rock", tmp_path, ["mesh.maxh=4", "adaptivity.max_refinements=2"])
    assert got["adaptivity"]["target"] == "mechanics"


@needs_mpi
@one_mpi_job
def test_adaptive_heat_scene_four_workers(tmp_path):
    scene = tmp_path / "warm_lens.toml"
    scene.write_text(LENS)
    _compare(str(scene), tmp_path, ["mesh.maxh=0.1"], ranks=5)


def test_distributed_runs_refuse_only_the_followed_meshes():
    """Stationary adaptivity by the estimators (and the mesh adapted once) runs distributed; the contact-zone
    indicator and meshes that follow a phase boundary or contact zones over time are refused by their key (checked
    in-process, no MPI needed)."""
    from ngs_geomech.scene.parse import load_scene
    from ngs_geomech.validation.validate import distributed_problems

    assert distributed_problems(load_scene("heated_rock", ["adaptivity.max_refinements=2"])) == []
    problems = distributed_problems(load_scene("melting_block", ['adaptivity.indicators=["phase_front"]']))
    assert [p.item for p in problems] == ["adaptivity.indicators"]
    assert "phase_front" in problems[0].message
    problems = distributed_problems(load_scene("heated_rock", ['adaptivity.indicators=["contact_zone"]']))
    assert [p.item for p in problems] == ["adaptivity.indicators"] and "contact_zone" in problems[0].message
