"""The contact laws of an interface (:class:`ContactLaw`, the Coulomb bound :func:`slip_bound`) and the options of
the contact solvers (:class:`ContactOptions`), validated against the choice lists of :mod:`.choices`.

Units: slip bounds and pressures Pa, augmentation Pa/m, friction coefficient dimensionless."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .choices import LAWS, LINEAR_SOLVERS, METHODS


def slip_bound(friction: float, lam_n: np.ndarray) -> np.ndarray:
    """The Coulomb slip bound F_c max(lam_n, 0) (Pa) of the normal pressures ``lam_n`` (Pa): no friction where
    the node is open (lam_n <= 0)."""
    return friction * np.maximum(lam_n, 0.0)


@dataclass
class ContactLaw:
    """The law of one interface: ``kind`` in :data:`LAWS`; ``slip_bound`` g_c per node (Pa, Tresca);
    ``friction`` F_c (Coulomb: one number, or one per node); ``augmentation`` c (Pa/m, None: E_max / nodal
    size); ``penalty``: this interface keeps the penalty rows (lam_n = c x penetration, lam_t = c_t x stick
    slip) to the end instead of switching to exact constraints (the whole solve is penalty with
    ContactSolver(method="penalty"))."""

    kind: str = "frictionless"
    slip_bound: np.ndarray | float | None = None
    friction: np.ndarray | float = 0.0
    augmentation: float | None = None
    penalty: bool = False

    def __post_init__(self):
        if self.kind not in LAWS:
            raise ValueError(f"unknown contact law {self.kind!r}; choose one of {', '.join(LAWS)}")
        if self.kind == "tresca" and self.slip_bound is None:
            raise ValueError("Tresca friction needs a slip bound g_c (Pa)")
        if self.kind == "coulomb":
            F = np.asarray(self.friction, dtype=float)
            if not (np.all(np.isfinite(F)) and np.all(F >= 0) and np.any(F > 0)):
                raise ValueError(f"Coulomb friction needs a positive coefficient (one per node: >= 0 at every node, "
                                 f"positive at some), got {self.friction}")
        if self.kind == "tresca":
            g = np.asarray(self.slip_bound, dtype=float)
            if not np.all(np.isfinite(g)) or np.any(g < 0):
                raise ValueError(f"the Tresca slip bound g_c must be finite and >= 0 (Pa), got {self.slip_bound}")
        if self.augmentation is not None and not (self.augmentation > 0 and np.isfinite(self.augmentation)):
            raise ValueError(f"the augmentation c must be positive (Pa/m), got {self.augmentation}")


@dataclass(frozen=True)
class ContactOptions:
    """How a contact solver iterates and solves its Newton steps (:func:`.factory.build_contact_solver`).

    ``method``: one of :data:`METHODS` ("uzawa" selects :class:`.uzawa.UzawaSolver`, the others
    :class:`.solver.ContactSolver`; "penalty" keeps the penalty rows of every interface to the end); ``maxit``:
    active-set iterations per solve; ``linear``: one of :data:`LINEAR_SOLVERS`, with ``linear_tol`` and
    ``linear_maxit`` for GMRES; ``reuse_rows``: the most changed rows needing new solves for which an old
    factorization is reused (Woodbury), -1: always factor; ``quasi_definite``: factor the symmetric quasi-definite
    companion of a symmetric saddle-point matrix by sparse Cholesky (False: always UMFPACK); ``check_solvable``:
    check the floating bodies' load before the solve; ``uzawa_step``: Uzawa's rho (Pa/m), one or one per interface
    (None: the default); ``uzawa_max_steps``: its outer steps; ``uzawa_settings``: the names of the step and
    step-limit settings its non-convergence error advises to change."""

    method: str = "ssn"
    maxit: int = 50
    linear: str = "auto"
    linear_tol: float | None = None
    linear_maxit: int = 3000
    reuse_rows: int = 12
    quasi_definite: bool = True
    check_solvable: bool = True
    uzawa_step: float | list | None = None
    uzawa_max_steps: int = 1000
    uzawa_settings: tuple = field(default=("rho", "maxit"))

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown contact method {self.method!r}; choose one of {', '.join(METHODS)}")
        if self.linear not in LINEAR_SOLVERS:
            raise ValueError("the contact solver's linear solver must be "
                             + ", ".join(f"'{k}'" for k in LINEAR_SOLVERS[:-1])
                             + f" or '{LINEAR_SOLVERS[-1]}', got {self.linear!r}")
