"""Thermo-elasticity and the lambda law, problem (P) (2.17)-(2.19), (2.1)-(2.5): elastic material data
(:mod:`.materials`), the forms (:mod:`.forms`), the solvers (:mod:`.solver`; with contact :mod:`.contact`), nested
iteration (:mod:`.nested`), the scene's mechanics setup (:mod:`.problem`) and the mechanics parts of a run
(:mod:`.run`)."""
