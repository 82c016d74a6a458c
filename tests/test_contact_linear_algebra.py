"""The linear algebra of the contact solver (ngs_geomech.contact.solver): a symmetric saddle-point matrix is
factored through its symmetric quasi-definite companion by sparse Cholesky, the refinement with the exact
residual makes the solve that of the exact system, and a non-symmetric one (Coulomb slip rows, a non-symmetric
bulk K) is factored by UMFPACK. Every case is compared with the all-UMFPACK solve (``quasi_definite=False``);
differences are printed (pytest -s)."""

from __future__ import annotations

import functools

import ngsolve as ngs
import numpy as np
import pytest

import ngs_geomech.contact.saddle as saddle
import ngs_geomech.contact.solver as sc
import ngs_geomech.contact.steps as steps
from ngs_geomech.contact.linear_algebra import is_symmetric
from ngs_geomech.verification import contact_problems as cp


class _Keep:
    """A solver factory that keeps the solver it built (for its history); the sparse direct path of the
    saddle-point factorizations these tests are about (not the condensed default)."""

    def __init__(self, **kw):
        self.kw = {"linear": "direct", **kw}
        self.solver = None

    def __call__(self, interfaces, **kw):
        self.solver = sc.ContactSolver(interfaces, **kw, **self.kw)
        return self.solver


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1e-300))


def test_hertz_quasi_definite_equals_umfpack(one_thread):
    """Frictionless, a floating cylinder: every factorization is the Cholesky one, same iterations and answer."""
    qd, umf = _Keep(), _Keep(quasi_definite=False)
    h = 0.1 * cp.R_HERTZ / 50
    r1 = cp.hertz(h, 2, solver_factory=qd, return_state=True)
    r0 = cp.hertz(h, 2, solver_factory=umf, return_state=True)
    i1, i0 = qd.solver.infos[-1], umf.solver.infos[-1]
    du = _rel(r1["state"]["u"], r0["state"]["u"])
    dp = _rel(r1["p"], r0["p"])
    print(f"\nHertz P2: u differs by {du:.1e}, lam_n by {dp:.1e}; Cholesky {i1.cholesky_factorizations} of "
          f"{i1.factorizations} factorizations, {i1.iterations} iterations (UMFPACK: {i0.factorizations}, "
          f"{i0.iterations}); wall {i1.wall_s:.3f} s vs {i0.wall_s:.3f} s")
    assert i1.iterations == i0.iterations
    assert i1.cholesky_factorizations == i1.factorizations >= 1
    assert i0.cholesky_factorizations == 0
    assert du < 1e-9 and dp < 1e-9
    assert r1["force_balance"] < 1e-8 and r1["max_penetration"] < 1e-12


@pytest.mark.parametrize("law,push,cholesky", [("tresca", "traction", "all"), ("tresca", "displacement", "all"),
                                               ("coulomb", "traction", "some"), ("coulomb", "displacement", "some")])
def test_friction_quasi_definite_equals_umfpack(one_thread, law, push, cholesky):
    """Tresca's slip rows fix lam_t alone (the companion leaves their columns out): Cholesky throughout. Coulomb's
    slip rows couple lam_t to lam_n: such a matrix has no companion and goes to UMFPACK when it is factored (the
    penalty start is symmetric; a few changed slip rows are Woodbury updates of the last factorization)."""
    qd, umf = _Keep(), _Keep(quasi_definite=False)
    r1 = cp.friction_block(push, law=law, ratio=0.5, order=2, solver_factory=qd)
    r0 = cp.friction_block(push, law=law, ratio=0.5, order=2, solver_factory=umf)
    i1 = r1["info"]
    du, dn, dt = _rel(r1["u"], r0["u"]), _rel(r1["lam_n"], r0["lam_n"]), _rel(r1["lam_t"], r0["lam_t"])
    print(f"\n{law} block, {push} push: u {du:.1e}, lam_n {dn:.1e}, lam_t {dt:.1e}; Cholesky "
          f"{i1.cholesky_factorizations} of {i1.factorizations}; {r1['stick']} stick, {r1['slip']} slip")
    assert du < 1e-9 and dn < 1e-9 and dt < 1e-9
    assert (r1["stick"], r1["slip"]) == (r0["stick"], r0["slip"])
    assert r1["slip"] > 0 or push == "traction"
    if cholesky == "all":
        assert i1.cholesky_factorizations == i1.factorizations >= 1
    else:       # the penalty start is symmetric; later slip rows are Woodbury row updates or UMFPACK
        assert i1.cholesky_factorizations >= 1


def test_weak_companion_falls_back_to_the_exact_factorization(one_thread, monkeypatch):
    """A companion far from the matrix (the exact rows' diagonal -w / (c x 1e-3): a penalty weaker than the
    body) does not converge in the refinement steps allowed: the solve factors the matrix itself (UMFPACK) and
    gives the same answer."""
    ref = cp.friction_block("traction", law="tresca", ratio=0.5, order=2,
                            solver_factory=_Keep(quasi_definite=False))
    monkeypatch.setattr(saddle, "QUASI_DEFINITE", 1e-3)
    r = cp.friction_block("traction", law="tresca", ratio=0.5, order=2, solver_factory=_Keep())
    i = r["info"]
    du = _rel(r["u"], ref["u"])
    print(f"\nweak companion: Cholesky {i.cholesky_factorizations}, all {i.factorizations} factorizations; "
          f"u differs by {du:.1e}")
    assert i.factorizations > i.cholesky_factorizations >= 1
    assert du < 1e-9


def test_symmetry_check_of_the_bulk_matrix():
    rows, cols = np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1])
    sym = ngs.la.SparseMatrixd.CreateFromCOO(rows, cols, np.array([2.0, -1.0, -1.0, 2.0]), 2, 2)
    non = ngs.la.SparseMatrixd.CreateFromCOO(rows, cols, np.array([2.0, -1.0, -0.5, 2.0]), 2, 2)
    assert is_symmetric(sym)
    assert not is_symmetric(non)


def test_non_symmetric_bulk_goes_to_umfpack(one_thread, monkeypatch):
    """With K reported non-symmetric (e.g. a tangent of a non-symmetric law) no companion is factored."""
    monkeypatch.setattr(steps, "is_symmetric", lambda matrix: False)
    keep = _Keep()
    r = cp.hertz(0.1 * cp.R_HERTZ / 50, 2, solver_factory=functools.partial(keep))
    i = keep.solver.infos[-1]
    assert i.cholesky_factorizations == 0 and i.factorizations >= 1
    assert r["force_balance"] < 1e-8


def test_companion_with_a_zero_pivot_falls_back(one_thread, monkeypatch):
    """A companion whose Cholesky solve is not finite (a zero pivot: K singular beyond the known floating bodies)
    is replaced by the UMFPACK factorization of the matrix: the answer is unchanged, nothing non-finite escapes."""
    ref = cp.friction_block("traction", law="tresca", ratio=0.5, order=2, solver_factory=_Keep(quasi_definite=False))
    real = steps.FactoredStep.apply

    def poisoned(self, r, dx):
        ok = real(self, r, dx)
        if not self.exact:
            dx.FV().NumPy()[0] = np.nan
        return ok
    monkeypatch.setattr(steps.FactoredStep, "apply", poisoned)
    r = cp.friction_block("traction", law="tresca", ratio=0.5, order=2, solver_factory=_Keep())
    i = r["info"]
    print(f"\nzero pivot: {i.cholesky_factorizations} Cholesky, {i.factorizations} factorizations")
    assert i.factorizations > i.cholesky_factorizations >= 1
    assert np.all(np.isfinite(r["u"])) and _rel(r["u"], ref["u"]) < 1e-9


def test_warm_solve_with_entering_nodes_reuses_the_companion(one_thread):
    """A warm Hertz solve at 1.5 x the load: the zone grows, so nodes enter the contact. The companion's
    factorization of the first iteration is reused with the entering nodes' rows and columns (Woodbury,
    :class:`.steps.WoodburyStep`) instead of factoring anew; the answer equals the all-UMFPACK warm solve."""
    out = {}
    for name, kw in (("qd", {}), ("umf", {"quasi_definite": False})):
        keep = _Keep(**kw)
        r = cp.hertz(0.1 * cp.R_HERTZ / 50, 2, solver_factory=keep, return_system=True)
        s = r["system"]
        u, info = keep.solver.solve(s["matrix"], 1.5 * np.asarray(s["rhs"]), s["free"], s["x0"], "warm")
        out[name] = (u, keep.solver.multipliers[0][0], info, r["ndof"])
    (u1, p1, i1, _), (u0, p0, i0, _) = out["qd"], out["umf"]
    grown = int(np.count_nonzero(p1 > 0))
    du, dp = _rel(u1, u0), _rel(p1, p0)
    print(f"\nwarm Hertz at 1.5 P: {grown} nodes in contact, {i1.iterations} iterations, {i1.factorizations} "
          f"factorizations ({i1.cholesky_factorizations} Cholesky), {i1.woodbury_columns} Woodbury columns; "
          f"u differs from UMFPACK by {du:.1e}, lam_n by {dp:.1e}")
    assert i1.iterations == i0.iterations >= 2
    assert i1.factorizations == 1 and i1.woodbury_columns > 0
    assert du < 1e-9 and dp < 1e-9


def test_failed_exact_start_is_solved_from_the_penalty_start(one_thread, monkeypatch):
    """A cold 2D solve starts with the exact constraints; when that fails (here: its first factorization is made to
    fail), the solve starts again with the penalty phase and gives the same answer."""
    ref = cp.hertz(0.1 * cp.R_HERTZ / 50, 2, solver_factory=_Keep(), return_state=True)
    real = steps.inverse
    calls = []

    def failing_once(mat, freedofs, symmetric, what="", hint=""):
        calls.append(what)
        if len(calls) == 1:
            raise sc.SolverError(f"{what}: the factorization failed (made to fail by the test)")
        return real(mat, freedofs, symmetric, what, hint)
    monkeypatch.setattr(steps, "inverse", failing_once)
    keep = _Keep()
    r = cp.hertz(0.1 * cp.R_HERTZ / 50, 2, solver_factory=keep, return_state=True)
    i = keep.solver.infos[-1]
    du = _rel(r["state"]["u"], ref["state"]["u"])
    print(f"\nexact start failed: solved from the penalty start in {i.iterations} iterations "
          f"({i.penalty_iterations} penalty); u differs by {du:.1e}")
    assert i.exact_start_failed and i.penalty_iterations > 0
    assert du < 1e-9 and r["force_balance"] < 1e-8
