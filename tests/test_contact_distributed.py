"""The linear algebra of distributed contact solves (:mod:`ngs_geomech.contact.distributed`) on one process: the
3D punch of :func:`~ngs_geomech.verification.contact_problems.punch_3d` with its bulk K handed to the solver as a
:class:`DistributedBulk` (PETSc's GMRES with the augmented-Lagrangian GAMG preconditioner on the saddle-point
systems) takes the Newton iterations of the direct solves and reaches their solution: displacements and
multipliers to 1e-9 (relative) for Tresca and Coulomb friction; frictionless, where nothing holds the punch's
sliding, the multipliers to 1e-9 and the displacement to the serial Krylov path's (both fix the free motion by
projection, the direct solves by a shift)."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.contact.distributed import DistributedBulk
from ngs_geomech.contact.solver import ContactSolver
from ngs_geomech.linalg import petsc
from ngs_geomech.parallel import GlobalDofs
from ngs_geomech.verification import contact_problems as cp

pytestmark = [pytest.mark.usefixtures("one_thread"),
              pytest.mark.skipif(not petsc.available(), reason="petsc4py not installed (extra 'petsc')")]


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(float(np.max(np.abs(b))), 1e-300))


@pytest.fixture
def distributed_bulk(monkeypatch):
    """Hand every contact solve its K as a DistributedBulk (serial numbering: one process)."""
    solve = ContactSolver.solve

    def wrapped(self, matrix, rhs, free, x0, where=""):
        return solve(self, DistributedBulk(matrix, GlobalDofs(self.forms.V)), rhs, free, x0, where)

    return lambda: monkeypatch.setattr(ContactSolver, "solve", wrapped)


@pytest.mark.parametrize("law,order", [("frictionless", 1), ("tresca", 1), ("coulomb", 1), ("coulomb", 2)])
def test_petsc_steps_reach_the_direct_solution(distributed_bulk, law, order):
    h = 0.2 if order == 1 else 0.3
    ref = cp.punch_3d(h, order, law=law, linear="direct")
    krylov = cp.punch_3d(h, order, law=law, linear="iterative", linear_tol=1e-12)
    distributed_bulk()
    got = cp.punch_3d(h, order, law=law, linear="iterative", linear_tol=1e-12)
    du, dn = _rel(got["u"], ref["u"]), _rel(got["lam_n"], ref["lam_n"])
    dt = _rel(got["lam_t"], ref["lam_t"]) if law != "frictionless" else 0.0
    print(f"\n{law} P{order} {got['ndof']} dofs: Newton iterations {got['iterations']} (direct {ref['iterations']}), "
          f"GMRES {got['gmres']}; relative difference to direct u {du:.1e}, lam_n {dn:.1e}, lam_t {dt:.1e}; "
          f"u to the serial Krylov path {_rel(got['u'], krylov['u']):.1e}")
    assert got["iterations"] == ref["iterations"]
    assert dn < 1e-9 and dt < 1e-9
    if law == "frictionless":
        assert _rel(got["u"], krylov["u"]) < 1e-9
    else:
        assert du < 1e-9
    assert got["force_balance_n"] < 1e-8
