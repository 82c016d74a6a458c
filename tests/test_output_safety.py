"""What ``--out`` may be and what the program may touch there (ngs_geomech/io/outdir.py): a directory of the
user's files is refused without ``--overwrite`` and keeps every file with it, an earlier output is replaced
without touching the user's files in it, an existing file, ``/``, a mount point, a non-writable or impossible
parent and a dangling link are refused with one line before any meshing; a full disk stops a run with one line
naming the kept checkpoint; bad ``--threads``/``--workers`` name the option.

Runs use the steady slab of tests/scenes/uncertainty/slab.toml (well under a second), made transient where a
checkpoint is needed; the refusals are checked with meshing made to fail.
"""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest

from ngs_geomech import cli
from ngs_geomech.errors import OutputError
from ngs_geomech.io import vtk
from ngs_geomech.io.atomic import OutputDir
from ngs_geomech.io.outdir import MARKER, check_output
from ngs_geomech.io.sample_log import SampleLog
from ngs_geomech.run import driver as run_module

pytestmark = pytest.mark.usefixtures("one_thread")

SLAB = str(Path(__file__).resolve().parent / "scenes" / "uncertainty" / "slab.toml")
QUICK = ["--quiet", "--set", "output.vtk=true"]
TRANSIENT = [*QUICK, "--set", "physics.thermal=transient", "--set", "time.end='4 day'", "--set", "time.dt='1 day'",
             "--set", "materials.slab.rho_c=2e6", "--set", "output.checkpoint_every=1"]


def files(d: Path) -> dict[str, bytes]:
    return {p.relative_to(d).as_posix(): p.read_bytes() for p in d.rglob("*") if p.is_file()}


def user_dir(d: Path) -> Path:
    """A directory of the user's: a scene file and a note."""
    d.mkdir(parents=True, exist_ok=True)
    (d / "myscene.toml").write_text(Path(SLAB).read_text())
    (d / "notes.txt").write_text("mine")
    return d


@pytest.fixture
def no_meshing(monkeypatch):
    """Refusals come before any meshing: meshing fails the test."""
    def make_mesh(*args, **kwargs):
        raise AssertionError("meshed before the output directory was checked")
    monkeypatch.setattr(run_module, "make_mesh", make_mesh)


def refused(capsys, argv: list[str], *words: str) -> str:
    """Run the command line; it must exit 2 with one error line holding ``words``."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ngs-geomech: error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


# -- refusals, before any meshing ---------------------------------------------------------------------------

def test_out_dot_among_user_files_is_refused(tmp_path, monkeypatch, capsys, no_meshing):
    before = files(user_dir(tmp_path))
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", "myscene.toml", "--out", ".", *QUICK], "--out .", "notes.txt", "--overwrite")
    assert files(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["myscene.toml", "notes.txt"]


def test_existing_file_is_refused(tmp_path, monkeypatch, capsys, no_meshing):
    (tmp_path / "F").write_text("mine")
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", SLAB, "--out", "F", *QUICK], "--out F", "existing file")
    assert files(tmp_path) == {"F": b"mine"}


@pytest.mark.parametrize("out", ["/", "MOUNT"])
def test_root_and_mount_points_are_refused(tmp_path, monkeypatch, capsys, no_meshing, out):
    mount = tmp_path / "MOUNT"
    mount.mkdir()
    real_ismount = os.path.ismount
    monkeypatch.setattr(os.path, "ismount", lambda p: Path(p) == mount or real_ismount(p))
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", SLAB, "--out", out, *QUICK], f"--out {out}", "root directory" if out == "/" else
            "mount point")
    assert list(mount.iterdir()) == []


def test_parent_not_writable_is_one_line(tmp_path, monkeypatch, capsys, no_meshing):
    """Refused by the permission check (non-root users) and, where that passes (root, or a read-only file
    system found only on writing), by the failing creation of the staging directory."""
    ro = tmp_path / "RO"
    ro.mkdir()
    monkeypatch.setattr(os, "access", lambda p, mode: Path(p) != ro)
    refused(capsys, ["run", SLAB, "--out", str(ro / "out"), *QUICK], str(ro), "not writable")
    monkeypatch.undo()
    real_mkdir = os.mkdir

    def mkdir(p, *args, **kwargs):
        if Path(p).parent == ro:
            raise PermissionError(errno.EROFS, "Read-only file system", str(p))
        return real_mkdir(p, *args, **kwargs)
    monkeypatch.setattr(os, "mkdir", mkdir)
    monkeypatch.setattr(run_module, "make_mesh", lambda *a, **k: pytest.fail("meshed"))
    refused(capsys, ["run", SLAB, "--out", str(ro / "out"), *QUICK], "cannot create", "Read-only file system")
    assert list(ro.iterdir()) == []


def test_parent_that_is_a_file_is_refused(tmp_path, monkeypatch, capsys, no_meshing):
    (tmp_path / "file.txt").write_text("mine")
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", SLAB, "--out", "file.txt/sub", *QUICK], "file.txt is a file")
    assert files(tmp_path) == {"file.txt": b"mine"}


def test_symlinks_name_their_target(tmp_path, monkeypatch, capsys, no_meshing):
    """A link to a directory of other files is refused like that directory; a link to nothing is refused."""
    before = files(user_dir(tmp_path / "real"))
    (tmp_path / "L").symlink_to("real")
    (tmp_path / "dangling").symlink_to("nowhere")
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", SLAB, "--out", "L", *QUICK], "--out L", "notes.txt")
    refused(capsys, ["run", SLAB, "--out", "dangling", *QUICK], "symbolic link", "nowhere")
    assert files(tmp_path / "real") == before and (tmp_path / "L").is_symlink()
    assert not (tmp_path / "nowhere").exists()


@pytest.mark.parametrize("argv", [["run", SLAB, "--out", "D", "--threads", "-3"],
                                  ["run", SLAB, "--out", "D", "--threads", "0"],
                                  ["uncertain", SLAB, "--out", "D", "--workers", "-3"],
                                  ["uncertain", SLAB, "--out", "D", "--threads", "x"]])
def test_thread_and_worker_counts_must_be_positive(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert f"argument {argv[4]}: '{argv[5]}' is not a positive integer" in err
    assert list(tmp_path.iterdir()) == []


# -- what a commit replaces, keeps and removes (OutputDir, no run) ---------------------------------------------

def stage(out: Path, names: dict[str, str], **kwargs) -> Path:
    """Commit an output of the files ``names`` (relative path -> text) into ``out``."""
    staging = OutputDir(out, scene="s", **kwargs)
    for rel, text in names.items():
        (staging.path / rel).parent.mkdir(parents=True, exist_ok=True)
        (staging.path / rel).write_text(text)
    return staging.commit()


def test_earlier_output_replaced_user_files_kept(tmp_path):
    out = tmp_path / "DIR"
    stage(out, {"a.vtu": "1", "b.vtu": "1", "figures/x.png": "1", "summary.json": "1"})
    (out / "view.pvsm").write_text("the user's")
    (out / "figures" / "mine.png").write_text("the user's")
    inode = out.stat().st_ino
    stage(out, {"a.vtu": "2", "summary.json": "2"})          # no overwrite needed: an earlier output
    assert files(out) == {"a.vtu": b"2", "summary.json": b"2", "view.pvsm": b"the user's",
                          "figures/mine.png": b"the user's", MARKER: (out / MARKER).read_bytes()}
    marker = json.loads((out / MARKER).read_text())
    assert marker["files"] == ["a.vtu", "summary.json"] and marker["complete"] and marker["command"] == "run"
    assert out.stat().st_ino == inode                      # the directory itself is kept, not replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["DIR"]
    stage(out, {"a.vtu": "3"})
    assert not (out / "figures" / "x.png").exists() and (out / "figures" / "mine.png").exists()


def test_overwrite_writes_into_a_user_directory(tmp_path):
    out = user_dir(tmp_path / "DIR")
    (out / "summary.json").write_text("the user's, same name")
    with pytest.raises(OutputError, match="directory of other files"):
        OutputDir(out)
    stage(out, {"summary.json": "new", "a.vtu": "new"}, overwrite=True)
    got = files(out)
    assert got["summary.json"] == b"new" and got["a.vtu"] == b"new"                   # same name: replaced
    assert got["myscene.toml"] == Path(SLAB).read_bytes() and got["notes.txt"] == b"mine"


def test_new_output_appears_in_one_rename_and_empty_dir_is_used(tmp_path):
    assert stage(tmp_path / "new" / "DIR", {"a.vtu": "1"}) == tmp_path / "new" / "DIR"
    assert set(files(tmp_path / "new" / "DIR")) == {"a.vtu", MARKER}
    (tmp_path / "empty").mkdir()
    stage(tmp_path / "empty", {"a.vtu": "1"})
    assert set(files(tmp_path / "empty")) == {"a.vtu", MARKER}


def test_symlink_target_written_link_kept(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "L").symlink_to("real")
    assert stage(tmp_path / "L", {"a.vtu": "1"}) == tmp_path / "real"
    assert (tmp_path / "L").is_symlink() and (tmp_path / "real" / "a.vtu").read_text() == "1"


def test_staging_inside_an_existing_target_when_its_parent_is_not_writable(tmp_path, monkeypatch):
    """``--out .`` in a directory whose parent one may not write: the staging directory goes inside."""
    out = user_dir(tmp_path / "DIR")
    real_mkdir = os.mkdir

    def mkdir(p, *args, **kwargs):
        if Path(p).parent == tmp_path:
            raise PermissionError(errno.EACCES, "Permission denied", str(p))
        return real_mkdir(p, *args, **kwargs)
    monkeypatch.setattr(os, "mkdir", mkdir)
    staging = OutputDir(out, overwrite=True)
    assert staging.path.parent == out
    (staging.path / "a.vtu").write_text("1")
    staging.commit()
    assert sorted(p.name for p in out.iterdir()) == ["a.vtu", "myscene.toml", MARKER, "notes.txt"]


def test_check_output_allows_resume_and_earlier_outputs(tmp_path):
    out = user_dir(tmp_path / "DIR")
    assert check_output(out, command="run", resume=True) == out
    (out / MARKER).write_text(json.dumps({"program": "ngs-geomech", "command": "uncertain", "files": []}))
    with pytest.raises(OutputError):                  # another command's output: not this command's to replace
        check_output(out, command="run")
    assert check_output(out, command="uncertain") == out


# -- end to end: overwrite, disk full ------------------------------------------------------------------------

def test_run_overwrite_into_cwd_keeps_the_users_files(tmp_path, monkeypatch, capsys):
    before = files(user_dir(tmp_path))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "myscene.toml", "--out", ".", "--overwrite", *QUICK]) == 0
    after = files(tmp_path)
    assert {k: after[k] for k in before} == before
    marker = json.loads(after[MARKER])
    assert set(after) == set(before) | set(marker["files"]) | {MARKER}
    assert "summary.json" in marker["files"] and "uncertain_slab.vtu" in marker["files"]
    assert "myscene.toml" not in marker["files"]
    # a second run, now without --overwrite: the directory holds an earlier output
    assert cli.main(["run", "myscene.toml", "--out", ".", *QUICK, "--set", "output.vtk=false"]) == 0
    after = files(tmp_path)
    assert {k: after[k] for k in before} == before and "uncertain_slab.vtu" not in after


def vtk_disk_full_at(monkeypatch, n: int) -> None:
    original = vtk.VtkSeries.write
    calls = {"n": 0}

    def write(self, time):
        calls["n"] += 1
        if calls["n"] == n:
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(self, time)
    monkeypatch.setattr(vtk.VtkSeries, "write", write)


def test_disk_full_keeps_the_checkpoint(tmp_path, monkeypatch, capsys):
    """The earlier output in D (and the user's note there) stays as it was; --resume then commits into D."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", SLAB, "--out", "D", *QUICK]) == 0
    (tmp_path / "D" / "notes.txt").write_text("mine")
    before = files(tmp_path / "D")
    vtk_disk_full_at(monkeypatch, 4)
    line = refused(capsys, ["run", SLAB, "--out", "D", *TRANSIENT], "disk full: checkpoint kept in",
                   "--resume after freeing space")
    assert files(tmp_path / "D") == before
    (staging,) = [p for p in tmp_path.iterdir() if p.is_dir() and p.name != "D"]
    assert str(staging / "checkpoint") in line and (staging / "checkpoint" / "checkpoint.npz").is_file()
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", SLAB, "--out", "D", *TRANSIENT, "--resume"]) == 0
    after = files(tmp_path / "D")
    assert after["notes.txt"] == b"mine" and "uncertain_slab_step00004.vtu" in after
    assert json.loads(after["summary.json"])["resumed"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["D"]


def test_disk_full_before_a_checkpoint_leaves_nothing(tmp_path, monkeypatch, capsys):
    vtk_disk_full_at(monkeypatch, 1)
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", SLAB, "--out", "D", *TRANSIENT], "disk full: D was not written")
    assert list(tmp_path.iterdir()) == []


# -- uncertain --out -----------------------------------------------------------------------------------------

UNC = ["--executor", "serial", "--quiet", "--no-figures", "--set", "uncertainty.vertices=no", "--set",
       "uncertainty.samples=2", "--set", "uncertainty.local_search=false"]


def test_uncertain_refuses_user_directory_and_overwrite_keeps_other_files(tmp_path, monkeypatch, capsys):
    before = files(user_dir(tmp_path))
    (tmp_path / "table.md").write_text("the user's table")
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["uncertain", "myscene.toml", "--out", ".", *UNC], "table.md", "--overwrite")
    assert (tmp_path / "table.md").read_text() == "the user's table"
    assert cli.main(["uncertain", "myscene.toml", "--out", ".", "--overwrite", *UNC]) == 0
    after = files(tmp_path)
    assert {k: after[k] for k in before} == before
    assert json.loads(after[MARKER])["files"] == ["results.json", "samples.jsonl", "table.csv", "table.md"]
    # the same study again: refused (its samples), --overwrite starts over and removes only the study's files
    refused(capsys, ["uncertain", "myscene.toml", "--out", ".", *UNC], "--resume", "--overwrite")
    (tmp_path / "results.json").unlink()
    (tmp_path / MARKER).write_text(after[MARKER].decode().replace('"table.csv"', '"old.png", "table.csv"'))
    (tmp_path / "old.png").write_text("an earlier study's figure")
    assert cli.main(["uncertain", "myscene.toml", "--out", ".", "--overwrite", *UNC]) == 0
    after = files(tmp_path)
    assert {k: after[k] for k in before} == before and "old.png" not in after and "results.json" in after


def test_uncertain_disk_full_is_one_line(tmp_path, monkeypatch, capsys):
    def append(self, record):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(SampleLog, "append", append)
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["uncertain", SLAB, "--out", "U", *UNC], "disk full", "samples.jsonl", "--resume")
