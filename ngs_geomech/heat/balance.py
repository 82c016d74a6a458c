"""The energy balance of a heat run, body by body (:class:`HeatBalance`): what crosses each contact interface
appears as heat leaving one body and entering the other.

A body is a set of regions joined by shared vertices (glued interfaces); contact interfaces separate bodies.
Summing the equations of one theta step (:mod:`ngs_geomech.heat.forms`) over the vertex dofs of a body (the
test function 1 on the body; the higher-order dofs of the hierarchical basis have coefficient 0) leaves, with
the conduction terms summing to zero,

    int_b rho c (T1 - T0) dx = dt [ R_b + F_b - int_Robin,b h T_theta ds - sum_interfaces Q_out ],

R_b the heat the Dirichlet boundaries give (the residual of the step equations at the fixed dofs), F_b the
sources, fluxes, Robin ambient terms and deformation heating, T_theta = theta T1 + (1 - theta) T0 and Q_out the
heat flow from the body across each interface (contact conductance: int w q ds of the conductance law, master ->
minion; mortar: int w lambda ds). The gain on the left is integrated independently (the volume rule of the
forms), the interface flows from their own formula, so the balance checks that the flows reported are what
the discrete equations move. A steady solve is the same with dt = 1 s and no gain (a power balance, W).
Units: J (W for steady) per m of depth in plane scenes; axisymmetric scenes are integrated over 2 pi.
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .forms import HeatForms


def bodies(mesh) -> list[list[str]]:
    """The regions joined by shared vertices, as sorted lists (in the order of their first region)."""
    parent = {r: r for r in mesh.GetMaterials()}

    def find(r):
        while parent[r] != r:
            r = parent[r]
        return r
    owner: dict[int, str] = {}
    for el in mesh.Elements(ngs.VOL):
        for v in el.vertices:
            other = owner.setdefault(v.nr, el.mat)
            if other != el.mat:
                parent[find(other)] = find(el.mat)
    groups: dict[str, list[str]] = {}
    for r in dict.fromkeys(mesh.GetMaterials()):
        groups.setdefault(find(r), []).append(r)
    return [sorted(g) for g in groups.values()]


class HeatBalance:
    """Per step, per body: gain, Dirichlet heat, loads, Robin losses and interface heat (module docstring)."""

    def __init__(self, forms: HeatForms):
        self.f = forms
        mesh = forms.mesh
        self.bodies = bodies(mesh)
        self.labels = ["+".join(b) for b in self.bodies]
        region_body = {r: k for k, b in enumerate(self.bodies) for r in b}
        nV = forms.V.ndof
        self.masks = np.zeros((len(self.bodies), nV), dtype=bool)
        for el in mesh.Elements(ngs.VOL):
            self.masks[region_body[el.mat], [d for d in forms.V.GetDofNrs(el) if d >= 0]] = True
        self.fixed = ~np.array(list(forms.V.FreeDofs()), dtype=bool)
        # the test function 1 on a body: its coefficients are 1 at the vertex dofs and 0 at the higher-order ones
        # (NGSolve's hierarchical H1 basis), so the sums over a body weight the vertex dofs only
        ones = np.zeros(nV)
        for vert in mesh.vertices:
            ones[[d for d in forms.V.GetDofNrs(ngs.NodeId(ngs.VERTEX, vert.nr)) if d >= 0]] = 1.0
        self.weights = self.masks * ones
        self.side_body = {}
        for el in mesh.Elements(ngs.BND):
            if el.mat not in self.side_body:
                vol = mesh[mesh[el.vertices[0]].elements[0]]
                self.side_body[el.mat] = region_body[vol.mat]
        self.scale = 2 * math.pi if forms.setup.axisymmetric else 1.0
        T, v = forms.V.TnT()
        self.robin = None
        if forms.setup.robin:
            self.robin = ngs.BilinearForm(forms.V)
            self.robin += sum(forms.weight * h * T * v * ngs.ds(definedon=mesh.Boundaries(n))
                              for n, (h, _) in forms.setup.robin.items())
            self.robin.Assemble()
        self.steps: list[dict] = []

    def _gain(self, T1, T0) -> np.ndarray:
        f = self.f
        th = f.theta.Get()
        c = f.capacity(th * T1 + (1 - th) * T0) if f.setup.capacity_uses_temperature else f.rho_c
        return self._per_body(c * (T1 - T0))

    def _per_body(self, cf) -> np.ndarray:
        f = self.f
        order = 2 * f.setup.order + 1
        return np.array([self.scale * float(ngs.Integrate(f.weight * cf, f.mesh, order=order,
                                                          definedon=f.mesh.Materials("|".join(f"^{r}$" for r in b))))
                         for b in self.bodies])

    def contents(self, T) -> np.ndarray:
        """int_b rho c T dx per body (J; rho c at T when it depends on T), for the change of a mesh transfer."""
        f = self.f
        return self._per_body((f.capacity(T) if f.setup.capacity_uses_temperature else f.rho_c) * T)

    def record_transfer(self, moved: np.ndarray) -> None:
        """The heat content a transfer to another mesh changed per body (J): counted as a gain with its own term."""
        zero = np.zeros(len(self.bodies))
        self.steps.append({"gain": np.asarray(moved, dtype=float), "dirichlet": zero, "loads": zero, "robin": zero,
                           "interface": zero, "transfer": np.asarray(moved, dtype=float), "flows": {},
                           "steady": False})

    def measure(self, dt: float | None, flows: dict[str, tuple[str, str, float]]) -> dict:
        """The terms of the step just solved (for :meth:`record` once the step is kept): ``dt`` (s; None for a
        steady solve) and the interface flows of the step (name -> (master side, minion side, W master -> minion
        per m of depth or per radian, the step's theta average))."""
        f = self.f
        nV = f.V.ndof
        th = 1.0 if dt is None else f.theta.Get()
        res = f.gf.vec.CreateVector()
        rhs = f.right_hand_side()
        f.lhs.Apply(f.gf.vec, res)
        f.add_coupling(f.gf.vec, res)
        res.data -= rhs
        r = res.FV().NumPy()[:nV]
        loads = th * f.loads(f.t_new.Get()).FV().NumPy()[:nV]
        if dt is not None and th < 1:
            loads = loads + (1 - th) * f.loads(f.t_old.Get()).FV().NumPy()[:nV]
        if dt is not None and f.extra_load is not None:
            loads = loads + f.extra_load.FV().NumPy()[:nV]
        T1 = f.gf.vec.FV().NumPy()[:nV]
        T0 = f.gf_old.vec.FV().NumPy()[:nV]
        robin = np.zeros(nV)
        if self.robin is not None:
            Tt = th * T1 + (1 - th) * T0 if dt is not None else T1
            robin = self._apply(self.robin.mat, Tt)
        interface = np.zeros(len(self.bodies))
        per_itf = {}
        for name, (master, minion, q) in flows.items():
            a, b = self.side_body[master], self.side_body[minion]
            interface[a] -= q
            interface[b] += q
            per_itf[name] = q
        s = self.scale * (dt if dt is not None else 1.0)
        gain = (self._gain(f.temperature(), f.temperature(f.gf_old)) if dt is not None
                else np.zeros(len(self.bodies)))
        return {"gain": gain, "dirichlet": s * np.array([w[self.fixed] @ r[self.fixed] for w in self.weights]),
                "loads": s * (self.weights @ loads), "robin": s * (self.weights @ robin),
                "interface": s * interface, "flows": {k: s * v for k, v in per_itf.items()}, "steady": dt is None}

    def record(self, terms: dict) -> None:
        """Keep the terms of a step (:meth:`measure`)."""
        self.steps.append(terms)

    def as_data(self, n: int) -> list[dict]:
        """The first ``n`` steps' terms as JSON data (a checkpoint's)."""
        return [{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in s.items()} for s in self.steps[:n]]

    def from_data(self, data: list[dict]) -> None:
        """The steps' terms of :meth:`as_data` back."""
        self.steps[:] = [{k: (np.asarray(v, dtype=float) if isinstance(v, list) else v) for k, v in s.items()}
                         for s in data]

    @staticmethod
    def _apply(mat, x: np.ndarray) -> np.ndarray:
        vec = mat.CreateColVector()
        vec.FV().NumPy()[:] = x
        out = mat.CreateColVector()
        out.data = mat * vec
        return out.FV().NumPy().copy()

    def report(self) -> dict:
        """The summary block: per body the totals and the relative imbalance |gain - (dirichlet + loads - robin +
        interface)| / (the largest term), and the heat across each interface (master -> minion)."""
        if not self.steps:
            return {}
        steady = self.steps[-1]["steady"]
        steps = [s for s in self.steps if s["steady"] == steady]
        zero = np.zeros(len(self.bodies))
        total = {k: np.sum([s.get(k, zero) for s in steps], axis=0)
                 for k in ("gain", "dirichlet", "loads", "robin", "interface", "transfer")}
        out, worst = {}, 0.0
        for k, label in enumerate(self.labels):
            terms = [total[n][k] for n in ("gain", "dirichlet", "loads", "robin", "interface", "transfer")]
            scale = max(max(abs(t) for t in terms), 1e-300)
            imb = abs(terms[0] - terms[1] - terms[2] + terms[3] - terms[4] - terms[5]) / scale
            worst = max(worst, imb)
            out[label] = {"heat_gain": float(terms[0]), "dirichlet_heat": float(terms[1]),
                          "sources_fluxes": float(terms[2]), "robin_loss": float(terms[3]),
                          "interface_heat_in": float(terms[4]), "imbalance_rel": float(imb)}
            if any(("transfer" in s) for s in steps):
                out[label]["heat_transferred"] = float(terms[5])
        names = dict.fromkeys(n for s in steps for n in s["flows"])
        flows = {n: float(sum(s["flows"].get(n, 0.0) for s in steps)) for n in names}
        unit = ("W" if steady else "J") + (" per m of depth" if self.f.mesh.dim == 2 and not
                                           self.f.setup.axisymmetric else "")
        return {"units": unit, "bodies": out, "interface_heat": flows, "imbalance_rel": float(worst),
                "note": "per body: heat_gain = dirichlet_heat + sources_fluxes - robin_loss + interface_heat_in "
                        "(+ heat_transferred by mesh transfers); interface_heat: master -> minion"
                        + (" (steady: powers)" if steady else "")}
