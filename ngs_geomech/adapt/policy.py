"""How a run chooses and changes its mesh: the interface (:class:`MeshPolicy`) and the fixed mesh
(:class:`FixedMesh`). One class per policy:

* :class:`FixedMesh`: the scene's own mesh throughout;
* :class:`~.stationary.PreAdapted`: a transient scene on a mesh adapted once to the steady heat problem with the
  data at the start time (``[adaptivity]`` without a followed feature);
* :class:`~.stationary.StationaryAdaptive`: a stationary scene solved by the adaptive loop
  (:func:`.loop.adaptive_solve`: SOLVE (heat, then mechanics) -> ESTIMATE -> MARK -> REFINE);
* :class:`~.front_following.FrontFollowing`: meshes that follow the phase boundary of a Stefan problem;
* :class:`~.contact_following.ContactFollowing`: meshes that follow the contact zones.

The driver (:mod:`ngs_geomech.run`) calls :meth:`MeshPolicy.prepare` once, then :meth:`MeshPolicy.steady` (a
stationary scene) or :meth:`MeshPolicy.started` after the initial state and :meth:`MeshPolicy.advance` per step;
each returns the model (the parts of the scene on one mesh, :class:`ngs_geomech.run.model.Model`) to go on with,
a new one after a remesh. ``build(mesh)`` makes a model on a mesh.
"""

from __future__ import annotations


class MeshPolicy:
    """The interface of the module docstring. ``checkpoints``: whether a run on it writes checkpoints (and can
    be resumed); ``adapts_first``: whether :meth:`prepare` adapts the mesh before the run (its time is reported
    as the run's adaptivity time); ``factorizations_before``: those of the models left behind (followed
    meshes)."""

    checkpoints = True
    adapts_first = False
    serial_copy = None
    """Where rank 0 keeps the whole mesh of a distributed run (a
    :class:`~ngs_geomech.geometry.mesh.SerialCopy`, for policies that refine it; None: not kept)."""

    def __init__(self) -> None:
        self.factorizations_before = 0

    def prepare(self, model, t0: float | None):
        """The model to start on (an adapted mesh's, or ``model``); ``t0`` the start time (None: stationary)."""
        return model

    def steady(self, model, where: str):
        """Solve a stationary scene's parts."""
        model.steady(where)
        return model

    def started(self, model, t0: float, where: str):
        """After the initial state of a time-dependent run was set at t0 (s)."""
        return model

    def advance(self, model, step):
        """Advance the model over ``step`` (a :class:`~ngs_geomech.parts.Step`)."""
        model.advance(step)
        return model

    def factorizations(self, model) -> int:
        return self.factorizations_before + model.factorizations

    def summary(self) -> dict | None:
        """The summary's ``adaptivity`` block (None on a fixed mesh)."""
        return None

    def figures(self, canvas) -> None:
        """The policy's figures (the adaptive loop's convergence)."""


class FixedMesh(MeshPolicy):
    """The scene's own mesh throughout."""
