"""Command line: ``ngs-geomech run|validate|list|uncertain``. It only parses arguments and calls the package."""

from __future__ import annotations

import argparse
import os
import sys

from .errors import GeomechError

OVERWRITE = ("allow an --out directory that holds other files: the outputs are written into it, files of the same "
             "names replaced, no other file removed")


def _count(text: str) -> int:
    """A positive integer option value (threads, workers)."""
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return n


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="ngs-geomech", description="Coupled thermo-mechanics in geomechanics "
                                     "(NGSolve). Scenes are TOML files or built-in names (see 'list').")
    sub = parser.add_subparsers(dest="command", required=True)
    p_run = sub.add_parser("run", help="run a scene and write VTK, figures and summary.json")
    p_run.add_argument("scene", help="scene file or built-in scene name")
    p_run.add_argument("--out", help="output directory: new, empty, or the output of an earlier run (its files "
                                     "are replaced when the run succeeds, other files in it are kept); an existing "
                                     "file, / and mount points are refused")
    p_run.add_argument("--overwrite", action="store_true", help=OVERWRITE)
    p_run.add_argument("--resume", nargs="?", const=True, default=None, metavar="DIR",
                       help="continue the interrupted (killed, failed) time-dependent run into --out (or DIR) from "
                            "its last checkpoint; give the same scene and --set values (time steps, solver and "
                            "output settings may change)")
    p_run.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scene value, e.g. --set mesh.maxh=2 --set time.end='10 year'")
    p_run.add_argument("--quiet", action="store_true", help="no progress display")
    p_run.add_argument("--threads", type=_count, default=None, help="number of threads (default: NGSolve's)")
    p_val = sub.add_parser("validate", help="check a scene (no meshing, no solving)")
    p_val.add_argument("scene")
    p_val.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    sub.add_parser("list", help="list the built-in scenes")
    p_unc = sub.add_parser("uncertain", help="worst-scenario or Monte Carlo study over the scene's [uncertainty] "
                                             "table: results.json, table.md/.csv, figures, samples.jsonl")
    p_unc.add_argument("scene", help="scene file or built-in scene name (with an [uncertainty] table)")
    p_unc.add_argument("--out", required=True, help="output directory (its samples.jsonl keeps every finished "
                                                    "sample): new, empty, or the output of an earlier study")
    p_unc.add_argument("--overwrite", action="store_true", help=OVERWRITE + "; an earlier study there starts over")
    p_unc.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scene value for every sample, e.g. --set mesh.maxh=50 or "
                            "--set uncertainty.mode=monte_carlo")
    p_unc.add_argument("--executor", choices=("serial", "process", "mpi"), default="process",
                       help="where samples run: 'process' (default: a pool of --workers processes on this "
                            "machine), 'serial', or 'mpi' (the ranks of 'mpiexec -n N python -m mpi4py.futures "
                            "-m ngs_geomech.cli uncertain ...', one machine or a cluster)")
    p_unc.add_argument("--workers", type=_count, default=None,
                       help="worker processes (default: the number of cores); one NGSolve thread each")
    p_unc.add_argument("--threads", type=_count, default=None,
                       help="NGSolve threads of a serial study (default: NGSolve's); pools use one per worker")
    p_unc.add_argument("--resume", action="store_true",
                       help="continue the killed study in --out from its samples.jsonl (same scene and --set)")
    p_unc.add_argument("--quiet", action="store_true", help="no progress display")
    p_unc.add_argument("--no-figures", action="store_true", help="write no PNG figures")
    args = parser.parse_args(argv)
    if args.command == "run":
        if isinstance(args.resume, str):
            if args.out is not None and os.path.realpath(args.out) != os.path.realpath(args.resume):
                parser.error(f"--out {args.out} and --resume {args.resume} name different directories")
            args.out = args.resume
        if args.out is None:
            parser.error("the following arguments are required: --out")

    from .api import list_builtin, run, validate_scene
    from .parallel import world, world_rank
    try:
        if args.command == "list":
            for name, path in list_builtin().items():
                print(f"{name:30s} {path}")
            return 0
        if args.command == "validate":
            summary = validate_scene(args.scene, args.overrides)
            print(summary)
            return 0
        if args.command == "uncertain":
            from .uncertainty.study import run_uncertainty
            res = run_uncertainty(args.scene, args.out, overrides=args.overrides, executor=args.executor,
                                  workers=args.workers, threads=args.threads, resume=args.resume,
                                  overwrite=args.overwrite,
                                  progress=not args.quiet, figures=not args.no_figures)
            print(_uncertainty_report(res, args.out))
            return 0
        result = run(args.scene, args.out, overrides=args.overrides, progress=not args.quiet,
                     threads=args.threads, resume=bool(args.resume), overwrite=args.overwrite, comm=world())
        resumed = result.summary.get("resumed")
        note = f", resumed at step {resumed[-1]['step']} of {result.summary['steps']}" if resumed else ""
        ranks = result.summary["mesh"].get("ranks")
        note += f", {ranks} MPI ranks" if ranks else ""
        if world_rank() == 0:
            print(f"wrote {result.out} ({result.summary['wall_time_s']['total_s']:.1f} s{note})")
        return 0
    except GeomechError as exc:
        if world_rank() == 0:              # a distributed run raises it on every rank: said once
            print(f"ngs-geomech: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        what = str(exc) or "no output written"
        if args.command == "uncertain":
            what = (f"the finished samples are in {os.path.join(args.out, 'samples.jsonl')}; continue with the "
                    "same command and --resume")
        print(f"ngs-geomech: interrupted; {what}", file=sys.stderr)
        return 130


def _uncertainty_report(res: dict, out: str) -> str:
    body = res[res["mode"]]
    lines = []
    for name, e in body["criteria"].items():
        unit = f" {e['unit']}" if e.get("unit") else ""
        # the range over every finished sample and the margin taken from it, in every mode
        covering = (f"range [{e['range'][0]:.6g}, {e['range'][1]:.6g}]{unit}"
                    + (f", margin to the limit {e['margin_to_limit']:.4g}{unit}" if "margin_to_limit" in e else "")
                    if "range" in e else "")
        if res["mode"] == "worst_scenario":
            lines.append(f"  {name}: nominal {e['nominal']:.6g}, {covering}")
        elif e.get("n"):
            ci = e["mean_ci"]
            lines.append(f"  {name}: mean {e['mean']:.6g}{unit} ({ci[0]:.6g} .. {ci[1]:.6g}), "
                         f"5-95 % {e['quantiles']['q05']:.6g} .. {e['quantiles']['q95']:.6g}, {covering}"
                         + (f", P(> {e['limit']:g}) = {e['p_exceed']:.3g}" if "p_exceed" in e else ""))
    s = res["samples"]
    warn = f"; {s['failed']} samples FAILED (see results.json failed_samples)" if s["failed"] else ""
    return "\n".join([f"wrote {out} ({res['mode']}, {s['total']} samples, {res['wall_time_s']:.1f} s{warn})"]
                     + lines)


if __name__ == "__main__":
    sys.exit(main())
