"""The built-in 3D scene ``repository_panel_3d`` (a KBS-3 panel: four deposition holes along a tunnel, each
canister in contact with its buffer, and a steep Coulomb fracture zone crossing the tunnels beyond their
deposition section), at a short level (the quick mesh, 30 years, mechanics at t = 0 and 30 years), checked against
what its data imply.

- Contacts: the scene has five contact interfaces, the four canister/buffer gaps (canister_i against buffer_i)
  and the fracture (rock against rock_east); the gaps' initial gaps are zero to rounding (flat facets).
- Temperature: the mirror images (holes 1 and 4, 2 and 3: x -> -x) have equal canister temperatures (to the
  meshes' asymmetry); the inner holes are warmer than the outer ones by what the decaying point sources of the
  panel give (their neighbours' contributions, verification.md section 5, as line sources summed over the row
  and the mirrored tunnels 40 m apart), and no hotter than the bound of an infinite panel of such sources at the
  canister wall.
- Energy: no heat has reached the surface, the base or the far planes in 30 years, and the mirror planes are
  insulated, so the heat stored, int rho c (T - T_init), is four canisters' released heat int_0^t P.
- Mechanics: at t = 0 every gap is closed, pressed by the in-situ stress (sigma0 continues through the canisters:
  the gap's normal force is sigma0's normal stress integrated over the canister's surface); heated,
  the canisters expand against their buffers (no gap node opens, the normal force grows). The fracture is closed;
  near the panel it sticks, its shear / normal stress below both the friction (0.6) and the in-situ ratio plus the
  heat's increment (cot 80 = 0.18 of the added normal stress); nodes in slip sit on the Coulomb bound; the global
  force balance closes.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.contact.problem import STATUS_OPEN, STATUS_SLIP, STATUS_STICK
from ngs_geomech.scene.parse import load_scene
from ngs_geomech.scene.units import YEAR
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification.point_source import canister_array_peak_rise, decaying_point_source_temperature

pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_repository_panel")]

# geometries/repository_panel_3d.toml data
HOLES_X = (-9.0, -3.0, 3.0, 9.0)                  # m, holes 1-4 on the tunnel's axis y = 0
TUNNEL_SPACING = 40.0                             # m: the mirror planes y = +-20 m
K_ROCK, RHO_C_ROCK = 3.0, 2.16e6                  # W/(m K), J/(m^3 K)
KAPPA = K_ROCK / RHO_C_ROCK                       # m^2/s
RHO_C = {"rock": 2.16e6, "rock_east": 2.16e6, "tunnel": 2.5e6,
         **{f"buffer_{i}": 2.8e6 for i in range(1, 5)}, **{f"canister_{i}": 3.6e6 for i in range(1, 5)}}
P0 = 1700.0                                       # W per canister at deposition
DECAY = [(0.45, 20.0 * YEAR), (0.40, 80.0 * YEAR), (0.15, 1000.0 * YEAR)]
CANISTER_RADIUS = 0.525                           # m (the cylinder of the 12-sided prism's cross-section area)
T_REPOSITORY = 11.5                               # degC, the geotherm at 500 m
K0, RHO_G = 1.5, 2700.0 * 9.81                    # in-situ stress ratio, Pa/m
CANISTER_TOP, CANISTER_BOTTOM = 497.6, 502.4      # m depth
APOTHEM, END_AREA = 0.518940, 0.865901            # m, m^2: the canister's 12-sided cross-section
BETA = 1.0096e6                                   # Pa/K, the granite's thermal stress modulus in sigma0
FRICTION = 0.6
DIP = math.radians(80.0)                          # the fracture's dip
END = 30.0 * YEAR

STUDY = Path(__file__).resolve().parents[1] / "studies" / "repository_panel" / "run.py"
COARSE = ["time.end=30 year", "time.dt_max=5 year", "output.every=100", "output.vtk=false",
          "output.figures=false"]
"""The test level: the quick mesh, 30 years (past the canisters' peak), mechanics at t = 0 and at the end."""


@pytest.fixture(scope="session")
def panel():
    return api.run("repository_panel_3d", None, overrides=COARSE, progress=False)


def released_heat(t: float) -> float:
    """int_0^t P(s) ds of one canister, J."""
    return P0 * sum(a * tau * (1.0 - math.exp(-t / tau)) for a, tau in DECAY)


def neighbours_rise(x0: float, t: float, tunnels: int = 25, n: int = 9) -> float:
    """The mean temperature rise (K) along the axis of the canister at x = ``x0`` from the other canisters of its
    row and all canisters of the mirrored tunnels: decaying line sources (each canister's power spread over its
    4.8 m as ``n`` point sources, verification.md section 5), granite, no buffer."""
    xs = np.array(HOLES_X)
    ys = TUNNEL_SPACING * np.arange(-tunnels, tunnels + 1)
    X, Y = np.meshgrid(xs - x0, ys)
    d = np.hypot(X, Y).ravel()
    d = d[d > 0]
    s = np.linspace(-2.4, 2.4, n)
    r = np.sqrt(d[:, None, None] ** 2 + (s[None, :, None] - s[None, None, :]) ** 2).ravel()
    return sum(float(np.sum(decaying_point_source_temperature(r, t, P0 * a / n, 1.0 / tau, K_ROCK, KAPPA)))
               for a, tau in DECAY) / n


def test_scene_has_the_four_gaps_and_the_fracture_as_contacts():
    geo = validate(load_scene("repository_panel_3d"))
    assert sorted(geo.contacts) == ["fracture", "gap_1", "gap_2", "gap_3", "gap_4"]
    for i in range(1, 5):
        cs = geo.contacts[f"gap_{i}"]
        assert (cs.master_block, cs.minion_block) == (f"canister_{i}", f"buffer_{i}")
        assert not cs.initial_gap
    cs = geo.contacts["fracture"]
    assert (cs.master_block, cs.minion_block) == ("rock", "rock_east")


def canister_means(panel) -> list[float]:
    """The mean temperature of each canister at the end of the run, degC."""
    mesh, T = panel.mesh, panel.forms.temperature()
    return [ngs.Integrate(T, mesh, definedon=mesh.Materials(f"canister_{i}"))
            / ngs.Integrate(1.0, mesh, definedon=mesh.Materials(f"canister_{i}")) for i in range(1, 5)]


def test_canister_temperatures_symmetric_and_inner_warmer(panel):
    s = panel.summary
    assert not s["warnings"]
    peak = [s["probes"][f"canister_{i}_surface_max"]["max"] for i in range(1, 5)]
    mean = canister_means(panel)
    rise = max(peak) - T_REPOSITORY
    inner_outer = 0.5 * (mean[1] + mean[2]) - 0.5 * (mean[0] + mean[3])
    expected = neighbours_rise(HOLES_X[1], END) - neighbours_rise(HOLES_X[0], END)
    bound = T_REPOSITORY + canister_array_peak_rise(P0, DECAY, 6.0, TUNNEL_SPACING, 200.0, 50, CANISTER_RADIUS,
                                                    K_ROCK, KAPPA)
    print(f"\ncanister surface peaks {[round(p, 2) for p in peak]} C, means at 30 years {[round(m, 2) for m in mean]} "
          f"C; inner - outer at 30 years {inner_outer:.3f} K (line sources {expected:.3f} K); infinite-panel bound "
          f"{bound:.1f} C")
    assert all(math.isfinite(p) for p in peak + mean)
    for a, b in ((0, 3), (1, 2)):                                   # mirror images
        assert abs(peak[a] - peak[b]) < 0.02 * rise
        assert abs(mean[a] - mean[b]) < 0.02 * (mean[a] - T_REPOSITORY)
    assert min(peak[1], peak[2]) > max(peak[0], peak[3])            # the inner holes are the warmer
    assert inner_outer == pytest.approx(expected, rel=0.1)
    assert max(peak) < bound


def test_stored_heat_is_the_released_heat(panel):
    mesh, T = panel.mesh, panel.forms.temperature()
    t_init = 4.0 - 0.015 * ngs.z
    stored = sum(rc * ngs.Integrate(T - t_init, mesh, definedon=mesh.Materials(m)) for m, rc in RHO_C.items())
    released = 4 * released_heat(END)
    print(f"\nstored {stored:.6e} J, released {released:.6e} J, relative {stored / released - 1:.2e}")
    assert stored == pytest.approx(released, rel=5e-3)


def in_situ_normal_force() -> float:
    """int sigma0_nn dA over a canister's surface (N): sigma0's horizontal stress on the 12 side facets (linear in
    depth: its value at mid-height), the vertical one on the lid and the floor, each with the geotherm's term
    beta (-7.5 - 0.015 z) of the scene's initial_stress."""
    def sigma0(k0: float, depth: float) -> float:
        return k0 * RHO_G * depth - BETA * (-7.5 + 0.015 * depth)
    side = 12 * 2 * APOTHEM * math.tan(math.pi / 12) * (CANISTER_BOTTOM - CANISTER_TOP)
    return side * sigma0(K0, 500.0) + END_AREA * (sigma0(1.0, CANISTER_TOP) + sigma0(1.0, CANISTER_BOTTOM))


def test_gaps_closed_by_the_in_situ_stress_and_pressed_by_the_heat(panel):
    c = panel.summary["mechanics"]["contact"]
    hist = c["history"]
    assert len(hist) == 2 and hist[-1]["time_s"] == pytest.approx(END, rel=1e-12)
    ref = in_situ_normal_force()
    for i in range(1, 5):
        g0, g1 = (h[f"gap_{i}"] for h in hist)
        print(f"\ngap_{i}: normal force {g0['normal_force'] / 1e6:.2f} MN at t = 0 (sigma0: {ref / 1e6:.2f} MN), "
              f"{g1['normal_force'] / 1e6:.2f} MN at 30 years; nodes {g0['nodes']} -> {g1['nodes']}")
        assert g0["nodes"]["open"] == 0 and g1["nodes"]["open"] == 0
        # the in-situ traction crosses the gap; the canister's excess weight (~0.13 MN) presses the floor more
        assert g0["normal_force"] == pytest.approx(ref, rel=5e-3)
        assert g1["normal_force"] > g0["normal_force"]              # heated: the canister expands in its buffer
        gap = c["interfaces"][f"gap_{i}"]["initial_gap_m"]
        assert max(abs(gap[0]), abs(gap[1])) < 1e-12


def test_fracture_stuck_near_the_panel(panel):
    """The in-situ shear / normal stress on the fracture is 0.058 and the heat's horizontal stress adds cot(dip) =
    0.18 of its normal part as shear: near the panel every node sticks, below the friction. Nodes on the lines where
    the fracture meets the model's sides and surface (the mortar's boundary nodes, partly held by the rollers) are
    left out of that check."""
    c = panel.summary["mechanics"]["contact"]
    first, last = (h["fracture"] for h in c["history"])
    out = panel.mechanics.contact_output
    res = dict(zip([spec.name for spec in out.specs], out.latest))["fracture"]
    status, p, q = res["status"], res["pressure"], res["traction"]
    near = (np.abs(res["y"]) < 19.0) & (res["z"] < -20.0) & (np.hypot(res["x"], res["z"] + 500.0) < 100.0)
    in_situ = 0.5 * (K0 - 1) * math.sin(2 * DIP) / (K0 * math.sin(DIP) ** 2 + math.cos(DIP) ** 2)
    print(f"\nfracture: t = 0 {first['nodes']}, 30 years {last['nodes']}; near the panel ({near.sum()} nodes) "
          f"shear / normal up to {np.max(q[near] / p[near]):.3f} (in situ {in_situ:.3f}, heat's increment "
          f"{1 / math.tan(DIP):.3f}, friction {FRICTION})")
    assert first["nodes"]["open"] == 0 and last["nodes"]["open"] == 0
    assert near.sum() > 20 and np.all(status[near] == STATUS_STICK)
    assert np.all(q[near] < FRICTION * p[near])
    assert np.all(q[near] / p[near] < in_situ + 1 / math.tan(DIP))
    slip, stick = status == STATUS_SLIP, status == STATUS_STICK
    assert (slip | stick | (status == STATUS_OPEN)).all()
    np.testing.assert_allclose(q[slip], FRICTION * p[slip], rtol=1e-6)
    assert np.all(q[stick] <= res["bound"][stick] * (1 + 1e-9))
    assert c["force_balance"]["imbalance_rel"] < 1e-8


@pytest.mark.slow
def test_large_level_has_the_size_for_distributed_runs():
    """The large level of studies/repository_panel (P2, finer near the holes) meshes to 0.5-1.5 M dofs."""
    spec = importlib.util.spec_from_file_location("study_repository_panel", STUDY)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    size, _ = study.large_mesh()
    print(f"\nlarge level: {size['large_elements']} elements, {size['dofs_large']} dofs (heat "
          f"{size['dofs_large_heat']}, mechanics {size['dofs_large_mechanics']}), mesh {size['large_mesh_s']:.1f} s")
    assert 5e5 <= size["dofs_large"] <= 1.5e6
