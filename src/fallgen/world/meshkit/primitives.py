"""Primitive solids: boxes, rounded boxes and slabs, cylinders, ellipsoids, spheres,
capsules, convex hulls, and the 2-D :func:`rounded_rect`."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import shapely
import trimesh
from shapely.geometry import Polygon
from shapely.geometry import box as _sbox

from .flat import extrude
from .lathe import Lathe
from .profiles import half_section, round_section, section_profile, solid_section
from .tubes import sweep

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
