"""Linear algebra shared by the physics: watched direct solves (:mod:`.direct`), Krylov solvers and
preconditioners (:mod:`.iterative`) and the oneMKL PARDISO Schur complement (:mod:`.pardiso`)."""
