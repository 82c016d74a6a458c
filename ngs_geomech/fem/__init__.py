"""Finite-element building blocks shared by the physics: coefficient functions from scene data
(:mod:`.coefficients`), mortar operators of non-matching interfaces (:mod:`.mortar`) and time-step schedules
(:mod:`.timesteps`)."""
