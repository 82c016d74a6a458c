"""Numbers the documentation quotes from studies, filled in from the studies' committed results.

A quoted number in ``README.md`` or ``docs/*.md`` stands between two HTML comments (invisible when rendered)::

    sticks at <!-- q scene_figures contact_melting_stick_nodes d -->13<!-- /q --> nodes

``scene_figures`` names the study, ``contact_melting_stick_nodes`` a metric in its committed results
``docs/results/scene_figures/results.json``, and the optional last word a format specification (default
``.3g``). ``python studies/quote.py`` rewrites every quoted number from the results; ``--check`` changes nothing
and exits 1 when a number differs from its results (the test suite runs it). The results are written by the study
itself: ``python studies/<name>/run.py --level <its documented level> --out docs/results/<name>``.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
QUOTE = re.compile(r"<!-- q (?P<study>[a-z0-9_]+) (?P<metric>[A-Za-z0-9_]+)(?: (?P<fmt>[^ ]+))? -->"
                   r"(?P<value>.*?)<!-- /q -->")


def documents() -> list[Path]:
    """The files that may quote numbers: the README and the Markdown files in ``docs/``."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def metric(study: str, name: str) -> float | int:
    """A metric of a study's committed results; KeyError naming the file when it is absent."""
    path = RESULTS / study / "results.json"
    if not path.is_file():
        raise KeyError(f"{path.relative_to(ROOT)} does not exist: run studies/{study}/run.py --out "
                       f"docs/results/{study} at its documented level")
    metrics = json.loads(path.read_text())["metrics"]
    if name not in metrics:
        raise KeyError(f"{path.relative_to(ROOT)} has no metric {name!r}")
    return metrics[name]


def render(text: str) -> tuple[str, list[str]]:
    """``text`` with every quoted number filled in from the results, and the quotes that changed."""
    changed = []

    def fill(m: re.Match) -> str:
        fmt = m["fmt"] or ".3g"
        value = format(metric(m["study"], m["metric"]), fmt)
        if value != m["value"]:
            changed.append(f"{m['study']}.{m['metric']}: {m['value']!r} -> {value!r}")
        return m[0].replace(f"-->{m['value']}<!-- /q -->", f"-->{value}<!-- /q -->")

    return QUOTE.sub(fill, text), changed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 when a number is stale")
    args = parser.parse_args(argv)
    stale = []
    for path in documents():
        text = path.read_text()
        new, changed = render(text)
        stale += [f"{path.relative_to(ROOT)}: {c}" for c in changed]
        if changed and not args.check:
            path.write_text(new)
    for line in stale:
        print(line)
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
