"""The out-of-plane prestress of plane strain: a 3x3 ``mechanics.initial_stress`` whose zz entry enters sigma_zz
(and so sigma_1, sigma_3, von Mises, the mean stress), checked against closed forms, and refused with xz, yz
shears or outside plane strain.

Closed form (an oedometer column, plane strain, rollers on the sides and the base, free or loaded top): with
gravity and the lithostatic prestress sigma0 = rho g y diag(K0, 1, Kz) the displacement is 0 and sigma = sigma0,
so sigma_zz = Kz rho g y. A top pressure q and a uniform heating dT add the uniaxial-strain state
e_yy = (beta dT - q) / M (M = lambda + 2 mu, beta = E alpha / (1 - 2 nu)), sigma_yy = -q and
sigma_xx = sigma_zz = lambda e_yy - beta dT. Both are linear in y: exact in P1 and P2 (errors to round-off)."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.api import run
from ngs_geomech.errors import SceneError
from ngs_geomech.scene.parse import scene_from_dict

pytestmark = pytest.mark.usefixtures("one_thread")

E, NU, ALPHA, RHO, G = 70e9, 0.25, 8e-6, 2700.0, 9.81
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
M = LAM + E / (1 + NU)
BETA = E * ALPHA / (1 - 2 * NU)
K0, KZ = 0.7, 0.85
H = 100.0                        # m, column height
POINTS = [[25.0, -60.0], [10.0, -95.0], [40.0, -5.0]]


def _column(*, initial_stress, q=0.0, dT=None, model="plane_strain", order=2, formulation="auto"):
    blocks = [{"name": "rock", "shape": "rectangle", "origin": [0, -H], "size": [50, H],
               "boundaries": {"sides": ["xmin", "xmax"], "bottom": "ymin", "top": "ymax"}}]
    bcs = {"sides": {"symmetry": True}, "bottom": {"symmetry": True}, "top": {"pressure": q}}
    mat = {"youngs_modulus": E, "poisson_ratio": NU, "thermal_expansion": ALPHA, "density": RHO,
           "stress_free_temperature": 0.0, "conductivity": 3.0}
    physics = {"mechanics": "static", "plane_model": model}
    if dT is not None:
        physics["thermal"] = "steady"
        for b in ("sides", "bottom", "top"):
            bcs[b]["temperature"] = dT
    d = {"scene": {"name": "column", "dimension": "plane"}, "physics": physics,
         "mesh": {"maxh": 20.0, "order": order}, "blocks": blocks, "materials": {"rock": mat},
         "boundary_conditions": bcs, "output": {"vtk": False, "figures": False},
         "mechanics": {"gravity": [0, -G], "initial_stress": initial_stress, "formulation": formulation}}
    return scene_from_dict(d)


def _lithostatic(kz=KZ):
    w = f"{RHO}*{G}*y"
    return [[f"{K0}*{w}", "0", "0"], ["0", w, "0"], ["0", "0", f"{kz}*{w}"]]


def _fields(res, p):
    mip = res.mesh(*p)
    f = res.mechanics.fields
    sig = np.array(res.mechanics.sigma(mip)).reshape(3, 3)
    return (np.array(res.mechanics.forms.displacement()(mip)), sig,
            {k: float(f[k](mip)) for k in ("von_mises", "mean_stress", "sigma_1", "sigma_3")})


def _expected(y, q, dT):
    """The exact 3x3 principal stresses (xx, yy, zz; Pa) of the column at height y (m)."""
    w = RHO * G * y
    e_yy = (BETA * dT - q) / M
    lateral = LAM * e_yy - BETA * dT
    return np.array([K0 * w + lateral, w - q, KZ * w + lateral])


def _measures(s):
    mean = s.mean()
    vm = np.sqrt(0.5 * ((s[0] - s[1]) ** 2 + (s[1] - s[2]) ** 2 + (s[2] - s[0]) ** 2))
    return {"von_mises": vm, "mean_stress": mean, "sigma_1": s.max(), "sigma_3": s.min()}


@pytest.mark.parametrize("order, formulation", [(1, "auto"), (2, "auto"), (2, "mixed")])
@pytest.mark.parametrize("q, dT", [(0.0, None), (2.0e6, None), (2.0e6, 40.0)])
def test_sigma_zz_of_a_plane_strain_column_is_exact(order, formulation, q, dT):
    """Displacement formulation (P1, P2) and the mixed displacement-pressure one (Taylor-Hood P2-P1)."""
    res = run(_column(initial_stress=_lithostatic(), q=q, dT=dT, order=order, formulation=formulation), None,
              progress=False)
    worst = 0.0
    for p in POINTS:
        u, sig, meas = _fields(res, p)
        exact = _expected(p[1], q, dT or 0.0)
        scale = float(np.abs(exact).max())
        err = float(np.abs(np.diag(sig) - exact).max()) / scale
        ex_m = _measures(exact)
        err_m = max(abs(meas[k] - ex_m[k]) / scale for k in ex_m)
        worst = max(worst, err, err_m)
        if q == 0.0 and dT is None:
            assert np.abs(u).max() < 1e-12
        print(f"\nP{order} {formulation} q={q:.0e} dT={dT}: y={p[1]:.0f} m sigma_zz {sig[2, 2]:.6e} Pa "
              f"(exact {exact[2]:.6e}), rel. error of the 3x3 diagonal {err:.1e}, of the measures {err_m:.1e}", end="")
    assert worst < 1e-9


def test_a_2x2_initial_stress_leaves_sigma_zz_without_prestress():
    """The existing behaviour: without a zz entry sigma_zz is the plane-strain elastic part only (here 0)."""
    two = [row[:2] for row in _lithostatic()[:2]]
    res = run(_column(initial_stress=two), None, progress=False)
    _, sig, _ = _fields(res, POINTS[0])
    assert abs(sig[2, 2]) < 1e-6 * RHO * G * H
    assert sig[1, 1] == pytest.approx(RHO * G * POINTS[0][1], rel=1e-9)


def test_out_of_plane_shear_prestress_is_refused():
    s0 = _lithostatic()
    s0[0][2] = s0[2][0] = "1e6"
    with pytest.raises(SceneError, match=r"mechanics\.initial_stress.*\[0\]\[2\], \[2\]\[0\]"):
        run(_column(initial_stress=s0), None, progress=False)


def test_3x3_initial_stress_is_refused_in_plane_stress():
    with pytest.raises(SceneError, match=r"mechanics\.initial_stress.*must be a 2x2 table"):
        run(_column(initial_stress=_lithostatic(), model="plane_stress"), None, progress=False)
