"""Thermal contact conductance of a contact interface: the heat flux across it follows the mechanics' contact
state (seed (2.22) relaxed to imperfect contact; Madhusudana, Thermal Contact Conductance, 2014, ch. 1-3).

Flux from the master side to the minion side, W/m^2, at a point of the interface with the contact pressure p
(Pa, compression > 0) and the gap g (m) of the mechanics:

    q = h(p, g) (T_m - T_s) + sigma eps (T_m^4 - T_s^4),                                      (C1)
    h(p, g) = h_c(p) [closed] + k_gap / max(g, g_min) [with a gap conductivity],              (C2)

the three paths in parallel: conduction through the touching spots h_c where the interface is closed (p > 0 or
g <= 0), conduction through the gas (or fill) of the gap, and radiation between the faces (T absolute: K, the
scene's temperatures + 273.15 in a scene in degC). h_c is one of

    a number h (W/(m^2 K)),  a power law h_c = C p^m (C in W/(m^2 K) Pa^-m),  a table p -> h_c (piecewise linear,
    constant beyond its ends);

k_gap (W/(m K)) the gap conductivity and g_min (m) the gap floor (the surfaces' roughness: an open gap thinner
than that conducts as one of g_min, so k_gap / g stays finite at closure); eps = 1/(1/eps_1 + 1/eps_2 - 1) the
effective emissivity of two parallel grey faces, sigma = 5.670374419e-8 W/(m^2 K^4). 'perfect' contact (T and the
flux continuous) is the limit h -> infinity: the mortar coupling of the heat forms, the jump penalty of the
Stefan forms.

The state (p, g) is given at the master side's vertices (the contact side S of the mechanics, whose nodal
pressure and gap the contact solver returns, :func:`ngs_geomech.contact.problem.interface_results`) and
interpolated by the P1 hat functions; without mechanics it comes from the geometry (p = 0; g = 0 between
touching blocks, the distance to the other side across an initial gap). Radiation is either exact (Newton
linearizes T^4) or 'linearized': q_rad = h_rad (T_m - T_s) with h_rad = sigma eps (T_m^2 + T_s^2)(T_m + T_s) at
the temperatures of the start of the step (lagged; exact in the steady limit).
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..fem.interface_quadrature import InterfaceQuadrature

STEFAN_BOLTZMANN = 5.670374419e-8
"""sigma, W/(m^2 K^4)."""

KELVIN = 273.15


class ContactConductanceLaw(abc.ABC):
    """h_c(p) of the closed parts of an interface, W/(m^2 K); ``uses_pressure``: it needs the contact pressure of
    the mechanics (a run without mechanics cannot evaluate it)."""

    uses_pressure = True

    @abc.abstractmethod
    def __call__(self, p: np.ndarray) -> np.ndarray:
        """h_c at the pressures ``p`` (Pa, >= 0)."""

    @abc.abstractmethod
    def describe(self) -> str:
        """The law in words (summary)."""


@dataclass(frozen=True)
class ConstantConductance(ContactConductanceLaw):
    h: float
    uses_pressure = False

    def __call__(self, p):
        return np.full(np.shape(p), self.h)

    def describe(self) -> str:
        return f"h = {self.h:g} W/(m^2 K)"


@dataclass(frozen=True)
class PowerLawConductance(ContactConductanceLaw):
    """h_c = C p^m (p in Pa)."""

    coefficient: float
    exponent: float

    def __call__(self, p):
        return self.coefficient * np.power(np.maximum(p, 0.0), self.exponent)

    def describe(self) -> str:
        return f"h = {self.coefficient:g} p^{self.exponent:g} W/(m^2 K), p in Pa"


@dataclass(frozen=True)
class TableConductance(ContactConductanceLaw):
    """h_c(p) interpolated linearly in the table ``pressures`` (Pa, increasing) -> ``values`` (W/(m^2 K)),
    constant beyond the ends."""

    pressures: tuple
    values: tuple

    @property
    def uses_pressure(self) -> bool:
        return len(set(self.values)) > 1

    def __call__(self, p):
        return np.interp(p, self.pressures, self.values)

    def describe(self) -> str:
        return f"table of {len(self.pressures)} rows p (Pa) -> h (W/(m^2 K))"


def contact_law(conductance, coefficient, exponent) -> ContactConductanceLaw | None:
    """The closed-part law from an interface's keys (``conductance``: a number or a table [[p, h], ...];
    ``conductance_coefficient``, ``conductance_exponent``: the power law), or None (no conduction through the
    touching spots)."""
    if coefficient is not None:
        return PowerLawConductance(float(coefficient), float(exponent))
    if conductance is None or conductance == "perfect":
        return None
    if isinstance(conductance, (list, tuple)):
        rows = sorted((float(p), float(h)) for p, h in conductance)
        return TableConductance(tuple(r[0] for r in rows), tuple(r[1] for r in rows))
    return ConstantConductance(float(conductance))


@dataclass(frozen=True)
class InterfaceConductance:
    """The thermal settings of one contact interface with a conductance (module docstring): ``name`` (the
    interface's), ``master``/``minion`` (its two boundaries), ``law`` (h_c of the closed parts or None),
    ``gap_conductivity`` (k_gap, W/(m K), or None), ``minimum_gap`` (g_min, m), ``emissivity`` (the effective
    eps, or None: no radiation), ``radiation`` ('exact' or 'linearized'), ``initial_gap`` (the sides are apart in
    the geometry), ``reach`` (m: the farthest partner point on the other side; None: half an element) and
    ``kelvin`` (added to the temperatures for radiation: 273.15 in degC scenes)."""

    name: str
    master: str
    minion: str
    law: ContactConductanceLaw | None = None
    gap_conductivity: float | None = None
    minimum_gap: float = 1e-6
    emissivity: float | None = None
    radiation: str = "exact"
    initial_gap: bool = False
    reach: float | None = None
    kelvin: float = 0.0

    @property
    def exact_radiation(self) -> bool:
        return self.emissivity is not None and self.radiation == "exact"

    @property
    def lagged_radiation(self) -> bool:
        return self.emissivity is not None and self.radiation == "linearized"

    def conductance(self, pressure: np.ndarray, gap: np.ndarray) -> np.ndarray:
        """h(p, g) of (C2), W/(m^2 K), at points or nodes with the pressures (Pa) and gaps (m) given."""
        pressure = np.asarray(pressure, dtype=float)
        gap = np.asarray(gap, dtype=float)
        h = np.zeros(pressure.shape)
        if self.law is not None:
            h += np.where(closed(pressure, gap), self.law(np.maximum(pressure, 0.0)), 0.0)
        if self.gap_conductivity is not None:
            h += self.gap_conductivity / np.maximum(gap, self.minimum_gap)
        return h

    def radiation_flux(self, Tm: np.ndarray, Ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, dq/dT_m, dq/dT_s) of the radiation term of (C1), W/m^2 and W/(m^2 K); zeros without radiation."""
        if self.emissivity is None:
            z = np.zeros(np.shape(Tm))
            return z, z, z
        a, b = np.asarray(Tm) + self.kelvin, np.asarray(Ts) + self.kelvin
        se = STEFAN_BOLTZMANN * self.emissivity
        return se * (a ** 4 - b ** 4), 4 * se * a ** 3, -4 * se * b ** 3

    def radiation_conductance(self, Tm: np.ndarray, Ts: np.ndarray) -> np.ndarray:
        """h_rad = sigma eps (T_m^2 + T_s^2)(T_m + T_s) (absolute T), W/(m^2 K): q_rad = h_rad (T_m - T_s)."""
        if self.emissivity is None:
            return np.zeros(np.shape(Tm))
        a, b = np.asarray(Tm) + self.kelvin, np.asarray(Ts) + self.kelvin
        return STEFAN_BOLTZMANN * self.emissivity * (a * a + b * b) * (a + b)


def closed(pressure: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """Where an interface is closed: a contact pressure, or no gap (bool)."""
    return (np.asarray(pressure) > 0) | (np.asarray(gap) <= 0)


def effective_emissivity(e1: float, e2: float) -> float:
    """The effective emissivity eps = 1/(1/e1 + 1/e2 - 1) of two parallel grey faces."""
    return 1.0 / (1.0 / e1 + 1.0 / e2 - 1.0)


@dataclass
class ContactNodes:
    """The contact state of one interface at the master side's vertices: ``side`` (the master boundary's name),
    ``vertices`` (mesh vertex numbers), ``pressure`` (Pa, >= 0), ``gap`` (m; <= 0 where closed)."""

    side: str
    vertices: np.ndarray
    pressure: np.ndarray
    gap: np.ndarray

    def closed_pressure(self) -> float:
        """The largest pressure (Pa; 0 when nowhere closed)."""
        return float(np.max(self.pressure, initial=0.0))

    def full(self, nv: int) -> tuple[np.ndarray, np.ndarray]:
        """(pressure, gap) as arrays over all ``nv`` mesh vertices (0 elsewhere)."""
        p, g = np.zeros(nv), np.zeros(nv)
        p[self.vertices] = self.pressure
        g[self.vertices] = self.gap
        return p, g


class ConductanceTerm:
    """The interface term of (C1) in a heat problem on the quadrature ``quad``
    (:mod:`ngs_geomech.fem.interface_quadrature`): int w q(T) (v_m - v_s) ds, for the settings ``spec``. The state
    is held at the points (``pressure``, ``gap``), the linear conductance h of (C2) in ``h`` (plus the lagged
    radiation conductance ``h_rad``)."""

    def __init__(self, spec: InterfaceConductance, quad: InterfaceQuadrature, nv: int):
        self.spec, self.quad, self.nv = spec, quad, nv
        self.jump = quad.jump
        self.h_rad = np.zeros(quad.size)
        self.source = "geometry"
        self.set_geometry()

    def set_geometry(self) -> None:
        """The state of the geometry: p = 0, g = 0 where touching blocks touch (the partner within half an element),
        else the distance to the other side."""
        self.pressure = np.zeros(self.quad.size)
        d = self.quad.distance
        self.gap = d.copy() if self.spec.initial_gap else np.where(self.quad.touching, 0.0, d)
        self.source = "geometry"
        self.h = self.spec.conductance(self.pressure, self.gap)

    def set_nodes(self, nodes: ContactNodes) -> None:
        """The mechanics' nodal state, interpolated to the points (P1)."""
        p, g = nodes.full(self.nv)
        self.pressure = np.maximum(self.quad.nodal @ p, 0.0)
        self.gap = self.quad.nodal @ g
        self.source = "mechanics"
        self.h = self.spec.conductance(self.pressure, self.gap)

    def lag_radiation(self, T: np.ndarray) -> None:
        """h_rad at the temperatures ``T`` (the coefficient vector of the temperature space)."""
        self.h_rad = self.spec.radiation_conductance(self.quad.master @ T, self.quad.minion @ T)

    def matrix(self) -> sp.csr_matrix:
        """J^T diag(w (h + h_rad)) J, W/K (per m of depth in plane scenes, per radian in axisymmetric ones)."""
        J = self.jump
        return (J.T @ sp.diags(self.quad.weights * (self.h + self.h_rad)) @ J).tocsr()

    def radiation(self, T: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """The exact radiation term: its vector J^T w q_rad (W) and its Jacobian J^T diag(w dq/dT_m) P_m +
        J^T diag(w dq/dT_s) P_s at ``T``."""
        q, dm, ds = self.spec.radiation_flux(self.quad.master @ T, self.quad.minion @ T)
        w = self.quad.weights
        J = self.jump
        jac = J.T @ (sp.diags(w * dm) @ self.quad.master + sp.diags(w * ds) @ self.quad.minion)
        return J.T @ (w * q), jac.tocsr()

    def flux(self, T: np.ndarray) -> np.ndarray:
        """The flux q of (C1) at the points, W/m^2 (the lagged radiation with its conductance)."""
        jump = self.jump @ T
        q = (self.h + self.h_rad) * jump
        if self.spec.exact_radiation:
            q = q + self.spec.radiation_flux(self.quad.master @ T, self.quad.minion @ T)[0]
        return q

    def flow(self, T: np.ndarray) -> float:
        """The heat flow from the master side to the minion side, W (per m of depth in plane scenes, per radian in
        axisymmetric ones)."""
        return float(self.quad.weights @ self.flux(T))

    def conductance_range(self) -> tuple[float, float]:
        """(min, max) of h + h_rad over the points, W/(m^2 K)."""
        h = self.h + self.h_rad
        return (float(h.min()), float(h.max())) if len(h) else (0.0, 0.0)


def heatless_closed(states: dict[str, ContactNodes] | None, conductances: list[InterfaceConductance],
                    perfect_sides: set[str]) -> list[str]:
    """Warnings for the interfaces the contact state ``states`` closes (a node with pressure) that carry no heat
    there: neither coupled perfectly (their master side in ``perfect_sides``) nor given a conductance that is
    positive at some closed node (``conductances``)."""
    specs = {c.name: c for c in conductances}
    out = []
    for name, nodes in (states or {}).items():
        shut = np.asarray(nodes.pressure) > 0
        if not np.any(shut) or nodes.side in perfect_sides:
            continue
        spec = specs.get(name)
        if spec is None:
            why = ("it has an initial gap and no conductance keys (interfaces.conductance, conductance_coefficient, "
                   "gap_conductivity, emissivities), so heat does not cross it")
        elif spec.emissivity is None and not np.any(spec.conductance(nodes.pressure[shut],
                                                                     np.minimum(nodes.gap[shut], 0.0)) > 0):
            why = "its conductance is zero at every closed node"
        else:
            continue
        out.append(f"interfaces ({name}): the mechanics closes it (contact pressure up to "
                   f"{nodes.closed_pressure():.4g} Pa) but it carries no heat: {why}")
    return out


def unfollowed_closed(states: dict[str, ContactNodes] | None, conductances: list[InterfaceConductance]) -> list[str]:
    """Warnings for the interfaces with an initial gap and a conductance that ``states`` closes while the heat
    problem keeps the geometry's state (a run without coupling)."""
    out = []
    for c in conductances:
        nodes = (states or {}).get(c.name)
        if c.initial_gap and nodes is not None and np.any(np.asarray(nodes.pressure) > 0):
            out.append(f"interfaces ({c.name}): the mechanics closes it (contact pressure up to "
                       f"{nodes.closed_pressure():.4g} Pa) but the heat problem keeps the geometry's gap "
                       "(physics.coupling = 'none'); use coupling = 'staggered' or 'iterated' to follow it")
    return out
