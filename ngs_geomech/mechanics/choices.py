"""The choice lists of the elastic problem, declared once (the scene's ``[mechanics]`` keys and the forms' and
solvers' arguments validate against them). No imports: the scene model reads them without loading the forms."""

FORMULATIONS = ("auto", "displacement", "mixed")
"""The unknowns of elasticity: "displacement", "mixed" (displacement-pressure, for Poisson ratios near 1/2) or
"auto" (mixed in the isotropic regions with nu > 0.45 when the law is linear)."""

NONLINEAR_SOLVERS = ("newton", "secant")
"""The iteration of the lambda law (2.1)-(2.5): Newton on the energy W (with line search) or the secant modules
method (2.32)-(2.34)."""
