"""Direct linear solves with a finiteness check."""

from __future__ import annotations

import numpy as np

from ..errors import SolverError


def inverse(mat, freedofs, symmetric: bool):
    """Factor ``mat`` on ``freedofs``: sparse Cholesky for SPD systems, UMFPACK otherwise."""
    return mat.Inverse(freedofs, inverse="sparsecholesky" if symmetric else "umfpack")


def check_finite(vec, what: str, hint: str = "") -> None:
    """Raise SolverError when a vector holds NaN or Inf (never let NaN reach the output)."""
    a = vec.FV().NumPy()
    if not np.all(np.isfinite(a)):
        bad = int(np.count_nonzero(~np.isfinite(a)))
        raise SolverError(f"{what}: {bad} of {a.size} values are NaN or infinite. {hint}".strip())
