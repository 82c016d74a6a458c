"""Direct linear solves watched: a finiteness check and the residual after the solve (iterative refinement when
the factorization left a large one; a SolverError naming the solve when refinement does not bring it down)."""

from __future__ import annotations

import numpy as np

from ..errors import SolverError


def inverse(mat, freedofs, symmetric: bool, what: str = "linear solve", hint: str = ""):
    """Factor ``mat`` on ``freedofs``: sparse Cholesky for SPD systems, UMFPACK otherwise. A failed
    factorization (singular matrix) raises SolverError naming ``what``, never an NGSolve exception."""
    try:
        return mat.Inverse(freedofs, inverse="sparsecholesky" if symmetric else "umfpack")
    except Exception as exc:  # NgException from the direct solver
        raise SolverError(f"{what}: the factorization failed ({exc}). The matrix is singular: "
                          f"{hint or 'check the boundary conditions and material data.'}") from None


def not_finite(vec) -> int:
    """The number of NaN or infinite entries of a vector (summed over the ranks of a distributed vector, so that
    every rank sees the same count)."""
    bad = int(np.count_nonzero(~np.isfinite(vec.FV().NumPy())))
    if vec.comm is not None and vec.comm.size > 1:
        bad = int(vec.comm.Sum(bad))
    return bad


def check_finite(vec, what: str, hint: str = "") -> None:
    """Raise SolverError when a vector holds NaN or Inf (never let NaN reach the output)."""
    bad = not_finite(vec)
    if bad:
        raise SolverError(f"{what}: {bad} values are NaN or infinite. {hint}".strip())


RESIDUAL_TOL = 1e-10
"""Relative residual below which a direct solve is accepted without refinement."""
RESIDUAL_FAIL = 1e-6
"""Relative residual above which a solve stops the run (after refinement)."""


def solve_watched(mat, inv, rhs, x, freedofs, what: str, hint: str = "", maxit: int = 3) -> float:
    """Solve: x += inv (rhs - mat x), then refine while the relative residual ||(rhs - mat x)_free|| /
    (||rhs_free|| + ||mat x|| + ||first residual||) exceeds RESIDUAL_TOL (at most ``maxit`` refinements; they
    reuse the factorization). Returns the final relative residual; raises SolverError naming ``what`` when it
    stays above RESIDUAL_FAIL (an ill-conditioned or nearly singular system: stiffness contrasts,
    near-incompressibility, tiny time steps) or when the solution is not finite."""
    free = np.asarray(list(freedofs), dtype=bool) if not isinstance(freedofs, np.ndarray) else freedofs
    r = rhs.CreateVector()
    ax = rhs.CreateVector()
    rel = np.inf
    r0 = 0.0
    for k in range(maxit + 1):
        ax.data = mat * x
        r.data = rhs - ax
        ra = r.FV().NumPy()
        if k == 0:
            r0 = float(np.linalg.norm(ra[free]))
        # the forces the residual is measured against: the load, the matrix times the solution and the first
        # residual (the load the solve had to balance: a uniform temperature gives mat x = 0 and rhs = 0)
        scale = float(np.linalg.norm(rhs.FV().NumPy()[free])) + float(np.linalg.norm(ax.FV().NumPy())) + r0
        rel = float(np.linalg.norm(ra[free])) / max(scale, 1e-300) if k else np.inf
        if rel <= RESIDUAL_TOL or k == maxit:
            break
        ra[~free] = 0.0
        x.data += inv * r
        check_finite(x, what, hint)
    if not rel <= RESIDUAL_FAIL:
        raise SolverError(f"{what}: the direct solve leaves a relative residual {rel:.1e} after {maxit} refinement "
                          f"steps (the system is nearly singular or badly scaled). {hint}".strip())
    return rel
