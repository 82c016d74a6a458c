"""Reading scenes: TOML files, built-in scene names, ``--set key=value`` overrides."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any

from ..errors import Problem, SceneError
from . import schema
from .model import Scene

BUILTIN_DIRS = (Path(__file__).resolve().parents[1] / "_geometries",   # wheel install
                Path(__file__).resolve().parents[2] / "geometries")    # source / editable install


def builtin_scenes() -> dict[str, Path]:
    """Names of the built-in scenes (the TOML files in ``geometries/``) and their paths."""
    found: dict[str, Path] = {}
    for d in BUILTIN_DIRS:
        if d.is_dir():
            for p in sorted(d.glob("*.toml")):
                found.setdefault(p.stem, p)
    return found


def resolve(name_or_path: str) -> Path:
    """A scene file path from a path or a built-in scene name."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    scenes = builtin_scenes()
    if name_or_path in scenes:
        return scenes[name_or_path]
    raise SceneError([Problem(name_or_path, "no such scene file and no built-in scene of that name "
                                            f"(built-in: {', '.join(scenes) or 'none'})")], source="scene")


def read_toml(path: Path) -> dict:
    """The data of a TOML scene file: UTF-8 text, with or without a byte order mark (some Windows editors
    write one; TOML itself does not allow it). The relative paths of imported geometry files (``blocks.file``)
    are made absolute, relative to the scene file's folder."""
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise SceneError([Problem(str(path), f"cannot read: {exc.strerror}")], source=str(path)) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SceneError([Problem(str(path), f"not a text (UTF-8) file: byte 0x{raw[exc.start]:02x} at offset "
                                             f"{exc.start} is not UTF-8; a scene is a TOML text file")],
                         source=str(path)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError([Problem(str(path), f"TOML syntax error: {exc}")], source=str(path)) from None
    return anchor_files(data, Path(path).resolve().parent)


def anchor_files(data: dict, folder: Path) -> dict:
    """``data`` with each block's relative ``file`` joined to ``folder`` (other values, also wrong types, are
    left to the schema's checks)."""
    blocks = data.get("blocks")
    if isinstance(blocks, list):
        for b in blocks:
            if isinstance(b, dict) and isinstance(b.get("file"), str) and b["file"] \
                    and not Path(b["file"]).is_absolute():
                b["file"] = str(folder / b["file"])
    return data


def apply_overrides(data: dict, overrides: list[str]) -> dict:
    """Apply ``key.path=value`` overrides (value in TOML syntax, bare words as strings).

    List items are addressed by index (``blocks.0.maxh=2``) or, for lists of named tables, by name
    (``blocks.granite.maxh=2``).
    """
    data = copy.deepcopy(data)
    problems = []
    for item in overrides:
        if "=" not in item:
            problems.append(Problem(item, "override must be key.path=value"))
            continue
        key, raw = item.split("=", 1)
        try:
            parsed = tomllib.loads(f"v = {raw}")
        except tomllib.TOMLDecodeError:
            parsed = {"v": raw}
        if len(parsed) != 1:
            problems.append(Problem(key, f"the value {raw!r} is more than one TOML value"))
            continue
        value = parsed["v"]
        parts = key.strip().split(".")
        if not all(parts):
            problems.append(Problem(key or "--set", f"{item!r}: the key path has an empty part; write "
                                                    "key.path=value, e.g. mesh.maxh=2"))
            continue
        node: Any = data
        ok = True
        for i, part in enumerate(parts[:-1]):
            nxt = child_table(node, part)
            if nxt is None:
                if isinstance(node, dict):
                    node[part] = {}
                    nxt = node[part]
                else:
                    problems.append(Problem(key, f"no item {part!r} at {'.'.join(parts[:i]) or 'top'}"))
                    ok = False
                    break
            node = nxt
        if not ok:
            continue
        last = parts[-1]
        if isinstance(node, dict):
            node[last] = value
        elif isinstance(node, list) and last.isdigit() and int(last) < len(node):
            node[int(last)] = value
        else:
            problems.append(Problem(key, f"cannot set {last!r} here"))
    if problems:
        raise SceneError(problems, source="--set")
    return data


def child_table(node: Any, part: str) -> Any:
    if isinstance(node, dict):
        return node.get(part)
    if isinstance(node, list):
        if part.isdigit() and int(part) < len(node):
            return node[int(part)]
        for item in node:
            if isinstance(item, dict) and item.get("name") == part:
                return item
    return None


def scene_from_dict(data: dict, source: str = "scene") -> Scene:
    """Read a scene from plain data; raises SceneError listing every problem found."""
    problems: list[Problem] = []
    scene = schema.read(Scene, data, "", problems)
    if problems:
        raise SceneError(problems, source=source)
    return scene


def load_scene(name_or_path: str | Path, overrides: list[str] | None = None) -> Scene:
    """Load a scene file or built-in scene, apply overrides, check the schema (not yet the geometry)."""
    path = resolve(str(name_or_path))
    data = read_toml(path)
    if overrides:
        data = apply_overrides(data, overrides)
    return scene_from_dict(data, source=str(path))
