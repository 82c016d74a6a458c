"""The built-in repository scenes of issue 7, each at a coarse, short level, checked against what their data imply.

``repository_section`` (plane-strain section through a row of KBS-3 deposition holes with a Coulomb fault): the peak
temperature on the canister/buffer interface is finite, above the geotherm and below the bound of the decaying point
sources of verification.md section 5 summed over the repository's canisters (6 m x 40 m, k = 3 W/(m K), no buffer);
its rise is that of the repository's heat per plan area (an infinite plane source with the same decay); the fault
is closed under the in-situ stress with the normal and shear forces of the lithostatic stress on a 60 degree fault;
the force balance holds at every mechanics time.

``permafrost`` (Stefan problem in a granite column under a 50 kyr cold period): the frozen front deepens while the
surface is cold, stays above the steady frozen depth of the cold surface with the geothermal gradient (400 m, so
above the repository at 500 m) and within the conduction scale 2 erfinv(0.6) sqrt(kappa t); the energy balance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import erfinv

from ngs_geomech import api
from ngs_geomech.io.stress_figures import principal_2d
from ngs_geomech.verification.point_source import canister_array_peak_rise

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_repository_scenes")]

YEAR = 365.25 * 86400.0

# repository_section data (geometries/repository_section.toml)
K_ROCK, RHO_C = 3.0, 2.16e6                       # W/(m K), J/(m^3 K)
KAPPA = K_ROCK / RHO_C                            # m^2/s
P0 = 1700.0                                       # W per canister at deposition
DECAY = [(0.45, 20.0 * YEAR), (0.40, 80.0 * YEAR), (0.15, 1000.0 * YEAR)]
HOLE_SPACING, TUNNEL_SPACING = 6.0, 40.0          # m
PANEL_HALF_LENGTH = 200.0                         # m, the deposition panel along the tunnel
CANISTER_RADIUS = 0.525                           # m
T_REPOSITORY = 11.5                               # degC, the geotherm at 500 m
RHO_G = 2700.0 * 9.81                             # Pa/m
K0 = 1.5                                          # horizontal / vertical in-situ stress
DEPTH, DIP, FRICTION = 1500.0, math.radians(60.0), 0.6
REPOSITORY_DEPTH = 500.0
HOLES = (-12.0, -6.0, 0.0, 6.0, 12.0)           # m, hole axes

REPOSITORY_COARSE = ["mesh.maxh=150", "mesh.boundary_maxh.fault__rock_west=40",
                     "mesh.boundary_maxh.fault__rock_east=40", "time.end=100 year", "time.dt=1 year",
                     "time.dt_max=20 year", "output.every=3", "output.vtk=false", "output.figures=false"]

# permafrost data (geometries/permafrost.toml)
T_SURFACE_WARM, T_SURFACE_COLD = 4.0, -6.0        # degC
GRADIENT = 0.015                                  # K/m
COLD_FROM, COLD_TO = 3000.0 * YEAR, 50000.0 * YEAR   # s: the surface is within 0.1 K of -6 C
PERMAFROST_COARSE = ["mesh.maxh=10", "time.dt=50 year", "time.dt_max=1000 year", "time.end=56000 year",
                     "output.vtk=false", "output.figures=false"]
PERMAFROST_H = 10.0                               # m


@pytest.fixture(scope="module")
def repository():
    return api.run("repository_section", None, overrides=REPOSITORY_COARSE, progress=False)


@pytest.fixture(scope="module")
def permafrost():
    return api.run("permafrost", None, overrides=PERMAFROST_COARSE, progress=False)


def _point_source_array_bound() -> float:
    """Largest temperature rise (K) at a canister wall over 1000 years: verification.md section 5's decaying point
    source summed over the panel's canisters (6 m x 40 m, +-200 m along the tunnels, 2 km across), k of granite."""
    return canister_array_peak_rise(P0, DECAY, HOLE_SPACING, TUNNEL_SPACING, PANEL_HALF_LENGTH, 50, CANISTER_RADIUS,
                                    K_ROCK, KAPPA)


def _plane_source_peak() -> float:
    """Largest temperature rise (K) of an infinite plane source with the repository's heat per plan area
    (1700 W per 6 m x 40 m) and the canisters' decay, in infinite granite."""
    q = P0 / (HOLE_SPACING * TUNNEL_SPACING)

    def rise(t):
        def f(s):
            power = q * sum(a * math.exp(-s / tau) for a, tau in DECAY)
            return power / (RHO_C * math.sqrt(4 * math.pi * KAPPA * (t - s)))
        return quad(f, 0.0, t, limit=200)[0]
    return max(rise(t) for t in np.geomspace(10.0, 1000.0, 40) * YEAR)


def test_repository_peak_buffer_temperature_within_the_closed_form_bounds(repository):
    s = repository.summary
    assert s["mechanics"]["times_s"][-1] == pytest.approx(100.0 * YEAR, rel=1e-12)
    assert not s["warnings"]
    peak = s["probes"]["canister_buffer_max_3"]["max"]
    when = s["probes"]["canister_buffer_max_3"]["time_of_max"] / YEAR
    bound = T_REPOSITORY + _point_source_array_bound()
    plane = _plane_source_peak()
    print(f"\npeak canister/buffer temperature {peak:.2f} C at {when:.0f} years; point-source array bound "
          f"{bound:.1f} C; plane-source rise {plane:.2f} K against {peak - T_REPOSITORY:.2f} K")
    assert math.isfinite(peak)
    assert T_REPOSITORY < peak < bound
    # the plane section carries the repository's heat per plan area: its rise is the plane source's, within
    # the finite panel, the cold surface (-) and the section's own near field (+)
    assert 0.8 < (peak - T_REPOSITORY) / plane < 1.25
    assert 20.0 < when < 100.0 + 1e-9
    # the end hole of the five is cooler than the middle one, but not by much (the smeared panel goes on)
    end = s["probes"]["canister_buffer_max_1"]["max"]
    assert T_REPOSITORY < end <= peak + 1e-9 and peak - end < 2.0


def test_repository_fault_closed_under_the_in_situ_stress(repository):
    c = repository.summary["mechanics"]["contact"]
    first = c["history"][0]
    assert first["time_s"] == 0.0
    f = first["fault"]
    # the lithostatic stress on the 60 degree fault, integrated over its length H / sin(dip)
    length = DEPTH / math.sin(DIP)
    sn = (math.cos(DIP) ** 2 + K0 * math.sin(DIP) ** 2)          # sigma_n / (rho g depth)
    tau = (K0 - 1.0) * math.sin(DIP) * math.cos(DIP)              # |tau| / (rho g depth)
    normal = RHO_G * sn * DEPTH * length / 2.0
    print(f"\nt = 0: fault normal force {f['normal_force']:.4e} N/m (closed form {normal:.4e}), tangential "
          f"{f['tangential_force']:.4e} (closed form {tau / sn * normal:.4e}), nodes {f['nodes']}")
    assert f["nodes"]["open"] == 0 and f["nodes"]["slip"] == 0
    assert f["normal_force"] == pytest.approx(normal, rel=0.01)
    assert abs(f["tangential_force"]) == pytest.approx(tau / sn * normal, rel=0.02)
    assert abs(f["tangential_force"]) / f["normal_force"] < FRICTION
    for h in c["history"]:                      # heated, the fault stays closed (open at most near the surface)
        nodes = h["fault"]["nodes"]
        assert nodes["stick"] + nodes["slip"] >= 0.9 * sum(nodes.values())
        assert h["imbalance_rel"] < 1e-8
    final = c["interfaces"]["fault"]
    assert final["max_penetration_m"] < 1e-9
    assert final["action_reaction"] < 1e-8


def test_repository_in_plane_principal_stresses(repository):
    s = repository.summary
    series = s["probe_series"]["sigma_3_hole_wall"]
    sv = RHO_G * REPOSITORY_DEPTH
    # t = 0: the in-situ stress (the most compressive one horizontal, K0 rho g depth)
    assert series[0] == pytest.approx(-K0 * sv, rel=1e-3)
    mesh = repository.mesh
    pts = np.array([v.point for v in mesh.vertices])
    sig = np.array([repository.mechanics.fields["stress"](mesh(*p)) for p in pts])     # 3x3 row-major, t = 100 y
    s1, s2, _ = principal_2d(sig[:, 0], sig[:, 4], sig[:, 1])
    near = (np.abs(pts[:, 0]) < 30.0) & (np.abs(pts[:, 1] + REPOSITORY_DEPTH) < 30.0)
    # the rectangular holes' and the tunnel's corners are re-entrant corners of the rock (singular stresses)
    corners = [(x + dx, y) for x in HOLES for dx in (-0.875, 0.875) for y in (-502.9, -494.9)]
    corners += [(x, y) for x in (-15.0, 15.0) for y in (-494.9, -489.9)]
    d = np.min([np.hypot(pts[:, 0] - cx, pts[:, 1] - cy) for cx, cy in corners], axis=0)
    away = near & (d > 2.0)
    print(f"\nnear field in-plane principal stresses at 100 years: {s2[near].min():.3e} .. {s1[near].max():.3e} Pa "
          f"({s2[away].min():.3e} Pa 2 m from corners); sigma_3 at the hole wall {series[0]:.3e} -> "
          f"{series[-1]:.3e} Pa")
    assert np.all(np.isfinite(sig))
    # heated rock is squeezed: more compressive than in situ, by less than beta dT with dT < 50 K
    assert series[-1] < series[0]
    assert s2[away].min() > -K0 * RHO_G * (REPOSITORY_DEPTH + 30.0) - 1.0096e6 * 50.0
    assert s1[near].max() < 0.0                 # no tension in the near-field rock


def test_permafrost_front_deepens_while_cold_within_its_bounds(permafrost):
    s = permafrost.summary
    ps = s["probe_series"]
    t = np.array(ps["times_s"]["frozen_depth"])
    depth = np.array([np.nan if d is None else d for d in ps["frozen_depth"]])
    cold = (t >= COLD_FROM) & (t <= COLD_TO)
    d = depth[cold]
    steady = -T_SURFACE_COLD / GRADIENT                             # 400 m: the cold steady geotherm's 0 C
    scale = 2.0 * erfinv(-T_SURFACE_COLD / (T_SURFACE_WARM - T_SURFACE_COLD)) * np.sqrt(KAPPA * t[cold])
    print(f"\nfrozen depth {d[0]:.0f} m at {t[cold][0] / YEAR:.0f} y -> {d.max():.0f} m at "
          f"{t[cold][np.argmax(d)] / YEAR:.0f} y; steady bound {steady:.0f} m; conduction scale at the end "
          f"{scale[-1]:.0f} m")
    assert np.all(np.isfinite(d))
    assert np.all(np.diff(d) > -0.5)                               # deepens (to a fraction of an element)
    assert d[-1] > d[0] + 100.0
    assert np.all(d <= scale + PERMAFROST_H)
    assert d.max() <= steady + PERMAFROST_H
    assert d.max() < REPOSITORY_DEPTH                              # the repository stays unfrozen
    assert min(ps["liquid_fraction_repository"]) == pytest.approx(1.0)
    assert min(ps["T_repository"]) > 0.0
    frozen = 1.0 - np.array(ps["unfrozen_fraction"])               # frozen fraction of the 1000 m column
    assert frozen[cold].max() == pytest.approx(d.max() / 1000.0, abs=PERMAFROST_H / 1000.0)
    # warm again (from 52 kyr): the thin latent heat (0.77 K of rho c) lets the permafrost thaw out within ~1 kyr
    assert np.isnan(depth[-1])
    e = s["stefan"]["energy"]
    assert e["imbalance_rel_max"] < 1e-8


def test_repository_adaptive_level_follows_the_fault_and_agrees(repository):
    """The adaptive level (meshes that follow the fault's contact zones) at the test level: the peak temperature,
    the fault's forces and the force balance agree with the fixed mesh; the transfers are small."""
    res = api.run("repository_section", None, progress=False,
                  overrides=REPOSITORY_COARSE + ['adaptivity.indicators=["contact_zone"]', "adaptivity.levels=2"])
    a = res.summary["adaptivity"]
    peak, peak_fixed = (r.summary["probes"]["canister_buffer_max_3"]["max"] for r in (res, repository))
    f, f_fixed = (r.summary["mechanics"]["contact"]["interfaces"]["fault"] for r in (res, repository))
    print(f"\nadaptive: remeshes {a['remesh_count']}, dofs per solve {a['dofs']['per_solve']}, transfer "
          f"{a['transfer']}; peak {peak:.3f} C (fixed mesh {peak_fixed:.3f}), fault normal force "
          f"{f['normal_force']:.5e} ({f_fixed['normal_force']:.5e}), nodes {f['nodes']} ({f_fixed['nodes']})")
    assert a["mode"] == "contact_zone_following" and a["mechanics_solves"] == len(res.summary["mechanics"]["times_s"])
    assert abs(peak - peak_fixed) < 0.5
    assert f["normal_force"] == pytest.approx(f_fixed["normal_force"], rel=1e-2)
    assert a["transfer"]["heat_content_change_rel_max"] < 1e-3
    assert max(h["imbalance_rel"] for h in res.summary["mechanics"]["contact"]["history"]) < 1e-8
