"""The README's worked example is a valid scene: its TOML block validates (no meshing, no solving)."""

from __future__ import annotations

import re
from pathlib import Path

from ngs_geomech import api

ROOT = Path(__file__).resolve().parents[1]


def test_the_readme_example_scene_validates(tmp_path):
    blocks = re.findall(r"```toml\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    assert len(blocks) == 1, "the README holds one worked example scene"
    scene = tmp_path / "heated_block.toml"
    scene.write_text(blocks[0])
    report = api.validate_scene(scene)
    assert "heated_block" in report and "mechanics=static" in report
