"""Problem (P_c) (:mod:`ngs_geomech.coupling.problem`): the deformation heating against a closed form (uniform
adiabatic compression, with and without a phase change), the order of the staggered lag, the coupled
contact-Stefan case of issue 5 (two blocks in Coulomb contact, one partly melting) with the effect of the
deformation heating measured against switching it off, and a failed coupled run resumed from its checkpoint."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ngs_geomech.errors import SolverError
from ngs_geomech.io.checkpoint import load_checkpoint
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.verification import coupled as cp

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_coupled")]


@pytest.mark.parametrize("phase_change", [False, True])
def test_iterated_coupling_reproduces_adiabatic_compression_heating(phase_change):
    r = cp.adiabatic_compression(coupling="iterated", dt=5.0, phase_change=phase_change)
    print(f"\nphase change {phase_change}: enthalpy gain {r['gain_mean']:.8e} J/m^3, closed form "
          f"{r['exact']:.8e} (rel. error {r['rel_error']:.1e}, spread {r['gain_spread']:.1e}); T_end "
          f"{r['T_end']:.4f} degC, melted fraction {r['melted_fraction']:.5f}; passes mean {r['passes_mean']:.2f} "
          f"max {r['passes_max']}")
    assert r["rel_error"] < 1e-12
    assert r["gain_spread"] < 1e-9 * r["exact"]
    assert r["deformation_heat_reported"] == pytest.approx(r["exact"], rel=1e-12)   # 1 m^2 block
    assert r["passes_max"] <= 3
    if phase_change:        # C_s (1 K) = 2e6 J/m^3 to reach Theta_R, then latent heat 4e6 J/m^3
        assert r["melted_fraction"] == pytest.approx((r["exact"] - 2e6) / 4e6, rel=1e-9)
        assert r["T_end"] == pytest.approx(21.0, abs=1e-9)


def test_staggered_coupling_lags_one_step_first_order_in_dt():
    rows = [cp.adiabatic_compression(coupling="staggered", dt=dt) for dt in (20.0, 10.0, 5.0)]
    errs = [r["rel_error"] for r in rows]
    order = math.log(errs[0] / errs[-1]) / math.log(4.0)
    print("\nstaggered: dt " + ", ".join(f"{r['dt']:g} s: rel. error {r['rel_error']:.4f}" for r in rows)
          + f"; observed order {order:.3f}")
    for r in rows:                                   # exactly one step's heating is missing
        assert r["rel_error"] == pytest.approx(r["dt"] / 60.0, rel=1e-9)
    assert order == pytest.approx(1.0, abs=1e-6)


@pytest.fixture(scope="module")
def melting():
    return cp.contact_melting(end="1 year", dt="10 day")


def test_contact_melting_case_runs_and_measures_the_deformation_heating(melting):
    r = melting
    print("\nmode       melted salt  T_max (C)  deformation heat (J/m)  heat supplied (J/m)  imbalance  passes  "
          "mech solves  wall s")
    for mode, row in r.items():
        print(f"{mode:9s} {row['melted_fraction']['salt']:10.4f} {row['T_max']:10.4f} "
              f"{row.get('deformation_heat', 0.0):22.4e} {row['heat_supplied']:20.4e} {row['imbalance']:10.1e} "
              f"{row.get('passes_mean', 0.0):7.2f} {row['mechanics_solves']:11d} {row['wall_s']:7.2f}")
    none, stag, it = r["none"], r["staggered"], r["iterated"]
    for row in r.values():
        assert row["imbalance"] < 1e-10                     # deformation heat counted as supplied heat
        assert 0.05 < row["melted_fraction"]["salt"] < 0.6   # partly melting
        assert row["melted_fraction"]["core"] == 1.0
        c = row["contact"]["interfaces"]["bedding"]
        assert c["nodes"]["stick"] + c["nodes"]["slip"] > 0 and c["normal_force"] > 0
        assert row["contact"]["force_balance"]["imbalance_rel"] < 1e-8
    assert none["mechanics_solves"] == 2 and stag["mechanics_solves"] == stag["steps"] + 1
    # the plate squeezes the blocks: deformation heating adds heat, more salt melts
    assert stag["deformation_heat"] > 0 and it["deformation_heat"] > 0
    # the deformation heat is the only difference in the sources (part of the energy balance)
    assert stag["source_heat"] - none["source_heat"] == pytest.approx(stag["deformation_heat"], rel=1e-9)
    assert stag["melted_fraction"]["salt"] > none["melted_fraction"]["salt"]
    # iterating within the step changes the result by much less than the term itself
    d_it = abs(it["melted_fraction"]["salt"] - stag["melted_fraction"]["salt"])
    d_term = stag["melted_fraction"]["salt"] - none["melted_fraction"]["salt"]
    print(f"effect of deformation heating on the melted salt fraction: {d_term:+.4f}; iterated - staggered "
          f"{it['melted_fraction']['salt'] - stag['melted_fraction']['salt']:+.2e}")
    assert d_it < 0.2 * d_term


def test_coupled_run_resumes_after_a_failed_step(tmp_path, monkeypatch):
    data = cp.contact_melting_scene(coupling="staggered", end="200 day", dt="10 day")
    data["output"]["every"] = 5
    ref = run_scene(scene_from_dict(data), tmp_path / "REF", progress=False)
    original = StefanSolver.step
    calls = {"n": 0}

    def step(self, t_old, t_new, extra_load=None):
        calls["n"] += 1
        if calls["n"] >= 13:              # every try from the 13th step on: the step halvings fail as well
            raise SolverError("Stefan Newton step diverged (injected)")
        return original(self, t_old, t_new, extra_load)
    monkeypatch.setattr(StefanSolver, "step", step)
    with pytest.raises(SolverError, match=r"injected.*\n.*The last good state \(step 12 of 20"):
        run_scene(scene_from_dict(data), tmp_path / "DIR", progress=False)
    monkeypatch.undo()
    (staging,) = [p for p in tmp_path.glob(".DIR.partial-*") if p.is_dir()]
    ck = load_checkpoint(staging / "checkpoint")
    assert ck.meta["step"] == 12 and "coupling/rate" in ck.arrays
    assert len(ck.meta["parts"]["coupling"]["passes"]) == 12
    res = run_scene(scene_from_dict(data), tmp_path / "DIR", progress=False, resume=True)
    a = json.loads((tmp_path / "REF" / "summary.json").read_text())
    b = json.loads((tmp_path / "DIR" / "summary.json").read_text())
    # the checkpoint restores the Stefan Newton matrix's reuse and the contact sets: the resumed run repeats the
    # uninterrupted one to the last bit (one thread), contact iteration counts included
    assert b["coupling"]["deformation_heat_per_step"] == a["coupling"]["deformation_heat_per_step"]
    assert b["mechanics"]["contact"]["iterations_per_solve"] == a["mechanics"]["contact"]["iterations_per_solve"]
    assert b["stefan"]["newton_iterations"] == a["stefan"]["newton_iterations"]
    assert np.array_equal(res.stefan.solver.e, ref.stefan.solver.e)
    assert np.array_equal(res.mechanics.forms.gf.vec.FV().NumPy(), ref.mechanics.forms.gf.vec.FV().NumPy())


def test_coupling_stops_with_a_diagnosis_when_passes_run_out():
    data = cp.adiabatic_compression_scene(coupling="iterated", dt=10.0)
    data["physics"]["coupling_max_iterations"] = 1
    with pytest.raises(SolverError, match=r"coupled heat-mechanics step at step 1 .*still differ after 1 passes.*"
                                          r"coupling_max_iterations"):
        run_scene(scene_from_dict(data), None, progress=False)


def test_builtin_contact_melting_scene_writes_the_coupled_output(tmp_path):
    """The built-in (P_c) scene, coarse and short: VTK with the deformation heating, the phase boundary and
    contact series, the figures, and the coupling block of the summary."""
    from ngs_geomech.api import run
    res = run("contact_melting", tmp_path / "OUT", overrides=["time.end=60 day", "time.dt=10 day", "mesh.maxh=0.25",
                                                               "output.every=3"], progress=False)
    s = json.loads((tmp_path / "OUT" / "summary.json").read_text())
    c = s["coupling"]
    print(f"\ncontact_melting (60 days, coarse): deformation heat {c['deformation_heat_total']:.3e} J/m over "
          f"{len(c['deformation_heat_per_step'])} steps, salt melted {s['stefan']['melted_fraction']['salt'][-1]:.4f}, "
          f"imbalance {s['stefan']['energy']['imbalance_rel']:.1e}, {res.timings['total_s']:.1f} s")
    assert c["mode"] == "staggered" and c["deformation_heat_total"] > 0
    assert len(c["deformation_heat_per_step"]) == s["steps"] and c["deformation_heat_per_step"][0] == 0.0
    assert s["stefan"]["energy"]["imbalance_rel"] < 1e-10
    assert s["mechanics"]["solves"] == s["steps"] + 1
    figs = {p.name for p in (tmp_path / "OUT" / "figures").iterdir()}
    assert {"deformation_heating.png", "phase_boundary.png", "contact_bedding.png", "principal_stress.png"} <= figs
    vtu = sorted((tmp_path / "OUT").glob("contact_melting*.vtu"))[-1].read_text(errors="ignore")
    assert "deformation_heating" in vtu and "liquid_fraction" in vtu


def _pressure_scene(c_p: float, k: float, phase_change: bool) -> dict:
    """A 2 m x 1 m block under a uniform compression (u_x = -1e-3 x on the right, rollers left and bottom, free
    top, no thermal expansion: a uniform stress), heated from the left: the mean pressure p0 is uniform and
    constant, so kappa(T, p) = kappa (1 + c_p p0) everywhere."""
    mat = {"conductivity": k, "rho_c": 2e6, "youngs_modulus": 50e9, "poisson_ratio": 0.25,
           "conductivity_pressure_coefficient": c_p}
    if phase_change:
        mat.update(phase_change_temperature=5.0, latent_heat_volumetric=5e7, rho_c_liquid=2.5e6,
                   conductivity_liquid=0.6 * k)
    return {
        "scene": {"name": "pressure_conductivity", "temperature_unit": "C"},
        "physics": {"thermal": "transient", "mechanics": "static", "coupling": "staggered"},
        "mesh": {"maxh": 0.2},
        "time": {"end": "20 day", "dt": "1 day"},
        "blocks": [{"name": "block", "shape": "rectangle", "origin": [0, 0], "size": [2.0, 1.0],
                    "boundaries": {"left": "xmin", "right": "xmax", "bottom": "ymin"}}],
        "materials": {"block": mat},
        "initial": {"temperature": 0.0},
        "boundary_conditions": {"left": {"symmetry": True, "temperature": 20.0}, "bottom": {"symmetry": True},
                                "right": {"displacement": ["-1e-3*x", "free"]}},
        "output": {"vtk": False, "figures": False},
    }


@pytest.mark.parametrize("phase_change", [False, True])
def test_pressure_dependent_conductivity_equals_the_scaled_conductivity(phase_change):
    """kappa(T, p) = kappa(T) (1 + c_p p) with a uniform pressure p0 gives the run with kappa (1 + c_p p0)."""
    c_p = 2e-9                                          # 1/Pa
    res = run_scene(scene_from_dict(_pressure_scene(c_p, 3.0, phase_change)), None, progress=False)
    f = res.summary["coupling"]["conductivity_pressure_factor"]
    assert f["max"] - f["min"] < 1e-9 * f["max"]       # uniform
    ref = run_scene(scene_from_dict(_pressure_scene(0.0, 3.0 * f["min"], phase_change)), None, progress=False)
    if phase_change:
        T, T_ref = (r.stefan.forms.nodal_state(r.stefan.solver.e).T for r in (res, ref))
    else:
        T, T_ref = (r.forms.temperature().vec.FV().NumPy() for r in (res, ref))
    diff = float(np.max(np.abs(T - T_ref)))
    print(f"\nphase change {phase_change}: conductivity factor {f['min']:.6f} (p0 = {(f['min'] - 1) / c_p:.4e} Pa), "
          f"max |T - T(scaled kappa)| = {diff:.1e} K")
    # plane strain, e_xx = -1e-3, sigma_yy = 0 (lambda = mu = 20 GPa): sigma_xx = -53.33, sigma_zz = -13.33 MPa,
    # p0 = 66.67 / 3 = 22.22 MPa
    assert f["min"] == pytest.approx(1 + c_p * 2.0 / 90 * 1e9, rel=1e-9) and diff < 1e-9


def test_pressure_law_out_of_range_stops_by_region():
    with pytest.raises(SolverError, match=r"coupled step at t = 0 s: conductivity of region 'block': the factor "
                                          r"1 \+ c_p p = .* is not positive"):
        run_scene(scene_from_dict(_pressure_scene(-1e-6, 3.0, False)), None, progress=False)
