"""From a scene to the heat problem's plain inputs (:class:`HeatSetup`)."""

from __future__ import annotations

import math
from itertools import islice

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import Problem, SceneError
from ..fem.coefficients import Separable, expression_function, region_cf
from ..fem.timesteps import schedule
from ..geometry.assemble import GeometryModel
from ..linalg.direct import not_finite
from ..scene.expressions import short
from ..scene.model import Scene, Source
from .conductance import KELVIN, InterfaceConductance, contact_law, effective_emissivity
from .forms import HeatSetup
from .materials import thermal_properties

THETA = {"backward_euler": 1.0, "crank_nicolson": 0.5}


def region_measure(mesh, region: str, axisymmetric: bool) -> float:
    """Volume of a region in m^3 (axisymmetric: 2 pi int r dA; plane: area, i.e. m^3 per m of depth)."""
    w = 2 * math.pi * ngs.x if axisymmetric else ngs.CoefficientFunction(1.0)
    return float(ngs.Integrate(w, mesh, definedon=mesh.Materials(region)))


def source_function(src: Source, volume: float):
    """Power density Q(t) of a source, W/m^3, as a TimeFunction (separable for 'power' with 'decay')."""
    if src.density is not None:
        dens = expression_function(src.density)
        if src.start == 0:
            return dens
        return lambda t: ngs.IfPos(t - src.start, 1.0, 0.0) * dens(t)
    terms = src.decay or [[1.0, math.inf]]

    def scale(t: float) -> float:
        if t < src.start:
            return 0.0
        return sum(a if math.isinf(tau) else a * math.exp(-(t - src.start) / tau) for a, tau in terms)

    def scale_cf(t):
        total = sum((a if math.isinf(tau) else a * ngs.exp(-(t - src.start) / tau) for a, tau in terms),
                    ngs.CoefficientFunction(0.0))
        return ngs.IfPos(t - src.start, total, 0.0) if src.start != 0 else total
    return Separable(ngs.CoefficientFunction(src.power / volume), scale, scale_cf)


def _startup_until(scene: Scene) -> float | None:
    """The end time (s) of the scene's first ``time.startup_steps`` steps (None without a start-up)."""
    ts = scene.time
    if ts is None or ts.scheme != "crank_nicolson" or ts.startup_steps <= 0:
        return None
    steps = list(islice(schedule(ts.start, ts.end, ts.dt, ts.dt_growth, ts.dt_max), ts.startup_steps))
    return steps[-1][1] if steps else None


def heat_setup(scene: Scene, geo: GeometryModel, mesh) -> HeatSetup:
    """The HeatSetup of a validated scene on its mesh."""
    axi = scene.scene.dimension == "axisymmetric"
    dim = 3 if scene.scene.dimension == "3d" else 2
    props = {name: thermal_properties(m, dim) for name, m in scene.materials.items()}
    setup = HeatSetup(props=props, order=scene.mesh.order, axisymmetric=axi,
                      steady=scene.physics.thermal == "steady",
                      theta=THETA[scene.time.scheme] if scene.time else 1.0,
                      startup_until=_startup_until(scene))
    for name, bc in scene.boundary_conditions.items():
        if bc.temperature is not None:
            setup.dirichlet[name] = expression_function(bc.temperature)
        elif bc.flux is not None:
            setup.flux[name] = expression_function(bc.flux)
        elif bc.heat_transfer_coefficient is not None:
            setup.robin[name] = (bc.heat_transfer_coefficient, expression_function(bc.ambient_temperature))
    for src in scene.sources:
        setup.sources.setdefault(src.region, []).append(
            source_function(src, region_measure(mesh, src.region, axi)))
    # an interface with an initial gap (Interface.sides) and no conductance keys carries no heat (its sides are
    # outer boundaries of the heat problem); one with conductance keys passes q = h(p, g) (T_m - T_s)
    setup.conductances = list(interface_conductances(scene, geo, mesh).values())
    conducting = {c.name for c in setup.conductances}
    setup.contacts = [(cs.master, cs.minion) for cs in geo.contacts.values()
                      if not cs.initial_gap and cs.name not in conducting]
    setup.pressure_coefficients = pressure_coefficients(scene)
    return setup


def has_conductance(itf) -> bool:
    """Whether an interface passes heat by a contact conductance (:mod:`.conductance`): a conductance other than
    'perfect', a power law, a gap conductivity or emissivities."""
    return ((itf.conductance is not None and itf.conductance != "perfect") or itf.conductance_coefficient is not None
            or itf.gap_conductivity is not None or itf.emissivities is not None)


MINIMUM_GAP = 1e-6
"""The default gap floor g_min of k_gap / max(g, g_min), m."""


def interface_conductances(scene: Scene, geo: GeometryModel, mesh,
                           radiation: str = "exact") -> dict[str, InterfaceConductance]:
    """Interface name -> :class:`InterfaceConductance` of the validated scene's contact interfaces with a
    conductance (:func:`has_conductance`); ``radiation`` is the default way radiation enters (exact in heat
    scenes, linearized in Stefan ones). The partner points of the other side are searched up to the interface's
    search_distance (default a quarter of the extent of its master side, as the mechanics'): the mechanics may
    close parts that are apart in the geometry (a Hertz contact, an initial gap)."""
    out = {}
    byname = {i.name: i for i in scene.interfaces}
    kelvin = KELVIN if scene.scene.temperature_unit == "C" else 0.0
    for name, cs in geo.contacts.items():
        itf = byname[name]
        if not has_conductance(itf):
            continue
        reach = itf.search_distance
        if reach is None:
            pts = np.array([mesh[v].point[:mesh.dim] for el in mesh.Boundaries(cs.master).Elements()
                            for v in el.vertices]).reshape(-1, mesh.dim)
            reach = 0.25 * float(np.max(np.ptp(parallel.concat(mesh, pts), axis=0)))
        eps = effective_emissivity(*itf.emissivities) if itf.emissivities is not None else None
        out[name] = InterfaceConductance(
            name, cs.master, cs.minion, law=contact_law(itf.conductance, itf.conductance_coefficient,
                                                        itf.conductance_exponent),
            gap_conductivity=itf.gap_conductivity,
            minimum_gap=itf.minimum_gap if itf.minimum_gap is not None else MINIMUM_GAP, emissivity=eps,
            radiation=itf.radiation or radiation, initial_gap=cs.initial_gap, reach=reach, kelvin=kelvin)
    return out


def pressure_coefficients(scene: Scene) -> dict[str, float]:
    """Region -> c_p (1/Pa) of the regions with a pressure-dependent conductivity."""
    return {n: float(m.conductivity_pressure_coefficient) for n, m in scene.materials.items()
            if m.conductivity_pressure_coefficient != 0.0}


def set_initial_temperature(gf, scene: Scene, mesh, t_param) -> None:
    """``gf.Set`` the initial temperature; SceneError naming its key when it is not finite at a point of the
    interpolation (validation samples a coarse grid; a singularity between its points shows here). Collective on
    a distributed mesh."""
    gf.Set(initial_temperature(scene, mesh, t_param))
    if not not_finite(gf.vec):
        return
    key, value = "initial.temperature", scene.initial.temperature
    for name, v in scene.initial.regions.items():
        g = ngs.GridFunction(gf.space)
        g.Set(expression_function(v)(t_param), definedon=mesh.Materials(f"^{name}$"))
        if not_finite(g.vec):
            key, value = f"initial.regions.{name}", v
            break
    raise SceneError([Problem(key, f"{short(str(value))!r} is not finite at some points of the mesh (between "
                              "the points validation samples): a singularity or a function outside its domain")],
                     source=f"scene {scene.scene.name!r}")


def initial_temperature(scene: Scene, mesh, t_param):
    """The initial temperature as one CoefficientFunction (per-region values where given)."""
    base = expression_function(scene.initial.temperature)(t_param)
    if not scene.initial.regions:
        return base
    return region_cf(mesh, {n: expression_function(v)(t_param) for n, v in scene.initial.regions.items()},
                     default=base)
