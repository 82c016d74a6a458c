"""The command line and what a run writes: ``list``, ``run`` (VTK series, figures, summary.json), replacing
an older output, leaving nothing behind when a run fails, and the 3D (``block3d``) and curved-fault
(``fault2d``) scenes.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech import cli
from ngs_geomech.api import run
from ngs_geomech.errors import SolverError
from ngs_geomech.heat.solver import HeatSolver

GEOMETRIES = Path(__file__).resolve().parents[1] / "geometries"


# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_cli_output")]


def leftovers(parent: Path, name: str) -> list[Path]:
    """Staging or backup directories a run may have left beside its output ``parent/name``."""
    return [p for p in parent.iterdir() if p.name.startswith(f".{name}.")]


def pvd_files(pvd: Path) -> list[str]:
    return re.findall(r'file="([^"]+)"', pvd.read_text())


def test_list_shows_the_builtin_scenes(capsys):
    assert cli.main(["list"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    names = [line.split()[0] for line in out.splitlines()]
    assert {"canister", "block3d", "fault2d"} <= set(names)


# -- the canister scene, shortened ------------------------------------------------------------------

@pytest.fixture(scope="module")
def canister_run(tmp_path_factory):
    """One short canister run through the command line (in its own working directory)."""
    cwd = tmp_path_factory.mktemp("canister")
    mp = pytest.MonkeyPatch()
    mp.chdir(cwd)
    try:
        rc = cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='2 year'", "--quiet"])
    finally:
        mp.undo()
    assert rc == 0
    return cwd


def test_run_writes_vtk_series_listed_in_pvd(canister_run):
    out = canister_run / "DIR"
    pvd = out / "canister.pvd"
    assert pvd.is_file()
    listed = pvd_files(pvd)
    assert len(listed) >= 2
    for f in listed:
        assert (out / f).is_file() and (out / f).stat().st_size > 0, f
    assert sorted(p.name for p in out.glob("*.vtu")) == sorted(listed)
    times = [float(t) for t in re.findall(r'timestep="([^"]+)"', pvd.read_text())]
    assert times == sorted(times) and times[0] == 0.0
    assert times[-1] == pytest.approx(2 * 365.25 * 86400, rel=1e-5)
    # every field is in the files
    text = (out / listed[-1]).read_text(errors="replace")
    for field in ("temperature", "region", "heat_flux"):
        assert f'Name="{field}"' in text


def test_run_writes_figures(canister_run):
    figs = sorted(p.name for p in (canister_run / "DIR" / "figures").glob("*.png"))
    assert {"temperature.png", "probes.png", "temperature_zoom.png"} <= set(figs)
    for f in (canister_run / "DIR" / "figures").glob("*.png"):
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_run_writes_summary(canister_run):
    summary = json.loads((canister_run / "DIR" / "summary.json").read_text())
    for key in ("scene", "versions", "wall_time_s", "probes", "mesh"):
        assert key in summary, key
    assert summary["scene"]["scene"]["name"] == "canister"
    assert summary["scene"]["time"]["end"] == pytest.approx(2 * 365.25 * 86400)   # the --set value
    assert "ngsolve" in summary["versions"]
    assert summary["wall_time_s"]["total_s"] > 0
    assert summary["mesh"]["elements"] > 0 and summary["mesh"]["vertices"] > 0
    assert set(summary["probes"]) == {"buffer_max", "canister_max", "hole_wall_mid", "rock_5m", "rock_20m"}
    for name, stats in summary["probes"].items():
        assert math.isfinite(stats["max"]) and math.isfinite(stats["time_of_max"]), name
        assert 0 <= stats["time_of_max"] <= summary["scene"]["time"]["end"]
    # the canister heats up: the hottest point is hotter than the initial 11.5 C
    assert summary["probes"]["canister_max"]["max"] > 20.0


def test_run_output_is_clean_with_ordinary_permissions(canister_run):
    """The output looks as if written directly: no temporary names, permissions from the umask (the
    staging directory and temporary files are created 0700 / 0600 by tempfile)."""
    out = canister_run / "DIR"
    umask = os.umask(0)
    os.umask(umask)
    for p in [out, *out.rglob("*")]:
        expected = (0o777 if p.is_dir() else 0o666) & ~umask
        assert stat.S_IMODE(p.stat().st_mode) == expected, f"{p}: {oct(p.stat().st_mode)}"
    assert leftovers(canister_run, "DIR") == []
    assert not list(out.rglob(".*")), "no temporary files inside the output"


def test_second_run_replaces_the_output(tmp_path, monkeypatch, capsys):
    """The files of the first run are replaced or removed (its longer VTK series); a file the user put into
    the output directory stays."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='60 day'", "--quiet"]) == 0
    (tmp_path / "DIR" / "notes.txt").write_text("the user's")
    first = json.loads((tmp_path / "DIR" / "summary.json").read_text())
    assert cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='30 day'", "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert "wrote" in out
    second = json.loads((tmp_path / "DIR" / "summary.json").read_text())
    assert (tmp_path / "DIR" / "notes.txt").read_text() == "the user's"
    assert second["scene"]["time"]["end"] == pytest.approx(first["scene"]["time"]["end"] / 2)
    assert sorted(p.name for p in (tmp_path / "DIR").glob("*.vtu")) == sorted(pvd_files(tmp_path / "DIR" /
                                                                                          "canister.pvd"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["DIR"]


def solver_fails_at_call(monkeypatch, n: int) -> dict:
    original = HeatSolver.solve
    calls = {"n": 0}

    def solve(self, where):
        calls["n"] += 1
        if calls["n"] == n:
            raise SolverError(f"heat solve at {where} diverged (injected by the test)")
        return original(self, where)
    monkeypatch.setattr(HeatSolver, "solve", solve)
    return calls


def test_run_failing_at_the_first_step_leaves_nothing(tmp_path, monkeypatch, capsys):
    calls = solver_fails_at_call(monkeypatch, 1)
    monkeypatch.chdir(tmp_path)
    rc = cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='2 year'", "--quiet"])
    out, err = capsys.readouterr()
    assert rc == 2 and calls["n"] == 1
    assert "step 1" in err and "diverged" in err
    assert "Traceback" not in err and "--resume" not in err     # no step done: nothing to resume
    assert list(tmp_path.iterdir()) == []


def test_run_failing_in_the_middle_leaves_no_output_but_a_checkpoint(tmp_path, monkeypatch, capsys):
    """No DIR (output complete or absent); the staging directory stays with the last good state for --resume
    (tests/test_checkpoint.py resumes such runs)."""
    calls = solver_fails_at_call(monkeypatch, 3)
    monkeypatch.chdir(tmp_path)
    rc = cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='2 year'", "--quiet"])
    out, err = capsys.readouterr()
    assert rc == 2
    assert calls["n"] == 3
    assert "step 3" in err and "diverged" in err
    assert "The last good state (step 2 of" in err and "--resume" in err
    assert "Traceback" not in err
    assert not (tmp_path / "DIR").exists()
    (staging,) = [p for p in leftovers(tmp_path, "DIR") if p.is_dir()]
    assert (staging / "checkpoint" / "checkpoint.npz").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([staging.name, f"{staging.name}.lock"])


def test_run_failing_in_the_middle_keeps_the_older_output(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='30 day'", "--quiet"]) == 0
    before = {p.relative_to(tmp_path): p.read_bytes() for p in (tmp_path / "DIR").rglob("*") if p.is_file()}
    solver_fails_at_call(monkeypatch, 3)
    assert cli.main(["run", "canister", "--out", "DIR", "--set", "time.end='2 year'", "--quiet"]) == 2
    after = {p.relative_to(tmp_path): p.read_bytes() for p in (tmp_path / "DIR").rglob("*") if p.is_file()}
    assert after == before
    assert all(p.name.startswith(".DIR.partial-") for p in leftovers(tmp_path, "DIR"))   # the checkpoint only


# -- 3D: glued inclusion, contact with a non-matching mesh -----------------------------------------

@pytest.fixture(scope="module")
def block3d(tmp_path_factory):
    out = tmp_path_factory.mktemp("block3d") / "out"
    result = run("block3d", out, progress=False)
    return result, out


def test_block3d_runs_and_writes(block3d):
    result, out = block3d
    assert result.out == out.resolve()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["mesh"]["regions"] == ["host", "ore", "neighbour"]
    assert (out / "block3d.pvd").is_file()          # a steady run has a one-entry series
    assert pvd_files(out / "block3d.pvd") == ["block3d.vtu"]
    assert (out / "block3d.vtu").is_file()
    assert summary["probes"]["ore_max"]["max"] > 20.0     # the source heats the ore above both faces


def test_block3d_contact_meshes_do_not_match(block3d):
    result, _ = block3d
    mesh = result.mesh
    sides = {}
    for name in ("joint__host", "joint__neighbour"):
        verts = {v.nr for el in mesh.Boundaries(name).Elements() for v in el.vertices}
        sides[name] = verts
    assert not sides["joint__host"] & sides["joint__neighbour"]
    assert len(sides["joint__host"]) > len(sides["joint__neighbour"])


def test_block3d_heat_passes_the_contact_interface(block3d):
    result, out = block3d
    summary = json.loads((out / "summary.json").read_text())
    flow = summary["interface_heat_flow_W"]["joint__host"][-1]
    assert flow > 1.0        # W from the host into the neighbour, a sizeable part of the 50 W source
    mesh, forms = result.mesh, result.forms
    T = forms.temperature()
    n = ngs.specialcf.normal(3)
    q = ngs.BoundaryFromVolumeCF(forms.heat_flux(T))

    def outflow(name):
        return ngs.Integrate(q * n * ngs.ds(definedon=mesh.Boundaries(name)), mesh)
    # everything that crosses the contact leaves through the cold face; the source leaves through both faces
    assert outflow("cold_face") == pytest.approx(flow, rel=0.02)
    assert outflow("hot_face") + outflow("cold_face") == pytest.approx(50.0, rel=0.02)


def test_block3d_temperature_is_continuous_across_the_contact(block3d):
    result, _ = block3d
    mesh, T = result.mesh, result.forms.temperature()
    values = T.vec.FV().NumPy()[:mesh.nv]
    span = values.max() - values.min()

    grad = ngs.grad(T)
    eps = 1e-4

    def side_value(y, z, region, side):
        """T on the contact face x = 2 seen from one side: evaluated in an element of that side just beside
        the face and extrapolated to the face with the element's own gradient (exact for P1)."""
        mip = mesh(2.0 + side * eps, y, z)
        assert mesh[ngs.ElementId(ngs.VOL, mip.nr)].mat == region, (y, z, region)
        return T(mip) - side * eps * grad(mip)[0]
    for y in (0.2, 0.5, 0.8):
        for z in (0.3, 0.7):
            a, b = side_value(y, z, "host", -1), side_value(y, z, "neighbour", +1)
            assert abs(a - b) < 1e-3 * span, (y, z, a, b)

    def mean(name):
        ds = ngs.ds(definedon=mesh.Boundaries(name))
        return ngs.Integrate(T * ds, mesh) / ngs.Integrate(ngs.CoefficientFunction(1.0) * ds, mesh)
    assert abs(mean("joint__host") - mean("joint__neighbour")) < 1e-3 * span


# -- 2D: curved fault, anisotropy, flux and Robin conditions, transient ----------------------------

def test_fault2d_runs(tmp_path):
    """Through the installed command: exit status 0, one line on stdout, nothing on stderr."""
    out = tmp_path / "fault"
    script = Path(sys.executable).with_name("ngs-geomech")
    command = [str(script)] if script.exists() else [sys.executable, "-m", "ngs_geomech.cli"]
    proc = subprocess.run([*command, "run", str(GEOMETRIES / "fault2d.toml"), "--out", str(out), "--quiet",
                           "--threads", "1"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert proc.stdout.startswith(f"wrote {out}") and proc.stdout.count("\n") == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] >= 3
    assert summary["mesh"]["regions"] == ["west", "east"]
    for f in pvd_files(out / "fault2d.pvd"):
        assert (out / f).is_file()
    assert {"temperature.png", "probes.png"} <= {p.name for p in (out / "figures").glob("*.png")}
    flows = summary["interface_heat_flow_W"]["fault__west"]
    assert len(flows) == summary["steps"] and all(math.isfinite(v) for v in flows)
    assert max(abs(v) for v in flows) > 0.1
    probes = summary["probes"]
    # the base heater warms the rock, the surface loses heat to the 5 C air
    assert probes["west_max"]["max"] > 15.0
    assert probes["surface_mean"]["final"] < 10.0
    # no jump across the fault: the two probes beside it differ by far less than the temperature range
    assert abs(probes["fault_west_side"]["final"] - probes["fault_east_side"]["final"]) < 3.0


def test_fault2d_meshes_differ_on_the_two_sides_of_the_fault():
    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.scene.parse import load_scene
    from ngs_geomech.validation.validate import validate
    sc = load_scene("fault2d")
    geo = validate(sc)
    mesh = make_mesh(geo, sc.mesh)
    counts = {name: len({v.nr for el in mesh.Boundaries(name).Elements() for v in el.vertices})
              for name in ("fault__west", "fault__east")}
    assert counts["fault__west"] > 1.5 * counts["fault__east"]
    length = {name: ngs.Integrate(1, mesh, ngs.BND, definedon=mesh.Boundaries(name))
              for name in counts}
    assert length["fault__west"] == pytest.approx(length["fault__east"], rel=2e-2)
    assert length["fault__west"] > np.hypot(0.4, 2.0)   # longer than the chord: curved


def test_figure_labels_name_units(tmp_path, monkeypatch):
    """The probe figure's axis labels carry the temperature unit and the time unit, not a number."""
    from ngs_geomech.io import figures

    seen = {}

    def spy(times, curves, path, **kw):
        seen.update(kw)
    monkeypatch.setattr(figures, "time_curves", spy)
    assert cli.main(["run", "canister", "--out", str(tmp_path / "o"), "--quiet", "--set", "time.end='3 year'",
                     "--set", "output.vtk=false"]) == 0
    assert seen["ylabel"] == "temperature (degC)" and seen["time_label"] == "t (years)"
