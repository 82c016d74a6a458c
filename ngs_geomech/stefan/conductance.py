"""Contact conductance in the Stefan forms (:class:`NodalConductances`): the jump penalty of
:mod:`ngs_geomech.stefan.forms` with the penalty gamma_c replaced by the physical conductance h of
:mod:`ngs_geomech.heat.conductance`, node by node,

    A_Gamma T = B^T diag(h_i / D_i) B T,     (B T)_i = int_Gamma w mu_i (T_m - T_s) ds,   D_i = int_Gamma w mu_i ds,

mu_i the P1 hat functions of the master side's vertices and h_i = h(p_i, g_i) (+ h_rad,i) at vertex i from the
contact state there (the mechanics' nodal pressure and gap, or the geometry's). (B T)_i / D_i is the jump averaged
around node i, so the heat flux through node i's part of the interface is h_i times that jump: for a jump that
is constant (two slabs in steady state) the flux is h times the jump exactly. The integrals use the quadrature of
:mod:`ngs_geomech.fem.interface_quadrature` (segment-based; across an open gap the partner points up to the
interface's reach). Columns sum to zero (B 1 = 0): the heat leaving one side enters the other, so the energy
balance stays exact; the matrix is symmetric positive semi-definite (the step stays monotone). Radiation enters
linearized (h_rad at the nodal mean temperatures of the two sides at the start of the step: the enthalpy solver's
interface group is linear in T). Units: h W/(m^2 K), the matrix W/K per m of depth (plane) or W/K (3D).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..fem.interface_quadrature import interface_quadrature
from ..heat.conductance import ContactNodes, InterfaceConductance


@dataclass
class _Interface:
    spec: InterfaceConductance
    vertices: np.ndarray        # master vertices with D > 0 (mesh vertex numbers)
    B: sp.csr_matrix            # (m x n)
    D: np.ndarray               # (m,)
    Tm: sp.csr_matrix           # (m x n): the nodal mean of T_m, (Q^T w P_m) / D
    Ts: sp.csr_matrix
    gap0: np.ndarray            # the geometry's nodal gap, m
    h: np.ndarray
    h_rad: np.ndarray
    source: str = "geometry"


class NodalConductances:
    """The conductance interfaces ``specs`` of a Stefan problem on the P1 space ``V`` (module docstring)."""

    def __init__(self, mesh, V, specs: list[InterfaceConductance], *, axisymmetric: bool = False):
        self.n = V.ndof
        self.items: list[_Interface] = []
        for s in specs:
            q = interface_quadrature(mesh, V, s.master, s.minion, order=2, axisymmetric=axisymmetric, reach=s.reach)
            Q = q.nodal[:, q.vertices].tocsc()
            D = np.asarray(Q.T @ q.weights).ravel()
            keep = D > 0
            Qw = (sp.diags(q.weights) @ Q[:, keep]).T.tocsr()              # (m x nq): w mu_i at the points
            Dk = D[keep]
            inv = sp.diags(1.0 / Dk)
            gap0 = (Qw @ q.distance) / Dk if s.initial_gap else np.zeros(len(Dk))
            item = _Interface(s, q.vertices[keep], (Qw @ q.jump).tocsr(), Dk, (inv @ Qw @ q.master).tocsr(),
                              (inv @ Qw @ q.minion).tocsr(), gap0, np.zeros(len(Dk)), np.zeros(len(Dk)))
            self.items.append(item)
            self._geometry(item)

    @property
    def lagged_radiation(self) -> bool:
        return any(it.spec.emissivity is not None for it in self.items)

    @staticmethod
    def _geometry(it: _Interface) -> None:
        it.h = it.spec.conductance(np.zeros(len(it.D)), it.gap0)
        it.source = "geometry"

    def set_state(self, states: dict[str, ContactNodes] | None) -> bool:
        """The nodal contact state per interface name (None or a missing name: the geometry's); returns whether a
        conductance changed."""
        before = [it.h.copy() for it in self.items]
        self._set_state(states)
        return not all(np.array_equal(h, it.h) for h, it in zip(before, self.items))

    def _set_state(self, states: dict[str, ContactNodes] | None) -> None:
        for it in self.items:
            nodes = (states or {}).get(it.spec.name)
            if nodes is None:
                self._geometry(it)
                continue
            index = {int(v): k for k, v in enumerate(nodes.vertices)}
            rows = np.array([index.get(int(v), -1) for v in it.vertices])
            found = rows >= 0
            p = np.where(found, np.asarray(nodes.pressure)[np.maximum(rows, 0)], 0.0)
            g = np.where(found, np.asarray(nodes.gap)[np.maximum(rows, 0)], it.gap0)
            it.h = it.spec.conductance(np.maximum(p, 0.0), g)
            it.source = "mechanics"

    def lag(self, T: np.ndarray) -> None:
        """The radiation conductances at the nodal temperatures ``T`` (K or degC, as the scene)."""
        for it in self.items:
            if it.spec.emissivity is not None:
                it.h_rad = it.spec.radiation_conductance(it.Tm @ T, it.Ts @ T)

    def matrix(self, structure: bool = False) -> sp.csr_matrix:
        """The matrix sum B^T diag((h + h_rad) / D) B (W/K); ``structure``: a matrix whose pattern holds that of every
        conductance (the pattern the Newton matrices keep)."""
        total = sp.csr_matrix((self.n, self.n))
        for it in self.items:
            if structure:                # |B|^T |B|: no entry cancels, the pattern holds every product
                total = total + abs(it.B).T @ sp.diags(1.0 / it.D) @ abs(it.B)
            else:
                total = total + it.B.T @ sp.diags((it.h + it.h_rad) / it.D) @ it.B
        return total.tocsr()

    def flows(self, T: np.ndarray) -> dict[str, float]:
        """The heat flow master -> minion per interface at the nodal temperatures ``T``, W (per m of depth in
        plane scenes)."""
        return {it.spec.name: float((it.h + it.h_rad) @ (it.B @ T)) for it in self.items}

    def ranges(self) -> dict[str, tuple[float, float]]:
        """(min, max) of the nodal conductance per interface, W/(m^2 K)."""
        return {it.spec.name: (float(np.min(it.h + it.h_rad, initial=np.inf)),
                               float(np.max(it.h + it.h_rad, initial=0.0))) for it in self.items}
