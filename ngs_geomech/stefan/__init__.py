"""The two-phase Stefan problem in enthalpy form, problem (P_c) (2.49)-(2.58): the nodal enthalpy forms
(:mod:`.forms`), the semi-smooth Newton solver (:mod:`.solver`) and the scene's phase-change problem
(:mod:`.problem`)."""
