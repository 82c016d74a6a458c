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


def test_every_choice_of_a_scene_key_names_a_registered_strategy():
    """The adaptivity choice lists of the scene model are the names the registries implement (the strategies are
    registered by name where they are written; the scene declares which names a scene may use)."""
    from ngs_geomech.adapt.estimators import ESTIMATORS as REGISTERED
    from ngs_geomech.adapt.marking import MARKERS as REGISTERED_MARKERS
    from ngs_geomech.contact.factory import SOLVERS as CONTACT_SOLVERS
    from ngs_geomech.scene import model

    kinds = {name: entry.kind for name, entry in REGISTERED.items()}
    assert sorted(n for n, k in kinds.items() if k == "estimator") == sorted(model.ESTIMATORS)
    assert sorted(n for n, k in kinds.items() if k == "indicator") == sorted(model.INDICATORS)
    assert sorted(REGISTERED_MARKERS) == sorted(model.MARKERS)
    assert tuple(CONTACT_SOLVERS) == model.CONTACT_METHODS
