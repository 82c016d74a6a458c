"""Signorini contact with Tresca and Coulomb friction, (2.24)-(2.27), (2.66): the mortar operators
(:mod:`.forms`, :mod:`.forms3d`), the contact solvers (:mod:`.solver`, :mod:`.condensed`, :mod:`.krylov`,
:mod:`.uzawa`), elasticity with contact (:mod:`.elastic`), the scene's contact setup (:mod:`.problem`) and its
output (:mod:`.output`)."""
