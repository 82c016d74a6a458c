"""One run of a time-dependent scene for the checkpoint tests (tests/test_mpi_resume.py), on a distributed mesh under
``mpiexec`` or serially, through :func:`ngs_geomech.api.run` (the path of ``ngs-geomech run``):

    mpiexec -n 3 python resume_case.py SCENE OUT RESULT.json [--fail-at N] [--resume] [--set key=value ...]

SCENE: a scene file or built-in name, or a ``.json`` file holding a scene dict.

``--fail-at N``: the N-th and later thermal solves (heat solves or Stefan steps) raise a SolverError on every rank
(a diverging step; ``--fail-contact-at N``: the mechanics solves with contact): the run saves its last good state
and stops. ``--resume``: continue the interrupted run into OUT.
Rank 0 writes RESULT.json: ``error`` (the message, or None), ``summary`` (probes, steps, resumed) and ``state``, the
parts' checkpointed vectors of the final state in the canonical numbering of :mod:`ngs_geomech.run.numbering`
(comparable between rank counts and serial runs).
"""

from __future__ import annotations

import argparse
import json
import sys


def canonical_state(result, comm=None) -> dict | None:
    """The parts' checkpointed vectors of ``result``'s final state in canonical numbering (name -> list); None on
    the ranks other than 0. Rank 0 of a distributed run meshes the scene again serially for the whole mesh's
    tables (netgen meshes the same scene the same way)."""
    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.run.numbering import RunNumbering, WholeMesh
    from ngs_geomech.validation.validate import validate

    model = result.model
    whole = None
    if comm is not None and comm.rank == 0:
        scene = model.scene
        serial = make_mesh(validate(scene), scene.mesh)
        whole = WholeMesh(serial.ngmesh)
        del serial
    numbering = RunNumbering(model.mesh, whole if comm is not None else None)
    out = {}
    for p in model.parts:
        arrays, _ = p.capture()
        for name, space in p.checkpoint_spaces().items():
            if name in arrays:
                vec = numbering.of(space).gather(arrays[name])
                if vec is not None:
                    out[name] = vec.tolist()
    return out if comm is None or comm.rank == 0 else None


def fail_thermal_solve_at(n: int, patch=setattr) -> None:
    """The n-th and later heat solves or Stefan steps raise a SolverError (on every rank: each calls them alike);
    ``patch`` replaces the methods (pytest's ``monkeypatch.setattr`` undoes it after a test)."""
    from ngs_geomech.errors import SolverError
    from ngs_geomech.heat.solver import HeatSolver
    from ngs_geomech.stefan.solver import StefanSolver

    calls = {"n": 0}

    def failing(original):
        def call(self, *args, **kwargs):
            calls["n"] += 1
            if calls["n"] >= n:               # and every retry (the Stefan step control retries with substeps)
                raise SolverError(f"injected divergence at thermal solve {n}")
            return original(self, *args, **kwargs)
        return call

    patch(HeatSolver, "solve", failing(HeatSolver.solve))
    patch(StefanSolver, "step", failing(StefanSolver.step))


def fail_contact_solve_at(n: int, patch=setattr) -> None:
    """The n-th and later mechanics solves with contact raise a SolverError (on every rank)."""
    from ngs_geomech.errors import SolverError
    from ngs_geomech.mechanics.contact import ElasticContactSolver

    original, calls = ElasticContactSolver.solve, {"n": 0}

    def solve(self, where):
        calls["n"] += 1
        if calls["n"] >= n:
            raise SolverError(f"injected divergence at contact solve {n}")
        return original(self, where)
    patch(ElasticContactSolver, "solve", solve)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scene")
    parser.add_argument("out")
    parser.add_argument("result")
    parser.add_argument("--fail-at", type=int, default=None)
    parser.add_argument("--fail-contact-at", type=int, default=None)
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--set", action="append", default=[])
    args = parser.parse_args(argv)

    from ngs_geomech import parallel
    from ngs_geomech.api import run
    from ngs_geomech.errors import ResumeError, SolverError

    comm = parallel.world()
    if args.fail_at is not None:
        fail_thermal_solve_at(args.fail_at)
    if args.fail_contact_at is not None:
        fail_contact_solve_at(args.fail_contact_at)
    data = {"error": None, "summary": None, "state": None}
    scene = args.scene
    if scene.endswith(".json"):                   # a scene dict (the --set values do not apply)
        from ngs_geomech.scene.parse import scene_from_dict

        with open(scene) as f:
            scene = scene_from_dict(json.load(f), source=scene)
    try:
        result = run(scene, args.out, overrides=args.set, progress=False, threads=1, resume=args.resume,
                     comm=comm)
    except (SolverError, ResumeError) as exc:
        data["error"] = f"{type(exc).__name__}: {exc}"
    else:
        s = result.summary
        data["summary"] = {"probes": s["probes"], "probe_series": s["probe_series"], "steps": s["steps"],
                           "resumed": s.get("resumed"), "mesh": s["mesh"]}
        data["state"] = canonical_state(result, comm)
    if comm is None or comm.rank == 0:
        with open(args.result, "w") as f:
            json.dump(data, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
