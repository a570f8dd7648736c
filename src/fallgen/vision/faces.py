"""The faces a scene's renderer draws opaque, as occluders: triangles in the room frame, and
the convex solids among them (a box, a convex mesh, a round geom's stand-in) with the planes
that separate each from an object.

- Drawn and opaque: a geom in the groups views draw, alpha 1 in its colour and its material.
- A box's six faces and a mesh's triangles are what the renderer draws. A sphere, ellipsoid,
  cylinder or capsule the renderer draws as a polyhedron with its vertices on the surface
  (``numslices`` around, ``numstacks`` along); a polyhedron inside that one stands in for it
  (:func:`inner_ratio`; a capsule's cylinder only). Every triangle is counter-clockwise seen
  from its front (outward for a closed solid).
- A convex solid hides a point from an eye when a plane separates the solid (with the eye on
  its side) from the point: along the ray, the solid comes first. :class:`FaceSet` finds such
  planes, among the world's axes and the solid's own, for the hull of an object's points.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numba import njit

#: The geom groups views draw (MuJoCo's default visualisation options): 0, 1 and 2.
DRAWN_GROUPS = np.array(mujoco.MjvOption().geomgroup, np.uint8)

#: The six faces of a unit box: the corner signs of each, counter-clockwise seen from outside.
_BOX_FACES = np.array([
    [[-1, -1, -1], [-1, -1, 1], [-1, 1, 1], [-1, 1, -1]],
    [[1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1]],
    [[-1, -1, -1], [1, -1, -1], [1, -1, 1], [-1, -1, 1]],
    [[-1, 1, -1], [-1, 1, 1], [1, 1, 1], [1, 1, -1]],
    [[-1, -1, -1], [-1, 1, -1], [1, 1, -1], [1, -1, -1]],
    [[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
], float)
_BOX_TRIANGLES = np.concatenate([_BOX_FACES[:, [0, 1, 2]], _BOX_FACES[:, [0, 2, 3]]])


def drawn_opaque(model: mujoco.MjModel, g: int) -> bool:
    """Whether the views draw geom ``g`` (its group) and draw it opaque (its colour's and its
    material's alpha 1)."""
    if not DRAWN_GROUPS[min(int(model.geom_group[g]), len(DRAWN_GROUPS) - 1)]:
        return False
    alpha = float(model.geom_rgba[g, 3])
    mat = int(model.geom_matid[g])
    if mat >= 0:
        alpha = min(alpha, float(model.mat_rgba[mat, 3]))
    return alpha >= 1.0


def _prism(sides: int) -> np.ndarray:
    """(4 sides, 3, 3) triangles of a unit prism (radius 1, z in [-1, 1]) with ``sides``
    sides, counter-clockwise seen from outside."""
    a = 2 * np.pi * np.arange(sides) / sides
    ring = np.column_stack([np.cos(a), np.sin(a)])
    tris = []
    for i in range(sides):
        (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % sides]
        tris += [[(x0, y0, -1), (x1, y1, -1), (x1, y1, 1)], [(x0, y0, -1), (x1, y1, 1), (x0, y0, 1)],
                 [(0, 0, 1), (x0, y0, 1), (x1, y1, 1)], [(0, 0, -1), (x1, y1, -1), (x0, y0, -1)]]
    return np.array(tris, float)


def _octasphere() -> np.ndarray:
    """Triangles of a unit sphere's inscribed polyhedron (an octahedron split twice: 128
    faces, vertices on the sphere), counter-clockwise seen from outside."""
    tris = [np.array(t, float) for t in (
        [(1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 1, 0), (-1, 0, 0), (0, 0, 1)],
        [(-1, 0, 0), (0, -1, 0), (0, 0, 1)], [(0, -1, 0), (1, 0, 0), (0, 0, 1)],
        [(0, 1, 0), (1, 0, 0), (0, 0, -1)], [(-1, 0, 0), (0, 1, 0), (0, 0, -1)],
        [(0, -1, 0), (-1, 0, 0), (0, 0, -1)], [(1, 0, 0), (0, -1, 0), (0, 0, -1)])]
    for _ in range(2):
        out = []
        for a, b, c in tris:
            ab, bc, ca = ((u + v) / np.linalg.norm(u + v) for u, v in ((a, b), (b, c), (c, a)))
            out += [np.array(t) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
        tris = out
    return np.array(tris)


_PRISM = _prism(12)
_SPHERE = _octasphere()


def inner_ratio(model: mujoco.MjModel) -> float:
    """The fraction of a round geom's size that the renderer's polyhedron for it holds
    everywhere: its faces' vertices lie on the surface, ``numslices`` around and
    ``numstacks`` along, so every face lies within (pi / slices + pi / stacks) of the
    surface's normal direction; a little less again for rounding."""
    q = model.vis.quality
    return 0.999 * math.cos(math.pi / q.numslices + math.pi / q.numstacks)


def geom_triangles(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> np.ndarray | None:
    """(M, 3, 3) world triangles of geom ``g``, counter-clockwise seen from their front: a
    box's faces, a mesh's as stored; for a round geom, a polyhedron inside the one the
    renderer draws (:func:`inner_ratio`; a capsule's cylinder only). None for other types."""
    pos, rot = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
    t = int(model.geom_type[g])
    size = model.geom_size[g]
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        local = _BOX_TRIANGLES * size
    elif t == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[g])
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        local = model.mesh_vert[v0:v0 + nv].astype(float)[model.mesh_face[f0:f0 + nf]]
    elif t in (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_ELLIPSOID):
        radii = size[[0, 0, 0]] if t == mujoco.mjtGeom.mjGEOM_SPHERE else size[:3]
        local = _SPHERE * (inner_ratio(model) * radii)
    elif t in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE):
        r = inner_ratio(model) * size[0]
        local = _PRISM * np.array([r, r, 0.999 * size[1]])
    else:
        return None
    return local @ rot.T + pos


def coplanar_pairs(t: np.ndarray, n: np.ndarray, group: np.ndarray | None = None
                   ) -> np.ndarray:
    """For each triangle of ``t`` (M, 3, 3; unit normals ``n``), the index of a triangle of
    the same ``group`` (e.g. its geom; all one group if None) that shares an edge with it, lies
    in its plane and makes a strictly convex quadrilateral with it (a box face's two halves),
    or -1: each triangle in one pair at most, the first such edge in index order."""
    m = len(t)
    partner = np.full(m, -1, np.int64)
    if m < 2:
        return partner
    group = np.zeros(m, np.int64) if group is None else np.asarray(group, np.int64)
    rows = np.ascontiguousarray(t.reshape(-1, 3).round(9) + 0.0)  # -0.0 -> 0.0
    _, vid = np.unique(rows.view(np.dtype((np.void, 24))).ravel(), return_inverse=True)
    vid = vid.reshape(m, 3).astype(np.int64)
    a, b = vid, np.roll(vid, -1, axis=1)  # edge e of a triangle: vertices e, e + 1
    nv = int(vid.max()) + 1
    key = ((group[:, None] * nv + np.minimum(a, b)) * nv + np.maximum(a, b)).ravel()
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order][1:] == key[order][:-1])
    ti, te, tj = order[same] // 3, order[same] % 3, order[same + 1] // 3
    keep = (ti != tj) & (np.einsum("ij,ij->i", n[ti], n[tj]) >= 1.0 - 1e-9)
    ti, te, tj = ti[keep], te[keep], tj[keep]
    # j's far vertex: the one off the shared edge (exactly one)
    ea, eb = vid[ti, te], vid[ti, (te + 1) % 3]
    off = (vid[tj] != ea[:, None]) & (vid[tj] != eb[:, None])
    one = off.sum(1) == 1
    ti, te, tj, off = ti[one], te[one], tj[one], off[one]
    far = t[tj, np.argmax(off, axis=1)]
    tol = 1e-9 * (1.0 + float(np.abs(t).max()))
    flat = np.abs(np.einsum("ij,ij->i", far - t[ti, 0], n[ti])) <= tol
    q = np.stack([t[ti, (te + 1) % 3], t[ti, (te + 2) % 3], t[ti, te], far], axis=1)
    nrm = np.cross(t[ti, 1] - t[ti, 0], t[ti, 2] - t[ti, 0])
    convex = flat.copy()
    for k in range(4):
        turn = np.cross(q[:, (k + 1) % 4] - q[:, k], q[:, (k + 2) % 4] - q[:, (k + 1) % 4])
        convex &= np.einsum("ij,ij->i", turn, nrm) > 0.0
    for i, j in zip(ti[convex].tolist(), tj[convex].tolist()):
        if partner[i] < 0 and partner[j] < 0:
            partner[i], partner[j] = j, i
    return partner


def unique_rows(a: np.ndarray) -> np.ndarray:
    """``np.unique(a, axis=0)`` of an (N, 3) float array, the same rows in the same order, by
    one lexicographic sort of the columns (~5x faster for a mesh's few hundred vertices).
    Rows equal as numbers but not as bits (a zero of either sign, NaN) are left to NumPy,
    whose sort keeps one of them by its own order."""
    a = np.ascontiguousarray(a)
    if not len(a) or np.isnan(a).any() or np.signbit(a[a == 0]).any():
        return np.unique(a, axis=0)
    s = a[np.lexsort((a[:, 2], a[:, 1], a[:, 0]))]
    new = np.ones(len(s), bool)
    new[1:] = (s[1:] != s[:-1]).any(1)
    return s[new]


def _round(model: mujoco.MjModel, g: int) -> bool:
    return int(model.geom_type[g]) in (mujoco.mjtGeom.mjGEOM_SPHERE,
                                       mujoco.mjtGeom.mjGEOM_ELLIPSOID,
                                       mujoco.mjtGeom.mjGEOM_CYLINDER,
                                       mujoco.mjtGeom.mjGEOM_CAPSULE)


def geom_points(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> np.ndarray:
    """(N, 3) world points whose hull holds geom ``g`` as drawn: a mesh's vertices, a box's
    corners, the corners of another type's bounding box."""
    pos, rot = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
    if int(model.geom_type[g]) == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[g])
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        return model.mesh_vert[v0:v0 + nv].astype(float) @ rot.T + pos
    c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    return (c + signs * h) @ rot.T + pos


@njit(cache=True)
def behind_planes(tris, normals, points, margin):
    """For each face, whether every point lies at least ``margin`` behind its plane."""
    out = np.zeros(len(tris), np.bool_)
    for i in range(len(tris)):
        n0, n1, n2 = normals[i, 0], normals[i, 1], normals[i, 2]
        v0, v1, v2 = tris[i, 0, 0], tris[i, 0, 1], tris[i, 0, 2]
        ok = True
        for j in range(points.shape[0]):
            if n0 * (points[j, 0] - v0) + n1 * (points[j, 1] - v1) \
                    + n2 * (points[j, 2] - v2) > -margin:
                ok = False
                break
        out[i] = ok
    return out


@njit(cache=True)
def is_convex(tris, normals, verts, tol):
    """Whether every vertex lies behind (or within ``tol`` of) every face's plane: a closed
    mesh that is convex."""
    for i in range(len(tris)):
        for j in range(verts.shape[0]):
            if normals[i, 0] * (verts[j, 0] - tris[i, 0, 0]) \
                    + normals[i, 1] * (verts[j, 1] - tris[i, 0, 1]) \
                    + normals[i, 2] * (verts[j, 2] - tris[i, 0, 2]) > tol:
                return False
    return True


#: Vertices a convex solid keeps for its image (a subset spans a polyhedron inside it).
SOLID_VERTICES = 48


def spread_subset(v: np.ndarray, k: int) -> np.ndarray:
    """``k`` of the points ``v`` spread over them (farthest-point sampling from the first), or
    all of them when there are no more than ``k``."""
    if len(v) <= k:
        return v
    chosen = [0]
    d = np.linalg.norm(v - v[0], axis=1)
    for _ in range(k - 1):
        i = int(np.argmax(d))
        chosen.append(i)
        d = np.minimum(d, np.linalg.norm(v - v[i], axis=1))
    return v[chosen]


def _cat(parts: list[np.ndarray], shape: tuple[int, ...], dtype=float) -> np.ndarray:
    return np.ascontiguousarray(np.concatenate(parts) if parts else np.zeros(shape, dtype))


class SceneFaces:
    """The faces some geoms of a scene are drawn with (those of ``geoms`` drawn opaque), what
    does not depend on the object they may hide: triangles (M, 3, 3), unit ``normals``, boxes
    ``lo``/``hi``, ``spheres`` (M, 4: a stand-in's bounding sphere, used only from outside it;
    radius -1 for a face the renderer draws itself), ``owner`` (its convex solid, or -1); the
    convex solids' image vertices (at most :data:`SOLID_VERTICES` of theirs, spread over them:
    their hull lies inside the solid, so its image inside the solid's; ``solid_verts`` from
    ``solid_start[k]``), boxes (of every vertex), bounding spheres and their extents along 12
    directions (the world's axes and their own, both ways: ``dirs``, ``support``), from which
    :class:`FaceSet` finds the planes that separate each from an object. Keep one for the
    geoms that stay put (a room's) and make one for the objects of each scene."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, geoms) -> None:
        tris, spheres, owners, groups = [], [], [], []
        verts, slo, shi, ssph, dirs, support = [], [], [], [], [], []
        for g in geoms:
            if not drawn_opaque(model, g):
                continue
            t = geom_triangles(model, data, g)
            if t is None or not len(t):
                continue
            n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
            length = np.linalg.norm(n, axis=1)
            keep = length > 1e-12  # degenerate triangles cover nothing
            t = np.ascontiguousarray(t[keep])
            n = np.ascontiguousarray(n[keep] / length[keep, None])
            if not len(t):
                continue
            r = float(model.geom_rbound[g]) if _round(model, g) else -1.0
            solid = -1
            v = unique_rows(t.reshape(-1, 3))
            if int(model.geom_type[g]) != mujoco.mjtGeom.mjGEOM_MESH or is_convex(
                    t, n, v, 1e-9 * (1.0 + float(np.abs(v).max()))):
                solid = len(verts)
                rot = data.geom_xmat[g].reshape(3, 3)
                dd = np.vstack([np.eye(3), rot.T])
                dd = np.vstack([dd, -dd])
                verts.append(spread_subset(v, SOLID_VERTICES))
                slo.append(v.min(0))
                shi.append(v.max(0))
                ssph.append([*data.geom_xpos[g], r])
                dirs.append(dd)
                support.append((v @ dd.T).max(0))
            groups.append(np.full(len(t), len(tris), np.int64))
            tris.append(t)
            spheres.append(np.tile([*data.geom_xpos[g], r], (len(t), 1)))
            owners.append(np.full(len(t), solid, np.int64))
        self.triangles = _cat(tris, (0, 3, 3))
        e = np.cross(self.triangles[:, 1] - self.triangles[:, 0],
                     self.triangles[:, 2] - self.triangles[:, 0])
        self.normals = np.ascontiguousarray(
            e / np.maximum(np.linalg.norm(e, axis=1), 1e-300)[:, None])
        self.lo = np.ascontiguousarray(self.triangles.min(1)) if len(tris) else np.zeros((0, 3))
        self.hi = np.ascontiguousarray(self.triangles.max(1)) if len(tris) else np.zeros((0, 3))
        self.spheres = _cat(spheres, (0, 4))
        self.owner = _cat(owners, (0,), np.int64)
        self.partner = coplanar_pairs(self.triangles, self.normals,
                                      _cat(groups, (0,), np.int64))
        self.solid_verts = _cat(verts, (0, 3))
        self.solid_start = np.cumsum([0] + [len(v) for v in verts]).astype(np.int64)
        self.solid_lo, self.solid_hi = _cat([np.atleast_2d(x) for x in slo], (0, 3)), \
            _cat([np.atleast_2d(x) for x in shi], (0, 3))
        self.solid_spheres = np.array(ssph, float).reshape(-1, 4)
        self.dirs = np.array(dirs, float).reshape(-1, 12, 3)
        self.support = np.array(support, float).reshape(-1, 12)


class FaceSet:
    """The occluders of one object in a scene made of ``parts`` (:class:`SceneFaces`): the
    faces with ``behind`` (the object lies at least ``behind_m`` behind the face's own plane)
    or of a convex solid, each solid with its separating ``planes`` (K, 12, 4: (n, d), the
    solid in n.x <= d and the object at n.x >= d + ``behind_m``; ``nplanes`` of them, maybe
    none), the rest left out. ``points`` (N, 3): points whose hull holds the object as
    drawn."""

    def __init__(self, parts: list[SceneFaces], points: np.ndarray, behind_m: float) -> None:
        fields = ("triangles", "normals", "lo", "hi", "spheres", "owner", "behind")
        keep: dict[str, list] = {f: [] for f in fields}
        solids: dict[str, list] = {f: [] for f in ("verts", "lo", "hi", "sph", "planes")}
        starts, n_solids, offset = [0], 0, 0
        keep["partner"] = []
        for part in parts:
            behind = behind_planes(part.triangles, part.normals, points, behind_m)
            # each solid's separating planes
            reach = (points @ part.dirs.reshape(-1, 3).T).min(0).reshape(-1, 12) \
                if len(part.dirs) else np.zeros((0, 12))
            ok = reach >= part.support + behind_m
            # every convex solid, with or without planes: its separating directions first
            # (in their order), then rows of zeros
            nk = len(ok)
            number = np.arange(n_solids, n_solids + nk, dtype=np.int64)
            n_solids += nk
            first = np.argsort(~ok, axis=1, kind="stable")
            planes = np.zeros((nk, 12, 4))
            planes[:, :, :3] = np.take_along_axis(part.dirs.reshape(nk, 12, 3),
                                                  first[:, :, None], axis=1)
            planes[:, :, 3] = np.take_along_axis(part.support.reshape(nk, 12), first, axis=1)
            count = ok.sum(1)
            planes[np.arange(12)[None, :] >= count[:, None]] = 0.0
            solids["planes"].append((count, planes))
            # the part's solids' vertices are its solid_verts, solid by solid from 0
            solids["verts"].append(part.solid_verts)
            starts.extend((starts[-1] + part.solid_start[1:]).tolist())
            solids["lo"].append(part.solid_lo)
            solids["hi"].append(part.solid_hi)
            solids["sph"].append(part.solid_spheres)
            owner = np.where(part.owner >= 0, number[np.maximum(part.owner, 0)], -1) \
                if len(number) else np.full(len(part.owner), -1, np.int64)
            use = behind | (owner >= 0)
            index = np.cumsum(use) - 1 + offset
            pair = np.where(part.partner >= 0, part.partner, 0)
            keep["partner"].append(np.where((part.partner >= 0) & use[pair], index[pair],
                                            -1)[use])
            offset += int(use.sum())
            for f, x in (("triangles", part.triangles), ("normals", part.normals),
                         ("lo", part.lo), ("hi", part.hi), ("spheres", part.spheres),
                         ("owner", owner), ("behind", behind)):
                keep[f].append(x[use])
        self.triangles = _cat(keep["triangles"], (0, 3, 3))
        self.normals = _cat(keep["normals"], (0, 3))
        self.lo, self.hi = _cat(keep["lo"], (0, 3)), _cat(keep["hi"], (0, 3))
        self.spheres = _cat(keep["spheres"], (0, 4))
        self.owner = _cat(keep["owner"], (0,), np.int64)
        self.behind = _cat(keep["behind"], (0,), np.bool_)
        #: the index of the face that makes a convex quadrilateral with each (or -1)
        self.partner = _cat(keep["partner"], (0,), np.int64)
        #: each solid's faces: ``face_start[k]`` to ``face_end[k]`` (they are consecutive)
        self.face_start = np.zeros(n_solids, np.int64)
        self.face_end = np.zeros(n_solids, np.int64)
        mine = np.flatnonzero(self.owner >= 0)
        if len(mine):
            ids, first, count = np.unique(self.owner[mine], return_index=True,
                                          return_counts=True)
            self.face_start[ids] = mine[first]
            self.face_end[ids] = mine[first] + count
            if not np.array_equal(self.owner[mine], np.repeat(ids, count)):
                raise AssertionError("a solid's faces are not consecutive")
        self.solid_verts = _cat(solids["verts"], (0, 3))
        self.solid_start = np.array(starts, np.int64)
        self.solid_lo = _cat(solids["lo"], (0, 3))
        self.solid_hi = _cat(solids["hi"], (0, 3))
        self.solid_spheres = _cat(solids["sph"], (0, 4))
        self.nplanes = _cat([n for n, _ in solids["planes"]], (0,), np.int64)
        self.planes = _cat([p for _, p in solids["planes"]], (0, 12, 4))


__all__ = ["DRAWN_GROUPS", "FaceSet", "SceneFaces", "behind_planes", "drawn_opaque",
           "geom_points", "geom_triangles", "inner_ratio", "is_convex", "spread_subset"]
