"""Messages go through logging: the command line shows a run's warnings on stderr (``-q`` hides them, ``-v`` adds
notes, ``-vv`` solver diagnostics), its result on stdout; the library itself writes nothing; drawing figures leaves
the user's matplotlib backend alone; ``python -m ngs_geomech --version``; a closed stdout pipe ends quietly."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import ngs_geomech
from ngs_geomech import cli
from ngs_geomech.api import run
from ngs_geomech.scene.parse import load_scene

pytestmark = pytest.mark.usefixtures("one_thread")

ROOT = Path(__file__).resolve().parents[1]
WARNING = "warning: the displacement leaves the small-strain range"

# a 1 km block with E = 3 Pa under gravity (as in test_mechanics_scenes): a few elements, one small-strain warning
SOFT_BLOCK = """\
[scene]
name = "soft"

[physics]
mechanics = "static"

[mesh]
maxh = 500.0
order = 1

[[blocks]]
name = "rock"
shape = "rectangle"
origin = [0.0, -1000.0]
size = [1000.0, 1000.0]
boundaries = { base = "ymin", left = "xmin", right = "xmax" }

[materials.rock]
youngs_modulus = 3.0
poisson_ratio = 0.25
density = 2500.0

[mechanics]
gravity = [0.0, -9.81]

[time]
end = 2.0
dt = 1.0

[boundary_conditions]
base = { displacement = [0.0, 0.0] }
left = { symmetry = true }
right = { symmetry = true }

[output]
vtk = false
figures = FIGURES
"""


def soft_block(tmp_path: Path, figures: bool = False) -> str:
    path = tmp_path / "soft.toml"
    path.write_text(SOFT_BLOCK.replace("FIGURES", "true" if figures else "false"))
    return str(path)


def environment() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}


@pytest.mark.parametrize("options", [[], ["-v"], ["-vv"], ["-q"], ["--quiet"]],
                         ids=["default", "v", "vv", "q", "subcommand_quiet"])
def test_the_levels_of_the_command_line(options, tmp_path, capsys):
    """Default: the run's warning on stderr, once; -v adds the mesh note, -vv the steps' diagnostics; -q before
    the subcommand and --quiet after it show nothing on stderr, nor the progress display. The result line is the
    last line on stdout in every case."""
    before, after = (options, []) if options != ["--quiet"] else ([], options)
    assert cli.main([*before, "run", soft_block(tmp_path), "--out", str(tmp_path / "o"), *after]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[-1].startswith(f"wrote {tmp_path / 'o'}") and "warning" not in out
    if options in (["-q"], ["--quiet"]):
        assert err == "" and out.count("\n") == 1
        return
    assert err.count(WARNING) == 1
    assert ("soft: " in err and " elements, " in err) == bool(options)
    assert ("debug: ngs_geomech.run: step 1 (t = " in err) == (options == ["-vv"])


def test_the_library_writes_nothing_itself(tmp_path, capsys, caplog):
    """Through the API (no progress display) the warning is a log record of ngs_geomech.run, not text."""
    res = run(load_scene(soft_block(tmp_path)), None, progress=False)
    assert capsys.readouterr() == ("", "")
    records = [r for r in caplog.records if r.name == "ngs_geomech.run" and r.levelname == "WARNING"]
    assert len(records) == 1 and records[0].getMessage() in res.summary["warnings"]


def test_figures_leave_the_matplotlib_backend_alone(tmp_path):
    """Importing the driver loads no matplotlib; a run that draws figures leaves the backend chosen before and
    pyplot unloaded."""
    script = textwrap.dedent(f"""
        import sys
        import matplotlib
        matplotlib.use("svg")
        before = set(sys.modules)
        import ngs_geomech.run
        assert not [m for m in set(sys.modules) - before if m.startswith("matplotlib")], "matplotlib imported"
        from ngs_geomech import cli
        assert cli.main(["-q", "run", {soft_block(tmp_path, figures=True)!r}, "--out", {str(tmp_path / "o")!r}]) == 0
        assert "matplotlib.pyplot" not in sys.modules
        print(matplotlib.get_backend())
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                          env={**environment(), "MPLBACKEND": "pdf"})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "svg"
    assert {"von_mises.png", "principal_stress.png"} <= {p.name for p in (tmp_path / "o" / "figures").iterdir()}


def test_version_through_python_m():
    proc = subprocess.run([sys.executable, "-m", "ngs_geomech", "--version"], capture_output=True, text=True,
                          timeout=120, env=environment())
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout == f"ngs-geomech {ngs_geomech.__version__}\n"


def test_a_closed_stdout_pipe_ends_quietly():
    """``ngs-geomech list | head -0``: the reader is gone before the first line; no traceback, exit 141."""
    r, w = os.pipe()
    os.close(r)
    try:
        proc = subprocess.run([sys.executable, "-m", "ngs_geomech", "list"], stdout=w, stderr=subprocess.PIPE,
                              text=True, timeout=120, env=environment())
    finally:
        os.close(w)
    assert proc.returncode == 141 and proc.stderr == ""
