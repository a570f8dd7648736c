"""2-D polylines, lathe profiles and their shapely sections in the (r, z) plane.

Polyline helpers (resampling, cleaning, filleting, PCHIP curves), profile checks, and the
solid / open / hollow sections of lathe-turned parts with their conversion back to profiles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry import box as _sbox
from shapely.geometry.polygon import orient

from ._common import _BIG, AXIS_EPS

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
