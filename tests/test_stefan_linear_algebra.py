"""The linear algebra of the Stefan solver (:class:`ngs_geomech.stefan.column_jacobian.ColumnJacobian`): solves with a
factorization kept over many Newton matrices and Sherman-Morrison-Woodbury corrections for the changed columns
agree with direct sparse solves to round-off, also with a partly factored set (mushy columns left out) and
after the rows kept of the correction vectors are outrun; a Stefan run reusing factorizations gives the same
iterations and states as one that factors at every change. The same for the window mode (Schur complement on a
window of nodes around the front, placed anew when the front leaves it), forced on the small mesh."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ngs_geomech.fem.timesteps import schedule
from ngs_geomech.stefan.column_jacobian import ColumnJacobian
from ngs_geomech.stefan.forms import StefanForms, StefanSetup
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.verification import stefan as st

# one worker for the whole module: its module-scoped fixture is computed once, not once per xdist worker
pytestmark = [pytest.mark.usefixtures("one_thread"), pytest.mark.xdist_group("test_stefan_linear_algebra")]


@pytest.fixture(scope="module")
def strip():
    p = st.TWO_PHASE
    mesh = st.strip_mesh(p.domain_length(0.5), 0.1, 0.025)
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": p.material}, dirichlet={"hot": p.t_hot, "far": p.t_cold}))
    return p, mesh, forms


def _direct(forms, jac, mc, wd, w, dt, b):
    F = jac.free
    K = forms.stiffness[0][F][:, F]
    Kd = K.diagonal()
    M = sp.diags(mc / dt + Kd * wd[:, 0]) + (K - sp.diags(Kd)) @ sp.diags(w[:, 0])
    return spla.spsolve(M.tocsc(), b)


def test_random_column_changes_match_direct_solves(strip):
    _, _, forms = strip
    jac = ColumnJacobian(forms, max_changed=30)
    nF = jac.nF
    rng = np.random.default_rng(7)
    mc = forms.mass[jac.free] * 3.0
    w = np.full((nF, 1), 1.5)
    wd = w.copy()
    worst = 0.0
    for it in range(40):
        if it:
            idx = rng.choice(nF, 4, replace=False)
            w[idx, 0] = rng.choice([0.0, 1.0, 1.5], 4)
            wd[idx, 0] = np.where(w[idx, 0] == 0.0, rng.choice([1.0, 1.5], 4), w[idx, 0])
            mc[idx] = forms.mass[jac.free][idx] * rng.choice([1.0, 3.0], 4)
        dt = 0.005 * (1 + 1e-15 * (it % 2))            # t1 - t0 of a constant schedule differs in the last bits
        b = rng.standard_normal(nF)
        x = jac.solve(mc, wd, w, b, dt, "test")
        ref = _direct(forms, jac, mc, wd, w, dt, b)
        worst = max(worst, float(np.max(np.abs(x - ref)) / np.max(np.abs(ref))))
    print(f"\n40 solves, {jac.factorizations} factorizations, {jac.corrections} correction columns, worst relative "
          f"difference to spsolve {worst:.1e}")
    assert worst < 1e-11
    assert 1 < jac.factorizations < 10


def test_partly_factored_set_and_a_moving_band(strip):
    """Mushy columns (w = 0) far from any sensible node are not factored; a front sweeping the strip outruns
    the rows kept of the correction vectors and the reference is refactored around it."""
    _, mesh, forms = strip
    jac = ColumnJacobian(forms)
    jac.BAND = 2                                       # a narrow band on this small mesh, so that it is outrun
    xs = np.array([v.point[0] for v in mesh.vertices])[jac.free]
    nF = jac.nF
    rng = np.random.default_rng(3)
    mc = forms.mass[jac.free]
    wd = np.full((nF, 1), 1.0)
    worst, sizes, banded = 0.0, [], 0
    for k in range(120):
        sensible = xs < 0.1 + 0.006 * k
        w = np.where(sensible, 1.0, 0.0)[:, None]
        b = rng.standard_normal(nF) * sensible
        x = jac.solve(mc, wd, w, b, 0.005, "test")
        ref = _direct(forms, jac, mc, wd, w, 0.005, b)
        worst = max(worst, float(np.max(np.abs(x - ref)[sensible]) / np.max(np.abs(ref[sensible]))))
        sizes.append(jac.factored_size)
        banded += jac.banded
    print(f"\nfront sweep: {jac.factorizations} factorizations, factored set {min(sizes)} .. {max(sizes)} of {nF}, "
          f"worst relative difference on the sensible nodes {worst:.1e}; {banded} solves with a band of rows")
    assert worst < 1e-11
    assert banded > 0
    assert min(sizes) < nF // 2
    assert jac.factorizations < 30


def test_reuse_gives_the_same_run_as_factoring_at_every_change(strip):
    p, _, forms = strip
    runs = []
    for max_changed in (None, 0):
        solver = StefanSolver(forms, max_changed=max_changed)
        solver.set_initial_enthalpy(st.initial_enthalpy(forms, p, 0.05))
        infos = [solver.step(a, b) for a, b in schedule(0.05, 0.2, 0.005)]
        runs.append((solver, infos))
    (reuse, ri), (fresh, fi) = runs
    print(f"\nreuse: {reuse.factorizations} factorizations, {sum(i.corrections for i in ri)} corrections; "
          f"factoring at every change: {fresh.factorizations}; max |de| {np.max(np.abs(reuse.e - fresh.e)):.1e}")
    assert [i.iterations for i in ri] == [i.iterations for i in fi]
    assert np.max(np.abs(reuse.e - fresh.e)) < 1e-10
    assert reuse.factorizations < fresh.factorizations / 5
    assert sum(i.factorizations for i in ri) == reuse.factorizations


def _windowed(jac, width=2):
    """Window mode (the Schur complement on a window around the changing columns) on a small mesh, the window's
    width fixed (not adapted to the measured costs)."""
    jac.WINDOW_MIN = 0
    jac.WINDOW = width
    jac.WINDOW_RANGE = (width, width)
    return jac


def test_window_mode_matches_direct_solves(strip):
    """Window mode: M0 factored outside a window of nodes around the last changes, the window's Schur complement
    factored per changed matrix; a front sweeping the strip leaves the window, which is placed anew around it
    (the refactor trigger), and with it the conductivity jump; mushy columns far from it are not factored."""
    _, mesh, forms = strip
    jac = _windowed(ColumnJacobian(forms))
    xs = np.array([v.point[0] for v in mesh.vertices])[jac.free]
    nF = jac.nF
    rng = np.random.default_rng(5)
    mc = forms.mass[jac.free] * rng.choice([1.0, 3.0], nF)
    wd = np.full((nF, 1), 1.0)
    worst, windowed, sizes = 0.0, 0, []
    for k in range(120):
        front = 0.1 + 0.006 * k
        sensible = xs < front
        w = np.where(sensible, np.where(xs < front - 0.03, 1.0, 1.5), 0.0)[:, None]
        b = rng.standard_normal(nF) * sensible
        x = jac.solve(mc, wd, w, b, 0.005, "test")
        ref = _direct(forms, jac, mc, wd, w, 0.005, b)
        worst = max(worst, float(np.max(np.abs(x - ref)[sensible]) / np.max(np.abs(ref[sensible]))))
        if jac.window_size is not None:
            windowed += 1
            sizes.append(jac.window_size)
    print(f"\nwindow mode, front sweep: {jac.factorizations} factorizations (placements), "
          f"{jac.window_factorizations} Schur complement factorizations, {jac.corrections} interface solves, "
          f"window {min(sizes)} .. {max(sizes)} of {nF} nodes; worst relative difference {worst:.1e}")
    assert windowed == 120
    assert worst < 1e-11
    assert 3 < jac.factorizations < 60
    assert max(sizes) <= jac.WINDOW_FRACTION * nF


def test_window_mode_gives_the_same_run_as_factoring_at_every_change(strip):
    p, _, forms = strip
    runs = []
    for window in (True, False):
        solver = StefanSolver(forms, max_changed=None if window else 0)
        if window:
            _windowed(solver.jac)
        solver.set_initial_enthalpy(st.initial_enthalpy(forms, p, 0.05))
        infos = [solver.step(a, b) for a, b in schedule(0.05, 0.2, 0.005)]
        runs.append((solver, infos))
    (win, wi), (fresh, fi) = runs
    print(f"\nwindow mode: {win.factorizations} placements, {win.jac.window_factorizations} Schur complement "
          f"factorizations, {sum(i.corrections for i in wi)} interface solves; factoring at every change: "
          f"{fresh.factorizations}; max |de| {np.max(np.abs(win.e - fresh.e)):.1e}")
    assert win.jac.window_size is not None
    assert [i.iterations for i in wi] == [i.iterations for i in fi]
    assert np.max(np.abs(win.e - fresh.e)) < 1e-10
    assert 1 < win.factorizations < fresh.factorizations / 3
    assert sum(i.factorizations for i in wi) == win.factorizations
