"""VTK output: a series of .vtu files and a .pvd with the times (NGSolve's VTKOutput, headless)."""

from __future__ import annotations

from pathlib import Path

import ngsolve as ngs

from .atomic import write_text_atomic


class VtkSeries:
    """Write named coefficient functions over the mesh at chosen times into ``directory/basename*``."""

    def __init__(self, mesh, fields: dict[str, object], directory: Path, basename: str, subdivision: int = 0):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.names = list(fields)
        self.basename = basename
        self.out = ngs.VTKOutput(mesh, coefs=list(fields.values()), names=self.names,
                                 filename=str(self.directory / basename), subdivision=subdivision,
                                 floatsize="double")
        self.count = 0

    def write(self, time: float) -> None:
        self.out.Do(time=time)
        self.count += 1
        if self.count == 1:
            # NGSolve writes the .pvd only from the second output on; a steady run writes one output, and
            # its series must have a .pvd too (NGSolve's own replaces this one at the next write)
            write_text_atomic(self.directory / f"{self.basename}.pvd",
                              '<?xml version="1.0"?>\n<VTKFile type ="Collection" version="1.0" '
                              'byte_order="LittleEndian">\n<Collection>\n'
                              f'<DataSet timestep="{time:g}" file="{self.basename}.vtu"/>\n'
                              "</Collection>\n</VTKFile>\n")
