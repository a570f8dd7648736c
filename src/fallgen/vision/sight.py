"""What of an object the scene can let an eye point see, bounded from the faces the renderer
draws, so that most views need not be rendered to know they show too little.

The expert's search asks the renderer whether a pose shows the object (at least a few pixels of
it: ``EgoCamera.shows``); an eye point within reach of the object is asked about up to a dozen
views (headings and tilts). From most such eyes little or nothing of the object shows: it lies
behind a cabinet, inside a pan or a box. :meth:`Occluders.look` bounds, without rendering, the
directions in which the object can show from an eye, and :meth:`Sight.max_pixels` the pixels a
view can then show; the bounds never fall short:

- the occluders are the faces the renderer draws opaque (:class:`fallgen.vision.faces.FaceSet`:
  boxes, meshes, stand-ins for round geoms; the object's own geoms excluded), used only from
  eyes outside a stand-in's geom;
- a convex solid hides the object from an eye when a plane separates them with the eye on the
  solid's side (every vertex of the hull of the object's drawn geometry at least ``BEHIND_M``
  beyond it) and the eye lies outside the solid's box grown by twice the renderer's near
  clipping distance: its image is then the hull of its vertices' images;
- any other face counts only from its front (the renderer culls back faces: ``tests/vision``
  checks it), with the eye farther from its plane than twice the near clipping distance, and
  hides what lies behind its plane (the object ``BEHIND_M`` or more behind it): along every
  ray through it, it comes first, far beyond the depth buffer's resolution;
- seen from the eye (a gnomonic projection about the direction to the object), the image of
  the hull of the object's boxes, grown by ``MARGIN`` (0.03 pixels or more of any view), minus
  the faces' images, is what can show (:func:`fallgen.vision.cover.subtract`, exact convex
  pieces); nothing left: the object is hidden from every view there;
- a view's pixels that can show the object are its pixel centres within ``SLACK_PX`` of those
  pieces (far beyond the rasteriser's sub-pixel precision): fewer than the judge's count, and
  the view cannot show the object.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numba import njit

from fallgen.vision.cover import (MAX_VERTICES, area2, convex_hull, extents, extents_polygon,
                                  subtract)
from fallgen.vision.faces import DRAWN_GROUPS, FaceSet, SceneFaces

#: How far (m) the object must lie behind an occluding face's plane: far beyond the depth
#: buffer's resolution (24 bits from a near plane of ~5 cm: ~0.03 mm at 5 m).
BEHIND_M = 0.002
#: The object's image grown by this much (tangent units about its direction) before the faces
#: are taken away: 0.03 pixels of a 90 degree, 300 pixel view at its centre, more elsewhere.
#: With :data:`SLACK_PX`, 0.08 pixels or more: 20 times the rasteriser's sub-pixel step (Mesa's
#: llvmpipe and GPUs place vertices on 1/256 of a pixel), and over 100 times the float32
#: rounding of the renderer's projection in a room. Measured: over 43 500 views (210 rehearsed
#: events, random eyes within 2.2 m, 5 tilts) none showed more pixels than the bound counts,
#: and none from an eye proven hidden showed any; ``tests/vision/test_sight.py`` checks both.
#: (With 0.15 and 0.2 pixels, thin slivers along the occluders' edges were left that counted
#: the 4 pixels of a visible view, and the renderer was asked about 2.8 times as many views.)
MARGIN = 2e-4
#: A view's pixel centres this close (pixels) to what can show are counted.
SLACK_PX = 0.05
#: Pieces the subtraction may keep before it gives up (then every view is rendered).
MAX_PIECES = 8192
#: Steps (a piece looked at, a clip) the subtraction may take for one eye before it stops
#: and keeps what is left (a looser bound: more views rendered).
BUDGET = 20_000
#: Area (tangent units squared) below which a leftover piece is rounding, not a gap: a pixel
#: is about 4e-5.
DUST = 1e-14
#: The object's image is bounded by its extents along this many directions (each both ways).
SIDES = 16
#: A piece's edge shorter than this (pixels) bounds nothing when its pixels are counted: the
#: subtraction leaves vertices that coincide up to rounding, and the line through two such
#: points points anywhere (it would cut away half of the piece). Leaving a side out only
#: widens the piece.
DEGENERATE_EDGE_PX = 1e-6


@njit(cache=True, inline="always")
def _box_beside(lo, hi, s, eye, w, p, q, box):
    """Whether every point of the box ``lo[s]``..``hi[s]`` in front of ``eye`` has its
    gnomonic image (about ``w``, basis ``p``, ``q``) beyond one side of ``box`` (x0, y0, x1,
    y1), by far more than rounding: x < x0 is (P - eye) . (p - x0 w) < 0 for a point P in
    front, a linear function, largest at a corner. (Inlined, and given the boxes' arrays and
    a row, not the row: a call or a view counts references to its arrays, atomically.)"""
    for side in range(4):
        a = box[side]
        sign = 1.0 if side < 2 else -1.0
        nx = sign * ((p[0] if side % 2 == 0 else q[0]) - a * w[0])
        ny = sign * ((p[1] if side % 2 == 0 else q[1]) - a * w[1])
        nz = sign * ((p[2] if side % 2 == 0 else q[2]) - a * w[2])
        top = -np.inf
        for c in range(8):
            x = (hi[s, 0] if c & 1 else lo[s, 0]) - eye[0]
            y = (hi[s, 1] if c & 2 else lo[s, 1]) - eye[1]
            z = (hi[s, 2] if c & 4 else lo[s, 2]) - eye[2]
            top = max(top, x * nx + y * ny + z * nz)
        if top < -1e-9:
            return True
    return False


@njit(cache=True)
def _project_solids(sverts, sstart, slo, shi, ssph, planes, nplanes, eye, w, p, q, box, near,
                    ox, oy, sizes, used):
    """The images of the convex solids that hide the object from ``eye`` (a separating plane
    with the eye on the solid's side, the eye outside the solid's box grown by ``near`` and
    outside a stand-in's bounding sphere): the hull of their vertices' images (every other
    vertex dropped until it fits: a polygon inside the image), where it meets ``box``;
    written from index 0, ``used[k]`` set; returns how many."""
    k = 0
    for s in range(len(nplanes)):
        d2 = 0.0
        for a in range(3):
            gap = max(slo[s, a] - eye[a], 0.0, eye[a] - shi[s, a])
            d2 += gap * gap
        if d2 < near * near:
            continue
        r = ssph[s, 3]
        if r > 0.0 and (eye[0] - ssph[s, 0]) ** 2 + (eye[1] - ssph[s, 1]) ** 2 \
                + (eye[2] - ssph[s, 2]) ** 2 <= r * r:
            continue
        ok = False
        for j in range(nplanes[s]):
            if planes[s, j, 0] * eye[0] + planes[s, j, 1] * eye[1] + planes[s, j, 2] * eye[2] \
                    < planes[s, j, 3]:
                ok = True
                break
        if not ok:
            continue
        if _box_beside(slo, shi, s, eye, w, p, q, box):
            continue  # its image misses the object's: the test below would drop it too
        n = sstart[s + 1] - sstart[s]
        ix, iy = np.empty(n), np.empty(n)
        for j in range(n):
            v = sstart[s] + j
            rx, ry, rz = sverts[v, 0] - eye[0], sverts[v, 1] - eye[1], sverts[v, 2] - eye[2]
            z = rx * w[0] + ry * w[1] + rz * w[2]
            if z <= 1e-3:
                ok = False
                break
            ix[j] = (rx * p[0] + ry * p[1] + rz * p[2]) / z
            iy[j] = (rx * q[0] + ry * q[1] + rz * q[2]) / z
        if not ok:
            continue
        if ix.max() < box[0] or ix.min() > box[2] or iy.max() < box[1] or iy.min() > box[3]:
            continue
        hx, hy = np.empty(n), np.empty(n)
        m = convex_hull(ix, iy, n, hx, hy)
        while m > MAX_VERTICES - 2:  # keep every other vertex: a polygon inside the hull
            half = 0
            for j in range(0, m, 2):
                hx[half], hy[half] = hx[j], hy[j]
                half += 1
            m = half
        if m < 3:
            continue
        ox[k, :m], oy[k, :m], sizes[k] = hx[:m], hy[:m], m
        used[s] = True
        k += 1
    return k


@njit(cache=True)
def _project_faces(tris, normals, lo, hi, solids, owner, behind, used, eye, corners, w, p, q,
                   box, near, ox, oy, sizes, k):
    """The gnomonic images (about ``w``, basis ``p``, ``q``) of the faces with the object
    behind them, not of a solid already ``used``, that face ``eye`` and whose images meet
    ``box`` (x0, y0, x1, y1), clipped to z >= 1e-3, written to ``ox``, ``oy`` (vertex counts
    in ``sizes``) from index ``k``; returns the new count."""
    xs, ys = np.empty(4), np.empty(4)
    zs, us, vs = np.empty(3), np.empty(3), np.empty(3)
    # the faces that can matter meet the box holding the eye and the object
    blo, bhi = np.empty(3), np.empty(3)
    for a in range(3):
        blo[a] = min(eye[a], corners[:, a].min())
        bhi[a] = max(eye[a], corners[:, a].max())
    for i in range(tris.shape[0]):
        if lo[i, 0] > bhi[0] or hi[i, 0] < blo[0] or lo[i, 1] > bhi[1] or hi[i, 1] < blo[1] \
                or lo[i, 2] > bhi[2] or hi[i, 2] < blo[2]:
            continue
        if not behind[i] or (owner[i] >= 0 and used[owner[i]]):
            continue
        r = solids[i, 3]
        if r > 0.0 and (eye[0] - solids[i, 0]) ** 2 + (eye[1] - solids[i, 1]) ** 2 \
                + (eye[2] - solids[i, 2]) ** 2 <= r * r:
            continue  # a stand-in seen from inside its geom
        n0, n1, n2 = normals[i, 0], normals[i, 1], normals[i, 2]
        # front: the eye in front of the plane, beyond twice the near clipping distance
        if n0 * (eye[0] - tris[i, 0, 0]) + n1 * (eye[1] - tris[i, 0, 1]) \
                + n2 * (eye[2] - tris[i, 0, 2]) < near:
            continue
        for a in range(3):
            rx, ry, rz = tris[i, a, 0] - eye[0], tris[i, a, 1] - eye[1], tris[i, a, 2] - eye[2]
            zs[a] = rx * w[0] + ry * w[1] + rz * w[2]
            us[a] = rx * p[0] + ry * p[1] + rz * p[2]
            vs[a] = rx * q[0] + ry * q[1] + rz * q[2]
        m = 0
        zmin = 1e-3
        for a in range(3):
            b = (a + 1) % 3
            ina, inb = zs[a] >= zmin, zs[b] >= zmin
            if ina:
                xs[m], ys[m] = us[a] / zs[a], vs[a] / zs[a]
                m += 1
            if ina != inb:
                t = (zmin - zs[a]) / (zs[b] - zs[a])
                xs[m] = (us[a] + t * (us[b] - us[a])) / zmin
                ys[m] = (vs[a] + t * (vs[b] - vs[a])) / zmin
                m += 1
        if m < 3:
            continue
        lx, ly, hx, hy = extents(xs, ys, (), m)
        if hx < box[0] or lx > box[2] or hy < box[1] or ly > box[3]:
            continue
        for a in range(m):
            ox[k, a], oy[k, a] = xs[a], ys[a]
        sizes[k] = m
        k += 1
    return k


def kernel_within(kernel: tuple, centre_xy, radius_m: float, eye_z: float) -> tuple:
    """:attr:`Occluders.kernel` for eyes at height ``eye_z`` within ``radius_m`` (horizontally)
    of ``centre_xy`` only, for :func:`hidden_from`: without the faces that lie outside the box
    spanned by every such eye and the object's corners (the faces :func:`hidden_from` skips
    from each of those eyes: its verdicts there are the same, a room's far faces not looked
    at), and without the faces' coplanar pairs and the solids' face ranges (which only the
    region proofs read: they take the whole kernel)."""
    (tris, normals, lo, hi, spheres, owner, behind, *rest) = kernel
    corners = kernel[14]
    c = np.array([float(centre_xy[0]), float(centre_xy[1]), eye_z])
    r = np.array([radius_m, radius_m, 0.0])
    blo = np.minimum(c - r, corners.min(axis=0))
    bhi = np.maximum(c + r, corners.max(axis=0))
    keep = ~((lo > bhi).any(axis=1) | (hi < blo).any(axis=1))
    faces = tuple(np.ascontiguousarray(a[keep]) for a in (tris, normals, lo, hi, spheres, owner,
                                                          behind))
    return (*faces, *rest[:10], *(np.zeros(0, a.dtype) for a in rest[10:]))


class Occluders:
    """The opaque faces of a static scene that can hide an object, for :meth:`look`:
    ``parts`` (:class:`fallgen.vision.faces.SceneFaces`, every drawn geom but the object's);
    ``points`` (N, 3): points whose hull holds the object as drawn (e.g. the vertices of its
    meshes' hull); ``near_m``: twice the renderer's near clipping distance (see
    :func:`near_distance`)."""

    def __init__(self, parts: list[SceneFaces], points: np.ndarray, near_m: float,
                 behind_m: float = BEHIND_M) -> None:
        """``behind_m``: how far beyond a face's or a separating plane the object must lie
        (:data:`BEHIND_M`; tests pass a wrong value to see the proof fail)."""
        self.behind_m, self.near_m = behind_m, near_m
        self.points = np.ascontiguousarray(points, float)
        lo, hi = self.points.min(0), self.points.max(0)
        #: the corners of the points' box: where the object lies
        self.corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                                 for z in (lo[2], hi[2])])
        self.faces = FaceSet(parts, self.points, behind_m)

    def look(self, eye: np.ndarray) -> Sight:
        """What of the object can show from ``eye`` (3,)."""
        eye = np.asarray(eye, float)
        f = self.faces
        frame = gnomonic_frame(eye, self.corners)
        xs, ys, ns, count = _leftover(
            f.triangles, f.normals, f.lo, f.hi, f.spheres, f.owner, f.behind, f.solid_verts,
            f.solid_start, f.solid_lo, f.solid_hi, f.solid_spheres, f.planes, f.nplanes, eye,
            self.corners, self.points, self.near_m, *frame)
        if count < 0:
            return Sight(eye, frame, None)
        return Sight(eye, frame, (xs[:count].copy(), ys[:count].copy(), ns[:count].copy()))

    @property
    def kernel(self) -> tuple:
        """The arrays :func:`hidden_from` takes (the faces, the object's corners and points,
        the near distance, each face's coplanar partner, each solid's faces), for compiled
        callers."""
        f = self.faces
        return (f.triangles, f.normals, f.lo, f.hi, f.spheres, f.owner, f.behind, f.solid_verts,
                f.solid_start, f.solid_lo, f.solid_hi, f.solid_spheres, f.planes, f.nplanes,
                self.corners, self.points, float(self.near_m), f.partner, f.face_start,
                f.face_end)

    def hide(self, eye: np.ndarray) -> bool:
        """Whether the faces hide every point of the hull of the corners from ``eye`` (3,):
        then no view from there shows any of it. False when it cannot be proven."""
        return self.look(eye).hidden


class Sight:
    """What of an object can show from one eye point (:meth:`Occluders.look`): convex pieces
    of directions (gnomonic coordinates about ``frame``'s axis), or None where no bound was
    found (the object reaches behind the eye, too many pieces)."""

    def __init__(self, eye: np.ndarray, frame: tuple[np.ndarray, np.ndarray, np.ndarray],
                 pieces: tuple[np.ndarray, np.ndarray, np.ndarray] | None) -> None:
        self.eye, self.frame, self.pieces = eye, frame, pieces

    @property
    def hidden(self) -> bool:
        """Nothing can show: no view from here shows a pixel of the object."""
        return self.pieces is not None and len(self.pieces[2]) == 0

    def max_pixels(self, yaw_rad: float, tilt_rad: float, size: int, fov_deg: float,
                   enough: int) -> int:
        """An upper bound on the pixels of the view (a free camera at the eye, its right
        vector horizontal; ``size`` square pixels over ``fov_deg``) that can show the object,
        counted up to ``enough``."""
        if self.pieces is None:
            return enough
        xs, ys, ns = self.pieces
        if len(ns) == 0:
            return 0
        return int(_count_pixels(xs, ys, ns, *self.frame, yaw_rad, tilt_rad, size,
                                 size / 2 / math.tan(math.radians(fov_deg) / 2), SLACK_PX,
                                 enough))

    def may_show(self, yaw_rad: float, tilts_rad: np.ndarray, size: int, fov_deg: float,
                 enough: int) -> np.ndarray:
        """For each tilt, whether the view can show ``enough`` pixels of the object
        (:meth:`max_pixels` >= ``enough``)."""
        tilts_rad = np.asarray(tilts_rad, float)
        if self.pieces is None:
            return np.ones(len(tilts_rad), bool)
        xs, ys, ns = self.pieces
        if len(ns) == 0:
            return np.zeros(len(tilts_rad), bool)
        scale = size / 2 / math.tan(math.radians(fov_deg) / 2)
        return _enough_pixels(xs, ys, ns, *self.frame, yaw_rad, tilts_rad, size, scale,
                              SLACK_PX, enough)


def near_distance(model: mujoco.MjModel) -> float:
    """Twice the renderer's near clipping distance for ``model`` (a fraction of its extent):
    nearer than that to the eye, a face may be clipped away."""
    return 2 * float(model.vis.map.znear) * float(model.stat.extent)


@njit(cache=True)
def gnomonic_frame(eye, corners):
    """The gnomonic frame about the direction from ``eye`` to the corners' mean: (w, p, q)."""
    w = np.empty(3)
    for a in range(3):
        w[a] = corners[:, a].mean() - eye[a]
    w /= np.sqrt((w * w).sum())
    up = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    p = np.cross(up, w)
    p /= np.sqrt((p * p).sum())
    q = np.cross(w, p)
    return w, p, q


@njit(cache=True)
def _leftover(tris, normals, lo, hi, spheres, owner, behind, sverts, sstart, slo, shi, ssph,
              planes, nplanes, eye, corners, points, near, w, p, q):
    """The pieces of the object's grown image that no face hides (see :func:`subtract`)."""
    for j in range(corners.shape[0]):
        if (corners[j, 0] - eye[0]) * w[0] + (corners[j, 1] - eye[1]) * w[1] \
                + (corners[j, 2] - eye[2]) * w[2] <= 0.01:
            e = np.empty((1, 1))
            return e, e, np.zeros(1, np.int64), -1
    # the object's image: within the 32-sided polygon of its points' images' extents along
    # 16 directions, every side pushed out by the margin
    n = points.shape[0]
    ix, iy = np.empty(n), np.empty(n)
    for j in range(n):
        rx, ry, rz = points[j, 0] - eye[0], points[j, 1] - eye[1], points[j, 2] - eye[2]
        z = rx * w[0] + ry * w[1] + rz * w[2]
        ix[j] = (rx * p[0] + ry * p[1] + rz * p[2]) / z
        iy[j] = (rx * q[0] + ry * q[1] + rz * q[2]) / z
    hx, hy = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    hn = extents_polygon(ix, iy, n, SIDES, MARGIN, hx, hy)
    box = np.array([hx[:hn].min(), hy[:hn].min(), hx[:hn].max(), hy[:hn].max()])
    nsol = len(nplanes)
    ox = np.empty((nsol + len(tris), MAX_VERTICES))
    oy = np.empty((nsol + len(tris), MAX_VERTICES))
    sizes = np.zeros(nsol + len(tris), np.int64)
    used = np.zeros(nsol, np.bool_)
    k = _project_solids(sverts, sstart, slo, shi, ssph, planes, nplanes, eye, w, p, q, box,
                        near, ox, oy, sizes, used)
    k = _project_faces(tris, normals, lo, hi, spheres, owner, behind, used, eye, corners, w, p,
                       q, box, near, ox, oy, sizes, k)
    # the largest images first: fewer pieces to carry through the rest
    areas = np.empty(k)
    for i in range(k):
        areas[i] = -abs(area2(ox[i], oy[i], sizes[i]))
    order = np.argsort(areas)
    ox, oy, sizes = ox[order], oy[order], sizes[order]
    return subtract(hx, hy, hn, ox, oy, sizes, k, DUST, MAX_PIECES, BUDGET)


@njit(cache=True)
def hidden_from(x, y, z, kernel):
    """Whether the faces of ``kernel`` (:attr:`Occluders.kernel`) hide the object from the
    eye at (x, y, z): no view from there shows any of it (compiled form of
    :meth:`Occluders.hide`)."""
    (tris, normals, lo, hi, spheres, owner, behind, sverts, sstart, slo, shi, ssph, planes,
     nplanes, corners, points, near, _, _, _) = kernel
    eye = np.array([x, y, z])
    w, p, q = gnomonic_frame(eye, corners)
    return _leftover(tris, normals, lo, hi, spheres, owner, behind, sverts, sstart, slo, shi,
                     ssph, planes, nplanes, eye, corners, points, near, w, p, q)[3] == 0


@njit(cache=True)
def _enough_pixels(xs, ys, ns, w, p, q, yaw, tilts, size, scale, slack, enough):
    """For each of ``tilts``, whether :func:`_count_pixels` reaches ``enough``."""
    out = np.empty(len(tilts), np.bool_)
    for k in range(len(tilts)):
        out[k] = _count_pixels(xs, ys, ns, w, p, q, yaw, tilts[k], size, scale, slack,
                               enough) >= enough
    return out


@njit(cache=True)
def _count_pixels(xs, ys, ns, w, p, q, yaw, tilt, size, scale, slack, enough):
    """Pixel centres of the view within ``slack`` pixels of the pieces, up to ``enough``."""
    ct, st, cy, sy = math.cos(tilt), math.sin(tilt), math.cos(yaw), math.sin(yaw)
    f = np.array([ct * cy, ct * sy, st])
    r = np.array([sy, -cy, 0.0])
    u = np.array([r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2],
                  r[0] * f[1] - r[1] * f[0]])
    half = size / 2
    total = 0
    cx, cy_ = np.empty(xs.shape[1]), np.empty(xs.shape[1])
    for i in range(len(ns)):
        m = ns[i]
        for v in range(m):
            d = w + xs[i, v] * p + ys[i, v] * q
            z = (d * f).sum()
            if z <= 1e-9:
                return enough  # the piece reaches behind the view: no bound
            cx[v] = half + scale * (d * r).sum() / z
            cy_[v] = half - scale * (d * u).sum() / z
        area = 0.0
        for v in range(m):
            j = (v + 1) % m
            area += cx[v] * cy_[j] - cx[j] * cy_[v]
        orient = 1.0 if area >= 0.0 else -1.0
        c0 = max(int(math.floor(cx[:m].min() - slack - 0.5)), 0)
        c1 = min(int(math.ceil(cx[:m].max() + slack - 0.5)), size - 1)
        r0 = max(int(math.floor(cy_[:m].min() - slack - 0.5)), 0)
        r1 = min(int(math.ceil(cy_[:m].max() + slack - 0.5)), size - 1)
        for row in range(r0, r1 + 1):
            py_ = row + 0.5
            for col in range(c0, c1 + 1):
                px_ = col + 0.5
                inside = True
                for v in range(m):
                    j = (v + 1) % m
                    ex, ey = cx[j] - cx[v], cy_[j] - cy_[v]
                    length = math.sqrt(ex * ex + ey * ey)
                    if length < DEGENERATE_EDGE_PX:  # its direction is rounding: no bound
                        continue
                    if orient * (ex * (py_ - cy_[v]) - ey * (px_ - cx[v])) / length < -slack:
                        inside = False
                        break
                if inside:
                    total += 1
                    if total >= enough:
                        return total
    return total


__all__ = ["DRAWN_GROUPS", "Occluders", "Sight", "BEHIND_M", "hidden_from", "kernel_within",
           "near_distance", "MARGIN", "SIDES", "SLACK_PX", "gnomonic_frame"]
