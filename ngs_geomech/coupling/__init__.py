"""The coupled thermo-mechanical step of problem (P_c): deformation heating and the staggered or iterated
heat-mechanics step (:mod:`.problem`), frictional heating of sliding contacts (:mod:`.frictional`)."""
