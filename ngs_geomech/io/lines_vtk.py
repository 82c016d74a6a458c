"""VTK PolyData output of data on boundaries (e.g. contact interfaces): line segments (2D scenes) or
triangles (3D scenes); one ``.vtp`` per output time and a ``.pvd`` collection with the times, written
atomically (ASCII, readable by ParaView and meshio)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..scene.names import plain_file_name
from .atomic import write_text_atomic


def _array(name: str, values: np.ndarray, components: int = 1) -> str:
    flat = " ".join(f"{float(v):.10g}" for v in np.asarray(values, dtype=float).ravel())
    return (f'<DataArray type="Float64" Name="{name}" NumberOfComponents="{components}" format="ascii">'
            f"{flat}</DataArray>\n")


def polyline_vtp(points: np.ndarray, cells: np.ndarray, point_data: dict[str, np.ndarray]) -> str:
    """The text of a .vtp file: ``points`` (m x 2 or 3), ``cells`` (k x 2 point indices: line segments, written
    as ``<Lines>``; k x 3: triangles, written as ``<Polys>``), nodal arrays (m values each; an m x c array is
    written with c components)."""
    pts = np.zeros((len(points), 3))
    pts[:, :points.shape[1]] = points
    cells = np.asarray(cells, dtype=int)
    if cells.ndim != 2:
        cells = cells.reshape(-1, 2)
    nc = cells.shape[1]
    if nc not in (2, 3):
        raise ValueError(f"boundary cells must have 2 (segments) or 3 (triangles) points, got {nc}")
    conn = " ".join(str(int(i)) for i in cells.ravel())
    offs = " ".join(str(nc * (k + 1)) for k in range(len(cells)))
    data = "".join(_array(name, vals, 1 if np.ndim(vals) == 1 else np.shape(vals)[1])
                   for name, vals in point_data.items())
    nlines, npolys = (len(cells), 0) if nc == 2 else (0, len(cells))
    tag = "Lines" if nc == 2 else "Polys"
    return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">\n<PolyData>\n'
            f'<Piece NumberOfPoints="{len(pts)}" NumberOfVerts="0" NumberOfLines="{nlines}" '
            f'NumberOfStrips="0" NumberOfPolys="{npolys}">\n'
            f"<Points>\n{_array('Points', pts, 3)}</Points>\n"
            f"<PointData>\n{data}</PointData>\n"
            f'<{tag}>\n<DataArray type="Int64" Name="connectivity" format="ascii">'
            f"{conn}</DataArray>\n"
            f'<DataArray type="Int64" Name="offsets" format="ascii">{offs}</DataArray>\n</{tag}>\n'
            "</Piece>\n</PolyData>\n</VTKFile>\n")


class LineSeries:
    """A time series of boundary data (segments or triangles): ``directory/basename_stepNNNNN.vtp`` and
    ``basename.pvd``."""

    def __init__(self, directory: Path, basename: str):
        self.directory = Path(directory)
        self.basename = plain_file_name(basename)     # every file stays inside ``directory``
        self.entries: list[tuple[float, str]] = []

    def write(self, time: float, points: np.ndarray, cells: np.ndarray, point_data: dict[str, np.ndarray]) -> None:
        name = f"{self.basename}_step{len(self.entries):05d}.vtp"
        write_text_atomic(self.directory / name, polyline_vtp(points, cells, point_data))
        self.entries.append((time, name))
        self._write_pvd()

    def _write_pvd(self) -> None:
        sets = "".join(f'<DataSet timestep="{t:.10g}" file="{f}"/>\n' for t, f in self.entries)
        write_text_atomic(self.directory / f"{self.basename}.pvd",
                          '<?xml version="1.0"?>\n<VTKFile type="Collection" version="1.0" '
                          f'byte_order="LittleEndian">\n<Collection>\n{sets}</Collection>\n</VTKFile>\n')

    def restore(self, entries: list) -> None:
        """Continue the series after ``entries`` (from a checkpoint): files written after them are removed."""
        self.entries = [(float(t), str(f)) for t, f in entries]
        keep = {f for _, f in self.entries}
        for p in self.directory.glob(f"{self.basename}_step*.vtp"):
            if p.name not in keep:
                p.unlink()
        if self.entries:
            self._write_pvd()
        else:
            (self.directory / f"{self.basename}.pvd").unlink(missing_ok=True)
