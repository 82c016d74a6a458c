"""The choice lists of contact: laws, methods and the Newton steps' linear algebra, declared once (the scene's keys
and the solvers' options validate against them). No imports: the scene model reads them without loading the
solvers."""

LAWS = ("frictionless", "tresca", "coulomb")
"""Contact laws: Signorini without friction, Tresca (given slip bound g_c), Coulomb (slip bound F_c p)."""
METHODS = ("ssn", "penalty", "uzawa")
"""Contact methods: the semi-smooth Newton (active set) iteration, its penalty rows kept to the end, Uzawa's
algorithm (the seed's reference method for friction)."""
LINEAR_SOLVERS = ("auto", "direct", "iterative", "condensed")
"""The Newton steps' linear algebra: "auto" (condensed in 2D with PARDISO, else direct), sparse direct
factorizations, GMRES (Krylov), the problem condensed onto the contact surface."""
