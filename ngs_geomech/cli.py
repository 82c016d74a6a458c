"""Command line: ``ngs-geomech run|validate|list``. It only parses arguments and calls the package."""

from __future__ import annotations

import argparse
import os
import sys

from .errors import GeomechError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="ngs-geomech", description="Coupled thermo-mechanics in geomechanics "
                                     "(NGSolve). Scenes are TOML files or built-in names (see 'list').")
    sub = parser.add_subparsers(dest="command", required=True)
    p_run = sub.add_parser("run", help="run a scene and write VTK, figures and summary.json")
    p_run.add_argument("scene", help="scene file or built-in scene name")
    p_run.add_argument("--out", help="output directory (replaced when the run succeeds)")
    p_run.add_argument("--resume", nargs="?", const=True, default=None, metavar="DIR",
                       help="continue the interrupted (killed, failed) time-dependent run into --out (or DIR) from "
                            "its last checkpoint; give the same scene and --set values (time steps, solver and "
                            "output settings may change)")
    p_run.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scene value, e.g. --set mesh.maxh=2 --set time.end='10 year'")
    p_run.add_argument("--quiet", action="store_true", help="no progress display")
    p_run.add_argument("--threads", type=int, default=None, help="number of threads (default: NGSolve's)")
    p_val = sub.add_parser("validate", help="check a scene (no meshing, no solving)")
    p_val.add_argument("scene")
    p_val.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    sub.add_parser("list", help="list the built-in scenes")
    args = parser.parse_args(argv)
    if args.command == "run":
        if isinstance(args.resume, str):
            if args.out is not None and os.path.realpath(args.out) != os.path.realpath(args.resume):
                parser.error(f"--out {args.out} and --resume {args.resume} name different directories")
            args.out = args.resume
        if args.out is None:
            parser.error("the following arguments are required: --out")

    from .api import list_builtin, run, validate_scene
    try:
        if args.command == "list":
            for name, path in list_builtin().items():
                print(f"{name:30s} {path}")
            return 0
        if args.command == "validate":
            summary = validate_scene(args.scene, args.overrides)
            print(summary)
            return 0
        result = run(args.scene, args.out, overrides=args.overrides, progress=not args.quiet,
                     threads=args.threads, resume=bool(args.resume))
        resumed = result.summary.get("resumed")
        note = f", resumed at step {resumed[-1]['step']} of {result.summary['steps']}" if resumed else ""
        print(f"wrote {result.out} ({result.summary['wall_time_s']['total_s']:.1f} s{note})")
        return 0
    except GeomechError as exc:
        print(f"ngs-geomech: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(f"ngs-geomech: interrupted; {exc or 'no output written'}", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
