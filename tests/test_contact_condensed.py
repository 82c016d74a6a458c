"""The contact problem condensed onto the contact surface (solvers/contact_condensed.py) and its PARDISO Schur
factorization (solvers/pardiso.py): the same solution as the sparse direct path, the candidate set growing
when its window misses a node, warm solves with changed gaps, the fallback."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

import ngs_geomech.contact.condensed as cc
from ngs_geomech.contact.solver import ContactSolver
from ngs_geomech.errors import SolverError
from ngs_geomech.linalg import pardiso
from ngs_geomech.verification import contact_problems as cp

pytestmark = pytest.mark.skipif(not pardiso.available(), reason="oneMKL PARDISO (the mkl package) is not installed")


class _Keep:
    def __init__(self, **kw):
        self.kw, self.solver = kw, None

    def __call__(self, interfaces, **kw):
        self.solver = ContactSolver(interfaces, **kw, **self.kw)
        return self.solver


def _laplacian(nx: int, shift: float) -> sp.csr_matrix:
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(nx, nx))
    return (sp.kron(T, sp.eye(nx)) + sp.kron(sp.eye(nx), T) + shift * sp.eye(nx * nx)).tocsr()


@pytest.mark.parametrize("ordering", ["mmd", "metis"])
def test_schur_factorization_against_dense_algebra(ordering):
    """S, the reduced right-hand side and the interior solve against dense formulas; a singular A whose kernel
    the Schur set holds (the floating body's case); a plain solve; refactoring new values; bad input named."""
    rng = np.random.default_rng(1)
    for shift in (0.01, 0.0):              # shift 0: the Neumann Laplacian, singular (constants), held by s
        A = _laplacian(12, shift)
        if shift == 0.0:                   # the pure Neumann operator: zero row sums
            A = (A - sp.diags(np.asarray(A.sum(axis=1)).ravel())).tocsr()
        n = A.shape[0]
        s = np.sort(rng.choice(n, 9, replace=False))
        i = np.setdiff1d(np.arange(n), s)
        F = pardiso.SchurFactorization(A, s, ordering=ordering, threads=1)
        D = A.toarray()
        S = D[np.ix_(s, s)] - D[np.ix_(s, i)] @ np.linalg.solve(D[np.ix_(i, i)], D[np.ix_(i, s)])
        b = rng.standard_normal(n)
        y, work = F.reduce(b)
        y_ref = b[s] - D[np.ix_(s, i)] @ np.linalg.solve(D[np.ix_(i, i)], b[i])
        x_s = rng.standard_normal(len(s))
        x = F.expand(work, x_s)
        x_ref = np.linalg.solve(D[np.ix_(i, i)], b[i] - D[np.ix_(i, s)] @ x_s)
        errs = (np.abs(F.S - S).max() / np.abs(S).max(), np.abs(y - y_ref).max() / np.abs(y_ref).max(),
                np.abs(x[i] - x_ref).max() / np.abs(x_ref).max())
        print(f"\n{ordering}, shift {shift}: S {errs[0]:.1e}, reduced rhs {errs[1]:.1e}, interior {errs[2]:.1e}")
        assert max(errs) < 1e-12 and np.array_equal(x[s], x_s)
        if shift:
            F.factor(2.0 * A)                       # new values, same pattern: the numeric phase only
            assert np.abs(F.S - 2.0 * S).max() < 1e-12 * np.abs(S).max()
            with pytest.raises(ValueError, match="sparsity pattern"):
                F.factor(A + sp.eye(n, k=3))
        F.close()
    P = pardiso.SchurFactorization(_laplacian(10, 0.1), ordering=ordering, threads=1)
    b = rng.standard_normal(100)
    assert np.abs(_laplacian(10, 0.1) @ P.solve(b) - b).max() < 1e-12
    with pytest.raises(SolverError, match="zero pivot"):         # not definite: named, never garbage
        pardiso.SchurFactorization(-_laplacian(6, 0.1), threads=1, what="the test's matrix")


def _compare(run):
    cond, direct = _Keep(linear="condensed"), _Keep(linear="direct")
    r1, r0 = run(cond), run(direct)
    return r1, r0, cond.solver, direct.solver


def test_hertz_condensed_equals_direct(one_thread):
    """P2 Hertz (floating cylinder): the condensed solve has the sparse path's contact set and multipliers and one
    factorization, and its surface is a small part of the dofs."""
    a = cp.R_HERTZ / 50

    def run(factory):
        return cp.hertz(a / 5 / 2, 2, maxh=cp.R_HERTZ / 8, solver_factory=factory, return_state=True)
    r1, r0, s1, s0 = _compare(run)
    i1, i0 = s1.infos[-1], s0.infos[-1]
    lam1, lam0 = s1.multipliers[0][0], s0.multipliers[0][0]
    u1, u0 = r1["state"]["u"], r0["state"]["u"]
    du = float(np.abs(u1 - u0).max() / np.abs(u0).max())
    dl = float(np.abs(lam1 - lam0).max() / np.abs(lam0).max())
    print(f"\nHertz P2 {r1['ndof']} dofs: condensed {i1.condensed_dofs} dofs, {i1.iterations} iterations, "
          f"{i1.factorizations} factorization ({i1.wall_s:.2f} s); direct {i0.iterations} / {i0.factorizations} "
          f"({i0.wall_s:.2f} s); u differs by {du:.1e}, lam_n by {dl:.1e}")
    assert i1.condensed_dofs > 0 and not i1.condensed_fallback and i1.candidate_passes == 1
    assert i1.factorizations == 1 and i1.condensed_dofs < 0.2 * r1["ndof"]
    assert np.array_equal(lam1 > 0, lam0 > 0)
    assert du < 1e-8 and dl < 1e-8
    assert r1["p0_rel_error"] == pytest.approx(r0["p0_rel_error"], abs=1e-9)
    assert r1["max_penetration"] < 1e-12 and r1["force_balance"] < 1e-10


def test_coulomb_blocks_condensed_equals_direct(one_thread):
    """Two elastic blocks with Coulomb friction (stick and slip zones, the upper one held by contact only)."""
    r1, r0, s1, s0 = _compare(lambda f: cp.two_blocks_coulomb(0.08, 2, solver_factory=f))
    (ln1, lt1), (ln0, lt0) = s1.multipliers[0], s0.multipliers[0]
    i1 = s1.infos[-1]
    dn = float(np.abs(ln1 - ln0).max() / np.abs(ln0).max())
    dt = float(np.abs(lt1 - lt0).max() / np.abs(lt0).max())
    print(f"\nCoulomb blocks: stick/slip {r1['stick']}/{r1['slip']} (direct {r0['stick']}/{r0['slip']}), "
          f"condensed {i1.condensed_dofs} of {r1['ndof']} dofs; lam_n differs by {dn:.1e}, lam_t by {dt:.1e}")
    assert not i1.condensed_fallback and r1["stick"] > 0 and r1["slip"] > 0
    assert (r1["stick"], r1["slip"]) == (r0["stick"], r0["slip"])
    assert dn < 1e-8 and dt < 1e-8
    assert r1["force_balance_n"] < 1e-10 and r1["force_balance_t"] < 1e-10


def test_a_window_that_misses_nodes_grows_the_candidate_set(one_thread, monkeypatch):
    """A gap window far too small (1e-7 of the extent: only the first-touch nodes): the solution penetrates at
    nodes outside it, the set grows from the deformed gaps and the second pass solves the whole problem."""
    monkeypatch.setattr(cc, "CANDIDATE_GAP", 1e-7)
    a = cp.R_HERTZ / 50
    small, ref = _Keep(linear="condensed"), _Keep(linear="direct")
    cp.hertz(a / 5, 2, maxh=cp.R_HERTZ / 4, solver_factory=small)
    cp.hertz(a / 5, 2, maxh=cp.R_HERTZ / 4, solver_factory=ref)
    info = small.solver.infos[-1]
    lam1, lam0 = small.solver.multipliers[0][0], ref.solver.multipliers[0][0]
    print(f"\nwindow 1e-7: {info.candidate_passes} passes, {info.factorizations} factorizations, "
          f"{info.condensed_dofs} condensed dofs, lam_n differs by {np.abs(lam1 - lam0).max() / lam0.max():.1e}")
    assert info.candidate_passes >= 2 and not info.condensed_fallback
    assert np.abs(lam1 - lam0).max() < 1e-8 * lam0.max()


def test_warm_solves_and_changed_gaps(one_thread):
    """The same solver again: a larger load (warm: the factorization and the sets kept), then the gaps of
    another step (an initial gap everywhere: the block lifted by 1e-5 m), each equal to a fresh direct solve."""
    keep = _Keep(linear="condensed")
    res = cp.hertz(cp.R_HERTZ / 250, 2, maxh=cp.R_HERTZ / 4, solver_factory=keep, return_system=True,
                   return_state=True)
    system, op = res["system"], res["state"]["op"]
    solver = keep.solver
    K, f, free, x0 = system["matrix"], np.asarray(system["rhs"]), system["free"], system["x0"]
    for step, (scale, lift) in enumerate(((1.3, 0.0), (1.3, 1e-5))):
        op.g0[:] = op.g0 + lift * op.weight            # a uniform extra gap of ``lift`` m
        u1, i1 = solver.solve(K, scale * f, free, x0, f"warm {step}")
        ref = ContactSolver([(op, solver.items[0][1])], modulus=solver.modulus, floating=solver.floating,
                            linear="direct")
        u0, _ = ref.solve(K, scale * f, free, x0, "reference")
        d = float(np.abs(u1 - u0).max() / np.abs(u0).max())
        print(f"\nwarm solve {step}: {i1.iterations} iterations, {i1.factorizations} factorizations, u differs by "
              f"{d:.1e}")
        assert d < 1e-8 and not i1.condensed_fallback
        assert i1.factorizations == 0      # the same K: its factorization is reused


def test_fallback_to_the_sparse_path(one_thread, monkeypatch):
    """What the condensed path cannot take (here: PARDISO made to fail) is solved by the sparse direct path,
    and the history says so."""
    def failing(*args, **kw):
        raise SolverError("made to fail by the test")
    monkeypatch.setattr(pardiso, "SchurFactorization", failing)
    cond = _Keep(linear="condensed")
    r1 = cp.friction_block("traction", law="coulomb", ratio=0.75, order=2, solver_factory=cond)
    r0 = cp.friction_block("traction", law="coulomb", ratio=0.75, order=2, solver_factory=_Keep(linear="direct"))
    info = cond.solver.infos[-1]
    assert info.condensed_fallback and info.condensed_dofs == 0
    assert np.abs(r1["u"] - r0["u"]).max() <= 1e-12 * np.abs(r0["u"]).max()


def test_auto_picks_the_condensed_solver_in_2d_only(monkeypatch):
    assert ContactSolver([], modulus=1.0).linear == "condensed"
    assert ContactSolver([], modulus=1.0, linear="direct").linear == "direct"
    assert ContactSolver([(SimpleNamespace(Bt2=sp.eye(1)), None)], modulus=1.0).linear == "direct"     # 3D
    monkeypatch.setattr(pardiso, "available", lambda: False)
    assert ContactSolver([], modulus=1.0).linear == "direct"
    with pytest.raises(ValueError, match="mkl"):
        ContactSolver([], modulus=1.0, linear="condensed")
