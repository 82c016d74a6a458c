"""The coupled thermo-mechanical time step of problem (P_c), seed (2.49), (2.53), (2.55), (2.58): the heat
(Stefan) step with the deformation heating as a source, then the (contact) mechanics step with the thermal
stress of the new temperature, optionally repeated within the step until neither changes.

Deformation heating. (2.49) reads dH/dt + rho beta_ij Theta_0 e_ij(u_t) = div(k grad T) + W; with the thermal
stress coefficients beta_ij of the stress law (2.18) in Pa/K (the seed's rho beta_ij, beta per unit mass) the
term is the thermoelastic heat

    Q_def = -Theta_0 beta_ij e_ij(u_t)    (W/m^3),

Theta_0 the absolute reference temperature (K: the stress-free temperature of the material, plus 273.15 in a
scene in degC; where the stress-free temperature or beta vary, the source takes their fields). Compression
(tr e(u_t) < 0 for isotropic beta) heats, expansion cools. In the reduced 2D models beta and e are the model's
reduced Voigt vectors (plane strain: e_zz = 0; plane stress: the in-plane conjugate of the reduced thermal stress;
axisymmetric: with the hoop strain).

Time stepping (per step t_n -> t_n+1, the seed's splitting):
  'staggered': the heat step takes u_t = (u^n - u^(n-1)) / dt_n, the rate of the previous step (zero in the
  first), then the mechanics step at t_n+1 with the new temperature. One heat and one mechanics solve per step;
  the lag makes the deformation heating first order in dt.
  'iterated': the pair is repeated within the step with u_t = (u^(n+1,k) - u^n) / dt_n+1 from the last
  mechanics iterate until the temperature and the displacement change by less than ``tolerance`` (relative to
  their ranges), at most ``max_iterations`` times; this removes the lag (the backward Euler step of the fully
  coupled system).

This module holds the source and the bookkeeping (no meshes, no files); the run loop (:mod:`ngs_geomech.run`)
calls it.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import SolverError

KELVIN = 273.15


class DeformationHeating:
    """The source Q_def = -Theta_0 beta . e(u_t) (module docstring) of an elastic problem (``mech_forms``,
    :class:`ngs_geomech.mechanics.forms.ElasticForms`), against the test function ``v`` of a heat space
    ``space`` with the volume measure ``dx`` and weight ``weight`` (2 pi r-free: r in axisymmetric heat forms).
    ``offset`` is added to the materials' stress-free temperatures to make Theta_0 absolute (273.15 for degC;
    varying data: checked positive at the smallest sampled T0);
    ``extra`` (a CoefficientFunction, W/m^3, or None) is added to the source: the viscous dissipation density.

    The displacement rate is held in :attr:`rate` (a GridFunction of the displacement space, m/s)."""

    def __init__(self, mech_forms, space, v, dx, weight=1.0, offset: float = 0.0, extra=None):
        self.mech = mech_forms
        V = mech_forms.V
        self.rate = ngs.GridFunction(V)
        self.u_prev = ngs.GridFunction(V)           # u^n: the displacement at the start of the step
        self.theta0 = {}
        for name, props in mech_forms.setup.props.items():
            th0 = float(props.T0) + offset
            if not th0 > 0:
                raise ValueError(f"deformation heating: the absolute reference temperature of region {name!r} is "
                                 f"{th0:g} K (stress-free temperature {props.T0:g} + {offset:g}); it must be > 0 K "
                                 "(a scene in degC needs temperature_unit = 'C')")
            self.theta0[name] = th0
        self.source = self._source(mech_forms.strain_vector(self.rate), offset, extra)
        """Q_def (plus ``extra``), W/m^3."""
        self.field = (self._source(mech_forms.strain_vector(self.rate, on_axis=True), offset, extra)
                      if mech_forms.setup.model == "axisymmetric" else self.source)
        """Q_def for output at points (axisymmetric: finite on the axis, :meth:`ElasticForms.strain_vector`)."""
        self.space = space
        self.lf = ngs.LinearForm(space)
        self.lf += weight * self.source * v * dx
        self._zero = True
        self._owned = None                     # distributed meshes: the dofs this rank owns (power), once

    def _source(self, e, offset: float, extra):
        """-Theta_0 beta . e per region (plus ``extra``), W/m^3, for the strain-rate vector ``e``."""
        mf = self.mech
        terms = {}
        for name, props in mf.setup.props.items():
            b = mf.b[name]
            if props.varying is not None:      # Theta_0(x) and beta(x): the smallest T0 was checked
                terms[name] = -(mf.T0[name] + offset) * ngs.InnerProduct(mf.cf_vector(b), e)
                continue
            terms[name] = -self.theta0[name] * ngs.InnerProduct(ngs.CoefficientFunction(tuple(float(x) for x in b)),
                                                                e)
        source = mf.mesh.MaterialCF(terms, default=0.0)
        return source if extra is None else source + extra     # e.g. the viscous dissipation of dynamic mechanics

    def start_step(self) -> None:
        """Remember u^n (the displacement at the start of the step)."""
        self.u_prev.vec.data = self.mech.displacement().vec

    def set_rate(self, dt: float) -> None:
        """u_t = (u - u^n) / dt from the current displacement (m/s)."""
        u = self.mech.displacement()
        self.rate.vec.data = (1.0 / dt) * (u.vec - self.u_prev.vec)
        self._zero = False

    def vector(self):
        """The assembled source vector over ``space`` (NGSolve vector; W per metre of depth in 2D, W in 3D)."""
        self.lf.Assemble()
        if parallel.anyof(self.space.mesh, not np.all(np.isfinite(self.lf.vec.FV().NumPy()))):
            raise SolverError("deformation heating: the source is not finite (the displacement rate is NaN or "
                              "infinite); check the mechanics of the previous step")
        return self.lf.vec

    def load(self) -> np.ndarray:
        """:meth:`vector` as a numpy copy (zeros while the rate is zero); on a distributed mesh cumulated (every
        copy of a shared dof holds its whole value: what the Stefan solver's nodal loads are)."""
        if self._zero:
            return np.zeros(self.space.ndof)
        vec = self.vector()
        if not parallel.distributed(self.space.mesh):
            return vec.FV().NumPy().copy()
        tmp = vec.CreateVector()
        tmp.data = vec
        tmp.Cumulate()
        return tmp.FV().NumPy().copy()

    def power(self) -> float:
        """The total deformation-heating power of the last :meth:`vector` (W per metre of depth in 2D, W in 3D),
        summed over all ranks of a distributed mesh."""
        if self._zero:
            return 0.0
        vec = self.lf.vec
        arr = vec.FV().NumPy()
        if not parallel.distributed(self.space.mesh):
            return float(np.sum(arr))
        # a solve that added the vector to its right-hand side may have cumulated it (NGSolve changes the parallel
        # status of operands): then each shared dof is counted by its owner only
        if vec.GetParallelStatus() == ngs.la.PARALLEL_STATUS.CUMULATED:
            if self._owned is None:
                self._owned = parallel.owned(self.space)
            arr = arr[self._owned]
        return float(parallel.allsum(self.space.mesh, float(np.sum(arr))))

    def capture(self) -> dict:
        return {"coupling/rate": np.array(self.rate.vec.FV().NumPy())}

    def restore(self, arrays: dict) -> None:
        self.rate.vec.FV().NumPy()[:] = arrays["coupling/rate"]
        if parallel.distributed(self.space.mesh):               # every copy of a shared dof holds the value
            self.rate.vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)
        # the same on every rank of a distributed mesh (a zero rate skips collective assembly)
        self._zero = not parallel.anyof(self.space.mesh, bool(np.any(arrays["coupling/rate"])))


def relative_change(new: np.ndarray, old: np.ndarray, mesh=None) -> float:
    """Max |new - old| / max(range of new, 1e-3 max |new|, tiny): relative to the field's variation, or to its
    size when it is (nearly) uniform. ``mesh`` (distributed): the arrays are this rank's part, the maxima global."""
    some = new.size > 0
    hi, lo = (float(np.max(new)), float(np.min(new))) if some else (-math.inf, math.inf)
    d = float(np.max(np.abs(new - old))) if some else 0.0
    if mesh is not None:                     # the same on every rank (the plain values on a serial mesh)
        hi, lo, d = parallel.allmax(mesh, hi), parallel.allmin(mesh, lo), parallel.allmax(mesh, d)
    if hi < lo:                              # no values anywhere
        return 0.0
    scale = max(hi - lo, max(abs(hi), abs(lo)) * 1e-3, 1e-300)
    return d / scale if math.isfinite(d) else math.inf
