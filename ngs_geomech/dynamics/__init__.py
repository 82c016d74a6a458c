"""The global evolutionary model (2.6)-(2.16): inertia and viscosity forms (:mod:`.forms`), the time
integrators (:mod:`.solver`) and the scene's dynamic mechanics (:mod:`.problem`)."""
