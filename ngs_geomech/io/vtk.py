"""VTK output: a series of .vtu files and a .pvd with the times (NGSolve's VTKOutput, headless).

Each output time is one file, ``basename.vtu`` for the first and ``basename_stepNNNNN.vtu`` after it (NGSolve's
own naming), written under a temporary name and renamed; the ``.pvd`` lists every file written so far and is
replaced atomically after each one. ``entries`` (time, file) is what a checkpoint keeps; :meth:`restore`
continues a series from them.
"""

from __future__ import annotations

import os
from pathlib import Path

import ngsolve as ngs

from .atomic import write_text_atomic


class VtkSeries:
    """Write named coefficient functions over the mesh at chosen times into ``directory/basename*``."""

    def __init__(self, mesh, fields: dict[str, object], directory: Path, basename: str, subdivision: int = 0):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.mesh = mesh
        self.names = list(fields)
        self.coefs = list(fields.values())
        self.basename = basename
        self.subdivision = subdivision
        self.entries: list[tuple[float, str]] = []

    @property
    def count(self) -> int:
        return len(self.entries)

    def _filename(self, k: int) -> str:
        return f"{self.basename}.vtu" if k == 0 else f"{self.basename}_step{k:05d}.vtu"

    def write(self, time: float) -> None:
        name = self._filename(len(self.entries))
        tmp = f".{name[:-4]}.tmp-{os.getpid()}"
        out = ngs.VTKOutput(self.mesh, coefs=self.coefs, names=self.names, filename=str(self.directory / tmp),
                            subdivision=self.subdivision, floatsize="double")
        out.Do(time=time)
        os.replace(self.directory / f"{tmp}.vtu", self.directory / name)
        self.entries.append((float(time), name))
        self._write_pvd()

    def _write_pvd(self) -> None:
        sets = "".join(f'<DataSet timestep="{t:.12g}" file="{f}"/>\n' for t, f in self.entries)
        write_text_atomic(self.directory / f"{self.basename}.pvd",
                          '<?xml version="1.0"?>\n<VTKFile type="Collection" version="1.0" '
                          f'byte_order="LittleEndian">\n<Collection>\n{sets}</Collection>\n</VTKFile>\n')

    def restore(self, entries: list) -> None:
        """Continue the series after ``entries`` (from a checkpoint): files written after them are removed."""
        self.entries = [(float(t), str(f)) for t, f in entries]
        keep = {f for _, f in self.entries}
        for p in [self.directory / f"{self.basename}.vtu", *self.directory.glob(f"{self.basename}_step*.vtu")]:
            if p.name not in keep and p.exists():
                p.unlink()
        if self.entries:
            self._write_pvd()
        else:
            (self.directory / f"{self.basename}.pvd").unlink(missing_ok=True)
