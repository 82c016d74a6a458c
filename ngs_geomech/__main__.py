"""``python -m ngs_geomech ...``: the command line (:mod:`ngs_geomech.cli`)."""

import sys

from .cli import main

sys.exit(main())
