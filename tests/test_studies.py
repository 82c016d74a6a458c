"""The studies contract: every study is registered, runs at level 0, and writes a well-formed results.json."""

from __future__ import annotations

import importlib.util
import json
import math
import tomllib
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[1] / "studies"
REGISTRY = tomllib.loads((STUDIES / "registry.toml").read_text())
FOLDERS = sorted(p.parent.name for p in STUDIES.glob("*/run.py"))


def test_every_study_is_registered():
    missing = [f for f in FOLDERS if f not in REGISTRY]
    assert not missing, f"studies without an entry in studies/registry.toml: {missing}"
    orphans = [n for n in REGISTRY if n not in FOLDERS]
    assert not orphans, f"registered studies without studies/<name>/run.py: {orphans}"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"study_{name}", STUDIES / name / "run.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("name", FOLDERS)
def test_study_level0(name, tmp_path):
    mod = _load(name)
    assert mod.__doc__ and len(mod.__doc__) > 80, "a study opens with a docstring: physics, command, cost"
    result = mod.main(level=0, out=tmp_path)
    data = json.loads((tmp_path / "results.json").read_text())
    assert data == json.loads(json.dumps(result))
    assert data["study"] == name and data["level"] == 0
    assert isinstance(data["metrics"], dict) and data["metrics"]
    for k, v in data["metrics"].items():
        assert isinstance(v, (int, float)) and math.isfinite(v), f"metric {k} = {v!r}"
    for c in data["convergence"]:
        assert set(c) >= {"quantity", "h", "dofs", "errors", "observed_order", "expected_order"}
        assert len(c["h"]) == len(c["errors"]) == len(c["dofs"]) >= 2
        print(f"{name}: {c['quantity']}: observed {c['observed_order']:.2f}, expected {c['expected_order']}")
    assert isinstance(data["timing_s"], dict)
