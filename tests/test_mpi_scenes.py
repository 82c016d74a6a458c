"""Distributed scene runs (issue 10): ``mpiexec -n 3 ngs-geomech run SCENE`` (3 ranks = 2 workers: netgen keeps no
elements on rank 0) against the serial run of the same scene in this process, through the command line and the
whole output pipeline:

* ``heated_rock``: steady heat (anisotropic) + static thermal stresses, plane strain, P2, symmetry planes;
* a transient thermal scene with a temperature-dependent conductivity (k(T): Newton with GMRES on the
  distributed mesh), a curved inclusion (P2, the parts curved with the geometry) and Crank-Nicolson steps;
* the same with thermal stresses (hardening lambda law, secant method) and deformation heating, iterated in each
  step (problem (P_c) without contact);
* ``melting_block``: the Stefan problem (enthalpy form), a few steps;

the probes of summary.json equal the serial ones to the solver tolerances; the output is complete (one VTK part
per worker and time, a .pvd listing every part, figures, summary.json with the rank layout). Scenes the distributed
run cannot do (contact interfaces) stop with an error naming the key before any output is written."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mpi_cases.launch import mpiexec, needs_mpi, one_mpi_job

from ngs_geomech.api import run
from ngs_geomech.linalg import petsc

pytestmark = pytest.mark.usefixtures("one_thread")

THERMAL = """
[scene]
name = "warm_slab"
dimension = "plane"

[physics]
thermal = "transient"

[mesh]
maxh = 0.15
order = 2

[[blocks]]
name = "rock"
shape = "rectangle"
origin = [0.0, 0.0]
size = [2.0, 1.0]
boundaries = { left = "xmin", right = "xmax", bottom = "ymin", top = "ymax" }

[[blocks]]
name = "lens"                  # a curved inclusion: the distributed mesh is curved with the geometry as well
shape = "circle"
center = [1.0, 0.5]
radius = 0.25

[[interfaces]]
name = "lens_wall"
blocks = ["rock", "lens"]
type = "glued"

[materials.lens]
conductivity = 6.0
rho_c = 2.0e6

[materials.rock]
conductivity = 2.5
conductivity_temperature_coefficient = -0.002
reference_temperature = 10.0
rho_c = 2.2e6

[boundary_conditions.left]
temperature = "10 + 40 * tanh(t / (5 * day))"

[boundary_conditions.right]
temperature = 10.0

[initial]
temperature = 10.0

[time]
end = "20 day"
dt = "2 day"

[[output.probes]]
name = "centre_T"
quantity = "temperature"
point = [0.3, 0.5]

[[output.probes]]
name = "mean_T"
quantity = "temperature"
region = "rock"
statistic = "mean"

[[output.probes]]
name = "lens_mean_T"
quantity = "temperature"
region = "lens"
statistic = "mean"

[[output.probes]]
name = "max_T_top"
quantity = "temperature"
boundary = "top"
statistic = "max"
"""


COUPLED = THERMAL.replace('thermal = "transient"', 'thermal = "transient"\nmechanics = "static"\n'
                          'plane_model = "plane_strain"\ncoupling = "iterated"').replace(
    'rho_c = 2.2e6\n', 'rho_c = 2.2e6\ndensity = 2600.0\nyoungs_modulus = 50e9\npoisson_ratio = 0.25\n'
    'thermal_expansion = 8e-6\nstress_free_temperature = 10.0\nrheology_lambda = 1.3\n').replace(
    'rho_c = 2.0e6\n', 'rho_c = 2.0e6\ndensity = 2600.0\nyoungs_modulus = 30e9\npoisson_ratio = 0.25\n'
    'thermal_expansion = 8e-6\nstress_free_temperature = 10.0\nrheology_lambda = 1.3\n').replace(
    '[boundary_conditions.right]\ntemperature = 10.0', '[boundary_conditions.right]\ntemperature = 10.0\n'
    'symmetry = true\n\n[boundary_conditions.bottom]\nsymmetry = true') + """
[mechanics]
nonlinear_solver = "secant"

[[output.probes]]
name = "max_von_mises"
quantity = "von_mises"
region = "rock"
statistic = "max"

[[output.probes]]
name = "corner_uy"
quantity = "displacement_y"
point = [0.1, 0.95]
"""
"""The warm slab with thermal stresses (hardening lambda law, secant method) and deformation heating, iterated
within each step (problem (P_c) without contact)."""


def _distributed(scene: str, out: Path, overrides: list[str], ranks: int = 3) -> subprocess.CompletedProcess:
    cmd = [mpiexec(), "-n", str(ranks), sys.executable, "-m", "ngs_geomech.cli", "run", scene, "--out", str(out),
           "--quiet", "--threads", "1"]
    for o in overrides:
        cmd += ["--set", o]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def _compare(scene: str, tmp_path: Path, overrides: list[str], tol: float) -> tuple[dict, dict]:
    out = tmp_path / "mpi"
    proc = _distributed(scene, out, overrides)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.count("wrote") == 1 and "3 MPI ranks" in proc.stdout      # said once, by rank 0
    got = json.loads((out / "summary.json").read_text())
    want = run(scene, None, overrides=overrides, progress=False).summary
    assert got["mesh"]["ranks"] == 3
    assert got["mesh"]["elements_per_rank"][0] == 0 and all(n > 0 for n in got["mesh"]["elements_per_rank"][1:])
    for key in ("vertices", "elements", "dofs"):
        assert got["mesh"][key] == want["mesh"][key], key
    assert got["steps"] == want["steps"]
    worst = 0.0
    for name, series in want["probe_series"].items():
        if name in ("time_s", "times_s"):
            continue
        mine = got["probe_series"][name]
        assert len(mine) == len(series)
        assert [a is None for a in mine] == [b is None for b in series], name     # front probes: no crossing yet
        scale = max((abs(b) for b in series if b is not None), default=0.0) or 1.0
        worst = max([worst] + [abs(a - b) / scale for a, b in zip(mine, series) if b is not None])
    print(f"\n{scene}: {got['mesh']['dofs']} dofs on {got['mesh']['elements_per_rank']} elements per rank; "
          f"max rel. difference of the probes to serial {worst:.1e}; wall {got['wall_time_s']['total_s']:.1f} s "
          f"(serial {want['wall_time_s']['total_s'] if 'wall_time_s' in want else float('nan'):.1f} s)")
    assert worst < tol
    # complete output: each worker's part at every output time, one collection listing them all
    name = got["scene"]["scene"]["name"]
    pvd = (out / f"{name}.pvd").read_text()
    for rank in (1, 2):
        parts = sorted(out.glob(f"{name}*_proc{rank}.vtu"))
        assert parts and all(f'file="{p.name}"' in pvd for p in parts)
    assert not list(out.glob(".*tmp*")) and not list(tmp_path.glob(".mpi.partial-*"))
    return got, want


@needs_mpi
@one_mpi_job
def test_thermoelastic_scene_two_workers_equal_serial(tmp_path):
    got, _ = _compare("heated_rock", tmp_path, ["mesh.maxh=4"], 1e-8)
    figs = {p.name for p in (tmp_path / "mpi" / "figures").glob("*.png")}
    assert {"temperature.png", "von_mises.png", "principal_stress.png"} <= figs


@needs_mpi
@one_mpi_job
def test_transient_nonlinear_thermal_scene_two_workers_equal_serial(tmp_path):
    scene = tmp_path / "warm_slab.toml"
    scene.write_text(THERMAL)
    got, want = _compare(str(scene), tmp_path, [], 1e-8)
    assert got["newton_iterations_max"] >= 2                  # k(T): Newton steps (GMRES on the distributed mesh)
    assert got["probe_series"]["centre_T"][-1] > 15.0        # the heat went in


@pytest.mark.slow          # 19 s alone, 40-70 s beside the suite's other worker (MPI ranks poll): on demand
@needs_mpi
@one_mpi_job
def test_coupled_thermoelastic_scene_two_workers_equal_serial(tmp_path):
    scene = tmp_path / "warm_slab_coupled.toml"
    scene.write_text(COUPLED)
    got, want = _compare(str(scene), tmp_path, ["time.end=6 day", "mesh.maxh=0.3"], 1e-7)
    c, w = got["coupling"], want["coupling"]
    print(f"coupling passes per step {c['passes_per_step']} (serial {w['passes_per_step']}), deformation heat "
          f"{c['deformation_heat_total']:.6e} (serial {w['deformation_heat_total']:.6e}) J/m")
    assert c["passes_per_step"] == w["passes_per_step"] and c["passes_per_step"]["max"] >= 2
    assert c["deformation_heat_total"] == pytest.approx(w["deformation_heat_total"], rel=1e-7)
    assert abs(w["deformation_heat_total"]) > 0
    assert got["probe_series"]["max_von_mises"][-1] > 1e6


@needs_mpi
@one_mpi_job
def test_stefan_scene_two_workers_equal_serial(tmp_path):
    got, want = _compare("melting_block", tmp_path, ["time.end=20 day", "time.dt=5 day", "mesh.maxh=0.3"], 1e-6)
    assert got["newton_iterations_max"] == want["newton_iterations_max"] >= 2
    assert (tmp_path / "mpi" / "figures" / "phase_boundary.png").exists()


@needs_mpi
@one_mpi_job
@pytest.mark.skipif(not petsc.available(), reason="distributed contact needs petsc4py (extra 'petsc')")
def test_axisymmetric_contact_scene_with_heat_across_the_gap_equals_serial(tmp_path):
    """canister_gap: axisymmetric, the canister in frictionless contact with its buffer (a floating body), heat across
    the gap; both runs iterative to 1e-13 (at the default 1e-10 the two preconditioners leave 1e-6 in a small
    displacement)."""
    got, want = _compare("canister_gap", tmp_path, ["solver.linear=iterative", "solver.tolerance=1e-13"], 1e-8)
    c, w = got["mechanics"]["contact"], want["mechanics"]["contact"]
    assert c["iterations_per_solve"] == w["iterations_per_solve"]


@needs_mpi
@one_mpi_job
@pytest.mark.skipif(not petsc.available(), reason="distributed contact needs petsc4py (extra 'petsc')")
def test_plane_contact_scene_with_softening_equals_serial(tmp_path):
    """fault_wedge: plane strain, a Coulomb fault with a softening (lambda = 0.9) wedge, the secant method inside
    the contact solve."""
    got, want = _compare("fault_wedge", tmp_path, ["solver.linear=iterative", "solver.tolerance=1e-13"], 1e-8)
    c, w = got["mechanics"]["contact"], want["mechanics"]["contact"]
    assert c["iterations_per_solve"] == w["iterations_per_solve"]
    f, g = c["interfaces"]["fault"], w["interfaces"]["fault"]
    assert f["normal_force"] == pytest.approx(g["normal_force"], rel=1e-8)


@needs_mpi
@one_mpi_job
def test_contact_scene_refused_before_any_output(tmp_path):
    """Through the command line (2 ranks: the refusal comes before any mesh is made or distributed)."""
    out = tmp_path / "mpi"
    proc = _distributed("fault_heating", out, [], ranks=2)
    assert proc.returncode != 0
    assert proc.stderr.count("ngs-geomech: error:") == 1
    assert "interfaces[0] (fault).frictional_heating" in proc.stderr and "distributed runs" in proc.stderr
    assert not out.exists() and not list(tmp_path.glob(".mpi.partial-*"))


def test_distributed_problems_name_the_keys():
    """What a distributed run refuses, checked in-process (no MPI needed)."""
    from ngs_geomech.scene.parse import load_scene
    from ngs_geomech.validation.validate import distributed_problems

    assert distributed_problems(load_scene("heated_rock")) == []
    assert distributed_problems(load_scene("melting_block")) == []
    items = {p.item for p in distributed_problems(load_scene("fault_heating"))}
    assert "interfaces[0] (fault).frictional_heating" in items
    assert "--resume" not in items                # distributed runs write checkpoints and resume
    if petsc.available():        # heat crosses its fracture by the mortar coupling (tests/test_mpi_heat_contact.py)
        assert distributed_problems(load_scene("repository_fracture_3d")) == []
    items = {p.item for p in distributed_problems(load_scene("contact_melting"))}
    assert "interfaces[1] (bedding)" in items               # heat across a contact in a Stefan scene
    items = {p.item for p in distributed_problems(load_scene(
        "heated_rock", ["solver.linear=direct", "mechanics.nested_levels=1", "physics.mechanics=dynamic"]))}
    assert {"solver.linear", "mechanics.nested_levels", "physics.mechanics"} <= items
