"""Heat across contact interfaces in the Stefan forms (:mod:`ngs_geomech.stefan.forms`): the jump penalty
gamma_c B^T D^-1 B on non-matching meshes.

Closed form: two blocks [0, 1] x [0, H] and [1, 2] x [0, H] with conductivities k1, k2, T = T_hot at x = 0 and
T_cold at x = 2, insulated elsewhere, joined by an interface of conductance gamma_c: the steady state is linear
in each block with the flux q = (T_hot - T_cold) / (1/k1 + 1/k2 + 1/gamma_c) and the jump q / gamma_c at the
interface. The penalty form reproduces this exactly (a linear field is in P1 and the averaged jump of a
constant jump is that constant), so the steady state is compared to round-off; with the default penalty the
jump is about 1/penalty of the temperature drop over one element."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.geometry.mesh import make_mesh
from ngs_geomech.scene.parse import scene_from_dict
from ngs_geomech.stefan.forms import DEFAULT_INTERFACE_PENALTY, StefanForms, StefanSetup
from ngs_geomech.stefan.materials import PhaseChangeMaterial, PlainThermalMaterial
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.validation.validate import validate

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_stefan_interfaces")]

H = 0.4


def _two_blocks(maxh_left=0.1, maxh_right=0.07):
    scene = scene_from_dict({
        "scene": {"name": "two_blocks"},
        "physics": {"thermal": "transient"},
        "mesh": {"maxh": 0.1},
        "time": {"end": 1.0, "dt": 1.0},
        "blocks": [{"name": "left", "shape": "rectangle", "origin": [0, 0], "size": [1.0, H], "maxh": maxh_left,
                    "boundaries": {"hot": "xmin"}},
                   {"name": "right", "shape": "rectangle", "origin": [1.0, 0], "size": [1.0, H],
                    "maxh": maxh_right, "boundaries": {"cold": "xmax"}}],
        "interfaces": [{"name": "joint", "blocks": ["left", "right"], "type": "contact"}],
        "materials": {"left": {"conductivity": 2.0, "rho_c": 2e6},
                      "right": {"conductivity": 1.0, "rho_c": 1e6}},
        "boundary_conditions": {"hot": {"temperature": 1.0}, "cold": {"temperature": 0.0}},
        "output": {"vtk": False, "figures": False},
    })
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh)
    cs = geo.contacts["joint"]
    return mesh, cs.master, cs.minion


@pytest.fixture(scope="module")
def blocks():
    return _two_blocks()


def _steady(mesh, master, minion, penalty, right=None):
    setup = StefanSetup(materials={"left": PlainThermalMaterial(rho_c=2e6, conductivity=2.0),
                                   "right": right or PlainThermalMaterial(rho_c=1e6, conductivity=1.0)},
                        dirichlet={"hot": 1.0, "cold": 0.0}, interfaces=[(master, minion, penalty)])
    forms = StefanForms(mesh, setup)
    solver = StefanSolver(forms)
    solver.set_initial(np.full(forms.n, 0.5))
    t = 0.0
    for dt in (1e3, 1e5, 1e7, 1e8, 1e8, 1e8):
        solver.step(t, t + dt)
        t += dt
    return forms, solver


def _sides(mesh, forms, T):
    pts = np.array([v.point for v in mesh.vertices])
    left = np.zeros(forms.n, dtype=bool)
    for el in mesh.Elements():
        if el.mat == "left":
            left[[v.nr for v in el.vertices]] = True
    return pts, left


@pytest.mark.parametrize("penalty", [1.0, 10.0, DEFAULT_INTERFACE_PENALTY])
def test_steady_two_blocks_match_the_closed_form_with_the_interface_conductance(blocks, penalty):
    mesh, master, minion = blocks
    forms, solver = _steady(mesh, master, minion, penalty)
    gamma = forms.interface_conductance[0]
    q = 1.0 / (1 / 2.0 + 1 / 1.0 + 1 / gamma)
    T = solver.temperature()
    pts, left = _sides(mesh, forms, T)
    x = pts[:, 0]
    exact = np.where(left, 1.0 - q * x / 2.0, q * (2.0 - x) / 1.0)
    err = float(np.max(np.abs(T - exact)))
    jump = q / gamma
    print(f"\npenalty {penalty:g}: gamma_c {gamma:.4g} W/(m^2 K), jump {jump:.3e} K, max |T - exact| {err:.1e} K")
    assert err < 1e-9
    hmax = 0.1
    assert gamma == pytest.approx(penalty * 2.0 / forms_h(mesh, master), rel=1e-12)
    if penalty == DEFAULT_INTERFACE_PENALTY:         # jump / (drop over one element of the stiffer side)
        assert jump / (q * hmax / 2.0) < 5.0 / penalty


def forms_h(mesh, master) -> float:
    lengths = []
    for el in mesh.Boundaries(master).Elements():
        p = np.array([mesh[v].point for v in el.vertices])
        lengths.append(float(np.linalg.norm(p[1] - p[0])))
    return float(np.mean(lengths))


def test_interface_keeps_the_energy_balance_and_melts_across(blocks):
    """A phase-change block heated through the interface: the heat content changes by exactly the heat that
    entered at the Dirichlet nodes (the penalty's columns sum to zero), and the PCM melts from the interface."""
    mesh, master, minion = blocks
    pcm = PhaseChangeMaterial(melting_temperature=0.2, latent_heat=1e7, rho_c_solid=1e6, rho_c_liquid=1.2e6,
                              conductivity_solid=1.0, conductivity_liquid=0.8)
    setup = StefanSetup(materials={"left": PlainThermalMaterial(rho_c=2e6, conductivity=2.0), "right": pcm},
                        dirichlet={"hot": 1.0}, interfaces=[(master, minion, DEFAULT_INTERFACE_PENALTY)])
    forms = StefanForms(mesh, setup)
    solver = StefanSolver(forms)
    solver.set_initial(np.zeros(forms.n))
    e0 = forms.heat_content(solver.e)
    heat_in, t, its = 0.0, 0.0, []
    for _ in range(40):
        info = solver.step(t, t + 1e5)
        t += 2e4
        heat_in += info.boundary_heat + info.source_heat
        its.append(info.iterations)
    gain = forms.heat_content(solver.e) - e0
    melted = forms.melted_volume(solver.e)
    print(f"\nheat gain {gain:.6e} J/m, supplied {heat_in:.6e}, imbalance {abs(gain - heat_in) / heat_in:.1e}; "
          f"melted {melted:.4f} m^2 of {H:.2f}; Newton mean {np.mean(its):.2f} max {max(its)}")
    assert abs(gain - heat_in) <= 1e-10 * abs(heat_in)
    assert 0.01 < melted < H
    frac = forms.liquid_fractions(solver.e)[:, 1]
    pts, left = _sides(mesh, forms, None)
    near = ~left & (pts[:, 0] < 1.08)
    far = ~left & (pts[:, 0] > 1.9)
    assert frac[near].min() > 0.99 and frac[far].max() == 0.0
