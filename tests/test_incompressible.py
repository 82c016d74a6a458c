"""Near incompressibility (issue 8): the mixed displacement-pressure formulation of :mod:`physics.elasticity`
(Taylor-Hood P2-P1, stabilized P1-P1) against the thick-walled cylinder's closed forms (Lame's internal pressure
and the thermal stress; plane strain quarter ring and axisymmetric section) at nu = 0.3 ... 0.49999: errors of
u_r, every stress component and the mean stress uniform in nu, observed orders asserted; the displacement
formulation's locking for comparison; contact, floating bodies, the Lagrangian residual and the strain energy
with the extra component; the rules of ``formulation = "auto"``. Prints the error tables."""

from __future__ import annotations

import functools
import math

import ngsolve as ngs
import numpy as np
import pytest

from ngs_geomech.mechanics.forms import MIXED_POISSON, ElasticForms, ElasticSetup, mixed_regions
from ngs_geomech.mechanics.materials import ElasticProperties, isotropic
from ngs_geomech.mechanics.solver import ElasticSolver
from ngs_geomech.verification import contact_problems as cp
from ngs_geomech.verification import thermoelastic as te
from ngs_geomech.verification.contact_scenes import heated_bar, heated_bar_3d

pytestmark = pytest.mark.usefixtures("one_thread")

HS = (0.2, 0.1, 0.05)
NUS = (0.3, 0.49, 0.4999, 0.49999)
KEYS = ("u_r", "sigma_r", "sigma_theta", "sigma_z", "mean")


@functools.cache
def cylinder(case: str, order: int, load: str, nu: float, formulation: str = "mixed") -> dict:
    return te.incompressible_cylinder(case, nu, order, HS, load=load, formulation=formulation)


def _table(title: str, rows: dict) -> None:
    print(f"\n{title}   (errors at h = {', '.join(map(str, HS))}; u_r over max |u_r|, stresses over max |sigma_theta|)")
    for label, r in rows.items():
        print(f"  {label:>22}: " + "  ".join(f"{k} {' '.join(f'{v:.2e}' for v in r[k])} ({r['order_' + k]:.2f})"
                                              for k in KEYS))


# (finest-mesh bounds of u_r and of the largest stress error, least orders of u_r and of the largest stress error)
BOUNDS = {2: (3e-5, 2e-3, 2.6, 1.4), 1: (2e-3, 8e-2, 1.7, 0.75)}


@pytest.mark.parametrize("load", ["pressure", "thermal"])
@pytest.mark.parametrize("order", [2, 1])
@pytest.mark.parametrize("case", ["plane_strain", "axisymmetric"])
def test_cylinder_uniform_in_nu(case, order, load):
    """Mixed formulation: every error of the finest mesh within its bound for every nu, the largest stress error
    within 1.5x of its nu = 0.3 value and each error within 1.1x of its nu = 0.49 value (uniform in nu), the
    observed orders of u_r and of the stresses (P2: 3 and 2, the max norm near the surfaces giving ~1.6; P1: 2
    and 1) asserted; the displacement formulation at nu = 0.4999 for comparison (its mean stress locks)."""
    rows = {f"mixed nu = {nu:g}": cylinder(case, order, load, nu) for nu in NUS}
    rows["displacement nu = 0.4999"] = cylinder(case, order, load, 0.4999, "displacement")
    _table(f"{case}, P{order}, {load} load", rows)
    u_max, s_max, u_order, s_order = BOUNDS[order]
    ref, near = rows["mixed nu = 0.3"], rows["mixed nu = 0.49"]
    for nu in NUS:
        r = rows[f"mixed nu = {nu:g}"]
        assert r["mixed"]
        assert r["u_r"][-1] < u_max and r["max_stress"][-1] < s_max, nu
        assert r["order_u_r"] > u_order and r["order_max_stress"] > s_order, nu
        assert r["max_stress"][-1] < 1.5 * ref["max_stress"][-1], nu
        for k in KEYS:
            assert nu < 0.49 or r[k][-1] < 1.1 * near[k][-1], (nu, k)
    locked = rows["displacement nu = 0.4999"]
    assert not locked["mixed"]
    assert locked["mean"][-1] > 10 * rows["mixed nu = 0.4999"]["mean"][-1]


@pytest.mark.parametrize("case", ["plane_strain", "axisymmetric"])
def test_auto_formulation_threshold(case):
    """'auto' keeps the displacement formulation (X = V, bitwise the old results) up to nu = MIXED_POISSON and
    switches above; at nu = 0.3 the mixed formulation's errors are within the displacement formulation's
    (the same continuous problem: they differ by discretization error)."""
    auto = cylinder(case, 2, "pressure", 0.3, "auto")
    disp = cylinder(case, 2, "pressure", 0.3, "displacement")
    mixed = cylinder(case, 2, "pressure", 0.3, "mixed")
    _table(f"{case}, P2, pressure, nu = 0.3", {"auto": auto, "displacement": disp, "mixed": mixed})
    assert not auto["mixed"] and auto["dofs"] == disp["dofs"]
    for k in KEYS:
        assert auto[k] == disp[k]
        assert mixed[k][-1] < 1.2 * disp[k][-1] + 1e-5, k
    assert cylinder(case, 2, "pressure", 0.49, "auto")["mixed"]


def test_energy_and_residual():
    """Plane strain quarter ring under the internal pressure at nu = 0.4999, P2 mixed: the strain energy
    (int of strain_energy_density) equals the work 1/2 p u_r(a) pi a / 2 of the closed form, the Lagrangian's
    gradient (newton_form) vanishes at the solution, the stress measures are finite."""
    from ngs_geomech.mechanics.forms import stress_measures
    from ngs_geomech.verification.elastic_closed_forms import cylinder_pressure_stresses
    c, nu = te.CYLINDER, 0.4999
    mesh, _, setup = te._build(te._ni_cylinder_scene("plane_strain", 0.1, 2, nu, "pressure"))
    forms = ElasticForms(mesh, setup)
    assert forms.mixed and forms.compound
    ElasticSolver(forms).solve("energy")
    energy = ngs.Integrate(forms.strain_energy_density(), mesh, order=8)
    work = 0.5 * te.P_INNER * cylinder_pressure_stresses(c["a"], c["a"], c["b"], te.P_INNER, c["E"], nu).u_r \
        * math.pi * c["a"] / 2
    res = forms.gf.vec.CreateVector()
    forms.newton_form.Apply(forms.gf.vec, res)
    free = np.array(list(forms.X.FreeDofs()), dtype=bool)
    rel = float(np.linalg.norm(res.FV().NumPy()[free])) / float(np.linalg.norm(forms.secant_rhs.vec.FV().NumPy()))
    m = stress_measures(forms.stress_tensor())
    vals = [float(ngs.Integrate(m[k] * m[k], mesh)) for k in m]
    print(f"\nstrain energy {energy:.6e} J/m vs work {work:.6e} ({energy / work - 1:+.1e}); "
          f"Lagrangian residual {rel:.1e}")
    assert energy == pytest.approx(work, rel=2e-4)
    assert rel < 1e-10
    assert all(math.isfinite(v) for v in vals)


@pytest.mark.parametrize("order", [1, 2])
def test_contact_scene_heated_bar(order):
    """The heated bar between two frictionless foundations (scene path: contact solver on X with the pressure
    component, semi-coercive along x) at nu = 0.4999: the exact uniform contact pressure, force balance."""
    r = heated_bar(nu=0.4999, order=order)
    print(f"\nheated bar P{order}, nu = 0.4999: p_ref {r['p_ref'] / 1e6:.6f} MPa, max nodal error {r['p_error']:.1e}, "
          f"imbalance {r['imbalance_rel']:.1e}")
    assert r["p_ref"] > 1e7
    assert r["p_error"] < 1e-8
    assert r["imbalance_rel"] < 1e-8


def test_contact_scene_heated_bar_3d():
    """The same in 3D (Taylor-Hood on tetrahedra; P1: stabilized)."""
    r = heated_bar_3d(nu=0.4999, order=1)
    print(f"\nheated bar 3D P1, nu = 0.4999: p_ref {r['p_ref'] / 1e6:.6f} MPa, error {r['p_error']:.1e}")
    assert r["p_error"] < 1e-8


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("law,push", [("frictionless", "none"), ("coulomb", "traction"), ("tresca", "displacement")])
def test_contact_block_on_foundation(order, law, push):
    """A block on a rigid foundation (floating when not pushed by a displacement) at nu = 0.4999: the normal force
    carries the load, friction the push; frictionless: the exact uniform pressure."""
    r = cp.friction_block(push, law=law, nu=0.4999, order=order)
    print(f"\nblock P{order} {law} {push}: normal {r['normal_force']:.6e}, friction {r['friction_force']:.4e}, "
          f"{r['iterations']} iterations")
    assert r["normal_force"] == pytest.approx(r["load"], rel=1e-9)
    if law == "frictionless":
        assert np.allclose(r["lam_n"], r["load"], rtol=1e-9)
    elif push == "traction":
        assert r["friction_force"] == pytest.approx(r["applied"], rel=1e-9)
    else:
        assert r["friction_force"] == pytest.approx(r["capacity"], rel=1e-9)


def _props(nu: float, lam: float = 1.0, aniso: bool = False) -> ElasticProperties:
    C = isotropic(10e9, nu)
    if aniso:                   # cubic: another shear modulus in the xy plane, the bulk modulus unchanged
        C[5, 5] *= 1.3
    return ElasticProperties(C=C, alpha=np.zeros((3, 3)), beta=np.zeros((3, 3)), lam=lam)


def test_mixed_region_rules():
    """Which regions the formulation covers, and the notes (the warning texts) for those it cannot."""
    both = {"soft": _props(0.4999), "rock": _props(0.25)}
    assert mixed_regions(ElasticSetup(both, "plane_strain")) == (["soft"], [])
    assert mixed_regions(ElasticSetup(both, "plane_strain", formulation="mixed"))[0] == ["soft", "rock"]
    assert mixed_regions(ElasticSetup(both, "plane_strain", formulation="displacement")) == ([], [])
    assert mixed_regions(ElasticSetup(both, "plane_stress")) == ([], [])
    assert mixed_regions(ElasticSetup({"r": _props(MIXED_POISSON)}, "3d")) == ([], [])
    names, notes = mixed_regions(ElasticSetup({"soft": _props(0.4999), "law": _props(0.3, lam=1.5)}, "axisymmetric"))
    assert names == [] and "materials.soft" in notes[0] and "rheology_lambda" in notes[0]
    names, notes = mixed_regions(ElasticSetup({"a": _props(0.4999, aniso=True), "b": _props(0.49)}, "plane_strain"))
    print("\n" + "\n".join(notes))
    assert names == ["b"] and len(notes) == 1 and "materials.a" in notes[0] and "anisotropic" in notes[0]
    with pytest.raises(ValueError, match="rheology_lambda"):
        mixed_regions(ElasticSetup({"law": _props(0.3, lam=1.5)}, "3d", formulation="mixed"))
    with pytest.raises(ValueError, match="plane stress"):
        mixed_regions(ElasticSetup(both, "plane_stress", formulation="mixed"))
    with pytest.raises(ValueError, match="unknown formulation"):
        mixed_regions(ElasticSetup(both, "3d", formulation="bbar"))
