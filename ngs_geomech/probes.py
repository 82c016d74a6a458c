"""Probes: a field's value at a point, or its max/min/mean over a region or boundary, over time."""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .errors import Problem, SceneError
from .scene.model import Probe

THERMAL = ("temperature",)


class ProbeSet:
    """Evaluates the scene's probes; keeps a time series per probe.

    ``record(t, fields, kind)`` samples the probes whose quantity is in ``fields`` (a dict quantity -> CF or
    GridFunction); thermal probes are recorded at every step, mechanical ones when mechanics is solved.
    max/min over a region sample every element of it at its vertices and centre (the element's own values,
    also where fields jump between regions); over a boundary, the boundary elements' vertices. mean is the
    integral mean (weighted by r in axisymmetric scenes).
    """

    def __init__(self, mesh, probes: list[Probe], axisymmetric: bool):
        self.mesh = mesh
        self.probes = probes
        self.w = ngs.x if axisymmetric else ngs.CoefficientFunction(1.0)
        self.times: dict[str, list[float]] = {p.name: [] for p in probes}
        self.series: dict[str, list[float]] = {p.name: [] for p in probes}
        self._points = {}
        self._samples = {}
        problems = []
        for p in probes:
            if p.point is not None:
                mip = mesh(*p.point)
                if mip.nr < 0:
                    problems.append(Problem(f"output.probes ({p.name}).point", f"{p.point} is not inside the mesh"))
                self._points[p.name] = mip
            elif p.statistic in ("max", "min"):
                if p.region:
                    et = ngs.TRIG if mesh.dim == 2 else ngs.TET
                    pts = [(0, 0), (1, 0), (0, 1), (1 / 3, 1 / 3)] if mesh.dim == 2 else \
                        [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0.25, 0.25, 0.25)]
                    ir = ngs.IntegrationRule(pts, [0.0] * len(pts))
                    self._samples[p.name] = mesh.MapToAllElements({et: ir}, mesh.Materials(p.region))
                else:
                    et = ngs.SEGM if mesh.dim == 2 else ngs.TRIG
                    pts = [(0,), (1,)] if mesh.dim == 2 else [(0, 0), (1, 0), (0, 1)]
                    ir = ngs.IntegrationRule(pts, [0.0] * len(pts))
                    self._samples[p.name] = mesh.MapToAllElements({et: ir}, mesh.Boundaries(p.boundary))
        if problems:
            raise SceneError(problems)

    def record(self, t: float, fields: dict) -> None:
        for p in self.probes:
            if p.quantity not in fields:
                continue
            cf = fields[p.quantity]
            if p.point is not None:
                v = float(cf(self._points[p.name]))
            elif p.statistic in ("max", "min"):
                vals = np.asarray(cf(self._samples[p.name])).ravel()
                v = float(vals.max() if p.statistic == "max" else vals.min())
            else:
                if p.region:
                    dx = ngs.dx(definedon=self.mesh.Materials(p.region))
                else:
                    dx = ngs.ds(definedon=self.mesh.Boundaries(p.boundary))
                v = float(ngs.Integrate(self.w * cf * dx, self.mesh) / ngs.Integrate(self.w * dx, self.mesh))
            if not math.isfinite(v):
                raise ValueError(f"probe {p.name} is not finite at t = {t}")
            self.times[p.name].append(float(t))
            self.series[p.name].append(v)
