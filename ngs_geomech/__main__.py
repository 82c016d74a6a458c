"""``python -m ngs_geomech ...``: the command line (:mod:`ngs_geomech.cli`)."""

from .cli import entry

entry()
