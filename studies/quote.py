"""Numbers the documentation quotes from studies, filled in from the studies' committed results.

A quoted number in ``README.md`` or ``docs/*.md`` stands between two HTML comments (invisible when rendered)::

    sticks at <!-- q scene_figures contact_melting_stick_nodes d -->13<!-- /q --> nodes

``scene_figures`` names the study, ``contact_melting_stick_nodes`` a metric in its committed results
``docs/results/scene_figures/results.json``, and the optional last word a format specification (default
``.3g``). ``python studies/quote.py`` rewrites every quoted number from the results; ``--check`` changes nothing
and exits 1 when a number differs from its results (the test suite runs it). The results are written by the study
itself: ``python studies/<name>/run.py --level <its documented level> --out docs/results/<name>``.

A quoted table stands between an opening comment on a line of its own and ``<!-- /table -->``::

    <!-- table heat_convergence convergence p1_l2_error h -->
    ...rendered rows...
    <!-- /table -->

``convergence QUANTITY [HNAME]`` renders the results' ``convergence`` entry of that quantity (columns HNAME,
default ``h``, dofs, error and the rate between rows, then the observed and expected order); ``orders [PREFIX]``
the observed and expected order of every convergence entry (whose quantity starts with PREFIX); ``metrics
NAME[:FMT] ...`` a table of the named metrics; ``rows COLUMN[:FMT] ...`` the results' ``rows`` (row name ->
{column: value}) as one line per row, its name first (titled by the results' ``row_name``), then the named columns
(numbers in FMT, text as it is, ``-`` where a row has no such column). Each table ends with a line naming the
study and the level of its results, so a reader sees which level a table is from.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
QUOTE = re.compile(r"<!-- q (?P<study>[a-z0-9_]+) (?P<metric>[A-Za-z0-9_]+)(?: (?P<fmt>[^ ]+))? -->"
                   r"(?P<value>.*?)<!-- /q -->")


TABLE = re.compile(r"<!-- table (?P<study>[a-z0-9_]+) (?P<kind>convergence|orders|metrics|rows)"
                   r"(?: (?P<args>[^>]*?))? -->\n(?P<body>.*?)<!-- /table -->", re.S)


def documents() -> list[Path]:
    """The files that may quote numbers: the README and the Markdown files in ``docs/``."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def metric(study: str, name: str) -> float | int:
    """A metric of a study's committed results; KeyError naming the file when it is absent."""
    metrics = results(study)["metrics"]
    if name not in metrics:
        raise KeyError(f"docs/results/{study}/results.json has no metric {name!r}")
    return metrics[name]


def results(study: str) -> dict:
    """A study's committed results; KeyError naming the file when it is absent."""
    path = RESULTS / study / "results.json"
    if not path.is_file():
        raise KeyError(f"{path.relative_to(ROOT)} does not exist: run studies/{study}/run.py --out "
                       f"docs/results/{study} at its documented level")
    return json.loads(path.read_text())


def _rate(h0: float, h1: float, e0: float, e1: float) -> str:
    try:
        return f"{math.log(e0 / e1) / math.log(h0 / h1):.2f}"
    except (ValueError, ZeroDivisionError):
        return "-"


def convergence_table(study: str, quantity: str, hname: str = "h") -> str:
    """The Markdown table of one ``convergence`` entry of a study's committed results."""
    data = results(study)
    entries = [c for c in data["convergence"] if c["quantity"] == quantity]
    if not entries:
        raise KeyError(f"docs/results/{study}/results.json has no convergence entry {quantity!r}")
    c = entries[0]
    rows = [f"| {hname} | dofs | error | rate |", "| --- | --- | --- | --- |"]
    for k, (h, d, e) in enumerate(zip(c["h"], c["dofs"], c["errors"])):
        rate = "-" if k == 0 else _rate(c["h"][k - 1], h, c["errors"][k - 1], e)
        rows.append(f"| {h:.4g} | {d} | {e:.3e} | {rate} |")
    order = c["observed_order"]
    observed = "-" if order is None else f"{order:.2f}"
    rows += ["", f"*`{quantity}`: observed order {observed} (expected {_expected(c['expected_order'])}); "
                 f"`{study}`, level {data['level']}.*"]
    return "\n".join(rows) + "\n"


def _format(value: float | int, fmt: str) -> str:
    """``value`` in format ``fmt``; ``d`` takes a float that holds an integer (counts stored as floats)."""
    if fmt.endswith("d") and isinstance(value, float) and value.is_integer():
        value = int(value)
    return format(value, fmt)


def _expected(value) -> str:
    return format(value, ".3g") if isinstance(value, float) else str(value)


def orders_table(study: str, prefix: str = "") -> str:
    """The Markdown table of the observed and expected orders of a study's convergence entries."""
    data = results(study)
    rows = ["| quantity | finest value | observed order | expected |", "| --- | --- | --- | --- |"]
    for c in data["convergence"]:
        if c["quantity"].startswith(prefix):
            order = "-" if c["observed_order"] is None else f"{c['observed_order']:.2f}"
            rows.append(f"| `{c['quantity']}` | {c['errors'][-1]:.2e} | {order} | {_expected(c['expected_order'])} |")
    rows += ["", f"*`{study}`, level {data['level']}.*"]
    return "\n".join(rows) + "\n"


def metrics_table(study: str, names: list[str]) -> str:
    """The Markdown table of the named metrics (``name`` or ``name:fmt``) of a study's committed results."""
    data = results(study)
    rows = ["| metric | value |", "| --- | --- |"]
    for item in names:
        name, _, fmt = item.partition(":")
        rows.append(f"| `{name}` | {_format(metric(study, name), fmt or '.3g')} |")
    rows += ["", f"*`{study}`, level {data['level']}.*"]
    return "\n".join(rows) + "\n"


def _cell(value, fmt: str) -> str:
    if value is None:
        return "-"
    return _format(value, fmt) if isinstance(value, (int, float)) else str(value)


def rows_table(study: str, columns: list[str]) -> str:
    """The Markdown table of a study's ``rows`` (row name -> {column: value}) against the named columns
    (``name`` or ``name:fmt``)."""
    data = results(study)
    if "rows" not in data:
        raise KeyError(f"docs/results/{study}/results.json has no rows")
    names = [c.partition(":")[0] for c in columns]
    lines = ["| " + " | ".join([data.get("row_name", "row"), *names]) + " |", "|" + " --- |" * (len(names) + 1)]
    for row, values in data["rows"].items():
        cells = [_cell(values.get(name), c.partition(":")[2] or ".3g") for name, c in zip(names, columns)]
        lines.append("| " + " | ".join([f"`{row}`", *cells]) + " |")
    lines += ["", f"*`{study}`, level {data['level']}.*"]
    return "\n".join(lines) + "\n"


def render(text: str) -> tuple[str, list[str]]:
    """``text`` with every quoted number and table filled in from the results, and the quotes that changed."""
    changed = []

    def table(m: re.Match) -> str:
        args = (m["args"] or "").split()
        if m["kind"] == "convergence":
            body = convergence_table(m["study"], *args[:2])
        elif m["kind"] == "orders":
            body = orders_table(m["study"], *args[:1])
        elif m["kind"] == "rows":
            body = rows_table(m["study"], args)
        else:
            body = metrics_table(m["study"], args)
        if body != m["body"]:
            changed.append(f"{m['study']} table {m['kind']} {m['args'] or ''}: rows differ")
        return m[0].replace(f"-->\n{m['body']}<!-- /table -->", f"-->\n{body}<!-- /table -->")

    text = TABLE.sub(table, text)

    def fill(m: re.Match) -> str:
        fmt = m["fmt"] or ".3g"
        value = _format(metric(m["study"], m["metric"]), fmt)
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
