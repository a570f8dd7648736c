"""Flat parts: polygon cleaning and triangulation, extrusion along z, and vertex warps
(:func:`warp`, :func:`bend_z`, :func:`smoothstep`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import shapely
import trimesh
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.polygon import orient

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
