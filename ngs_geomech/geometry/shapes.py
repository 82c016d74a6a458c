"""netgen.occ shapes of single blocks, with their own sides named by selectors.

A 2D block is an OCC face in the x-y plane (in axisymmetric scenes x is the radius r and y the axial
coordinate z); a 3D block is a solid. Sides are edges (2D) or faces (3D). A prism is a polygon or profile outline
drawn in a plane (origin, in-plane directions u, v) and extruded; its side faces take the outline's side names.
An imported block (:mod:`.imports`) may hold several regions (the file's named solids).
"""

from __future__ import annotations

import numpy as np
from netgen import occ

from ..scene.model import SHAPES_2D, SHAPES_3D, Block
from .imports import read_import


def sides(shape, dim: int):
    """The boundary entities of a shape: edges in 2D, faces in 3D."""
    return shape.edges if dim == 2 else shape.faces


def cells(shape, dim: int):
    """The cells of a shape: faces in 2D, solids in 3D."""
    return shape.faces if dim == 2 else shape.solids


def make_block(block: Block, dim: int):
    """Build the OCC shape of one block, name its cells and its sides (selectors, polygon/profile names).

    Returns the shape; raises ValueError naming the missing or wrong data.
    """
    s = block.shape
    if dim == 2 and s not in SHAPES_2D:
        raise ValueError(f"shape {s!r} is a 3D shape; 2D shapes are {', '.join(SHAPES_2D)}")
    if dim == 3 and s not in SHAPES_3D:
        raise ValueError(f"shape {s!r} is a 2D shape; 3D shapes are {', '.join(SHAPES_3D)}")
    shape = BUILDERS[s](block)
    box = declared_extent(block, dim)
    if box is not None and not 0 < abs(shape.mass) <= 1.01 * float(np.prod(box[1] - box[0])):
        raise ValueError(f"the geometry kernel built a {'face' if dim == 2 else 'solid'} of measure "
                         f"{shape.mass:.3g} from this block's data (its box is {np.prod(box[1] - box[0]):.3g}): "
                         "check its coordinates")
    if s != "import":       # an import's cells carry their regions' names (Block.solids)
        cells(shape, dim).name = block.name
    if block.maxh is not None:
        cells(shape, dim).maxh = block.maxh
    _name_sides(shape, block, dim)
    return shape


def _rectangle(block: Block):
    _need(block, "origin", 2)
    _need(block, "size", 2)
    if min(block.size) <= 0:
        raise ValueError(f"size {block.size} must be positive")
    (x0, y0), (w, h) = block.origin, block.size
    shape = occ.WorkPlane().MoveTo(x0, y0).Rectangle(w, h).Face()
    if not shape.edges:
        # netgen's WorkPlane.Rectangle returns an unbounded face without edges for sides above about
        # 5.3e5 m; the same outline point by point is bounded
        shape = occ.WorkPlane().MoveTo(x0, y0).LineTo(x0 + w, y0).LineTo(x0 + w, y0 + h).LineTo(x0, y0 + h) \
            .Close().Face()
    return shape


def _circle(block: Block):
    _need(block, "center", 2)
    if block.radius is None or block.radius <= 0:
        raise ValueError(f"radius must be given and positive, got {block.radius}")
    return occ.WorkPlane().Circle(*block.center, block.radius).Face()


def _polygon(block: Block, wp=None):
    """The polygon's face, drawn on the work plane ``wp`` (default the x-y plane)."""
    pts = block.points or []
    if len(pts) < 3 or any(len(p) != 2 for p in pts):
        raise ValueError("points must hold at least 3 points [x, y]")
    names = block.edges or [""] * len(pts)
    if len(names) != len(pts):
        raise ValueError(f"edges names {len(names)} sides but the polygon has {len(pts)}")
    xy = np.asarray(pts, dtype=float)
    why = polygon_problem(xy)
    if why is not None:
        raise ValueError(why)
    area2 = float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))
    if area2 < 0:           # clockwise: the same polygon counterclockwise (a clockwise face has negative area)
        pts = [pts[0]] + list(pts[:0:-1])
        names = list(names[::-1])
    wp = (occ.WorkPlane() if wp is None else wp).MoveTo(*pts[0])
    for p, name in zip(pts[1:], names[:-1]):
        wp.LineTo(*p, name=name or None)
    wp.Close(name=names[-1] or None)
    return wp.Face()


def _profile(block: Block, wp=None):
    """The profile's face (lines, splines, arcs), drawn on the work plane ``wp`` (default the x-y plane)."""
    _need(block, "start", 2)
    segs = block.segments or []
    if not segs:
        raise ValueError("a profile needs segments")
    wp = (occ.WorkPlane() if wp is None else wp).MoveTo(*block.start)
    pos = np.array(block.start, float)
    for i, seg in enumerate(segs):
        pos = _draw_segment(wp, seg, i, pos)
    scale = max(1.0, float(np.abs(np.array(block.start)).max()))
    if np.linalg.norm(pos - np.array(block.start)) > 1e-9 * scale:
        raise ValueError(f"profile is not closed: ends at {pos.tolist()}, starts at {block.start}")
    shape = wp.Face()
    span = np.ptp(np.array([[v.p.x, v.p.y, v.p.z] for v in shape.vertices]), axis=0)
    if abs(shape.mass) <= 1e-12 * float(np.max(span)) ** 2:
        raise ValueError("the profile encloses no area (its outline runs back on itself)")
    if shape.mass < 0:
        raise ValueError("the profile runs clockwise: list its segments counterclockwise (the region on the "
                         "left of the direction of travel)")
    return shape


def _draw_segment(wp, seg, i: int, pos: np.ndarray) -> np.ndarray:
    """Draw profile segment ``i`` from ``pos`` on the work plane; returns its end point."""
    given = [k for k in ("line", "spline", "arc") if getattr(seg, k) is not None]
    if len(given) != 1:
        raise ValueError(f"segments[{i}] must have exactly one of 'line', 'spline' or 'arc'")
    if seg.line is not None and len(seg.line) != 2:
        raise ValueError(f"segments[{i}].line must be an end point [x, y]")
    if seg.spline is not None and (not seg.spline or any(len(p) != 2 for p in seg.spline)):
        raise ValueError(f"segments[{i}].spline must hold at least one point [x, y] (the last is its end)")
    if seg.line is not None:
        end = np.array(seg.line, float)
        wp.LineTo(*end, name=seg.name or None)
    elif seg.spline is not None:
        pts = [occ.gp_Pnt2d(*p) for p in seg.spline]
        end = np.array(seg.spline[-1], float)
        wp.Spline(pts, name=seg.name or None)
    else:
        if any(len(p) != 2 for p in seg.arc):
            raise ValueError(f"segments[{i}].arc must be [[x, y] a point on the arc, [x, y] its end]")
        through, end = (np.array(p, float) for p in seg.arc)
        try:
            center, _ = arc_circle(pos, through, end)
        except ValueError as exc:
            raise ValueError(f"segments[{i}].arc: {exc}") from None
        r = pos - center
        turn = _cross(through - pos, end - through)
        tangent = (-r[1], r[0]) if turn > 0 else (r[1], -r[0])     # counterclockwise or clockwise arc
        wp.ArcTo(*end, occ.gp_Vec2d(*tangent), name=seg.name or None)
    return end


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def arc_circle(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, float]:
    """The centre and radius (m) of the circle through the points a, b, c (2D); raises ValueError when two
    coincide or the three lie on one line (within 1e-9 relative: the sine of the angle at b)."""
    ab, bc, ac = b - a, c - b, c - a
    la, lb, lc = (float(np.linalg.norm(v)) for v in (ab, bc, ac))
    scale = max(la, lb, lc, float(np.abs(a).max()), 1e-300)
    if min(la, lb, lc) <= 1e-12 * scale:
        which = "start and end" if lc <= 1e-12 * scale else "start and through point" if la <= 1e-12 * scale \
            else "through point and end"
        raise ValueError(f"its {which} coincide (an arc needs three distinct points; a full circle is two arcs)")
    d = 2 * _cross(ab, ac)
    if abs(d) <= 2e-9 * la * lc:
        raise ValueError(f"the start {a.tolist()}, the point {b.tolist()} and the end {c.tolist()} lie on one "
                         "line: no circle passes through them (use a line)")
    o = np.array([ac[1] * (ab @ ab) - ab[1] * (ac @ ac), ab[0] * (ac @ ac) - ac[0] * (ab @ ab)]) / d
    return a + o, float(np.linalg.norm(o))


def arc_extremes(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> list[np.ndarray]:
    """The points of the arc from a through b to c that bound it: its ends, b and the points of its circle at
    0, 90, 180, 270 degrees it passes (for its bounding box)."""
    o, r = arc_circle(a, b, c)

    def ang(p):
        return float(np.arctan2(p[1] - o[1], p[0] - o[0]))
    ccw = _cross(b - a, c - b) > 0
    t0, t1 = ang(a), ang(c)
    sweep = (t1 - t0) % (2 * np.pi) if ccw else -((t0 - t1) % (2 * np.pi))
    out = [a, b, c]
    for k in range(4):
        rel = (k * np.pi / 2 - t0) % (2 * np.pi) if ccw else -((t0 - k * np.pi / 2) % (2 * np.pi))
        if abs(rel) <= abs(sweep):
            out.append(o + r * np.array([np.cos(k * np.pi / 2), np.sin(k * np.pi / 2)]))
    return out


def _box(block: Block):
    _need(block, "origin", 3)
    _need(block, "size", 3)
    if min(block.size) <= 0:
        raise ValueError(f"size {block.size} must be positive")
    p0 = occ.Pnt(*block.origin)
    p1 = occ.Pnt(*(np.array(block.origin) + np.array(block.size)))
    return occ.Box(p0, p1)


def _cylinder(block: Block):
    _need(block, "center", 3)
    if block.radius is None or block.radius <= 0 or block.height is None or block.height <= 0:
        raise ValueError("cylinder needs positive radius and height")
    axis = [0.0, 0.0, 1.0] if block.axis is None else block.axis
    if len(axis) != 3 or not np.linalg.norm(np.asarray(axis, float)) > 0:
        raise ValueError(f"'axis' must be a direction of 3 numbers, not the zero vector, got {axis}")
    return occ.Cylinder(occ.Pnt(*block.center), occ.Dir(*axis), block.radius, block.height)


def prism_frame(block: Block) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The frame of a prism: origin o, unit in-plane directions u, v, the outline plane's unit normal n = u x v
    and the unit extrusion direction a; raises ValueError for bad directions."""
    o = np.zeros(3) if block.origin is None else np.asarray(block.origin, float)
    if o.shape != (3,):
        raise ValueError(f"'origin' of a prism must be a point [x, y, z], got {block.origin}")
    uv = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] if block.directions is None else block.directions
    if len(uv) != 2 or any(len(d) != 3 for d in uv):
        raise ValueError(f"'directions' must be two directions [[ux, uy, uz], [vx, vy, vz]], got {uv}")
    u, v = (np.asarray(d, float) for d in uv)
    if not (np.linalg.norm(u) > 0 and np.linalg.norm(v) > 0):
        raise ValueError(f"'directions' must not hold the zero vector, got {uv}")
    u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
    if abs(float(u @ v)) > 1e-9:
        raise ValueError(f"'directions' u = {uv[0]} and v = {uv[1]} must be orthogonal (u.v = {float(u @ v):.3g} "
                         "for unit vectors)")
    n = np.cross(u, v)
    a = n if block.axis is None else np.asarray(block.axis, float)
    if a.shape != (3,) or not np.linalg.norm(a) > 0:
        raise ValueError(f"'axis' must be a direction of 3 numbers, not the zero vector, got {block.axis}")
    a = a / np.linalg.norm(a)
    if abs(float(a @ n)) < 1e-3:
        raise ValueError(f"'axis' {block.axis} lies in the outline's plane (spanned by directions u, v): it "
                         "extrudes nothing")
    return o, u, v, n, a


def _prism(block: Block):
    o, u, v, n, a = prism_frame(block)
    if block.length is None or not block.length > 0:
        raise ValueError(f"'length' (of the extrusion) must be given and positive, got {block.length}")
    if (block.points is None) == (block.start is None and block.segments is None):
        raise ValueError("a prism's outline is either a polygon ('points', 'edges') or a profile ('start', "
                         "'segments'): give one")
    wp = occ.WorkPlane(occ.Axes(occ.Pnt(*o), n=occ.Dir(*n), h=occ.Dir(*u)))
    face = _polygon(block, wp) if block.points is not None else _profile(block, wp)
    return face.Extrude(occ.Vec(*(a * block.length)))      # (occ.Prism drops the side names)


def _import(block: Block):
    return read_import(block)


BUILDERS = {"rectangle": _rectangle, "circle": _circle, "polygon": _polygon, "profile": _profile, "box": _box,
            "cylinder": _cylinder, "prism": _prism, "import": _import}
"""The OCC shape of a block from its data, by ``Block.shape`` (:data:`~ngs_geomech.scene.model.SHAPES_2D`,
:data:`~ngs_geomech.scene.model.SHAPES_3D`); each raises ValueError naming missing or wrong data."""


def polygon_problem(xy: np.ndarray) -> str | None:
    """Why the closed polygon through the points ``xy`` (n x 2, side k from point k to point k+1, the last
    side back to point 0) is not a simple polygon of positive area: coinciding points, all points on one line,
    sides that cross or touch (also two sides folding back on each other: the end of one lies on the other).
    None when it is simple. O(n^2) pair tests."""
    n = len(xy)
    p, q = xy, np.roll(xy, -1, axis=0)
    d = q - p
    scale = float(np.max(np.abs(d)))
    short = np.flatnonzero(np.linalg.norm(d, axis=1) <= 1e-9 * scale) if scale > 0 else np.arange(n)
    if short.size:
        k = int(short[0])
        return f"points {k} and {(k + 1) % n} coincide (side {k} has no length)"
    eps = 1e-12 * scale ** 2

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    far = xy[int(np.argmax(np.linalg.norm(xy - xy[0], axis=1)))] - xy[0]
    if np.all(np.abs(cross(far, xy - xy[0])) <= eps):
        return "the polygon has zero area (its points lie on one line)"

    def side(o):                      # orientation sign, 0 within the rounding tolerance
        return np.where(np.abs(o) <= eps, 0, np.sign(o))

    def within(c, tol=1e-9 * scale):  # [i, j]: point c[j] inside the bounding box of side i
        lo, hi = np.minimum(p, q)[:, None], np.maximum(p, q)[:, None]
        return np.all((c[None] >= lo - tol) & (c[None] <= hi + tol), axis=2)

    s1 = side(cross(d[:, None], p[None] - p[:, None]))     # [i, j]: start of side j about the line of side i
    s2 = side(cross(d[:, None], q[None] - p[:, None]))     # [i, j]: end of side j about the line of side i
    proper = (s1 * s2 < 0) & (s1.T * s2.T < 0)
    touch = ((s1 == 0) & within(p)) | ((s2 == 0) & within(q))
    meet = proper | touch | touch.T
    k = np.arange(n)
    apart = (np.abs(k[:, None] - k[None]) > 1) & ~(((k[:, None] == 0) & (k[None] == n - 1))
                                                    | ((k[:, None] == n - 1) & (k[None] == 0)))
    hits = np.argwhere(meet & apart & (k[:, None] < k[None]))
    if hits.size:
        i, j = (int(v) for v in hits[0])
        return f"sides {i} and {j} cross or touch (side k runs from point k to point k+1): the outline must " \
               "not intersect itself"
    return None


def declared_extent(block: Block, dim: int) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The bounding box (lo, hi) of a block and its thickness (smallest extent; a circle's or cylinder's
    diameter or height), m, from its data: no OCC shape, since a block too small for the geometry kernel may
    crash it. None when the data are incomplete (then :func:`make_block` says what is missing) and for imports."""
    try:
        if block.shape in ("rectangle", "box"):
            a = np.asarray(block.origin, float)
            pts = [a, a + np.asarray(block.size, float)]
        elif block.shape in ("polygon", "profile"):
            pts = outline_points(block)
        elif block.shape == "prism":
            o, u, v, _, ax = prism_frame(block)
            base = [o + q[0] * u + q[1] * v for q in outline_points(block)]
            pts = base + [q + float(block.length) * ax for q in base]
        elif block.shape == "import":
            return None
        else:                                       # circle, cylinder: the box of the end discs' axis points
            c, r = np.asarray(block.center, float), float(block.radius)
            ends = [c]
            if block.shape == "cylinder":
                ax = np.asarray(block.axis or [0.0, 0.0, 1.0], float)
                ends.append(c + float(block.height) * ax / max(float(np.linalg.norm(ax)), 1e-300))
            pts = [e + sgn * r * np.eye(len(c))[k] for e in ends for k in range(len(c)) for sgn in (-1, 1)]
        xy = np.array([q[:dim] for q in pts], float)
    except (TypeError, ValueError, IndexError):
        return None
    if xy.ndim != 2 or xy.shape[1] != dim or not np.all(np.isfinite(xy)):
        return None
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    if block.shape == "circle":
        return lo, hi, 2 * float(block.radius)
    if block.shape == "cylinder":
        return lo, hi, min(2 * float(block.radius), float(block.height))
    return lo, hi, float(np.min(hi - lo))


def outline_points(block: Block) -> list[np.ndarray]:
    """Points [x, y] bounding a polygon's or profile's outline (corners, spline points, an arc's extremes);
    raises TypeError, ValueError or IndexError for incomplete data."""
    if block.points is not None:
        return [np.asarray(q, float) for q in block.points]
    pos = np.asarray(block.start, float)
    pts = [pos]
    for seg in block.segments:
        if seg.arc is not None:
            b, c = (np.asarray(q, float) for q in seg.arc)
            pts += arc_extremes(pos, b, c)
            pos = c
        else:
            more = [np.asarray(q, float) for q in ([seg.line] if seg.line is not None else seg.spline)]
            pts += more
            pos = more[-1]
    return pts


def _need(block: Block, attr: str, n: int) -> None:
    v = getattr(block, attr)
    if v is None or len(v) != n:
        raise ValueError(f"'{attr}' must be given as {n} numbers")


def _name_sides(shape, block: Block, dim: int) -> None:
    for name, sel in block.boundaries.items():
        for selector in ([sel] if isinstance(sel, str) else sel):
            for side in select(shape, block, selector, dim):
                side.name = name


def select(shape, block: Block, selector: str, dim: int) -> list:
    """The sides of a block a selector picks (raises ValueError for a selector the shape does not have)."""
    all_sides = list(sides(shape, dim))
    if selector == "all":
        return all_sides
    axes = {"x": occ.X, "y": occ.Y, "z": occ.Z}
    if selector in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"):
        if selector[0] == "z" and dim == 2:
            raise ValueError(f"selector {selector!r} needs a 3D block")
        if block.shape in ("circle", "cylinder") and not (block.shape == "cylinder" and selector[0] == "z"
                                                          and (block.axis or [0, 0, 1]) == [0, 0, 1]):
            raise ValueError(f"selector {selector!r} does not apply to a {block.shape}; use 'all' "
                             "(or 'top', 'bottom', 'lateral' for a cylinder)")
        lst = sides(shape, dim)
        ax = axes[selector[0]]
        return [lst.Min(ax) if selector.endswith("min") else lst.Max(ax)]
    if selector in ("top", "bottom", "lateral"):
        if block.shape not in ("cylinder", "prism"):
            raise ValueError(f"selector {selector!r} applies to cylinders and prisms only")
        p, d, top = _end_frame(block)
        out = []
        for f in all_sides:
            c = f.center
            t = float(np.dot(np.array([c.x, c.y, c.z]) - p, d))
            kind = "bottom" if abs(t) < 1e-9 * abs(top) else "top" if abs(t - top) < 1e-9 * abs(top) else "lateral"
            if kind == selector:
                out.append(f)
        return out
    raise ValueError(f"unknown selector {selector!r}")


def _end_frame(block: Block) -> tuple[np.ndarray, np.ndarray, float]:
    """A cylinder's or prism's end faces: a point of the bottom face, the unit normal d of the end faces and
    the distance of the top face along d (m)."""
    if block.shape == "cylinder":
        d = np.array(block.axis or [0, 0, 1], float)
        return np.array(block.center, float), d / np.linalg.norm(d), float(block.height)
    o, _, _, n, a = prism_frame(block)
    return o, n, float(block.length) * float(a @ n)
