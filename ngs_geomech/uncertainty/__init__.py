"""Uncertain data (the seed's conclusion: data known only in intervals): the worst-scenario (reliable solution)
search and Monte Carlo / quasi-Monte Carlo estimates over a scene's ``[uncertainty]`` table; see
:mod:`ngs_geomech.uncertainty.study`."""
