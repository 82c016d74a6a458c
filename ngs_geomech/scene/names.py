"""The rule for names that become part of output file names.

The scene name (``<scene>.pvd``, ``<scene>_stepNNNNN.vtu``), interface and foundation names
(``contact_<name>.png``, ``<scene>_contact_<name>.pvd``), uncertainty criterion names (``samples_<name>.png``),
and the probe, block and boundary names a scene refers to must be plain file names: a name holding ``/``,
``..``, a NUL or nothing would put a file outside the output directory, make it hidden, or fail at the first
write. Validation checks every such name with :func:`name_problem`; the writers check theirs again with
:func:`plain_file_name` (a scene built in Python may skip validation).
"""

from __future__ import annotations

import re

MAX_LENGTH = 64
_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
RULE = (f"a name is 1 to {MAX_LENGTH} characters: letters, digits, '_', '-' and '.', starting with a letter, "
        "digit or '_', without '..' (it becomes part of output file names)")


def name_problem(name: object) -> str | None:
    """Why ``name`` cannot be part of a file name (with the rule), or None when it can."""
    if not isinstance(name, str):
        return f"expected a string, got {name!r}; {RULE}"
    if not name:
        return f"the name is empty; {RULE}"
    if len(name) > MAX_LENGTH:
        return f"{name[:20]!r}... has {len(name)} characters; {RULE}"
    if not _PLAIN.fullmatch(name) or ".." in name:
        return f"{name!r} is not allowed; {RULE}"
    return None


def plain_file_name(name: str) -> str:
    """``name`` itself when it is a plain file name (the characters of :data:`RULE`, any length: writers join
    checked names, e.g. ``<scene>_contact_<interface>``); raises ValueError otherwise (for the writers)."""
    if not isinstance(name, str) or not _PLAIN.fullmatch(name) or ".." in name:
        raise ValueError(f"refusing to write a file named after {name!r}: not a plain file name ({RULE})")
    return name
