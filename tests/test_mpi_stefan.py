"""The Stefan problem (enthalpy form, semi-smooth Newton) on a netgen distributed mesh: 3 MPI ranks (2 workers,
rank 0 keeps no elements) run the built-in scene ``melting_block`` through :class:`StefanRun`
(tests/mpi_cases/stefan_case.py), with each Krylov preconditioner of the distributed Newton path (Jacobi, BDDC),
and equal the serial run (SuperLU path) in this process: temperatures at sample points to the Newton / GMRES
tolerance, the same Newton iterations (+1 at most), melted volumes, heat content, heats per step and phase
boundary to round-off; the same for the one-phase Neumann strip (a mushy region held fixed in the Newton
steps). A contact-interface scene is refused on the distributed mesh with a clear message."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.verification.scaling import max_rel_difference

pytestmark = pytest.mark.usefixtures("one_thread")

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "tests" / "mpi_cases" / "stefan_case.py"
PRECONDITIONERS = ("jacobi", "bddc")


def _case():
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location("stefan_case", CASE)
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@needs_mpi
@one_mpi_job
def test_stefan_two_workers_equal_serial(tmp_path):
    out = tmp_path / "stefan_mpi.json"
    proc = subprocess.run([mpiexec(), "-n", "3", sys.executable, str(CASE), str(out), *PRECONDITIONERS],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    runs = json.loads(out.read_text())
    case = _case()
    ref = case.solve(None)
    for name in PRECONDITIONERS:
        got = runs[name]
        assert got["elements_per_rank"][0] == 0 and all(n > 0 for n in got["elements_per_rank"][1:])
        assert got["vertices"] == ref["vertices"]
        dT = max_rel_difference(np.array(got["temperature"]), np.array(ref["temperature"]))
        melted = {r: max_rel_difference(np.array(got["melted_volume"][r]), np.array(v))
                  for r, v in ref["melted_volume"].items()}
        heat = max_rel_difference(np.array(got["heat_content"]), np.array(ref["heat_content"]))
        supplied = max_rel_difference(np.array(got["boundary_heat"]) + np.array(got["source_heat"]),
                                      np.array(ref["boundary_heat"]) + np.array(ref["source_heat"]))
        print(f"\n{name}: Newton {got['newton']} (serial {ref['newton']}), GMRES per Newton solve {got['krylov']} "
              f"(max true rel. residual {got['krylov_residual_max']:.1e}); max rel. difference T {dT:.1e}, melted "
              f"volume {max(melted.values()):.1e}, heat content {heat:.1e}, heat supplied {supplied:.1e}; "
              f"imbalance {got['imbalance_rel']:.1e}")
        assert dT < 1e-6
        assert all(0 <= a - b <= 1 for a, b in zip(got["newton"], ref["newton"]))
        assert got["phase_changes"] == ref["phase_changes"]
        assert max(melted.values()) < 1e-8 and heat < 1e-8 and supplied < 1e-8
        assert ref["melted_volume"]["silt"][-1] > 0.5          # the thaw front moved: a two-phase problem
        assert got["volume"] == pytest.approx(ref["volume"], rel=1e-12)
        assert got["imbalance_rel"] < 1e-10
        assert got["krylov_unconverged"] == 0 and got["krylov_residual_max"] < 1e-8
        # the phase boundary gathered over the parts: the same segments as the serial one
        assert got["phase_boundary_segments"] == ref["phase_boundary_segments"] > 0
        assert got["phase_boundary_length"] == pytest.approx(ref["phase_boundary_length"], rel=1e-8)
        assert got["phase_boundary_temperature_max_abs"] == pytest.approx(
            ref["phase_boundary_temperature_max_abs"], rel=1e-6, abs=1e-9)
    assert np.mean(runs["bddc"]["krylov"]) < np.mean(runs["jacobi"]["krylov"])
    # the one-phase strip: a mushy region ahead of the front (fixed dofs of the Newton steps)
    got, want = runs["one_phase"], case.one_phase_strip(None)
    dT = max_rel_difference(np.array(got["temperature"]), np.array(want["temperature"]))
    print(f"one-phase strip: Newton {sum(got['newton'])} in {len(got['newton'])} steps (serial "
          f"{sum(want['newton'])}), GMRES mean {np.mean(got['krylov']):.1f}, BDDC builds {got['builds']}; max rel. "
          f"difference T {dT:.1e}")
    assert dT < 1e-6 and all(0 <= a - b <= 1 for a, b in zip(got["newton"], want["newton"]))
    assert got["heat_content"] == pytest.approx(want["heat_content"], rel=1e-8)
    assert got["melted_volume"] == pytest.approx(want["melted_volume"], rel=1e-8)
    assert "not supported" in runs["contact"] and "MPI" in runs["contact"]
