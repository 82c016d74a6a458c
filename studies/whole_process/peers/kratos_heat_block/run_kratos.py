"""The Kratos twin of studies/whole_process/heat_block.toml: steady conduction in a 1 m x 1 m block, T = 80 on
x = 0 and 10 on x = 1, conductivity 3 W/(m K), P1 triangles (LaplacianElement2D3N) on the mesh ngs-geomech
makes of the scene (heat_block.mdpa, written by ../make_meshes.py).

Run from any folder with the peers environment: ``OMP_NUM_THREADS=1 ~/peers-venv/bin/python run_kratos.py``.
It runs the analysis of ProjectParameters.json (VTK output in vtk_output/) and writes kratos_summary.json: the
largest nodal deviation from the closed form T = 80 - 70 x (K) and the heat flow through the hot side (W/m;
closed form k * 70 K/m = 210 W/m).
"""

import json
import os
from pathlib import Path

HERE = Path(__file__).resolve().parent
os.chdir(HERE)

import KratosMultiphysics as KM  # noqa: E402
from KratosMultiphysics.ConvectionDiffusionApplication.convection_diffusion_analysis import (  # noqa: E402
    ConvectionDiffusionAnalysis,
)


def main() -> None:
    with open(HERE / "ProjectParameters.json") as f:
        parameters = KM.Parameters(f.read())
    model = KM.Model()
    ConvectionDiffusionAnalysis(model, parameters).Run()
    part = model["ThermalModelPart"]
    error = max(abs(n.GetSolutionStepValue(KM.TEMPERATURE) - (80.0 - 70.0 * n.X0)) for n in part.Nodes)
    hot_flow = sum(n.GetSolutionStepValue(KM.REACTION_FLUX) for n in model["ThermalModelPart.Hot"].Nodes)
    summary = {"nodes": part.NumberOfNodes(), "elements": part.NumberOfElements(),
               "max_nodal_error_K": error, "hot_side_heat_flow_W_per_m": hot_flow}
    (HERE / "kratos_summary.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
