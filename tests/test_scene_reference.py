"""The scene-key reference is generated from the keys' declarations and every key is documented."""

from __future__ import annotations

from pathlib import Path

from ngs_geomech.scene import reference

DOC = Path(__file__).resolve().parents[1] / "docs" / "scene_keys.md"


def test_every_scene_key_has_a_doc_and_a_described_type():
    assert reference.undocumented() == []


def test_the_committed_reference_is_the_generated_one():
    assert DOC.read_text() == reference.markdown(), (
        "docs/scene_keys.md is stale: python -m ngs_geomech.scene.reference > docs/scene_keys.md")


def test_the_reference_holds_every_table_and_key():
    text = reference.markdown()
    for heading, _, fields in reference.sections():
        if heading == "top level":           # the top-level keys are the tables themselves
            continue
        assert f"## `{heading}`" in text
        for f in fields:
            assert f"| `{f.name}` |" in text
    assert "## `[materials.NAME]`" in text and "## `[[blocks]]`" in text
