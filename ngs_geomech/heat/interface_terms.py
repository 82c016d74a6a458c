"""The contact-conductance interfaces of one heat problem (:class:`InterfaceTerms`): what
:class:`~ngs_geomech.heat.forms.HeatForms` adds to its step for them.

With the theta scheme of the heat forms the interface term of (C1) (:mod:`ngs_geomech.heat.conductance`) enters
like the conduction term: theta c(T) + (1 - theta) c(T0) with c(T) = int w q(T) (v_m - v_s) ds. Its linear part
is the matrix C = sum over the interfaces of J^T diag(w h) J (symmetric positive semi-definite, C 1 = 0: the heat
leaving one side enters the other, so the energy balance stays exact); exact radiation adds the vector
J^T w q_rad(T) and its Jacobian (Newton's method of the heat solver). The matrices act on the temperature dofs,
the first block of the heat state (the mortar multipliers follow).
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..fem.interface_quadrature import interface_quadrature
from .conductance import ConductanceTerm, ContactNodes, InterfaceConductance


class InterfaceTerms:
    """The conductance terms of ``specs`` on the temperature space ``V`` (order ``order``) of a heat state with
    ``ndof`` dofs (module docstring); ``version`` changes with every change of the conductances."""

    def __init__(self, mesh, V, specs: list[InterfaceConductance], *, order: int, axisymmetric: bool, ndof: int,
                 quadratures: list | None = None, sizes: tuple[int, int] | None = None):
        """``quadratures`` (one per spec) and ``sizes`` (temperature dofs, vertices) given: the terms on them, in
        their numbering (a distributed mesh's global one, :mod:`.distributed`), instead of this part's own."""
        self.nV, self.ndof = (V.ndof, ndof) if sizes is None else (sizes[0], ndof)
        nv = mesh.nv if sizes is None else sizes[1]
        if quadratures is None:
            quadratures = [interface_quadrature(mesh, V, s.master, s.minion, order=2 * order + 2,
                                                axisymmetric=axisymmetric, reach=s.reach) for s in specs]
        self.terms = [ConductanceTerm(s, q, nv) for s, q in zip(specs, quadratures)]
        self.version = 0
        self._C = None
        self._coupling = (None, None)

    @property
    def exact_radiation(self) -> bool:
        return any(t.spec.exact_radiation for t in self.terms)

    @property
    def lagged_radiation(self) -> bool:
        return any(t.spec.lagged_radiation for t in self.terms)

    def _changed(self) -> None:
        self._C = None
        self.version += 1

    def set_state(self, states: dict[str, ContactNodes] | None) -> bool:
        """The contact state per interface name (the mechanics'); interfaces not in ``states`` (or None) take the
        state of the geometry. Returns whether a conductance changed."""
        before = [t.h.copy() for t in self.terms]
        for t in self.terms:
            node = (states or {}).get(t.spec.name)
            if node is None:
                t.set_geometry()
            else:
                t.set_nodes(node)
        if all(np.array_equal(h, t.h) for h, t in zip(before, self.terms)):
            return False
        self._changed()
        return True

    def lag(self, T: np.ndarray) -> None:
        """The lagged radiation conductances at the temperature dofs ``T``."""
        for t in self.terms:
            if t.spec.lagged_radiation:
                t.lag_radiation(T)
        self._changed()

    def matrix(self) -> sp.csr_matrix:
        """C (nV x nV), W/K."""
        if self._C is None:
            self._C = sum((t.matrix() for t in self.terms), sp.csr_matrix((self.nV, self.nV))).tocsr()
        return self._C

    def coupling(self, mortar: tuple | None, theta: float) -> object:
        """The mortar entries ``mortar`` (COO arrays over the state, or None) plus theta C, an NGSolve matrix of the
        state's size (cached per theta and version)."""
        key = (theta, self.version)
        if self._coupling[0] == key:
            return self._coupling[1]
        C = (theta * self.matrix()).tocoo()
        parts = [(C.row, C.col, C.data)] + ([mortar] if mortar is not None else [])
        r, c, v = (np.concatenate([p[k] for p in parts]) for k in range(3))
        mat = ngs.la.SparseMatrixd.CreateFromCOO(list(map(int, r)), list(map(int, c)), list(map(float, v)),
                                                 self.ndof, self.ndof)
        self._coupling = (key, mat)
        return mat

    def old_terms(self, T_old: np.ndarray) -> np.ndarray:
        """c(T0) = C T0 (+ the exact radiation vector at T0), over the temperature dofs, W."""
        out = self.matrix() @ T_old
        if self.exact_radiation:
            out = out + self.radiation(T_old)[0]
        return out

    def radiation(self, T: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """The exact radiation terms at ``T``: their vector (W) and Jacobian (W/K), over the temperature dofs."""
        vec, jac = np.zeros(self.nV), sp.csr_matrix((self.nV, self.nV))
        for t in self.terms:
            if t.spec.exact_radiation:
                v, j = t.radiation(T)
                vec, jac = vec + v, jac + j
        return vec, jac.tocsr()

    def flows(self, T: np.ndarray) -> dict[str, float]:
        """The heat flow master -> minion per interface at ``T``, W (per m of depth, plane; per radian,
        axisymmetric)."""
        return {t.spec.name: t.flow(T) for t in self.terms}

    def ranges(self) -> dict[str, tuple[float, float]]:
        """(min, max) of the conductance per interface, W/(m^2 K)."""
        return {t.spec.name: t.conductance_range() for t in self.terms}
