"""Heat conduction, problem (P) (2.17), (2.20)-(2.23) and its transient form: conductivity and heat capacity
from scene materials (:mod:`.materials`), the weak forms (:mod:`.forms`), the solver (:mod:`.solver`) and the
scene's heat problem (:mod:`.problem`)."""
