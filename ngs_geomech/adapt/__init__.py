"""Adaptive mesh refinement: a posteriori estimators and indicators (:mod:`.estimators`), marking
strategies and stopping rules (:mod:`.marking`), and the SOLVE -> ESTIMATE -> MARK -> REFINE loop for stationary
problems (:mod:`.loop`).

Imports point one way: ``marking`` uses nothing of the package; ``estimators`` reads the physics forms
(:class:`~ngs_geomech.heat.forms.HeatForms`, :class:`~ngs_geomech.mechanics.forms.ElasticForms`) and the
contact operators; ``loop`` uses both and the solvers. Nothing here builds a mesh from a geometry or writes files.
"""
