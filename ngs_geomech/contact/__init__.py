"""Signorini contact with Tresca and Coulomb friction, (2.24)-(2.27), (2.66): the mortar operators
(:mod:`.forms`, :mod:`.forms3d`), the laws, options and choice lists (:mod:`.laws`, :mod:`.choices`), the contact
solvers behind one interface (:mod:`.base`; :mod:`.solver` with its state :mod:`.state`, nodal rows and sets
:mod:`.active_set`, floating-body checks :mod:`.floating` and Newton-step strategies :mod:`.steps` on the
saddle-point pattern :mod:`.saddle`, :mod:`.condensed`, :mod:`.krylov`, :mod:`.uzawa`) built in one place
(:mod:`.factory`), the scene's contact setup (:mod:`.problem`) and its output (:mod:`.output`). Elasticity with
contact (the secant loop around a contact solve) is :mod:`ngs_geomech.mechanics.contact`."""
