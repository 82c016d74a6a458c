"""The adaptive loop for stationary problems: SOLVE -> ESTIMATE -> MARK -> REFINE until a :class:`StopRule` says
stop (a tolerance on the estimated error, a dof budget, a number of refinements).

A problem taking part implements :class:`AdaptiveProblem`: ``solve()`` on its current mesh (starting from the
last solution, transferred to the refined mesh, where the solver can use a start), ``ndof``,
``estimator_input(needs)`` (what a registered estimator needs: its forms, its contact operators and status, its
liquid fraction) and ``refine(marks)`` (refine the mesh, recurve it, rebuild spaces, forms and contact pairs
on the new mesh and transfer the state); optionally ``refinement``: how the element values are marked and in
which element order ``refine`` takes the marks (:class:`SerialRefinement` when absent,
:class:`.distributed.DistributedRefinement` on a distributed mesh: the whole mesh's marks, on rank 0).
:class:`StationaryHeat` is the one for steady heat problems;
:mod:`ngs_geomech.verification.adaptivity` has the Hertz contact one.

Refinement is netgen's marked bisection (:func:`refine_mesh`): ``mesh.SetRefinementFlags`` then
``mesh.Refine()``, which places the new boundary vertices on the geometry (OCC or geom2d) but drops the curved
element mapping, so the mesh is curved again to its order (``mesh.Curve``): curved boundaries stay exact to
the geometry order after every refinement.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Protocol

import ngsolve as ngs
import numpy as np

from ..heat.forms import HeatForms, HeatSetup
from ..heat.solver import HeatSolver
from .estimators import Estimate, get_estimator
from .marking import StopRule, get_marker


def refine_mesh(mesh, marks, curve_order: int = 0) -> None:
    """Bisect the marked volume elements (bool per element; netgen closes the refinement conformingly) and,
    with ``curve_order`` >= 2, curve the mesh again to that order."""
    marks = np.asarray(marks, dtype=bool)
    if marks.shape != (mesh.ne,):
        raise ValueError(f"marks must have one entry per volume element ({mesh.ne}), got shape {marks.shape}")
    mesh.SetRefinementFlags([bool(m) for m in marks])
    mesh.Refine()
    if curve_order >= 2:
        mesh.Curve(curve_order)


@dataclass
class Marking:
    """The decision of one step: ``total`` (sqrt(sum eta_T^2) over the whole mesh), ``elements`` (the whole
    mesh's count), ``marks`` (marker's marks or indicator flags, in the order :meth:`refine` takes them; None on the
    ranks that do not refine) and the counts ``marked`` (by the marker) and ``flagged`` (by the indicators only);
    every number is the same on every rank."""

    total: float
    elements: int
    marks: np.ndarray | None
    marked: int
    flagged: int


def decide(eta: np.ndarray, flags: np.ndarray, marker, theta: float) -> Marking:
    """The marking of the whole mesh's element values ``eta`` and indicator ``flags`` (serial numbers)."""
    total = float(math.sqrt(float(np.sum(eta ** 2))))
    marks = marker(eta, theta)
    return Marking(total, len(eta), marks | flags, int(marks.sum()), int((flags & ~marks).sum()))


class SerialRefinement:
    """The adaptive loop's marking and refinement on a serial mesh: the element values are the whole mesh's,
    refined in place (:func:`refine_mesh`)."""

    def mark(self, mesh, eta: np.ndarray, flags: np.ndarray, marker, theta: float) -> Marking:
        return decide(np.asarray(eta, dtype=float), np.asarray(flags, dtype=bool), marker, theta)

    def refine(self, mesh, marks: np.ndarray, curve_order: int):
        refine_mesh(mesh, marks, curve_order)
        return mesh


class Transfer:
    """Carries a nodal H1 field of a given order over one refinement: ``Transfer(mesh, order, values, dim)``
    before :func:`refine_mesh`, ``.vector(space)`` after it: the field interpolated (``Set``) into the refined
    mesh's H1 space of the same order (exact for the old field: the refined space contains it). The old field
    lives on a copy of the coarse mesh (curved to ``curve_order``). NGSolve's own ``autoupdate`` prolongation was
    not used: for P2 it changed a quadratic field by 1e-2 (relative) on a refined unit square."""

    def __init__(self, mesh, order: int, values, dim: int = 1, curve_order: int = 0):
        self.order, self.dim = order, dim
        self.old_mesh = ngs.Mesh(mesh.ngmesh.Copy())
        if curve_order >= 2:
            self.old_mesh.Curve(curve_order)
        space = self._space(self.old_mesh)
        self.gf = ngs.GridFunction(space)
        self.gf.vec.FV().NumPy()[:] = np.asarray(values)[:space.ndof]

    def _space(self, mesh):
        return ngs.H1(mesh, order=self.order) if self.dim == 1 else ngs.VectorH1(mesh, order=self.order)

    def vector(self, mesh) -> np.ndarray:
        """The field's coefficients in the H1 space of the same order on the refined ``mesh``."""
        g = ngs.GridFunction(self._space(mesh))
        g.Set(self.gf)
        return np.array(g.vec.FV().NumPy())


class AdaptiveProblem(Protocol):
    """What :func:`adaptive_solve` needs from a problem (see the module docstring)."""

    mesh: object

    @property
    def ndof(self) -> int: ...

    def solve(self) -> dict: ...

    def estimator_input(self, needs: str): ...

    def refine(self, marks: np.ndarray) -> None: ...


@dataclass
class AdaptiveStep:
    """One pass of the loop: mesh size (``ndof``, ``elements``), the ``estimate`` (the estimator's total),
    the numbers of ``marked`` (by the marker) and ``flagged`` (by the indicators) elements (0 on the last
    step), wall times in s, and the ``quantities`` the problem's solve returned."""

    refinement: int
    ndof: int
    elements: int
    estimate: float
    marked: int
    flagged: int
    solve_s: float
    estimate_s: float
    refine_s: float
    quantities: dict = field(default_factory=dict)

    @property
    def wall_s(self) -> float:
        return self.solve_s + self.estimate_s + self.refine_s


@dataclass
class AdaptiveRun:
    """The steps of one adaptive run and why it stopped (``stop``: "tolerance", "dof budget", "refinements")."""

    steps: list[AdaptiveStep]
    stop: str

    @property
    def wall_s(self) -> float:
        """Total wall time of the run (every solve, estimate and refinement), s."""
        return float(sum(s.wall_s for s in self.steps))

    def cumulative_wall_s(self) -> list[float]:
        """Wall time from the start to the end of each step's solve (estimates and refinements before it
        included), s."""
        out, acc = [], 0.0
        for s in self.steps:
            out.append(acc + s.solve_s)
            acc += s.wall_s
        return out


def evaluate(name: str, problem: AdaptiveProblem, options: dict | None = None) -> Estimate:
    """Run the registered estimator or indicator ``name`` on ``problem`` (with ``options``)."""
    entry = get_estimator(name)
    return entry.function(problem.estimator_input(entry.needs), **(options or {}))


def adaptive_solve(problem: AdaptiveProblem, *, estimator: str = "zz", indicators=(), marker: str = "doerfler",
                   theta: float = 0.5, stop: StopRule | None = None, options: dict | None = None,
                   callback=None) -> AdaptiveRun:
    """SOLVE -> ESTIMATE -> MARK -> REFINE on ``problem`` until ``stop``.

    ``estimator``: a registered estimator's name (:data:`~ngs_geomech.adapt.estimators.ESTIMATORS`, kind
    "estimator"); ``indicators``: names of registered indicators whose flagged elements are refined as well;
    ``marker`` and ``theta``: a registered marker (:data:`~ngs_geomech.adapt.marking.MARKERS`) and its
    parameter; ``stop``: the :class:`StopRule` (default: 20 refinements); ``options``: per name, keyword
    options of an estimator or indicator; ``callback(step, problem)`` after each step's estimate (e.g. to
    measure true errors on that mesh). Returns the steps and why the loop stopped."""
    options = options or {}
    stop = stop if stop is not None else StopRule()
    if get_estimator(estimator).kind != "estimator":
        raise ValueError(f"{estimator!r} is an indicator; pass it in indicators=")
    for name in indicators:
        get_estimator(name)
    mark = get_marker(marker)
    refinement = getattr(problem, "refinement", None) or SerialRefinement()
    steps: list[AdaptiveStep] = []
    refinements, growth = 0, 1.0
    while True:
        tic = time.perf_counter()
        quantities = problem.solve() or {}
        t_solve = time.perf_counter() - tic
        tic = time.perf_counter()
        est = evaluate(estimator, problem, options.get(estimator))
        flags = np.zeros(problem.mesh.ne, dtype=bool)
        for name in indicators:
            flags |= evaluate(name, problem, options.get(name)).eta > 0
        decision = refinement.mark(problem.mesh, est.eta, flags, mark, theta)
        t_est = time.perf_counter() - tic
        step = AdaptiveStep(refinements, problem.ndof, decision.elements, decision.total, 0, 0, t_solve, t_est, 0.0,
                            dict(quantities))
        steps.append(step)
        if callback is not None:
            callback(step, problem)
        reason = stop.reason(decision.total, problem.ndof, refinements, growth)
        if reason is not None:
            return AdaptiveRun(steps, reason)
        step.marked, step.flagged = decision.marked, decision.flagged
        before = problem.ndof
        tic = time.perf_counter()
        problem.refine(decision.marks)
        step.refine_s = time.perf_counter() - tic
        growth = problem.ndof / max(before, 1)
        refinements += 1


class StationaryHeat:
    """A steady heat problem (:class:`HeatSetup` with ``steady=True``) on a refinable mesh, for
    :func:`adaptive_solve`: forms, solver and mortar contact pairs rebuilt on each refined mesh, the last
    temperature transferred as the next start (Newton's start for the k(T) law; the Dirichlet values are set
    anew). ``curve_order``: the geometry order to curve to after each refinement (0: straight)."""

    def __init__(self, mesh, setup: HeatSetup, *, curve_order: int = 0):
        if not setup.steady:
            raise ValueError("StationaryHeat needs a steady HeatSetup (setup.steady = True)")
        self.mesh = mesh
        self.setup = setup
        self.curve_order = curve_order
        self._start = None
        self._build()

    def _build(self):
        self.forms = HeatForms(self.mesh, self.setup)
        self.solver = HeatSolver(self.forms)
        if self._start is not None:
            T = self.forms.temperature()
            T.vec.FV().NumPy()[:] = self._start

    @property
    def ndof(self) -> int:
        return int(self.forms.X.ndof)

    def solve(self) -> dict:
        self.forms.t_new.Set(0.0)
        info = self.solver.solve("adaptive steady heat")
        return {"iterations": info.iterations}

    def estimator_input(self, needs: str):
        if needs != "forms":
            raise ValueError(f"a heat problem has no {needs!r} input for an estimator")
        return self.forms

    def refine(self, marks) -> None:
        T = self.forms.temperature()
        keep = Transfer(self.mesh, self.setup.order, T.vec.FV().NumPy(), curve_order=self.curve_order)
        refine_mesh(self.mesh, marks, self.curve_order)
        self._start = keep.vector(self.mesh)
        self._build()


def transfer_contact_sets(old_coords: np.ndarray, old_sets: tuple, new_coords: np.ndarray) -> tuple:
    """The nodal sets (active, stick, slip: bool arrays over the old contact nodes at ``old_coords``, m) carried
    to the contact nodes of a refined mesh at ``new_coords`` (m): each new node takes the state of the nearest
    old node (a node of the old mesh keeps its own)."""
    old_coords, new_coords = np.asarray(old_coords, float), np.asarray(new_coords, float)
    d = np.linalg.norm(new_coords[:, None, :] - old_coords[None, :, :], axis=2)
    nearest = np.argmin(d, axis=1)
    return tuple(np.asarray(s, dtype=bool)[nearest] for s in old_sets)
