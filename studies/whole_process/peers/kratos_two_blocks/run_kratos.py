"""The Kratos twin of studies/whole_process/two_blocks.toml: two elastic blocks pressed together, frictionless
mortar contact (augmented Lagrangian, ALMContactFrictionless), plane strain, P1 triangles on the mesh
ngs-geomech makes of the scene (two_blocks.mdpa, written by ../make_meshes.py).

Run from any folder with the peers environment: ``OMP_NUM_THREADS=1 ~/peers-venv/bin/python run_kratos.py``.
It runs the analysis of ProjectParameters.json (VTK output in vtk_output/) and writes kratos_summary.json: the
mean and the nodal contact pressures on the slave (upper) side (Pa), the contact force (N/m) and the extreme
vertical displacement (m).
"""

import json
import os
from pathlib import Path

HERE = Path(__file__).resolve().parent
os.chdir(HERE)

import KratosMultiphysics as KM  # noqa: E402
import KratosMultiphysics.ContactStructuralMechanicsApplication as CSMA  # noqa: E402
from KratosMultiphysics.StructuralMechanicsApplication.structural_mechanics_analysis import (  # noqa: E402
    StructuralMechanicsAnalysis,
)


def contact_figures(model) -> dict:
    """Nodal contact pressures on the slave side (Pa, compression positive), their integral over the joint (the
    contact force, N/m, trapezoidal rule along x) and its mean over the closed length."""
    slave = model["Structure.Slave_Part"]
    pts = sorted((n.X0, -n.GetValue(CSMA.AUGMENTED_NORMAL_CONTACT_PRESSURE)) for n in slave.Nodes)
    xs, ps = [p[0] for p in pts], [p[1] for p in pts]
    force = sum((xs[i + 1] - xs[i]) * (ps[i] + ps[i + 1]) / 2 for i in range(len(xs) - 1))
    closed = [x for x, p in pts if p > 0]
    length = max(closed) - min(closed) if closed else 0.0
    return {"slave_nodes_x_m": xs, "slave_pressures_Pa": ps, "contact_force_N_per_m": force,
            "closed_length_m": length, "mean_pressure_Pa": force / length if length else 0.0,
            "max_pressure_Pa": max(ps)}


def main() -> None:
    with open(HERE / "ProjectParameters.json") as f:
        parameters = KM.Parameters(f.read())
    model = KM.Model()
    analysis = StructuralMechanicsAnalysis(model, parameters)
    analysis.Run()
    structure = model["Structure"]
    uy = [n.GetSolutionStepValue(KM.DISPLACEMENT_Y) for n in structure.Nodes]
    summary = contact_figures(model)
    summary.update({"nodes": structure.NumberOfNodes(), "elements": structure.NumberOfElements(),
                    "min_displacement_y_m": min(uy), "max_abs_displacement_y_m": max(abs(u) for u in uy),
                    "base_reaction_y_N_per_m": sum(n.GetSolutionStepValue(KM.REACTION_Y)
                                                   for n in model["Structure.Base"].Nodes)})
    (HERE / "kratos_summary.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
