"""Validation of a scene before any expensive work (:func:`.validate.validate`): every problem collected and
reported together, each naming its key, region, boundary or value: the declared ranges and names
(:mod:`.check_values`), the settings and their combinations (:mod:`.check_settings`, :mod:`.check_adaptivity`),
the material data (:mod:`.check_materials`), the geometry and its names (:mod:`.check_geometry`), the
expressions' values at sample points (:mod:`.expression_values`) and what a distributed run cannot do
(:mod:`.check_distributed`)."""
