"""The built-in geomechanics scenarios of issue 7, each run at a coarse, short level and checked for physical sanity.

``plate_collision`` (the seed's test model, Central Aleutians): runs to the end; in-plane principal stresses of
the collision (the stress less the lithostatic prestress) of the order of the convergence strain times E; the
plates in contact where they converge; force balance; the Stefan energy balance; the melting zone melted as far as
the slab geotherm reaches past the solidus (and no further within the short run). tests/test_plate_collision.py
has the lithostatic state at t = 0 and the megathrust at the quick level."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech import api
from ngs_geomech.io.stress_figures import principal_2d
from ngs_geomech.scene import expressions
from ngs_geomech.scene.parse import load_scene

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_scenarios")]

YEAR = 365.25 * 86400.0

# scene data (geometries/plate_collision.toml)
E = 1.7e11                      # Pa, the mantle blocks
RHO_G = 3300.0 * 9.81           # Pa/m: the lithostatic prestress rho g y
CONVERGENCE = 0.06              # m/year, on the back-arc edge
END = 1.0e5 * YEAR              # s
OVERRIDING_WIDTH = 300.0e3      # m, trench (x = 100 km) to the back-arc edge (x = 400 km)
T_MANTLE_MAX = 1345.0           # degC: the adiabat at 150 km, the geotherm's largest value
THETA_R = 1300.0                # degC, solidus of the melting zone
ZONE = (300.0e3, 360.0e3, -140.0e3, -90.0e3)   # m, x and y range of the melting zone


COARSE = ["mesh.maxh=30e3", "blocks.melt_zone.maxh=10e3", "time.dt=25000 year", "output.every=1"]


@pytest.fixture(scope="module")
def plate_collision():
    return api.run("plate_collision", None, overrides=COARSE, progress=False)


def _vertex_values(result, cf):
    mesh = result.mesh
    pts = [v.point for v in mesh.vertices]
    return np.array([cf(mesh(*p)) for p in pts])


def test_plate_collision_runs_to_the_end(plate_collision):
    s = plate_collision.summary
    assert s["mechanics"]["times_s"][-1] == pytest.approx(END, rel=1e-12)
    assert s["stefan"]["output_times_s"][-1] == pytest.approx(END, rel=1e-12)
    assert not s["warnings"]


def test_plate_collision_stresses_of_the_order_of_the_convergence_strain_times_e(plate_collision):
    sig = _vertex_values(plate_collision, plate_collision.mechanics.fields["stress"])   # 3x3 row-major
    assert np.all(np.isfinite(sig))
    y = np.array([v.point[1] for v in plate_collision.mesh.vertices])
    s1, s2, _ = principal_2d(sig[:, 0] - RHO_G * y, sig[:, 4] - RHO_G * y, sig[:, 1])     # less the prestress
    peak = float(np.max(np.maximum(np.abs(s1), np.abs(s2))))
    expected = E * CONVERGENCE * END / YEAR / OVERRIDING_WIDTH      # 6 km over 300 km: 3e9 Pa
    print(f"\nmax |in-plane principal stress| {peak:.3e} Pa, convergence strain times E {expected:.3e} Pa; "
          f"most compressive {float(np.min(s2)):.3e} Pa")
    assert 0.1 * expected < peak < 10.0 * expected
    assert float(np.min(s2)) < -0.1 * expected             # the collision compresses


def test_plate_collision_contact_closed_where_the_plates_converge(plate_collision):
    c = plate_collision.summary["mechanics"]["contact"]
    itf = c["interfaces"]
    for name, row in itf.items():
        print(f"\n{name}: normal force {row['normal_force']:.3e} N/m, max pressure {row['max_pressure_Pa']:.3e} Pa, "
              f"nodes {row['nodes']}, max penetration {row['max_penetration_m']:.1e} m", end="")
        assert row["normal_force"] >= 0.0
        assert row["max_penetration_m"] < 1e-6
    wedge = itf["slab_wedge"]            # the advancing mantle wedge against the steep slab face: closed
    assert wedge["nodes"]["stick"] + wedge["nodes"]["slip"] > wedge["nodes"]["open"]
    assert wedge["normal_force"] > 0.0
    assert itf["slab_base_2"]["normal_force"] > 0.0       # the slab pressed onto its rigid foundation
    assert itf["megathrust"]["normal_force"] > 0.0        # touching where the arc plate is pushed onto the slab
    assert c["force_balance"]["imbalance_rel"] < 1e-8


def test_plate_collision_stefan_energy_balance(plate_collision):
    e = plate_collision.summary["stefan"]["energy"]
    print(f"\nStefan energy imbalance {e['imbalance_rel']:.1e} (max over time {e['imbalance_rel_max']:.1e})")
    assert e["imbalance_rel"] < 1e-8
    assert e["imbalance_rel_max"] < 1e-8


def _geotherm_in_the_zone():
    """The scene's initial temperature of the melting zone (degC) on a 121 x 101 grid over the zone."""
    f = expressions.float_function(load_scene("plate_collision").initial.regions["melt_zone"])
    x0, x1, y0, y1 = ZONE
    return np.array([[f(x=x, y=y) for x in np.linspace(x0, x1, 121)] for y in np.linspace(y0, y1, 101)])


def test_plate_collision_melting_zone_melts_as_far_as_the_geotherm_says(plate_collision):
    s = plate_collision.summary
    frac = s["stefan"]["melted_fraction"]["melt_zone"]
    T0 = _geotherm_in_the_zone()
    expected = float(np.mean(T0 > THETA_R))                  # the share of the zone above the solidus
    # 1e5 years of conduction move the solidus isotherm by ~sqrt(kappa t) ~ 2 km << the zone; the nodal
    # (lumped) melted volume is exact to about half an element of the zone (maxh 10 km over 60 km)
    print(f"\nmelted fraction {frac[0]:.4f} -> {frac[-1]:.4f}, geotherm {expected:.4f}")
    assert 0.0 < frac[-1] < 1.0
    assert frac[0] == pytest.approx(expected, abs=0.1)
    assert abs(frac[-1] - frac[0]) < 0.02
    tmax = s["probes"]["melt_zone_T_max"]["max"]
    assert float(T0.max()) - 1.0 < tmax < float(T0.max()) + 30.0      # + the deformation heat (~20 K)
    T = _vertex_values(plate_collision, plate_collision.stefan.fields["temperature"])
    print(f"temperature {T.min():.2f} .. {T.max():.2f} C")
    assert T.min() > -1.0 and T.max() < T_MANTLE_MAX + 30.0                      # the geotherm's range


def test_viscous_plate_collision_against_the_quasi_static_run():
    """Issue 9: the scenario with Kelvin-Voigt viscosity in the mantle wedge and the melting zone
    (physics.mechanics = "viscous") runs to the end; the viscous stress (C tau_v e_t, ~1e-3 x C here) changes the
    stresses and contact forces by a few percent, and its dissipation joins the deformation heating."""
    from ngs_geomech.verification.viscous_plate import viscous_vs_quasistatic

    r = viscous_vs_quasistatic(COARSE)
    s, v, d = r["static"], r["viscous"], r["difference"]
    print(f"\nquasi-static: sigma_3 min {s['sigma_3_min_Pa']:.4e} Pa, slab_wedge force "
          f"{s['contacts']['slab_wedge']['normal_force']:.4e} N/m, deformation heat {s['deformation_heat_J']:.4e} J/m"
          f"\nviscous:      sigma_3 min {v['sigma_3_min_Pa']:.4e} Pa, slab_wedge force "
          f"{v['contacts']['slab_wedge']['normal_force']:.4e} N/m, deformation heat {v['deformation_heat_J']:.4e} J/m "
          f"(viscous dissipation {v['viscous_dissipation_J']:.4e})\ndifferences: {d}")
    assert v["viscous_dissipation_J"] > 0 and d["deformation_heat_J"] > 0
    assert 1e-4 < abs(d["sigma_3_min_Pa"]) / abs(s["sigma_3_min_Pa"]) < 0.2
    assert 1e-4 < abs(d["contacts_normal_force_rel"]["slab_wedge"]) < 0.2


def test_plate_collision_adaptive_level_follows_the_contacts(plate_collision):
    """Meshes that follow the contact zones with a phase change and deformation heating (coupled steps): the
    balances hold, the melting zone is the fixed mesh's, the contacts stay closed where the plates converge."""
    res = api.run("plate_collision", None, progress=False,
                  overrides=COARSE + ['adaptivity.indicators=["contact_zone"]', "adaptivity.levels=2"])
    s, f = res.summary, plate_collision.summary
    a = s["adaptivity"]
    c = s["mechanics"]["contact"]
    print(f"\nremeshes {a['remesh_count']} at {[r['t_s'] for r in a['remeshes']]}, dofs {a['dofs']['per_solve']}, "
          f"transfer {a['transfer']}; melted fraction {s['stefan']['melted_fraction']['melt_zone'][-1]:.4f} "
          f"(fixed {f['stefan']['melted_fraction']['melt_zone'][-1]:.4f}); trench uy "
          f"{s['probes']['trench_uy']['final']:.1f} m (fixed {f['probes']['trench_uy']['final']:.1f}); rejected "
          f"remeshes {[r['t_s'] for r in a['rejected_remeshes']]}")
    assert a["remesh_count"] >= 1 and s["mechanics"]["times_s"][-1] == pytest.approx(END, rel=1e-12)
    assert s["stefan"]["energy"]["imbalance_rel_max"] < 1e-8
    assert max(h["imbalance_rel"] for h in c["history"]) < 1e-8
    assert s["stefan"]["melted_fraction"]["melt_zone"][-1] == pytest.approx(      # half an element of the zone:
        f["stefan"]["melted_fraction"]["melt_zone"][-1], abs=0.1)                 # the meshes differ there
    assert s["probes"]["trench_uy"]["final"] == pytest.approx(f["probes"]["trench_uy"]["final"], rel=0.2)
    assert c["interfaces"]["slab_wedge"]["normal_force"] > 0.0 and c["interfaces"]["slab_base_2"]["normal_force"] > 0
