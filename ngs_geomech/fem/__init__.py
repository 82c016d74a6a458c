"""Finite-element building blocks shared by the physics: coefficient functions from scene data
(:mod:`.coefficients`), mortar operators of non-matching interfaces (:mod:`.mortar`), outward normals on boundaries
(:mod:`.normals`) and time-step schedules (:mod:`.timesteps`)."""
