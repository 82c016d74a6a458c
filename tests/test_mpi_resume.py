"""Checkpoints and ``--resume`` of distributed runs (``mpiexec -n N``, tests/mpi_cases/resume_case.py): a run on 3
ranks (2 workers) stopped by a failing thermal solve saves its last good state (rank 0 writes one checkpoint, the
vectors in the partition-independent numbering of :mod:`ngs_geomech.run.numbering`); resumed on 3 ranks it equals
the uninterrupted distributed run to round-off, resumed on 5 ranks or serially to the solver tolerances; a
checkpoint of another scene is refused naming the key; a serial run's checkpoint of an order-1 (Stefan) scene
resumes distributed; a contact scene's checkpoint (the contact solver's warm start follows the partition) resumes on
the same rank count to round-off and is refused on another.

Scenes: the warm slab with thermal stresses of tests/test_mpi_scenes.py (P2, curved inclusion, k(T), hardening
lambda law, deformation heating, iterated coupling; 10 steps), the built-in ``melting_block`` (Stefan, P1) and the
Tresca stack of tests/test_mpi_contact.py loaded over 4 steps (3D, P1, PETSc)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech import parallel
from ngs_geomech.api import run
from ngs_geomech.errors import SolverError
from ngs_geomech.io.checkpoint import load_checkpoint
from ngs_geomech.linalg import petsc

pytestmark = [pytest.mark.usefixtures("one_thread"), needs_mpi, one_mpi_job]

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "tests" / "mpi_cases" / "resume_case.py"
COUPLED_SETS = ["output.checkpoint_every=2", "output.figures=false"]
STEFAN_SETS = ["mesh.maxh=0.35", "time.end='30 day'", "time.dt='5 day'", "time.dt_growth=1.0",
               "output.checkpoint_every=2", "output.figures=false"]


def _case():
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location("resume_case", CASE)
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def launch(ranks: int, scene: str, out: Path, sets: list[str], *extra: str) -> dict:
    """The case on ``ranks`` ranks; its RESULT.json."""
    result = out.parent / f"{out.name}-{ranks}-{len(list(out.parent.glob('*.json')))}.json"
    cmd = [mpiexec(), "-n", str(ranks), sys.executable, str(CASE), scene, str(out), str(result), *extra]
    for s in sets:
        cmd += ["--set", s]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=parallel.launch_environment())
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads(result.read_text())


def staging(parent: Path, name: str = "OUT") -> Path:
    (d,) = [p for p in parent.glob(f".{name}.partial-*") if p.is_dir()]
    return d


def copy_interrupted(src: Path, dst_parent: Path) -> Path:
    """A copy of the interrupted run's staging directory beside ``dst_parent/OUT`` (another resume of it)."""
    dst_parent.mkdir()
    d = staging(src)
    shutil.copytree(d, dst_parent / d.name)
    return dst_parent / "OUT"


def differences(got: dict, ref: dict) -> dict:
    """Relative 2-norm differences of the canonical state vectors."""
    assert set(got) == set(ref) and got
    return {n: float(np.linalg.norm(np.subtract(got[n], ref[n])) / max(np.linalg.norm(ref[n]), 1e-300))
            for n in ref}


def probe_difference(got: dict, ref: dict) -> float:
    worst = 0.0
    for n, v in ref["probe_series"].items():
        if n == "times_s" or not isinstance(v, list):
            continue
        a, b = np.array(got["probe_series"][n], dtype=float), np.array(v, dtype=float)
        worst = max(worst, float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)))
    return worst


def interrupted(tmp_path: Path, scene: str, sets: list[str], fail_at: int) -> tuple[Path, dict]:
    out = tmp_path / "a" / "OUT"
    out.parent.mkdir()
    got = launch(3, scene, out, sets, "--fail-at", str(fail_at))
    assert got["error"] is not None and "injected divergence" in got["error"] and "--resume" in got["error"]
    assert not out.exists()
    cp = load_checkpoint(staging(out.parent) / "checkpoint")
    assert cp.meta["numbering"] == "canonical" and cp.meta["ranks"] == 3
    return out, cp.meta


def test_thermoelastic_distributed_run_resumes_on_any_rank_count(tmp_path):
    from test_mpi_scenes import COUPLED

    scene = tmp_path / "slab.toml"
    scene.write_text(COUPLED)
    ref = launch(3, str(scene), tmp_path / "REF", COUPLED_SETS)
    assert ref["error"] is None and ref["summary"]["steps"] == 10
    out, meta = interrupted(tmp_path, str(scene), COUPLED_SETS, 13)
    assert 1 <= meta["step"] < 10
    again = [copy_interrupted(out.parent, tmp_path / k) for k in ("b", "c", "d")]

    same = launch(3, str(scene), out, COUPLED_SETS, "--resume")
    assert same["error"] is None and same["summary"]["resumed"][0]["step"] == meta["step"]
    d3, p3 = differences(same["state"], ref["state"]), probe_difference(same["summary"], ref["summary"])
    five = launch(5, str(scene), again[0], COUPLED_SETS, "--resume")
    d5, p5 = differences(five["state"], ref["state"]), probe_difference(five["summary"], ref["summary"])
    serial = run(str(scene), again[1], overrides=COUPLED_SETS, progress=False, resume=True)
    ds = differences(_case().canonical_state(serial), ref["state"])
    print(f"\nstopped after step {meta['step']} of 10; final state vs the uninterrupted 3-rank run (relative): "
          f"resumed on 3 ranks {d3} (probes {p3:.1e}), on 5 ranks {d5} (probes {p5:.1e}), serially {ds}")
    assert max(d3.values()) <= 1e-10 and p3 <= 1e-10
    assert max(d5.values()) <= 1e-8 and p5 <= 1e-8
    assert max(ds.values()) <= 1e-8
    assert five["summary"]["mesh"]["ranks"] == 5 and five["summary"]["steps"] == 10
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in (tmp_path / "REF").iterdir())

    refused = launch(3, str(scene), again[2], [*COUPLED_SETS, "materials.rock.conductivity=3.0"], "--resume")
    assert "the scene differs from the checkpointed run's" in refused["error"]
    assert "materials.rock.conductivity: 2.5 in the checkpoint, 3.0 now" in refused["error"]
    assert not again[2].exists()


def test_stefan_checkpoints_move_between_serial_and_distributed_runs(tmp_path, monkeypatch):
    ref = launch(3, "melting_block", tmp_path / "REF", STEFAN_SETS)
    assert ref["error"] is None and ref["summary"]["steps"] == 6
    out, meta = interrupted(tmp_path, "melting_block", STEFAN_SETS, 4)
    assert 1 <= meta["step"] < 6
    other = copy_interrupted(out.parent, tmp_path / "b")
    same = launch(3, "melting_block", out, STEFAN_SETS, "--resume")
    d3 = differences(same["state"], ref["state"])
    serial = run("melting_block", other, overrides=STEFAN_SETS, progress=False, resume=True)
    ds = differences(_case().canonical_state(serial), ref["state"])

    # a serial run's checkpoint (P1: the serial numbering is the canonical one) resumed on 3 ranks
    case = _case()
    case.fail_thermal_solve_at(4, monkeypatch.setattr)
    sdir = tmp_path / "s" / "OUT"
    sdir.parent.mkdir()
    with pytest.raises(SolverError, match="injected divergence"):
        run("melting_block", sdir, overrides=STEFAN_SETS, progress=False)
    monkeypatch.undo()
    cp = load_checkpoint(staging(sdir.parent) / "checkpoint")
    assert cp.meta["numbering"] == "serial" and 1 <= cp.meta["step"] < 6
    from_serial = launch(3, "melting_block", sdir, STEFAN_SETS, "--resume")
    df = differences(from_serial["state"], ref["state"])
    print(f"\nStefan, stopped after step {meta['step']} of 6 (serial run: {cp.meta['step']}); final enthalpy vs "
          f"the uninterrupted 3-rank run (relative): resumed on 3 ranks {d3}, serially {ds}; a serial checkpoint "
          f"resumed on 3 ranks {df}")
    assert max(d3.values()) <= 1e-10
    assert max(ds.values()) <= 1e-8 and max(df.values()) <= 1e-8


@pytest.mark.skipif(not petsc.available(), reason="petsc4py not installed (extra 'petsc')")
def test_contact_checkpoint_resumes_on_any_rank_count(tmp_path):
    """The Tresca stack of tests/test_mpi_contact.py (P1) loaded over 4 time steps: stopped by its solve of step 3, the
    contact solver's warm start (node arrays stored with their coordinates) resumes on 3 ranks to the uninterrupted
    run's state, and on 5 ranks (another partition: another node order) to the solver tolerance."""
    from ngs_geomech.verification.distributed_contact import stack_scene

    data = stack_scene("tresca", 0.4, 1)
    data["time"] = {"end": 4.0, "dt": 1.0}
    data["boundary_conditions"]["top"] = {"pressure": "2e5 * (1 + t)"}
    data["output"]["checkpoint_every"] = 1
    scene = tmp_path / "stack.json"
    scene.write_text(json.dumps(data))
    ref = launch(3, str(scene), tmp_path / "REF", [])
    out = tmp_path / "a" / "OUT"
    out.parent.mkdir()
    got = launch(3, str(scene), out, [], "--fail-contact-at", "4")
    assert "injected divergence" in got["error"] and "--resume" in got["error"]
    cp = load_checkpoint(staging(out.parent) / "checkpoint")
    assert cp.meta["step"] == 2 and any(k.startswith("warm/") for k in cp.arrays)
    other = copy_interrupted(out.parent, tmp_path / "b")
    same = launch(3, str(scene), out, [], "--resume")
    d3 = differences(same["state"], ref["state"])
    print(f"\ncontact stack stopped after step 2 of 4, resumed on 3 ranks: relative difference {d3}")
    assert max(d3.values()) <= 1e-10
    five = launch(5, str(scene), other, [], "--resume")
    d5 = differences(five["state"], ref["state"])
    print(f"resumed on 5 ranks: relative difference {d5}")
    assert max(d5.values()) <= 1e-8
