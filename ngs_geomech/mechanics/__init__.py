"""Thermo-elasticity and the lambda law, problem (P) (2.17)-(2.19), (2.1)-(2.5): elastic material data
(:mod:`.materials`), the forms (:mod:`.forms`), the solvers (:mod:`.solver`), nested iteration (:mod:`.nested`)
and the scene's mechanics setup (:mod:`.problem`)."""
