"""Whether the scene hides an object from every eye in a horizontal square (a cell of the
navigation grid at the camera's height), proven without rendering: the region form of
:func:`fallgen.vision.sight.hidden_from`.

The proof projects everything from the square's four corners onto one plane Pi beyond the
object, perpendicular to the direction from the square's centre to the object (extended
projections, Durand et al., SIGGRAPH 2000):

- the object: the hull of its points grown by a ball that subtends at least
  :data:`fallgen.vision.sight.MARGIN` radians from every eye (the point proof's margin, which
  it takes in tangent units about the eye's axis: no more than that angle); the union of its
  images from every eye of the square lies in the hull of its points' images from the four
  corners (a central projection maps convex sets to convex sets, for the eyes about a point and
  for the points about an eye);
- an occluder (a front-facing face, or a convex solid with a separating plane or whose every
  face that can face an eye has the object behind its plane, under the point proof's
  conditions, which here must hold at every eye of the square: they are linear in the eye, or
  are tested on the square's box), cut to the slab between the eyes and Pi (a solid:
  its points there and where its points' segments cross the slab's planes), is convex: a point y
  of Pi is hidden behind a convex piece P from every eye of the square when it is from the four
  corners, because the eyes from which the segment to y meets P, {y + s (f - y): f in P,
  s >= 1}, form a convex set;
- what of the object's image no occluder's image from all four corners covers is left
  (:func:`fallgen.vision.cover.subtract`); nothing left: every ray from every eye of the square
  to the object meets an occluder before the object, so no view from the square shows it.

Every step drops what it cannot bound (an occluder reaching behind an eye, an image with too
many vertices): the proof may fail where the object is hidden, never succeed where it shows.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fallgen.vision.cover import (MAX_VERTICES, area2, clip, convex_hull, extents_polygon,
                                  subtract)
from fallgen.vision.sight import BUDGET, DUST, MARGIN, MAX_PIECES, SIDES, gnomonic_frame

#: An occluder's image from one corner keeps at most this many vertices (every other vertex
#: dropped until it fits: a polygon inside the image), so that four of them intersect within
#: :data:`fallgen.vision.cover.MAX_VERTICES`.
_CORNER_VERTICES = 15
#: A convex solid cut to the slab between the eyes and Pi keeps at most this many points.
_CUT_POINTS = 2048


@njit(cache=True)
def _project(pts, n, eye, lvl, c0, w, p, q, d0, ox, oy):
    """Images on Pi (w . x = ``lvl``) of ``pts[:n]`` seen from ``eye``, in Pi's coordinates
    (about ``c0``, basis ``p``, ``q``, scaled by ``d0``); False if one is not in front."""
    ew = eye[0] * w[0] + eye[1] * w[1] + eye[2] * w[2]
    for j in range(n):
        rx, ry, rz = pts[j, 0] - eye[0], pts[j, 1] - eye[1], pts[j, 2] - eye[2]
        z = rx * w[0] + ry * w[1] + rz * w[2]
        if z <= 1e-6:
            return False
        t = (lvl - ew) / z
        yx, yy, yz = eye[0] + t * rx - c0[0], eye[1] + t * ry - c0[1], eye[2] + t * rz - c0[2]
        ox[j] = (yx * p[0] + yy * p[1] + yz * p[2]) / d0
        oy[j] = (yx * q[0] + yy * q[1] + yz * q[2]) / d0
    return True


@njit(cache=True)
def _keep(src, n, w, level, sign, dst):
    """The planar polygon ``src[:n]`` (3D) cut to sign (w . x - level) >= 0, into ``dst``;
    returns its vertex count."""
    m = 0
    for i in range(n):
        j = (i + 1) % n
        si = sign * (src[i, 0] * w[0] + src[i, 1] * w[1] + src[i, 2] * w[2] - level)
        sj = sign * (src[j, 0] * w[0] + src[j, 1] * w[1] + src[j, 2] * w[2] - level)
        if si >= 0.0:
            dst[m] = src[i]
            m += 1
        if (si >= 0.0) != (sj >= 0.0):
            dst[m] = src[i] + (si / (si - sj)) * (src[j] - src[i])
            m += 1
    return m


@njit(cache=True)
def _cut(src, n, w, lo, hi, dst, tmp):
    """The planar polygon ``src[:n]`` (3D) cut to the slab lo <= w . x <= hi, into ``dst``;
    returns its vertex count."""
    return _keep(tmp, _keep(src, n, w, lo, 1.0, tmp), w, hi, -1.0, dst)


@njit(cache=True)
def _slab(vs, w, level, sign):
    """Points whose hull is the hull of ``vs`` cut to sign (w . x - level) >= 0: the points
    on that side and where the segments between the two sides cross; none if that would take
    more than :data:`_CUT_POINTS` (the solid is then left to its faces)."""
    n = vs.shape[0]
    side = np.empty(n)
    kept = 0
    for j in range(n):  # (vs[j] * w).sum(), as Numba sums it, without a temporary array
        dot = 0.0
        for a in range(3):
            dot += vs[j, a] * w[a]
        side[j] = sign * (dot - level)
        kept += side[j] >= 0.0
    total = kept + kept * (n - kept)
    if kept == n:
        return vs
    if kept == 0 or total > _CUT_POINTS:
        return np.empty((0, 3))
    out = np.empty((total, 3))
    k = 0
    for j in range(n):
        if side[j] >= 0.0:
            for a in range(3):
                out[k, a] = vs[j, a]
            k += 1
            for i in range(n):
                if side[i] < 0.0:
                    t = side[j] / (side[j] - side[i])
                    for a in range(3):
                        out[k, a] = vs[j, a] + t * (vs[i, a] - vs[j, a])
                    k += 1
    return out


@njit(cache=True)
def _thin(hx, hy, m, most):
    """Keep every other vertex of the convex polygon until at most ``most`` are left (a
    polygon inside it); returns the count."""
    while m > most:
        half = 0
        for j in range(0, m, 2):
            hx[half], hy[half] = hx[j], hy[j]
            half += 1
        m = half
    return m


@njit(cache=True)
def _common(pts, n, hull, eyes, lvl, c0, w, p, q, d0, box, ox, oy, row):
    """The intersection of the images of ``pts[:n]`` (a convex piece, or a convex solid's
    vertices with ``hull``) from the four ``eyes``, written to ``ox[row]``, ``oy[row]``;
    returns its vertex count (0: empty, outside ``box`` or not bounded)."""
    ix, iy = np.empty(n), np.empty(n)
    hx, hy = np.empty(max(n, 3)), np.empty(max(n, 3))
    ax, ay = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    bx, by = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    m = 0
    for k in range(4):
        if not _project(pts, n, eyes[k], lvl, c0, w, p, q, d0, ix, iy):
            return 0
        if hull:
            c = convex_hull(ix, iy, n, hx, hy)
        else:
            c = n
            hx[:n], hy[:n] = ix, iy
            if area2(hx, hy, c) < 0.0:  # counter-clockwise
                hx[:n], hy[:n] = ix[::-1], iy[::-1]
        c = _thin(hx, hy, c, _CORNER_VERTICES)
        if c < 3:
            return 0
        if k == 0:
            # the intersection lies in this first image: one that misses the box (by more
            # than the clips' rounding) leaves nothing, whatever the other three are
            tol = 1e-9 * (1.0 + max(abs(box[0]), abs(box[1]), abs(box[2]), abs(box[3])))
            if hx[:c].max() < box[0] - tol or hx[:c].min() > box[2] + tol \
                    or hy[:c].max() < box[1] - tol or hy[:c].min() > box[3] + tol:
                return 0
            ax[:c], ay[:c] = hx[:c], hy[:c]
            m = c
            continue
        for e in range(c):  # keep the left of each edge of this image
            f = (e + 1) % c
            a, b = -(hy[f] - hy[e]), hx[f] - hx[e]
            m = clip(ax, ay, m, a, b, -(a * hx[e] + b * hy[e]), bx, by)
            if m < 3:
                return 0
            ax[:m], ay[:m] = bx[:m], by[:m]
    if ax[:m].max() < box[0] or ax[:m].min() > box[2] or ay[:m].max() < box[1] \
            or ay[:m].min() > box[3]:
        return 0
    # drop repeated vertices (a clip through a vertex repeats it): a zero-length edge has no
    # outside, and the subtraction would keep the whole piece beyond it
    k = 0
    for e in range(m):
        px_, py_ = ax[e], ay[e]
        if k > 0 and abs(px_ - ox[row, k - 1]) <= 1e-15 and abs(py_ - oy[row, k - 1]) <= 1e-15:
            continue
        ox[row, k], oy[row, k] = px_, py_
        k += 1
    while k > 1 and abs(ox[row, k - 1] - ox[row, 0]) <= 1e-15 \
            and abs(oy[row, k - 1] - oy[row, 0]) <= 1e-15:
        k -= 1
    return k if k >= 3 else 0


@njit(cache=True)
def _outline(tris, i, j, out):
    """Face ``i``, or with its partner ``j`` >= 0 the quadrilateral of both (``i``'s order,
    ``j``'s far vertex in the shared edge's place), into ``out``; returns the vertex count."""
    if j < 0:
        out[:3] = tris[i]
        return 3
    for e in range(3):
        u, v = tris[i, e], tris[i, (e + 1) % 3]
        far, shared = -1, 0
        for k in range(3):
            x = tris[j, k]
            if np.abs(x - u).max() <= 1e-9 or np.abs(x - v).max() <= 1e-9:
                shared += 1
            else:
                far = k
        if shared == 2 and far >= 0:
            out[0], out[1], out[2], out[3] = v, tris[i, (e + 2) % 3], u, tris[j, far]
            return 4
    out[:3] = tris[i]
    return 3


@njit(cache=True)
def _off_square(c, r, x0, y0, x1, y1, z):
    """Whether the ball (centre ``c``, radius ``r``) misses the square [x0, x1] x [y0, y1] at
    height z (r <= 0: no ball)."""
    if r <= 0.0:
        return True
    dx = max(x0 - c[0], 0.0, c[0] - x1)
    dy = max(y0 - c[1], 0.0, c[1] - y1)
    return dx * dx + dy * dy + (z - c[2]) ** 2 > r * r


@njit(cache=True)
def _every_corner(n):
    """Every (point, cube corner) pair of ``n`` points, point by point."""
    index, corner = np.empty(8 * n, np.int64), np.empty(8 * n, np.int64)
    for j in range(n):
        for s in range(8):
            index[8 * j + s], corner[8 * j + s] = j, s
    return index, corner


@njit(cache=True)
def _extreme_corners(points):
    index, corner = np.empty(8 * len(points), np.int64), np.empty(8 * len(points), np.int64)
    m = 0
    for s in range(8):
        sx = 1.0 if s & 1 else -1.0
        sy = 1.0 if s & 2 else -1.0
        sz = 1.0 if s & 4 else -1.0
        for j in range(len(points)):
            beaten = False
            for i in range(len(points)):
                dx = sx * (points[i, 0] - points[j, 0])
                dy = sy * (points[i, 1] - points[j, 1])
                dz = sz * (points[i, 2] - points[j, 2])
                if dx >= 0.0 and dy >= 0.0 and dz >= 0.0 and (dx > 0.0 or dy > 0.0 or dz > 0.0):
                    beaten = True
                    break
            if not beaten:
                index[m], corner[m] = j, s
                m += 1
    return index[:m].copy(), corner[:m].copy()


def extreme_corners(kernel: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The (point, cube corner) pairs of ``kernel``'s object points, each grown by a cube in
    :func:`hidden_from_cell`, whose grown point can be the farthest along some direction.

    Point p at corner c (signs s) is left out when another point q is at least as far along
    every axis, s_i (q_i - p_i) >= 0: along any direction of signs s, where the cube is
    farthest at its corner c, q + r c is then at least as far as p + r c. The proof takes the
    extents of the grown points' images (the largest value of a linear-fractional function,
    reached where a linear function of some signs s is largest: at a corner s), so the kept
    pairs give the extents of all 8 N. On objects of the paper-size build 23 % of the pairs
    are kept (0.8 ms an object). Made once for the many squares of one proof
    (:mod:`fallgen.nav.hidden`)."""
    return _extreme_corners(np.ascontiguousarray(kernel[15], float))


@njit(cache=True)
def hidden_from_cell(x0, y0, x1, y1, z, kernel, extreme=None):
    """Whether the faces of ``kernel`` (:attr:`fallgen.vision.sight.Occluders.kernel`) hide
    the object from every eye in the square [x0, x1] x [y0, y1] at height ``z``: then no view
    from there shows any of it. False when it cannot be proven. ``extreme``: the kernel's
    :func:`extreme_corners`, for many squares of one kernel (the same verdicts, faster)."""
    (tris, normals, lo, hi, spheres, owner, behind, sverts, sstart, slo, shi, ssph, planes,
     nplanes, corners, points, near, partner, fstart, fend) = kernel
    eyes = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])
    c0 = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1), z])
    w, p, q = gnomonic_frame(c0, corners)
    emax = -np.inf
    for k in range(4):
        emax = max(emax, (eyes[k] * w).sum())
    dmax = 0.0
    for j in range(corners.shape[0]):
        if (corners[j] * w).sum() - emax <= 0.01:
            return False  # the object reaches beside or behind an eye
        for k in range(4):
            dmax = max(dmax, np.sqrt(((corners[j] - eyes[k]) ** 2).sum()))
    # the object grown by a ball subtending MARGIN radians from every eye (a cube holds it)
    r = dmax * math.sin(MARGIN) * 1.01
    n0 = points.shape[0]
    # only the corners that can be extreme, where none can reach behind an eye (each is in
    # front by 0.01 - r sqrt 3 at least: the object's box is 0.01 beyond every eye)
    if extreme is None:
        index, corner = _every_corner(n0)
    elif r * math.sqrt(3.0) < 0.01 - 1e-5:
        index, corner = extreme[0], extreme[1]
    else:
        index, corner = _every_corner(n0)
    grown = np.empty((len(index), 3))
    for m in range(len(index)):
        j, s = index[m], corner[m]
        grown[m, 0] = points[j, 0] + (r if s & 1 else -r)
        grown[m, 1] = points[j, 1] + (r if s & 2 else -r)
        grown[m, 2] = points[j, 2] + (r if s & 4 else -r)
    lvl = -np.inf
    for j in range(grown.shape[0]):
        lvl = max(lvl, (grown[j] * w).sum())
    lvl += 0.01  # Pi lies beyond the object
    d0 = lvl - (c0 * w).sum()
    front = emax + 1e-3  # every occluder point kept lies in front of every eye
    # the object's image: within the 32-sided polygon of its points' images' extents
    ng = grown.shape[0]
    ix, iy = np.empty(4 * ng), np.empty(4 * ng)
    for k in range(4):
        if not _project(grown, ng, eyes[k], lvl, c0, w, p, q, d0, ix[k * ng:], iy[k * ng:]):
            return False
    hx, hy = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    hn = extents_polygon(ix, iy, 4 * ng, SIDES, 1e-9, hx, hy)
    box = np.array([hx[:hn].min(), hy[:hn].min(), hx[:hn].max(), hy[:hn].max()])
    # the box holding the square and the object: occluders outside it cannot matter
    blo, bhi = np.empty(3), np.empty(3)
    for a in range(3):
        blo[a] = min(eyes[:, a].min(), corners[:, a].min())
        bhi[a] = max(eyes[:, a].max(), corners[:, a].max())
    nsol = len(nplanes)
    ox = np.empty((nsol + len(tris), MAX_VERTICES))
    oy = np.empty((nsol + len(tris), MAX_VERTICES))
    sizes = np.zeros(nsol + len(tris), np.int64)
    used = np.zeros(nsol, np.bool_)
    cnt = 0
    # convex solids: the eyes outside the box grown by the near distance and outside a
    # stand-in's sphere, one separating plane with every eye on the solid's side, every vertex
    # between the eyes and Pi
    for s in range(nsol):
        d2 = 0.0
        for a in range(3):
            gap = max(slo[s, a] - eyes[:, a].max(), eyes[:, a].min() - shi[s, a], 0.0)
            d2 += gap * gap
        if d2 < near * near or not _off_square(ssph[s], ssph[s, 3], x0, y0, x1, y1, z):
            continue
        ok = False
        for j in range(nplanes[s]):
            side = True
            for k in range(4):
                if planes[s, j, 0] * eyes[k, 0] + planes[s, j, 1] * eyes[k, 1] \
                        + planes[s, j, 2] * eyes[k, 2] >= planes[s, j, 3]:
                    side = False
                    break
            if side:
                ok = True
                break
        if not ok:
            # or every face that can face an eye of the square (at some corner: it is linear
            # in the eye) has the object behind its plane: a ray that meets the solid enters
            # through such a face, and crosses its plane before the object
            ok = fend[s] > fstart[s]
            for i in range(fstart[s], fend[s]):
                facing = False
                for k in range(4):
                    if normals[i, 0] * (eyes[k, 0] - tris[i, 0, 0]) + normals[i, 1] \
                            * (eyes[k, 1] - tris[i, 0, 1]) + normals[i, 2] \
                            * (eyes[k, 2] - tris[i, 0, 2]) >= -1e-9:
                        facing = True
                        break
                if facing and not behind[i]:
                    ok = False
                    break
        if not ok:
            continue
        vs = _slab(_slab(sverts[sstart[s]:sstart[s + 1]], w, lvl, -1.0), w, front, 1.0)
        if vs.shape[0] < 3:
            continue  # its faces may still count, one by one
        m = _common(vs, vs.shape[0], True, eyes, lvl, c0, w, p, q, d0, box, ox, oy, cnt)
        if m >= 3:
            sizes[cnt] = m
            used[s] = True
            cnt += 1
    # faces: the object behind, every eye in front beyond the near distance and outside a
    # stand-in's sphere; cut to the slab between the eyes and Pi
    # a face and its coplanar partner count as one convex quadrilateral: apart, the seam
    # between their images moves with the eye and leaves a sliver that neither covers
    poly, piece, tmp = np.empty((4, 3)), np.empty((8, 3)), np.empty((8, 3))
    for i in range(tris.shape[0]):
        j = partner[i]
        if j >= 0 and (partner[j] != i or behind[j] != behind[i]):
            j = -1
        if j >= 0 and j < i:
            continue  # counted with its partner
        # the box of the face (and its partner), axis by axis without an array
        out = False
        for a in range(3):
            fl, fh = lo[i, a], hi[i, a]
            if j >= 0:
                fl, fh = min(fl, lo[j, a]), max(fh, hi[j, a])
            if fl > bhi[a] or fh < blo[a]:
                out = True
                break
        if out:
            continue
        if not behind[i] or (owner[i] >= 0 and used[owner[i]]):
            continue
        if not _off_square(spheres[i], spheres[i, 3], x0, y0, x1, y1, z):
            continue
        v0 = tris[i, 0]
        facing = True
        for k in range(4):
            if normals[i, 0] * (eyes[k, 0] - v0[0]) + normals[i, 1] * (eyes[k, 1] - v0[1]) \
                    + normals[i, 2] * (eyes[k, 2] - v0[2]) < near:
                facing = False
                break
        if not facing:
            continue
        nv = _outline(tris, i, j, poly)
        m = _cut(poly, nv, w, front, lvl, piece, tmp)
        if m < 3:
            continue
        m = _common(piece, m, False, eyes, lvl, c0, w, p, q, d0, box, ox, oy, cnt)
        if m >= 3:
            sizes[cnt] = m
            cnt += 1
    areas = np.empty(cnt)
    for i in range(cnt):
        areas[i] = -abs(area2(ox[i], oy[i], sizes[i]))
    order = np.argsort(areas)
    ox, oy, sizes = ox[order], oy[order], sizes[order]
    return subtract(hx, hy, hn, ox, oy, sizes, cnt, DUST, MAX_PIECES, BUDGET)[3] == 0


__all__ = ["extreme_corners", "hidden_from_cell"]
