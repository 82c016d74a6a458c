"""The documentation stays inside the repository: README.md and docs/*.md link only to files that exist here,
the README stays an entry point of at most 260 lines, and no document cites issue numbers."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def _links(path: Path) -> list[str]:
    """The link targets of a Markdown file, fenced code blocks left out."""
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    return LINK.findall(text)


def test_every_relative_link_resolves_to_a_file_of_the_repository():
    bad = []
    for path in DOCS:
        for target in _links(path):
            if re.match(r"[a-z]+://", target) or target.startswith("#"):
                continue
            file = (path.parent / target.split("#")[0]).resolve()
            if target.startswith("/") or not file.is_relative_to(ROOT) or not file.exists():
                bad.append(f"{path.relative_to(ROOT)}: {target}")
    assert not bad, "links that leave the repository or point to nothing:\n" + "\n".join(bad)


def test_the_readme_is_an_entry_point():
    lines = len((ROOT / "README.md").read_text().splitlines())
    assert lines <= 260, f"README.md has {lines} lines; move details into docs/"


def test_no_document_names_paths_outside_the_repository():
    hits = [f"{p.relative_to(ROOT)}: {m.group(0)!r}" for p in DOCS
            for m in re.finditer(r"\.\./shared|(?<![\w.])/(?:work|home|tmp)/", p.read_text())]
    assert not hits, "paths outside the repository in the documentation:\n" + "\n".join(hits)


def test_no_document_cites_issue_numbers():
    hits = [f"{p.relative_to(ROOT)}: {m.group(0)!r}" for p in DOCS
            for m in re.finditer(r"\bissues? #?\d+", p.read_text(), flags=re.I)]
    assert not hits, "issue numbers in the documentation:\n" + "\n".join(hits)
