"""Malformed input found by an adversarial pass that the bad-scene corpus (``tests/scenes/bad/fuzz_*.toml``) does
not cover: ``--set`` overrides and the ``[uncertainty]`` table (checked by ``ngs-geomech uncertain`` before any
sample runs). Each is refused with one problem naming the item; nothing is written."""

from __future__ import annotations

from pathlib import Path

import pytest

from ngs_geomech.errors import SceneError
from ngs_geomech.scene.parse import apply_overrides
from ngs_geomech.uncertainty.study import Study

SLAB = Path(__file__).parent / "scenes" / "uncertainty" / "slab.toml"


@pytest.mark.parametrize("item, expect", [
    ("=1", "the key path has an empty part"),
    (".=1", "the key path has an empty part"),
    ("mesh..maxh=1", "the key path has an empty part"),
    ("mesh.maxh=1\n[scene]\nname = 'x'", "more than one TOML value"),
])
def test_malformed_override_is_refused(item, expect):
    with pytest.raises(SceneError) as info:
        apply_overrides({"mesh": {"maxh": 2.0}}, [item])
    assert len(info.value.problems) == 1
    assert expect in str(info.value)


@pytest.mark.parametrize("override, item, expect", [
    ("uncertainty.seed=-1", "uncertainty.seed", "must be >= 0"),
    ("uncertainty.criteria.0.summary='probes.peak.nosuch'", "uncertainty.criteria.peak_temperature.summary",
     "STAT max, min, final"),
])
def test_uncertainty_table_problem_is_refused_before_sampling(tmp_path, override, item, expect):
    out = tmp_path / "study"
    with pytest.raises(SceneError) as info:
        Study(SLAB, out, overrides=[override])
    assert [p.item for p in info.value.problems] == [item]
    assert expect in str(info.value)
    assert not out.exists()
