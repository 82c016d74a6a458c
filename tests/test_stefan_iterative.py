"""Serial Stefan Newton steps by GMRES (StefanSolver(linear="iterative"): the Krylov Jacobian of the distributed
path on a serial mesh, preconditioned by NGSolve's h1amg; issue 10): the same Newton iterations and states as the
direct path (SuperLU with low-rank updates) on the Neumann strips and a scene, and GMRES iterations that stay
nearly constant when h halves. Figures are printed (pytest -s)."""

from __future__ import annotations

import numpy as np
import pytest

from ngs_geomech.fem.timesteps import schedule
from ngs_geomech.run import run_scene
from ngs_geomech.scene.parse import load_scene
from ngs_geomech.stefan.forms import StefanForms, StefanSetup
from ngs_geomech.stefan.solver import StefanSolver
from ngs_geomech.verification import stefan as st

pytestmark = pytest.mark.usefixtures("one_thread")


def _strip(problem, h: float, linear: str, steps: int = 20):
    t0 = 0.5
    mesh = st.strip_mesh(problem.domain_length(1.0), 0.1, h)
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": problem.material},
                                          dirichlet={"hot": problem.t_hot, "far": problem.t_cold}))
    solver = StefanSolver(forms, linear=linear)
    solver.set_initial_enthalpy(st.initial_enthalpy(forms, problem, t0))
    dt = 0.2 * h
    for a, b in list(schedule(t0, t0 + steps * dt, dt))[:steps]:
        solver.step(a, b)
    return solver, forms


@pytest.mark.parametrize("name", ["TWO_PHASE", "ONE_PHASE"])
def test_strip_iterative_equals_direct(name):
    problem = getattr(st, name)
    direct, forms = _strip(problem, 0.025, "direct")
    iterative, _ = _strip(problem, 0.025, "iterative")
    d = float(np.max(np.abs(iterative.temperature() - direct.temperature())))
    scale = float(np.max(np.abs(direct.temperature())))
    jac = iterative.jac
    print(f"\nNeumann strip {name}: {forms.n} nodes; Newton per step {direct.iterations} / {iterative.iterations}; "
          f"max |T_iter - T_direct| / max |T| = {d / scale:.1e}; GMRES per solve {jac.krylov_iterations}; "
          f"h1amg builds {jac.factorizations}")
    assert iterative.linear == "iterative" and direct.linear == "direct"
    assert iterative.iterations == direct.iterations
    assert d <= 1e-9 * scale
    assert forms.melted_volume(iterative.e) == pytest.approx(forms.melted_volume(direct.e), rel=1e-9)
    assert jac.unconverged == 0 and max(jac.residuals) < 1e-8


def test_gmres_iterations_under_refinement():
    """h1amg: the GMRES iterations per Newton solve grow slowly when h halves (two-phase strip)."""
    counts = []
    for h in (0.025, 0.0125):
        solver, forms = _strip(st.TWO_PHASE, h, "iterative", steps=10)
        counts.append((forms.n, max(solver.jac.krylov_iterations), float(np.mean(solver.jac.krylov_iterations))))
    print(f"\nGMRES per Newton solve (nodes, max, mean): {counts}")
    assert counts[1][1] <= 1.5 * counts[0][1] + 2


def test_scene_solver_linear_reaches_the_stefan_solver():
    """melting_block (plane, 60 days, coarse) with solver.linear = 'iterative': the probes equal the direct run's."""
    runs = {}
    for linear in ("direct", "iterative"):
        scene = load_scene("melting_block", overrides=['time.end="60 day"', "mesh.maxh=0.3",
                                                       f'solver.linear="{linear}"', "output.vtk=false",
                                                       "output.figures=false"])
        runs[linear] = run_scene(scene, None, progress=False)
    a, b = runs["direct"].summary["probes"], runs["iterative"].summary["probes"]
    worst = 0.0
    for name in a:
        for key in ("final", "max", "min"):
            va, vb = a[name].get(key), b[name].get(key)
            assert (va is None) == (vb is None)
            if va is not None:
                worst = max(worst, abs(va - vb) / max(abs(va), 1e-300))
    print(f"\nmelting_block iterative vs direct: max relative probe difference {worst:.1e}")
    assert worst < 1e-8
