"""The built-in 3D repository scene ``repository_3d`` (issue 7: one KBS-3 deposition hole under its tunnel in the
repository's unit cell between symmetry planes), at a coarse, short level (P1, 30 years), checked against what its
data imply.

- Temperature: the peak on the canister/buffer interface is finite, hotter than the repository-scale heating of the
  plane section (45 C) and than the single canister of ``canister`` (61.8 C: no neighbours, no tunnel), below the
  bound of verification.md section 5's decaying point sources summed over a panel of canisters 6 m x 40 m apart
  (k of granite, no buffer: 104.5 C at the canister wall); it comes within the first decades, when the canister's
  power is high, and falls monotonically after it (no Crank-Nicolson oscillation: see the scene's [time] comments).
- Energy: no heat has reached the surface or the base in 30 years (conduction length 2 sqrt(kappa t) = 70 m against
  500 m and 1000 m), and the four sides are insulated, so the heat stored, int rho c (T - T_init), is the heat the
  canister released, int_0^t P (the Crank-Nicolson trapezoid rule on the decay: ~1e-3).
- Symmetry planes (seed eq. 2.16): u_n = 0 on them (essential: to rounding) and tau_t = 0 (natural: weakly, small
  against the normal stress); the temperature is mirror symmetric about the planes through the hole's axis (to the
  mesh's asymmetry).
- Mechanics: at t = 0 the in-situ stress (sigma_3 at the hole wall = -K0 rho g 500 m); heated, the rock at the hole
  wall is more compressive; the surface uplift is that of the laterally confined column, (1 + nu)/(1 - nu) alpha
  times the plan mean of int dT dz (exact for a homogeneous cell with these symmetry planes; the buffer, canister and
  backfill are a small part of the heated volume).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.scene.units import YEAR
from ngs_geomech.verification.point_source import canister_array_peak_rise

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_repository_3d")]

# geometries/repository_3d.toml data
K_ROCK, RHO_C_ROCK = 3.0, 2.16e6                  # W/(m K), J/(m^3 K)
KAPPA = K_ROCK / RHO_C_ROCK                       # m^2/s
RHO_C = {"rock": 2.16e6, "tunnel": 2.5e6, "buffer": 2.8e6, "canister": 3.6e6}   # J/(m^3 K)
P0 = 1700.0                                       # W at deposition
DECAY = [(0.45, 20.0 * YEAR), (0.40, 80.0 * YEAR), (0.15, 1000.0 * YEAR)]
HOLE_SPACING, TUNNEL_SPACING = 6.0, 40.0          # m: the unit cell is [-3, 3] x [-20, 20]
PLAN_AREA = HOLE_SPACING * TUNNEL_SPACING         # m^2
CANISTER_RADIUS = 0.525                           # m
T_REPOSITORY = 11.5                               # degC, the geotherm at 500 m
NU, ALPHA = 0.24, 7.5e-6                          # granite
K0, RHO_G, DEPTH = 1.5, 2700.0 * 9.81, 500.0
SECTION_PEAK = 45.0                               # degC, repository_section (plane: repository-scale heating only)
SINGLE_CANISTER_PEAK = 61.8                       # degC, canister (axisymmetric, no neighbours, no tunnel)
END = 30.0 * YEAR

COARSE = ["mesh.maxh=200", "mesh.order=1", "blocks.buffer.maxh=0.3", "blocks.canister.maxh=0.3",
          "blocks.tunnel.maxh=2", "time.end=30 year", "time.dt_max=5 year", "output.every=5",
          "output.vtk=false", "output.figures=false"]


@pytest.fixture(scope="module")
def repository():
    return api.run("repository_3d", None, overrides=COARSE, progress=False)


def point_source_array_bound(half_length: float = 200.0, tunnels: int = 50) -> float:
    """Largest temperature rise (K) at a canister wall over 1000 years: the panel's decaying point sources
    (6 m x 40 m apart), k of granite, no buffer."""
    return canister_array_peak_rise(P0, DECAY, HOLE_SPACING, TUNNEL_SPACING, half_length, tunnels, CANISTER_RADIUS,
                                    K_ROCK, KAPPA)


def released_heat(t: float) -> float:
    """int_0^t P(s) ds, J."""
    return P0 * sum(a * tau * (1.0 - math.exp(-t / tau)) for a, tau in DECAY)


def test_peak_canister_wall_temperature_within_the_bounds(repository):
    s = repository.summary
    assert not s["warnings"]
    p = s["probes"]["canister_buffer_max"]
    peak, when = p["max"], p["time_of_max"] / YEAR
    bound = T_REPOSITORY + point_source_array_bound()
    print(f"\npeak canister/buffer temperature {peak:.2f} C at {when:.1f} years; point-source array bound "
          f"{bound:.1f} C; hole wall {s['probes']['hole_wall']['max']:.2f} C")
    assert math.isfinite(peak)
    assert SECTION_PEAK < SINGLE_CANISTER_PEAK < peak < bound
    assert 2.0 < when < 20.0
    # no Crank-Nicolson oscillation (the scene's first step is below the canister's and buffer's element diffusion
    # times): after the peak the interface cools monotonically
    series = np.array(s["probe_series"]["canister_buffer_max"])
    assert np.all(np.diff(series[np.argmax(series):]) < 1e-9)
    # the buffer's hottest point is on the canister, the rock's cooler than it
    assert s["probes"]["buffer_max"]["max"] == pytest.approx(peak, abs=1e-9)
    assert T_REPOSITORY < s["probes"]["hole_wall"]["max"] < peak
    # neighbours: half-way to the next hole warmer than half-way to the next tunnel
    assert s["probes"]["mid_between_holes"]["final"] > s["probes"]["mid_between_tunnels"]["final"] > T_REPOSITORY


def test_stored_heat_is_the_released_heat(repository):
    mesh, T = repository.mesh, repository.forms.temperature()
    t_init = 4.0 - 0.015 * ngs.z
    stored = sum(rc * ngs.Integrate(T - t_init, mesh, definedon=mesh.Materials(m)) for m, rc in RHO_C.items())
    released = released_heat(END)
    print(f"\nstored {stored:.6e} J, released {released:.6e} J, relative {stored / released - 1:.2e}")
    assert stored == pytest.approx(released, rel=5e-3)


def test_symmetry_planes(repository):
    mesh = repository.mesh
    u = repository.mechanics.fields["displacement"]
    sigma = repository.mechanics.fields["stress"]
    n = ngs.specialcf.normal(3)
    for name, comp in (("symmetry_x", 0), ("symmetry_y", 1)):
        pts = np.unique(np.array([mesh[v].point for el in mesh.Boundaries(name).Elements() for v in el.vertices]),
                        axis=0)
        un = np.array([u(mesh(*p))[comp] for p in pts])
        traction = ngs.BoundaryFromVolumeCF(sigma) * n
        tn = traction * n
        area = ngs.Integrate(1.0, mesh, ngs.BND, definedon=mesh.Boundaries(name))
        tau_t = ngs.Integrate(ngs.Norm(traction - tn * n), mesh, ngs.BND, definedon=mesh.Boundaries(name)) / area
        sig_n = ngs.Integrate(ngs.sqrt(tn * tn), mesh, ngs.BND, definedon=mesh.Boundaries(name)) / area
        print(f"\n{name}: max |u_n| {np.abs(un).max():.1e} m, mean |tau_t| {tau_t:.3e} Pa, mean |sigma_n| "
              f"{sig_n:.3e} Pa")
        assert np.abs(un).max() < 1e-12
        assert tau_t < 5e-3 * sig_n
    T = repository.forms.temperature()
    for p, q in (((2.0, 0.0, -500.0), (-2.0, 0.0, -500.0)), ((0.0, 10.0, -500.0), (0.0, -10.0, -500.0)),
                 ((1.5, 5.0, -505.0), (-1.5, -5.0, -505.0))):
        a, b = T(mesh(*p)), T(mesh(*q))
        assert abs(a - b) < 0.03 * (max(a, b) - T_REPOSITORY)


def test_in_situ_stress_heated_hole_wall_and_uplift(repository):
    s = repository.summary
    for name in ("sigma_3_hole_wall", "sigma_3_hole_wall_y"):
        series = s["probe_series"][name]
        assert series[0] == pytest.approx(-K0 * RHO_G * DEPTH, rel=2e-3)
        assert min(series) < series[0] - 10e6          # heated: more compressive by over 10 MPa
        assert max(series) < 0.0
    mesh, T = repository.mesh, repository.forms.temperature()
    column = ngs.Integrate(T - (4.0 - 0.015 * ngs.z), mesh) / PLAN_AREA         # plan mean of int dT dz, K m
    confined = (1 + NU) / (1 - NU) * ALPHA * column
    uplift = s["probe_series"]["surface_uplift"]
    print(f"\nsurface uplift {uplift[-1]:.4e} m at 30 years, laterally confined column {confined:.4e} m")
    # t = 0: gravity is balanced by sigma0 in the granite; the lighter backfill and buffer lift the column by tens
    # of micrometres (their missing weight, ~0.9 MN, on the column's stiffness, ~2e10 N/m)
    assert 0.0 < uplift[0] < 1e-4
    assert uplift[-1] - uplift[0] == pytest.approx(confined, rel=0.02)


def test_adaptive_level_on_a_pre_adapted_mesh(repository):
    """The adaptive level at the test level: the 3D mesh adapted once to the steady heat problem at full power
    (ZZ, Doerfler 0.3, one refinement), the run on it: finer where the estimate is, the peak within the bounds and
    near the fixed mesh's."""
    res = api.run("repository_3d", None, progress=False,       # to 12 years: past the peak (8 years)
                  overrides=COARSE + ["time.end=12 year", "adaptivity.estimator=zz", "adaptivity.theta=0.3",
                                      "adaptivity.max_refinements=1"])
    a = res.summary["adaptivity"]
    peak, peak_fixed = (r.summary["probes"]["canister_buffer_max"]["max"] for r in (res, repository))
    print(f"\npre-adapted 3D: {[(s['ndof'], round(s['estimate'], 3)) for s in a['steps']]}; peak {peak:.3f} C "
          f"(fixed mesh {peak_fixed:.3f} C)")
    assert a["mode"] == "pre_adapted" and len(a["steps"]) == 2
    assert a["steps"][1]["estimate"] < a["steps"][0]["estimate"]
    assert res.summary["mesh"]["dofs"] == a["steps"][-1]["ndof"] > a["steps"][0]["ndof"]
    assert SECTION_PEAK < peak < T_REPOSITORY + point_source_array_bound()
    assert abs(peak - peak_fixed) < 2.0
