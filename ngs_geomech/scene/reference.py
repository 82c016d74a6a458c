"""The scene-key reference, generated from the keys' declarations in :mod:`ngs_geomech.scene.model`.

Each key is declared once, as a dataclass field with its converter (type, allowed values, range), default and
doc (:func:`ngs_geomech.scene.schema.field`); this module walks the declarations from :class:`~.model.Scene`
down and writes one Markdown table per TOML table. ``python -m ngs_geomech.scene.reference`` prints it; the
file ``docs/scene_keys.md`` is its output, checked by the test suite.
"""

from __future__ import annotations

import dataclasses
import sys

from .model import Scene
from .schema import MISSING

HEADER = """# Scene keys

Generated from the declarations in `ngs_geomech/scene/model.py` by `python -m ngs_geomech.scene.reference`;
do not edit by hand. [scenes.md](scenes.md) shows the keys in use, with examples. Units are SI; temperatures
are in the scene's `temperature_unit`. A key without a default is required where its table is given.
"""


def _schema(conv) -> tuple[type | None, str]:
    """The schema class a converter reads (through lists and tables) and how the table repeats in TOML."""
    schema = getattr(conv, "schema", None)
    if schema is not None:
        return schema, ""
    item = getattr(conv, "item", None)
    if item is not None:
        inner, _ = _schema(item)
        if inner is not None:
            return inner, "list" if conv.what.startswith("list") else "named"
    return None, ""


def _default(f: dataclasses.Field) -> str:
    if f.default is MISSING and f.default_factory is MISSING:
        return "required"
    value = f.default if f.default is not MISSING else f.default_factory()
    if dataclasses.is_dataclass(value):
        return "(table)"
    if value is None:
        return "-"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    return f"`{value!r}`"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("``", "`").replace("|", "\\|")


def sections(cls: type = Scene, path: str = "", kind: str = "") -> list[tuple[str, type, list[dataclasses.Field]]]:
    """The tables of the scene: (TOML heading, schema class, its fields), depth first from ``cls``."""
    heading = {"": f"[{path}]", "list": f"[[{path}]]", "named": f"[{path}.NAME]"}[kind] if path else "top level"
    out = [(heading, cls, list(dataclasses.fields(cls)))]
    here = f"{path}.NAME" if kind == "named" else path
    for f in dataclasses.fields(cls):
        sub, how = _schema(f.metadata["conv"])
        if sub is not None:
            out += sections(sub, f"{here}.{f.name}" if here else f.name, how)
    return out


def undocumented(cls: type = Scene) -> list[str]:
    """Keys without a doc or without a described type (empty: every key is documented)."""
    missing = []
    for heading, _, fields in sections(cls):
        for f in fields:
            if not f.metadata.get("doc", "").strip() or not getattr(f.metadata["conv"], "what", ""):
                missing.append(f"{heading} {f.name}")
    return missing


def markdown(cls: type = Scene) -> str:
    """The reference: one table per TOML table (key, accepted values, default, doc)."""
    lines = [HEADER]
    for heading, schema, fields in sections(cls):
        if heading == "top level":
            continue
        lines += [f"## `{heading}`", "", _cell((schema.__doc__ or "").strip()), "",
                  "| key | accepts | default | meaning |", "| --- | --- | --- | --- |"]
        for f in fields:
            conv = f.metadata["conv"]
            lines.append(f"| `{f.name}` | {_cell(conv.what)} | {_default(f)} | {_cell(f.metadata.get('doc', ''))} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.stdout.write(markdown())
