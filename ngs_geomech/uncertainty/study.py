"""An uncertainty study of a scene (``ngs-geomech uncertain SCENE --out DIR``): the scene's ``[uncertainty]``
table gives the uncertain data (intervals, distributions) and the criteria; the study runs the scene at many
parameter sets and reports the worst scenario (range of each criterion over the admissible set, the worst
parameter sets) or the stochastic estimates (mean with confidence interval, quantiles, probability of exceeding
a limit).

Order of work: everything is checked before the first run (the scene and its ``[uncertainty]`` table, every
parameter's scene items, the scene at both ends of the intervals, the output directory by the rules of
:mod:`ngs_geomech.io.outdir`: new, empty, an earlier study's output, or with ``overwrite`` a directory of other
files, which are kept); then the nominal scene
runs and each criterion's summary path is checked on its summary; then the samples. Every finished sample is
appended to ``DIR/samples.jsonl`` at once; ``--resume`` continues a killed study from it (the samples are
deterministic: the same seed gives the same points, so a resumed study reruns nothing it has). The results
(``results.json``, ``table.md``, ``table.csv``, figures) are written at the end, each file atomically; the
marker ``ngs-geomech-output.json`` lists every file the study wrote (``complete`` once the results are written).
A new study in the directory of an earlier one (``overwrite``) first removes the earlier study's files.
"""

from __future__ import annotations

import contextlib
import csv
import io
import time
from pathlib import Path

import numpy as np

from ..errors import OutputError, Problem, ResumeError, SceneError, SolverError
from ..io.atomic import write_json_atomic, write_marker, write_text_atomic
from ..io.outdir import check_output, creating, disk_full, owned_files
from ..io.sample_log import SampleLog, differing_items, fingerprint, flatten
from ..io.summary import json_safe
from ..io.uncertainty_figures import distribution_figure, ranges_figure, scatter_figure
from ..scene.names import name_problem
from ..scene.parse import apply_overrides, read_toml, resolve, scene_from_dict
from ..validation.validate import validate
from . import stochastic, worst
from .executors import Runner
from .parameters import ParameterSpace
from .samples import Sample, Sampler

LOG_NAME = "samples.jsonl"
PROBE_STATS = ("max", "min", "final")
"""The figures of a probe in summary.json a criterion can watch (:func:`ngs_geomech.io.summary.probe_statistics`)."""


class Study:
    """A checked study, ready to run: scene data, parameter space, criteria and the sample log."""

    def __init__(self, scene: str | Path | dict, out: str | Path, overrides: list[str] | None = None,
                 resume: bool = False, overwrite: bool = False):
        if isinstance(scene, dict):          # the scene's data, as read from TOML (studies edit it first)
            path, raw = "scene", scene
        else:
            path = resolve(str(scene))
            raw = read_toml(path)
        if overrides:
            raw = apply_overrides(raw, overrides)
        sc = scene_from_dict(raw, source=str(path))
        if sc.uncertainty is None:
            raise SceneError([Problem("uncertainty", "the scene has no [uncertainty] table (parameters with "
                                                     "intervals and criteria; see the README)")], source=str(path))
        self.scene = sc
        self.unc = sc.uncertainty
        self.raw = {k: v for k, v in raw.items() if k != "uncertainty"}
        self.space = ParameterSpace(self.unc, self.raw)
        self.criteria = {c.name: c.summary for c in self.unc.criteria}
        problems = _check_settings(sc)
        if problems:
            raise SceneError(problems, source=str(path))
        self._check_ends(str(path))
        if not resume and not overwrite and SampleLog(Path(out) / LOG_NAME).exists():
            raise ResumeError(f"{out} holds the samples of an earlier study ({LOG_NAME}); give --resume to "
                              "continue it, --overwrite to start a new one, or another --out")
        self.out = check_output(out, command="uncertain", overwrite=overwrite, resume=resume)
        self.log = SampleLog(self.out / LOG_NAME)
        self.written = {LOG_NAME}
        self.header = {"scene": sc.scene.name,
                       "items": flatten({"scene": self.raw, "parameters": self.space.describe(),
                                         "criteria": self.criteria})}
        self.header["fingerprint"] = fingerprint(self.header["items"])
        self.previous: list[dict] = []
        if resume:
            head, records = self.log.read()
            if head is None:
                raise ResumeError(f"{self.out}: no sample log ({LOG_NAME}) to resume from; run without --resume")
            if head.get("fingerprint") != self.header["fingerprint"]:
                diff = differing_items(head.get("items", {}), self.header["items"])
                raise ResumeError(f"{self.out}: the samples were computed with other data; differing items:\n  "
                                  + "\n  ".join(diff) + "\nGive the same scene and --set values, or another --out")
            self.previous = records

    def _check_ends(self, source: str) -> None:
        """The scene must be valid with every parameter at its lower and at its upper end."""
        problems = []
        for end, z in (("lower", 0.0), ("upper", 1.0)):
            values = self.space.box_values(np.full(self.space.dimension, z))
            try:
                validate(scene_from_dict(apply_overrides(self.raw, self.space.overrides(values)), source=source))
            except SceneError as exc:
                problems += [Problem(f"uncertainty (all parameters at their {end} ends) {p.item}", p.message)
                             for p in exc.problems]
        if problems:
            raise SceneError(problems, source=source)

    def run(self, *, executor: str = "serial", workers: int | None = None, threads: int | None = None,
            progress: bool = True, figures: bool = True) -> dict:
        try:
            return self._run(executor, workers, threads, progress, figures)
        except OSError as exc:
            if not disk_full(exc):
                raise
            raise OutputError(f"disk full: the finished samples are kept in {self.log.path}, --resume after freeing "
                              "space") from None

    def _run(self, executor: str, workers: int | None, threads: int | None, progress: bool, figures: bool) -> dict:
        t0 = time.perf_counter()
        self._start()
        with Runner(executor, workers, threads) as runner:
            values_of = (self.space.box_values if self.unc.mode == "worst_scenario" else self.space.random_values)
            sampler = Sampler(self.space, self.raw, self.criteria, runner, self.log, values_of, progress=progress)
            sampler.preload(self.previous)
            nominal = self._nominal(sampler)
            if self.unc.mode == "worst_scenario":
                body = self._worst(sampler, nominal)
            else:
                body = self._stochastic(sampler)
        results = self._results(sampler, runner, nominal, body, time.perf_counter() - t0)
        self._write(results, sampler, figures)
        return results

    def _start(self) -> None:
        """Mark the output directory as the study's (``complete: false``) and begin the sample log; a new study
        first removes the files of an earlier one there (its marker's list)."""
        with creating(self.out):
            self.out.mkdir(parents=True, exist_ok=True)
        earlier = owned_files(self.out, "uncertain")
        if self.previous:
            self.written.update(earlier)
        else:
            for rel in earlier:
                with contextlib.suppress(IsADirectoryError, FileNotFoundError):
                    (self.out / rel).unlink()
        self._mark(complete=False)
        if not self.previous:
            self.log.start({k: v for k, v in self.header.items()})

    def _mark(self, complete: bool) -> None:
        write_marker(self.out, "uncertain", self.written, self.scene.scene.name, complete)

    def _file(self, rel: str) -> Path:
        """The path of the output file ``rel``, recorded in the marker's list."""
        self.written.add(rel)
        return self.out / rel

    # -- the nominal run: the criteria's paths must exist in its summary --------------------------------------
    def _nominal(self, sampler: Sampler) -> Sample:
        z0 = (self.space.nominal_coordinates() if self.unc.mode == "worst_scenario"
              else self.space.nominal_probabilities())
        s = sampler.batch([z0], "nominal")[0]
        if not s.ok:
            if s.criteria_problems:
                raise SceneError([Problem("uncertainty.criteria", m) for m in s.criteria_problems],
                                 source="uncertainty")
            raise SolverError(f"the nominal scene failed, so no sample can be trusted: {s.message}")
        return s

    # -- worst scenario ---------------------------------------------------------------------------------------
    def _worst(self, sampler: Sampler, nominal: Sample) -> dict:
        u = self.unc
        d = self.space.dimension
        design = sampler.batch(worst.design_points(d, u.samples, u.seed, u.vertices), "design")
        body: dict = {"design": {"points": len(design), "latin_hypercube": u.samples,
                                 "vertices": len(design) - u.samples}}
        if u.derivative_check:
            body["derivative_check"] = self._derivative_check(sampler, nominal)
        searches = {}
        for c in u.criteria:
            ok = [s for s in sampler.done.values() if s.ok and c.name in s.values]
            vals = np.array([s.values[c.name] for s in ok])
            scale = float(np.ptp(vals)) if len(vals) else 0.0
            senses = ("max", "min") if c.sense == "both" else (c.sense,)
            res = {}
            for sense in senses:
                pool = [s for s in sampler.done.values() if s.ok and c.name in s.values]
                start = (max if sense == "max" else min)(pool, key=lambda s, n=c.name: s.values[n])
                res[sense] = worst.local_search(sampler, c.name, sense, start, h=u.fd_step,
                                                max_iterations=u.max_local_iterations, scale=scale,
                                                enabled=u.local_search).as_dict(self.space)
            searches[c.name] = {"nominal": nominal.values[c.name], "unit": c.unit, **res}
        # the ranges only now: a later criterion's search may have passed a more extreme point of an earlier one
        for c in u.criteria:
            searches[c.name].update(covering_range(sampler.done.values(), c.name, c.limit))
        body["criteria"] = searches
        return body

    def _derivative_check(self, sampler: Sampler, nominal: Sample) -> dict:
        """Finite-difference gradients at the nominal point with steps 0.1, 0.01, 0.001 of the interval
        (forward) and 0.01 (central), in criterion units per parameter unit, and their differences to the
        central one: truncation error (large steps) against solver and discretization noise (small steps)."""
        z0 = nominal.z
        widths = np.array([p.upper - p.lower for p in self.space.parameters])
        out: dict = {}
        grads = {}
        for h in (0.1, 0.01, 0.001):
            g, _ = worst.fd_gradient(sampler, z0, nominal.values, h, "fd_check")
            grads[f"forward_{h:g}"] = g
        g, _ = worst.fd_gradient(sampler, z0, nominal.values, 0.01, "fd_check", central=True)
        grads["central_0.01"] = g
        for c in self.criteria:
            ref = grads["central_0.01"][c] / widths
            rows = {}
            for k, g in grads.items():
                gp = g[c] / widths
                rel = float(np.linalg.norm(gp - ref) / max(float(np.linalg.norm(ref)), 1e-300))
                rows[k] = {"gradient": dict(zip(self.space.names, gp.tolist())),
                           "rel_difference_to_central": rel}
            # first-order range about the nominal point: f0 +- sum |df/dp| * distance to the interval's ends
            lo = sum(min(gi * (p.lower - p.nominal), gi * (p.upper - p.nominal))
                     for gi, p in zip(ref, self.space.parameters))
            hi = sum(max(gi * (p.lower - p.nominal), gi * (p.upper - p.nominal))
                     for gi, p in zip(ref, self.space.parameters))
            out[c] = {"steps": rows, "linearized_range": [nominal.values[c] + lo, nominal.values[c] + hi]}
        return out

    # -- stochastic ---------------------------------------------------------------------------------------------
    def _stochastic(self, sampler: Sampler) -> dict:
        u = self.unc
        d = self.space.dimension
        if u.mode == "monte_carlo":
            groups_pts = [stochastic.monte_carlo_points(d, u.samples, u.seed)]
        else:
            groups_pts = stochastic.sobol_replicates(d, u.samples, u.replicates, u.seed)
        pts = [p for g in groups_pts for p in g]
        gid = np.concatenate([np.full(len(g), i) for i, g in enumerate(groups_pts)])
        res = sampler.batch(pts, u.mode)
        ok = np.array([s.ok for s in res])
        body: dict = {"samples": len(res), "failed": int(np.sum(~ok)), "criteria": {}}
        if np.any(~ok):
            body["warning"] = (f"{int(np.sum(~ok))} of {len(res)} samples failed; the estimates use the others "
                               "and are biased if the failures depend on the data")
        for c in u.criteria:
            v = np.array([s.values[c.name] for s, k in zip(res, ok) if k])
            g = None if u.mode == "monte_carlo" else gid[ok]
            est = stochastic.estimate(v, g, u.confidence, c.limit)
            est["unit"] = c.unit
            est["running"] = stochastic.running_mean(v, u.confidence)
            est.update(covering_range(sampler.done.values(), c.name, c.limit))
            body["criteria"][c.name] = est
        return body

    # -- results --------------------------------------------------------------------------------------------------
    def _results(self, sampler: Sampler, runner: Runner, nominal: Sample, body: dict, wall: float) -> dict:
        samples = list(sampler.done.values())
        failed = [s for s in samples if not s.ok]
        return {"study": "uncertainty", "scene": self.scene.scene.name, "mode": self.unc.mode,
                "parameters": self.space.describe(),
                "criteria": {c.name: {"summary": c.summary, "unit": c.unit, "sense": c.sense, "limit": c.limit}
                             for c in self.unc.criteria},
                "nominal": {"parameters": nominal.params, "values": nominal.values},
                self.unc.mode: body,
                "samples": {"total": len(samples), "ok": len(samples) - len(failed), "failed": len(failed),
                            "run_in_this_session": sampler.runs, "reused_from_log": sampler.reused,
                            "run_wall_s_sum": sampler.run_wall_s,
                            "mean_run_wall_s": sampler.run_wall_s / max(sampler.runs, 1)},
                "failed_samples": [{"parameters": s.params, "tag": s.tag, "message": s.message[:2000]}
                                   for s in failed],
                "executor": {"kind": runner.kind, "workers": runner.workers},
                "wall_time_s": wall,
                "settings": {k: getattr(self.unc, k) for k in ("samples", "vertices", "local_search",
                                                               "max_local_iterations", "fd_step",
                                                               "derivative_check", "replicates", "confidence",
                                                               "seed")}}

    def _write(self, results: dict, sampler: Sampler, figures: bool) -> None:
        write_json_atomic(self._file("results.json"), json_safe(results))
        md, rows = _table(results)
        write_text_atomic(self._file("table.md"), md)
        buf = io.StringIO()
        w = csv.writer(buf)
        w.writerows(rows)
        write_text_atomic(self._file("table.csv"), buf.getvalue())
        if figures:
            (self.out / "figures").mkdir(parents=True, exist_ok=True)
            self._figures(results, sampler)
        self._mark(complete=True)

    def _figures(self, results: dict, sampler: Sampler) -> None:
        ok = [s for s in sampler.done.values() if s.ok]
        body = results[self.unc.mode]
        if self.unc.mode == "worst_scenario":
            rows = []
            for c in self.unc.criteria:
                e = body["criteria"][c.name]
                rows.append({"name": c.name, "unit": c.unit, "values": [s.values[c.name] for s in ok],
                             "nominal": e["nominal"], "min": e["range"][0], "max": e["range"][1], "limit": c.limit})
                marks = {"max": e["max_over_all_samples"], "min": e["min_over_all_samples"]}
                scatter_figure({n: np.array([s.params[n] for s in ok]) for n in self.space.names},
                               np.array([s.values[c.name] for s in ok]), [s.tag for s in ok],
                               self._file(f"figures/samples_{c.name}.png"), criterion=c.name, marks=marks)
            ranges_figure(rows, self._file("figures/worst_scenario.png"),
                          title=f"{self.scene.scene.name}: worst scenario over the admissible data")
        else:
            for c in self.unc.criteria:
                e = body["criteria"][c.name]
                if e.get("n", 0) < 2:
                    continue
                v = np.array([s.values[c.name] for s in ok if s.tag == self.unc.mode])
                distribution_figure(v, e["running"], self._file(f"figures/distribution_{c.name}.png"),
                                    criterion=c.name, unit=c.unit, mean_ci=e["mean_ci"], limit=c.limit)


def run_uncertainty(scene: str | Path | dict, out: str | Path, *, overrides: list[str] | None = None,
                    executor: str = "serial", workers: int | None = None, threads: int | None = None,
                    resume: bool = False, overwrite: bool = False, progress: bool = True,
                    figures: bool = True) -> dict:
    """Check, run and write an uncertainty study (see the module docstring); returns ``results.json``'s data.
    ``threads``: NGSolve threads of a serial study (pools use one per worker)."""
    return Study(scene, out, overrides, resume, overwrite).run(executor=executor, workers=workers, threads=threads,
                                                    progress=progress, figures=figures)


def covering_range(samples, name: str, limit: float | None) -> dict:
    """The range of criterion ``name`` over every finished sample (the nominal one, the design, every search's
    gradient and step points, those read from the log), the samples at its ends and, with a limit (an upper
    one: the criterion must stay below it), the margin ``limit - max`` taken from that covering range."""
    allv = [(s.values[name], s) for s in samples if s.ok and name in s.values]
    if not allv:
        return {}
    lo = min(allv, key=lambda t: t[0])
    hi = max(allv, key=lambda t: t[0])
    out = {"range": [lo[0], hi[0]], "range_samples": len(allv),
           "max_over_all_samples": {"value": hi[0], "parameters": hi[1].params, "found_by": hi[1].tag},
           "min_over_all_samples": {"value": lo[0], "parameters": lo[1].params, "found_by": lo[1].tag}}
    if limit is not None:
        out["limit"] = limit
        out["margin_to_limit"] = limit - hi[0]
    return out


def _check_settings(sc) -> list[Problem]:
    u = sc.uncertainty
    p: list[Problem] = []
    names = [c.name for c in u.criteria]
    if not u.criteria:
        p.append(Problem("uncertainty.criteria", "no criteria given"))
    for n in {n for n in names if names.count(n) > 1}:
        p.append(Problem(f"uncertainty.criteria.{n}", "duplicate criterion name"))
    for i, c in enumerate(u.criteria):
        why = name_problem(c.name)          # figures/samples_<name>.png
        if why is not None:
            p.append(Problem(f"uncertainty.criteria[{i}].name", why))
    probes = {pr.name for pr in sc.output.probes}
    for c in u.criteria:
        parts = c.summary.split(".")
        if parts[0] == "probes" and (len(parts) != 3 or parts[1] not in probes or parts[2] not in PROBE_STATS):
            p.append(Problem(f"uncertainty.criteria.{c.name}.summary",
                             f"{c.summary!r}: 'probes.NAME.STAT' with NAME one of the scene's probes "
                             f"({', '.join(sorted(probes)) or 'none'}) and STAT {', '.join(PROBE_STATS)}"))
    if u.seed < 0:
        p.append(Problem("uncertainty.seed", f"must be >= 0 (a seed of numpy's generators), got {u.seed}"))
    if u.mode == "worst_scenario":
        if u.samples < 0:
            p.append(Problem("uncertainty.samples", f"must be >= 0, got {u.samples}"))
        if not 0 < u.fd_step <= 0.5:
            p.append(Problem("uncertainty.fd_step", f"must be in (0, 0.5] (a fraction of the interval), "
                                                    f"got {u.fd_step}"))
        if u.max_local_iterations < 0:
            p.append(Problem("uncertainty.max_local_iterations", f"must be >= 0, got {u.max_local_iterations}"))
    elif u.mode == "monte_carlo":
        if u.samples < 2:
            p.append(Problem("uncertainty.samples", f"Monte Carlo needs at least 2 samples, got {u.samples}"))
    else:
        m = u.samples // max(u.replicates, 1)
        if u.replicates < 2 or u.samples % u.replicates or m < 1 or m & (m - 1):
            p.append(Problem("uncertainty.samples", f"quasi_monte_carlo needs samples = replicates x a power of "
                                                    f"two with replicates >= 2; got {u.samples} samples, "
                                                    f"{u.replicates} replicates"))
    if not 0 < u.confidence < 1:
        p.append(Problem("uncertainty.confidence", f"must be in (0, 1), got {u.confidence}"))
    return p


def _table(results: dict) -> tuple[str, list[list]]:
    mode = results["mode"]
    body = results[mode]
    lines = [f"# {results['scene']}: {mode.replace('_', ' ')}", ""]
    lines += ["| parameter | interval | nominal | unit | items |", "|---|---|---|---|---|"]
    for n, p in results["parameters"].items():
        lines.append(f"| {n} | [{p['interval'][0]:.6g}, {p['interval'][1]:.6g}] | {p['nominal']:.6g} | "
                     f"{p['unit']} | {', '.join(p['keys'])} ({p['scale']}) |")
    lines.append("")
    rows: list[list] = []
    if mode == "worst_scenario":
        head = ["criterion", "unit", "nominal", "min", "max", "limit", "margin", "worst parameters (max)",
                "max found by", "worst parameters (min)", "min found by"]
        rows.append(head)
        for n, e in body["criteria"].items():
            hi, lo = e["max_over_all_samples"], e["min_over_all_samples"]
            rows.append([n, e["unit"], e["nominal"], e["range"][0], e["range"][1], e.get("limit", ""),
                         e.get("margin_to_limit", ""), _params(hi["parameters"]), hi["found_by"],
                         _params(lo["parameters"]), lo["found_by"]])
    else:
        head = ["criterion", "unit", "n", "mean", "ci_low", "ci_high", "std", "q05", "q50", "q95", "min", "max",
                "limit", "margin", "p_exceed", "p_ci_low", "p_ci_high"]
        rows.append(head)
        for n, e in body["criteria"].items():
            if e.get("n", 0) == 0:
                rows.append([n, e["unit"], 0] + [""] * (len(head) - 3))
                continue
            pci = e.get("p_exceed_ci", ["", ""])
            rows.append([n, e["unit"], e["n"], e["mean"], e["mean_ci"][0], e["mean_ci"][1], e["std"],
                         e["quantiles"]["q05"], e["quantiles"]["q50"], e["quantiles"]["q95"], e["range"][0],
                         e["range"][1], e.get("limit", ""), e.get("margin_to_limit", ""), e.get("p_exceed", ""),
                         pci[0], pci[1]])
    lines.append("| " + " | ".join(rows[0]) + " |")
    lines.append("|" + "---|" * len(rows[0]))
    for r in rows[1:]:
        lines.append("| " + " | ".join(_fmt(v) for v in r) + " |")
    s = results["samples"]
    lines += ["", f"{s['total']} samples ({s['failed']} failed), {s['run_in_this_session']} run in this session "
                  f"(mean {s['mean_run_wall_s']:.2f} s each), {s['reused_from_log']} from the log; "
                  f"{results['executor']['kind']} executor, {results['wall_time_s']:.1f} s wall."]
    for f in results["failed_samples"][:10]:
        lines.append(f"- failed at {_params(f['parameters'])}: {f['message'].splitlines()[0][:300]}")
    return "\n".join(lines) + "\n", rows


def _params(p: dict) -> str:
    return "; ".join(f"{k}={v:.6g}" for k, v in p.items())


def _fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


__all__ = ["Study", "run_uncertainty"]
