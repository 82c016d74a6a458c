"""Direct solves watch their residual (issue 8 section 3, :func:`ngs_geomech.linalg.direct.solve_watched`):
a factorization that does not solve its system (here: of a perturbed matrix, as an ill-conditioned system
effectively is) is refined with its own residual, and a solve whose residual stays large stops with a
SolverError naming the solve instead of passing a wrong state on."""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import pytest
from netgen.geom2d import unit_square

from ngs_geomech.errors import SolverError
from ngs_geomech.linalg.direct import RESIDUAL_TOL, solve_watched

pytestmark = pytest.mark.usefixtures("one_thread")


def _laplace(scale: float = 1.0):
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.2))
    V = ngs.H1(mesh, order=1, dirichlet="left|bottom")
    u, v = V.TnT()
    a = ngs.BilinearForm(V)
    a += (1.0 + scale * ngs.x) * ngs.grad(u) * ngs.grad(v) * ngs.dx
    a.Assemble()
    f = ngs.LinearForm(V)
    f += v * ngs.dx
    f.Assemble()
    return V, a, f


def test_refinement_repairs_a_slightly_wrong_factorization():
    V, a, f = _laplace()
    _, a2, _ = _laplace(scale=1.01)                 # 1 % off: the refinement contracts by about 1e-2 per step
    x = ngs.GridFunction(V).vec
    free = np.array(list(V.FreeDofs()), dtype=bool)
    rel = solve_watched(a.mat, a2.mat.Inverse(V.FreeDofs()), f.vec, x, free, "test solve", maxit=8)
    exact = ngs.GridFunction(V).vec
    exact.data = a.mat.Inverse(V.FreeDofs()) * f.vec
    err = float(np.max(np.abs(x.FV().NumPy() - exact.FV().NumPy())) / np.max(np.abs(exact.FV().NumPy())))
    print(f"\nrefined: relative residual {rel:.1e}, error {err:.1e}")
    assert rel <= RESIDUAL_TOL and err < 1e-8


def test_a_solve_whose_residual_stays_large_stops_by_name():
    V, a, f = _laplace()
    _, a2, _ = _laplace(scale=30.0)                 # far off: the refinement diverges or stalls
    x = ngs.GridFunction(V).vec
    free = np.array(list(V.FreeDofs()), dtype=bool)
    with pytest.raises(SolverError, match=r"heat solve at step 7: the direct solve leaves a relative residual .* "
                                          r"after 2 refinement steps .*Check the data"):
        solve_watched(a.mat, a2.mat.Inverse(V.FreeDofs()), f.vec, x, free, "heat solve at step 7",
                      "Check the data.", maxit=2)
