"""The choice lists of the linear solvers of the heat and elasticity systems, declared once (the scene's
``[solver]`` keys and the solvers' arguments validate against them). No imports: the scene model reads them without
loading the solvers."""

SOLVERS = ("auto", "direct", "iterative")
"""Values of the ``solver`` argument of :class:`~ngs_geomech.heat.solver.HeatSolver` and
:class:`~ngs_geomech.mechanics.solver.ElasticSolver` (and of the scene key ``solver.linear``): sparse direct
factorizations, preconditioned CG, or the choice by size of :func:`~ngs_geomech.linalg.iterative.choose_solver`."""

PRECONDITIONERS = ("auto", "bddc", "gamg")
"""Values of their ``preconditioner`` argument (and of ``solver.preconditioner``): "auto" the choice of
:mod:`ngs_geomech.linalg.iterative` (on a distributed mesh "gamg" when petsc4py is installed, else "bddc"), "bddc"
NGSolve's BDDC with the vertex wirebasket and its vertex problem factored directly for every order >= 2 (the serial
default before the two-level preconditioner, kept for comparison: ``studies/scaling``), "gamg" PETSc's CG with
algebraic multigrid and the rigid-body near-null space (:mod:`ngs_geomech.linalg.petsc`, needs petsc4py)."""
