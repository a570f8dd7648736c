"""Approximate convex decomposition of 2-D polygons (for collision pieces)."""

from __future__ import annotations

import math

import numpy as np
import shapely
import shapely.ops
from shapely.geometry import LineString, Polygon
from shapely.geometry.polygon import orient

from ._common import AXIS_EPS

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
