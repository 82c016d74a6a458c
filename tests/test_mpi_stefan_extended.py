"""A Stefan scene with a heat transfer (Robin) condition, plane, axisymmetric and plane with conductivities of depth,
on a netgen distributed mesh (3 MPI ranks, 2 workers; tests/mpi_cases/stefan_robin_case.py) equals the serial run:
the same Newton iterations, heats (the Robin exchange included) and melted volumes to round-off, the energy balance
closed."""

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

CASE = Path(__file__).resolve().parent / "mpi_cases" / "stefan_robin_case.py"


def _case():
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location("stefan_robin_case", CASE)
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@needs_mpi
@one_mpi_job
def test_robin_plane_and_axisymmetric_two_workers_equal_serial(tmp_path):
    out = tmp_path / "stefan_robin_mpi.json"
    proc = subprocess.run([mpiexec(), "-n", "3", sys.executable, str(CASE), str(out)], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    runs = json.loads(out.read_text())
    case = _case()
    for variant in case.VARIANTS:
        got, ref = runs[variant], case.solve(None, variant)
        heat = max_rel_difference(np.array(got["heat_gain"]), np.array(ref["heat_gain"]))
        robin = max_rel_difference(np.array(got["robin"]), np.array(ref["robin"]))
        melted = max_rel_difference(np.array(got["melted_volume"]["silt"]), np.array(ref["melted_volume"]["silt"]))
        print(f"\n{variant}: Newton {got['newton']} (serial {ref['newton']}); max rel. difference heat gain "
              f"{heat:.1e}, Robin heat {robin:.1e}, melted volume {melted:.1e}; imbalance {got['imbalance_rel']:.1e}")
        assert all(0 <= a - b <= 1 for a, b in zip(got["newton"], ref["newton"]))
        assert heat < 1e-8 and robin < 1e-8 and melted < 1e-8
        assert got["imbalance_rel"] < 1e-10 and ref["imbalance_rel"] < 1e-10
        assert ref["robin"][-1] > 0 and ref["melted_volume"]["silt"][-1] > 0.5
