"""Probes: values of a field at a point, or its max/min/mean over a region or boundary, over time."""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .errors import Problem, SceneError
from .scene.model import Probe


class ProbeSet:
    """Evaluates the scene's probes on a scalar H1 GridFunction; keeps their time series.

    max/min use vertex values (exact for P1, the vertex values for higher order); mean is the integral mean
    (weighted by r in axisymmetric scenes).
    """

    def __init__(self, mesh, probes: list[Probe], axisymmetric: bool):
        self.mesh = mesh
        self.probes = probes
        self.w = ngs.x if axisymmetric else ngs.CoefficientFunction(1.0)
        self.times: list[float] = []
        self.series: dict[str, list[float]] = {p.name: [] for p in probes}
        self._vertices: dict[str, np.ndarray] = {}
        self._points = {}
        problems = []
        for p in probes:
            if p.point is not None:
                mip = mesh(*p.point)
                if mip.nr < 0:
                    problems.append(Problem(f"output.probes ({p.name}).point", f"{p.point} is not inside the mesh"))
                self._points[p.name] = mip
            else:
                region = mesh.Materials(p.region) if p.region else mesh.Boundaries(p.boundary)
                verts = set()
                for el in region.Elements():
                    verts.update(v.nr for v in el.vertices)
                self._vertices[p.name] = np.array(sorted(verts), dtype=int)
        if problems:
            raise SceneError(problems)

    def record(self, t: float, gf) -> None:
        self.times.append(float(t))
        vals = gf.vec.FV().NumPy()
        for p in self.probes:
            if p.point is not None:
                v = float(gf(self._points[p.name]))
            elif p.statistic in ("max", "min"):
                sub = vals[self._vertices[p.name]]
                v = float(sub.max() if p.statistic == "max" else sub.min())
            else:
                if p.region:
                    dx = ngs.dx(definedon=self.mesh.Materials(p.region))
                else:
                    dx = ngs.ds(definedon=self.mesh.Boundaries(p.boundary))
                v = float(ngs.Integrate(self.w * gf * dx, self.mesh) / ngs.Integrate(self.w * dx, self.mesh))
            if not math.isfinite(v):
                raise ValueError(f"probe {p.name} is not finite at t = {t}")
            self.series[p.name].append(v)
