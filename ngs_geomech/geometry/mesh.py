"""Meshing an assembled geometry with netgen."""

from __future__ import annotations

import ngsolve as ngs

from ..scene.model import MeshSettings
from .assemble import GeometryModel


def make_mesh(geo: GeometryModel, settings: MeshSettings):
    """Mesh the geometry (sizes from blocks, boundaries and ``settings``); curve it to the field order."""
    ngmesh = geo.occ_geometry().GenerateMesh(maxh=settings.maxh, grading=settings.grading)
    mesh = ngs.Mesh(ngmesh)
    if settings.order > 1:
        mesh.Curve(settings.order)
    return mesh
