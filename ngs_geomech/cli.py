"""Command line: ``ngs-geomech [-v | -q] run|validate|list|uncertain``. It only parses arguments and calls the
package.

A command's result (the ``wrote OUT (...)`` line, ``validate``'s summary, ``list``) goes to stdout; the package's
log messages go to stderr: warnings by default, notes with ``-v``, solver diagnostics with ``-vv``, only errors
with ``-q`` (which also turns the progress display off). Errors are ``ngs-geomech: error: ...`` with exit code 2.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys

from .errors import GeomechError

OVERWRITE = ("allow an --out directory that holds other files: the outputs are written into it, files of the same "
             "names replaced, no other file removed")
PROG = "ngs-geomech"


def _count(text: str) -> int:
    """A positive integer option value (threads, workers)."""
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return n


def version() -> str:
    """The installed distribution's version, else the package's ``__version__`` (a source checkout)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("ngs-geomech")
    except PackageNotFoundError:
        from . import __version__

        return __version__


class _Version(argparse.Action):
    """``--version``: the version is looked up when asked (importlib.metadata costs start-up time otherwise)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{PROG} {version()}")
        parser.exit()


def _verbosity() -> argparse.ArgumentParser:
    """-v / -q, accepted before the subcommand and after it (defaults suppressed: the subcommand's parse does not
    reset what was given before it)."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                   help="more messages on stderr: -v notes (remeshes, resumption), -vv solver diagnostics")
    p.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                   help="only errors on stderr, and no progress display")
    return p


def _parser() -> argparse.ArgumentParser:
    verbosity = _verbosity()
    parser = argparse.ArgumentParser(prog=PROG, parents=[verbosity],
                                     description="Coupled thermo-mechanics in geomechanics (NGSolve). Scenes are "
                                                 "TOML files or built-in names (see 'list').")
    parser.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    p_run = sub.add_parser("run", parents=[verbosity], help="run a scene and write VTK, figures and summary.json")
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
    p_run.add_argument("--threads", type=_count, default=None,
                       help="NGSolve threads (default: 1, or every core for large problems; docs/methods.md)")
    p_val = sub.add_parser("validate", parents=[verbosity], help="check a scene (no meshing, no solving)")
    p_val.add_argument("scene")
    p_val.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    sub.add_parser("list", parents=[verbosity], help="list the built-in scenes")
    p_unc = sub.add_parser("uncertain", parents=[verbosity],
                           help="worst-scenario or Monte Carlo study over the scene's [uncertainty] table: "
                                "results.json, table.md/.csv, figures, samples.jsonl")
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
                       help="NGSolve threads of a serial study (default: by the problem's size, as 'run'); pools "
                            "use one per worker")
    p_unc.add_argument("--resume", action="store_true",
                       help="continue the killed study in --out from its samples.jsonl (same scene and --set)")
    p_unc.add_argument("--no-figures", action="store_true", help="write no PNG figures")
    return parser


class _Formatter(logging.Formatter):
    """``warning: ...``, plain notes, ``debug: module: ...``, ``ngs-geomech: error: ...``."""

    def format(self, record: logging.LogRecord) -> str:
        text = super().format(record)
        if record.levelno >= logging.ERROR:
            return f"{PROG}: error: {text}"
        if record.levelno >= logging.WARNING:
            return f"warning: {text}"
        if record.levelno >= logging.INFO:
            return text
        return f"debug: {record.name}: {text}"


def _log_to_stderr(verbose: int, quiet: bool) -> tuple[logging.Handler, int]:
    """One handler on the package logger, writing to stderr at the chosen level; returns it and the logger's
    previous level (restored by :func:`_stop_logging`)."""
    level = logging.ERROR if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Formatter("%(message)s"))
    handler.setLevel(level)
    logger = logging.getLogger("ngs_geomech")
    previous = logger.level
    logger.setLevel(level)
    logger.addHandler(handler)
    return handler, previous


def _stop_logging(handler: logging.Handler, previous: int) -> None:
    logger = logging.getLogger("ngs_geomech")
    logger.removeHandler(handler)
    logger.setLevel(previous)


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command == "run":
        if isinstance(args.resume, str):
            if args.out is not None and os.path.realpath(args.out) != os.path.realpath(args.resume):
                parser.error(f"--out {args.out} and --resume {args.resume} name different directories")
            args.out = args.resume
        if args.out is None:
            parser.error("the following arguments are required: --out")
    args.quiet = getattr(args, "quiet", False)
    handler, previous = _log_to_stderr(getattr(args, "verbose", 0), args.quiet)
    try:
        code = _call(args)
        sys.stdout.flush()                 # a closed pipe is found here, not at the interpreter's exit
        return code
    except BrokenPipeError:
        # stdout closed early (``ngs-geomech list | head -1``): end quietly, as a command killed by SIGPIPE
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    finally:
        _stop_logging(handler, previous)


def entry() -> None:
    """The process's entry (the ``ngs-geomech`` script, ``python -m ngs_geomech``): :func:`main`, then the exit
    without the interpreter's teardown, which frees NGSolve's and scipy's objects one by one (0.1-0.2 s measured
    on a small run) where the operating system frees the process at once. Every output file is complete and
    closed when main returns (written atomically); stdout, stderr and the log handlers are flushed first. An MPI
    job (mpi4py's MPI_Finalize runs at exit) and a process that started worker processes leave the usual way."""
    code = main()
    if "mpi4py.MPI" in sys.modules or "multiprocessing" in sys.modules:
        sys.exit(code)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    logging.shutdown()
    os._exit(code)


def _call(args: argparse.Namespace) -> int:
    """Run the parsed command; its result on stdout, errors on stderr (exit 2), Ctrl-C exits 130."""
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
            print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        what = str(exc) or "no output written"
        if args.command == "uncertain":
            what = (f"the finished samples are in {os.path.join(args.out, 'samples.jsonl')}; continue with the "
                    "same command and --resume")
        print(f"{PROG}: interrupted; {what}", file=sys.stderr)
        return 130
    except Exception:
        comm = world()
        if comm is None:
            raise
        # an unexpected error on some ranks of a distributed run: the others would wait for them forever
        import traceback

        print(f"{PROG}: rank {comm.rank}: unexpected error; stopping every rank", file=sys.stderr)
        traceback.print_exc()
        sys.stderr.flush()
        comm.Abort(1)
        return 1


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
