"""The in-situ traction across non-matching contact interfaces (:class:`ngs_geomech.mechanics.contact.InSituTraction`)
and the outward normals it integrates with (:func:`ngs_geomech.fem.normals.outward_normal`).

Closed form (:mod:`ngs_geomech.verification.insitu`): rock under gravity with a lithostatic initial stress (K0 = 0.8)
on rollers, cut by a dipping Coulomb fault with non-matching meshes: u = 0. With the exact transfer the computed
displacement is round-off; with the mortar's transfer alone the fault's depth-linear traction leaves an O(h^2)
consistency load (printed with pytest -s).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import pytest

from ngs_geomech.fem.normals import outward_normal
from ngs_geomech.verification.insitu import lithostatic_fault

pytestmark = pytest.mark.usefixtures("one_thread")


def test_lithostatic_state_stays_at_rest_across_a_dipping_fault_2d():
    coarse = lithostatic_fault(dim=2, dip=40.0, strike=180.0, maxh=250.0, fine=130.0)
    fine = lithostatic_fault(dim=2, dip=40.0, strike=180.0, maxh=125.0, fine=65.0)
    order = math.log2(coarse["mortar"] / fine["mortar"])
    print(f"\n2D lithostatic fault, max |u| (m): exact transfer {coarse['exact']:.1e}, {fine['exact']:.1e}; mortar "
          f"transfer {coarse['mortar']:.2e}, {fine['mortar']:.2e} (order {order:.2f}); smallest pressure "
          f"{fine['min_pressure']:.3g} Pa")
    assert coarse["exact"] < 1e-10 and fine["exact"] < 1e-10
    assert fine["mortar"] > 1e4 * fine["exact"]
    assert order > 1.8
    assert fine["min_pressure"] > 0 and fine["pressure_deviation"] < 0.1


def test_lithostatic_state_stays_at_rest_across_an_oblique_fault_3d():
    r = lithostatic_fault(dim=3, dip=50.0, strike=30.0, order=2)
    print(f"\n3D lithostatic fault (dip 50, strike 30, P2, {r['ndof']} dofs), max |u| (m): exact transfer "
          f"{r['exact']:.1e}, mortar transfer {r['mortar']:.2e}")
    assert r["exact"] < 1e-10
    assert r["mortar"] > 1e-5
    assert r["min_pressure"] > 0 and r["pressure_deviation"] < 0.1


@pytest.mark.parametrize("strike", [0.0, 30.0])
def test_rows_the_supports_make_dependent_are_left_out_p1_3d(strike):
    """P1 in 3D: where the fault meets the rollers the supports hold part of the relative motion, so some contact
    rows (of one node, or combined over the nodes on a roller) are dependent on the free dofs; their exact stick
    rows made the matrix singular (the sets cycled). The solver leaves them out; the state stays at rest."""
    r = lithostatic_fault(dim=3, dip=60.0 if strike == 0.0 else 50.0, strike=strike)
    print(f"\n3D lithostatic fault (strike {strike:g}, P1, {r['ndof']} dofs), max |u| (m): exact transfer "
          f"{r['exact']:.1e}, mortar transfer {r['mortar']:.2e}")
    assert r["exact"] < 1e-9
    assert r["mortar"] > 1e-5


@pytest.mark.parametrize("dim", [2, 3])
def test_outward_normal_points_out_of_each_body(dim):
    from netgen import occ
    if dim == 2:
        a = occ.Rectangle(1, 1).Face()
        b = occ.Rectangle(1, 1).Face().Move((1, 0, 0))
        a.edges.Max(occ.X).name, b.edges.Min(occ.X).name = "a_right", "b_left"
        shape = occ.OCCGeometry(occ.Compound([a, b]), dim=2)
    else:
        a = occ.Box((0, 0, 0), (1, 1, 1))
        b = occ.Box((1, 0, 0), (2, 1, 1))
        a.faces.Max(occ.X).name, b.faces.Min(occ.X).name = "a_right", "b_left"
        shape = occ.OCCGeometry(occ.Compound([a, b]))
    mesh = ngs.Mesh(shape.GenerateMesh(maxh=0.4))
    for side, expect in (("a_right", 1.0), ("b_left", -1.0)):
        n = outward_normal(mesh, side)
        area = ngs.Integrate(1.0, mesh, definedon=mesh.Boundaries(side))
        nx = ngs.Integrate(n[0], mesh, definedon=mesh.Boundaries(side))
        assert area > 0.5 and abs(nx / area - expect) < 1e-12
