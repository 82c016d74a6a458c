"""ngs-geomech: coupled thermo-mechanical problems in geomechanics on NGSolve/Netgen.

After J. Nedoma, "Numerical Solutions of Coupled Thermo-Mechanical Problems with Applications in
Geomechanics" (2001). Entry points: :func:`ngs_geomech.api.run`, :func:`ngs_geomech.api.validate_scene`,
:func:`ngs_geomech.scene.parse.load_scene`; the scene objects are in :mod:`ngs_geomech.scene.model`.
"""

import logging as _logging

__version__ = "0.1.0"

# the package's messages (warnings of a run, notes, solver diagnostics) go to the "ngs_geomech" loggers; the
# application (the command line, a script) decides where they go
_logging.getLogger(__name__).addHandler(_logging.NullHandler())

# before any MPI starts in this process: rank 0 of a distributed run sleeps in MPI's waits (parallel.py)
from .parallel import sleep_while_waiting_on_rank_zero as _quiet  # noqa: E402

_quiet()
