"""Surfaces of revolution: :func:`revolve`, :class:`Lathe` (a revolved section with its mesh
and collision pieces) and :func:`convex_pieces_of_revolution`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
import trimesh
from shapely.geometry import LineString, Polygon

from ._common import AXIS_EPS, capped_ring_faces
from .convex2d import concavity_2d, convex_parts_2d
from .profiles import (
    _profile_array,
    _signed_area,
    half_section,
    hollow_section,
    resample_polyline,
    section_profile,
    solid_section,
)

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
    f = capped_ring_faces(n, segments)
    if _signed_area(p) < 0:  # clockwise profile: flip every face
        f = f[:, ::-1]
    return trimesh.Trimesh(verts, f, process=False)


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
