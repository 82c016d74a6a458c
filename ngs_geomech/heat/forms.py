"""Heat conduction forms: steady (2.17), (2.19)-(2.22) and transient (2.43) of the seed, with anisotropic
conductivity per body, Kirchhoff-transformed temperature-dependent conductivity, sources, Dirichlet,
flux and Robin conditions, and temperature/flux continuity across contact interfaces (2.22).

Weak form of one theta step from t0 to t1 = t0 + dt (unknown T = T(t1), old T0 = T(t0), weight w = 1 in
plane and 3D scenes, w = r in axisymmetric ones; all integrals carry w):

    (rho c (T - T0)/dt, v) + theta (kappa f(T) grad T, grad v) + (1 - theta) (kappa f(T0) grad T0, grad v)
      + sum_Robin <h (theta T + (1 - theta) T0), v> + sum_contact c((T, lambda), (v, mu))
      = theta l(t1; v) + (1 - theta) l(t0; v),
    l(t; v) = (Q(t), v) + sum_flux <q0(t), v> + sum_Robin <h T_amb(t), v>,

where f(T) = 1 + b (T - T_ref) per region (kappa f(T) grad T = kappa grad Theta(T), Theta the Kirchhoff
transform). The conductivity kappa(x, T) and the heat capacity rho c(x, T) may vary in space and with T
(material values given as expressions): kappa(x, T) f(T) enters the theta terms with the temperature of each term
(T and T0), and a rho c that depends on T enters as rho c(T_theta) (T - T0)/dt with T_theta = theta T +
(1 - theta) T0 (second order for Crank-Nicolson); Newton's tangent (NGSolve's linearization of the integrand)
then holds the terms d kappa/dT dT grad T . grad v and d(rho c)/dT theta dT (T - T0)/dt v, so the iteration
stays exact (quadratic). A steady solve drops the time terms (theta = 1). Units: T in K (or degC), kappa W/(m K),
rho c J/(m^3 K), Q W/m^3, q0 W/m^2, h W/(m^2 K).

Contact interfaces are coupled by a mortar method: on the master side Gamma_m a multiplier lambda (the
heat flux -kappa dT/dn_m, W/m^2) in the trace space of order p, and

    c((T, lambda), (v, mu)) = <lambda, v_m - v_s> + <mu, T_m - T_s>   on Gamma_m,

with T_s the minion trace opposite. The integrals are split where the two sides' elements overlap
(segment-based, :mod:`ngs_geomech.fem.mortar`), so they are exact on non-matching meshes. The
coupling is taken implicitly (at t1), so that T_m = T_s holds weakly at every step; with Crank-Nicolson
lambda is then the step's average flux. Multiplier dofs at interface ends on Dirichlet boundaries are
reduced as in the standard modified mortar space (see ``HeatForms._free_dofs``); otherwise the
saddle-point matrix is singular there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..fem.coefficients import Separable, TimeFunction, boundary_cf, material_cf, region_cf, regions_regex, tensor_cf
from ..fem.mortar import mortar_coupling_2d, mortar_coupling_3d
from .materials import ThermalProperties

if TYPE_CHECKING:
    from .conductance import InterfaceConductance


class LocalInterfaceDofs:
    """The numbering the interface terms act in on a serial mesh: the first ``nV`` dofs of the state (the
    temperature). On a distributed mesh the forms take :class:`.distributed.GlobalInterfaces` instead."""

    def __init__(self, nV: int):
        self.nV = nV

    def temperatures(self, vec) -> np.ndarray:
        """The temperature dofs of a state vector (a view)."""
        return vec.FV().NumPy()[:self.nV]

    def add(self, b, values: np.ndarray) -> None:
        """Add ``values`` (temperature dofs) to the right-hand side ``b``."""
        b.FV().NumPy()[:self.nV] += values

    @staticmethod
    def mortar_flows(forms: HeatForms, total: bool) -> list[float]:
        """The flows int w lambda ds over each mortar interface of ``forms`` (W per m of depth or per radian; with
        ``total`` in axisymmetric scenes over 2 pi, W)."""
        mesh = forms.mesh
        if total:
            w = 2 * math.pi * ngs.x if forms.setup.axisymmetric else 1.0
            return [float(ngs.Integrate(w * lam * ngs.ds(definedon=mesh.Boundaries(m)), mesh))
                    for (m, _), lam in zip(forms.setup.contacts, forms.multipliers())]
        return [float(ngs.Integrate(forms.weight * lam * ngs.ds(definedon=mesh.Boundaries(m)), mesh))
                for (m, _), lam in zip(forms.setup.contacts, forms.multipliers())]


@dataclass
class HeatSetup:
    """Plain inputs of the heat forms.

    ``dirichlet``, ``flux`` map boundary names to TimeFunctions (K, W/m^2); ``robin`` maps boundary names
    to (h in W/(m^2 K), ambient TimeFunction); ``sources`` maps region names to TimeFunctions of the power
    density (W/m^3); ``contacts`` lists (master boundary, minion boundary) name pairs.
    """

    props: dict[str, ThermalProperties]
    order: int = 1
    axisymmetric: bool = False
    steady: bool = False
    theta: float = 1.0
    startup_until: float | None = None      # s: steps ending at or before it use theta = 1 (start-up)
    dirichlet: dict[str, TimeFunction] = field(default_factory=dict)
    flux: dict[str, TimeFunction] = field(default_factory=dict)
    robin: dict[str, tuple[float, TimeFunction]] = field(default_factory=dict)
    sources: dict[str, TimeFunction | list[TimeFunction]] = field(default_factory=dict)
    contacts: list[tuple[str, str]] = field(default_factory=list)
    conductances: list[InterfaceConductance] = field(default_factory=list)
    """Contact interfaces that pass heat by a contact conductance (:mod:`.conductance`) instead of the mortar
    coupling of ``contacts``."""
    pressure_coefficients: dict[str, float] = field(default_factory=dict)
    """Region name -> c_p (1/Pa) of kappa(T, p) = kappa f(T) (1 + c_p p), p the mean pressure (compression > 0)
    set with :meth:`HeatForms.set_pressure` (the seed's remark on its model: k depends on the pressure)."""

    @property
    def nonlinear(self) -> bool:
        return any(p.nonlinear for p in self.props.values())

    @property
    def conductivity_uses_temperature(self) -> bool:
        return any(p.conductivity_uses_temperature for p in self.props.values())

    @property
    def capacity_uses_temperature(self) -> bool:
        return any(p.capacity_uses_temperature for p in self.props.values())


def check_pressure_factors(mesh, gf_pressure, coefficients: dict, changed) -> tuple[float, float]:
    """Factors 1 + c_p p per element of the regions with c_p != 0: their (min, max); ValueError naming the
    region and the pressure when one is not positive. Calls ``changed()`` (the conductivity changed)."""
    p = gf_pressure.vec.FV().NumPy()
    lo, hi = float("inf"), float("-inf")
    for name, c in coefficients.items():
        if c == 0.0:
            continue
        els = [el.nr for el in mesh.Materials(name).Elements()]
        f = 1.0 + c * p[els]
        bad = np.nonzero(~(f > 0))[0]
        if len(bad):
            raise ValueError(f"conductivity of region {name!r}: the factor 1 + c_p p = {f[bad[0]]:.3g} is not "
                             f"positive at the pressure {p[els][bad[0]]:.4g} Pa (c_p = {c:g} 1/Pa): the linear "
                             "pressure law has left its range")
        lo, hi = min(lo, float(f.min())), max(hi, float(f.max()))
    changed()
    return lo, hi


class HeatForms:
    """Spaces, state and forms of one heat problem on a given mesh (builds no mesh, writes no file).

    ``gf`` holds the new state (temperature and interface multipliers), ``gf_old`` the old one;
    ``t_new``, ``t_old``, ``inv_dt`` are Parameters the driver sets before each step.
    """

    def __init__(self, mesh, setup: HeatSetup):
        self.mesh = mesh
        self.setup = setup
        dir_names = regions_regex(setup.dirichlet)
        self.V = ngs.H1(mesh, order=setup.order, dirichlet=dir_names)
        self.multiplier_spaces = [ngs.H1(mesh, order=setup.order, definedon=mesh.Boundaries(m))
                                  for m, _ in setup.contacts]
        self.X = ngs.FESpace([self.V, *self.multiplier_spaces]) if setup.contacts else self.V
        self.freedofs = self._free_dofs(dir_names)
        self.gf = ngs.GridFunction(self.X)
        self.gf_old = ngs.GridFunction(self.X)
        self.t_new = ngs.Parameter(0.0)
        self.t_old = ngs.Parameter(0.0)
        self.inv_dt = ngs.Parameter(1.0)
        self.t_load = ngs.Parameter(0.0)
        self.theta = ngs.Parameter(1.0 if setup.steady else setup.theta)
        self.weight = ngs.x if setup.axisymmetric else ngs.CoefficientFunction(1.0)
        self.kappa = self.conductivity(self.temperature())
        """kappa(x, T) without f(T) (W/(m K)), T the current temperature when it depends on it."""
        self.rho_c = self.capacity(self.temperature())
        """rho c(x, T) (J/(m^3 K)), T the current temperature when it depends on it."""
        self.version = 0
        """Changes when the conductivity changes (:meth:`set_pressure`): the solver's cached matrices are stale."""
        self.gf_pressure = None
        if any(c != 0.0 for c in setup.pressure_coefficients.values()):
            self.gf_pressure = ngs.GridFunction(ngs.L2(mesh, order=0))
            self.pressure_factor = region_cf(mesh, {n: 1 + c * self.gf_pressure
                                                    for n, c in setup.pressure_coefficients.items()}, 1.0)
            self.kappa = self.pressure_factor * self.kappa
            self._kappa_x = self.pressure_factor * self._kappa_x if self._kappa_x is not None else None
        self.extra_load = None
        """An assembled source vector over X (W) added to every right-hand side, e.g. the deformation heating
        of problem (P_c) (lagged, full weight also with theta < 1), or None."""
        self._mortar = self._mortar_coo = None
        self.interface_dofs = LocalInterfaceDofs(self.V.ndof)
        """The numbering of the interface terms (a distributed mesh: the global one, :mod:`.distributed`)."""
        self.interface_terms = None
        """The contact-conductance terms (:class:`.interface_terms.InterfaceTerms`, built with the mortar coupling
        by :meth:`update_contact_pairs`), or None."""
        self._build_forms()

    def _free_dofs(self, dir_names: str):
        """Free dofs of the state: X's, less multiplier dofs at contact-interface ends on a Dirichlet boundary
        (cross points, where the temperature is fixed on both sides), as in the standard modified mortar
        space: the multiplier has degree p - 1 on the end element, so it still carries the flux there.

        2D, order p >= 2: the top-degree bubble of the end element is removed. 2D, order 1: the end vertex
        function is merged into its neighbour's (``self.merge``: the multiplier is constant on the end
        element). 3D, p >= 2: on every master triangle touching the cross curve the top-degree edge bubbles (and
        for p >= 3 the face bubbles) are removed, so the multiplier is of degree p - 1 there and keeps its vertex
        functions (measured: P2 keeps the glued order, H1 1.85 / 2.00 on a box pair). 3D, p = 1: the vertex
        functions on the cross curve are removed.
        """
        free = ngs.BitArray(self.X.FreeDofs())
        self.merge = [dict() for _ in self.setup.contacts]
        if not self.setup.contacts or not self.setup.dirichlet:
            return free
        dirichlet_vertices = self._dirichlet_vertices(dir_names)
        offset = self.V.ndof
        for k, ((master, _), L) in enumerate(zip(self.setup.contacts, self.multiplier_spaces)):
            for el in self.mesh.Boundaries(master).Elements():
                ends = [v for v in el.vertices if v.nr in dirichlet_vertices]
                if not ends:
                    continue
                if self.mesh.dim == 2 and self.setup.order >= 2:
                    dofs = [L.GetDofNrs(el.edges[0])[-1]]
                elif self.mesh.dim == 2:
                    dofs = [d for v in ends for d in L.GetDofNrs(v)]
                    others = [v for v in el.vertices if v.nr not in dirichlet_vertices]
                    if others:
                        for d in dofs:
                            self.merge[k][d] = L.GetDofNrs(others[0])[0]
                elif self.setup.order >= 2:
                    # 3D, p >= 2: the multiplier on triangles touching the cross curve is reduced to degree
                    # p - 1 (top edge bubbles; face bubbles for p >= 3) and keeps its vertex functions
                    dofs = [L.GetDofNrs(e)[-1] for e in el.edges if len(L.GetDofNrs(e))]
                    if self.setup.order >= 3:
                        dofs += list(L.GetDofNrs(ngs.NodeId(ngs.FACE, el.faces[0].nr)))
                else:
                    dofs = [d for v in ends for d in L.GetDofNrs(v)]
                for d in dofs:
                    free[offset + d] = False
            offset += L.ndof
        return free

    def _dirichlet_vertices(self, dir_names: str) -> set[int]:
        """The numbers of this part's vertices on a Dirichlet boundary (of any part, on a distributed mesh: the
        boundary element may lie on another part than the interface's)."""
        mine = {v.nr for el in self.mesh.Boundaries(dir_names).Elements() for v in el.vertices}
        if not parallel.distributed(self.mesh):
            return mine
        scalar = parallel.GlobalDofs(self.V).scalar        # vertex v has the dof v
        marked = set(np.concatenate([np.asarray(p, dtype=np.int64) for p in parallel.allgather(
            self.mesh, scalar[np.array(sorted(mine), dtype=int)])]).tolist())
        return {v for v in range(self.mesh.nv) if int(scalar[v]) in marked}

    # -- pieces ---------------------------------------------------------------------------------------
    def temperature(self, gf=None):
        """The temperature component of a state GridFunction (default: the new state)."""
        g = gf if gf is not None else self.gf
        return g.components[0] if self.setup.contacts else g

    def multipliers(self, gf=None) -> list:
        g = gf if gf is not None else self.gf
        return list(g.components[1:]) if self.setup.contacts else []

    def set_pressure(self, pressure) -> tuple[float, float]:
        """The mean pressure p (Pa, compression > 0; a CoefficientFunction, e.g. minus the mean stress of the
        mechanics) of kappa(T, p), element averages; returns the range (min, max) of the factors 1 + c_p p.
        Raises ValueError naming the region when a factor is not positive (c_p p <= -1: the law has left its
        range)."""
        if self.gf_pressure is None:
            raise ValueError("set_pressure: no region has a pressure coefficient")
        self.gf_pressure.Set(pressure)
        return check_pressure_factors(self.mesh, self.gf_pressure, self.setup.pressure_coefficients,
                                       self._bump)

    def _bump(self) -> None:
        self.version += 1
        self._matrices_assembled = False

    def conductivity(self, T):
        """kappa(x, T) per region, without f(T) (dim x dim CF, W/(m K); times the pressure factor when set): for
        data that do not depend on T one CF built once (the number path: one constant per region)."""
        kx = getattr(self, "_kappa_x", None)
        if kx is not None:
            return kx
        dim, props = self.mesh.dim, self.setup.props
        zero = ngs.CoefficientFunction((0.0,) * dim * dim, dims=(dim, dim))
        k = region_cf(self.mesh, {n: tensor_cf(p.kappa, T) for n, p in props.items()}, default=zero)
        if not self.setup.conductivity_uses_temperature:
            self._kappa_x = k
        elif getattr(self, "gf_pressure", None) is not None:
            k = self.pressure_factor * k
        return k

    def capacity(self, T):
        """The heat capacity rho c(x, T) per region (J/(m^3 K); 0 where not given)."""
        props = self.setup.props
        if not any(p.varying for p in props.values()):
            return region_cf(self.mesh, {n: p.rho_c or 0.0 for n, p in props.items()})
        return region_cf(self.mesh, {n: material_cf(p.rho_c, T) if p.rho_c is not None else 0.0
                                     for n, p in props.items()})

    def conductivity_factor(self, T):
        """f(T) = 1 + b (T - T_ref) per region (dimensionless)."""
        if not self.setup.nonlinear:
            return ngs.CoefficientFunction(1.0)
        return region_cf(self.mesh, {n: 1 + p.b * (T - p.t_ref) for n, p in self.setup.props.items()}, 1.0)

    def kirchhoff(self, T):
        """Kirchhoff variable Theta(T) = int_{T_ref}^T f(s) ds per region, K."""
        return region_cf(self.mesh, {n: (T - p.t_ref) + p.b / 2 * (T - p.t_ref) ** 2
                                     for n, p in self.setup.props.items()})

    def heat_flux(self, T):
        """Heat flux vector q = -kappa f(T) grad T, W/m^2."""
        return -self.conductivity_factor(T) * (self.conductivity(T) * ngs.grad(T))

    def _load_terms(self, v):
        """The load l(t; v) split by how it depends on time: a list of (integrand maker, kind, scale) with
        kind 'static' (assembled once), 'separable' (assembled once, times scale(t)) or 'dynamic'
        (assembled at every time it is needed)."""
        s, w = self.setup, self.weight
        items = []
        for region, funcs in s.sources.items():
            measure = ngs.dx(definedon=self.mesh.Materials(region))
            for f in (funcs if isinstance(funcs, list) else [funcs]):
                items.append((f, lambda g, m=measure: w * g * v * m))
        for name, f in s.flux.items():
            measure = ngs.ds(definedon=self.mesh.Boundaries(name))
            items.append((f, lambda g, m=measure: w * g * v * m))
        for name, (h, amb) in s.robin.items():
            measure = ngs.ds(definedon=self.mesh.Boundaries(name))
            items.append((amb, lambda g, m=measure, h=h: w * h * g * v * m))
        terms = []
        for f, integrand in items:
            if isinstance(f, Separable):
                terms.append((lambda t, f=f, i=integrand: i(f.spatial), "separable", f.scale))
            elif getattr(f, "time_dependent", True) is False:
                terms.append((lambda t, f=f, i=integrand: i(f(t)), "static", None))
            else:
                terms.append((lambda t, f=f, i=integrand: i(f(t)), "dynamic", None))
        return terms

    def _build_loads(self, v):
        X = self.X
        self._static = []          # (vector, scale or None)
        dynamic = ngs.LinearForm(X)
        has_dynamic = False
        for make, kind, scale in self._load_terms(v):
            if kind == "dynamic":
                dynamic += make(self.t_load)
                has_dynamic = True
            else:
                lf = ngs.LinearForm(X)
                lf += make(None)
                self._static.append((lf, scale))
        self._dynamic = dynamic if has_dynamic else None
        self._load_cache: dict[float, object] = {}
        self._static_assembled = False

    def loads(self, t: float):
        """The load vector l(t; .) (W), assembling only what depends on t (two times are cached)."""
        if t in self._load_cache:
            return self._load_cache[t]
        if not self._static_assembled:
            for lf, _ in self._static:
                lf.Assemble()
            self._static_assembled = True
        vec = self.gf.vec.CreateVector()
        vec[:] = 0.0
        for lf, scale in self._static:
            vec.data += (1.0 if scale is None else scale(t)) * lf.vec
        if self._dynamic is not None:
            self.t_load.Set(t)
            self._dynamic.Assemble()
            vec.data += self._dynamic.vec
        if len(self._load_cache) >= 2:
            self._load_cache.pop(next(iter(self._load_cache)))
        self._load_cache[t] = vec
        return vec

    def volume_measure(self):
        """The volume measure: one fixed quadrature rule per element type (order 2p + 1, exact for straight
        elements with the weight r), shared by the matrix and the old-state terms. NGSolve's default rules differ
        between BilinearForm and LinearForm (for p >= 2 with the weight r, and on curved elements); with
        theta < 1 that mismatch made the step operator amplify stiff modes (Crank-Nicolson blew up)."""
        q = 2 * self.setup.order + 1
        types = (ngs.TRIG, ngs.QUAD) if self.mesh.dim == 2 else (ngs.TET, ngs.HEX, ngs.PRISM, ngs.PYRAMID)
        return ngs.dx(intrules={et: ngs.IntegrationRule(et, q) for et in types})

    def _build_forms(self):
        s, w, X = self.setup, self.weight, self.X
        dx = self.volume_measure()
        if s.contacts:
            trials, tests = X.TnT()
            T, v = trials[0], tests[0]
        else:
            T, v = X.TnT()
        T_old = self.temperature(self.gf_old)
        th = self.theta
        k_new = self.conductivity_factor(T) * (self.conductivity(T) * ngs.grad(T))
        lhs = ngs.BilinearForm(X)  # full storage: the solver copies it (with the mortar coupling)
        form = th * w * ngs.InnerProduct(k_new, ngs.grad(v)) * dx
        if not s.steady and s.capacity_uses_temperature:
            form += w * self.inv_dt * self.capacity(th * T + (1 - th) * T_old) * (T - T_old) * v * dx
        elif not s.steady:
            form += w * self.inv_dt * self.rho_c * T * v * dx
        for name, (h, _) in s.robin.items():
            form += th * w * h * T * v * ngs.ds(definedon=self.mesh.Boundaries(name))
        lhs += form
        self._build_loads(v)
        self.lhs = lhs
        # old-state terms: matrices for linear problems (mass and stiffness, the same quadrature as lhs),
        # a linear form in T_old for the k(T) law
        self.mass = self.stiffness = self.old_state = None
        if not s.steady and not s.nonlinear:
            self.mass = ngs.BilinearForm(X)
            self.mass += w * self.rho_c * T * v * dx
            self.stiffness = ngs.BilinearForm(X)
            stiff = w * ngs.InnerProduct(self.kappa * ngs.grad(T), ngs.grad(v)) * dx
            for name, (h, _) in s.robin.items():
                stiff += w * h * T * v * ngs.ds(definedon=self.mesh.Boundaries(name))
            self.stiffness += stiff
        elif not s.steady:
            old = -(1 - th) * w * ngs.InnerProduct(self.conductivity_factor(T_old) * (self.conductivity(T_old)
                                                                                       * ngs.grad(T_old)),
                                                   ngs.grad(v)) * dx
            if not s.capacity_uses_temperature:        # else in lhs: rho c(T_theta) (T - T_old) / dt
                old = w * self.inv_dt * self.rho_c * T_old * v * dx + old
            for name, (h, _) in s.robin.items():
                old += -(1 - th) * w * h * T_old * v * ngs.ds(definedon=self.mesh.Boundaries(name))
            self.old_state = ngs.LinearForm(X)
            self.old_state += old
        self._matrices_assembled = False

    def update_contact_pairs(self) -> None:
        """(Re)build the mortar coupling matrix of the contact interfaces (after creating the forms and after every
        mesh change), integrated segment-based so that it is exact on non-matching meshes
        (:mod:`ngs_geomech.fem.mortar`; 2D: master segments cut at the minion nodes, 3D: master triangles clipped
        against the minion triangles), and the contact-conductance terms (:mod:`.interface_terms`)."""
        self._mortar = self._mortar_coo = None
        self.interface_terms = None
        if parallel.distributed(self.mesh) and (self.setup.conductances or self.setup.contacts):
            from .distributed import GlobalInterfaces

            glob = GlobalInterfaces(self)
            self.interface_dofs, self.interface_terms = glob, glob.terms
            self._mortar_coo, self._mortar = glob.mortar_coo, glob.mortar
            self._bump()
            return
        if self.setup.conductances:
            # with scipy.sparse: loaded by scenes with contact conductance only (start-up)
            from .interface_terms import InterfaceTerms

            self.interface_terms = InterfaceTerms(self.mesh, self.V, self.setup.conductances, order=self.setup.order,
                                                  axisymmetric=self.setup.axisymmetric, ndof=self.X.ndof)
            self._bump()
        if not self.setup.contacts:
            return
        rows, cols, vals = [], [], []
        offset = self.V.ndof
        for (master, minion), L, merge in zip(self.setup.contacts, self.multiplier_spaces, self.merge):
            if self.mesh.dim == 2:
                r, c, v = mortar_coupling_2d(self.mesh, self.V, L, master, minion, merge=merge,
                                             axisymmetric=self.setup.axisymmetric, order=2 * self.setup.order)
            else:
                r, c, v = mortar_coupling_3d(self.mesh, self.V, L, master, minion, order=self.setup.order)
            rows += [r + offset, c]
            cols += [c, r + offset]
            vals += [v, v]
            offset += L.ndof
        n = self.X.ndof
        self._mortar_coo = (np.concatenate(rows), np.concatenate(cols), np.concatenate(vals))
        self._mortar = ngs.la.SparseMatrixd.CreateFromCOO(
            list(map(int, self._mortar_coo[0])), list(map(int, self._mortar_coo[1])),
            list(map(float, self._mortar_coo[2])), n, n)

    @property
    def coupling(self):
        """The interface matrix added to the step matrix: the mortar coupling, plus theta times the conductance
        matrix C of the contact-conductance interfaces (None without interfaces)."""
        if self.interface_terms is None:
            return self._mortar
        return self.interface_terms.coupling(self._mortar_coo, self.theta.Get())

    @property
    def nonlinear(self) -> bool:
        """Whether a step needs Newton's method: a k(T) law, or exact radiation across an interface."""
        return self.setup.nonlinear or (self.interface_terms is not None and self.interface_terms.exact_radiation)

    def set_contact_state(self, states) -> None:
        """The contact state of the mechanics per interface name (:class:`~.conductance.ContactNodes`; None or a
        missing name: the state of the geometry) for the contact-conductance interfaces."""
        if self.interface_terms is not None and self.interface_terms.set_state(states):
            self.version += 1             # the step matrix changes (the mass and stiffness matrices do not)

    def prepare_step(self) -> None:
        """Before a solve: the lagged radiation conductances at the old temperature (steady: the current one)."""
        terms = self.interface_terms
        if terms is not None and terms.lagged_radiation:
            gf = self.gf if self.setup.steady else self.gf_old
            terms.lag(self.interface_dofs.temperatures(gf.vec))
            self.version += 1

    def add_coupling(self, vec, res) -> None:
        """Add to ``res`` the interface terms at the state ``vec`` (the coupling matrix, and theta times the exact
        radiation vector)."""
        coupling = self.coupling
        if coupling is not None:
            res.data += coupling * vec
        terms = self.interface_terms
        if terms is not None and terms.exact_radiation:      # (terms.nV: the temperature dofs of their numbering)
            res.FV().NumPy()[:terms.nV] += self.theta.Get() * terms.radiation(vec.FV().NumPy()[:terms.nV])[0]

    def coupling_jacobian(self, vec):
        """The derivative of :meth:`add_coupling` at ``vec`` (an NGSolve matrix, or None)."""
        terms = self.interface_terms
        if terms is None or not terms.exact_radiation:
            return self.coupling
        jac = (self.theta.Get() * terms.radiation(vec.FV().NumPy()[:terms.nV])[1]).tocoo()
        r, c, v = (np.array(a) for a in self.coupling.COO())
        r, c, v = np.concatenate([r, jac.row]), np.concatenate([c, jac.col]), np.concatenate([v, jac.data])
        return ngs.la.SparseMatrixd.CreateFromCOO(list(map(int, r)), list(map(int, c)), list(map(float, v)),
                                                  terms.ndof, terms.ndof)

    def right_hand_side(self):
        """The right-hand side of the step from t_old to t_new (see the module docstring), W."""
        s = self.setup
        t1 = self.t_new.Get()
        if s.steady:
            b = self.gf.vec.CreateVector()
            b.data = self.loads(t1)
            return b
        th = self.theta.Get()
        b = self.gf.vec.CreateVector()
        b.data = th * self.loads(t1)
        if self.extra_load is not None:
            b.data += self.extra_load
        if th < 1:
            b.data += (1 - th) * self.loads(self.t_old.Get())
        if self.old_state is not None:
            self.old_state.Assemble()
            b.data += self.old_state.vec
        else:
            if not self._matrices_assembled:
                self.mass.Assemble()
                self.stiffness.Assemble()
                self._matrices_assembled = True
            b.data += self.inv_dt.Get() * (self.mass.mat * self.gf_old.vec)
            if th < 1:
                b.data -= (1 - th) * (self.stiffness.mat * self.gf_old.vec)
        if th < 1 and self.interface_terms is not None:
            dofs = self.interface_dofs
            dofs.add(b, -((1 - th) * self.interface_terms.old_terms(dofs.temperatures(self.gf_old.vec))))
        return b

    def dirichlet_values(self, t_param) -> object | None:
        """Boundary CF of the Dirichlet temperatures at time t_param (None without Dirichlet conditions)."""
        if not self.setup.dirichlet:
            return None
        return boundary_cf(self.mesh, {n: f(t_param) for n, f in self.setup.dirichlet.items()})
