"""Elasticity forms of problem (P) without contact: (2.17)-(2.21) with the stress law (2.18)/(2.37)

    tau_ij = c*_ijkl(u) e_kl(u) - beta_ij (T - T0) + sigma0_ij,    c* = lam (A1/A_ref + delta)^(lam-1) c,

A1 = c_ijkl e_ij e_kl (2.1)-(2.5), written with the strain energy (Voigt vectors, engineering shear)

    W(e) = (A_ref/2) ((A1/A_ref + delta)^lam - delta^lam) - beta (T - T0) . e + sigma0 . e,

so that dW/de = tau; lam = 1 is linear elasticity with c (the seed's c = C/2, A1 measured in units of
A_ref = the A1 of a uniaxial strain eps_ref). Loads: body forces rho g and f (per region), tractions P and
pressure -p n on boundaries (2.19), prescribed displacements u0 per component (2.20)-(2.21), symmetry u_n = 0, tau_t = 0
(2.16): on boundaries along a coordinate axis as a component constraint, on oblique straight boundaries
with a multiplier (the normal traction, Pa) <mu, u.n> + <lambda, v.n>.

Models: plane strain and plane stress (x, y), axisymmetric (r = x, z = y; e_thetatheta = u_r / r, weight
r, u_r = 0 on the axis) and 3D. Units: u in m, stresses in Pa, T in K (or degC), beta in Pa/K.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

from ..elastic_materials import ElasticProperties, axisymmetric, plane_strain, plane_stress, to_voigt_stress
from .coefficients import TimeFunction, regions_regex

MODELS = ("plane_strain", "plane_stress", "axisymmetric", "3d")


@dataclass
class ElasticSetup:
    """Plain inputs of the elastic forms.

    ``dirichlet`` maps boundary names to one TimeFunction or None (free) per component (m); ``traction``
    to a TimeFunction per component (Pa); ``pressure`` to a TimeFunction (Pa); ``symmetry`` lists boundary
    names with u_n = 0; ``axis`` lists boundaries on the axis of an axisymmetric model (u_r = 0);
    ``initial_stress`` is a dim x dim list of TimeFunctions (Pa, in-plane/axisymmetric components only);
    ``temperature`` is a CoefficientFunction of T (K) for the thermal stress, or None; ``body_force`` maps
    region names to a TimeFunction per component (N/m^3), a volume load added to rho g.
    """

    props: dict[str, ElasticProperties]
    model: str
    order: int = 1
    dirichlet: dict[str, list] = field(default_factory=dict)
    traction: dict[str, list] = field(default_factory=dict)
    pressure: dict[str, TimeFunction] = field(default_factory=dict)
    symmetry: list[str] = field(default_factory=list)
    axis: list[str] = field(default_factory=list)
    gravity: tuple | None = None
    initial_stress: list | None = None
    temperature: object | None = None
    regularization: float = 1e-6
    body_force: dict[str, list] = field(default_factory=dict)

    @property
    def nonlinear(self) -> bool:
        return any(p.lam != 1.0 for p in self.props.values())


@dataclass
class FloatingBody:
    """A body with rigid motions no displacement or symmetry condition holds (see
    :meth:`ElasticForms.floating_bodies`): its ``regions``, the ``names`` of the free motions and their
    coefficient vectors as the columns of ``modes`` (X-sized; translations in m per m, rotations in rad)."""

    regions: list
    names: list
    modes: np.ndarray


def _axis_aligned_normal(mesh, name: str) -> tuple[int, np.ndarray] | None:
    """(component, normal) when boundary ``name`` is straight and normal to a coordinate axis, else the
    normal (component None) when it is straight; raises ValueError when it is not straight."""
    normals = []
    dim = mesh.dim
    for el in mesh.Boundaries(name).Elements():
        pts = np.array([mesh[v].point for v in el.vertices])
        if dim == 2:
            t = pts[1] - pts[0]
            n = np.array([t[1], -t[0]])
        else:
            n = np.cross(pts[1] - pts[0], pts[2] - pts[0])
        normals.append(n / np.linalg.norm(n))
    if not normals:
        raise ValueError(f"boundary {name!r} has no elements")
    n0 = normals[0]
    if any(abs(abs(float(np.dot(n, n0))) - 1) > 1e-8 for n in normals):
        raise ValueError(f"symmetry boundary {name!r} is not straight (planar)")
    k = int(np.argmax(np.abs(n0)))
    if abs(abs(n0[k]) - 1) < 1e-10:
        return k, n0
    return None, n0


def _rigid_modes(model: str, dim: int, center=(0.0, 0.0, 0.0)) -> dict:
    """The rigid motions of a model as CoefficientFunction components, rotations about ``center`` (m):
    axisymmetric the axial translation, plane 2 translations and the rotation, 3D 3 + 3."""
    x, y = ngs.x - center[0], ngs.y - center[1]
    z = ngs.z - center[2] if dim == 3 else 0
    if model == "axisymmetric":
        return {"translation along z": (0, 1)}
    if dim == 3:
        return {"translation along x": (1, 0, 0), "translation along y": (0, 1, 0),
                "translation along z": (0, 0, 1), "rotation about x": (0, -z, y),
                "rotation about y": (z, 0, -x), "rotation about z": (-y, x, 0)}
    return {"translation along x": (1, 0), "translation along y": (0, 1), "rotation about z": (-y, x)}


def _free_combinations(A: np.ndarray, names: list[str]) -> tuple[np.ndarray, list[str]]:
    """The combinations of rigid motions (columns of the constraint matrix A, one row per constrained
    value) that no constraint holds: (rows of coefficients, their names: a motion's name or a weighted sum)."""
    if A.size:
        _, sv, vt = np.linalg.svd(A, full_matrices=True)
        rank = int(np.sum(sv > 1e-10 * max(1.0, float(np.abs(A).max()))))
        null = vt[rank:]
    else:
        null = np.eye(len(names))
    labels = [names[int(np.argmax(np.abs(v)))] if np.count_nonzero(np.abs(v) > 1e-8) == 1
              else " + ".join(f"{c:.2g} x ({n})" for c, n in zip(v, names) if abs(c) > 1e-8) for v in null]
    return null, labels


class ElasticForms:
    """Spaces, state and forms of the elastic problem on a given mesh (builds no mesh, writes no file)."""

    def __init__(self, mesh, setup: ElasticSetup):
        if setup.model not in MODELS:
            raise ValueError(f"unknown model {setup.model!r}")
        self.mesh = mesh
        self.setup = setup
        self.dim = mesh.dim
        self.t = ngs.Parameter(0.0)
        self.linear_switch = ngs.Parameter(0.0)   # 1: the secant form uses c* = c (start of the iterations)
        comp_dirichlet: list[list[str]] = [[] for _ in range(self.dim)]
        for name, comps in setup.dirichlet.items():
            for k, c in enumerate(comps):
                if c is not None:
                    comp_dirichlet[k].append(name)
        self.oblique: list[tuple[str, np.ndarray]] = []
        for name in setup.symmetry:
            k, n = _axis_aligned_normal(mesh, name)
            if k is not None:
                comp_dirichlet[k].append(name)
            else:
                self.oblique.append((name, n))
        for name in setup.axis:
            comp_dirichlet[0].append(name)
        flags = {f"dirichlet{'xyz'[k]}": regions_regex(set(names)) for k, names in enumerate(comp_dirichlet)
                 if names}
        self.fixed_names = comp_dirichlet
        self.V = ngs.VectorH1(mesh, order=setup.order, **flags)
        dir_all = regions_regex({n for names in comp_dirichlet for n in names}) if any(comp_dirichlet) else ""
        self.multiplier_spaces = [ngs.H1(mesh, order=setup.order, definedon=mesh.Boundaries(name),
                                         dirichlet=dir_all) for name, _ in self.oblique]
        self.X = ngs.FESpace([self.V, *self.multiplier_spaces]) if self.oblique else self.V
        self.gf = ngs.GridFunction(self.X)
        self.weight = ngs.x if setup.model == "axisymmetric" else ngs.CoefficientFunction(1.0)
        self._material_matrices()
        self.u_frozen = ngs.GridFunction(self.V)   # the last iterate u_n of the secant method
        # one quadrature (order 2 order) for every integral of the energy, the secant form and its right-hand
        # side: NGSolve's default orders differ between energies and linear forms (a P2 temperature in the
        # thermal stress was integrated exactly by the linear form, not by the energy), so Newton and the
        # secant method solved different discrete problems (1e-2 apart in H1 on a thermal P2 case)
        order2 = 2 * setup.order
        if setup.model == "axisymmetric" and order2 < 4:
            # the degree-2 triangle rule has its points on the edge midpoints: on an edge on the axis r = 0 the
            # hoop strain u_r / r was 0 / 0 (NaN in the matrix and the load of every element touching the axis)
            order2 = 4
        self.rule_order = order2
        self.intrules = {et: ngs.IntegrationRule(et, order2) for et in (ngs.ET.TRIG, ngs.ET.QUAD, ngs.ET.TET,
                                                                         ngs.ET.PRISM, ngs.ET.PYRAMID, ngs.ET.HEX)}
        self.bnd_intrules = {et: ngs.IntegrationRule(et, order2) for et in (ngs.ET.SEGM, ngs.ET.TRIG, ngs.ET.QUAD)}
        self._build()

    # -- material data in the model's reduced Voigt form ----------------------------------------------------
    def _material_matrices(self):
        """Per region: the reduced stiffness D (Pa), thermal stress vector b (Pa/K) and, for plane strain,
        the sigma_zz row and its thermal coefficient (see :mod:`ngs_geomech.elastic_materials`)."""
        self.D, self.b, self.zz = {}, {}, {}
        for name, p in self.setup.props.items():
            zz = None
            if self.setup.model == "3d":
                D, b = p.C, to_voigt_stress(p.beta)
            elif self.setup.model == "plane_strain":
                red = plane_strain(p.C, p.beta)
                D, b, zz = red.D, red.beta, (red.stress_out[0], red.beta_out[0])
            elif self.setup.model == "plane_stress":
                red = plane_stress(p.C, p.beta)
                D, b = red.Q, red.beta
            else:
                red = axisymmetric(p.C, p.beta, name)
                D, b = red.D, red.beta
            self.D[name], self.b[name], self.zz[name] = np.asarray(D), np.asarray(b), zz

    def displacement(self, gf=None):
        g = gf if gf is not None else self.gf
        return g.components[0] if self.oblique else g

    def strain_vector(self, u):
        """Reduced Voigt strain: (exx, eyy, gxy) plane; (err, ezz, ett, grz) axisymmetric; 6 in 3D."""
        G = ngs.grad(u)
        if self.setup.model == "3d":
            return ngs.CoefficientFunction((G[0, 0], G[1, 1], G[2, 2], G[1, 2] + G[2, 1], G[0, 2] + G[2, 0],
                                            G[0, 1] + G[1, 0]))
        if self.setup.model == "axisymmetric":
            return ngs.CoefficientFunction((G[0, 0], G[1, 1], u[0] / ngs.x, G[0, 1] + G[1, 0]))
        return ngs.CoefficientFunction((G[0, 0], G[1, 1], G[0, 1] + G[1, 0]))

    def _cf_matrix(self, a: np.ndarray):
        return ngs.CoefficientFunction(tuple(float(v) for v in a.flatten()), dims=a.shape)

    def _cf_vector(self, a: np.ndarray):
        return ngs.CoefficientFunction(tuple(float(v) for v in a))

    def delta_T(self, name: str):
        if self.setup.temperature is None:
            return None
        return self.setup.temperature - self.setup.props[name].T0

    def _sigma0_vector(self):
        s0 = self.setup.initial_stress
        if s0 is None:
            return None
        m = [[f(self.t) for f in row] for row in s0]
        if self.setup.model == "3d":
            return ngs.CoefficientFunction((m[0][0], m[1][1], m[2][2], m[1][2], m[0][2], m[0][1]))
        if self.setup.model == "axisymmetric":
            return ngs.CoefficientFunction((m[0][0], m[1][1], m[0][0], m[0][1]))  # hoop = radial (isotropic)
        return ngs.CoefficientFunction((m[0][0], m[1][1], m[0][1]))

    def factor(self, name: str, e):
        """The secant factor lam (A1/A_ref + delta)^(lam - 1) of region ``name`` for the strain vector e."""
        p = self.setup.props[name]
        if p.lam == 1.0:
            return ngs.CoefficientFunction(1.0)
        return p.secant_factor(self.A1(name, e), self.setup.regularization)

    def A1(self, name: str, e):
        """A1 = e : c : e (Pa) of region ``name`` for the reduced strain vector e (2.2)."""
        return ngs.InnerProduct(e, self._cf_matrix(self.D[name]) * e)

    def stress_vector(self, name: str, u):
        """Reduced Voigt stress of region ``name`` (Pa), the law (2.18) with the lambda factor."""
        e = self.strain_vector(u)
        s = self.factor(name, e) * (self._cf_matrix(self.D[name]) * e)
        dT = self.delta_T(name)
        if dT is not None:
            s = s - dT * self._cf_vector(self.b[name])
        s0 = self._sigma0_vector()
        return s if s0 is None else s + s0

    # -- forms -----------------------------------------------------------------------------------------------
    def _loads(self, v, sign: float = 1.0):
        """The load terms (body forces, tractions, pressure) tested with v, each times ``sign``."""
        s, w = self.setup, sign * self.weight
        terms = []
        if s.gravity is not None:
            for name, p in s.props.items():
                if p.density:
                    g = ngs.CoefficientFunction(tuple(p.density * gi for gi in s.gravity[:self.dim]))
                    terms.append(w * g * v * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules))
        for name, comps in s.body_force.items():
            f = ngs.CoefficientFunction(tuple(fc(self.t) for fc in comps))
            terms.append(w * f * v * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules))
        n = ngs.specialcf.normal(self.dim)
        for name, comps in s.traction.items():
            P = ngs.CoefficientFunction(tuple(f(self.t) for f in comps))
            terms.append(w * P * v * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules))
        for name, f in s.pressure.items():
            terms.append(-w * f(self.t) * (n * v)
                         * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules))
        return terms

    def _build(self):
        s, w = self.setup, self.weight
        if self.oblique:
            trials, tests = self.X.TnT()
            u, v = trials[0], tests[0]
        else:
            u, v = self.X.TnT()
        # energy (Newton) -------------------------------------------------------------------------
        energy = 0
        for name, p in s.props.items():
            e = self.strain_vector(u)
            W = p.energy(self.A1(name, e), s.regularization)
            dT = self.delta_T(name)
            if dT is not None:
                W = W - dT * ngs.InnerProduct(self._cf_vector(self.b[name]), e)
            s0 = self._sigma0_vector()
            if s0 is not None:
                W = W + ngs.InnerProduct(s0, e)
            energy += w * W * ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules)
        for term in self._loads(u, -1.0):
            energy += term
        for k, (name, nvec) in enumerate(self.oblique):
            lam = trials[1 + k]
            nn = ngs.CoefficientFunction(tuple(float(c) for c in nvec[:self.dim]))
            energy += w * lam * (nn * u) * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules)
        self.newton_form = ngs.BilinearForm(self.X)
        self.newton_form += ngs.Variation(energy)
        # secant modules method: coefficients frozen at u_n (2.32)-(2.34) --------------------------------
        sec = ngs.BilinearForm(self.X)
        rhs = ngs.LinearForm(self.X)
        for name in s.props:
            D = self._cf_matrix(self.D[name])
            fac = self.linear_switch + (1 - self.linear_switch) * self.factor(name, self.strain_vector(self.u_frozen))
            mdx = ngs.dx(definedon=self.mesh.Materials(name), intrules=self.intrules)
            sec += w * fac * ngs.InnerProduct(D * self.strain_vector(u), self.strain_vector(v)) * mdx
            dT = self.delta_T(name)
            if dT is not None:
                rhs += w * dT * ngs.InnerProduct(self._cf_vector(self.b[name]), self.strain_vector(v)) * mdx
            s0 = self._sigma0_vector()
            if s0 is not None:
                rhs += -w * ngs.InnerProduct(s0, self.strain_vector(v)) * mdx
        for term in self._loads(v):
            rhs += term
        for k, (name, nvec) in enumerate(self.oblique):
            lam, mu = trials[1 + k], tests[1 + k]
            nn = ngs.CoefficientFunction(tuple(float(c) for c in nvec[:self.dim]))
            sec += (w * (lam * (nn * v) + mu * (nn * u))
                    * ngs.ds(definedon=self.mesh.Boundaries(name), intrules=self.bnd_intrules))
        self.secant_form, self.secant_rhs = sec, rhs

    def unheld_rigid_motions(self) -> list[str]:
        """The rigid motions the displacement and symmetry conditions do not hold (empty: all held).

        Each rigid motion of the model (plane: 2 translations and the rotation; axisymmetric: the axial
        translation; 3D: 3 translations and 3 rotations) is evaluated on the constrained dofs and, for oblique
        symmetry boundaries, as u.n there; the combinations vanishing on all of them are free. A mesh of several
        bodies (parts not joined by glued interfaces) is checked body by body (``'<motion> of body <regions>'``):
        a rigid motion of the whole mesh is held as soon as one body is, which left a second, unsupported body
        free (a singular system solved without a word).
        """
        if self._bodies()[0] > 1:
            return [f"{name} of body {'+'.join(fb.regions)}" for fb in self.floating_bodies() for name in fb.names]
        return self._unheld_whole_mesh()

    def _bodies(self):
        """(number of bodies, body label per vertex, volume elements): connected parts of the mesh."""
        from scipy.sparse.csgraph import connected_components
        mesh = self.mesh
        els = list(mesh.Elements(ngs.VOL))
        rows = [el.nr for el in els for _ in el.vertices]
        cols = [v.nr for el in els for v in el.vertices]
        inc = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(mesh.ne, mesh.nv))
        ncomp, labels = connected_components(inc.T @ inc, directed=False)
        return ncomp, labels, els

    def _unheld_whole_mesh(self) -> list[str]:
        modes = _rigid_modes(self.setup.model, self.dim)
        fixed = ~np.array(list(self.V.FreeDofs()), dtype=bool)
        g = ngs.GridFunction(self.V)
        oblique_points = []
        for name, nvec in self.oblique:
            pts = {v.nr: np.array(self.mesh[v].point) for el in self.mesh.Boundaries(name).Elements()
                   for v in el.vertices}
            oblique_points += [(p, nvec[:self.dim]) for p in pts.values()]
        columns = []
        for comps in modes.values():
            cf = ngs.CoefficientFunction(comps)
            g.Set(cf)
            col = list(g.vec.FV().NumPy()[fixed])
            for p, nvec in oblique_points:   # u.n = 0 at the vertices of oblique symmetry boundaries
                col.append(float(np.dot(np.array(cf(self.mesh(*p))).ravel(), nvec)))
            columns.append(col)
        return _free_combinations(np.array(columns, dtype=float).T, list(modes))[1]

    def floating_bodies(self) -> list[FloatingBody]:
        """The bodies (connected parts of the mesh: blocks joined by glued interfaces) with rigid motions the
        displacement and symmetry conditions do not hold: semi-coercive bodies that only contact can hold.

        Per body its regions, the names of its free rigid motions (rotations about the body's centroid) and
        their coefficient vectors in X (columns of ``modes``, zero outside the body)."""
        mesh, dim = self.mesh, self.dim
        ncomp, labels, els = self._bodies()
        if ncomp == 1 and not self._unheld_whole_mesh():
            return []
        fixed = ~np.array(list(self.V.FreeDofs()), dtype=bool)
        pts = np.array([mesh[ngs.NodeId(ngs.VERTEX, k)].point[:dim] for k in range(mesh.nv)])
        obl = [(k, nvec[:dim]) for name, nvec in self.oblique
               for k in {v.nr for el in mesh.Boundaries(name).Elements() for v in el.vertices}]
        g = ngs.GridFunction(self.V)
        out = []
        for b in range(ncomp):
            body_els = [el for el in els if labels[el.vertices[0].nr] == b]
            dofs = np.unique([d for el in body_els for d in self.V.GetDofNrs(el) if d >= 0])
            regions = sorted({el.mat for el in body_els})
            where = self.mesh.Materials(regions_regex(set(regions)))
            vol = ngs.Integrate(ngs.CoefficientFunction(1.0), self.mesh, definedon=where)
            c = np.array([ngs.Integrate(cx, self.mesh, definedon=where) / vol
                          for cx in (ngs.x, ngs.y, ngs.z)[:dim]])    # the centroid (moments about it)
            modes = _rigid_modes(self.setup.model, dim, c)
            vecs, cons = [], []
            bfixed = dofs[fixed[dofs]]
            for comps in modes.values():
                cf = ngs.CoefficientFunction(comps)
                g.Set(cf)
                v = np.zeros(self.X.ndof)
                v[dofs] = g.vec.FV().NumPy()[dofs]
                vecs.append(v)
                col = list(v[bfixed])
                for k, nvec in obl:
                    if labels[k] == b:
                        col.append(float(np.dot(np.array(cf(mesh(*pts[k]))).ravel(), nvec)))
                cons.append(col)
            null, names = _free_combinations(np.array(cons, dtype=float).T, list(modes))
            if len(null) == 0:
                continue
            R = np.array(vecs).T @ null.T
            out.append(FloatingBody(regions, names, R))
        return out

    def dirichlet_values(self):
        """Vector boundary CF of the prescribed displacements at the current time (free components 0)."""
        vals = {}
        for name, comps in self.setup.dirichlet.items():
            vals[name] = ngs.CoefficientFunction(tuple(f(self.t) if f is not None else 0.0 for f in comps))
        if not vals:
            return None
        return self.mesh.BoundaryCF(vals, default=ngs.CoefficientFunction((0.0,) * self.dim))

    # -- post-processing --------------------------------------------------------------------------------------
    def stress_tensor(self, u=None):
        """The full 3x3 stress tensor (Pa) as one CoefficientFunction over all regions: plane strain with
        sigma_zz (without an initial-stress part: sigma0 is given in-plane), plane stress with sigma_zz = 0,
        axisymmetric in (r, z, theta) axes."""
        u = u if u is not None else self.displacement()
        per_region = {}
        for name in self.setup.props:
            sv = self.stress_vector(name, u)
            m = self.setup.model
            if m == "3d":
                comps = (sv[0], sv[5], sv[4], sv[5], sv[1], sv[3], sv[4], sv[3], sv[2])
            elif m == "axisymmetric":
                comps = (sv[0], sv[3], 0, sv[3], sv[1], 0, 0, 0, sv[2])
            else:
                if m == "plane_strain":
                    row, bz = self.zz[name]
                    e = self.strain_vector(u)
                    szz = self.factor(name, e) * ngs.InnerProduct(self._cf_vector(np.asarray(row)), e)
                    dT = self.delta_T(name)
                    if dT is not None:
                        szz = szz - dT * float(bz)
                else:
                    szz = 0
                comps = (sv[0], sv[2], 0, sv[2], sv[1], 0, 0, 0, szz)
            per_region[name] = ngs.CoefficientFunction(tuple(ngs.CoefficientFunction(c) for c in comps),
                                                       dims=(3, 3))
        return self.mesh.MaterialCF(per_region, default=ngs.CoefficientFunction((0.0,) * 9, dims=(3, 3)))

    def strain_energy_density(self, u=None):
        """W of the elastic part (J/m^3): (A_ref/2)((A1/A_ref + delta)^lam - delta^lam), per region."""
        u = u if u is not None else self.displacement()
        vals = {}
        for name, p in self.setup.props.items():
            vals[name] = p.energy(self.A1(name, self.strain_vector(u)), self.setup.regularization)
        return self.mesh.MaterialCF(vals, default=0.0)


def stress_measures(sigma):
    """Von Mises stress, mean stress (Pa) and the principal stresses sigma_1 >= sigma_2 >= sigma_3 (Pa) of a
    3x3 stress CoefficientFunction."""
    s = sigma
    mean = (s[0, 0] + s[1, 1] + s[2, 2]) / 3
    dev = s - mean * ngs.Id(3)
    vm = ngs.sqrt(1.5 * ngs.InnerProduct(dev, dev))
    eig = s.Eig()
    return {"von_mises": vm, "mean_stress": mean, "sigma_1": eig[11], "sigma_2": eig[10], "sigma_3": eig[9]}
