"""VTK PolyData output of line data along boundaries (e.g. contact interfaces): one ``.vtp`` per output time
and a ``.pvd`` collection with the times, written atomically (ASCII, readable by ParaView and meshio)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import write_text_atomic


def _array(name: str, values: np.ndarray, components: int = 1) -> str:
    flat = " ".join(f"{float(v):.10g}" for v in np.asarray(values, dtype=float).ravel())
    return (f'<DataArray type="Float64" Name="{name}" NumberOfComponents="{components}" format="ascii">'
            f"{flat}</DataArray>\n")


def polyline_vtp(points: np.ndarray, segments: np.ndarray, point_data: dict[str, np.ndarray]) -> str:
    """The text of a .vtp file: ``points`` (m x 2 or 3), ``segments`` (k x 2 point indices), nodal arrays."""
    pts = np.zeros((len(points), 3))
    pts[:, :points.shape[1]] = points
    seg = np.asarray(segments, dtype=int).reshape(-1, 2)
    conn = " ".join(str(int(i)) for i in seg.ravel())
    offs = " ".join(str(2 * (k + 1)) for k in range(len(seg)))
    data = "".join(_array(name, vals) for name, vals in point_data.items())
    return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">\n<PolyData>\n'
            f'<Piece NumberOfPoints="{len(pts)}" NumberOfVerts="0" NumberOfLines="{len(seg)}" '
            'NumberOfStrips="0" NumberOfPolys="0">\n'
            f"<Points>\n{_array('Points', pts, 3)}</Points>\n"
            f"<PointData>\n{data}</PointData>\n"
            '<Lines>\n<DataArray type="Int64" Name="connectivity" format="ascii">'
            f"{conn}</DataArray>\n"
            f'<DataArray type="Int64" Name="offsets" format="ascii">{offs}</DataArray>\n</Lines>\n'
            "</Piece>\n</PolyData>\n</VTKFile>\n")


class LineSeries:
    """A time series of line data: ``directory/basename_stepNNNNN.vtp`` and ``basename.pvd``."""

    def __init__(self, directory: Path, basename: str):
        self.directory = Path(directory)
        self.basename = basename
        self.entries: list[tuple[float, str]] = []

    def write(self, time: float, points: np.ndarray, segments: np.ndarray, point_data: dict[str, np.ndarray]) -> None:
        name = f"{self.basename}_step{len(self.entries):05d}.vtp"
        write_text_atomic(self.directory / name, polyline_vtp(points, segments, point_data))
        self.entries.append((time, name))
        sets = "".join(f'<DataSet timestep="{t:.10g}" file="{f}"/>\n' for t, f in self.entries)
        write_text_atomic(self.directory / f"{self.basename}.pvd",
                          '<?xml version="1.0"?>\n<VTKFile type="Collection" version="1.0" '
                          f'byte_order="LittleEndian">\n<Collection>\n{sets}</Collection>\n</VTKFile>\n')
