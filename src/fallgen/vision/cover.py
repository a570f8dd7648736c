"""A convex polygon minus a union of convex polygons, in the plane (compiled).

:func:`subtract` subtracts the covering polygons one at a time from what is left of the
polygon, kept as convex pieces: a piece minus a convex polygon is the piece clipped to the
outside of each edge in turn (at most one new piece an edge), so the pieces stay convex and
disjoint. Pieces of area below ``dust`` (the rounding of shared edges) are dropped. Where it
would need more pieces or clips than allowed, it stops and returns what is left then, which
still holds the whole difference. :func:`covered`: no piece is left.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Vertices a piece may have (a convex polygon clipped by half-planes gains at most one each).
MAX_VERTICES = 64


@njit(cache=True)
def area2(xs, ys, n):
    """Twice the signed area of the polygon's first ``n`` vertices."""
    s = 0.0
    for i in range(n):
        j = (i + 1) % n
        s += xs[i] * ys[j] - xs[j] * ys[i]
    return s


@njit(cache=True)
def clip(xs, ys, n, a, b, c, ox, oy):
    """The polygon (first ``n`` vertices) clipped to a x + b y + c >= 0, into ``ox``, ``oy``;
    returns its vertex count."""
    m = 0
    for i in range(n):
        j = (i + 1) % n
        si = a * xs[i] + b * ys[i] + c
        sj = a * xs[j] + b * ys[j] + c
        if si >= 0.0:
            ox[m], oy[m] = xs[i], ys[i]
            m += 1
        if (si >= 0.0) != (sj >= 0.0):
            t = si / (si - sj)
            ox[m] = xs[i] + t * (xs[j] - xs[i])
            oy[m] = ys[i] + t * (ys[j] - ys[i])
            m += 1
        if m >= MAX_VERTICES - 1:
            return -1
    return m


@njit(cache=True)
def extents(xs, ys, at, n):
    """(lowest x, lowest y, highest x, highest y) of the points ``xs[at + (i,)]``,
    ``ys[at + (i,)]``, i < ``n`` (``at``: the leading indices of a row of a larger array, ``()``
    for a 1-D one); NaN if one is, as ``min()`` and ``max()``. A loop over the row, not a
    slice of it: a slice counts a reference to its array in and out, an atomic operation
    each, and in the subtraction's and the projections' loops those were most of the time."""
    lx = hx = xs[at + (0,)]
    ly = hy = ys[at + (0,)]
    for i in range(1, n):
        u, v = xs[at + (i,)], ys[at + (i,)]
        if u < lx or u != u:
            lx = u
        if u > hx or u != u:
            hx = u
        if v < ly or v != v:
            ly = v
        if v > hy or v != v:
            hy = v
    return lx, ly, hx, hy


@njit(cache=True)
def extents_polygon(xs, ys, n, sides, margin, hx, hy):
    """The polygon of the ``n`` points' extents along ``sides`` directions, each both ways,
    every side pushed out by ``margin`` (it holds their hull), into ``hx``, ``hy`` (at least
    :data:`MAX_VERTICES`); returns its vertex count.

    The extents are taken point by point, all directions at once: independent maxima, where
    one direction at a time is a chain of dependent ones (1.7x faster for 560 points). Each
    direction still takes the largest of the same products, so the polygon is the same."""
    if 4 + 2 * sides > MAX_VERTICES - 1:
        raise ValueError("too many sides for MAX_VERTICES")
    tx, ty = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    m = 2 * sides
    cs, sn, reach = np.empty(m), np.empty(m), np.full(m, -np.inf)
    for k in range(m):
        ang = np.pi * k / sides
        cs[k], sn[k] = np.cos(ang), np.sin(ang)
    for j in range(n):
        x, y = xs[j], ys[j]
        for k in range(m):
            reach[k] = max(reach[k], cs[k] * x + sn[k] * y)
    big = 1e3
    hx[0], hx[1], hx[2], hx[3] = -big, big, big, -big
    hy[0], hy[1], hy[2], hy[3] = -big, -big, big, big
    hn = 4
    for k in range(m):
        # keep c x + s y <= reach (copied back by a loop: slices of the arrays, counted as
        # references atomically, took ~5 % of an occlusion proof)
        hn = clip(hx, hy, hn, -cs[k], -sn[k], reach[k] + margin, tx, ty)
        for i in range(hn):
            hx[i], hy[i] = tx[i], ty[i]
    return hn


@njit(cache=True)
def convex_hull(px, py, n, ox, oy):
    """The convex hull (counter-clockwise, Andrew's monotone chain) of ``n`` points into
    ``ox``, ``oy``; returns its vertex count."""
    order = np.argsort(px[:n] + 1e-12 * py[:n])
    xs, ys = px[:n][order], py[:n][order]
    # sort by x, then y (argsort on x alone leaves ties in input order: fix them up)
    for i in range(1, n):
        j = i
        while j > 0 and xs[j - 1] == xs[j] and ys[j - 1] > ys[j]:
            xs[j - 1], xs[j] = xs[j], xs[j - 1]
            ys[j - 1], ys[j] = ys[j], ys[j - 1]
            j -= 1
    hx, hy = np.empty(2 * n + 1), np.empty(2 * n + 1)
    k = 0
    for i in range(n):
        while k >= 2 and (hx[k - 1] - hx[k - 2]) * (ys[i] - hy[k - 2]) \
                - (hy[k - 1] - hy[k - 2]) * (xs[i] - hx[k - 2]) <= 0.0:
            k -= 1
        hx[k], hy[k] = xs[i], ys[i]
        k += 1
    lower = k + 1
    for i in range(n - 2, -1, -1):
        while k >= lower and (hx[k - 1] - hx[k - 2]) * (ys[i] - hy[k - 2]) \
                - (hy[k - 1] - hy[k - 2]) * (xs[i] - hx[k - 2]) <= 0.0:
            k -= 1
        hx[k], hy[k] = xs[i], ys[i]
        k += 1
    k -= 1  # the last point is the first
    for i in range(k):
        ox[i], oy[i] = hx[i], hy[i]
    return k


@njit(cache=True)
def subtract(gx, gy, gn, cx, cy, cn, count, dust, max_pieces, budget=200_000):
    """The convex polygon (``gx``, ``gy``, its first ``gn`` vertices) minus the union of the
    ``count`` convex polygons ``cx[i, :cn[i]]``, ``cy[i, :cn[i]]`` (either orientation), as
    convex pieces: (xs, ys, vertex counts, number of pieces). Where more than ``max_pieces``
    pieces or ``budget`` steps (a piece looked at, a clip) would be needed, the pieces left are
    returned as they are then
    (still holding all of the difference, with some of it not yet taken away); -1 pieces only
    for a polygon of too many vertices.

    Room for the pieces is made for 64 and, where a subtraction needs more, it is made again
    with twice the room (up to ``max_pieces``): the room changes nothing but whether the
    pieces fit, so the pieces are those of one pass with all the room it needs."""
    if gn > MAX_VERTICES - 2:
        return np.empty((1, MAX_VERTICES)), np.empty((1, MAX_VERTICES)), np.zeros(1, np.int64), -1
    cap = min(64, max_pieces)
    while True:
        px, py, pn, pieces = _subtract_in(gx, gy, gn, cx, cy, cn, count, dust, max_pieces,
                                          budget, cap)
        if pieces >= 0 or cap >= max_pieces:
            return px, py, pn, pieces
        cap *= 2


@njit(cache=True)
def _subtract_in(gx, gy, gn, cx, cy, cn, count, dust, max_pieces, budget, cap):
    """:func:`subtract` with room for ``cap`` pieces (-2 pieces: more room needed). The
    pieces live in one two-plane array per coordinate (the pieces, and what is left of them),
    made once and never rebound: an array rebound in a loop (swapped, grown) counted
    references to it at every step, an atomic operation each, and those were ~90 % of the
    reference counts of an occlusion proof (an eye proven 15-25 % faster without them)."""
    # the pieces (plane ``cur``) and what is left of them (the other plane), as one array
    # each: swapping arrays would count references to them, atomically, at every polygon
    px = np.empty((2, cap, MAX_VERTICES))
    py = np.empty((2, cap, MAX_VERTICES))
    pn = np.zeros((2, cap), np.int64)
    cur = 0
    sign = 1.0 if area2(gx, gy, gn) >= 0.0 else -1.0
    for i in range(gn):  # counter-clockwise
        k = i if sign > 0 else gn - 1 - i
        px[0, 0, i], py[0, 0, i] = gx[k], gy[k]
    pn[0, 0] = gn
    pieces = 1
    ax, ay = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    bx, by = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
    clips = 0
    stop = False
    for t in range(count):
        m = cn[t]
        s2 = 0.0  # area2 of the covering polygon
        for i in range(m):
            j = (i + 1) % m
            s2 += cx[t, i] * cy[t, j] - cx[t, j] * cy[t, i]
        orient = 1.0 if s2 >= 0.0 else -1.0
        x0, y0, x1, y1 = extents(cx, cy, (t,), m)
        out = 0
        nxt = 1 - cur
        for p in range(pieces):
            n = pn[cur, p]
            clips += 1
            # room for every piece this one can leave, and the piece itself
            if out + m + 1 > cap and cap < max_pieces:
                return px[cur], py[cur], pn[cur], -2
            keep = stop or out + m + 1 > cap or clips + 2 * m > budget
            if keep:
                stop = True  # keep the rest as it is
            else:  # kept as it is where it lies beside the polygon (their extents apart)
                lx, ly, hx_, hy_ = extents(px, py, (cur, p), n)
                keep = hx_ <= x0 or lx >= x1 or hy_ <= y0 or ly >= y1
            if not keep:
                # what is left of the piece inside the edges so far
                for v in range(n):
                    ax[v], ay[v] = px[cur, p, v], py[cur, p, v]
                na = n
                first = out
                for e in range(m):
                    f = (e + 1) % m
                    # inside: left of the edge for a counter-clockwise polygon
                    a = -(cy[t, f] - cy[t, e]) * orient
                    b = (cx[t, f] - cx[t, e]) * orient
                    c = -(a * cx[t, e] + b * cy[t, e])
                    # the part outside this edge is left over
                    nb = clip(ax, ay, na, -a, -b, -c, bx, by)
                    clips += 2
                    if nb < 0:  # too many vertices: keep the piece whole
                        out, keep = first, True
                        break
                    if nb >= 3 and abs(area2(bx, by, nb)) > 2 * dust:
                        for v in range(nb):
                            px[nxt, out, v], py[nxt, out, v] = bx[v], by[v]
                        pn[nxt, out] = nb
                        out += 1
                    na = clip(ax, ay, na, a, b, c, bx, by)
                    if na < 0:
                        out, keep = first, True
                        break
                    for v in range(na):
                        ax[v], ay[v] = bx[v], by[v]
                    if na < 3:
                        break
            if keep:
                for v in range(n):
                    px[nxt, out, v], py[nxt, out, v] = px[cur, p, v], py[cur, p, v]
                pn[nxt, out] = n
                out += 1
        cur = nxt
        pieces = out
        if pieces == 0 or stop:
            break
    return px[cur], py[cur], pn[cur], pieces


@njit(cache=True)
def covered(gx, gy, gn, cx, cy, cn, count, dust, max_pieces):
    """Whether the convex polygon lies in the union of the convex polygons (see
    :func:`subtract`; False where it stops short)."""
    return subtract(gx, gy, gn, cx, cy, cn, count, dust, max_pieces)[3] == 0
