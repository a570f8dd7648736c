"""Mesh booleans with manifold3d in float64 (:func:`union`, :func:`difference`,
:func:`intersection`) and the clean-up of their slivers (:func:`collapse_short_edges`,
:func:`flip_flat_caps`)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import manifold3d
import numpy as np
import trimesh

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

    def replace(edge_face: dict, fi: int, gi: int, old_f, old_g, t1, t2) -> None:
        """Faces fi, gi (old_f, old_g) become t1, t2; keep the directed-edge index current."""
        f[fi], f[gi] = t1, t2
        for t in (old_f, old_g):
            for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                edge_face.pop(e, None)
        for t, ti in ((t1, fi), (t2, gi)):
            edge_face[(t[0], t[1])] = ti
            edge_face[(t[1], t[2])] = ti
            edge_face[(t[2], t[0])] = ti

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
                replace(edge_face, fi, gi, (a, b, c), g, t1, t2)
                done.update((fi, gi))
                flipped += 1
                continue
            t1, t2 = (a, b, d), (a, d, c)
            if dot(normal(t1), n0) <= 0 or dot(normal(t2), n0) <= 0:
                continue
            if min(min_angle(t1), min_angle(t2)) <= min(min_angle((a, b, c)), min_angle(g)) + 1e-9:
                continue
            replace(edge_face, fi, gi, (a, b, c), g, t1, t2)
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
