"""Heat across contact interfaces on a distributed mesh (``mpiexec -n N``, N >= 2): the mortar coupling (perfect
contact) and the contact-conductance terms of :mod:`.forms` and :mod:`.interface_terms` in a global numbering, and
the solve of the step system that couples the parts' matrices through them.

The two sides of an interface are meshed independently, so a master element and the minion elements opposite may
lie on different parts. Each part integrates its own master elements (each element of the whole side by one part)
against the minion side gathered from all parts (:mod:`ngs_geomech.fem.gathered`), in the global numbering of
:class:`~ngs_geomech.parallel.GlobalDofs` of the temperature space; the parts' entries are then gathered, so every
rank holds the same interface operators (:class:`GlobalInterfaces`): the mortar matrix B (rows: the multipliers,
numbered after the nV global temperature dofs by the global temperature dof of their node on the master side) and
the conductance terms (:class:`.interface_terms.InterfaceTerms` over the joined quadrature, whose nodal matrix takes
the mechanics' nodal contact state in the same global vertex numbering).

The step system is then solved as the serial one is (:class:`GatheredSolve`): the serial heat path solves systems
with interfaces directly (the mortar saddle point and the conductance coupling are not SPD-by-construction CG
systems there either), so the parts' matrices (summing to the global matrix) and right-hand sides are gathered on
rank 0, which holds no elements, together with the interface matrix, factored there (UMFPACK, cached per time
step size as serially) and solved; the solution is sent back to every part. Memory and time of that factorization
are those of the serial heat solve with interfaces (the scalar heat system: a third of the elastic dofs in 3D).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import SolverError
from ..fem.gathered import gathered_boundary, owned_elements
from ..fem.interface_quadrature import interface_quadrature, join
from ..fem.mortar import Segment, Triangle, mortar_coupling_2d, mortar_coupling_3d
from ..linalg.direct import inverse, solve_watched


def _raise_collective(mesh, message: str | None) -> None:
    """Raise ValueError with the first message of any rank on every rank (None: no error here)."""
    errors = [m for m in parallel.allgather(mesh, message) if m]
    if errors:
        raise ValueError(errors[0])


class _Multipliers:
    """The multiplier space ``L`` of one mortar interface in the global numbering: ``nodes`` the sorted global
    temperature dofs of the master side's nodes (multiplier i sits on node ``nodes[i]``), ``local`` per local dof of
    L its global index (-1: not on this part's master elements), ``fixed`` the global indices reduced at cross
    points (not free on some part, :meth:`.forms.HeatForms._free_dofs`)."""

    def __init__(self, mesh, V, L, master: str, numbering, free: np.ndarray):
        els = [ngs.ElementId(ngs.BND, el.nr) for el in mesh.Boundaries(master).Elements()]
        mine = np.unique(np.concatenate([numbering.scalar[np.array(V.GetDofNrs(e), dtype=int)] for e in els])) \
            if els else np.zeros(0, dtype=np.int64)
        self.nodes = np.unique(np.concatenate([np.asarray(p, dtype=np.int64) for p in parallel.allgather(mesh, mine)]))
        self.local = np.full(L.ndof, -1, dtype=np.int64)
        for e in els:
            vd = numbering.scalar[np.array(V.GetDofNrs(e), dtype=int)]
            self.local[np.array(L.GetDofNrs(e), dtype=int)] = np.searchsorted(self.nodes, vd)
        held = self.local >= 0
        mine_fixed = self.local[held & ~free]
        self.fixed = np.unique(np.concatenate([np.asarray(p, dtype=np.int64)
                                               for p in parallel.allgather(mesh, mine_fixed)]))

    @property
    def size(self) -> int:
        return len(self.nodes)


class GlobalInterfaces:
    """The interface operators of the heat forms ``forms`` on a distributed mesh, the same on every rank (module
    docstring; collective): ``mortar_coo`` (COO arrays over the global state [T | multipliers], or None), ``terms``
    (the conductance terms, or None), ``size`` (global state size) and the maps between a part's state vector and
    the global state. Serves the heat forms as their interface numbering (:meth:`temperatures`, :meth:`add`)."""

    def __init__(self, forms):
        mesh, V, s = forms.mesh, forms.V, forms.setup
        self.mesh, self.nV_local = mesh, V.ndof
        self.numbering = parallel.GlobalDofs(V)
        self.nV = self.numbering.n_scalar
        free = np.array(list(forms.freedofs), dtype=bool)
        self.blocks = []                       # (local offset in X, global offset, _Multipliers)
        offset, goffset = V.ndof, self.nV
        for (master, _), L in zip(s.contacts, forms.multiplier_spaces):
            m = _Multipliers(mesh, V, L, master, self.numbering, free[offset:offset + L.ndof])
            self.blocks.append((offset, goffset, m))
            offset, goffset = offset + L.ndof, goffset + m.size
        self.size = goffset
        self._masses = None
        self._own: list[list[int]] = []        # per mortar interface: this part's master elements
        self.mortar_coo = self._mortar(forms) if s.contacts else None
        self.terms = self._terms(forms) if s.conductances else None
        self.free = np.concatenate([self.numbering.gather(free[:V.ndof].astype(float)) > 0.5,
                                    np.ones(self.size - self.nV, dtype=bool)])
        for _, g0, m in self.blocks:
            self.free[g0 + m.fixed] = False

    def _sides(self, master: str, minion: str, V):
        """(this part's master elements, the gathered minion side); ValueError on every rank when a side of the
        whole mesh has no elements."""
        own = owned_elements(self.mesh, master, self.numbering)
        minions = gathered_boundary(self.mesh, V, minion, self.numbering)
        if parallel.allsum(self.mesh, len(own)) == 0 or not minions:
            raise ValueError(f"contact interface sides {master!r} / {minion!r} have no boundary elements")
        return own, minions

    def _mortar(self, forms) -> tuple:
        """The symmetric mortar COO entries of all interfaces (rows and columns global), gathered."""
        mesh, V, s = self.mesh, forms.V, forms.setup
        rows, cols, vals = [], [], []
        message = None
        for (master, minion), L, merge, (_, g0, m) in zip(s.contacts, forms.multiplier_spaces, forms.merge,
                                                           self.blocks):
            own, minions = self._sides(master, minion, V)
            self._own.append(own)
            try:
                if mesh.dim == 2:
                    r, c, v = mortar_coupling_2d(mesh, V, L, master, minion, merge=merge,
                                                 axisymmetric=s.axisymmetric, order=2 * s.order, minions=minions,
                                                 numbering=self.numbering, elements=own)
                else:
                    r, c, v = mortar_coupling_3d(mesh, V, L, master, minion, order=s.order, minions=minions,
                                                 numbering=self.numbering, elements=own)
            except ValueError as exc:
                message, r, c, v = str(exc), np.zeros(0, int), np.zeros(0, int), np.zeros(0)
            r = g0 + m.local[r]
            rows += [r, c]
            cols += [c, r]
            vals += [v, v]
        _raise_collective(mesh, message)
        local = tuple(np.concatenate(a) for a in (rows, cols, vals))
        parts = parallel.allgather(mesh, local)
        return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))

    def _terms(self, forms):
        """The conductance terms over the joined quadratures of all parts."""
        from .interface_terms import InterfaceTerms

        mesh, V, s = self.mesh, forms.V, forms.setup
        quads = []
        for spec in s.conductances:
            own, minions = self._sides(spec.master, spec.minion, V)
            message, q = None, None
            try:
                q = interface_quadrature(mesh, V, spec.master, spec.minion, order=2 * s.order + 2,
                                         axisymmetric=s.axisymmetric, reach=spec.reach, minions=minions,
                                         numbering=self.numbering, elements=own)
            except ValueError as exc:
                message = str(exc)
            _raise_collective(mesh, message)
            quads.append(join(parallel.allgather(mesh, q)))
        return InterfaceTerms(mesh, V, s.conductances, order=s.order, axisymmetric=s.axisymmetric, ndof=self.size,
                              quadratures=quads, sizes=(self.nV, self.nV))

    @property
    def mortar(self):
        """The mortar matrix over the global state (an NGSolve matrix), or None."""
        if self.mortar_coo is None:
            return None
        r, c, v = self.mortar_coo
        return ngs.la.SparseMatrixd.CreateFromCOO(list(map(int, r)), list(map(int, c)), list(map(float, v)),
                                                  self.size, self.size)

    # -- the heat forms' interface numbering ------------------------------------------------------------------------
    def temperatures(self, vec) -> np.ndarray:
        """The global temperature dofs (nV,) of a state vector (cumulated) of the forms' space (collective)."""
        return self.numbering.gather(vec.FV().NumPy()[:self.nV_local])

    def add(self, b, values: np.ndarray) -> None:
        """Add the global temperature-dof values ``values`` (nV,) to the right-hand side ``b`` (made distributed:
        each global dof added once, at the part that owns it)."""
        if b.GetParallelStatus() == ngs.la.PARALLEL_STATUS.CUMULATED:
            b.Distribute()
        arr = b.FV().NumPy()[:self.nV_local]
        own = self.numbering.owned
        arr[own] += values[self.numbering.scalar[own]]

    def mortar_flows(self, forms, total: bool) -> list[float]:
        """The flows int w lambda ds over each mortar interface (W per m of depth or per radian; with ``total`` in
        axisymmetric scenes over 2 pi, W): the multipliers against their integrals int w mu_i ds (collective)."""
        if self._masses is None:
            self._masses = [self._multiplier_integrals(forms, L, own, g0, m)
                            for L, own, (_, g0, m) in zip(forms.multiplier_spaces, self._own, self.blocks)]
        x = self.state(forms.gf.vec)
        scale = 2 * np.pi if total and forms.setup.axisymmetric else 1.0
        return [scale * float(mass @ x) for mass in self._masses]

    def _multiplier_integrals(self, forms, L, own: list[int], g0: int, m: _Multipliers) -> np.ndarray:
        """The integrals int w mu_i ds of one interface's multipliers over the global state (Gauss rules exact for
        straight elements: degree p, times r in axisymmetric scenes)."""
        out = np.zeros(self.size)
        p, axi = forms.setup.order, forms.setup.axisymmetric
        if self.mesh.dim == 2:
            gx, gw = np.polynomial.legendre.leggauss(p + 2)
            for nr in own:
                sg = Segment(self.mesh, L, nr)
                idx = g0 + m.local[np.array(sg.dofs, dtype=int)]
                for x, w in zip((gx + 1) / 2, gw / 2):
                    r = sg.point(x)[0] if axi else 1.0
                    np.add.at(out, idx, w * sg.speed(x) * r * sg.shape(x))
        else:
            ir = ngs.IntegrationRule(ngs.TRIG, p + 2)
            for nr in own:
                tr = Triangle(self.mesh, L, nr)
                idx = g0 + m.local[np.array(tr.dofs, dtype=int)]
                for pt, w in zip(ir.points, ir.weights):
                    np.add.at(out, idx, w * tr.area2 * np.array(tr.fe.CalcShape(pt[0], pt[1])))
        return parallel.allsum(self.mesh, out)

    # -- gathering and scattering ---------------------------------------------------------------------------------
    def state(self, vec) -> np.ndarray:
        """The global state (size,) of a (cumulated) state vector: temperatures and multipliers (collective)."""
        arr = vec.FV().NumPy()
        out = np.full(self.size, np.nan)
        out[:self.nV] = self.temperatures(vec)
        mult = np.full(self.size - self.nV, np.nan)
        for off, g0, m in self.blocks:
            held = m.local >= 0
            mult[g0 - self.nV + m.local[held]] = arr[off:off + len(m.local)][held]
        mult = parallel.first_valid(self.mesh, mult[None, :])[0]
        out[self.nV:] = np.where(np.isnan(mult), 0.0, mult)       # (no part holds it: never set, 0)
        return out

    def scatter(self, x: np.ndarray, vec) -> None:
        """Put the global state ``x`` into this part's (cumulated) state vector ``vec``."""
        arr = vec.FV().NumPy()
        arr[:self.nV_local] = x[self.numbering.scalar]
        for off, g0, m in self.blocks:
            held = np.nonzero(m.local >= 0)[0]
            arr[off + held] = x[g0 + m.local[held]]
        vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)

    def local_entries(self, mat) -> tuple:
        """This part's entries of the assembled (distributed) step matrix ``mat`` on the temperature dofs, in the
        global numbering (the parts' entries sum to the global matrix)."""
        r, c, v = (np.asarray(a) for a in mat.local_mat.COO())
        keep = (r < self.nV_local) & (c < self.nV_local)
        sc = self.numbering.scalar
        return sc[r[keep].astype(int)], sc[c[keep].astype(int)], v[keep].astype(float)

    def local_load(self, rhs) -> tuple:
        """This part's (distributed) entries of the right-hand side on the temperature dofs: (global dofs, values)."""
        if rhs.GetParallelStatus() == ngs.la.PARALLEL_STATUS.CUMULATED:
            w = rhs.CreateVector()
            w.data = rhs
            w.Distribute()
            rhs = w
        return self.numbering.scalar, rhs.FV().NumPy()[:self.nV_local].copy()


class GatheredSolve:
    """The step solve of heat forms with contact interfaces on a distributed mesh (module docstring): the global
    system gathered on rank 0, factored there (the last two step operators kept, as serially) and solved; every
    rank gets the solution. ``symmetric``: factor by sparse Cholesky (else UMFPACK). Steps that need Newton's
    method (k(T), exact radiation) take :meth:`newton`."""

    def __init__(self, forms, symmetric: bool = False):
        self.f = forms
        self.symmetric = symmetric
        self.comm = parallel.comm(forms.mesh)
        self.keys: list[str] = []
        self._factors: dict[str, tuple] = {}       # rank 0: key -> (matrix, inverse)
        self._tmp = ngs.GridFunction(forms.X).vec
        self._out = self._tmp.CreateVector()

    def forget(self) -> None:
        self.keys.clear()
        self._factors.clear()

    def solve(self, where: str, rhs) -> bool:
        """Solve the step (t_new, inv_dt, theta and the Dirichlet values already set) into the forms' state; returns
        whether the step operator was assembled and factored anew (collective)."""
        f, g = self.f, self.f.interface_dofs
        key = f"{f.inv_dt.Get():.14g}:{f.theta.Get():g}:{f.version}"
        fresh = key not in self.keys
        root = self.comm.rank == 0
        message = None
        if fresh:
            f.lhs.Assemble()
            parts = self.comm.gather(g.local_entries(f.lhs.mat), root=0)
            coupling = f.coupling
            if root:
                message = self._factor(key, parts, coupling, g)
            self.keys.append(key)
            if len(self.keys) > 2:
                self._factors.pop(self.keys.pop(0), None)
        loads = self.comm.gather(g.local_load(rhs), root=0)
        x = g.state(f.gf.vec)
        if root and message is None:
            x, message = self._solve(key, loads, x, g, where)
        x, message = self.comm.bcast((x, message), root=0)
        if message is not None:
            raise SolverError(message)
        g.scatter(x, f.gf.vec)
        return fresh

    def _factor(self, key: str, parts: list, coupling, g) -> str | None:
        """Rank 0: the global step matrix from the parts' entries and the interface matrix, factored."""
        r, c, v = (np.concatenate([p[k] for p in parts]) for k in range(3))
        if coupling is not None:
            r2, c2, v2 = (np.asarray(a) for a in coupling.COO())
            r, c, v = np.concatenate([r, r2]), np.concatenate([c, c2]), np.concatenate([v, v2])
        mat = ngs.la.SparseMatrixd.CreateFromCOO(list(map(int, r)), list(map(int, c)), list(map(float, v)), g.size,
                                                 g.size)
        try:
            inv = inverse(mat, ngs.BitArray(g.free.tolist()), self.symmetric, "heat solve with contact interfaces")
        except SolverError as exc:
            return str(exc)
        self._factors[key] = (mat, inv)
        return None

    def _solve(self, key: str, loads: list, x: np.ndarray, g, where: str):
        """Rank 0: (the global solution, None) or (None, the error message)."""
        mat, inv = self._factors[key]
        b = mat.CreateColVector()
        bv = b.FV().NumPy()
        bv[:] = 0.0
        for idx, vals in loads:
            np.add.at(bv, np.asarray(idx, dtype=int), vals)
        xv = mat.CreateColVector()
        xv.FV().NumPy()[:] = x
        try:
            solve_watched(mat, inv, b, xv, g.free, f"heat solve at {where}",
                          "Check the material data and boundary conditions of the scene (conductivity contrasts "
                          "beyond 1e12, time steps far below the diffusion time of an element).")
        except SolverError as exc:
            return None, str(exc)
        return xv.FV().NumPy().copy(), None

    # -- Newton's method (k(T), exact radiation) ----------------------------------------------------------------
    def newton(self, where: str, rhs, tol: float, maxit: int) -> tuple[int, float, tuple]:
        """Newton's method of the serial heat solver (:meth:`.solver.HeatSolver._newton`: the residual with the
        interface terms, a backtracking line search) on the global state: the parts' residuals and tangents gathered
        on rank 0, which adds the interface terms, factors the tangent and takes the line search's decisions, which
        every rank follows (collective). Returns (iterations = factorizations, relative residual, its history); the
        state is put into the forms'."""
        f, g = self.f, self.f.interface_dofs
        root = self.comm.rank == 0
        loads = self.comm.gather(g.local_load(rhs), root=0)
        b = self._vector(g, loads) if root else None
        x = g.state(f.gf.vec)
        r0, res = self._residual(x, b)
        scale = self.comm.bcast(max(r0, float(np.linalg.norm(b.FV().NumPy())), 1e-300) if root else None, root=0)
        rel, history, it = r0 / scale, [r0 / scale], 0
        while rel > tol:
            if it >= maxit:
                raise SolverError(f"Newton for the k(T) heat problem at {where} did not converge in {maxit} "
                                  f"iterations (relative residual {rel:.3e}). Reduce the time step or check that "
                                  "kappa(T) stays positive.")
            du = self._tangent_solve(x, res)
            step, new_rel = 1.0, math.inf
            while step > 1e-4:
                trial = x - step * du if root else None
                rn, res_t = self._residual(trial, b)
                new_rel = rn / scale
                if math.isfinite(new_rel) and new_rel < (1 - 1e-4 * step) * rel:
                    break
                step /= 2
            if not math.isfinite(new_rel) or new_rel >= rel:
                if rel < 1e3 * tol:
                    break
                raise SolverError(f"Newton for the k(T) heat problem at {where} stagnated at relative residual "
                                  f"{rel:.3e}. Reduce the time step or check kappa(T) > 0.")
            x, res, rel = self._x, res_t, new_rel
            history.append(rel)
            it += 1
        g.scatter(x, f.gf.vec)
        return it, rel, tuple(history)

    def _vector(self, g, parts: list):
        """Rank 0: the global vector (an NGSolve vector of the state's size) of the parts' distributed entries."""
        v = ngs.la.BaseVector(g.size)
        arr = v.FV().NumPy()
        arr[:] = 0.0
        for idx, vals in parts:
            np.add.at(arr, np.asarray(idx, dtype=int), vals)
        return v

    def _residual(self, x, b) -> tuple[float, object]:
        """The norm of the residual lhs(x) + interface terms(x) - b on the free dofs, on every rank, and (rank 0)
        the residual; ``x`` (rank 0's) is sent to every rank and kept as ``self._x``."""
        f, g = self.f, self.f.interface_dofs
        x = self.comm.bcast(x, root=0)
        self._x = x
        g.scatter(x, self._tmp)
        f.lhs.Apply(self._tmp, self._out)
        parts = self.comm.gather(g.local_load(self._out), root=0)
        norm, res = None, None
        if self.comm.rank == 0:
            res = self._vector(g, parts)
            xv = self._vector(g, [(np.arange(g.size), x)])
            f.add_coupling(xv, res)
            res.data -= b
            arr = res.FV().NumPy()
            arr[~g.free] = 0.0
            norm = float(np.linalg.norm(arr))
        return self.comm.bcast(norm, root=0), res

    def _tangent_solve(self, x: np.ndarray, res) -> np.ndarray | None:
        """Rank 0: the Newton correction J^-1 res, J the tangent at ``x`` (the parts' linearizations and the
        interface terms' derivative); None elsewhere. A failed factorization raises on every rank."""
        f, g = self.f, self.f.interface_dofs
        g.scatter(x, self._tmp)
        f.lhs.AssembleLinearization(self._tmp)
        parts = self.comm.gather(g.local_entries(f.lhs.mat), root=0)
        du, message = None, None
        if self.comm.rank == 0:
            jac = f.coupling_jacobian(self._vector(g, [(np.arange(g.size), x)]))
            message = self._factor("tangent", parts, jac, g)
            if message is None:
                mat, inv = self._factors.pop("tangent")
                d = res.CreateVector()
                d.data = inv * res
                du = d.FV().NumPy().copy()
        message = self.comm.bcast(message, root=0)
        if message is not None:
            raise SolverError(message)
        return du
