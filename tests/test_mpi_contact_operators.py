"""The contact operators on a netgen distributed mesh (``mpiexec -n 3`` and ``-n 5``: 2 and 4 workers) equal the
serial ones: 3D (P1, P2) a punch on a block with non-matching meshes and a rigid foundation under the block, 2D (P1,
P2) two blocks and a foundation, and a curved (P2) disc on a block and on a foundation. Per multiplier node
(matched by coordinates): g0, weight, length, coverage and Bn u, Bt u (Bt2 u) for three linear or a linear and two
quadratic displacement fields, within 1e-12 relative in 3D (1e-9 in 2D, see :data:`TOLERANCE`); every rank holds
the same operator (:mod:`mpi_cases.contact_operators_case`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

pytestmark = pytest.mark.usefixtures("one_thread")
ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "tests" / "mpi_cases" / "contact_operators_case.py"
QUANTITIES = ("g0", "weight", "length", "coverage")
TOLERANCE = {"3d_p1": 1e-12, "3d_p2": 1e-12, "2d_p1": 1e-9, "2d_p2": 1e-9, "ball_p2": 1e-8}
"""The 2D operators integrate |dx/ds| of the serial mesh by a central difference of step 1e-6 (round-off ~1e-10
relative), the distributed ones the derivative of the segments' polynomial maps; the curved case's coverage of
its partly covered nodes also depends on grazing rays (see :func:`differences`)."""


def _run(out: Path, ranks: int | None) -> dict:
    cmd = [sys.executable, str(CASE), str(out)]
    if ranks is not None:
        cmd = [mpiexec(), "-n", str(ranks)] + cmd
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())


def _by_coordinates(item: dict) -> dict:
    """The nodal arrays of one contact in the order of the nodes' coordinates."""
    c = np.round(np.array(item["coords"]), 9)
    order = np.lexsort(c.T[::-1])
    out = {k: np.array(item[k])[order] for k in QUANTITIES}
    out["coords"] = np.array(item["coords"])[order]
    out["B_u"] = np.array(item["B_u"])[:, :, order]
    out["B_u_scale"] = np.array(item["B_u_scale"])[:, :, order]
    return out


def _diff(a: np.ndarray, b: np.ndarray, scale: float) -> float:
    return float(np.max(np.abs(a - b), initial=0.0)) / max(scale, 1e-300)


def differences(mine: dict, ref: dict) -> dict:
    """The largest differences of one contact's distributed arrays to the serial ones, relative to the size of the
    serial values: g0 to weight x search distance (|gap| <= search distance), B u to |B| |u| (the size of its
    terms: B u vanishes where both sides move alike); g0 and B u of the constrained (fully covered) nodes and, as
    "partial", of the others (which no solver constrains: at the edge of the covered part, rays grazing curved
    segments are found by Newton iterations with difference quotients, a few 1e-8 relative)."""
    a, b = _by_coordinates(mine), _by_coordinates(ref)
    assert a["coords"].shape == b["coords"].shape and np.allclose(a["coords"], b["coords"], atol=1e-12)
    out = {k: _diff(a[k], b[k], float(np.max(np.abs(b[k]), initial=0.0))) for k in ("weight", "length", "coverage")}
    full = b["coverage"] > 1 - 1e-6
    g0 = float(np.max(b["weight"])) * ref["search_distance"]
    out["g0"] = _diff(a["g0"][full], b["g0"][full], g0)
    out["B u"] = _diff(a["B_u"][:, :, full], b["B_u"][:, :, full], float(np.max(b["B_u_scale"])))
    out["partial g0"] = _diff(a["g0"][~full], b["g0"][~full], g0)
    out["partial B u"] = _diff(a["B_u"][:, :, ~full], b["B_u"][:, :, ~full], float(np.max(b["B_u_scale"])))
    return out


def compare(got: dict, want: dict) -> dict:
    """The largest relative difference (:func:`differences`) of the distributed operators ``got`` to the serial
    ``want`` per case, printed per contact; asserts that they have the same nodes and columns and that every rank
    held the same operator."""
    worst = {}
    for case, contacts in want.items():
        if case == "specs":
            continue
        for mine, ref in zip(got[case], contacts):
            assert mine["name"] == ref["name"] and mine["same_on_all_ranks"], (case, mine["name"])
            assert mine["columns"] == ref["columns"]
            assert mine["elements_per_rank"][0] == 0 and min(mine["elements_per_rank"][1:]) > 0
            diffs = differences(mine, ref)
            print(f"{case} {ref['name']}: {len(ref['coords'])} nodes, "
                  f"covered {int(np.sum(np.array(ref['coverage']) > 1 - 1e-6))}; "
                  + ", ".join(f"{k} {v:.1e}" for k, v in diffs.items()))
            worst[case] = max([worst.get(case, 0.0)] + [v for k, v in diffs.items() if not k.startswith("partial")])
            worst["partial"] = max(worst.get("partial", 0.0), diffs["partial g0"], diffs["partial B u"])
    return worst


def compare_specs(got: list[dict], want: list[dict]) -> None:
    """The contact specs of the scene on the distributed mesh equal the serial ones: kind, blocks, law and its nodal
    slip bounds, the operator's nodes and weights, the side's cells (the same triangles, oriented alike) and the
    number of the side's dofs; every rank holds the same spec."""
    assert [s["name"] for s in got] == [s["name"] for s in want]
    for mine, ref in zip(got, want):
        assert mine["same_on_all_ranks"], mine["name"]
        for key in ("kind", "blocks", "law", "columns", "side_dofs"):
            assert mine[key] == ref[key], (mine["name"], key)
        order = [np.lexsort(np.round(np.array(s["coords"]), 9).T[::-1]) for s in (mine, ref)]
        assert np.allclose(np.array(mine["coords"])[order[0]], np.array(ref["coords"])[order[1]], atol=1e-12)
        for key in ("weight", "bound") if ref["law"] == "tresca" else ("weight",):
            assert np.allclose(np.array(mine[key])[order[0]], np.array(ref[key])[order[1]], rtol=1e-12, atol=0)

        def triangles(item):      # each cell as its corners from the lowest one on, orientation kept
            out = set()
            for c in np.round(np.array(item["cells"]), 9):
                k = min(range(3), key=lambda i: tuple(c[i]))
                out.add(tuple(np.roll(c, -k, axis=0).ravel()))
            return out
        assert triangles(mine) == triangles(ref) and len(mine["cells"]) == len(ref["cells"]), mine["name"]
        print(f"specs {ref['name']} ({ref['kind']}, {ref['law']}, blocks {ref['blocks']}): {len(ref['coords'])} "
              f"nodes, {len(ref['cells'])} cells, {ref['side_dofs']} side dofs: equal")


@needs_mpi
@one_mpi_job
@pytest.mark.parametrize("ranks", [3, 5])
def test_distributed_contact_operators_equal_the_serial_ones(tmp_path, ranks):
    want = _run(tmp_path / "serial.json", None)
    got = _run(tmp_path / f"mpi{ranks}.json", ranks)
    print(f"\n{ranks} ranks ({ranks - 1} workers):")
    worst = compare(got, want)
    print("largest relative difference to serial per case: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    assert all(worst[case] < tol for case, tol in TOLERANCE.items()) and worst["partial"] < 1e-6, worst
    compare_specs(got["specs"], want["specs"])
    # the cases are not trivial: every contact has covered nodes, the interfaces and foundations see the other side
    for case, contacts in want.items():
        for item in contacts if case != "specs" else []:
            assert np.sum(np.array(item["coverage"]) > 1 - 1e-6) >= 3, item["name"]
