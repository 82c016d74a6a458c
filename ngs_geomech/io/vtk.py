"""VTK output: a series of .vtu files and a .pvd with the times (NGSolve's VTKOutput, headless).

Each output time is one file, ``basename.vtu`` for the first and ``basename_stepNNNNN.vtu`` after it (NGSolve's
own naming), written under a temporary name and renamed; the ``.pvd`` lists every file written so far and is
replaced atomically after each one. ``entries`` (time, file) is what a checkpoint keeps; :meth:`restore`
continues a series from them.

On a distributed mesh (MPI) every rank with elements writes its part of each time, ``<file>_procK.vtu``, and the
``.pvd`` lists every part of every time (``part="K"``): ParaView shows them as one data set.
"""

from __future__ import annotations

import os
from pathlib import Path

import ngsolve as ngs

from .. import parallel
from ..scene.names import plain_file_name
from .atomic import write_text_atomic


class VtkSeries:
    """Write named coefficient functions over the mesh at chosen times into ``directory/basename*``."""

    def __init__(self, mesh, fields: dict[str, object], directory: Path, basename: str, subdivision: int = 0):
        self.basename = plain_file_name(basename)     # every file stays inside ``directory``
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.mesh = mesh
        self.names = list(fields)
        self.coefs = list(fields.values())
        self.subdivision = subdivision
        self.entries: list[tuple[float, str]] = []

    @property
    def count(self) -> int:
        return len(self.entries)

    def _filename(self, k: int) -> str:
        return f"{self.basename}.vtu" if k == 0 else f"{self.basename}_step{k:05d}.vtu"

    def write(self, time: float) -> None:
        if parallel.distributed(self.mesh):
            self._write_parts(time)
            return
        name = self._filename(len(self.entries))
        tmp = f".{name[:-4]}.tmp-{os.getpid()}"
        out = ngs.VTKOutput(self.mesh, coefs=self.coefs, names=self.names, filename=str(self.directory / tmp),
                            subdivision=self.subdivision, floatsize="double")
        out.Do(time=time)
        os.replace(self.directory / f"{tmp}.vtu", self.directory / name)
        self.entries.append((float(time), name))
        self._write_pvd()

    def _write_parts(self, time: float) -> None:
        """A distributed mesh (collective): every rank with elements writes its part ``<name>_procK.vtu``
        (NGSolve's naming), rank 0 the collection with one data set per part and time (``part`` attribute)."""
        name = self._filename(len(self.entries))[:-4]
        rank = self.mesh.comm.rank
        tmp = f".{name}.tmp"
        if self.mesh.ne:
            out = ngs.VTKOutput(self.mesh, coefs=self.coefs, names=self.names, filename=str(self.directory / tmp),
                                subdivision=self.subdivision, floatsize="double")
            out.Do(time=time)
            os.replace(self.directory / f"{tmp}_proc{rank}.vtu", self.directory / f"{name}_proc{rank}.vtu")
        ranks = [r for r, ne in enumerate(parallel.allgather(self.mesh, self.mesh.ne)) if ne]
        self.entries.append((float(time), name))
        if rank == 0:
            (self.directory / f"{tmp}.pvd").unlink(missing_ok=True)      # NGSolve's own collection of the tmp
            self._write_pvd(ranks)

    def _write_pvd(self, parts: list[int] | None = None) -> None:
        if parts is None:
            sets = "".join(f'<DataSet timestep="{t:.12g}" file="{f}"/>\n' for t, f in self.entries)
        else:
            sets = "".join(f'<DataSet timestep="{t:.12g}" part="{r}" file="{f}_proc{r}.vtu"/>\n'
                           for t, f in self.entries for r in parts)
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
