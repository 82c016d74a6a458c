"""Verification of the solvers against closed-form and manufactured solutions (see ``studies/``)."""
