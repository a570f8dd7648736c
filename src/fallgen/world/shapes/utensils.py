"""Flat and long things: cutlery, kitchen utensils, keys, toothbrushes.

Flat parts are shapely outlines extruded along z (:func:`meshkit.extrude`) and bent by moving
their vertices; handles are swept tubes. They lie along x, flat side down, as they would rest
on a table. Collision pieces are clipped from the visual mesh with boxes (handle slabs, each
tine of a fork, a key's head and blade).
"""

from __future__ import annotations

import math

import numpy as np
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry import box as sbox
from shapely.ops import unary_union

from fallgen.world import meshkit as mk
from fallgen.world.shapes._core import Shape, finish, need, shape

INF = math.inf


def _outline(xs: np.ndarray, half_widths: np.ndarray) -> Polygon:
    """A polygon symmetric about the x axis from sampled half widths (0 allowed at the ends)."""
    upper = np.column_stack([xs, half_widths])
    lower = np.column_stack([xs[::-1], -half_widths[::-1]])
    pts = np.vstack([upper, lower])
    keep = np.ones(len(pts), bool)
    keep[1:] = np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9
    return Polygon(pts[keep]).buffer(0)


def _end_round(x: np.ndarray, x0: float, length: float) -> np.ndarray:
    """1 beyond ``length`` from ``x0``, an elliptic fall-off to 0 at ``x0``."""
    u = np.clip(np.abs(x - x0) / length, 0.0, 1.0)
    return np.sqrt(1.0 - (1.0 - u) ** 2)


def _slabs(mesh, cuts: list[float], axis: int = 0) -> list[np.ndarray]:
    """Clip pieces of a mesh between consecutive cut positions along ``axis``."""
    out = []
    edges = [-INF, *cuts, INF]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        lo, hi = [-INF] * 3, [INF] * 3
        lo[axis], hi[axis] = a, b
        out.append(mk.clip_piece(mesh, lo, hi))
    return out


# ---------------------------------------------------------------------------------------------
@shape("fork", tines=(2, 6), bend_m=(0.0, 0.05))
def fork(*, length_m: float = 0.19, thickness_m: float = 0.0022, tines: int = 4,
         tine_length_m: float = 0.037, head_width_m: float = 0.025,
         handle_width_m: float = 0.015, neck_width_m: float = 0.0065, gap_m: float = 0.0024,
         bend_m: float = 0.011) -> Shape:
    """Table fork: flat outline with ``tines`` tines, extruded and bent (handle end and tines
    raised by ``bend_m`` above the neck)."""
    L, hw = length_m, head_width_m
    tw = (hw - (tines - 1) * gap_m) / tines
    need(tw > 0.0012, "fork", "gap_m", "tines would be thinner than 1.2 mm")
    need(tine_length_m < 0.4 * L, "fork", "tine_length_m", "must be under 40% of the length")
    need(neck_width_m < min(hw, handle_width_m), "fork", "neck_width_m", "must be the narrowest part")
    x_neck, x_tr = 0.60 * L, L - tine_length_m
    x_hb = x_tr - 0.35 * (x_tr - x_neck)
    xs = np.linspace(0.0, L, 160)
    w = np.where(xs < x_neck,
                 handle_width_m / 2 + (neck_width_m - handle_width_m) / 2 * mk.smoothstep(xs, 0.2 * L, x_neck),
                 neck_width_m / 2 + (hw - neck_width_m) / 2 * mk.smoothstep(xs, x_neck, x_hb) ** 0.8)
    w = w * _end_round(xs, 0.0, 0.6 * handle_width_m)
    outline = _outline(xs, w)
    ys = [-hw / 2 + i * (tw + gap_m) - gap_m / 2 for i in range(1, tines)]
    slots = [LineString([(x_tr, y), (L + 0.01, y)]).buffer(gap_m / 2, quad_segs=4) for y in ys]
    outline = outline.difference(unary_union(slots))
    r = 0.35 * tw
    outline = outline.buffer(-r, quad_segs=4).buffer(r, quad_segs=4)
    m = mk.extrude(outline, thickness_m, max_len=0.0025)

    def dz(x: np.ndarray) -> np.ndarray:
        a = np.clip((x_neck - x) / x_neck, 0, 1) ** 2
        b = np.clip((x - x_neck) / (L - x_neck), 0, 1) ** 2.2
        return bend_m * (a + b)

    m = mk.warp(m, mk.bend_z(dz))
    pieces = _slabs(m, [0.22 * L, 0.42 * L, x_neck])
    pieces.append(mk.clip_piece(m, [x_neck, -INF, -INF], [x_hb, INF, INF]))
    x_root = x_tr - gap_m / 2
    pieces.append(mk.clip_piece(m, [x_hb, -INF, -INF], [x_root, INF, INF]))
    bounds = [-INF, *ys, INF]
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        pieces.append(mk.clip_piece(m, [x_root, a, -INF], [INF, b, INF]))
    return finish(m, pieces)


@shape("knife")
def knife(*, length_m: float = 0.225, blade_length_m: float = 0.12, blade_width_m: float = 0.02,
          blade_thickness_m: float = 0.002, handle_width_m: float = 0.017,
          handle_thickness_m: float = 0.008, pointed: bool = False) -> Shape:
    """Knife: flat blade (rounded table-knife tip, or ``pointed``) whose tang runs into a
    rounded handle of ``handle_width_m`` x ``handle_thickness_m``."""
    bl, bw, hl = blade_length_m, blade_width_m, length_m - blade_length_m
    need(hl > 0.04, "knife", "blade_length_m", "leaves a handle shorter than 4 cm")
    need(handle_thickness_m > blade_thickness_m, "knife", "handle_thickness_m",
         "must be thicker than the blade")
    xs = np.linspace(0.0, bl, 80)
    spine = np.full_like(xs, bw / 2)
    s = np.clip((xs - 0.45 * bl) / (0.55 * bl), 0, 1)
    edge = -bw / 2 + bw * s ** (2.2 if pointed else 2.0)
    neck = mk.smoothstep(xs, 0.0, 0.018)
    tang_w = 0.55 * min(bw, handle_width_m)
    top = tang_w / 2 + (spine - tang_w / 2) * neck
    bot = -tang_w / 2 + (edge + tang_w / 2) * neck
    pts = np.vstack([[[-0.02, tang_w / 2]], np.column_stack([xs, top]),
                     np.column_stack([xs[::-1], bot[::-1]]), [[-0.02, -tang_w / 2]]])
    blade = Polygon(pts).buffer(0)
    if not pointed:
        r = bw / 8
        blade = blade.buffer(-r, quad_segs=5).buffer(r, quad_segs=5)
    else:
        blade = blade.buffer(-0.0004, quad_segs=2).buffer(0.0004, quad_segs=2)
    bm = mk.extrude(blade, blade_thickness_m, max_len=0.004)
    hx = np.linspace(-0.004, -hl + handle_thickness_m / 2, 16)
    u = (hx - hx[0]) / (hx[-1] - hx[0])
    hwid = handle_width_m / 2 * (0.92 + 0.08 * np.sin(np.pi * u * 0.8))
    hhei = handle_thickness_m / 2 * (0.9 + 0.1 * u)
    handle = mk.sweep(np.column_stack([hx, np.zeros_like(hx), np.zeros_like(hx)]), hwid, hhei,
                      exponent=2.6, ring=24, caps="round")
    m = mk.union([bm, handle.mesh], tolerance=0.3 * blade_thickness_m)
    return finish(m, _slabs(m, [0.0]))


@shape("spoon", bend_m=(0.0, 0.06))
def spoon(*, length_m: float = 0.19, bowl_length_m: float = 0.058, bowl_width_m: float = 0.04,
          bowl_depth_m: float = 0.011, wall_m: float = 0.0013, handle_width_m: float = 0.014,
          neck_width_m: float = 0.0065, handle_thickness_m: float = 0.0022,
          bend_m: float = 0.016) -> Shape:
    """Spoon: half-ellipsoid bowl shell (``wall_m`` thick) and a flat handle rising by
    ``bend_m`` (tablespoons, teaspoons, wooden cooking spoons)."""
    a, b, c = bowl_length_m / 2, bowl_width_m / 2, bowl_depth_m
    hl = length_m - bowl_length_m
    need(hl > 0.03, "spoon", "bowl_length_m", "leaves a handle shorter than 3 cm")
    need(2.5 * wall_m < c, "spoon", "wall_m", "too thick for the bowl depth")
    need(neck_width_m < min(handle_width_m, bowl_width_m), "spoon", "neck_width_m",
         "must be narrower than handle and bowl")
    outer = mk.intersection(mk.ellipsoid((a, b, c), subdivisions=3),
                            mk.box((3 * a, 3 * b, 2 * c), center=(0, 0, -c)), tolerance=0)
    bowl = mk.difference(outer, mk.ellipsoid((a - wall_m, b - wall_m, c - wall_m), subdivisions=3),
                         tolerance=0)
    ov = min(0.15 * a, 0.004)
    xs = np.linspace(-a + ov, -a - hl, 90)
    s = np.clip((-a - xs) / hl, 0, 1)
    w = neck_width_m / 2 + (handle_width_m - neck_width_m) / 2 * mk.smoothstep(s, 0.05, 0.85)
    w = w * _end_round(xs, -a - hl, 0.7 * handle_width_m)
    outline = _outline(xs[::-1], w[::-1])
    hm = mk.extrude(outline, handle_thickness_m, max_len=0.003)
    hm.apply_translation([0, 0, -handle_thickness_m / 2 - 0.25 * wall_m])

    def lift(x: np.ndarray) -> np.ndarray:
        t = np.clip((-a - x) / hl, 0.0, 1.0)
        return bend_m * (0.75 * mk.smoothstep(t, 0.0, 0.55) + 0.25 * t)

    hm = mk.warp(hm, mk.bend_z(lift))
    m = mk.union([bowl, hm], tolerance=0.3 * wall_m)
    x0 = -a - 0.002
    pieces = [mk.clip_piece(m, [x0, -INF, -INF], [INF, INF, INF])]
    cuts = [x0 - 0.3 * hl, x0 - 0.62 * hl]
    pieces.append(mk.clip_piece(m, [cuts[0], -INF, -INF], [x0, INF, INF]))
    pieces.append(mk.clip_piece(m, [cuts[1], -INF, -INF], [cuts[0], INF, INF]))
    pieces.append(mk.clip_piece(m, [-INF, -INF, -INF], [cuts[1], INF, INF]))
    return finish(m, pieces)


@shape("spatula", angle_deg=(0.0, 45.0), slots=(0, 6))
def spatula(*, blade_length_m: float = 0.085, blade_width_m: float = 0.065,
            blade_thickness_m: float = 0.0025, neck_length_m: float = 0.05,
            handle_length_m: float = 0.15, handle_width_m: float = 0.022,
            handle_thickness_m: float = 0.012, angle_deg: float = 18.0, slots: int = 3) -> Shape:
    """Turner / spatula: slotted flat blade, a neck bent up by ``angle_deg`` and a handle."""
    bl, bw = blade_length_m, blade_width_m
    need(handle_thickness_m > blade_thickness_m, "spatula", "handle_thickness_m",
         "must be thicker than the blade")
    blade = mk.rounded_rect(bl, bw, 0.12 * bw, center=(bl / 2, 0.0))
    blade = blade.intersection(sbox(0.003, -bw, bl + 1, bw)).union(
        mk.rounded_rect(0.01, bw, 0.004, center=(0.006, 0.0)))
    if slots:
        sw = 0.006
        pitch = (bw - 0.02) / slots
        for i in range(slots):
            y = -bw / 2 + 0.01 + pitch * (i + 0.5)
            blade = blade.difference(LineString([(0.018, y), (bl - 0.014, y)]).buffer(
                min(sw, 0.6 * pitch) / 2, quad_segs=4))
    nw0, nw1 = 0.45 * bw, 0.75 * handle_width_m
    xe = bl + neck_length_m
    neck = Polygon([(bl - 0.01, nw0 / 2), (xe, nw1 / 2), (xe, -nw1 / 2), (bl - 0.01, -nw0 / 2)])
    outline = blade.union(neck).buffer(0.003, quad_segs=3).buffer(-0.003, quad_segs=3)
    m = mk.extrude(outline, blade_thickness_m, max_len=0.004)
    ta = math.tan(math.radians(angle_deg))
    wb = 0.02

    def lift(x: np.ndarray) -> np.ndarray:
        u = np.clip(x - bl, 0.0, None)
        return ta * np.where(u < wb, u**2 / (2 * wb), u - wb / 2)

    m = mk.warp(m, mk.bend_z(lift))
    d = np.array([math.cos(math.radians(angle_deg)), 0.0, math.sin(math.radians(angle_deg))])
    p0 = np.array([xe - 0.012, 0.0, float(lift(np.array([xe - 0.012]))[0])])
    path = p0 + np.linspace(0, handle_length_m, 14)[:, None] * d
    hw = handle_width_m / 2 * np.linspace(0.8, 1.0, 14)
    h = mk.sweep(path, hw, handle_thickness_m / 2, exponent=3.0, ring=24, caps="round")
    m = mk.union([m, h.mesh], tolerance=0.3 * blade_thickness_m)
    pieces = [mk.clip_piece(m, [-INF] * 3, [bl, INF, INF]),
              mk.clip_piece(m, [bl, -INF, -INF], [p0[0] + 0.004, INF, INF]),
              mk.clip_piece(m, [p0[0] + 0.004, -INF, -INF], [INF, INF, INF])]
    return finish(m, pieces)


@shape("ladle", angle_deg=(30.0, 90.0))
def ladle(*, bowl_diameter_m: float = 0.08, bowl_depth_m: float = 0.038, wall_m: float = 0.0012,
          handle_length_m: float = 0.26, handle_width_m: float = 0.014,
          handle_thickness_m: float = 0.0026, angle_deg: float = 68.0) -> Shape:
    """Ladle: a hemispherical shell bowl and a long flat handle rising at ``angle_deg`` from its
    rim, ending in a small hook."""
    R, D = bowl_diameter_m / 2, bowl_depth_m
    need(D <= R * 1.05, "ladle", "bowl_depth_m", "deeper than a hemisphere")
    phi = np.linspace(0.0, math.pi / 2, 14)
    outer = np.column_stack([R * np.sin(phi), D * (1 - np.cos(phi))])
    lathe = mk.Lathe.hollow(np.vstack([[0.0, 0.0], outer[1:]]), wall_m, rim_radius=0.45 * wall_m,
                            segments=40, min_len=min(3e-4, wall_m / 3))
    bowl = lathe.mesh()
    a = math.radians(angle_deg)
    d0 = np.array([math.cos(a), 0.0, math.sin(a)])
    p0 = np.array([R - wall_m / 2, 0.0, D - 0.004])
    n = 24
    s = np.linspace(0.0, 1.0, n + 1)
    path = p0 + np.outer(s * handle_length_m, d0)
    # the last 12 %: curl clockwise (away from the bowl) into a hanging hook
    hook = s > 0.88
    beta = (s[hook] - 0.88) / 0.12 * math.radians(150)
    rh = 0.12 * handle_length_m / math.radians(150)
    start = p0 + 0.88 * handle_length_m * d0
    nr = np.array([math.sin(a), 0.0, -math.cos(a)])
    ctr = start + nr * rh
    v0 = -nr * rh
    path[hook] = ctr + np.column_stack([v0[0] * np.cos(beta) + v0[2] * np.sin(beta),
                                        np.zeros_like(beta),
                                        -v0[0] * np.sin(beta) + v0[2] * np.cos(beta)])
    hw = handle_width_m / 2 * np.where(s < 0.15, 0.7 + 2.0 * s, 1.0)
    h = mk.sweep(path, hw, handle_thickness_m / 2, exponent=4.0, ring=20, caps="round",
                 cap_length=handle_thickness_m / 2)
    m = mk.union([bowl, h.mesh], tolerance=0.3 * wall_m)
    pieces = lathe.pieces(0.004, reserve=3, max_sectors=8) + h.pieces(3)
    return finish(m, pieces)


@shape("key", teeth=(0, 8))
def key(*, length_m: float = 0.055, head_length_m: float = 0.021, head_width_m: float = 0.024,
        thickness_m: float = 0.0019, blade_width_m: float = 0.0075, hole_diameter_m: float = 0.004,
        teeth: int = 5) -> Shape:
    """Pin-tumbler house key: rounded head with a ring hole, shoulder, and a blade with
    ``teeth`` V-cuts (fixed bitting) and an angled tip."""
    L, hlen, hwid, bw = length_m, head_length_m, head_width_m, blade_width_m
    need(hlen < 0.6 * L, "key", "head_length_m", "must be under 60% of the length")
    need(hole_diameter_m < 0.6 * min(hlen, hwid), "key", "hole_diameter_m", "too large for the head")
    need(bw < hwid, "key", "blade_width_m", "must be narrower than the head")
    head = Point(0, 0).buffer(1.0, quad_segs=12)
    head = affinity.scale(head, hlen / 2, hwid / 2).union(
        mk.rounded_rect(0.5 * hlen, 0.8 * hwid, 0.2 * hlen, center=(0.1 * hlen, 0.0)))
    hole = Point(-0.18 * hlen, 0).buffer(hole_diameter_m / 2, quad_segs=8)
    x0, x1 = 0.4 * hlen, L - hlen / 2
    yb, yt = -bw / 2, bw / 2
    top = [(x0, yt + 0.0016), (x0 + 0.0025, yt + 0.0016), (x0 + 0.003, yt)]
    depths = [0.55, 0.25, 0.8, 0.4, 0.65, 0.3, 0.7, 0.5][:teeth]
    pitch = (x1 - 0.006 - (x0 + 0.004)) / max(teeth, 1)
    for i, dpt in enumerate(depths):
        xc = x0 + 0.004 + pitch * (i + 0.5)
        top += [(xc - 0.45 * pitch, yt), (xc, yt - dpt * 0.4 * bw), (xc + 0.45 * pitch, yt)]
    top += [(x1 - 0.003, yt - 0.1 * bw), (x1, yb + 0.3 * bw), (x1 - 0.0015, yb)]
    blade = Polygon([*top, (x0, yb)])
    outline = head.union(blade).difference(hole)
    outline = outline.buffer(0.0003, quad_segs=2).buffer(-0.0003, quad_segs=2)
    m = mk.extrude(outline, thickness_m, max_len=0.003)
    cut = 0.45 * hlen
    pieces = [mk.clip_piece(m, [-INF] * 3, [cut, INF, INF]),
              mk.clip_piece(m, [cut, -INF, -INF], [INF, INF, INF])]
    return finish(m, pieces)


@shape("toothbrush")
def toothbrush(*, length_m: float = 0.19, handle_width_m: float = 0.013,
               handle_thickness_m: float = 0.009, head_length_m: float = 0.03,
               head_width_m: float = 0.012, bristle_height_m: float = 0.011) -> Shape:
    """Manual toothbrush: swept handle narrowing to a neck, flat head raised slightly, and a
    block of bristles."""
    L, hl = length_m, head_length_m
    need(hl < 0.3 * L, "toothbrush", "head_length_m", "must be under 30% of the length")
    x = np.linspace(0.0, L, 48)
    xn0, xn1 = L - hl - 0.035, L - hl
    hw = np.where(x < xn0, handle_width_m / 2 * (0.85 + 0.15 * np.sin(np.pi * np.clip(x / xn0, 0, 1))),
                  handle_width_m / 2)
    neck = mk.smoothstep(x, xn0, xn1 - 0.01)
    headw = mk.smoothstep(x, xn1 - 0.006, xn1 + 0.002)
    hw = hw * (1 - neck) + 0.0032 * neck
    hw = hw * (1 - headw) + head_width_m / 2 * headw
    hh = handle_thickness_m / 2 * (1 - neck) + 0.0025 * neck
    z = 0.005 * mk.smoothstep(x, xn0 - 0.02, xn1)
    path = np.column_stack([x, np.zeros_like(x), z])
    body = mk.sweep(path, hw, hh, exponent=2.6, ring=20, caps="round")
    bx = L - hl / 2 - 0.001
    bristles = mk.rounded_box((hl - 0.006, head_width_m - 0.0016, bristle_height_m + 0.002),
                              0.0012, segments=2,
                              center=(bx, 0.0, z[-1] + 0.0025 + bristle_height_m / 2 - 0.001))
    m = mk.union([body.mesh, bristles])
    pieces = _slabs(m, [0.3 * L, 0.6 * L, xn0 + 0.015, xn1 - 0.003])
    return finish(m, pieces)
