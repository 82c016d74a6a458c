"""ngs-geomech: coupled thermo-mechanical problems in geomechanics on NGSolve/Netgen.

After J. Nedoma, "Numerical Solutions of Coupled Thermo-Mechanical Problems with Applications in
Geomechanics" (2001). Entry points: :func:`ngs_geomech.api.run`, :func:`ngs_geomech.api.validate_scene`,
:func:`ngs_geomech.scene.parse.load_scene`; the scene objects are in :mod:`ngs_geomech.scene.model`.
"""

__version__ = "0.1.0"
