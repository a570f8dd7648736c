"""Collision pieces and checks: :func:`hull_points`, :func:`clip_piece`,
:func:`collision_stats`, :func:`validate_shape`, :func:`mesh_quality` and helpers."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError, cKDTree

from ._common import COVER_TOL, MIN_PIECE_VOLUME

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
