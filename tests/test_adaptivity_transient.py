"""Front-following meshes in transient scenes (``[adaptivity]`` with ``indicators = ['phase_front']``, issue 6
section 2; :mod:`ngs_geomech.adapt.front_following`): the scene's geometry is remeshed with a fine size at the
phase boundary, the enthalpy carried over by the lumped projection with its heat-content change recorded and counted
in the energy balance.

(1) the two-phase Neumann strip as a scene (:func:`tests.test_stefan_scenes.neumann_scene`) against the closed form
and the uniform run on the fine size; (2) the built-in ``permafrost`` scene at a coarse level against a uniform fine
run; (3) output (VTK on changing meshes, figures, summary, no checkpoints, --resume refused); (4) validation of the
unsupported combinations, each naming its key."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from test_stefan_scenes import HEIGHT, NEUMANN, T_END, neumann_scene

from ngs_geomech.errors import ResumeError, SceneError
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import load_scene, scene_from_dict
from ngs_geomech.scene.schema import to_dict
from ngs_geomech.validation.validate import validate

pytestmark = pytest.mark.usefixtures("one_thread")

FRONT = {"indicators": ["phase_front"], "levels": 2, "layers": 2}
DT = 0.005


def _neumann(h: float, adaptivity: dict | None = None, out=None, **changes):
    data = neumann_scene(**{"mesh.maxh": h, "time.dt": DT, **changes})
    if adaptivity is not None:
        data["adaptivity"] = adaptivity
    tic = time.perf_counter()
    res = run_scene(scene_from_dict(data), out, progress=False)
    return res, time.perf_counter() - tic


def _front_error(summary: dict) -> float:
    """|front - exact| at T_END from the melted volume / height (m)."""
    return abs(summary["stefan"]["melted_volume"]["pcm"][-1] / HEIGHT - NEUMANN.front(T_END))


def test_neumann_front_following_matches_uniform_fine_with_fewer_dofs():
    """Base mesh h = 0.05 m halved twice at the front (h_front = 0.014 m) against the uniform mesh h = 0.0125 m:
    front error at t = 0.5 s no worse (measured 1.2e-3 against 1.9e-3 m) with about a tenth of the unknowns
    (measured 280 mean against 2842), heat content change per transfer <= 2e-5 (measured max 8.5e-6), energy
    balance closed with the transfers counted (1e-16)."""
    ada, wall_a = _neumann(0.05, FRONT)
    uni, wall_u = _neumann(0.0125)
    coarse, _ = _neumann(0.05)
    a = ada.summary["adaptivity"]
    err_a, err_u, err_c = (_front_error(r.summary) for r in (ada, uni, coarse))
    mean_a, ndof_u = a["dofs"]["mean"], uni.summary["mesh"]["dofs"]
    energy = ada.summary["stefan"]["energy"]
    print(f"\nNeumann strip: front-following h_front = {a['h_front_m']:.4f} m: front error {err_a:.2e} m, mean dofs "
          f"{mean_a:.0f} (max {a['dofs']['max']}), {a['remesh_count']} remeshes ({a['repeated_steps']} steps "
          f"repeated), transfer error max {a['transfer_error_max']:.1e}, heat transferred "
          f"{energy['heat_transferred'][-1]:.2e} J/m of {energy['heat_gain'][-1]:.3f}, imbalance "
          f"{energy['imbalance_rel']:.1e}, wall {wall_a:.2f} s (remeshing {a['remesh_wall_s']:.2f} s); uniform "
          f"h = 0.0125: error {err_u:.2e} m, {ndof_u} dofs, wall {wall_u:.2f} s; uniform h = 0.05: {err_c:.2e} m")
    assert a["mode"] == "front_following" and a["remesh_count"] >= 3
    assert len(a["remeshes"]) == a["remesh_count"]
    assert err_a <= 1.1 * err_u and err_a < 0.5 * err_c
    assert mean_a <= 0.2 * ndof_u
    assert a["transfer_error_max"] <= 2e-5
    assert all(r["heat_change_rel"] <= 2e-5 for r in a["remeshes"])
    assert energy["imbalance_rel"] <= 1e-12 and energy["imbalance_rel_max"] <= 1e-12
    assert abs(energy["heat_transferred"][-1]) <= 1e-4 * energy["heat_gain"][-1]
    # the front probe follows the closed form on the moving meshes too
    times = np.array(ada.summary["probe_series"]["times_s"]["front"])
    front = np.array(ada.summary["probe_series"]["front"], dtype=float)
    exact = np.array([NEUMANN.front(t) for t in times])
    assert np.nanmax(np.abs(front - exact)[1:]) <= 1.5 * 0.0125
    assert ada.summary["mesh"]["dofs"] == a["dofs"]["final"]


def test_permafrost_front_following_agrees_with_uniform_fine():
    """permafrost to 20 kyr on mesh.maxh = 10 m halved twice at the front (h_front 2.8 m) against the uniform
    mesh.maxh = 2.5 m: the frozen-depth probe within 2 fine element sizes at every step (measured 0.8 m at most,
    0.55 m at 20 kyr, where the uniform 10 m mesh is 2.9 m off) with about a tenth of the unknowns."""
    def perm(*sets, adaptivity=None):
        data = to_dict(load_scene("permafrost", ["time.end='20000 year'", *sets]))
        if adaptivity is not None:
            data["adaptivity"] = adaptivity
        tic = time.perf_counter()
        res = run_scene(scene_from_dict(data), None, progress=False)
        return res.summary, time.perf_counter() - tic

    ada, wall_a = perm("mesh.maxh=10", adaptivity={"indicators": ["phase_front"], "levels": 2, "layers": 3})
    fine, wall_f = perm("mesh.maxh=2.5")
    coarse, _ = perm("mesh.maxh=10")
    a = ada["adaptivity"]
    series = {k: np.array([np.nan if v is None else v for v in s["probe_series"]["frozen_depth"]])
              for k, s in (("ada", ada), ("fine", fine), ("coarse", coarse))}
    assert ada["probe_series"]["times_s"]["frozen_depth"] == fine["probe_series"]["times_s"]["frozen_depth"]
    both = np.isfinite(series["ada"]) & np.isfinite(series["fine"])
    diff = np.abs(series["ada"] - series["fine"])[both]
    diff_c = np.abs(series["coarse"] - series["fine"])[both]
    print(f"\npermafrost to 20 kyr: front-following (h_front {a['h_front_m']:.2f} m): frozen depth "
          f"{series['ada'][-1]:.2f} m, max |ada - fine| {diff.max():.2f} m, mean dofs {a['dofs']['mean']:.0f}, "
          f"{a['remesh_count']} remeshes, transfer error max {a['transfer_error_max']:.1e}, imbalance "
          f"{ada['stefan']['energy']['imbalance_rel']:.1e}, wall {wall_a:.2f} s (remeshing {a['remesh_wall_s']:.2f} "
          f"s); uniform 2.5 m: {series['fine'][-1]:.2f} m, {fine['mesh']['dofs']} dofs, wall {wall_f:.2f} s; "
          f"uniform 10 m: {series['coarse'][-1]:.2f} m, max |coarse - fine| {diff_c.max():.2f} m")
    assert both.sum() >= 0.8 * len(both) and np.array_equal(np.isfinite(series["ada"]), np.isfinite(series["fine"]))
    assert diff.max() <= 2 * 2.5
    assert abs(series["ada"][-1] - series["fine"][-1]) <= 0.5 * abs(series["coarse"][-1] - series["fine"][-1])
    assert a["dofs"]["mean"] <= 0.2 * fine["mesh"]["dofs"]
    assert a["transfer_error_max"] <= 1e-5
    assert ada["stefan"]["energy"]["imbalance_rel"] <= 1e-12


def test_front_following_output_is_complete_and_not_resumable(tmp_path):
    """VTK series over the changing meshes (one .vtu per output time, each on its own mesh, all in the .pvd), the
    phase boundary lines, the figures on the last mesh, the adaptivity block in summary.json; no checkpoint and no
    staging directory left; --resume refused naming the reason."""
    out = tmp_path / "OUT"
    res, _ = _neumann(0.05, FRONT, out=out, **{"time.end": 0.2, "output.every": 5})
    s = json.loads((out / "summary.json").read_text())
    a = s["adaptivity"]
    vtus = sorted(out.glob("neumann*.vtu"))
    pvd = (out / "neumann.pvd").read_text()
    assert len(vtus) == len(s["stefan"]["output_times_s"]) == pvd.count("<DataSet")
    points = {int(v.read_bytes().split(b'NumberOfPoints="')[1].split(b'"')[0]) for v in vtus}
    assert len(points) >= 2                                   # the meshes changed between output times
    assert (out / "neumann_phase_boundary.pvd").exists()
    for f in ("temperature.png", "phase_boundary.png", "probes_front.png", "melted_fraction.png"):
        assert (out / "figures" / f).exists()
    assert a["remesh_count"] >= 1 and s["mesh"]["dofs"] == a["dofs"]["final"] == res.summary["mesh"]["dofs"]
    assert not (out / "checkpoint").exists()
    assert not list(tmp_path.glob(".OUT.partial*"))
    data = neumann_scene(**{"mesh.maxh": 0.05, "time.dt": DT})
    data["adaptivity"] = FRONT
    with pytest.raises(ResumeError, match="phase boundary"):
        run_scene(scene_from_dict(data), out, progress=False, resume=True)


def _problems(data: dict) -> str:
    with pytest.raises(SceneError) as info:
        validate(scene_from_dict(data))
    return str(info.value)


def test_unsupported_combinations_name_their_key():
    base = neumann_scene()
    ok = dict(base, adaptivity=FRONT)
    validate(scene_from_dict(ok))
    cases = {
        "adaptivity.indicators": dict(base, adaptivity={"indicators": []}),
        "adaptivity.levels": dict(base, adaptivity={**FRONT, "levels": 0}),
        "adaptivity.layers": dict(base, adaptivity={**FRONT, "layers": -1}),
        "adaptivity.remesh_every": dict(base, adaptivity={**FRONT, "remesh_every": -2}),
        "adaptivity.tolerance": dict(base, adaptivity={**FRONT, "tolerance": 1e-3}),
        "scene.dimension": dict(base, scene={"name": "neumann", "dimension": "axisymmetric"}, adaptivity=FRONT),
    }
    for key, data in cases.items():
        msg = _problems(data)
        assert key in msg, (key, msg)
    # both over time need the contact's mechanics (tests/test_adaptivity_contact_following.py)
    msg = _problems(dict(base, adaptivity={"indicators": ["phase_front", "contact_zone"]}))
    assert "physics.mechanics" in msg and "'static'" in msg
    # no phase change: a plain transient heat scene
    plain = neumann_scene()
    for k in ("phase_change_temperature", "latent_heat_volumetric", "rho_c_liquid", "conductivity_liquid"):
        plain["materials"]["pcm"].pop(k)
    plain["output"]["probes"] = []
    assert "phase change" in _problems(dict(plain, adaptivity=FRONT))
    # mechanics
    mech = neumann_scene(**{"physics.mechanics": "static"})
    mech["materials"]["pcm"].update(youngs_modulus=1e9, poisson_ratio=0.25)
    assert "physics.mechanics" in _problems(dict(mech, adaptivity=FRONT))
    # 'phase_front' in a stationary scene
    steady = neumann_scene(**{"physics.thermal": "steady", "time": None})
    steady["output"]["probes"] = []
    assert "adaptivity.indicators" in _problems(dict(steady, adaptivity={"indicators": ["phase_front"]}))


def test_contact_interface_is_refused():
    """Two touching phase-change blocks with a contact interface (heat by the jump penalty): not with
    front-following meshes (a conforming remesh is needed); 'glued' is fine."""
    data = neumann_scene()
    half = data["blocks"][0]["size"][0] / 2
    data["blocks"] = [{"name": "pcm", "shape": "rectangle", "origin": [0.0, 0.0], "size": [half, HEIGHT],
                       "boundaries": {"hot": "xmin"}},
                      {"name": "pcm2", "shape": "rectangle", "origin": [half, 0.0], "size": [half, HEIGHT],
                       "boundaries": {"far": "xmax"}}]
    data["materials"]["pcm2"] = dict(data["materials"]["pcm"])
    data["output"]["probes"] = []
    data["adaptivity"] = FRONT
    data["interfaces"] = [{"name": "mid", "blocks": ["pcm", "pcm2"], "type": "contact"}]
    assert "interfaces.mid" in _problems(data)
    data["interfaces"] = [{"name": "mid", "blocks": ["pcm", "pcm2"], "type": "glued"}]
    validate(scene_from_dict(data))
