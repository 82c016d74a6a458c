"""Direct linear solves with a finiteness check."""

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


def check_finite(vec, what: str, hint: str = "") -> None:
    """Raise SolverError when a vector holds NaN or Inf (never let NaN reach the output)."""
    a = vec.FV().NumPy()
    if not np.all(np.isfinite(a)):
        bad = int(np.count_nonzero(~np.isfinite(a)))
        raise SolverError(f"{what}: {bad} of {a.size} values are NaN or infinite. {hint}".strip())
