"""A small toolkit for building the procedural object meshes.

Units are metres; z is up. Every builder returns a closed, watertight
:class:`trimesh.Trimesh` with outward winding (counter-clockwise seen from outside, so that the
signed volume is positive). The pieces that make up a MuJoCo collision model are plain
``(n, 3)`` float64 vertex arrays: MuJoCo takes the convex hull of each one.

Building blocks
---------------
Lathe (surfaces of revolution about +z)
    A *profile* is a polyline of ``(r, z)`` points that starts and ends on the axis (``r == 0``)
    with ``r > 0`` in between. :func:`revolve` turns it into a closed mesh. Hollow vessels are
    one closed profile (outer bottom centre, outer wall, rim, inner wall, inner bottom centre);
    :func:`hollow_section` derives it from the outer curve alone by offsetting it in 2-D with
    shapely, and :class:`Lathe` bundles the 2-D section with its mesh and collision pieces.
Flat parts
    :func:`extrude` (a shapely polygon, optionally with holes, extruded along z) and
    :func:`warp` (bend or taper a mesh by moving its vertices).
Tubes
    :func:`sweep` moves a (super-)elliptic cross-section along a planar path: handles, bands,
    straps, pen bodies. :func:`torus_arc` is the circular special case.
Primitives
    :func:`box`, :func:`rounded_box`, :func:`rounded_slab`, :func:`cylinder`,
    :func:`rounded_cylinder`, :func:`ellipsoid`, :func:`sphere`, :func:`capsule`.
Booleans
    :func:`union`, :func:`difference`, :func:`intersection` run manifold3d (trimesh's boolean
    engine) directly in float64, then remove the slivers the cut lines leave
    (:func:`collapse_short_edges`, :func:`flip_flat_caps`); results are checked to be closed.
Collision pieces
    :func:`convex_parts_2d` (approximate convex decomposition of a polygon),
    :meth:`Lathe.pieces` / :func:`convex_pieces_of_revolution` (angular sectors of a revolved
    wall plus full-turn axial pieces), :meth:`Sweep.pieces`, :func:`clip_piece` (the part of a
    mesh inside a box) and :func:`hull_points`.
Checks
    :func:`validate_shape` lists what is wrong with a shape; :func:`collision_stats` gives the
    numbers behind it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import manifold3d
import numpy as np
import shapely
import shapely.ops
import trimesh
from scipy.spatial import ConvexHull, QhullError, cKDTree
from shapely.geometry import LineString, MultiPolygon, Polygon
from shapely.geometry import box as _sbox
from shapely.geometry.polygon import orient

#: Points closer than this to the axis count as on it (m).
AXIS_EPS = 1e-9
#: Smallest convex-hull volume accepted for a collision piece (m^3).
MIN_PIECE_VOLUME = 1e-10
#: Default tolerance for the collision pieces covering the visual mesh (m).
COVER_TOL = 1e-3

_BIG = 10.0  # "infinite" extent for half-planes in 2-D, m


# =============================================================================================
# Polylines and profiles
# =============================================================================================
def resample_polyline(points: Any, max_len: float | None, *, closed: bool = False) -> np.ndarray:
    """Split every segment longer than ``max_len`` into equal parts (keeps all input points)."""
    p = np.asarray(points, dtype=float)
    if max_len is None or max_len <= 0 or len(p) < 2:
        return p
    q = np.vstack([p, p[:1]]) if closed else p
    out = [q[:1]]
    for a, b in zip(q[:-1], q[1:], strict=True):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / max_len - 1e-9))
        t = (np.arange(1, n + 1) / n)[:, None]
        out.append(a + (b - a) * t)
    r = np.vstack(out)
    return r[:-1] if closed else r


def clean_polyline(points: Any, *, min_len: float = 1e-6, collinear_tol: float = 1e-9) -> np.ndarray:
    """Drop points closer than ``min_len`` to the previous one and points on a straight run.

    The first and last points are always kept.
    """
    p = np.asarray(points, dtype=float)
    if len(p) <= 2:
        return p
    keep = [p[0]]
    for q in p[1:-1]:
        if np.linalg.norm(q - keep[-1]) >= min_len:
            keep.append(q)
    if np.linalg.norm(p[-1] - keep[-1]) < min_len and len(keep) > 1:
        keep.pop()
    keep.append(p[-1])
    p = np.array(keep)
    changed = True
    while changed and len(p) > 2:
        changed = False
        out = [p[0]]
        for i in range(1, len(p) - 1):
            a, b, c = out[-1], p[i], p[i + 1]
            ac = c - a
            n = float(np.linalg.norm(ac))
            if n > 0:
                d = abs(ac[0] * (b - a)[1] - ac[1] * (b - a)[0]) / n
                inside = 0.0 <= float(np.dot(b - a, ac)) <= n * n
                if d < collinear_tol and inside:
                    changed = True
                    continue
            out.append(b)
        out.append(p[-1])
        p = np.array(out)
    return p


def arc_points(center: Sequence[float], radius: float, start: float, stop: float, n: int) -> np.ndarray:
    """``n + 1`` points on a circular arc in 2-D, angles in radians from ``start`` to ``stop``."""
    t = np.linspace(start, stop, n + 1)
    return np.column_stack([center[0] + radius * np.cos(t), center[1] + radius * np.sin(t)])


def fillet_polyline(points: Any, radii: Any, *, max_step_deg: float = 15.0) -> np.ndarray:
    """Replace corners of a 2-D polyline by tangent circular arcs.

    ``radii`` is one radius per point (0 = keep the corner; the end points are never
    rounded); a radius too large for its neighbouring segments is reduced so that each arc uses
    at most half of each adjacent segment.
    """
    p = np.asarray(points, dtype=float)
    r = np.broadcast_to(np.asarray(radii, dtype=float), (len(p),))
    out = [p[0]]
    for i in range(1, len(p) - 1):
        a, b, c = p[i - 1], p[i], p[i + 1]
        la, lc = np.linalg.norm(a - b), np.linalg.norm(c - b)
        if r[i] <= 0 or la == 0 or lc == 0:
            out.append(b)
            continue
        u, v = (a - b) / la, (c - b) / lc
        ang = math.acos(float(np.clip(np.dot(u, v), -1.0, 1.0)))
        if ang > math.pi - 1e-6 or ang < 1e-6:
            out.append(b)
            continue
        d = min(r[i] / math.tan(ang / 2.0), 0.5 * la, 0.5 * lc)
        re = d * math.tan(ang / 2.0)
        bis = (u + v) / np.linalg.norm(u + v)
        ctr = b + bis * re / math.sin(ang / 2.0)
        t1, t2 = b + u * d, b + v * d
        a1 = math.atan2(t1[1] - ctr[1], t1[0] - ctr[0])
        a2 = math.atan2(t2[1] - ctr[1], t2[0] - ctr[0])
        delta = (a2 - a1 + math.pi) % (2.0 * math.pi) - math.pi
        n = max(2, math.ceil(abs(math.degrees(delta)) / max_step_deg))
        ts = a1 + delta * np.arange(n + 1) / n
        out.extend(np.column_stack([ctr[0] + re * np.cos(ts), ctr[1] + re * np.sin(ts)]))
    out.append(p[-1])
    return clean_polyline(np.array(out), min_len=1e-7)


def pchip_curve(zs: Sequence[float], rs: Sequence[float], n: int = 24) -> np.ndarray:
    """``n + 1`` points ``(r(z), z)`` of a smooth, non-overshooting (PCHIP) curve through the
    control points ``(rs[i], zs[i])`` (``zs`` increasing)."""
    from scipy.interpolate import PchipInterpolator

    z = np.linspace(zs[0], zs[-1], n + 1)
    return np.column_stack([PchipInterpolator(zs, rs)(z), z])


def _profile_array(profile: Any) -> np.ndarray:
    p = np.array(profile, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3:
        raise ValueError("a profile must be an (n >= 3, 2) array of (r, z) points")
    if not np.all(np.isfinite(p)):
        raise ValueError("profile has non-finite points")
    if abs(p[0, 0]) > AXIS_EPS or abs(p[-1, 0]) > AXIS_EPS:
        raise ValueError("a profile must start and end on the axis (r == 0)")
    p[0, 0] = p[-1, 0] = 0.0
    if np.any(p[1:-1, 0] <= AXIS_EPS):
        raise ValueError("a profile may touch the axis only at its two ends")
    if np.any(np.linalg.norm(np.diff(p, axis=0), axis=1) <= 1e-12):
        raise ValueError("profile has repeated consecutive points")
    return p


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


# =============================================================================================
# Revolve
# =============================================================================================
def _grade_profile(p: np.ndarray, segments: int, *, ratio: float = 3.0,
                   floor: float = 1e-3) -> np.ndarray:
    """Split profile segments whose radius at least doubles and that are much longer than the
    ring spacing at their inner end (``ratio`` x 2 pi r / segments, at least ``floor``) into a
    geometric progression, so that rings near the axis are not joined to far ones by needle
    triangles. Segments from the axis points are left alone (their triangle fans are fine)."""
    step = ratio * 2.0 * np.pi / segments
    out = [p[0]]
    for i in range(len(p) - 1):
        a, b = p[i], p[i + 1]
        lo, hi = sorted((a[0], b[0]))
        if i == 0 or i == len(p) - 2 or hi < 2.0 * lo:  # only segments that change r a lot
            out.append(b)
            continue
        rev = b[0] < a[0]
        s, e = (b, a) if rev else (a, b)
        d = e - s
        ln = float(np.linalg.norm(d))
        pts, t = [], 0.0
        while True:
            r = s[0] + d[0] * t / ln
            t += max(step * r, floor)
            if t >= ln * 0.95:
                break
            pts.append(s + d * t / ln)
        if rev:
            pts = pts[::-1]
        out.extend(pts)
        out.append(b)
    return np.array(out)


def revolve(profile: Any, segments: int = 48, *, max_len: float | None = None,
            phase: float = 0.0) -> trimesh.Trimesh:
    """Closed surface of revolution about +z.

    ``profile`` is a polyline of ``(r, z)`` points that starts and ends on the axis; either
    direction works (the winding is fixed so that the volume is positive). Each interior point
    becomes a ring of ``segments`` vertices at angles ``phase + 2*pi*k/segments``; the two axis
    points become apex vertices joined to their neighbouring ring by a triangle fan, so no
    triangle is degenerate. ``max_len`` first splits long profile segments (for better-shaped
    triangles).
    """
    if segments < 3:
        raise ValueError("segments must be >= 3")
    p = _profile_array(profile)
    if max_len:
        p = resample_polyline(p, max_len)
    p = _grade_profile(p, segments)
    rings = p[1:-1]
    n = len(rings)
    th = phase + 2.0 * np.pi * np.arange(segments) / segments
    rv = np.empty((n, segments, 3))
    rv[..., 0] = rings[:, 0, None] * np.cos(th)
    rv[..., 1] = rings[:, 0, None] * np.sin(th)
    rv[..., 2] = rings[:, 1, None]
    verts = np.vstack([[0.0, 0.0, p[0, 1]], rv.reshape(-1, 3), [0.0, 0.0, p[-1, 1]]])
    idx = 1 + np.arange(n * segments).reshape(n, segments)
    k = np.arange(segments)
    k1 = (k + 1) % segments
    faces = [np.column_stack([np.zeros(segments, int), idx[0, k1], idx[0, k]])]
    for i in range(n - 1):
        a, b, c, d = idx[i, k], idx[i, k1], idx[i + 1, k1], idx[i + 1, k]
        faces.append(np.column_stack([a, b, c]))
        faces.append(np.column_stack([a, c, d]))
    top = len(verts) - 1
    faces.append(np.column_stack([np.full(segments, top), idx[-1, k], idx[-1, k1]]))
    f = np.vstack(faces)
    if _signed_area(p) < 0:  # clockwise profile: flip every face
        f = f[:, ::-1]
    return trimesh.Trimesh(verts, f, process=False)


# =============================================================================================
# 2-D sections of lathe-turned parts (shapely, in the (r, z) plane)
# =============================================================================================
def solid_section(profile: Any) -> Polygon:
    """Full (mirrored, symmetric about r = 0) section of the solid of revolution of a profile."""
    p = _profile_array(profile)
    mirror = p[-2:0:-1] * np.array([-1.0, 1.0])
    return _single_polygon(Polygon(np.vstack([p, mirror])).buffer(0), "solid section")


def open_section(outer: Any, *, extend: float = 0.0) -> Polygon:
    """Full solid section bounded by an *open* outer curve and the horizontal through its end.

    ``outer`` runs from an axis point ``(0, z0)`` to a rim point ``(r, z)`` with ``r > 0``.
    ``extend`` prolongs the last segment first (used to erode an open-topped vessel without
    eroding its rim).
    """
    o = np.array(outer, dtype=float)
    if o.ndim != 2 or o.shape[1] != 2 or len(o) < 2:
        raise ValueError("outer curve must be an (n >= 2, 2) array")
    if abs(o[0, 0]) > AXIS_EPS or o[-1, 0] <= AXIS_EPS:
        raise ValueError("outer curve must start on the axis and end off it")
    o[0, 0] = 0.0
    pts = list(o)
    if extend > 0:
        d = o[-1] - o[-2]
        d = d / np.linalg.norm(d)
        pts.append(o[-1] + d * extend)
    pts.append(np.array([0.0, pts[-1][1]]))
    return solid_section(np.array(pts))


def hollow_section(outer: Any, wall: float, *, bottom: float | None = None,
                   floor_z: float | None = None, rim_radius: float = 0.0, fillet: float = 0.0,
                   arc_segments: int = 3) -> Polygon:
    """Full section of an open-topped vessel with walls ``wall`` thick.

    ``outer`` is the outside curve from the bottom centre ``(0, z0)`` up to the rim. The cavity
    is the outer solid eroded by ``wall``; ``bottom`` (a thickness at the axis) or ``floor_z``
    (an absolute height) lifts the inside floor. ``fillet`` rounds the concave corners (inside
    bottom edge) and ``rim_radius`` the convex ones (rim, foot) with ``arc_segments`` segments
    per quarter circle.
    """
    o = np.asarray(outer, dtype=float)
    solid = open_section(o)
    ext = open_section(o, extend=4.0 * wall + 1e-3)
    cav = ext.buffer(-wall, quad_segs=arc_segments)
    z0 = float(o[0, 1])
    if bottom is not None:
        floor_z = z0 + bottom if floor_z is None else max(floor_z, z0 + bottom)
    if floor_z is not None:
        cav = cav.intersection(_sbox(-_BIG, floor_z, _BIG, _BIG))
    shell = solid.difference(cav)
    shell = round_section(shell, fillet=fillet, rim_radius=rim_radius, arc_segments=arc_segments)
    return _single_polygon(shell, "hollow section")


def round_section(section: Any, *, fillet: float = 0.0, rim_radius: float = 0.0,
                  arc_segments: int = 3) -> Polygon:
    """Round the concave corners (closing by ``fillet``) then the convex ones (opening)."""
    s = section
    if fillet > 0:
        s = s.buffer(fillet, quad_segs=arc_segments).buffer(-fillet, quad_segs=arc_segments)
    if rim_radius > 0:
        s = s.buffer(-rim_radius, quad_segs=arc_segments).buffer(rim_radius, quad_segs=arc_segments)
    return _single_polygon(s, "rounded section")


def half_section(section: Polygon) -> Polygon:
    """The ``r >= 0`` half of a full symmetric section."""
    h = section.intersection(_sbox(0.0, -_BIG, _BIG, _BIG))
    return _single_polygon(h, "half section")


def section_profile(half: Polygon, *, min_len: float = 2e-5) -> np.ndarray:
    """The revolve profile of a half section: its boundary minus the one stretch on the axis.

    Raises ``ValueError`` if the section has holes or touches the axis in more than one stretch
    (that would be a sealed cavity or a pinch, which one profile cannot describe).
    """
    if half.interiors and len(half.interiors):
        raise ValueError("section has holes (a sealed cavity): use two profiles")
    ring = np.asarray(orient(half, 1.0).exterior.coords)[:-1]
    on = np.abs(ring[:, 0]) <= AXIS_EPS
    if not on.any():
        raise ValueError("section does not touch the axis")
    n = len(ring)
    # start index: an on-axis vertex followed by an off-axis one
    starts = [i for i in range(n) if on[i] and not on[(i + 1) % n]]
    ends = [i for i in range(n) if on[i] and not on[(i - 1) % n]]
    if len(starts) != 1 or len(ends) != 1:
        raise ValueError("section touches the axis in more than one place")
    s, e = starts[0], ends[0]
    idx = [(s + j) % n for j in range(((e - s) % n) + 1)]
    prof = ring[idx].copy()
    prof[0, 0] = prof[-1, 0] = 0.0
    prof = clean_polyline(prof, min_len=min_len, collinear_tol=1e-8)
    if np.any(prof[1:-1, 0] <= AXIS_EPS):
        raise ValueError("section profile runs along the axis")
    return prof


def _single_polygon(g: Any, what: str) -> Polygon:
    if isinstance(g, Polygon) and not g.is_empty:
        return g
    if isinstance(g, MultiPolygon) or getattr(g, "geoms", None) is not None:
        polys = [q for q in getattr(g, "geoms", []) if isinstance(q, Polygon) and q.area > 0]
        if polys:
            big = max(polys, key=lambda q: q.area)
            if sum(q.area for q in polys) - big.area < 1e-6 * big.area:
                return big
    raise ValueError(f"{what} is not a single polygon (parts too thin or disconnected?)")


# =============================================================================================
# Approximate convex decomposition in 2-D
# =============================================================================================
def concavity_2d(poly: Polygon) -> float:
    """Largest distance from the polygon's convex hull boundary to the polygon (m)."""
    hull = poly.convex_hull
    if hull.area - poly.area <= 1e-12 * max(hull.area, 1e-30):
        return 0.0
    ring = shapely.segmentize(hull.exterior, hull.length / 96.0)
    pts = shapely.points(np.asarray(ring.coords))
    return float(np.max(shapely.distance(pts, poly)))


def _reflex_vertices(poly: Polygon) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(vertex, incoming dir, outgoing dir) for the reflex vertices of the exterior ring."""
    ring = np.asarray(orient(poly, 1.0).exterior.coords)[:-1]
    out = []
    n = len(ring)
    for i in range(n):
        a, b, c = ring[i - 1], ring[i], ring[(i + 1) % n]
        d1, d2 = b - a, c - b
        l1, l2 = np.linalg.norm(d1), np.linalg.norm(d2)
        if l1 == 0 or l2 == 0:
            continue
        cross = d1[0] * d2[1] - d1[1] * d2[0]
        if cross < -1e-12 * l1 * l2:  # right turn on a CCW ring: reflex
            out.append((b, d1 / l1, d2 / l2))
    return out


def _split(poly: Polygon, point: np.ndarray, direction: np.ndarray) -> list[Polygon]:
    ext = 2.0 * math.hypot(poly.bounds[2] - poly.bounds[0], poly.bounds[3] - poly.bounds[1]) + 1.0
    line = LineString([point - direction * ext, point + direction * ext])
    parts = shapely.ops.split(poly, line)
    return [g for g in parts.geoms if isinstance(g, Polygon)]


def convex_parts_2d(poly: Polygon, tol: float, *, max_len: float | None = None,
                    max_parts: int = 32, lathe: bool = False) -> list[Polygon]:
    """Approximate convex decomposition of a polygon (holes are filled first).

    Splits recursively along lines through reflex vertices (and, for pieces longer than
    ``max_len``, across their long axis) until every part's convex hull is within ``tol`` of the
    part (:func:`concavity_2d`) or ``max_parts`` is reached. Each split is chosen among a few
    candidate lines to minimise the worse concavity of its parts. With ``lathe`` (a half
    section, axis at x = 0), parts touching the axis are only cut horizontally, so that they
    stay on the axis (one full-turn piece each instead of a ring of sectors).
    """
    poly = Polygon(poly.exterior)
    todo, done = [poly], []
    while todo:
        p = todo.pop()
        conc = concavity_2d(p)
        length, axis = _long_axis(p)
        too_long = max_len is not None and length > max_len
        if (conc <= tol and not too_long) or len(done) + len(todo) + 1 >= max_parts:
            done.append(p)
            continue
        cands: list[tuple[np.ndarray, np.ndarray]] = []
        if conc > tol:
            refl = _reflex_vertices(p)
            # the deepest reflex vertices first (farthest from the hull boundary)
            hb = p.convex_hull.exterior
            refl.sort(key=lambda v: -hb.distance(shapely.Point(v[0])))
            axial = lathe and p.bounds[0] <= AXIS_EPS * 10
            for v, d1, d2 in refl[:8 if axial else 6]:
                if axial:
                    cands.append((v, np.array([1.0, 0.0])))
                    continue
                bis = d1 - d2
                nb = np.linalg.norm(bis)
                dirs = [d1, d2, np.array([1.0, 0.0]), np.array([0.0, 1.0])]
                if nb > 1e-9:
                    dirs.append(bis / nb)
                cands += [(v, d) for d in dirs]
        c = np.asarray(p.centroid.coords[0])
        perp = np.array([-axis[1], axis[0]])
        if not (lathe and p.bounds[0] <= AXIS_EPS * 10):
            cands.append((c, perp))
        best, best_score = None, math.inf
        for v, d in cands:
            parts = _split(p, v, d)
            if len(parts) < 2 or min(q.area for q in parts) < 0.02 * p.area:
                continue
            score = max(concavity_2d(q) for q in parts)
            if too_long and conc <= tol:
                score = max(_long_axis(q)[0] for q in parts)
            score += 1e-9 * len(parts)
            if score < best_score - 1e-12:
                best, best_score = parts, score
        if best is None:
            done.append(p)
        else:
            todo.extend(best)
    return done


def _long_axis(poly: Polygon) -> tuple[float, np.ndarray]:
    rect = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    l1, l2 = np.linalg.norm(e1), np.linalg.norm(e2)
    if l1 >= l2:
        return float(l1), e1 / max(l1, 1e-30)
    return float(l2), e2 / max(l2, 1e-30)


# =============================================================================================
# Lathe: a revolved section with its mesh and collision pieces
# =============================================================================================
@dataclass(frozen=True)
class Lathe:
    """A solid of revolution described by its half section (``r >= 0``) in the (r, z) plane.

    ``segments`` and ``phase`` fix the angular sampling, shared by :meth:`mesh` and
    :meth:`pieces` so that the collision pieces contain the visual vertices exactly.
    """

    section: Polygon
    segments: int = 48
    phase: float = 0.0
    min_len: float = 3e-4

    @classmethod
    def solid(cls, profile: Any, segments: int = 48, phase: float = 0.0,
              min_len: float = 3e-4) -> Lathe:
        return cls(half_section(solid_section(profile)), segments, phase, min_len)

    @classmethod
    def hollow(cls, outer: Any, wall: float, segments: int = 48, phase: float = 0.0,
               min_len: float = 3e-4, **kw: Any) -> Lathe:
        return cls(half_section(hollow_section(outer, wall, **kw)), segments, phase, min_len)

    def profile(self, max_len: float | None = None) -> np.ndarray:
        """The revolve profile: section boundary minus the axis, points closer than
        ``min_len`` merged, then Douglas-Peucker simplified to ``min_len / 2``."""
        p = section_profile(self.section, min_len=self.min_len)
        q = np.asarray(shapely.simplify(LineString(p), self.min_len / 2.0,
                                        preserve_topology=True).coords)
        if len(q) >= 3 and np.all(q[1:-1, 0] > AXIS_EPS):
            p = q
        return resample_polyline(p, max_len) if max_len else p

    def default_max_len(self) -> float:
        """Longest profile segment of :meth:`mesh`: three angular steps at the largest radius."""
        return 3.0 * 2.0 * math.pi * self.section.bounds[2] / self.segments

    def mesh(self, max_len: float | None = None) -> trimesh.Trimesh:
        """The revolved surface (profile segments at most ``max_len``, default
        :meth:`default_max_len`)."""
        max_len = self.default_max_len() if max_len is None else max_len
        return revolve(self.profile(), self.segments, max_len=max_len, phase=self.phase)

    def angles(self) -> np.ndarray:
        return self.phase + 2.0 * np.pi * np.arange(self.segments) / self.segments

    def pieces(self, tol: float, *, max_pieces: int = 24, min_sectors: int = 6,
               max_sectors: int = 16, reserve: int = 0,
               with_mesh_vertices: bool = False) -> list[np.ndarray]:
        """Convex collision pieces of the revolved solid.

        The half section is split into nearly convex parts (:func:`convex_parts_2d`, ``tol``
        in metres). A part touching the axis is revolved a full turn as one piece (it is convex
        when its 2-D hull is); every other part is cut into angular sectors, each a piece. The
        number of sectors is a divisor of ``segments`` within ``[min_sectors, max_sectors]``
        keeping the total at most ``max_pieces - reserve`` (``reserve`` leaves room for
        handles). Coarser splits (``tol`` x 1.5, x 2.25, ...) are tried too, and the layout
        whose worst deviation (a part's concavity or a sector's chord sagitta) is smallest wins.
        ``with_mesh_vertices`` adds the :meth:`mesh` vertices that fall in each piece, so that
        the pieces still cover the mesh after both are bent by the same :func:`warp`.
        """
        budget = max_pieces - reserve
        th = self.angles()
        best: tuple[float, list[Polygon], list[Polygon], int] | None = None
        t = tol
        for attempt in range(12):
            parts = convex_parts_2d(self.section, t, lathe=True)
            axial = [q for q in parts if q.bounds[0] <= AXIS_EPS * 10]
            wall = [q for q in parts if q.bounds[0] > AXIS_EPS * 10]
            if not wall:
                err = max(concavity_2d(q) for q in axial)
                if best is None or err < best[0]:
                    best = (err, axial, wall, 1)
                break
            room = budget - len(axial)
            divs = [s for s in range(min_sectors, max_sectors + 1)
                    if self.segments % s == 0 and s * len(wall) <= room]
            if divs:
                sectors = max(divs)
                err = max(max(concavity_2d(q), q.bounds[2] * (1 - math.cos(math.pi / sectors)))
                          for q in wall)
                err = max([err] + [concavity_2d(q) for q in axial])
                if best is None or err < best[0] - 1e-9:
                    best = (err, axial, wall, sectors)
                if len(wall) == 1 or attempt >= 6:
                    break
            t *= 1.5
        if best is None:
            raise ValueError("cannot fit the lathe collision into the piece budget")
        _, axial, wall, sectors = best
        extra = self.profile(self.default_max_len()) if with_mesh_vertices else None
        out = [self._revolve_points(q, th, extra) for q in axial]
        step = self.segments // sectors
        th2 = np.append(th, th[0] + 2 * np.pi)
        for q in wall:
            for j in range(sectors):
                out.append(self._revolve_points(q, th2[j * step:(j + 1) * step + 1], extra))
        return out

    @staticmethod
    def _revolve_points(part: Polygon, angles: np.ndarray,
                        profile: np.ndarray | None = None) -> np.ndarray:
        rz = np.asarray(part.convex_hull.exterior.coords)[:-1]
        if profile is not None:
            near = shapely.distance(shapely.points(profile), part) <= 1e-7
            rz = np.vstack([rz, profile[near]])
        on = rz[:, 0] <= AXIS_EPS * 10
        pts = [np.column_stack([np.zeros(on.sum()), np.zeros(on.sum()), rz[on, 1]])]
        off = rz[~on]
        c, s = np.cos(angles), np.sin(angles)
        pts.append(np.column_stack([
            (off[:, 0, None] * c).ravel(), (off[:, 0, None] * s).ravel(),
            np.repeat(off[:, 1], len(angles))]))
        return np.vstack(pts)


def convex_pieces_of_revolution(profile: Any, sectors: int | None = None, *,
                                segments: int = 48, tol: float = 0.002,
                                max_pieces: int = 24) -> list[np.ndarray]:
    """Convex collision pieces of the solid revolved from a closed ``profile`` (see
    :func:`revolve`; hollow shells included): the section is split into nearly convex parts
    (``tol`` m); parts on the axis become one full-turn piece each, the wall parts are cut into
    ``sectors`` angular sectors (default: as many as fit ``max_pieces``). Use the same
    ``segments`` as for the mesh so that the pieces contain its vertices exactly."""
    lathe = Lathe(half_section(solid_section(profile)), segments)
    if sectors is None:
        return lathe.pieces(tol, max_pieces=max_pieces)
    if segments % sectors:
        raise ValueError("sectors must divide segments")
    return lathe.pieces(tol, max_pieces=10**6, min_sectors=sectors, max_sectors=sectors)


# =============================================================================================
# Flat parts: extrusion, warping
# =============================================================================================
def _as_polygon(polygon: Any, holes: Iterable[Any] = ()) -> Polygon | MultiPolygon:
    if isinstance(polygon, (Polygon, MultiPolygon)):
        g = polygon
    else:
        g = Polygon(np.asarray(polygon, dtype=float))
    for h in holes:
        g = g.difference(h if isinstance(h, (Polygon, MultiPolygon)) else Polygon(np.asarray(h, float)))
    if g.is_empty or g.area <= 0:
        raise ValueError("empty polygon")
    return g


def clean_polygon(polygon: Polygon | MultiPolygon, min_len: float) -> Polygon | MultiPolygon:
    """Drop ring vertices closer than ``min_len`` to the previous kept one (the short edges that
    buffers and booleans leave), then repair the polygon."""

    def ring(coords: Any) -> np.ndarray | None:
        pts = np.asarray(coords)[:-1]
        keep = [pts[0]]
        for q in pts[1:]:
            if np.linalg.norm(q - keep[-1]) >= min_len:
                keep.append(q)
        if len(keep) > 1 and np.linalg.norm(keep[-1] - keep[0]) < min_len:
            keep.pop()
        return np.array(keep) if len(keep) >= 3 else None

    out = []
    for p in getattr(polygon, "geoms", [polygon]):
        ext = ring(p.exterior.coords)
        if ext is None:
            continue
        holes = [h for h in (ring(i.coords) for i in p.interiors) if h is not None]
        out.append(Polygon(ext, holes).buffer(0))
    g = shapely.union_all(out)
    if g.is_empty:
        raise ValueError("polygon vanished when cleaned")
    return g


def triangulate(polygon: Polygon | MultiPolygon) -> tuple[np.ndarray, np.ndarray]:
    """Constrained Delaunay triangulation of a polygon: ``(vertices (n, 2), faces (m, 3))``.

    Uses only the polygon's own vertices (segmentize it first for smaller triangles); faces are
    counter-clockwise.
    """
    tris = shapely.constrained_delaunay_triangles(polygon)
    coords = np.array([np.asarray(t.exterior.coords)[:3] for t in tris.geoms])
    verts, inv = np.unique(coords.reshape(-1, 2), axis=0, return_inverse=True)
    faces = inv.reshape(-1, 3)
    v = verts[faces]
    cross = (v[:, 1, 0] - v[:, 0, 0]) * (v[:, 2, 1] - v[:, 0, 1]) - (
        v[:, 1, 1] - v[:, 0, 1]) * (v[:, 2, 0] - v[:, 0, 0])
    faces = np.where((cross < 0)[:, None], faces[:, ::-1], faces)
    faces = faces[np.abs(cross) > 1e-18]
    return verts, faces


def extrude(polygon: Any, thickness: float, holes: Iterable[Any] = (), *,
            max_len: float | None = None, min_len: float = 2e-4) -> trimesh.Trimesh:
    """Extrude a 2-D polygon (x, y) along z, from ``z = -thickness/2`` to ``+thickness/2``.

    ``polygon`` is a shapely (Multi)Polygon or an (n, 2) array; ``holes`` are cut out of it.
    Boundary edges shorter than ``min_len`` are removed (:func:`clean_polygon`); ``max_len``
    then splits long ones (useful before :func:`warp`).
    """
    if thickness <= 0:
        raise ValueError("thickness must be positive")
    g = _as_polygon(polygon, holes)
    if min_len:
        g = clean_polygon(g, min_len)
    if max_len:
        g = shapely.segmentize(g, max_len)
    polys = list(g.geoms) if isinstance(g, MultiPolygon) else [g]
    layers = max(1, math.ceil(thickness / max_len - 1e-9)) if max_len else 1
    meshes = [_extrude_layers(orient(p, 1.0), thickness, layers) for p in polys]
    m = trimesh.util.concatenate(meshes) if len(meshes) > 1 else meshes[0]
    if m.volume < 0:
        m.invert()
    return m


def _extrude_layers(poly: Polygon, thickness: float, layers: int) -> trimesh.Trimesh:
    """Prism over a polygon, its side walls split into ``layers`` rows of quads."""
    v2, f2 = triangulate(poly)
    n = len(v2)
    zs = np.linspace(-thickness / 2.0, thickness / 2.0, layers + 1)
    verts = np.vstack([np.column_stack([v2, np.full(n, z)]) for z in zs])
    faces = [f2[:, ::-1], f2 + layers * n]  # bottom (facing down), top
    # boundary edges of the triangulation, oriented as in the counter-clockwise faces
    e = np.vstack([f2[:, [0, 1]], f2[:, [1, 2]], f2[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    bnd = e[cnt[inv.ravel()] == 1]
    for k in range(layers):
        a, b = bnd[:, 0] + k * n, bnd[:, 1] + k * n
        c, d = b + n, a + n
        faces += [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
    m = trimesh.Trimesh(verts, np.vstack(faces), process=False)
    if m.volume < 0:
        m.invert()
    return m


def warp(mesh: trimesh.Trimesh, fn: Callable[[np.ndarray], np.ndarray]) -> trimesh.Trimesh:
    """A copy of ``mesh`` with vertices moved by ``fn((n, 3)) -> (n, 3)`` (keep it smooth)."""
    v = np.asarray(fn(np.asarray(mesh.vertices, dtype=float).copy()), dtype=float)
    return trimesh.Trimesh(v, mesh.faces.copy(), process=False)


def bend_z(dz: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """A warp that lifts each point by ``dz(x)`` (a gentle bend of a flat part lying along x)."""

    def fn(v: np.ndarray) -> np.ndarray:
        v = v.copy()
        v[:, 2] += dz(v[:, 0])
        return v

    return fn


def smoothstep(x: Any, a: float, b: float) -> np.ndarray:
    """0 below ``a``, 1 above ``b``, a smooth cubic between."""
    t = np.clip((np.asarray(x, dtype=float) - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


# =============================================================================================
# Tubes
# =============================================================================================
@dataclass(frozen=True)
class Sweep:
    """A swept tube: ``rings`` (N, M, 3) cross-sections along the path, plus end points.

    ``start``/``end`` are the apexes closing the two ends (the centre of a flat cap or the tip
    of a rounded one).
    """

    rings: np.ndarray
    start: np.ndarray
    end: np.ndarray

    @property
    def mesh(self) -> trimesh.Trimesh:
        n, m, _ = self.rings.shape
        verts = np.vstack([self.start[None], self.rings.reshape(-1, 3), self.end[None]])
        idx = 1 + np.arange(n * m).reshape(n, m)
        k = np.arange(m)
        k1 = (k + 1) % m
        faces = [np.column_stack([np.zeros(m, int), idx[0, k1], idx[0, k]])]
        for i in range(n - 1):
            a, b, c, d = idx[i, k], idx[i, k1], idx[i + 1, k1], idx[i + 1, k]
            faces += [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
        last = len(verts) - 1
        faces.append(np.column_stack([np.full(m, last), idx[-1, k], idx[-1, k1]]))
        mesh = trimesh.Trimesh(verts, np.vstack(faces), process=False)
        if mesh.volume < 0:
            mesh.invert()
        return mesh

    def pieces(self, n: int) -> list[np.ndarray]:
        """Split the tube into ``n`` consecutive convex pieces (ring vertices, overlapping by one
        ring; the first and last include the end apexes)."""
        count = len(self.rings)
        n = max(1, min(n, count - 1))
        cuts = np.linspace(0, count - 1, n + 1).round().astype(int)
        out = []
        for j in range(n):
            pts = self.rings[cuts[j]:cuts[j + 1] + 1].reshape(-1, 3)
            if j == 0:
                pts = np.vstack([pts, self.start])
            if j == n - 1:
                pts = np.vstack([pts, self.end])
            out.append(pts)
        return out


def _path_frames(path: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.gradient(path, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    u = np.broadcast_to(normal, path.shape).copy()
    u -= (u * t).sum(1, keepdims=True) * t
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(t, u)
    return t, u, v


def sweep(path: Any, half_width: Any, half_height: Any, *, normal: Sequence[float] = (0, 1, 0),
          exponent: float = 2.0, ring: int = 24, caps: str = "round",
          cap_segments: int = 4, cap_length: float | None = None) -> Sweep:
    """Sweep a super-elliptic cross-section along a planar path.

    ``path`` (N, 3) lies in a plane with unit normal ``normal``; the cross-section has
    half-extent ``half_width`` along ``normal`` and ``half_height`` in the plane (scalars or
    per-station arrays). ``exponent`` 2 gives ellipses, larger values rounded rectangles.
    ``caps``: ``"flat"`` (a fan to the end centre) or ``"round"`` (half-ellipsoidal ends of
    length ``cap_length``, default the smaller half-extent). Keep the path's radius of
    curvature larger than ``half_height`` or the tube folds over itself.
    """
    P = np.asarray(path, dtype=float)
    N = len(P)
    a = np.broadcast_to(np.asarray(half_width, float), (N,)).copy()
    b = np.broadcast_to(np.asarray(half_height, float), (N,)).copy()
    nrm = np.asarray(normal, dtype=float)
    nrm = nrm / np.linalg.norm(nrm)
    t, u, v = _path_frames(P, nrm)
    phi = 2 * np.pi * (np.arange(ring) + 0.5) / ring
    c, s = np.cos(phi), np.sin(phi)
    e = 2.0 / exponent
    cx = np.sign(c) * np.abs(c) ** e
    cy = np.sign(s) * np.abs(s) ** e

    def rings_at(Pi: np.ndarray, ui: np.ndarray, vi: np.ndarray, ai: Any, bi: Any) -> np.ndarray:
        ai = np.asarray(ai, float)[..., None, None]
        bi = np.asarray(bi, float)[..., None, None]
        return (Pi[..., None, :] + ui[..., None, :] * (ai * cx[:, None])
                + vi[..., None, :] * (bi * cy[:, None]))

    rings = rings_at(P, u, v, a, b)
    if caps == "flat":
        return Sweep(rings, P[0].copy(), P[-1].copy())
    if caps != "round":
        raise ValueError("caps must be 'flat' or 'round'")
    ang = np.linspace(0, np.pi / 2, cap_segments + 1)[1:-1]
    L0 = cap_length if cap_length is not None else min(a[0], b[0])
    L1 = cap_length if cap_length is not None else min(a[-1], b[-1])
    pre = [rings_at(P[0] - t[0] * L0 * np.sin(g), u[0], v[0], a[0] * np.cos(g), b[0] * np.cos(g))
           for g in ang[::-1]]
    post = [rings_at(P[-1] + t[-1] * L1 * np.sin(g), u[-1], v[-1], a[-1] * np.cos(g),
                     b[-1] * np.cos(g)) for g in ang]
    allr = np.concatenate([np.array(pre).reshape(-1, ring, 3), rings,
                           np.array(post).reshape(-1, ring, 3)], axis=0)
    return Sweep(allr, P[0] - t[0] * L0, P[-1] + t[-1] * L1)


def arc_path(center: Sequence[float], radius: float, start: float, stop: float, n: int,
             plane: str = "xz") -> np.ndarray:
    """``n + 1`` points on a circular arc in the ``xz`` (angle from +x towards +z), ``xy`` or
    ``yz`` plane."""
    t = np.linspace(start, stop, n + 1)
    p = np.zeros((n + 1, 3))
    i, j = {"xz": (0, 2), "xy": (0, 1), "yz": (1, 2)}[plane]
    p[:, i] = radius * np.cos(t)
    p[:, j] = radius * np.sin(t)
    return p + np.asarray(center, float)


def torus_arc(major_radius: float, minor_radius: float, start: float, stop: float, *,
              center: Sequence[float] = (0, 0, 0), segments: int = 24, ring: int = 16,
              caps: str = "round") -> Sweep:
    """A tube of circular section along an arc in the xz plane (angles from +x towards +z)."""
    path = arc_path(center, major_radius, start, stop, segments, "xz")
    return sweep(path, minor_radius, minor_radius, normal=(0, 1, 0), ring=ring, caps=caps)


# =============================================================================================
# Primitives
# =============================================================================================
def box(size: Sequence[float], center: Sequence[float] = (0, 0, 0), *,
        max_len: float | None = None) -> trimesh.Trimesh:
    """Axis-aligned box. With ``max_len`` its faces are split into pieces of about that size
    (better triangles where booleans cut it)."""
    L, W, H = (float(x) for x in size)
    if max_len is None:
        m = trimesh.creation.box(extents=(L, W, H))
    else:
        m = extrude(_sbox(-L / 2, -W / 2, L / 2, W / 2), H, max_len=max_len, min_len=0)
    m.apply_translation(center)
    return m


def rounded_box(size: Sequence[float], radius: float, *, segments: int = 3,
                max_len: float | None = None, center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    """Box with all edges and corners rounded by ``radius`` (``segments`` steps per quarter
    circle; see :func:`rounded_slab`)."""
    size = np.asarray(size, dtype=float)
    if radius <= 0:
        return box(size, center)
    if np.any(size / 2.0 - radius < -1e-12):
        raise ValueError("rounded_box: radius larger than half the smallest side")
    return rounded_slab(size, radius, radius, corner_segments=2 * segments,
                        edge_segments=segments, max_len=max_len, center=center)


def rounded_slab(size: Sequence[float], corner_radius: float, edge_radius: float, *,
                 corner_segments: int = 6, edge_segments: int = 3, max_len: float | None = None,
                 center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    """Slab with plan corners rounded by ``corner_radius`` (vertical edges) and all horizontal
    edges rounded by ``edge_radius`` (<= ``corner_radius``).

    Built from rings (one per step around the edge rounding) so that no triangle is long and
    thin: straight runs are split into pieces of at most ``max_len`` (default: a fifth of the
    smaller plan side) and the flat top and bottom are Delaunay-triangulated with interior
    points on a grid.
    """
    L, W, H = (float(x) for x in size)
    rc, re = float(corner_radius), float(edge_radius)
    if not 0 <= re <= rc + 1e-12 or 2 * rc > min(L, W) + 1e-12 or 2 * re > H + 1e-12:
        raise ValueError("rounded_slab: radii do not fit the size")
    re = min(re, rc)
    if max_len is None:
        max_len = max(min(L, W) / 4.0, max(L, W) / 12.0, 1e-3)
        max_len = min(max_len, max(8.0 * H, min(L, W) / 8.0))  # thin plates: shorter runs
    # no rounding band much narrower than the straight runs are long (no needle triangles)
    edge_segments = int(np.clip(round(re * np.pi / 2 / (max_len / 6.0)), 1, edge_segments))
    hx, hy = L / 2 - rc, W / 2 - rc
    base, nrm = [], []
    corners = [(hx, hy, 0.0), (-hx, hy, 0.5 * np.pi), (-hx, -hy, np.pi), (hx, -hy, 1.5 * np.pi)]
    for i, (cx, cy, a0) in enumerate(corners):
        phi = a0 + np.linspace(0.0, np.pi / 2, corner_segments + 1)
        for f in phi:
            base.append((cx, cy))
            nrm.append((math.cos(f), math.sin(f)))
        nx, ny, _ = corners[(i + 1) % 4]
        side = math.hypot(nx - cx, ny - cy)
        k = max(1, math.ceil(side / max_len - 1e-9))
        d = (math.cos(a0 + np.pi / 2), math.sin(a0 + np.pi / 2))
        for j in range(1, k):
            t = j / k
            base.append((cx + (nx - cx) * t, cy + (ny - cy) * t))
            nrm.append(d)
    base, nrm = np.array(base), np.array(nrm)
    # rings: bottom rounding (psi -pi/2..0), straight band, top rounding (0..pi/2)
    zc = H / 2 - re
    psi = np.linspace(-np.pi / 2, 0.0, edge_segments + 1)
    nb = max(1, math.ceil(2 * zc / max_len - 1e-9)) if zc > 1e-9 else 0
    spec = [(p, -zc) for p in psi]
    spec += [(0.0, -zc + 2 * zc * j / nb) for j in range(1, nb)]
    if nb:
        spec += [(p, zc) for p in -psi[::-1]]
    else:
        spec += [(p, zc) for p in -psi[::-1][1:]]
    rings = []
    for p, z in spec:
        off = rc - re + re * math.cos(p)
        xy = base + nrm * off
        rings.append(np.column_stack([xy, np.full(len(xy), z + re * math.sin(p))]))
    rings = np.array(rings)
    n, m = rings.shape[:2]
    verts = [rings.reshape(-1, 3)]
    idx = np.arange(n * m).reshape(n, m)
    k = np.arange(m)
    k1 = (k + 1) % m
    faces = []
    for i in range(n - 1):
        a, b, c, d = idx[i, k], idx[i, k1], idx[i + 1, k1], idx[i + 1, k]
        faces += [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
    # caps: Delaunay of the (de-duplicated) end ring plus interior grid points
    count = n * m
    for ring_i, top in ((0, False), (n - 1, True)):
        ring = rings[ring_i]
        poly = Polygon(ring[:, :2]).buffer(0)
        x0, y0, x1, y1 = poly.bounds
        gx = np.arange(x0 + max_len / 2, x1, max_len)
        gy = np.arange(y0 + max_len / 2, y1, max_len)
        gp = np.array([(x, y) for x in gx for y in gy]).reshape(-1, 2)
        if len(gp):
            inner = poly.buffer(-0.4 * max_len)
            gp = gp[shapely.contains_xy(inner, gp[:, 0], gp[:, 1])] if not inner.is_empty else gp[:0]
        pts2 = np.vstack([ring[:, :2], gp])
        tri = shapely.delaunay_triangles(shapely.MultiPoint(pts2))
        tc = np.array([np.asarray(t.exterior.coords)[:3] for t in tri.geoms])
        # map triangle corners back to point indices (ring first, then grid)
        lookup = {}
        for j, q in enumerate(pts2):
            lookup.setdefault((q[0], q[1]), j)
        local = np.array([[lookup[(q[0], q[1])] for q in t] for t in tc])
        gid = np.where(local < m, idx[ring_i][np.minimum(local, m - 1)], count + local - m)
        z = ring[0, 2]
        verts.append(np.column_stack([gp, np.full(len(gp), z)]))
        count += len(gp)
        v2 = pts2[local]
        cross = (v2[:, 1, 0] - v2[:, 0, 0]) * (v2[:, 2, 1] - v2[:, 0, 1]) - (
            v2[:, 1, 1] - v2[:, 0, 1]) * (v2[:, 2, 0] - v2[:, 0, 0])
        ok = np.abs(cross) > 1e-16
        g = gid[ok]
        cw = cross[ok] < 0
        g = np.where(cw[:, None], g[:, ::-1], g)  # now counter-clockwise seen from +z
        faces.append(g if top else g[:, ::-1])
    mesh = trimesh.Trimesh(np.vstack(verts), np.vstack(faces), process=False)
    mesh.merge_vertices()
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    if mesh.volume < 0:
        mesh.invert()
    if not mesh.is_watertight:
        raise RuntimeError("rounded_slab: mesh is not closed")
    mesh.apply_translation(center)
    return mesh


def rounded_rect(length: float, width: float, radius: float, *, segments: int = 6,
                 center: Sequence[float] = (0.0, 0.0)) -> Polygon:
    """A 2-D rectangle with rounded corners (shapely)."""
    r = min(radius, length / 2, width / 2) * (1 - 1e-9)
    b = _sbox(center[0] - length / 2 + r, center[1] - width / 2 + r,
              center[0] + length / 2 - r, center[1] + width / 2 - r)
    return b.buffer(r, quad_segs=segments) if r > 0 else b


def hull_mesh(points: Any) -> trimesh.Trimesh:
    """Convex hull of points as a closed mesh with outward winding."""
    m = trimesh.convex.convex_hull(np.asarray(points, float))
    if m.volume < 0:
        m.invert()
    return m


def rounded_cylinder(radius: float, height: float, *, edge_radius: float = 0.0,
                     top_radius: float | None = None, segments: int = 48,
                     edge_segments: int = 3, center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    """Cylinder (or truncated cone, ``top_radius``) along z centred on ``center``, with its two
    circular edges rounded by ``edge_radius``."""
    return Lathe.solid(rounded_cylinder_profile(radius, height, edge_radius=edge_radius,
                                                top_radius=top_radius,
                                                edge_segments=edge_segments), segments
                       ).mesh().apply_translation(np.asarray(center, float)
                                                  - [0, 0, height / 2.0])


def rounded_cylinder_profile(radius: float, height: float, *, edge_radius: float = 0.0,
                             top_radius: float | None = None, edge_segments: int = 3,
                             z0: float = 0.0) -> np.ndarray:
    """Profile of a (tapered) cylinder from ``z0`` to ``z0 + height`` with rounded edges."""
    rt = radius if top_radius is None else top_radius
    sec = solid_section([(0, z0), (radius, z0), (rt, z0 + height), (0, z0 + height)])
    if edge_radius > 0:
        sec = round_section(sec, rim_radius=edge_radius, arc_segments=edge_segments)
    return section_profile(half_section(sec))


def cylinder(radius: float, height: float, *, segments: int = 48,
             center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    """Plain cylinder along z centred on ``center``."""
    return rounded_cylinder(radius, height, segments=segments, center=center)


def ellipsoid(radii: Sequence[float], *, subdivisions: int = 3,
              center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    m.apply_scale(np.asarray(radii, float))
    m.apply_translation(center)
    return m


def sphere(radius: float, *, subdivisions: int = 3, center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    return ellipsoid((radius, radius, radius), subdivisions=subdivisions, center=center)


def capsule(radius: float, length: float, *, axis: str = "z", segments: int = 24,
            center: Sequence[float] = (0, 0, 0)) -> trimesh.Trimesh:
    """Capsule of total ``length`` (tip to tip) along ``axis``."""
    if length < 2 * radius:
        raise ValueError("capsule shorter than its diameter")
    h = length / 2 - radius
    p = np.zeros((3, 3))
    ax = "xyz".index(axis)
    p[0, ax], p[2, ax] = -h, h
    c = np.asarray(center, float)
    normal = np.eye(3)[(ax + 1) % 3]
    return sweep(p + c, radius, radius, normal=normal, ring=segments, caps="round",
                 cap_segments=max(3, segments // 4)).mesh


# =============================================================================================
# Booleans
# =============================================================================================
def _check_solid(m: trimesh.Trimesh, what: str) -> trimesh.Trimesh:
    if len(m.faces) == 0 or not m.is_watertight or m.volume <= 0:
        raise RuntimeError(f"{what} did not produce a closed solid")
    return m


def _meshes(x: trimesh.Trimesh | Iterable[trimesh.Trimesh]) -> list[trimesh.Trimesh]:
    return [x] if isinstance(x, trimesh.Trimesh) else list(x)


def to_manifold(mesh: trimesh.Trimesh) -> manifold3d.Manifold:
    """A manifold3d solid from a closed trimesh (float64 vertices)."""
    m = manifold3d.Manifold(manifold3d.Mesh64(
        vert_properties=np.ascontiguousarray(mesh.vertices, dtype=np.float64),
        tri_verts=np.ascontiguousarray(mesh.faces, dtype=np.uint64)))
    if m.is_empty():
        raise RuntimeError(f"mesh is not a closed oriented 2-manifold ({m.status()})")
    return m


def from_manifold(m: manifold3d.Manifold) -> trimesh.Trimesh:
    mm = m.to_mesh64()
    return trimesh.Trimesh(np.array(mm.vert_properties[:, :3], dtype=float),
                           np.array(mm.tri_verts, dtype=np.int64), process=False)


#: Edges of boolean results shorter than this are collapsed (m): it removes the needle
#: triangles that intersection curves leave next to existing vertices.
BOOLEAN_TOLERANCE = 3e-4


def _boolean(op: Any, meshes: list[trimesh.Trimesh], what: str, tolerance: float) -> trimesh.Trimesh:
    ms = [to_manifold(m) for m in meshes]
    r = _check_solid(from_manifold(manifold3d.Manifold.batch_boolean(ms, op)), what)
    if tolerance > 0:
        r = collapse_short_edges(r, tolerance)
    return flip_flat_caps(r)


def flip_flat_caps(mesh: trimesh.Trimesh, *, max_angle_deg: float = 150.0,
                   max_dihedral_deg: float = 3.0, passes: int = 6) -> trimesh.Trimesh:
    """Improve "cap" triangles (one angle near 180 degrees) by flipping their longest edge
    where the neighbouring triangle is nearly coplanar and the flip raises the smaller of the
    two triangles' minimum angles. The surface shape is unchanged up to the dihedral limit."""
    v = np.asarray(mesh.vertices, dtype=float)
    vl = v.tolist()
    f = np.asarray(mesh.faces, dtype=np.int64).copy()
    cos_dih = math.cos(math.radians(max_dihedral_deg))

    def normal(t: Sequence[int]) -> tuple[float, float, float]:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = vl[t[0]], vl[t[1]], vl[t[2]]
        ux, uy, uz, wx, wy, wz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
        n = (uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx)
        ln = math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)
        return (n[0] / ln, n[1] / ln, n[2] / ln) if ln > 0 else n

    def dot(a: Sequence[float], b: Sequence[float]) -> float:
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

    def min_angle(t: Sequence[int]) -> float:
        p = [vl[i] for i in t]
        best = math.pi
        for k in range(3):
            a, b, c = p[k], p[(k + 1) % 3], p[(k + 2) % 3]
            u = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
            w = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
            nu, nw = math.sqrt(dot(u, u)), math.sqrt(dot(w, w))
            if nu == 0 or nw == 0:
                return 0.0
            best = min(best, math.acos(max(-1.0, min(1.0, dot(u, w) / (nu * nw)))))
        return best

    for _ in range(passes):
        ang = trimesh.triangles.angles(v[f])
        bad = np.nonzero(ang.max(axis=1) > math.radians(max_angle_deg))[0]
        if len(bad) == 0:
            break
        edge_face: dict[tuple[int, int], int] = {}
        for i, (a, b, c) in enumerate(f):
            edge_face[(a, b)] = i
            edge_face[(b, c)] = i
            edge_face[(c, a)] = i
        done = set()
        flipped = 0
        for fi in bad[np.argsort(-ang[bad].max(axis=1))]:
            if fi in done:
                continue
            k = int(np.argmax(ang[fi]))
            a, b, c = (int(x) for x in np.roll(f[fi], -k))  # obtuse corner at a
            gi = edge_face.get((c, b))
            if gi is None or gi in done:
                continue
            g = [int(x) for x in f[gi]]
            d = next(x for x in g if x not in (b, c))
            if (a, d) in edge_face or (d, a) in edge_face:
                continue
            n0 = normal((a, b, c))
            if dot(n0, normal(g)) < cos_dih:
                # a crease: only a (nearly) zero-area cap can go, by splitting the neighbour at
                # the cap's apex, which lies on the shared edge (the shape does not change)
                pa, pb, pc = v[a], v[b], v[c]
                e = pc - pb
                ln2 = float(e @ e)
                t = float((pa - pb) @ e) / ln2 if ln2 > 0 else -1.0
                if not 0.0 < t < 1.0 or np.linalg.norm(pa - pb - t * e) > 1e-3 * math.sqrt(ln2):
                    continue
                t1, t2 = (a, b, d), (c, a, d)
                if min(min_angle(t1), min_angle(t2)) <= min_angle((a, b, c)):
                    continue
                f[fi], f[gi] = t1, t2
                for e2 in ((a, b), (b, c), (c, a), (g[0], g[1]), (g[1], g[2]), (g[2], g[0])):
                    edge_face.pop(e2, None)
                for tt, ti in ((t1, fi), (t2, gi)):
                    edge_face[(tt[0], tt[1])] = ti
                    edge_face[(tt[1], tt[2])] = ti
                    edge_face[(tt[2], tt[0])] = ti
                done.update((fi, gi))
                flipped += 1
                continue
            t1, t2 = (a, b, d), (a, d, c)
            if dot(normal(t1), n0) <= 0 or dot(normal(t2), n0) <= 0:
                continue
            if min(min_angle(t1), min_angle(t2)) <= min(min_angle((a, b, c)), min_angle(g)) + 1e-9:
                continue
            f[fi], f[gi] = t1, t2
            for e in ((a, b), (b, c), (c, a)):
                edge_face.pop(e, None)
            for e in ((g[0], g[1]), (g[1], g[2]), (g[2], g[0])):
                edge_face.pop(e, None)
            for t, ti in ((t1, fi), (t2, gi)):
                edge_face[(t[0], t[1])] = ti
                edge_face[(t[1], t[2])] = ti
                edge_face[(t[2], t[0])] = ti
            done.update((fi, gi))
            flipped += 1
        if not flipped:
            break
    out = trimesh.Trimesh(v, f, process=False)
    if not (out.is_watertight and out.is_winding_consistent):
        return mesh
    return out


def collapse_short_edges(mesh: trimesh.Trimesh, min_len: float, *, passes: int = 8) -> trimesh.Trimesh:
    """Collapse edges shorter than ``min_len`` (keep ``min_len`` well under the thinnest wall).

    Each pass collapses a set of non-adjacent short edges to their midpoints (an edge whose
    collapse would pinch the surface is skipped: its end points may share only two neighbours),
    then drops the faces that became degenerate. The result stays closed and manifold; if a pass
    would break that, it is undone and the mesh returned as it was.
    """
    v = np.asarray(mesh.vertices, dtype=float).copy()
    f = np.asarray(mesh.faces, dtype=np.int64).copy()
    for _ in range(passes):
        m = trimesh.Trimesh(v, f, process=False)
        e = m.edges_unique
        ln = m.edges_unique_length
        short = np.argsort(ln)
        short = short[ln[short] < min_len]
        if len(short) == 0:
            break
        nbrs = [set() for _ in range(len(v))]
        for a, b in e:
            nbrs[a].add(b)
            nbrs[b].add(a)
        vf = m.vertex_faces
        fn = m.face_normals
        touched = np.zeros(len(v), bool)
        remap = np.arange(len(v))
        nv = v.copy()
        for k in short:
            a, b = e[k]
            if touched[a] or touched[b] or len(nbrs[a] & nbrs[b]) != 2:
                continue
            mid = (v[a] + v[b]) / 2.0
            # the surviving faces around a and b must not fold over (flip their normal)
            around = {int(x) for x in np.concatenate([vf[a], vf[b]]) if x >= 0}
            ok = True
            for fi in around:
                tri = f[fi]
                if a in tri and b in tri:
                    continue
                p = np.where(((tri == a) | (tri == b))[:, None], mid, v[tri])
                n = np.cross(p[1] - p[0], p[2] - p[0])
                ln = np.linalg.norm(n)
                if ln == 0 or float(n @ fn[fi]) < 0.5 * ln:
                    ok = False
                    break
            if not ok:
                continue
            touched[list(nbrs[a] | nbrs[b] | {a, b})] = True
            remap[b] = a
            nv[a] = mid
        nf = remap[f]
        keep = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
        nf = nf[keep]
        t = trimesh.Trimesh(nv, nf, process=False)
        if not (t.is_watertight and t.is_winding_consistent) or t.volume <= 0:
            break
        t.remove_unreferenced_vertices()
        v, f = np.asarray(t.vertices), np.asarray(t.faces)
    return trimesh.Trimesh(v, f, process=False)


def union(meshes: Iterable[trimesh.Trimesh], *, tolerance: float = BOOLEAN_TOLERANCE) -> trimesh.Trimesh:
    """Boolean union (manifold3d, float64), simplified to ``tolerance``; checked closed."""
    ms = _meshes(meshes)
    return _boolean(manifold3d.OpType.Add, ms, "union", tolerance)


def difference(a: trimesh.Trimesh, b: trimesh.Trimesh | Iterable[trimesh.Trimesh], *,
               tolerance: float = BOOLEAN_TOLERANCE) -> trimesh.Trimesh:
    """``a`` minus ``b`` (one mesh or several)."""
    return _boolean(manifold3d.OpType.Subtract, [a, *_meshes(b)], "difference", tolerance)


def intersection(a: trimesh.Trimesh, b: trimesh.Trimesh | Iterable[trimesh.Trimesh], *,
                 tolerance: float = BOOLEAN_TOLERANCE) -> trimesh.Trimesh:
    return _boolean(manifold3d.OpType.Intersect, [a, *_meshes(b)], "intersection", tolerance)


# =============================================================================================
# Collision pieces
# =============================================================================================
def hull_points(points: Any) -> np.ndarray:
    """The vertices of the convex hull of ``points`` (float64, (n, 3))."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    try:
        h = ConvexHull(p)
    except QhullError as e:
        raise ValueError(f"degenerate collision piece: {str(e).splitlines()[0]}") from None
    return np.ascontiguousarray(p[h.vertices])


def clip_piece(mesh: trimesh.Trimesh, lo: Sequence[float], hi: Sequence[float]) -> np.ndarray:
    """Hull vertices of the part of ``mesh``'s surface inside the box ``lo <= x <= hi``.

    Cut points on the box faces are included, so pieces of neighbouring boxes meet exactly.
    Use ``+-inf`` for unbounded sides.
    """
    m = mesh
    for ax in range(3):
        for sign, val in ((1.0, lo[ax]), (-1.0, hi[ax])):
            if not np.isfinite(val):
                continue
            n = np.zeros(3)
            n[ax] = sign
            o = np.zeros(3)
            o[ax] = val
            m = trimesh.intersections.slice_mesh_plane(m, n, o, cap=False)
            if len(m.faces) == 0:
                raise ValueError(f"clip_piece: box {lo}..{hi} contains no surface")
    return hull_points(m.vertices)


# =============================================================================================
# Checks
# =============================================================================================
def _piece_hull(points: np.ndarray) -> ConvexHull:
    return ConvexHull(np.asarray(points, float))


def collision_stats(shape: Any) -> dict[str, float]:
    """Numbers describing how the collision pieces fit the visual mesh.

    ``cover_max``: largest distance of a visual vertex outside every piece's hull (m);
    ``excursion_max``: largest distance from the visual surface of a point of a piece's hull
    surface that is not inside the visual solid (m; how far the pieces reach over gaps);
    ``hull_volume_ratio``: summed piece hull volume over the visual volume.
    """
    vis = shape.visual
    hulls = [_piece_hull(p) for p in shape.collision]
    v = np.asarray(vis.vertices, float)
    outside = np.full(len(v), np.inf)
    for h in hulls:
        d = (v @ h.equations[:, :3].T + h.equations[:, 3]).max(axis=1)
        outside = np.minimum(outside, d)
    outside = np.maximum(outside, 0.0)
    # plane distances underestimate the true distance only near hull edges; refine those
    cand = np.nonzero(outside > 1e-5)[0]
    if len(cand):
        best = np.full(len(cand), np.inf)
        for h in hulls:
            hm = trimesh.Trimesh(h.points, h.simplices, process=False)
            _, dist, _ = trimesh.proximity.closest_point(hm, v[cand])
            inside = (v[cand] @ h.equations[:, :3].T + h.equations[:, 3]).max(axis=1) <= 1e-9
            best = np.minimum(best, np.where(inside, 0.0, dist))
        outside[cand] = best
    # excursion: sample each hull's surface, distance to the visual surface samples
    area = float(vis.area)
    spacing = max(math.sqrt(area / 50000.0), 2e-4)
    surf, fidx = trimesh.sample.sample_surface(vis, int(min(50000, area / spacing**2)), seed=0)
    surf = np.vstack([surf, vis.triangles_center])
    snorm = np.vstack([vis.face_normals[fidx], vis.face_normals])
    tree = cKDTree(surf)
    exc = 0.0
    for h in hulls:
        tri = h.points[h.simplices]
        q = np.vstack([h.points[h.vertices], tri.mean(axis=1),
                       (tri[:, 0] + tri[:, 1]) / 2, (tri[:, 1] + tri[:, 2]) / 2,
                       (tri[:, 0] + tri[:, 2]) / 2])
        d, j = tree.query(q)
        # a point behind the nearest surface sample's face is inside the solid; confirm the
        # points that look outside and far with the (exact, slower) winding number
        ins = np.einsum("ij,ij->i", q - surf[j], snorm[j]) < 0
        d[ins] = 0.0
        far = np.nonzero(d > max(1e-3, exc))[0]
        far = far[np.argsort(-d[far])]
        for i in range(0, len(far), 64):  # farthest first: stop at the first one outside
            batch = far[i:i + 64]
            out = batch[winding_number(vis, q[batch]) <= 0.5]
            if len(out):
                exc = max(exc, float(d[out].max()))
                break
        else:
            exc = max(exc, float(np.max(d, initial=0.0, where=~np.isin(np.arange(len(d)), far))))
    vol = float(vis.volume)
    return {
        "cover_max": float(outside.max()) if len(outside) else 0.0,
        "excursion_max": exc,
        "hull_volume_ratio": sum(h.volume for h in hulls) / vol if vol > 0 else math.inf,
        "pieces": float(len(hulls)),
    }


def winding_number(mesh: trimesh.Trimesh, points: Any, chunk: int = 64) -> np.ndarray:
    """Generalised winding number of a closed mesh at each point (1 inside, 0 outside)."""
    tri = np.asarray(mesh.triangles, dtype=float)
    q = np.asarray(points, dtype=float).reshape(-1, 3)
    out = np.empty(len(q))
    for i in range(0, len(q), chunk):
        d = tri[None, :, :, :] - q[i:i + chunk, None, None, :]  # (p, f, 3, 3)
        a, b, c = d[..., 0, :], d[..., 1, :], d[..., 2, :]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        num = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc
               + np.einsum("pfi,pfi->pf", b, c) * la + np.einsum("pfi,pfi->pf", c, a) * lb)
        out[i:i + chunk] = np.arctan2(num, den).sum(axis=1) / (2.0 * np.pi)
    return out


def default_max_excursion(mesh: trimesh.Trimesh) -> float:
    """How far the collision pieces may reach beyond the visual surface: 10 % of the bounding
    box diagonal, at least 4 mm (sector chords of a revolved wall, a filled punt or lid
    recess, filled tine gaps...). A hull over a mug's cavity or handle exceeds it."""
    return max(4e-3, 0.10 * float(np.linalg.norm(mesh.extents)))


def validate_shape(shape: Any, *, cover_tol: float = COVER_TOL,
                   max_excursion: float | None = None, max_pieces: int = 24) -> list[str]:
    """Problems with a shape (an object with ``visual`` and ``collision``); empty when fine.

    Checks: the visual mesh is a closed, consistently and outwardly wound solid with no
    degenerate faces, centred on its bounding box; there are 1 to ``max_pieces`` collision
    pieces, each a finite (n, 3) float64 array whose hull is a proper solid (volume above
    ``MIN_PIECE_VOLUME``); every visual vertex lies within ``cover_tol`` of some piece's hull;
    no piece hull reaches more than ``max_excursion`` (default :func:`default_max_excursion`)
    from the visual surface into empty space.
    """
    problems: list[str] = []
    m = shape.visual
    if not isinstance(m, trimesh.Trimesh) or len(m.faces) == 0:
        return ["visual is not a non-empty trimesh.Trimesh"]
    v = np.asarray(m.vertices)
    if not np.all(np.isfinite(v)):
        return ["visual mesh has non-finite vertices"]
    if not m.is_watertight:
        problems.append("visual mesh is not watertight")
    if not m.is_winding_consistent:
        problems.append("visual mesh winding is inconsistent")
    if m.is_watertight and m.volume <= 0:
        problems.append(f"visual mesh volume is not positive ({m.volume:.3g} m^3): inward normals?")
    areas = m.area_faces
    if np.any(areas < 1e-13):
        problems.append(f"visual mesh has {int((areas < 1e-13).sum())} degenerate faces")
    center = m.bounds.mean(axis=0)
    if np.any(np.abs(center) > 1e-6):
        problems.append(f"bounding box is not centred on the origin (centre {center.round(6)})")
    pieces = shape.collision
    if not isinstance(pieces, tuple) or not 1 <= len(pieces) <= max_pieces:
        problems.append(f"collision must be a tuple of 1..{max_pieces} pieces, "
                        f"got {type(pieces).__name__} of {len(pieces)}")
        return problems
    ok = True
    for i, p in enumerate(pieces):
        if not isinstance(p, np.ndarray) or p.dtype != np.float64 or p.ndim != 2 \
                or p.shape[1] != 3 or len(p) < 4 or not np.all(np.isfinite(p)):
            problems.append(f"collision piece {i} is not a finite (n >= 4, 3) float64 array")
            ok = False
            continue
        try:
            h = _piece_hull(p)
        except QhullError:
            problems.append(f"collision piece {i} is degenerate (coplanar points)")
            ok = False
            continue
        if h.volume <= MIN_PIECE_VOLUME:
            problems.append(f"collision piece {i} hull volume {h.volume:.3g} m^3 is too small")
            ok = False
    if not ok or problems:
        return problems
    st = collision_stats(shape)
    if st["cover_max"] > cover_tol:
        problems.append(f"collision pieces leave visual vertices uncovered by "
                        f"{st['cover_max'] * 1e3:.2f} mm (> {cover_tol * 1e3:.2f} mm)")
    lim = default_max_excursion(m) if max_excursion is None else max_excursion
    if st["excursion_max"] > lim:
        problems.append(f"collision pieces reach {st['excursion_max'] * 1e3:.1f} mm beyond the "
                        f"visual surface (> {lim * 1e3:.1f} mm)")
    return problems


def mesh_quality(mesh: trimesh.Trimesh) -> dict[str, float]:
    """Triangle statistics: count, smallest angle (deg), largest aspect ratio, shortest edge."""
    tri = mesh.triangles
    e = np.linalg.norm(tri[:, [1, 2, 0]] - tri, axis=2)
    ang = trimesh.triangles.angles(tri)
    area = mesh.area_faces
    aspect = e.max(axis=1) ** 2 / np.maximum(2 * area, 1e-30)  # longest edge / height on it
    return {
        "faces": float(len(mesh.faces)),
        "min_angle_deg": float(np.degrees(ang.min())),
        "p1_angle_deg": float(np.degrees(np.percentile(ang.min(axis=1), 1))),
        "max_aspect": float(aspect.max()),
        "min_edge_mm": float(e.min() * 1e3),
    }
