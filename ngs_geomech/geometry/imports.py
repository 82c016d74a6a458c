"""Blocks read from STEP or BREP files (netgen.occ): the file's solids become regions and its named faces
boundaries, both renamed by the block's ``solids`` and ``faces`` tables; the file is only read.

Lengths: OCC's STEP reader converts coordinates to millimetres from the unit the file declares (a file
declaring m reads 1000 times larger). ``length_unit = 'declared'`` honours the declaration (the millimetres
are converted to m); a unit name takes the numbers as written in that unit, whatever the file declares: the
declared unit is read from the file's header (``LENGTH_UNIT`` entities) to undo the reader's conversion.
netgen.occ's own ``WriteStep`` labels its numbers millimetres. BREP files hold plain numbers and no unit
('declared' reads them in m). STEP keeps solid and face names; BREP keeps none (all solids are then the
block's region, the faces unnamed: name them with selectors).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from netgen import occ

from ..scene.model import LENGTH_UNITS, Block

SUFFIXES = (".step", ".stp", ".brep")
MAX_BYTES = 256 * 2 ** 20
"""Largest file read, bytes: a STEP text of a few hundred MB takes the reader minutes and gigabytes."""
STEP_PREFIXES = {"$": 1.0, ".MILLI.": 1e-3, ".CENTI.": 1e-2, ".DECI.": 1e-1, ".KILO.": 1e3, ".MICRO.": 1e-6}
"""SI prefixes of a STEP ``SI_UNIT(prefix, .METRE.)``, as factors to m."""
STEP_NAMED_UNITS = {"INCH": 0.0254, "FOOT": 0.3048, "MILLIMETRE": 1e-3, "METRE": 1.0}
"""Lengths of a STEP ``CONVERSION_BASED_UNIT('name', ...)``, m."""
READER_UNIT = 1e-3
"""The unit OCC's STEP reader converts coordinates to (mm), m."""


def read_import(block: Block):
    """The block's shape from its file: cells named by region (``block.solids``, else the block's name),
    faces renamed by ``block.faces``, scaled to m. Raises ValueError naming the file, the key and the cause."""
    path = checked_path(block.file)
    kind = "brep" if path.suffix.lower() == ".brep" else "step"
    try:
        shape = occ.OCCGeometry(str(path)).shape
    except Exception as exc:        # netgen raises NgException or RuntimeError (OCC's Standard_Failure)
        raise ValueError(f"file = {block.file!r}: the geometry kernel could not read it as {kind.upper()} "
                         f"({exc})") from None
    solids = list(shape.solids)
    if not solids:
        raise ValueError(f"file = {block.file!r} holds no solids (a 3D block needs closed volumes)")
    factor = _scale(block, path, kind)
    if factor != 1.0:
        shape = shape.Scale(occ.Pnt(0, 0, 0), factor)
        solids = list(shape.solids)
    _name(shape, solids, block)
    # several solids: glued here, so that solids touching in the file share their faces (one argument
    # compound alone is not intersected by the later Glue of the blocks)
    return occ.Glue(solids) if len(solids) > 1 else solids[0]


def checked_path(file: str | None) -> Path:
    """The path of an import file after the checks that need no geometry kernel: given, a STEP/BREP suffix,
    an existing regular file this process may read, not larger than :data:`MAX_BYTES`."""
    if not file:
        raise ValueError("an import needs 'file' (a STEP or BREP file)")
    path = Path(file)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(f"file = {file!r}: not a STEP or BREP file (suffixes {', '.join(SUFFIXES)})")
    if not path.exists():
        raise ValueError(f"file = {file!r} does not exist")
    if not path.is_file():
        raise ValueError(f"file = {file!r} is not a regular file")
    if not os.access(path, os.R_OK):
        raise ValueError(f"file = {file!r} cannot be read (no read permission)")
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise ValueError(f"file = {file!r} is {size / 2 ** 20:.0f} MB, more than the {MAX_BYTES / 2 ** 20:.0f} MB "
                         "read")
    return path


def _scale(block: Block, path: Path, kind: str) -> float:
    """The factor from the reader's coordinates to m."""
    unit = block.length_unit
    if kind == "brep":
        return 1.0 if unit == "declared" else LENGTH_UNITS[unit]
    if unit == "declared":
        return READER_UNIT
    declared = step_length_unit(path)
    if declared is None:
        raise ValueError(f"file = {block.file!r}: its declared length unit could not be read from the file, so "
                         f"length_unit = {unit!r} cannot undo the reader's conversion; use length_unit = "
                         "'declared'")
    return READER_UNIT * LENGTH_UNITS[unit] / declared


def step_length_unit(path: Path) -> float | None:
    """The length unit a STEP file declares (the ``LENGTH_UNIT`` among the units of its
    ``GLOBAL_UNIT_ASSIGNED_CONTEXT``), m; None when it declares none, one not known here, or several different
    ones."""
    text = path.read_text(encoding="latin-1")
    ids = {i.strip() for ctx in re.findall(r"GLOBAL_UNIT_ASSIGNED_CONTEXT\s*\(\s*\(([^)]*)\)", text)
           for i in ctx.split(",")}
    found = set()
    for ref in sorted(ids):
        m = re.search(re.escape(ref) + r"\s*=\s*([^;]*);", text)
        if m is None or "LENGTH_UNIT" not in m.group(1):
            continue
        entity = m.group(1)
        si = re.search(r"SI_UNIT\s*\(\s*(\$|\.\w+\.)\s*,\s*\.METRE\.\s*\)", entity)
        named = re.search(r"CONVERSION_BASED_UNIT\s*\(\s*'([^']*)'", entity)
        if named and named.group(1).upper() in STEP_NAMED_UNITS:
            found.add(STEP_NAMED_UNITS[named.group(1).upper()])
        elif si and si.group(1) in STEP_PREFIXES and not named:
            found.add(STEP_PREFIXES[si.group(1)])
        else:
            return None
    return found.pop() if len(found) == 1 else None


def _name(shape, solids: list, block: Block) -> None:
    """Name the cells by region and rename the faces; raises ValueError for names the file does not hold."""
    in_file = sorted({s.name for s in solids if s.name})
    unknown = sorted(set(block.solids) - set(in_file))
    if unknown:
        raise ValueError(f"solids: no solid {unknown[0]!r} in file {block.file!r} (its named solids: "
                         f"{in_file or 'none; BREP files keep no names'})")
    faces = list(shape.faces)
    face_names = sorted({f.name for f in faces if f.name})
    unknown = sorted(set(block.faces) - set(face_names))
    if unknown:
        raise ValueError(f"faces: no face {unknown[0]!r} in file {block.file!r} (its named faces: "
                         f"{face_names or 'none'})")
    for s in solids:
        s.name = block.solids.get(s.name, block.name) if s.name else block.name
    before = [f.name for f in faces]       # a face shared by two solids is listed twice: rename each once
    for f, old in zip(faces, before):
        if old in block.faces:
            f.name = block.faces[old]
