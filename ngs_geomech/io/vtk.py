"""VTK output: a series of .vtu files and a .pvd with the times, headless.

Each field is evaluated once per output time at the vertices of every element (NGSolve's
``MapToAllElements`` with the element's vertex rule, one vectorised evaluation per field) and written as a
discontinuous linear field (every element keeps its own copy of its vertices, so stresses and other
element-wise fields keep their jumps) into a binary, zlib-compressed VTU (meshio): coordinates in double, field
values in single precision (7 significant digits: what a picture needs; summary.json and the probes carry the
full values). ``subdivision`` > 0 (curved
or high-order fields drawn on subdivided elements) is written by NGSolve's ``VTKOutput`` instead, which
evaluates every field point by point (measured on repository_3d: many times slower).

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
import numpy as np

from .. import parallel
from ..scene.names import plain_file_name
from .atomic import write_text_atomic

VERTICES = {
    ngs.ET.TRIG: ("triangle", [(1, 0, 0), (0, 1, 0), (0, 0, 0)]),
    ngs.ET.QUAD: ("quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]),
    ngs.ET.TET: ("tetra", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0)]),
    ngs.ET.HEX: ("hexahedron", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1),
                                (0, 1, 1)]),
    ngs.ET.PRISM: ("wedge", [(1, 0, 0), (0, 1, 0), (0, 0, 0), (1, 0, 1), (0, 1, 1), (0, 0, 1)]),
}
"""NGSolve element type -> (meshio cell type, the reference coordinates of its vertices in NGSolve's order)."""


class ElementVertices:
    """The vertices of every volume element of ``mesh`` as mapped points (each element its own copies, in the
    mesh's element order): ``points`` (n x 3, m), ``cells`` [(meshio type, connectivity)], ``mips`` (the mapped
    points to evaluate CoefficientFunctions at) and :meth:`shaped` (values as VTK reads them)."""

    def __init__(self, mesh):
        types = [el.type for el in mesh.Elements(ngs.VOL)]
        unknown = sorted({str(t) for t in types if t not in VERTICES})
        if unknown:
            raise ValueError(f"VTK output: element types {unknown} are not supported")
        rules = {t: ngs.IntegrationRule(VERTICES[t][1], [0.0] * len(VERTICES[t][1])) for t in set(types)}
        self.mips = mesh.MapToAllElements(rules, ngs.VOL)
        xyz = [ngs.x, ngs.y, ngs.z][:mesh.dim]
        pts = np.asarray(ngs.CoefficientFunction(tuple(xyz))(self.mips), dtype=float).reshape(-1, mesh.dim)
        self.points = np.zeros((len(pts), 3))
        self.points[:, :mesh.dim] = pts
        sizes = np.array([len(VERTICES[t][1]) for t in types], dtype=int)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        self.cells = []
        for t in sorted(set(types), key=str):
            mask = np.array([u == t for u in types])
            n = len(VERTICES[t][1])
            self.cells.append((VERTICES[t][0], starts[mask][:, None] + np.arange(n)[None, :]))
        self.dim = mesh.dim

    def shaped(self, v: np.ndarray) -> np.ndarray:
        """Values (n x components) as VTK reads them: (n,) for a scalar, (n, 3) for a vector (2D vectors padded
        with 0 for ParaView), (n, 9) for a tensor (3 x 3; a 2D tensor in its upper-left block)."""
        d = self.dim
        if v.shape[1] == 1:
            return v[:, 0]
        if v.shape[1] == d and d == 2:
            return np.column_stack([v, np.zeros(len(v))])
        if v.shape[1] == d * d and d == 2:
            t = np.zeros((len(v), 3, 3))
            t[:, :2, :2] = v.reshape(-1, 2, 2)
            return t.reshape(-1, 9)
        return v


class VtkSeries:
    """Write named coefficient functions over the mesh at chosen times into ``directory/basename*``.
    ``derived``: name -> (source name, function): a field computed from another field's values at the points
    (n x components -> n or n x components; e.g. principal stresses from the stress tensor by numpy) instead of
    evaluating its own CoefficientFunction (subdivision 0)."""

    def __init__(self, mesh, fields: dict[str, object], directory: Path, basename: str, subdivision: int = 0,
                 derived: dict | None = None):
        self.basename = plain_file_name(basename)     # every file stays inside ``directory``
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.mesh = mesh
        self.names = list(fields)
        self.coefs = list(fields.values())
        self.subdivision = subdivision
        self.entries: list[tuple] = []       # (t, file) or, distributed, (t, name, ranks with a part)
        self._vertices: tuple | None = None       # (mesh, ElementVertices) of the last fast write
        self._compiled: tuple | None = None       # (ids of the fields, their compiled tuple, their dimensions)
        self.derived = dict(derived or {})

    def _fast(self, path: Path) -> None:
        """The fields at the element vertices into ``path`` (a binary, compressed VTU; module docstring)."""
        import meshio

        if self._vertices is None or self._vertices[0] is not self.mesh:
            self._vertices = (self.mesh, ElementVertices(self.mesh))
        ev = self._vertices[1]
        evaluated = [(n, c) for n, c in zip(self.names, self.coefs) if n not in self.derived]
        key = tuple(id(c) for _, c in evaluated)
        if self._compiled is None or self._compiled[0] != key:
            # one compiled tuple of every field: shared subexpressions (the stress in its measures) evaluated once
            self._compiled = (key, ngs.CoefficientFunction(tuple(c for _, c in evaluated)).Compile(),
                              [c.dim for _, c in evaluated])
        _, compiled, dims = self._compiled
        flat = np.asarray(compiled(ev.mips), dtype=float).reshape(len(ev.points), -1)
        bounds = np.cumsum([0] + dims)
        raw = {n: flat[:, a:b] for (n, _), a, b in zip(evaluated, bounds[:-1], bounds[1:])}
        raw.update({n: np.asarray(fn(raw[src])).reshape(len(ev.points), -1) for n, (src, fn) in self.derived.items()
                    if n in self.names})
        data = {n: ev.shaped(raw[n]).astype(np.float32) for n in self.names}
        meshio.write(path, meshio.Mesh(ev.points, ev.cells, point_data=data), file_format="vtu", binary=True,
                     compression="zlib")

    def _write_file(self, base: Path, time: float) -> Path:
        """One output time into ``base``.vtu (a distributed mesh: NGSolve's ``base_procK.vtu`` naming)."""
        if self.subdivision == 0:
            rank = self.mesh.comm.rank if parallel.distributed(self.mesh) else None
            path = base.with_name(base.name + (f"_proc{rank}.vtu" if rank is not None else ".vtu"))
            self._fast(path)
            return path
        out = ngs.VTKOutput(self.mesh, coefs=self.coefs, names=self.names, filename=str(base),
                            subdivision=self.subdivision, floatsize="double")
        out.Do(time=time)
        if parallel.distributed(self.mesh):
            return base.with_name(base.name + f"_proc{self.mesh.comm.rank}.vtu")
        return base.with_name(base.name + ".vtu")

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
        written = self._write_file(self.directory / f".{name[:-4]}.tmp-{os.getpid()}", time)
        os.replace(written, self.directory / name)
        self.entries.append((float(time), name))
        self._write_pvd()

    def _write_parts(self, time: float) -> None:
        """A distributed mesh (collective): every rank with elements writes its part ``<name>_procK.vtu``
        (NGSolve's naming), rank 0 the collection with one data set per part and time (``part`` attribute)."""
        name = self._filename(len(self.entries))[:-4]
        rank = self.mesh.comm.rank
        if self.mesh.ne:
            written = self._write_file(self.directory / f".{name}.tmp", time)
            os.replace(written, self.directory / f"{name}_proc{rank}.vtu")
        ranks = [r for r, ne in enumerate(parallel.allgather(self.mesh, self.mesh.ne)) if ne]
        self.entries.append((float(time), name, ranks))
        if rank == 0:
            (self.directory / f".{name}.tmp.pvd").unlink(missing_ok=True)    # VTKOutput's collection (subdivision)
            self._write_pvd()

    @staticmethod
    def _files(entry: tuple) -> list[str]:
        """The files of one entry: the .vtu, or a distributed run's parts (a resumed run's entries may come from
        runs on other rank counts)."""
        return [entry[1]] if len(entry) == 2 else [f"{entry[1]}_proc{r}.vtu" for r in entry[2]]

    def _write_pvd(self) -> None:
        sets = "".join(f'<DataSet timestep="{e[0]:.12g}" file="{f}"/>\n' if len(e) == 2 else
                       f'<DataSet timestep="{e[0]:.12g}" part="{r}" file="{f}"/>\n'
                       for e in self.entries for r, f in zip(e[2] if len(e) > 2 else [None], self._files(e)))
        write_text_atomic(self.directory / f"{self.basename}.pvd",
                          '<?xml version="1.0"?>\n<VTKFile type="Collection" version="1.0" '
                          f'byte_order="LittleEndian">\n<Collection>\n{sets}</Collection>\n</VTKFile>\n')

    def restore(self, entries: list, files: bool = True) -> None:
        """Continue the series after ``entries`` (from a checkpoint): files written after them are removed
        (``files`` False: the entries only, on the ranks other than 0 of a distributed run)."""
        self.entries = [(float(e[0]), str(e[1])) if len(e) == 2 else (float(e[0]), str(e[1]), [int(r) for r in e[2]])
                        for e in entries]
        if not files:
            return
        keep = {f for e in self.entries for f in self._files(e)}
        for p in [self.directory / f"{self.basename}.vtu", *self.directory.glob(f"{self.basename}_step*.vtu"),
                  *self.directory.glob(f"{self.basename}_proc*.vtu")]:
            if p.name not in keep and p.exists():
                p.unlink()
        if self.entries:
            self._write_pvd()
        else:
            (self.directory / f"{self.basename}.pvd").unlink(missing_ok=True)
