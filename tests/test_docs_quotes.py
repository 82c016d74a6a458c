"""Numbers the README and docs/ quote from runs come from the studies' committed results (studies/quote.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("quote", ROOT / "studies" / "quote.py")
quote = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(quote)


def test_every_quoted_number_equals_its_committed_result():
    stale, count = [], 0
    for path in quote.documents():
        text = path.read_text()
        count += len(quote.QUOTE.findall(text)) + len(quote.TABLE.findall(text))
        stale += [f"{path.name}: {c}" for c in quote.render(text)[1]]
    assert count > 0, "no quoted numbers found: the marker syntax changed?"
    assert not stale, "stale quoted numbers (run python studies/quote.py):\n" + "\n".join(stale)


def test_a_stale_number_and_a_missing_metric_are_reported(tmp_path):
    text = "<!-- q scene_figures contact_melting_stick_nodes d -->999<!-- /q -->"
    new, changed = quote.render(text)
    assert changed and "999" not in new
    try:
        quote.render("<!-- q scene_figures no_such_metric -->1<!-- /q -->")
    except KeyError as exc:
        assert "no_such_metric" in str(exc)
    else:
        raise AssertionError("a quote of a missing metric must fail")


def test_a_stale_table_is_reported_and_rendered_from_the_results():
    text = "<!-- table scene_figures metrics contact_melting_stick_nodes:d -->\n| stale |\n<!-- /table -->"
    new, changed = quote.render(text)
    assert changed and "| stale |" not in new
    assert "| `contact_melting_stick_nodes` | " in new and "level" in new
    assert quote.render(new) == (new, [])
