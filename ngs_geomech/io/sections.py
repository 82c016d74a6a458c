"""Plane sections of a 3D domain for figures (plain arrays; the fields are evaluated by the caller): a plane
(:class:`SectionPlane`) with its in-plane axes, the regular grid of points a field is sampled at on it, and the
cut of the mesh's surface triangles (outer boundaries and interfaces) by it, the blocks' outlines."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .layout import Frame

AXES = "xyz"
GRID_POINTS = 240
"""Grid points along the longer drawn side of a section (the shorter side gets as many per drawn length)."""


@dataclass(frozen=True)
class SectionPlane:
    """The plane through ``point`` with unit normal ``normal`` (3-vectors, m) and its in-plane axes ``u``,
    ``v`` (unit vectors, u x v = normal or a coordinate plane's own axes): a point p of the plane has the
    in-plane coordinates (p . u, p . v) (m), its coordinates themselves on a plane normal to x, y or z.
    ``labels`` name them; ``window`` = [umin, umax, vmin, vmax] (m) limits the figure (None: the domain's
    bounding box cut by the plane); ``name`` goes into the file names."""

    name: str
    point: tuple
    normal: tuple
    u: tuple
    v: tuple
    labels: tuple[str, str]
    window: tuple | None = None

    @classmethod
    def through(cls, name: str, point, normal, window=None) -> SectionPlane:
        """The plane through ``point`` normal to ``normal`` (any nonzero 3-vector). A plane normal to a
        coordinate axis has the other two axes in order (normal y: x and z); another plane has v up the plane
        (the steepest ascent of z in it; a vertical plane: z) and u = v x normal, horizontal."""
        n = np.asarray(normal, dtype=float)
        n = n / np.linalg.norm(n)
        axis = int(np.argmax(np.abs(n)))
        if np.allclose(np.delete(n, axis), 0.0, atol=1e-12):
            i, j = (k for k in range(3) if k != axis)
            u, v = np.eye(3)[i], np.eye(3)[j]
            labels = (f"{AXES[i]} (m)", f"{AXES[j]} (m)")
        else:
            v = np.array([0.0, 0.0, 1.0]) - n[2] * n
            v /= np.linalg.norm(v)
            u = np.cross(v, n)
            labels = (f"along ({_vec(u)}) (m)", f"up the plane, along ({_vec(v)}) (m)")
        return cls(name, tuple(map(float, point)), tuple(n), tuple(u), tuple(v), labels,
                   None if window is None else tuple(map(float, window)))

    @classmethod
    def mid_planes(cls, lo, hi) -> list[SectionPlane]:
        """The planes through the centre of the box (lo, hi) normal to x, y and z (named 'x', 'y', 'z')."""
        centre = 0.5 * (np.asarray(lo, dtype=float) + np.asarray(hi, dtype=float))
        return [cls.through(AXES[k], centre, np.eye(3)[k]) for k in range(3)]

    @property
    def description(self) -> str:
        """'y = 0 m' for a plane normal to an axis, else 'through (x, y, z) m, normal (nx, ny, nz)'."""
        n = np.asarray(self.normal)
        axis = int(np.argmax(np.abs(n)))
        if np.allclose(np.delete(n, axis), 0.0, atol=1e-12):
            return f"{AXES[axis]} = {self.point[axis]:.4g} m"
        return f"through ({_vec(self.point)}) m, normal ({_vec(n)})"

    @property
    def heading(self) -> str:
        """The name and :attr:`description` ('across_tunnel: x = 0 m'; a mid-plane: 'x = 1.5 m')."""
        return self.description if self.name in tuple(AXES) else f"{self.name}: {self.description}"

    def extent(self, lo, hi) -> tuple[float, float, float, float]:
        """[umin, umax, vmin, vmax]: the window, else the in-plane box around the section of the box (lo, hi) by
        the plane (the points where it cuts the box's 12 edges; the box's corners projected onto the plane when
        it misses the box)."""
        if self.window is not None:
            return self.window
        corners = np.array([[(lo, hi)[(k >> d) & 1][d] for d in range(3)] for k in range(8)], dtype=float)
        d = (corners - np.asarray(self.point)) @ np.asarray(self.normal)
        cuts = [corners[i] + d[i] / (d[i] - d[j]) * (corners[j] - corners[i]) if d[i] != d[j] else corners[i]
                for i in range(8) for j in (i | 1 << k for k in range(3)) if j != i and d[i] * d[j] <= 0]
        ab = self.to_plane(np.array(cuts) if cuts else corners)
        return float(ab[:, 0].min()), float(ab[:, 0].max()), float(ab[:, 1].min()), float(ab[:, 1].max())

    def grid(self, lo, hi, n: int = GRID_POINTS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The sample grid on the plane within :meth:`extent`: in-plane coordinates ``a`` (na,), ``b`` (nb,) and
        the points (nb * na, 3) in space, row by row (b outer), about as many per drawn length on both sides
        (a very thin section's short side is drawn stretched, :class:`~.layout.Frame`)."""
        a0, a1, b0, b1 = self.extent(lo, hi)
        w, h = Frame.of((a0, b0), (a1, b1)).shown
        na, nb = (n, max(8, round(n * h / w))) if w >= h else (max(8, round(n * w / h)), n)
        a, b = np.linspace(a0, a1, na), np.linspace(b0, b1, nb)
        ga, gb = np.meshgrid(a, b)
        return a, b, self.to_space(ga.ravel(), gb.ravel())

    def to_space(self, a, b) -> np.ndarray:
        """The points (n, 3) of the plane with in-plane coordinates ``a``, ``b``."""
        n = np.asarray(self.normal)
        offset = float(np.dot(self.point, n))
        return (np.multiply.outer(a, self.u) + np.multiply.outer(b, self.v) + offset * n).reshape(-1, 3)

    def to_plane(self, xyz) -> np.ndarray:
        """In-plane coordinates (..., 2) of points (..., 3)."""
        xyz = np.asarray(xyz, dtype=float)
        return np.stack([xyz @ np.asarray(self.u), xyz @ np.asarray(self.v)], axis=-1)

    def cut(self, triangles: np.ndarray) -> np.ndarray:
        """The segments (k, 2, 2), in-plane coordinates, where the plane cuts the triangles (nt, 3, 3): each
        triangle with vertices on both sides (a vertex on the plane counts to the positive side) gives one."""
        tri = np.asarray(triangles, dtype=float).reshape(-1, 3, 3)
        d = (tri - np.asarray(self.point)) @ np.asarray(self.normal)          # (nt, 3) signed distances
        side = d >= 0
        crossing = side.any(axis=1) & ~side.all(axis=1)
        tri, d, side = tri[crossing], d[crossing], side[crossing]
        ends = []
        for i, j in ((0, 1), (1, 2), (2, 0)):
            cuts = side[:, i] != side[:, j]
            t = np.where(cuts, d[:, i] / np.where(cuts, d[:, i] - d[:, j], 1.0), 0.0)
            ends.append((cuts, tri[:, i] + t[:, None] * (tri[:, j] - tri[:, i])))
        points = np.stack([p for _, p in ends], axis=1)                        # (k, 3 edges, 3)
        mask = np.stack([c for c, _ in ends], axis=1)                          # exactly two edges per triangle
        segments = points[mask].reshape(-1, 2, 3)
        return self.to_plane(segments)


def _vec(a) -> str:
    return ", ".join(f"{x:.3g}" for x in np.where(np.abs(a) < 1e-12, 0.0, a))
