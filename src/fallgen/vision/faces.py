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
  its side) from the point: along the ray, the solid comes first. :func:`separating_planes`
  finds such planes, among a few candidate directions, for the hull of an object's points.
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


def separating_planes(verts: np.ndarray, rot: np.ndarray, points: np.ndarray,
                      margin: float) -> np.ndarray:
    """(K, 4) planes (n, d), n a unit vector, with the solid of ``verts`` in n.x <= d and
    every one of ``points`` at n.x >= d + ``margin``, among the world axes, the solid's own
    axes (the columns of ``rot``) and the direction between the two's centres, both ways."""
    dirs = [np.eye(3), rot.T, (points.mean(0) - verts.mean(0))[None, :]]
    cand = np.vstack(dirs)
    cand = cand[np.linalg.norm(cand, axis=1) > 1e-12]
    cand = cand / np.linalg.norm(cand, axis=1)[:, None]
    cand = np.vstack([cand, -cand])
    d = (verts @ cand.T).max(0)
    ok = (points @ cand.T).min(0) >= d + margin
    return np.column_stack([cand[ok], d[ok]])


class FaceSet:
    """The occluders of a scene for one object: triangles (M, 3, 3) with their unit
    ``normals``, boxes ``lo``/``hi``, ``spheres`` (M, 4: a stand-in's bounding sphere, used
    only from outside it; radius -1 for a face the renderer draws itself), ``owner`` (the
    convex solid a face belongs to, or -1) and ``behind`` (whether the object lies behind the
    face's own plane); the convex solids' vertices (``solid_verts`` from ``solid_start[k]``),
    boxes, bounding spheres (as ``spheres``) and separating planes (``planes`` (K, P, 4),
    ``nplanes``)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, exclude_body: int,
                 points: np.ndarray, behind_m: float) -> None:
        tris, spheres, owners, behind = [], [], [], []
        verts, planes, solid_spheres = [], [], []
        for g in range(model.ngeom):
            if model.geom_bodyid[g] == exclude_body or not drawn_opaque(model, g):
                continue
            t = geom_triangles(model, data, g)
            if t is None or not len(t):
                continue
            n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
            length = np.linalg.norm(n, axis=1)
            keep = length > 1e-12  # degenerate triangles cover nothing
            t, n = np.ascontiguousarray(t[keep]), np.ascontiguousarray(n[keep] / length[keep, None])
            if not len(t):
                continue
            b = behind_planes(t, n, points, behind_m)
            v = np.unique(t.reshape(-1, 3), axis=0)
            kind = int(model.geom_type[g])
            solid = -1
            if kind != mujoco.mjtGeom.mjGEOM_MESH or is_convex(t, n, v, 1e-9 * (
                    1.0 + float(np.abs(v).max()))):
                p = separating_planes(v, data.geom_xmat[g].reshape(3, 3), points, behind_m)
            r = float(model.geom_rbound[g]) if _round(model, g) else -1.0
            if kind != mujoco.mjtGeom.mjGEOM_MESH or is_convex(t, n, v, 1e-9 * (
                    1.0 + float(np.abs(v).max()))):
                p = separating_planes(v, data.geom_xmat[g].reshape(3, 3), points, behind_m)
                if len(p):
                    solid = len(verts)
                    verts.append(v)
                    planes.append(p)
                    solid_spheres.append([*data.geom_xpos[g], r])
            if solid < 0 and not b.any():
                continue  # hides nothing of the object
            tris.append(t)
            spheres.append(np.tile([*data.geom_xpos[g], r], (len(t), 1)))
            owners.append(np.full(len(t), solid, np.int64))
            behind.append(b)
        cat = (lambda xs, shape: np.ascontiguousarray(np.concatenate(xs)) if xs
               else np.zeros(shape))
        self.triangles = cat(tris, (0, 3, 3))
        e = np.cross(self.triangles[:, 1] - self.triangles[:, 0],
                     self.triangles[:, 2] - self.triangles[:, 0])
        self.normals = np.ascontiguousarray(e / np.maximum(np.linalg.norm(e, axis=1), 1e-300)[
            :, None])
        self.lo = np.ascontiguousarray(self.triangles.min(1)) if len(tris) else np.zeros((0, 3))
        self.hi = np.ascontiguousarray(self.triangles.max(1)) if len(tris) else np.zeros((0, 3))
        self.spheres = cat(spheres, (0, 4))
        self.owner = np.ascontiguousarray(np.concatenate(owners)) if owners \
            else np.zeros(0, np.int64)
        self.behind = np.ascontiguousarray(np.concatenate(behind)) if behind \
            else np.zeros(0, np.bool_)
        self.solid_verts = cat(verts, (0, 3))
        self.solid_start = np.cumsum([0] + [len(v) for v in verts]).astype(np.int64)
        most = max((len(p) for p in planes), default=1)
        self.planes = np.zeros((len(planes), most, 4))
        self.nplanes = np.array([len(p) for p in planes], np.int64)
        for k, p in enumerate(planes):
            self.planes[k, :len(p)] = p
        self.solid_spheres = np.array(solid_spheres, float).reshape(-1, 4)
        self.solid_lo = np.array([v.min(0) for v in verts]).reshape(-1, 3)
        self.solid_hi = np.array([v.max(0) for v in verts]).reshape(-1, 3)


__all__ = ["DRAWN_GROUPS", "FaceSet", "behind_planes", "drawn_opaque", "geom_points",
           "geom_triangles", "inner_ratio", "is_convex", "separating_planes"]
