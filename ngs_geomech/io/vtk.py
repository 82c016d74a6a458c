"""VTK output: a series of .vtu files and a .pvd with the times (NGSolve's VTKOutput, headless)."""

from __future__ import annotations

from pathlib import Path

import ngsolve as ngs


class VtkSeries:
    """Write named coefficient functions over the mesh at chosen times into ``directory/basename*``."""

    def __init__(self, mesh, fields: dict[str, object], directory: Path, basename: str, subdivision: int = 0):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.names = list(fields)
        self.out = ngs.VTKOutput(mesh, coefs=list(fields.values()), names=self.names,
                                 filename=str(self.directory / basename), subdivision=subdivision,
                                 floatsize="double")
        self.count = 0

    def write(self, time: float) -> None:
        self.out.Do(time=time)
        self.count += 1
