"""Performance of the frictional contact solvers: semi-smooth Newton / active-set iterations, factorizations and
wall time against one linear elastic solve on the same mesh, and the seed's Uzawa method (2.66) as the reference.

Physics. Plane strain, P2, both problems of :mod:`ngs_geomech.verification.contact_problems`:
(1) Hertz line contact, frictionless (:func:`hertz`: a quarter cylinder R = 1 m, E = 200 GPa, nu = 0.3 on a
rigid flat, a = R/50, held vertically by the contact alone), refined as h_contact = a/5 / 2^k on the contact
arc and maxh = R/4 / 2^k elsewhere; the p0 relative error against the closed form. (2) Two elastic blocks with
Coulomb friction F_c = 0.3 (:func:`two_blocks_coulomb`): a lower block 1 m x 0.5 m fixed at its base, an upper
one meshed independently (non-matching, 0.7 h) and held by the contact alone, top pressure 5 MPa and a
left-side push at 0.7 of the friction capacity: a slip zone between two stick zones at every h (h = 0.16 / 2^k
m). (3) The seed's Uzawa algorithm (:class:`UzawaSolver`, tol 1e-10) on problem (2) on the coarse meshes: its
outer steps grow like L / h for a fixed step rho = 1.0 x modulus / L (the solver's default factor 2 does not
converge on two elastic bodies, which are more compliant than one on a rigid foundation).

Per level: dofs, Newton (active-set) iterations, factorizations, the contact solve's wall and CPU time (the
solver only: no assembly, no contact operators), and in the same run the time of ONE linear elastic solve on
the same mesh: K (with the contact solver's shift 1e-10 x mean diagonal on the free dofs of the floating body,
without which K is singular) factored on the free dofs plus one solve, by NGSolve's sparsecholesky, UMFPACK and
PARDISO's Cholesky with minimum degree and with METIS ordering; assembly is counted on neither side. The contact
solver is the product's default (``ContactSolver(linear="auto")``: the condensed solver of
:mod:`ngs_geomech.contact.condensed` when PARDISO is installed); the sparse saddle-point path
(``linear="direct"``) runs once per mesh beside it. Each cold contact solve and each linear solve is timed
``repeats`` times per mesh and the fastest kept (single samples vary on a shared machine). The headline ratio
(``time_ratio_*``, finest level) is the contact solve over the FASTEST of the four linear solves, so the contact
solve gains nothing from a faster library than the reference's; ``*_vs_sparsecholesky`` is the ratio against
the product's ElasticSolver, ``*_cpu`` the same in CPU time. One NGSolve thread, one MKL thread and one thread in
every loaded OpenBLAS (:func:`single_threaded_blas`) on both sides: spinning BLAS threads make direct solvers
several times slower on a loaded machine.

Targets, reported and not gated: at most 15 Newton iterations at every level (``target_newton_iterations_met``);
time ratio at most 2 frictionless and 3 with friction at the finest level (``target_time_ratio_*_met``). Level 0
is too small for the ratios to mean much (fixed costs dominate); the targets refer to level 1.

Command: ``python studies/contact_performance/run.py --level 1 --out out/contact_performance`` (writes
``results.json``; prints the tables). Levels: 0 Hertz k = 1, 3 (up to 13k dofs), blocks h = 0.16, 0.04 (9.6k),
Uzawa at h = 0.16; 1 Hertz k = 0 ... 5 (140k), blocks down to h = 0.01 (148k), Uzawa down to h = 0.04; 2 as 1
with Uzawa also at h = 0.02 (37k dofs).

Cost on one thread: level 0 a few seconds, level 1 about 3 minutes, level 2 about 6 minutes (most of it Uzawa).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import gc
import math
import time
from pathlib import Path

import ngsolve as ngs
import numpy as np
import scipy.linalg  # noqa: F401  (loads scipy's OpenBLAS before single_threaded_blas; linprog uses it)
import scipy.optimize  # noqa: F401
import scipy.sparse as sp

from ngs_geomech.contact.uzawa import UzawaSolver
from ngs_geomech.linalg import pardiso
from ngs_geomech.mechanics.materials import isotropic
from ngs_geomech.verification import contact_problems as cp
from ngs_geomech.verification.study import convergence_entry, metrics_lines, one_ngsolve_thread, study_cli, study_main

STUDY = "contact_performance"
LEVELS = {
    0: {"hertz_k": (1, 3), "blocks_h": (0.16, 0.04), "uzawa_h": (0.16,), "repeats": 1},
    1: {"hertz_k": (0, 1, 2, 3, 4, 5), "blocks_h": (0.16, 0.08, 0.04, 0.02, 0.01), "uzawa_h": (0.16, 0.08, 0.04),
        "repeats": 3},
    2: {"hertz_k": (0, 1, 2, 3, 4, 5), "blocks_h": (0.16, 0.08, 0.04, 0.02, 0.01),
        "uzawa_h": (0.16, 0.08, 0.04, 0.02), "repeats": 3},
}
"""Per level: the Hertz refinements k (h_contact = a/5 / 2^k, maxh = R/4 / 2^k), the block mesh sizes (m) of
the Newton runs and those of the (slow) Uzawa runs, and the cold contact solves and linear solves timed per
mesh (the fastest of each kept: the machine is shared)."""
ORDER = 2
FRICTION = 0.3
RATIO = 0.7
"""Coulomb coefficient and the push of the blocks as a fraction of the friction capacity."""
WARM_LOAD_FACTOR = 1.02
"""The load of the warm solve (the next step of a load or time history): 2 % more than the first."""
UZAWA_RHO_FACTOR = 1.0
UZAWA_TOL = 1e-10
UZAWA_MAXIT = 3000
LINEAR = "condensed" if pardiso.available() else "direct"
"""The contact solver's linear algebra (ContactSolver(linear=)): the condensed solver when PARDISO is installed."""
TARGET_NEWTON = 15
TARGET_RATIO_FRICTIONLESS = 2.0
TARGET_RATIO_COULOMB = 3.0


class _Timed:
    """A contact solver wrapper that also measures the CPU time of ``solve`` (process time: with one thread
    the work done, whatever else runs on the machine) and keeps the solver for its multipliers, and how it was
    built (for the repeated cold solves)."""

    def __init__(self, factory, interfaces, **kw):
        self.inner = factory(interfaces, **kw)
        self.factory, self.interfaces, self.kw = factory, interfaces, kw
        self.cpu_s = math.nan

    @property
    def multipliers(self):
        return self.inner.multipliers

    def solve(self, *args, **kw):
        c0 = time.process_time()
        out = self.inner.solve(*args, **kw)
        self.cpu_s = time.process_time() - c0
        return out


def _factory(store: dict, base):
    def make(interfaces, **kw):
        store["solver"] = _Timed(base, interfaces, **kw)
        return store["solver"]
    return make


def linear_solve_time(system: dict, repeats: int = 1) -> dict:
    """One linear elastic solve with the assembled K of a contact problem: factor K on the free dofs and solve once
    for the load, by NGSolve's sparsecholesky (the product's ElasticSolver), UMFPACK, and PARDISO's Cholesky with
    its two orderings (minimum degree, METIS: :class:`ngs_geomech.linalg.pardiso.SchurFactorization` without a
    Schur set, from K's COO as the condensed contact solver builds it); the floating body's free dofs get the
    contact solver's shift (1e-10 x their mean diagonal entry), without which K is singular. Each is timed
    ``repeats`` times and the fastest kept (the machine is shared). Returns wall and CPU seconds (factor + solve)
    per method, "best" (the fastest of all: the reference of the ratios) and the relative residual of the
    Cholesky solve."""
    K, free, f, x0 = system["matrix"], system["free"], np.asarray(system["rhs"]), system["x0"]
    n = len(x0)
    kr, kc, kv = (np.asarray(a) for a in K.COO())
    kr, kc, kv = kr.astype(np.int64), kc.astype(np.int64), np.array(kv, dtype=float)
    mask = np.zeros(n, dtype=bool)
    for body in system["floating"]:
        mask |= np.any(np.abs(body.modes[:n]) > 0, axis=1)
    reg = np.where(mask & free)[0]
    d = kr == kc
    diag = np.zeros(n)
    np.add.at(diag, kr[d], kv[d])
    eps = 1e-10 * float(np.mean(np.abs(diag[reg]))) if len(reg) else 0.0
    shift = np.zeros(n)
    shift[reg] = eps
    kv[d] += shift[kr[d]]
    A = ngs.la.SparseMatrixd.CreateFromCOO(kr, kc, kv, n, n)
    fd = ngs.BitArray(free.tolist())
    x = A.CreateColVector()
    x.FV().NumPy()[:] = x0
    r = A.CreateColVector()
    r.data = A * x
    r.FV().NumPy()[:] = (f - r.FV().NumPy()) * free
    out = {"shift": eps}

    def keep(name, wall, cpu):
        old = out.get(name)
        if old is None or wall < old["wall_s"]:
            out[name] = {"wall_s": wall, "cpu_s": cpu}

    for _ in range(repeats):
        for name in ("sparsecholesky", "umfpack"):
            dx = A.CreateColVector()
            gc.collect()
            t0, c0 = time.perf_counter(), time.process_time()
            inv = A.Inverse(fd, inverse=name)
            dx.data = inv * r
            keep(name, time.perf_counter() - t0, time.process_time() - c0)
            if name == "sparsecholesky":
                y = A.CreateColVector()
                y.data = x + dx
                res = A.CreateColVector()
                res.data = A * y
                out["residual"] = float(np.linalg.norm((f - res.FV().NumPy()) * free) / np.linalg.norm(f * free))
            del inv
        if pardiso.available():
            for ordering in ("mmd", "metis"):
                gc.collect()
                t0, c0 = time.perf_counter(), time.process_time()
                fi = np.nonzero(free)[0]
                loc = np.full(n, -1, dtype=np.int64)
                loc[fi] = np.arange(len(fi))
                up = free[kr] & free[kc] & (kr <= kc)
                U = sp.csr_matrix((kv[up], (loc[kr[up]], loc[kc[up]])), shape=(len(fi), len(fi)))
                fac = pardiso.SchurFactorization(U, upper=True, ordering=ordering)
                fac.solve(np.asarray(r.FV().NumPy())[fi])
                keep(f"pardiso_{ordering}", time.perf_counter() - t0, time.process_time() - c0)
                fac.close()
    best = min((v for k, v in out.items() if isinstance(v, dict)), key=lambda v: v["wall_s"])
    out["best"] = dict(best, name=next(k for k, v in out.items() if v is best))
    return out


def _pos(t: float) -> float:
    """A time to divide by (never 0)."""
    return max(t, 1e-9)


def _row(r: dict, store: dict, lin: dict, wall_total: float, cold: dict) -> dict:
    """One level's figures: the cold contact solve (the fastest of the repeats, ``cold``) against the fastest linear
    solve (``lin["best"]``), and against sparsecholesky and UMFPACK."""
    ch, um, best = lin["sparsecholesky"], lin["umfpack"], lin["best"]
    wall, cpu = cold["wall_s"], cold["cpu_s"]
    return {"ndof": r["ndof"], "iterations": r["iterations"], "factorizations": r["factorizations"],
            "penalty_iterations": r["penalty_iterations"], "wall_s": wall, "cpu_s": cpu,
            "wall_samples_s": cold["samples"], "linear": best["name"],
            "linear_wall_s": best["wall_s"], "linear_cpu_s": best["cpu_s"],
            "sparsecholesky_wall_s": ch["wall_s"], "umfpack_wall_s": um["wall_s"],
            "pardiso_wall_s": min((lin[k]["wall_s"] for k in ("pardiso_mmd", "pardiso_metis") if k in lin),
                                  default=math.nan),
            "ratio": wall / _pos(best["wall_s"]), "ratio_cpu": cpu / _pos(best["cpu_s"]),
            "ratio_sparsecholesky": wall / _pos(ch["wall_s"]), "ratio_umfpack": wall / _pos(um["wall_s"]),
            "linear_residual": lin["residual"], "condensed_dofs": cold["condensed_dofs"],
            "candidate_passes": cold["candidate_passes"], "fallback": cold["fallback"],
            "run_s": wall_total}


def _cold_samples(store: dict, system: dict, first: dict, repeats: int) -> dict:
    """The fastest of ``repeats`` cold solves (the first, ``first``, from the problem's own run; the others with a
    fresh solver built alike): wall and CPU seconds, the samples, the condensed solver's figures."""
    timed = store["solver"]
    info = timed.inner.infos[-1]
    walls, cpus = [first["wall_s"]], [timed.cpu_s]
    for _ in range(repeats - 1):
        solver = timed.factory(timed.interfaces, **timed.kw)
        gc.collect()
        c0 = time.process_time()
        _, inf = solver.solve(system["matrix"], system["rhs"], system["free"], system["x0"], "again")
        walls.append(inf.wall_s)
        cpus.append(time.process_time() - c0)
        del solver
    k = int(np.argmin(walls))
    return {"wall_s": walls[k], "cpu_s": cpus[k], "samples": walls, "condensed_dofs": info.condensed_dofs,
            "candidate_passes": info.candidate_passes, "fallback": bool(info.condensed_fallback)}


def _direct(store: dict, system: dict) -> dict:
    """The same cold solve by the sparse direct path (ContactSolver(linear="direct")), for comparison."""
    timed = store["solver"]
    kw = dict(timed.kw, linear="direct")
    solver = cp.ContactSolver(timed.interfaces, **kw)
    gc.collect()
    _, info = solver.solve(system["matrix"], system["rhs"], system["free"], system["x0"], "direct")
    return {"direct_wall_s": info.wall_s, "direct_iterations": info.iterations,
            "direct_factorizations": info.factorizations}


def _loaded_openblas() -> list[str]:
    """The OpenBLAS libraries loaded in this process (Linux: from /proc/self/maps; elsewhere none)."""
    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower()}
    except OSError:
        return []
    return sorted(p for p in paths if p.startswith("/"))


@contextlib.contextmanager
def single_threaded_blas():
    """Set every loaded OpenBLAS (NGSolve's, under UMFPACK; numpy's; scipy's) to one thread, restored on exit;
    yields the number of libraries changed. Extra BLAS threads cost CPU time for no gain here, and on a loaded
    machine their spinning makes UMFPACK several times slower."""
    changed = []
    for path in _loaded_openblas():
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix, suffix in (("openblas", ""), ("scipy_openblas", "64_"), ("scipy_openblas", "")):
            setter, getter = getattr(lib, f"{prefix}_set_num_threads{suffix}", None), \
                getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
            if setter is not None and getter is not None:
                changed.append((setter, int(getter())))
                setter(1)
                break
    try:
        yield len(changed)
    finally:
        for setter, old in changed:
            setter(old)


def _level(solve, extra, repeats: int = 1) -> tuple[dict, list]:
    """One level of the ssn runs: ``solve(solver_factory)`` returns the problem's dict with its "system", timed
    against one linear solve; the row (with ``extra(result)``) and the contact solver's multipliers."""
    t0 = time.perf_counter()
    store: dict = {}
    r = solve(_factory(store, functools.partial(cp.ContactSolver, linear=LINEAR)))
    system = r.pop("system")
    multipliers = [np.array(v) for v in store["solver"].multipliers[0]]
    cold = _cold_samples(store, system, r, repeats)
    lin = linear_solve_time(system, repeats)
    row = _row(r, store, lin, 0.0, cold)
    row.update(extra(r))
    row.update(_warm(store["solver"], system, lin))
    row.update(_direct(store, system))
    del r, store, lin
    gc.collect()
    row["run_s"] = time.perf_counter() - t0
    return row, multipliers


def _warm(solver, system: dict, lin: dict) -> dict:
    """A warm solve, as in a quasi-static time series or the secant loop of the lambda law: the same solver
    instance (its contact sets kept) on the load scaled by WARM_LOAD_FACTOR; its iterations, factorizations,
    wall time and ratio to the linear solve."""
    t0 = time.perf_counter()
    _, info = solver.solve(system["matrix"], WARM_LOAD_FACTOR * np.asarray(system["rhs"]), system["free"],
                           system["x0"], "warm")
    wall = time.perf_counter() - t0
    return {"warm_iterations": info.iterations, "warm_factorizations": info.factorizations, "warm_wall_s": wall,
            "warm_ratio": wall / _pos(lin["best"]["wall_s"])}


def _ratio_entry(name: str, rows: list) -> dict:
    """The convergence entry of the time ratios of a sequence of levels (no order expected)."""
    return convergence_entry(name, [row["h"] for row in rows], [row["ndof"] for row in rows],
                             [row["ratio"] for row in rows], None,
                             note="contact solve wall time / the fastest linear solve (factor + solve of K)",
                             **{key: [row[key] for row in rows] for key in
                                ("wall_s", "linear_wall_s", "linear", "ratio_cpu", "cpu_s", "linear_cpu_s",
                                 "sparsecholesky_wall_s", "ratio_sparsecholesky", "pardiso_wall_s",
                                 "umfpack_wall_s", "ratio_umfpack", "direct_wall_s", "condensed_dofs")})


def run(level: int) -> tuple[dict, dict]:
    """The results dict of ``level`` and the per-level rows (for the report), on one NGSolve thread and one BLAS
    thread (:func:`single_threaded_blas`), both restored afterwards."""
    if level not in LEVELS:
        raise ValueError(f"level must be one of {sorted(LEVELS)}, got {level}")
    with one_ngsolve_thread(), single_threaded_blas() as n_blas:
        result, tables = _run(level)
    result["blas_libraries_single_threaded"] = n_blas
    return result, tables


def _run(level: int) -> tuple[dict, dict]:
    p = LEVELS[level]
    t_start = time.perf_counter()
    timing: dict[str, float] = {}
    metrics: dict[str, float] = {}
    convergence: list[dict] = []
    tables: dict = {"hertz": [], "blocks": [], "uzawa": []}

    # (1) Hertz, frictionless
    a = cp.R_HERTZ / 50
    tic = time.perf_counter()
    for k in p["hertz_k"]:
        row, _ = _level(lambda factory, k=k: cp.hertz(a / 5 / 2 ** k, ORDER, maxh=cp.R_HERTZ / 4 / 2 ** k,
                                                      return_system=True, solver_factory=factory),
                        lambda r, k=k: dict(k=k, h=a / 5 / 2 ** k, maxh=cp.R_HERTZ / 4 / 2 ** k,
                                            p0_rel_error=r["p0_rel_error"], a_error_over_h=r["a_error"] / r["h"],
                                            force_balance=r["force_balance"], max_penetration=r["max_penetration"]),
                        p["repeats"])
        timing[f"hertz_k{k}_s"] = row["run_s"]
        tables["hertz"].append(row)
    timing["hertz_s"] = time.perf_counter() - tic
    hz = tables["hertz"]
    hs, dofs = [row["h"] for row in hz], [row["ndof"] for row in hz]
    convergence.append(convergence_entry("hertz_p0_rel_error", hs, dofs, [abs(row["p0_rel_error"]) for row in hz],
                                         None, note="|p0_num / p0 - 1|; h = h_contact (m); maxh refined with it; "
                                         "dominated by the model error of the finite cylinder (no order)",
                                         maxh=[row["maxh"] for row in hz]))
    convergence.append(convergence_entry("hertz_newton_iterations", hs, dofs, [row["iterations"] for row in hz], 0,
                                         **{key: [row[key] for row in hz] for key in
                                            ("factorizations", "penalty_iterations", "wall_s", "cpu_s")}))
    convergence.append(_ratio_entry("hertz_time_ratio", hz))

    # (2) two blocks with Coulomb friction (ssn)
    tic = time.perf_counter()
    lam_ref = {}
    for h in p["blocks_h"]:
        row, multipliers = _level(lambda factory, h=h: cp.two_blocks_coulomb(h, ORDER, friction=FRICTION, ratio=RATIO,
                                                                           return_system=True,
                                                                           solver_factory=factory),
                                  lambda r, h=h: dict(h=h, stick=r["stick"], slip=r["slip"], active=r["active"],
                                                      force_balance_n=r["force_balance_n"],
                                                      force_balance_t=r["force_balance_t"],
                                                      max_penetration=r["max_penetration"]), p["repeats"])
        if h in p["uzawa_h"]:
            lam_ref[h] = multipliers
        timing[f"blocks_h{h:g}_s"] = row["run_s"]
        tables["blocks"].append(row)
    timing["blocks_s"] = time.perf_counter() - tic
    bl = tables["blocks"]
    hs, dofs = [row["h"] for row in bl], [row["ndof"] for row in bl]
    convergence.append(convergence_entry("friction_newton_iterations", hs, dofs, [row["iterations"] for row in bl],
                                         0, **{key: [row[key] for row in bl] for key in
                                               ("factorizations", "penalty_iterations", "stick", "slip", "wall_s",
                                                "cpu_s")}))
    convergence.append(_ratio_entry("friction_time_ratio", bl))

    # (3) Uzawa (2.66) on the blocks, coarse meshes
    tic = time.perf_counter()
    modulus = float(np.max(np.diag(isotropic(10e9, 0.25))))   # the blocks' nodal_modulus: 12 GPa
    rho = UZAWA_RHO_FACTOR * modulus / 1.0                     # / L (the extent of the contact side, 1 m)

    def uzawa(interfaces, **kw):
        return UzawaSolver(interfaces, rho=rho, tol=UZAWA_TOL, maxit=UZAWA_MAXIT, **kw)

    for h in p["uzawa_h"]:
        t0 = time.perf_counter()
        store = {}
        r = cp.two_blocks_coulomb(h, ORDER, friction=FRICTION, ratio=RATIO, solver_factory=_factory(store, uzawa))
        row = {"h": h, "ndof": r["ndof"], "iterations": r["iterations"], "inner_iterations": r["inner_iterations"],
               "factorizations": r["factorizations"], "wall_s": r["wall_s"], "cpu_s": store["solver"].cpu_s,
               "stick": r["stick"], "slip": r["slip"], "rho": rho}
        ln, lt = store["solver"].multipliers[0]
        if h in lam_ref:
            scale = FRICTION * 5e6
            row["lam_t_diff"] = float(np.max(np.abs(lt - lam_ref[h][1]))) / scale
            row["lam_n_diff"] = float(np.max(np.abs(ln - lam_ref[h][0]))) / 5e6
        nl = next((b for b in bl if b["h"] == h), None)
        if nl is not None:
            row["ratio"] = r["wall_s"] / _pos(nl["linear_wall_s"])
            row["ratio_cpu"] = row["cpu_s"] / _pos(nl["linear_cpu_s"])
            row["newton_wall_s"] = nl["wall_s"]
        del r, store
        gc.collect()
        row["run_s"] = time.perf_counter() - t0
        timing[f"uzawa_h{h:g}_s"] = row["run_s"]
        tables["uzawa"].append(row)
    timing["uzawa_s"] = time.perf_counter() - tic
    uz = tables["uzawa"]
    if len(uz) >= 2:
        convergence.append(convergence_entry("uzawa_iterations", [row["h"] for row in uz], [row["ndof"] for row in uz],
                                             [row["iterations"] for row in uz], -1,
                                             note="outer Uzawa steps (tol 1e-10) at a fixed rho: ~ L / h",
                                             rho=rho, **{key: [row[key] for row in uz] for key in
                                                         ("inner_iterations", "factorizations", "wall_s",
                                                          "cpu_s")}))

    # metrics
    hf, bf = hz[-1], bl[-1]
    metrics["hertz_p0_rel_error"] = abs(hf["p0_rel_error"])
    metrics["hertz_newton_iterations_max"] = max(row["iterations"] for row in hz)
    metrics["friction_newton_iterations_max"] = max(row["iterations"] for row in bl)
    metrics["time_ratio_frictionless"] = hf["ratio"]
    metrics["time_ratio_coulomb"] = bf["ratio"]
    metrics["time_ratio_frictionless_warm"] = hf["warm_ratio"]
    metrics["time_ratio_coulomb_warm"] = bf["warm_ratio"]
    metrics["hertz_warm_iterations_max"] = max(row["warm_iterations"] for row in hz)
    metrics["friction_warm_iterations_max"] = max(row["warm_iterations"] for row in bl)
    metrics["uzawa_iterations_finest"] = uz[-1]["iterations"]
    metrics["uzawa_finest_h"] = uz[-1]["h"]
    metrics["uzawa_finest_ndof"] = uz[-1]["ndof"]
    metrics["target_newton_iterations_met"] = float(max(metrics["hertz_newton_iterations_max"],
                                                        metrics["friction_newton_iterations_max"]) <= TARGET_NEWTON)
    metrics["target_time_ratio_frictionless_met"] = float(hf["ratio"] <= TARGET_RATIO_FRICTIONLESS)
    metrics["target_time_ratio_coulomb_met"] = float(bf["ratio"] <= TARGET_RATIO_COULOMB)
    metrics["time_ratio_frictionless_cpu"] = hf["ratio_cpu"]
    metrics["time_ratio_coulomb_cpu"] = bf["ratio_cpu"]
    metrics["time_ratio_frictionless_vs_umfpack"] = hf["ratio_umfpack"]
    metrics["time_ratio_coulomb_vs_umfpack"] = bf["ratio_umfpack"]
    metrics["time_ratio_frictionless_vs_sparsecholesky"] = hf["ratio_sparsecholesky"]
    metrics["time_ratio_coulomb_vs_sparsecholesky"] = bf["ratio_sparsecholesky"]
    metrics["hertz_direct_wall_s_finest"] = hf["direct_wall_s"]
    metrics["friction_direct_wall_s_finest"] = bf["direct_wall_s"]
    metrics["hertz_condensed_dofs_finest"] = hf["condensed_dofs"]
    metrics["friction_condensed_dofs_finest"] = bf["condensed_dofs"]
    metrics["condensed_fallbacks"] = sum(row["fallback"] for row in hz + bl)
    metrics["candidate_passes_max"] = max(row["candidate_passes"] for row in hz + bl)
    metrics["hertz_ndof_finest"] = hf["ndof"]
    metrics["friction_ndof_finest"] = bf["ndof"]
    metrics["hertz_factorizations_finest"] = hf["factorizations"]
    metrics["friction_factorizations_finest"] = bf["factorizations"]
    metrics["hertz_contact_wall_s_finest"] = hf["wall_s"]
    metrics["friction_contact_wall_s_finest"] = bf["wall_s"]
    metrics["hertz_linear_wall_s_finest"] = hf["linear_wall_s"]
    metrics["friction_linear_wall_s_finest"] = bf["linear_wall_s"]
    metrics["friction_stick_nodes_finest"] = bf["stick"]
    metrics["friction_slip_nodes_finest"] = bf["slip"]
    metrics["friction_stick_and_slip_every_level"] = float(all(row["stick"] > 0 and row["slip"] > 0 for row in bl))
    metrics["uzawa_wall_s_finest"] = uz[-1]["wall_s"]
    if "lam_t_diff" in uz[-1]:
        metrics["uzawa_newton_lam_t_max_diff_finest"] = uz[-1]["lam_t_diff"]
    metrics = {k: float(v) for k, v in metrics.items() if isinstance(v, (int, float)) and math.isfinite(v)}
    timing["total_s"] = time.perf_counter() - t_start
    result = {"study": STUDY, "level": level, "metrics": metrics, "convergence": convergence, "timing_s": timing,
              "rows": tables}
    return result, tables


def _targets(m: dict) -> list[str]:
    def ok(key):
        return "met" if m.get(key) == 1.0 else "NOT met"
    return ["", "targets:",
            f"  Newton iterations <= {TARGET_NEWTON} at every level: Hertz max "
            f"{m['hertz_newton_iterations_max']:.0f}, Coulomb max {m['friction_newton_iterations_max']:.0f}: "
            f"{ok('target_newton_iterations_met')}",
            f"  time ratio frictionless <= {TARGET_RATIO_FRICTIONLESS:g} at the finest level: "
            f"{m['time_ratio_frictionless']:.1f} (CPU {m.get('time_ratio_frictionless_cpu', math.nan):.1f}): "
            f"{ok('target_time_ratio_frictionless_met')}",
            f"  time ratio Coulomb <= {TARGET_RATIO_COULOMB:g} at the finest level: {m['time_ratio_coulomb']:.1f} "
            f"(CPU {m.get('time_ratio_coulomb_cpu', math.nan):.1f}): {ok('target_time_ratio_coulomb_met')}"]


def _cols(row: dict) -> str:
    return (f"{row['iterations']:4d} {row['factorizations']:4d} {row['condensed_dofs']:5d} {row['wall_s']:7.2f} "
            f"{row['cpu_s']:7.2f} {row['linear_wall_s']:6.3f} {row['ratio']:6.2f} {row['ratio_cpu']:6.2f} "
            f"{row['sparsecholesky_wall_s']:6.3f} {row['ratio_sparsecholesky']:6.2f} {row['direct_wall_s']:7.2f} "
            f"{row['run_s']:6.1f} {row['warm_iterations']:4d} {row['warm_factorizations']:4d} "
            f"{row['warm_ratio']:6.2f}")


_HEAD = (f"{'Newt':>4} {'fact':>4} {'m_s':>5} {'wall':>7} {'cpu':>7} {'lin':>6} {'ratio':>6} {'r cpu':>6} "
         f"{'sc':>6} {'r sc':>6} {'direct':>7} {'run':>6} {'wNwt':>4} {'wfac':>4} {'wratio':>6}")


def tables_text(rows: dict) -> list[str]:
    """The per-level tables (Hertz, blocks, Uzawa) as text lines."""
    lines = ["", f"Hertz, frictionless, P2 (solver {LINEAR!r}; times in s, the fastest of the repeats; m_s: condensed "
             "dofs; lin = the fastest factor + solve of K; sc = NGSolve's sparsecholesky; direct: the sparse direct "
             f"path; w...: a warm solve at {WARM_LOAD_FACTOR:g} x the load from the converged sets)",
             f"{'k':>2} {'h_c':>8} {'dofs':>7} {'p0 err':>9} " + _HEAD]
    for row in rows["hertz"]:
        lines.append(f"{row['k']:2d} {row['h']:8.2e} {row['ndof']:7d} {row['p0_rel_error']:9.2e} " + _cols(row))
    lines += ["", f"two blocks, Coulomb F_c = {FRICTION:g}, push {RATIO:g} x capacity, P2 (stick / slip: nodes)",
              f"{'h':>6} {'dofs':>7} {'stick':>5} {'slip':>5} " + _HEAD]
    for row in rows["blocks"]:
        lines.append(f"{row['h']:6.3f} {row['ndof']:7d} {row['stick']:5d} {row['slip']:5d} " + _cols(row))
    if rows["uzawa"]:
        rho = rows["uzawa"][0]["rho"]
        lines += ["", f"Uzawa (2.66) on the blocks, rho = {rho:.3g} Pa/m, tol {UZAWA_TOL:g} (|dlam|: max difference "
                  "to the Newton multipliers, / F_c p_top)",
                  f"{'h':>6} {'dofs':>7} {'steps':>5} {'inner':>5} {'wall':>7} {'cpu':>7} {'ratio':>6} "
                  f"{'Newton':>6} {'|dlam_t|':>9}"]
        for row in rows["uzawa"]:
            lines.append(f"{row['h']:6.3f} {row['ndof']:7d} {row['iterations']:5d} {row['inner_iterations']:5d} "
                         f"{row['wall_s']:7.2f} {row['cpu_s']:7.2f} {row.get('ratio', math.nan):6.0f} "
                         f"{row.get('newton_wall_s', math.nan):6.2f} {row.get('lam_t_diff', math.nan):9.1e}")
    return lines


def report(result: dict) -> str:
    """A plain-text report: the per-level tables, the targets next to the measured values, the metrics."""
    m = result["metrics"]
    lines = [f"study {result['study']}, level {result['level']}"] + tables_text(result["rows"]) + _targets(m)
    lines.append(f"  Uzawa outer steps at the finest Uzawa level (h = {m['uzawa_finest_h']:g} m, "
                 f"{m['uzawa_finest_ndof']:.0f} dofs): {m['uzawa_iterations_finest']:.0f}")
    return "\n".join(lines + metrics_lines(result, width=44))


def main(level: int = 0, out: str | Path | None = None) -> dict:
    """Run the study at ``level`` (0 quick, 1 up to 140k dofs, 2 also Uzawa at 37k dofs); write
    ``out/results.json`` if ``out`` is given."""
    return study_main(run, level, out)


if __name__ == "__main__":
    study_cli(__doc__, run, report)
