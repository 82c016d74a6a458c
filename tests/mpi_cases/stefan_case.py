"""A small two-phase Stefan run of the built-in scene ``melting_block`` (frozen silt with an ice lens thawing under
a heated floor, granite below; :mod:`ngs_geomech.stefan.problem`), coarse and a few steps, on a serial or a
netgen distributed mesh: the same code path as ``ngs-geomech run`` takes for the Stefan problem.

    mpiexec -n 3 python stefan_case.py OUT.json [jacobi] [bddc]     (netgen keeps no elements on rank 0: 2 workers)

writes, on rank 0, for each preconditioner named (the distributed Newton path's GMRES; default bddc) the
temperatures at :data:`POINTS`, the Newton iterations per step, the GMRES iterations per Newton solve, the melted
volumes, the heat content and the energy balance of the summary, and the phase boundary (its segment count and
total length); under "one_phase" the one-phase Neumann strip (:func:`one_phase_strip`, default preconditioner),
under "contact" the message refusing a contact-interface scene (:func:`refused`). :func:`solve` and
:func:`one_phase_strip` run the same problems serially when ``comm`` is None (tests/test_mpi_stefan.py compares).
"""

from __future__ import annotations

import json
import sys

import numpy as np

OVERRIDES = ["mesh.maxh=0.35"]
"""Coarse: about 500 vertices."""

DT = 5 * 86400.0
"""Time step, s (5 days: the thaw front crosses about one element layer per step near the floor)."""

STEPS = 6

POINTS = np.array([[0.3, -0.2], [0.3, -0.6], [1.0, -0.5], [1.4, -1.2], [2.4, -0.3], [3.0, -0.4], [4.5, -1.0],
                   [1.0, -2.5], [5.0, -3.5], [0.5, -1.0]])
"""Sample points (m): under the floor, in and around the ice lens, outside the building, in the bedrock."""


def solve(comm=None, preconditioner: str = "bddc") -> dict:
    """The run on a serial mesh (``comm`` None) or on a distributed one (an mpi4py communicator; ``preconditioner``
    of its GMRES: "jacobi" or "bddc"); the dict of the module docstring (the same on every rank)."""
    from ngs_geomech import parallel
    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.io.meshdata import vertex_values
    from ngs_geomech.scene.parse import load_scene
    from ngs_geomech.stefan.problem import StefanRun
    from ngs_geomech.validation.validate import validate

    scene = load_scene("melting_block", OVERRIDES)
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh, comm=comm)
    run = StefanRun(scene, mesh, geo, krylov_preconditioner=preconditioner)
    run.set_initial(0.0)
    run.record(0.0)
    infos = []
    for k in range(STEPS):
        infos.append(run.step(k * DT, (k + 1) * DT, f"step {k + 1}"))
        run.record((k + 1) * DT)
    T = parallel.point_values(mesh, run.fields["temperature"], POINTS)[:, 0]
    summary = run.summary()["stefan"]
    iso = run.phase_boundary()
    seg = iso.as_segments()
    jac = run.solver.jac
    return {
        "elements_per_rank": [int(n) for n in parallel.allgather(mesh, mesh.ne)],
        "vertices": int(parallel.allsum(mesh, int(np.count_nonzero(run.forms.owned)))),
        "temperature": T.tolist(),
        "newton": [int(i.iterations) for i in infos],
        "krylov": list(getattr(jac, "krylov_iterations", [])),
        "krylov_unconverged": int(getattr(jac, "unconverged", 0)),
        "krylov_residual_max": float(max(getattr(jac, "residuals", []), default=0.0)),
        "factorizations": [int(i.factorizations) for i in infos],
        "phase_changes": [int(i.phase_changes) for i in infos],
        "boundary_heat": [float(i.boundary_heat) for i in infos],
        "source_heat": [float(i.source_heat) for i in infos],
        "melted_volume": summary["melted_volume"],
        "heat_content": run.records["heat_content"],
        "volume": {r: v["volume"] for r, v in summary["phase_change_regions"].items()},
        "imbalance_rel": summary["energy"]["imbalance_rel_max"],
        "phase_boundary_segments": int(len(seg)),
        "phase_boundary_length": float(np.sum(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1))) if len(seg) else 0.0,
        "phase_boundary_temperature_max_abs": (float(np.max(np.abs(iso.interpolate(
            vertex_values(run.forms.gf_temperature))))) if len(seg) else 0.0),
    }


def one_phase_strip(comm=None) -> dict:
    """The one-phase Neumann strip of :mod:`ngs_geomech.verification.stefan` (the solid at the melting
    temperature: a mushy region ahead of the front, held fixed in every Newton step), h = 0.05 m, dt = 0.2 h s/m,
    t = 0.1 ... 0.5 s, on a serial or distributed mesh (rank 0 meshes and distributes): Newton iterations per step,
    temperatures at points of the strip, heat content, melted volume, GMRES iterations and preconditioner builds."""
    import netgen.meshing as ngm
    import ngsolve as ngs

    from ngs_geomech import parallel
    from ngs_geomech.stefan.forms import StefanForms, StefanSetup
    from ngs_geomech.stefan.solver import StefanSolver
    from ngs_geomech.verification.stefan import ONE_PHASE, schedule, strip_mesh

    problem, h, t0, t1, height = ONE_PHASE, 0.05, 0.1, 0.5, 0.2
    length = problem.domain_length(t1)
    if comm is None:
        mesh = strip_mesh(length, height, h)
    elif comm.rank == 0:
        serial = strip_mesh(length, height, h)
        ngmesh = serial.ngmesh
        del serial                              # no ngsolve.Mesh of it may live while it is distributed
        mesh = ngs.Mesh(ngmesh.Distribute(comm))
    else:
        mesh = ngs.Mesh(ngm.Mesh.Receive(comm))
    forms = StefanForms(mesh, StefanSetup(materials={"pcm": problem.material},
                                          dirichlet={"hot": problem.t_hot, "far": problem.t_cold}))
    xs = np.array([v.point[0] for v in mesh.vertices]) if mesh.nv else np.zeros(0)
    solver = StefanSolver(forms)
    solver.set_initial(problem.temperature(xs, t0), (xs < problem.front(t0)).astype(float))
    newton = [solver.step(a, b).iterations for a, b in schedule(t0, t1, 0.2 * h)]
    points = np.column_stack([np.linspace(0.01, length - 0.01, 15), np.full(15, 0.5 * height)])
    return {"newton": newton, "temperature": parallel.point_values(mesh, forms.gf_temperature, points)[:, 0].tolist(),
            "heat_content": forms.heat_content(solver.e), "melted_volume": forms.melted_volume(solver.e),
            "krylov": list(getattr(solver.jac, "krylov_iterations", [])), "builds": solver.jac.factorizations}


def refused(comm) -> str:
    """The message with which the built-in scene ``contact_melting`` (heat through a contact interface: the mortar
    penalty) is refused on a distributed mesh ("" when it is not)."""
    from ngs_geomech.geometry.mesh import make_mesh
    from ngs_geomech.scene.parse import load_scene
    from ngs_geomech.stefan.problem import StefanRun
    from ngs_geomech.validation.validate import validate

    scene = load_scene("contact_melting", ["mesh.maxh=0.5"])
    geo = validate(scene)
    mesh = make_mesh(geo, scene.mesh, comm=comm)
    try:
        StefanRun(scene, mesh, geo)
    except ValueError as exc:
        return str(exc)
    return ""


if __name__ == "__main__":
    # mpi4py before ngsolve's first use of MPI
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    data = {name: solve(comm if comm.size > 1 else None, name) for name in sys.argv[2:] or ["bddc"]}
    if comm.size > 1:
        data["one_phase"] = one_phase_strip(comm)
        data["contact"] = refused(comm)
    if comm.rank == 0:
        with open(sys.argv[1], "w") as fh:
            json.dump(data, fh, indent=1)
