"""Iterative Newton steps of the contact solver (ngs_geomech.contact.krylov, issue 10): GMRES with the
augmented-Lagrangian AMG preconditioner against the direct factorizations on the same problems (the 3D punch
with Coulomb and Tresca friction and frictionless, P1 and P2; the 2D Coulomb blocks; a 3D scene), GMRES
iterations under refinement, and the errors. Figures are printed (pytest -s)."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.contact.solver import ContactSolver
from ngs_geomech.errors import SolverError
from ngs_geomech.verification.contact_problems import punch_3d, two_blocks_coulomb
from ngs_geomech.verification.contact_scenes import _compare, heated_bar_3d_pressure, heated_bar_3d_scene

pytestmark = pytest.mark.usefixtures("one_thread")


def _rel(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b))) / max(float(np.linalg.norm(b)), 1e-300)


def _compare_solvers(direct: dict, iterative: dict, label: str, u_tol: float = 1e-7) -> None:
    du, dn, dt = (_rel(iterative[k], direct[k]) for k in ("u", "lam_n", "lam_t"))
    print(f"\n{label}: {direct['ndof']} dofs; direct {direct['iterations']} Newton steps, iterative "
          f"{iterative['iterations']} with GMRES {iterative['gmres']}; relative differences u {du:.1e}, lam_n "
          f"{dn:.1e}, lam_t {dt:.1e}; stick/slip {direct['stick']}/{direct['slip']} and "
          f"{iterative['stick']}/{iterative['slip']}; force balance n {iterative['force_balance_n']:.1e}, "
          f"t {iterative['force_balance_t']:.1e}")
    assert (iterative["active"], iterative["stick"], iterative["slip"]) == (direct["active"], direct["stick"],
                                                                          direct["slip"])
    assert du < u_tol and dn < 1e-7
    if np.linalg.norm(direct["lam_t"]) > 0:
        assert dt < 1e-7
    assert iterative["force_balance_n"] < 1e-8 and iterative["force_balance_t"] < 1e-8
    assert iterative["max_penetration"] < 1e-12
    assert iterative["factorizations"] == 0 and len(iterative["gmres"]) >= iterative["iterations"]


@pytest.mark.parametrize("order,law", [(1, "coulomb"), (2, "tresca"), (1, "frictionless")])
def test_punch_3d_iterative_equals_direct(order, law):
    """The 3D punch (held by the contact alone; stick and slip zones with friction, sliding modes free without
    it): the GMRES Newton steps give the direct solves' sets and solution to the solver tolerance."""
    h = 0.2 if law != "frictionless" else 0.15
    direct = punch_3d(h, order, law=law)
    iterative = punch_3d(h, order, law=law, linear="iterative")
    # frictionless: the punch's unloaded sliding (x, y, rotation about z) is fixed by the direct solver's shift
    # (1e-10 of the stiffness) and removed from the GMRES iterates (contact.steps.free_motions); u agrees to ~1e-7
    _compare_solvers(direct, iterative, f"3D punch P{order} {law}", 1e-7 if law != "frictionless" else 1e-6)
    if law != "frictionless":
        assert direct["stick"] > 0 and direct["slip"] > 0


def test_two_blocks_2d_iterative_equals_direct():
    """The 2D Coulomb blocks (P2, non-matching, upper block floating): the same sets and solution."""
    direct = two_blocks_coulomb(0.08)
    iterative = two_blocks_coulomb(0.08, linear="iterative")
    _compare_solvers(direct, iterative, "2D Coulomb blocks P2")


def test_gmres_iterations_do_not_grow_under_refinement():
    """The augmented-Lagrangian preconditioner (augmentation E / h on every exact row) keeps the GMRES
    iterations per Newton step nearly constant when h halves (3D punch, P1, Coulomb; studies/scaling has the
    table)."""
    coarse = punch_3d(0.2, 1, law="coulomb", linear="iterative")
    fine = punch_3d(0.1, 1, law="coulomb", linear="iterative")
    print(f"\nGMRES per Newton step: h = 0.2 ({coarse['ndof']} dofs) {coarse['gmres']}; h = 0.1 "
          f"({fine['ndof']} dofs) {fine['gmres']}")
    assert max(fine["gmres"]) <= 1.3 * max(coarse["gmres"])
    assert max(fine["gmres"]) < 80


def test_scene_takes_the_iterative_contact_solver():
    """solver.linear = 'iterative' reaches the contact solver of a scene: the 3D heated bar between two rigid
    foundations (held along x by the contacts alone) keeps its closed-form pressure; 'auto' keeps this small
    scene direct."""
    p_ref, eyy = heated_bar_3d_pressure(gap=1e-4, dT=60.0, L=1.0, E=20e9, nu=0.25, alpha=1e-5)
    scene = heated_bar_3d_scene()
    scene["solver"] = {"linear": "iterative", "tolerance": 1e-11}
    out, result = _compare(scene, p_ref, eyy)
    contact = result.mechanics.solver.contact
    print(f"\n3D heated bar, iterative contact: max nodal pressure error {out['p_error']:.1e}, imbalance "
          f"{out['imbalance_rel']:.1e}, GMRES {[i.gmres_iterations for i in contact.infos]}")
    assert contact.linear == "iterative" and contact.infos[-1].gmres_iterations
    summ = out["summary"]["mechanics"]["contact"]
    assert summ["linear_solver"] == "iterative" and summ["gmres_max_per_solve"][-1] > 0
    assert out["p_error"] < 1e-8 and out["imbalance_rel"] < 1e-8
    _, auto = _compare(heated_bar_3d_scene(), p_ref, eyy)
    assert auto.mechanics.solver.contact.linear == "direct"


def test_bad_settings_and_gmres_failure():
    with pytest.raises(ValueError, match="'auto', 'direct', 'iterative' or 'condensed'"):
        ContactSolver([], modulus=1.0, linear="cg")
    with pytest.raises(ValueError, match="space"):
        ContactSolver([], modulus=1.0, linear="iterative")
    with pytest.raises(SolverError, match="GMRES did not converge in 3 iterations"):
        punch_3d(0.2, 1, law="coulomb", linear="iterative", linear_maxit=3)
