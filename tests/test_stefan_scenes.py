"""The Stefan problem in scenes (issue 5, part 1): phase-change materials in a scene are solved by the enthalpy
solver, with its output (VTK fields, the phase boundary as .vtp lines and a figure, front and liquid-fraction
probes, melted volumes, latent heat, energy balance and Newton iterations in summary.json), validation of the
phase-change keys, the built-in scene ``melting_block`` and checkpoint/resume of a Stefan run.

The Neumann two-phase solution (:mod:`ngs_geomech.verification.stefan`, TWO_PHASE: Theta_R = 0, L = 2 J/m^3,
C_s = 3, C_l = 1 J/(m^3 K), k_s = 1.5, k_l = 1 W/(m K), T_L = 1, T_S = -0.5) is declared as a scene (a strip,
h = 0.025 m, dt = 0.005 s, t = 0 -> 0.5 s, started from the cold strip) and compared with the closed form.
"""

from __future__ import annotations

import json
import re
import time

import ngsolve as ngs
import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import erfc

from ngs_geomech.api import run
from ngs_geomech.errors import SceneError, SolverError
from ngs_geomech.geometry.isolines import first_crossing, iso_segments
from ngs_geomech.io.checkpoint import load_checkpoint
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.validation.validate import validate
from ngs_geomech.verification import stefan as st
from ngs_geomech.verification.stefan_adaptive import strip_scene

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_stefan_scenes")]

NEUMANN = st.TWO_PHASE
T_END = 0.5
H = 0.025
HEIGHT = 0.1
LENGTH = NEUMANN.domain_length(T_END)


def neumann_scene(**changes) -> dict:
    """The two-phase Neumann problem as a scene dict (a strip [0, LENGTH] x [0, HEIGHT], hot at x = 0)."""
    data = {**strip_scene(NEUMANN, LENGTH, HEIGHT, H, name="neumann"),
            "initial": {"temperature": NEUMANN.t_cold},
            "time": {"end": T_END, "dt": 0.2 * H},
            "output": {"every": 10, "probes": [
                {"name": "front", "quantity": "front", "line": [[0.0, HEIGHT / 2], [LENGTH, HEIGHT / 2]]},
                {"name": "no_front", "quantity": "front", "line": [[LENGTH, HEIGHT / 2], [LENGTH - 0.5, HEIGHT / 2]]},
                {"name": "phi_near_face", "quantity": "liquid_fraction", "point": [0.1, HEIGHT / 2]},
                {"name": "phi_mean", "quantity": "liquid_fraction", "region": "pcm", "statistic": "mean"}]}}
    for key, value in changes.items():
        node = data
        *path, last = key.split(".")
        for p in path:
            node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
        if value is None:
            node.pop(last, None)
        else:
            node[last] = value
    return data


@pytest.fixture(scope="module")
def neumann():
    tic = time.perf_counter()
    result = run(scene_from_dict(neumann_scene()), None, progress=False)
    return result, time.perf_counter() - tic


# -- (a) the Neumann problem as a scene -----------------------------------------------------------------------
def test_neumann_scene_front_probe_and_melted_volume(neumann):
    """Front probe (liquid fraction 1/2 along the strip's mid line) within 1.5 h of the closed-form front at
    every step (none at t = 0: the hot face takes T_L in the first step); the melted volume / height within
    0.3 h at every output time (measured: 0.58 h, 0.20 h)."""
    result, wall = neumann
    s = result.summary
    times = np.array(s["probe_series"]["times_s"]["front"])
    front = np.array(s["probe_series"]["front"], dtype=float)
    exact = np.array([NEUMANN.front(t) for t in times])
    err = np.abs(front - exact)
    stefan = s["stefan"]
    out_t = np.array(stefan["output_times_s"])
    vol_front = np.array(stefan["melted_volume"]["pcm"]) / HEIGHT
    vol_err = np.abs(vol_front - np.array([NEUMANN.front(t) for t in out_t]))
    print(f"\nNeumann two-phase scene, h = {H} m, dt = {0.2 * H} s, {s['steps']} steps, {s['mesh']['vertices']} "
          f"nodes, {wall:.2f} s: front at t = {T_END} s exact {exact[-1]:.5f} m, probe {front[-1]:.5f} m, "
          f"melted volume / height {vol_front[-1]:.5f} m; max |probe - exact| = {np.nanmax(err):.2e} m = "
          f"{np.nanmax(err) / H:.2f} h, max |volume front - exact| = {vol_err.max():.2e} m = "
          f"{vol_err.max() / H:.2f} h; "
          f"Newton mean {stefan['newton_iterations']['mean']:.2f} max {stefan['newton_iterations']['max']}")
    assert len(times) == s["steps"] + 1
    assert s["probe_series"]["front"][0] is None and np.all(np.isfinite(front[1:]))     # no front at t = 0
    assert np.nanmax(err) <= 1.5 * H
    assert vol_err.max() <= 0.3 * H
    assert stefan["melted_fraction"]["pcm"][-1] == pytest.approx(vol_front[-1] * HEIGHT / (LENGTH * HEIGHT))
    assert stefan["newton_iterations"]["max"] <= 6
    # the probe lines with no front: recorded as missing, never NaN
    assert s["probes"]["no_front"] == {"final": None}
    assert s["probe_series"]["no_front"] == [None] * len(times)
    phi = s["probes"]["phi_near_face"]
    assert phi["final"] == 1.0 and phi["min"] == 0.0
    assert s["probes"]["phi_mean"]["final"] == pytest.approx(stefan["melted_fraction"]["pcm"][-1], rel=0.05)


# -- (b) energy balance ---------------------------------------------------------------------------------------
def test_neumann_scene_energy_balance(neumann):
    """Latent plus sensible heat gained equals the heat that entered (the scheme conserves it to rounding), and
    the heat that entered is near the closed form's boundary heat (discretization error)."""
    e = neumann[0].summary["stefan"]["energy"]
    gain, latent, sensible = (np.array(e[k]) for k in ("heat_gain", "latent_heat_gain", "sensible_heat_gain"))
    supplied = np.array(e["heat_supplied"])
    exact = NEUMANN.boundary_heat(0.0, T_END) * HEIGHT
    print(f"\nenergy at t = {T_END} s: latent {latent[-1]:.6f} + sensible {sensible[-1]:.6f} = {gain[-1]:.6f} J/m, "
          f"supplied {supplied[-1]:.6f} J/m (Dirichlet {e['heat_supplied_dirichlet'][-1]:.6f}); relative imbalance "
          f"{e['imbalance_rel']:.1e} (max over the output times {e['imbalance_rel_max']:.1e}); closed-form boundary "
          f"heat {exact:.6f} J/m (difference {abs(supplied[-1] - exact) / exact:.2%})")
    assert np.allclose(latent + sensible, gain, rtol=0, atol=1e-14 * abs(gain[-1]))
    assert e["imbalance_rel_max"] < 1e-10
    assert latent[-1] > 0 and sensible[-1] > 0
    assert abs(supplied[-1] - exact) < 0.01 * exact


def test_builtin_scene_energy_balance_with_fluxes_and_several_regions(melting_block):
    """Two phase-change regions (one latent heat per m^3, one per kg), a plain rock, a flux condition: the
    energy balance holds to rounding; the lens delays the thaw front."""
    s = melting_block[0].summary
    e = s["stefan"]["energy"]
    print(f"\nmelting_block: gain {e['heat_gain'][-1]:.6e} J/m, supplied {e['heat_supplied'][-1]:.6e} J/m (sources "
          f"and fluxes {e['heat_supplied_sources_fluxes'][-1]:.4e}), imbalance {e['imbalance_rel_max']:.1e}")
    assert e["imbalance_rel_max"] < 1e-10
    assert e["heat_supplied_sources_fluxes"][-1] == pytest.approx(0.06 * 6.0 * s["scene"]["time"]["end"], rel=1e-9)
    assert 0 < s["probes"]["thaw_depth_lens"]["final"] < s["probes"]["thaw_depth"]["final"]



def test_zero_latent_heat_sets_the_phase_from_the_temperature():
    """L = 0 (a phase change of k and rho c only): the liquid fraction is 1 above Theta_R and 0 below, and the
    front is the Theta_R isotherm. With equal phases the problem is plain conduction in the half-space,
    T = T_S + (T_L - T_S) erfc(x / (2 sqrt(a t))) (Carslaw & Jaeger 2.4), so the front lies at
    x_f = 2 z sqrt(a t), erfc(z) = (Theta_R - T_S)/(T_L - T_S); the nodal 0/1 fraction puts it within one
    element of x_f (measured 0.76 h, dt error included). A strip all at +14 C is liquid (fraction 1 at every
    node, no front)."""
    t_l, t_s, h, t_end = 14.0, -6.0, 0.025, 0.04
    pcm = {"conductivity": 1.0, "rho_c": 1.0, "phase_change_temperature": 0.0, "latent_heat_volumetric": 0.0,
           "rho_c_liquid": 1.0, "conductivity_liquid": 1.0}
    changes = {"scene.temperature_unit": "C", "materials.pcm": pcm, "mesh.maxh": h,
               "time.end": t_end, "time.dt": 0.002, "boundary_conditions.far": None,
               "boundary_conditions.hot.temperature": t_l, "blocks.0.size": [1.0, HEIGHT],
               "output.probes": [{"name": "front", "quantity": "front",
                                  "line": [[0.0, HEIGHT / 2], [1.0, HEIGHT / 2]]},
                                 {"name": "phi_near_face", "quantity": "liquid_fraction", "point": [0.1, HEIGHT / 2]},
                                 {"name": "phi_mean", "quantity": "liquid_fraction", "region": "pcm",
                                  "statistic": "mean"}]}
    tic = time.perf_counter()
    cold = run(scene_from_dict(neumann_scene(**changes, **{"initial.temperature": t_s})), None,
               progress=False).summary
    warm = run(scene_from_dict(neumann_scene(**changes, **{"initial.temperature": t_l})), None,
               progress=False).summary
    z = brentq(lambda z: erfc(z) - (0.0 - t_s) / (t_l - t_s), 0.0, 5.0)
    times = np.array(cold["probe_series"]["times_s"]["front"])
    front = np.array(cold["probe_series"]["front"][1:], dtype=float)
    err = np.abs(front - 2 * z * np.sqrt(times[1:]))
    print(f"\nL = 0: front at t = {t_end} s {front[-1]:.4f} m, closed form {2 * z * np.sqrt(t_end):.4f} m, max error "
          f"{err.max() / h:.2f} h; liquid fraction near the hot face {cold['probes']['phi_near_face']['final']}, "
          f"warm strip mean {warm['probes']['phi_mean']}; {time.perf_counter() - tic:.2f} s")
    assert err.max() <= h
    assert cold["probes"]["phi_near_face"]["final"] == 1.0
    assert 0 < cold["probes"]["phi_mean"]["final"] < 1
    assert warm["probes"]["phi_mean"]["min"] == 1.0 and warm["probes"]["phi_near_face"]["min"] == 1.0
    assert warm["probes"]["front"] == {"final": None}
    assert warm["stefan"]["melted_fraction"]["pcm"][-1] == pytest.approx(1.0)

# -- (c) validation -------------------------------------------------------------------------------------------
BAD = [
    ({"materials.pcm.latent_heat_volumetric": -1.0}, "materials.pcm.latent_heat_volumetric", "must be >= 0"),
    ({"materials.pcm.rho_c_liquid": 0.0}, "materials.pcm.rho_c_liquid", "must be positive"),
    ({"materials.pcm.rho_c_liquid": None}, "materials.pcm.rho_c_liquid", "liquid's heat capacity"),
    ({"materials.pcm.conductivity_liquid": None}, "materials.pcm.conductivity_liquid", "liquid's conductivity"),
    ({"materials.pcm.latent_heat_volumetric": None, "materials.pcm.latent_heat": 334e3}, "materials.pcm.density",
     "latent_heat is per kg"),
    ({"materials.pcm.latent_heat": 334e3}, "materials.pcm.latent_heat", "not both"),
    ({"materials.pcm.rho_c_liquid": None, "materials.pcm.specific_heat_liquid": 4200.0}, "materials.pcm.density",
     "specific_heat_liquid is per kg"),
    ({"materials.pcm.latent_heat_volumetric": None}, "materials.pcm.latent_heat", "needs latent_heat"),
    ({"materials.pcm.phase_change_temperature": None, "output.probes": []}, "materials.pcm.latent_heat_volumetric",
     "set phase_change_temperature"),     # and the same for rho_c_liquid and conductivity_liquid
    ({"materials.pcm.conductivity": [[1.5, 0.0], [0.0, 3.0]]}, "materials.pcm.conductivity_liquid",
     "not proportional"),
    ({"materials.pcm.conductivity_liquid": [[1.0, 0.0], [0.0, 3.0]]}, "materials.pcm.conductivity_liquid",
     "not proportional"),
    ({"materials.pcm.conductivity_liquid_principal": [1.0, 1.0]}, "materials.pcm.conductivity_liquid_principal",
     "not both"),
    ({"materials.pcm.conductivity_liquid": [[1.0, 2.0], [2.0, 1.0]]}, "materials.pcm.conductivity_liquid",
     "not positive definite"),
    ({"physics.thermal": "steady", "time": None}, "physics.thermal", "time-dependent"),
    ({"physics.thermal": None, "physics.mechanics": None, "boundary_conditions": None},
     "materials.pcm.phase_change_temperature", "physics.thermal is off"),
    ({"mesh.order": 2}, "mesh.order", "lumped P1"),
    ({"time.scheme": "crank_nicolson"}, "time.scheme", "backward Euler"),
    ({"output.probes": [{"name": "f", "quantity": "front", "point": [0.1, 0.05]}]}, "output.probes[0] (f).quantity",
     "needs a line"),
    ({"output.probes": [{"name": "f", "quantity": "temperature", "line": [[0, 0.05], [1, 0.05]]}]},
     "output.probes[0] (f).line", "a line goes with quantity = 'front'"),
    ({"output.probes": [{"name": "f", "quantity": "front", "line": [[-1, 0.05], [1, 0.05]]}]},
     "output.probes[0] (f).line", "lies outside the geometry"),
]


@pytest.mark.parametrize("changes, item, text", BAD, ids=[b[1].split(".", 1)[1] + ":" + b[2][:18] for b in BAD])
def test_validation_names_the_key(changes, item, text):
    data = neumann_scene(**{k: v for k, v in changes.items()})
    if "physics.thermal" in changes and changes["physics.thermal"] is None:
        data["physics"] = {"mechanics": "static"}
        data["materials"]["pcm"].update(youngs_modulus=1e9, poisson_ratio=0.3)
        data["boundary_conditions"] = {"far": {"displacement": [0.0, 0.0]}}
        data["output"]["probes"] = []
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    problems = info.value.problems
    print(f"\n{changes}: " + "; ".join(map(str, problems)))
    assert any(p.item == item and text in p.message for p in problems), problems
    assert len(problems) == (3 if "materials.pcm.phase_change_temperature" in changes else 1), problems


def test_liquid_fraction_probe_needs_a_phase_change():
    data = neumann_scene(**{"materials.pcm": {"conductivity": 1.0, "rho_c": 1.0}})
    with pytest.raises(SceneError, match=r"output.probes\[0\] \(front\).quantity: 'front' needs a phase change"):
        validate(scene_from_dict(data))


def test_contact_interface_thermal_penalty_is_checked_by_name():
    """Contact interfaces between touching blocks pass heat in Stefan scenes (jump penalty); thermal_penalty
    is refused where it does not apply (glued interfaces, scenes without phase change) and when not > 0."""
    data = neumann_scene()
    data["blocks"] = [{"name": "pcm", "shape": "rectangle", "origin": [0.0, 0.0], "size": [0.5, HEIGHT],
                       "boundaries": {"hot": "xmin"}},
                      {"name": "rock", "shape": "rectangle", "origin": [0.5, 0.0], "size": [0.5, HEIGHT],
                       "boundaries": {"far": "xmax"}}]
    data["interfaces"] = [{"name": "cut", "blocks": ["pcm", "rock"], "type": "contact", "thermal_penalty": 100.0}]
    data["materials"]["rock"] = {"conductivity": 3.0, "rho_c": 2e6}
    data["output"]["probes"] = []
    validate(scene_from_dict(data))
    for change, text in (({"type": "glued"}, "a glued interface shares its nodes"),
                         ({"thermal_penalty": 0.0}, "must be > 0")):
        bad = {**data, "interfaces": [{**data["interfaces"][0], **change}]}
        with pytest.raises(SceneError) as info:
            validate(scene_from_dict(bad))
        (problem,) = info.value.problems
        assert problem.item == "interfaces[0] (cut).thermal_penalty" and text in problem.message, problem
    plain = {**data, "materials": {"pcm": {"conductivity": 1.0, "rho_c": 2e6}, "rock": data["materials"]["rock"]}}
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(plain))
    assert any(p.item == "interfaces[0] (cut).thermal_penalty" and "Stefan" in p.message
               for p in info.value.problems), info.value.problems


# -- (d) the built-in scene -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def melting_block(tmp_path_factory):
    out = tmp_path_factory.mktemp("melting_block") / "OUT"
    tic = time.perf_counter()
    result = run("melting_block", out, progress=False)
    return result, out, time.perf_counter() - tic


def test_builtin_scene_runs_and_writes_its_output(melting_block):
    result, out, wall = melting_block
    s = result.summary
    st_ = s["stefan"]
    print(f"\nmelting_block: {wall:.2f} s wall ({s['wall_time_s']['solve_s']:.2f} s solve), {s['steps']} steps, "
          f"{s['mesh']['vertices']} nodes; Newton mean {st_['newton_iterations']['mean']:.2f} max "
          f"{st_['newton_iterations']['max']}; thaw depth {s['probes']['thaw_depth']['final']:.3f} m beside the lens, "
          f"{s['probes']['thaw_depth_lens']['final']:.3f} m through it; melted fractions "
          f"{ {r: round(v[-1], 4) for r, v in st_['melted_fraction'].items()} }; latent heat stored "
          f"{st_['latent_heat_stored_total'][-1]:.4e} J/m")
    assert (out / "figures" / "phase_boundary.png").stat().st_size > 0
    assert (out / "figures" / "melted_fraction.png").exists() and (out / "figures" / "probes_front.png").exists()
    listed = re.findall(r'file="([^"]+)"', (out / "melting_block_phase_boundary.pvd").read_text())
    vtus = re.findall(r'file="([^"]+)"', (out / "melting_block.pvd").read_text())
    assert len(listed) == len(vtus) == len(st_["output_times_s"]) >= 2
    assert sorted(p.name for p in out.glob("*.vtp")) == sorted(listed)
    last = (out / listed[-1]).read_text()
    assert int(re.search(r'NumberOfLines="(\d+)"', last).group(1)) > 10 and 'Name="temperature"' in last
    head = (out / vtus[-1]).read_bytes()
    for name in ("temperature", "enthalpy", "liquid_fraction", "heat_flux", "region"):
        assert f'Name="{name}"'.encode() in head
    for key in ("phase_change_regions", "output_times_s", "melted_volume", "melted_fraction", "latent_heat_stored",
                "latent_heat_stored_total", "energy", "newton_iterations", "units"):
        assert key in st_, key
    assert set(st_["melted_volume"]) == {"silt", "ice_lens"}
    assert st_["units"] == {"volume": "m^2 per m of depth", "heat": "J per m of depth"}
    assert 0 < st_["melted_fraction"]["silt"][-1] < 1
    assert st_["newton_iterations"]["mean"] <= 4 and st_["newton_iterations"]["max"] <= 8
    assert json.loads((out / "summary.json").read_text())["stefan"]["output_times_s"] == st_["output_times_s"]


def test_phase_boundary_lies_at_the_melting_temperature(melting_block):
    """The temperature interpolated at the iso-line's points is near Theta_R = 0 (within the temperature
    change across one element) and the line lies in the phase-change regions."""
    result = melting_block[0]
    iso = result.stefan.phase_boundary()
    T = result.stefan.forms.gf_temperature.vec.FV().NumPy()
    Ti = iso.interpolate(T)
    print(f"\nphase boundary: {len(iso.points)} points, {len(iso.segments)} segments, T there {Ti.min():.3f} .. "
          f"{Ti.max():.3f} degC")
    assert len(iso.segments) > 10
    assert np.all(np.abs(Ti) < 1.0)
    assert iso.points[:, 1].min() >= -3.0 - 1e-12          # not in the bedrock


def test_mechanics_takes_the_stefan_temperature():
    """physics.mechanics with a phase change: the thermal stress comes from the Stefan temperature."""
    data = neumann_scene(**{"physics.mechanics": "static", "output.probes": [
        {"name": "ux", "quantity": "displacement_x", "point": [LENGTH, HEIGHT / 2]}]})
    data["materials"]["pcm"].update(youngs_modulus=1e9, poisson_ratio=0.25, thermal_expansion=1e-3)
    data["boundary_conditions"]["hot"]["displacement"] = [0.0, "free"]
    data["boundary_conditions"]["bottom"] = {"symmetry": True}
    data["blocks"][0]["boundaries"]["bottom"] = "ymin"
    res = run(scene_from_dict(data), None, progress=False)
    ux = res.summary["probes"]["ux"]
    # a thin strip with T = T(x), free along y: eps_xx ~ (1 + nu) alpha T (plane strain), T0 = 0
    mean_T = float(ngs.Integrate(res.stefan.forms.gf_temperature, res.mesh)) / HEIGHT
    expected = (1.25 * 1e-3 * NEUMANN.t_cold * LENGTH, 1.25 * 1e-3 * mean_T)
    print(f"\nplane strain strip, free end displacement at t = 0 {ux['min']:.6e} m (1D estimate {expected[0]:.6e}), "
          f"at t = {T_END} s {ux['final']:.6e} m (1D estimate from the Stefan temperature {expected[1]:.6e})")
    assert ux["time_of_min"] == 0.0 and ux["min"] == pytest.approx(expected[0], rel=1e-3)
    assert ux["final"] == pytest.approx(expected[1], rel=1e-2)


# -- (e) checkpoint and resume --------------------------------------------------------------------------------
SETS = ["time.end='120 day'", "output.checkpoint_every=5", "output.figures=false"]
IGNORED = {"wall_time_s", "wall_s", "factorizations", "resumed"}


def assert_close(a, b, path: str = "summary") -> None:
    """Equal data, floats to 1e-12 relative (the pattern of tests/test_checkpoint.py)."""
    if isinstance(a, dict):
        assert set(a) - IGNORED == set(b) - IGNORED, path
        for k in set(a) - IGNORED:
            assert_close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-12), path
    else:
        assert a == b, path


def test_solver_error_then_resume_equals_the_uninterrupted_run(tmp_path, monkeypatch):
    ref = run("melting_block", tmp_path / "REF", overrides=SETS, progress=False)
    original = StefanSolver.step
    calls = {"n": 0}

    def step(self, t_old, t_new):
        calls["n"] += 1
        if calls["n"] >= 13:              # every try from the 13th step on: the step halvings fail as well
            raise SolverError("Stefan Newton step diverged (injected)")
        return original(self, t_old, t_new)
    monkeypatch.setattr(StefanSolver, "step", step)
    with pytest.raises(SolverError, match=r"step 13 .*injected.*\n.*The last good state \(step 12 of \d+.*--resume"):
        run("melting_block", tmp_path / "DIR", overrides=SETS, progress=False)
    monkeypatch.undo()
    (staging,) = [p for p in tmp_path.glob(".DIR.partial-*") if p.is_dir()]
    cp = load_checkpoint(staging / "checkpoint")
    assert cp.meta["step"] == 12 and "stefan/enthalpy" in cp.arrays
    assert len(cp.meta["parts"]["stefan"]["iterations"]) == 12
    res = run("melting_block", tmp_path / "DIR", overrides=SETS, progress=False, resume=True)
    assert res.summary["resumed"][0]["step"] == 12
    a = json.loads((tmp_path / "REF" / "summary.json").read_text())
    b = json.loads((tmp_path / "DIR" / "summary.json").read_text())
    assert_close(a, b)
    ea, eb = ref.stefan.solver.e, res.stefan.solver.e
    print(f"\nresumed at step 12 of {a['steps']}: |e - e_ref| / |e_ref| = "
          f"{np.linalg.norm(eb - ea) / np.linalg.norm(ea):.1e}; Newton iterations equal: "
          f"{a['stefan']['newton_iterations'] == b['stefan']['newton_iterations']}")
    assert np.linalg.norm(eb - ea) <= 1e-12 * np.linalg.norm(ea)
    names = sorted(p.name for p in (tmp_path / "DIR").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "REF").iterdir())
    for f in (tmp_path / "REF").glob("*.vtp"):
        assert (tmp_path / "DIR" / f.name).read_text() == f.read_text()


# -- the iso-line and crossing helpers ------------------------------------------------------------------------
def test_iso_segments_of_a_linear_field_are_exact():
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [2.0, 0.0], [2.0, 1.0]])
    tris = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
    v = 0.4 * pts[:, 0] + 0.1                      # level 0.5 at x = 1: through the vertices 1 and 2
    iso = iso_segments(pts, tris, v, 0.5)
    assert np.allclose(iso.points[:, 0], 1.0) and len(iso.segments) == 1
    v = pts[:, 0] - 0.25                           # x = 0.75: one segment per cut triangle, joined
    iso = iso_segments(pts, tris, v, 0.5)
    assert np.allclose(iso.points[:, 0], 0.75) and len(iso.segments) == 2 and len(iso.points) == 3
    assert np.allclose(iso.interpolate(pts[:, 1] * 2), 2 * iso.points[:, 1])
    assert len(iso_segments(pts, tris, np.zeros(6), 0.5).segments) == 0


def test_first_crossing():
    s = np.linspace(0.0, 1.0, 11)
    assert first_crossing(s, 1.0 - s, 0.5) == pytest.approx(0.5)
    assert first_crossing(s, np.where(s < 0.35, np.nan, s), 0.5) == pytest.approx(0.5)   # gaps skipped
    assert first_crossing(s, np.ones(11), 0.5) is None
    assert first_crossing(s, np.full(11, np.nan), 0.5) is None


def test_a_step_whose_newton_fails_is_halved():
    """dt = 0.4 h on h = 0.00625: the front crosses too many element layers in some steps and the semi-smooth
    Newton iteration diverged there (the run stopped at step 14); such steps are now split in halves, the run
    ends with the same energy balance and a front within the mesh's accuracy."""
    h, dt = 0.00625, 0.0025
    res = run(scene_from_dict(neumann_scene(**{"mesh.maxh": h, "time.dt": dt, "output.probes": None})), None,
              progress=False)
    s = res.summary["stefan"]
    melted = s["melted_volume"]["pcm"][-1] / HEIGHT
    exact = NEUMANN.front(T_END)
    print(f"\nh = {h}, dt = {dt}: {s['step_halvings']} halvings, Newton mean {s['newton_iterations']['mean']:.2f} "
          f"max {s['newton_iterations']['max']}, front {melted:.5f} m (exact {exact:.5f}), imbalance "
          f"{s['energy']['imbalance_rel']:.1e}")
    assert s["step_halvings"] >= 1 and s["energy"]["imbalance_rel"] < 1e-10
    assert abs(melted - exact) / exact < 5e-3
