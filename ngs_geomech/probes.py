"""Probes: a field's value at a point, or its max/min/mean over a region or boundary, over time; front probes:
where a field first crosses a level along a line (the phase boundary: liquid_fraction = 1/2)."""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from . import parallel
from .errors import Problem, SceneError
from .geometry.isolines import first_crossing
from .scene.model import PROBE_THERMAL, Probe

THERMAL = PROBE_THERMAL
"""The probe quantities recorded at every step (declared with the key ``output.probes.quantity``)."""
VOLUME_SAMPLES = {2: {ngs.TRIG: [(0, 0), (1, 0), (0, 1), (1 / 3, 1 / 3)],
                      ngs.QUAD: [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5)]},
                  3: {ngs.TET: [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0.25, 0.25, 0.25)],
                      ngs.HEX: [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)] + [(0.5, 0.5, 0.5)]}}
"""Reference points where a region's max / min probe samples each element type: the vertices and the centre."""
BOUNDARY_SAMPLES = {2: {ngs.SEGM: [(0,), (1,)]},
                    3: {ngs.TRIG: [(0, 0), (1, 0), (0, 1)], ngs.QUAD: [(0, 0), (1, 0), (1, 1), (0, 1)]}}
"""Reference points where a boundary's max / min probe samples each boundary element type: the vertices."""


def _sample_rules(points: dict) -> dict:
    return {et: ngs.IntegrationRule(pts, [0.0] * len(pts)) for et, pts in points.items()}


FRONT_LEVEL = 0.5
MAX_LINE_SAMPLES = 20000


class ProbeSet:
    """Evaluates the scene's probes; keeps a time series per probe.

    ``record(t, fields, kind)`` samples the probes whose quantity is in ``fields`` (a dict quantity -> CF or
    GridFunction); thermal probes are recorded at every step, mechanical ones when mechanics is solved.
    max/min over a region sample every element of it at its vertices and centre (the element's own values,
    also where fields jump between regions); over a boundary, the boundary elements' vertices. mean is the
    integral mean (weighted by r in axisymmetric scenes).

    Front probes (``line``, quantity 'front', given the liquid fraction as the field) sample the field from the
    line's first point to its second at a spacing of 1/8 of the shortest mesh edge (at most 20000 points;
    points outside the mesh are skipped) and record the distance (m) from the first point to the first crossing
    of 1/2 (:func:`first_crossing`), or None when there is none.
    """

    def __init__(self, mesh, probes: list[Probe], axisymmetric: bool):
        self.mesh = mesh
        self.probes = probes
        self.w = ngs.x if axisymmetric else ngs.CoefficientFunction(1.0)
        self.times: dict[str, list[float]] = {p.name: [] for p in probes}
        self.series: dict[str, list[float]] = {p.name: [] for p in probes}
        self._points = {}
        self._samples = {}
        self._lines = {}
        problems = []
        hmin = None
        for p in probes:
            if p.line is not None:
                if hmin is None:
                    hmin = _shortest_edge(mesh)
                a, b = (np.asarray(q, dtype=float) for q in p.line)
                length = float(np.linalg.norm(b - a))
                n = int(min(MAX_LINE_SAMPLES, max(100, math.ceil(8 * length / hmin)))) + 1
                s = np.linspace(0.0, length, n)
                xyz = a[None, :] + (s / length)[:, None] * (b - a)[None, :]
                mips = mesh(*xyz.T)
                inside = mips["nr"] >= 0                  # in this rank's part (a distributed mesh)
                if not parallel.anyof(mesh, inside[0]):
                    problems.append(Problem(f"output.probes ({p.name}).line", f"the first point {p.line[0]} is not "
                                            "inside the mesh"))
                self._lines[p.name] = (s, mips[inside], inside)
            elif p.point is not None:
                mip = mesh(*p.point)
                if not parallel.anyof(mesh, mip.nr >= 0):
                    problems.append(Problem(f"output.probes ({p.name}).point", f"{p.point} is not inside the mesh"))
                self._points[p.name] = mip
            elif p.statistic in ("max", "min"):
                if p.region:
                    rules = _sample_rules(VOLUME_SAMPLES[mesh.dim])
                    self._samples[p.name] = mesh.MapToAllElements(rules, mesh.Materials(p.region))
                else:
                    rules = _sample_rules(BOUNDARY_SAMPLES[mesh.dim])
                    self._samples[p.name] = mesh.MapToAllElements(rules, mesh.Boundaries(p.boundary))
        if problems:
            raise SceneError(problems)

    def record(self, t: float, fields: dict) -> None:
        for p in self.probes:
            if p.quantity not in fields:
                continue
            cf = fields[p.quantity]
            if p.line is not None:
                s, mips, inside = self._lines[p.name]
                vals = np.full(len(s), np.nan)
                if inside.any():
                    vals[inside] = np.asarray(cf(mips), dtype=float).ravel()
                vals = parallel.first_valid(self.mesh, vals)
                self.times[p.name].append(float(t))
                self.series[p.name].append(first_crossing(s, vals, FRONT_LEVEL))
                continue
            if p.point is not None:
                mip = self._points[p.name]
                v = float(cf(mip)) if mip.nr >= 0 else math.nan
                v = float(parallel.first_valid(self.mesh, np.array([v]))[0])
            elif p.statistic in ("max", "min"):
                samples = self._samples[p.name]
                vals = np.asarray(cf(samples)).ravel() if len(samples) else np.zeros(0)
                if p.statistic == "max":
                    v = parallel.allmax(self.mesh, float(vals.max()) if vals.size else -math.inf)
                else:
                    v = parallel.allmin(self.mesh, float(vals.min()) if vals.size else math.inf)
            else:
                # Integrate(cf, mesh, vb, definedon=...) is global on a distributed mesh (Integrate(cf * dx, mesh)
                # is this rank's part only)
                vb, where = ((ngs.VOL, self.mesh.Materials(p.region)) if p.region
                             else (ngs.BND, self.mesh.Boundaries(p.boundary)))
                v = float(ngs.Integrate(self.w * cf, self.mesh, vb, definedon=where)
                          / ngs.Integrate(self.w, self.mesh, vb, definedon=where))
            if not math.isfinite(v):
                raise ValueError(f"probe {p.name} is not finite at t = {t}")
            self.times[p.name].append(float(t))
            self.series[p.name].append(v)


def _shortest_edge(mesh) -> float:
    """The length of the shortest mesh edge, m (over all parts of a distributed mesh)."""
    if mesh.nv == 0:                             # rank 0 of a distributed mesh
        return parallel.allmin(mesh, math.inf)
    pts = np.array([v.point for v in mesh.vertices])
    ends = np.array([[v.nr for v in e.vertices] for e in mesh.edges])
    return parallel.allmin(mesh, float(np.min(np.linalg.norm(pts[ends[:, 0]] - pts[ends[:, 1]], axis=1))))
