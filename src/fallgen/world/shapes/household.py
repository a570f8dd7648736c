"""Household objects: bookends, toys, brushes, boxes, and the occluders (book, towel, carton).

Most are unions of rounded slabs, ellipsoids and sweeps. Boxes are shells with a realistic
wall thickness; a closed box keeps its cavity sealed unless the real thing has an opening
(a keyhole, hand holes).
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from shapely.geometry import Polygon
from shapely.ops import unary_union

from fallgen.world import meshkit as mk
from fallgen.world.shapes._core import Shape, finish, need, shape
from fallgen.world.shell import THIN_WALL_M, ThinShell

INF = math.inf

#: (u, v, w) -> (x, z, y): extrude a side profile drawn in (x, z) along y.
_XZ_TO_XYZ = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0],
                       [0.0, 0.0, 0.0, 1.0]])


def _extrude_side(profile: Polygon, depth: float, *, max_len: float | None = None) -> trimesh.Trimesh:
    """Extrude a profile drawn in the (x, z) plane along y (centred)."""
    m = mk.extrude(profile, depth, max_len=max_len)
    m.apply_transform(_XZ_TO_XYZ)
    if m.volume < 0:
        m.invert()
    return m


@shape("bookend")
def bookend(*, width_m: float = 0.125, height_m: float = 0.15, depth_m: float = 0.11,
            thickness_m: float = 0.0015, bend_radius_m: float = 0.003) -> Shape:
    """L-shaped bookend: an upright plate and a base plate joined by a rounded bend (sheet
    steel; thick ``thickness_m`` gives a wooden or stone one)."""
    H, D, t, r = height_m, depth_m, thickness_m, bend_radius_m
    need(t < 0.3 * min(H, D), "bookend", "thickness_m", "too thick for the plates")
    need(r + t < 0.5 * min(H, D), "bookend", "bend_radius_m", "too large")
    pts = np.array([[0.0, H], [0.0, 0.0], [D, 0.0], [D, t], [t, t], [t, H]])
    e = min(0.002, 0.3 * t)
    pts = mk.fillet_polyline(pts, [0.0, r + t, e, e, r, 0.0])
    prof = Polygon(pts).buffer(0)
    top = min(0.004, 0.45 * t)
    prof = mk.round_section(prof, rim_radius=top, arc_segments=2) if top > 1e-4 else prof
    m = _extrude_side(prof, width_m, max_len=max(0.01, 2 * t))
    c = r + t
    pieces = [mk.clip_piece(m, [-INF, -INF, c], [c, INF, INF]),
              mk.clip_piece(m, [-INF, -INF, -INF], [INF, INF, c])]
    return finish(m, pieces)


@shape("toy_car")
def toy_car(*, length_m: float = 0.10, width_m: float = 0.045, height_m: float = 0.042,
            wheel_diameter_m: float = 0.024, wheel_width_m: float = 0.009) -> Shape:
    """Toy car: rounded body, cabin on top and four wheels (a solid block-built toy)."""
    L, W, H = length_m, width_m, height_m
    rw = wheel_diameter_m / 2
    clear = 0.4 * rw
    body_h = 0.45 * (H - clear)
    need(wheel_diameter_m < 0.4 * L, "toy_car", "wheel_diameter_m", "too large for the length")
    need(H > clear + body_h + 0.006, "toy_car", "height_m", "too low for body and cabin")
    need(2 * wheel_width_m < 0.8 * W, "toy_car", "wheel_width_m", "too wide")
    body = mk.rounded_slab((L, W - 0.002, body_h), min(0.01, W / 4), min(0.004, body_h / 3),
                           center=(0, 0, clear + body_h / 2))
    cab_h = H - clear - body_h + 0.001
    cabin = mk.rounded_slab((0.5 * L, 0.86 * W, cab_h), min(0.008, W / 5), min(0.005, cab_h / 2.5),
                            center=(-0.06 * L, 0, H - cab_h / 2))
    parts, pieces = [body, cabin], [body.vertices, cabin.vertices]
    for sx in (1, -1):
        for sy in (1, -1):
            w = mk.rounded_cylinder(rw, wheel_width_m, edge_radius=0.0015, segments=28)
            w.apply_transform(np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]]))
            w.apply_translation([sx * 0.31 * L, sy * (W / 2 - wheel_width_m / 2), rw])
            parts.append(w)
            pieces.append(w.vertices)
    m = mk.union(parts)
    return finish(m, pieces)


@shape("rubber_duck")
def rubber_duck(*, length_m: float = 0.10, wall_m: float = 0.0016, hole_diameter_m: float = 0.005) -> Shape:
    """Bath duck: a hollow shell (``wall_m``) of ellipsoid body, spherical head, beak and tail,
    with the squeak hole under the body."""
    s = length_m / 0.10
    w = wall_m
    need(w < 0.006 * s, "rubber_duck", "wall_m", "too thick for the size")
    need(hole_diameter_m < 0.03 * s, "rubber_duck", "hole_diameter_m", "too large")
    body_c, body_r = np.array([-0.004, 0, 0.03]) * s, np.array([0.045, 0.036, 0.03]) * s
    head_c, head_r = np.array([0.022, 0, 0.071]) * s, 0.022 * s
    outer = [mk.ellipsoid(body_r, subdivisions=3, center=body_c),
             mk.sphere(head_r, subdivisions=3, center=head_c),
             mk.ellipsoid(np.array([0.014, 0.010, 0.0045]) * s, subdivisions=2,
                          center=np.array([0.045, 0, 0.066]) * s),
             mk.ellipsoid(np.array([0.014, 0.012, 0.011]) * s, subdivisions=2,
                          center=np.array([-0.04, 0, 0.045]) * s)]
    cut = mk.box((1, 1, 1), center=(0, 0, -0.5 + 0.004 * s))
    inner = [mk.ellipsoid(body_r - w, subdivisions=3, center=body_c),
             mk.sphere(head_r - w, subdivisions=3, center=head_c)]
    inner_cut = mk.box((1, 1, 1), center=(0, 0, -0.5 + 0.004 * s + w))
    inner_m = mk.difference(mk.union(inner, tolerance=0.3 * w), inner_cut, tolerance=0.3 * w)
    hole = mk.rounded_cylinder(hole_diameter_m / 2, 4 * w, segments=16, center=(0, 0, 0.004 * s))
    m = mk.difference(mk.union(outer, tolerance=0.3 * w), [cut, inner_m, hole], tolerance=0.3 * w)
    zc = 0.052 * s
    pieces = [mk.clip_piece(m, [-INF] * 3, [INF, INF, zc]), mk.clip_piece(m, [-INF, -INF, zc], [INF] * 3)]
    return finish(m, pieces)


@shape("clothes_brush", rows=(1, 10), handle_length_m=(0.0, 1.0))
def clothes_brush(*, length_m: float = 0.15, width_m: float = 0.05, block_height_m: float = 0.016,
                  bristle_height_m: float = 0.014, rows: int = 4, handle_length_m: float = 0.0) -> Shape:
    """Clothes brush: an oval wooden block over ``rows`` rows of bristles (each row a solid
    strip), optionally with a handle (``handle_length_m`` > 0) at +x."""
    L, W, bh, hb = length_m, width_m, block_height_m, bristle_height_m
    need(W > 0.02 and L > 2 * W / 2, "clothes_brush", "width_m", "too narrow or too short")
    need(handle_length_m == 0 or handle_length_m > 0.04, "clothes_brush", "handle_length_m",
         "must be 0 or over 4 cm")
    block = mk.rounded_slab((L, W, bh), 0.45 * W, min(0.005, bh / 2.5), center=(0, 0, hb + bh / 2))
    parts = [block]
    pitch = (W - 0.008) / rows
    rw = 0.62 * pitch
    rows_m = []
    for i in range(rows):
        y = -(W - 0.008) / 2 + pitch * (i + 0.5)
        edge = 1.0 - (2 * abs(y) / W) ** 2
        rl = L - 0.012 - (1 - edge) * 0.5 * W
        rows_m.append(mk.rounded_box((rl, rw, hb + 0.002), min(0.0012, rw / 3), segments=2,
                                     center=(0, y, hb / 2 + 0.001)))
    parts += rows_m
    pieces = [np.vstack([r.vertices for r in rows_m]), block.vertices]
    if handle_length_m > 0:
        x = np.linspace(L / 2 - 0.02, L / 2 + handle_length_m, 12)
        z = hb + bh / 2 + 0.25 * (x - x[0]) * np.linspace(0, 1, len(x))
        h = mk.sweep(np.column_stack([x, np.zeros_like(x), z]), 0.011, 0.007, exponent=2.6,
                     ring=20, caps="round")
        parts.append(h.mesh)
        pieces += h.pieces(2)
    m = mk.union(parts)
    return finish(m, pieces)


@shape("lidded_box")
def lidded_box(*, length_m: float = 0.15, width_m: float = 0.10, height_m: float = 0.07,
               wall_m: float = 0.008, lid_height_m: float = 0.02, keyhole: bool = True) -> Shape:
    """Closed box with a slightly overhanging lid (jewellery box, tea caddy). The cavity is
    open to the outside through a keyhole when ``keyhole`` is set, otherwise sealed."""
    L, W, H, w, hl = length_m, width_m, height_m, wall_m, lid_height_m
    need(2.5 * w < min(W, H), "lidded_box", "wall_m", "too thick for the size")
    need(w < hl < H - 2 * w, "lidded_box", "lid_height_m", "must be between wall_m and the height")
    o = min(0.0015, 0.5 * w)
    rc = min(0.006, W / 6)
    body = mk.rounded_slab((L, W, H - hl + 0.0005), rc, min(0.002, w / 2),
                           center=(0, 0, (H - hl + 0.0005) / 2))
    lid = mk.rounded_slab((L + 2 * o, W + 2 * o, hl), rc + o, min(0.003, hl / 3),
                          center=(0, 0, H - hl / 2))
    cav = mk.rounded_slab((L - 2 * w, W - 2 * w, H - 2 * w), max(rc - w, 5e-4), min(5e-4, max(rc - w, 5e-4)),
                          center=(0, 0, H / 2))
    cuts = [cav]
    if keyhole:
        zk = H - hl - min(0.008, 0.3 * (H - hl))
        kh = mk.rounded_cylinder(0.0018, 3 * w, segments=16)
        kh.apply_transform(np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]]))
        kh.apply_translation([0, -W / 2, zk])
        slot = mk.box((0.0014, 3 * w, 0.004), center=(0, -W / 2, zk - 0.0025))
        cuts += [kh, slot]
    m = mk.difference(mk.union([body, lid], tolerance=min(3e-4, 0.3 * w)), cuts,
                      tolerance=min(3e-4, 0.3 * w))
    return finish(m)


@shape("tin")
def tin(*, diameter_m: float = 0.075, height_m: float = 0.10, lid_height_m: float = 0.025,
        wall_m: float = 0.00025) -> Shape:
    """Round tinplate caddy with a slip-on lid (tea, biscuits): a thin closed shell (the
    cavity is sealed, so the mesh has an inner and an outer surface)."""
    R, H, hl, w = diameter_m / 2, height_m, lid_height_m, wall_m
    need(hl < 0.6 * H, "tin", "lid_height_m", "must be under 60% of the height")
    need(10 * w < R, "tin", "wall_m", "too thick")
    st = max(2 * w, 0.0005)
    outer = np.array([[0.0, 0.0], [R, 0.0], [R, H - hl], [R + st, H - hl + st], [R + st, H],
                      [0.0, H]])
    outer = mk.fillet_polyline(outer, [0, 0.002, 0, 0, 0.0025, 0], max_step_deg=22.5)
    cav = mk.solid_section(outer).buffer(-w, quad_segs=3)
    inner = mk.section_profile(mk.half_section(mk._single_polygon(cav, "tin cavity")), min_len=1e-4)
    om = mk.revolve(outer, 48, max_len=0.012)
    im = mk.revolve(inner, 48, max_len=0.012)
    im.invert()
    m = trimesh.util.concatenate([om, im])
    shell = ThinShell.cylinder(R, H, w, (0.0, 0.0, H / 2)) if w <= THIN_WALL_M else None
    return finish(m, [om.vertices], shell)


@shape("book")
def book(*, width_m: float = 0.155, length_m: float = 0.235, thickness_m: float = 0.03,
         cover_m: float = 0.0025, overhang_m: float = 0.003, hardcover: bool = True) -> Shape:
    """Book lying flat, spine at -x. Hardcover: two boards overhanging the page block on three
    sides and a rounded spine; paperback: a single rounded block."""
    W, L, T, c, o = width_m, length_m, thickness_m, cover_m, overhang_m
    need(2.5 * c < T, "book", "cover_m", "too thick for the book")
    if not hardcover:
        return finish(mk.rounded_slab((W, L, T), 0.002, min(0.0015, T / 3)))
    need(o < 0.1 * min(W, L), "book", "overhang_m", "too large")
    boards = [mk.rounded_slab((W - 0.002, L, c), 0.002, min(0.0008, c / 2.5),
                              center=(0.001, 0, s * (T / 2 - c / 2))) for s in (1, -1)]
    block = mk.rounded_slab((W - o - 0.003, L - 2 * o, T - 2 * c + 0.001), 0.0015, 0.0005,
                            center=(-W / 2 + 0.003 + (W - o - 0.003) / 2, 0, 0))
    y = np.linspace(-L / 2, L / 2, 12)
    spine = mk.sweep(np.column_stack([np.full_like(y, -W / 2 + 0.0035), y, np.zeros_like(y)]),
                     0.0035, T / 2, normal=(1, 0, 0), exponent=2.2, ring=24, caps="flat")
    m = mk.union([*boards, block, spine.mesh], tolerance=min(3e-4, 0.3 * c))
    return finish(m)


@shape("towel", layers=(1, 8))
def towel(*, length_m: float = 0.30, width_m: float = 0.21, thickness_m: float = 0.035,
          layers: int = 4) -> Shape:
    """Folded towel lying flat: ``layers`` soft layers whose folds alternate ends."""
    L, T = length_m, thickness_m
    tl = T / layers
    need(tl > 0.002, "towel", "thickness_m", "layers would be thinner than 2 mm")
    need(L > 4 * tl, "towel", "length_m", "too short for the thickness")
    polys = []
    for i in range(layers):
        dx = 0.004 * (1 if i % 2 else -1)
        polys.append(mk.rounded_rect(L - 0.008, tl * 1.02, 0.49 * tl, segments=5,
                                     center=(dx, (i + 0.5) * tl)))
    prof = unary_union(polys).buffer(0.3 * tl, quad_segs=4).buffer(-0.3 * tl, quad_segs=4)
    m = _extrude_side(prof, width_m, max_len=0.05)
    return finish(m)


@shape("cardboard_box")
def cardboard_box(*, length_m: float = 0.30, width_m: float = 0.20, height_m: float = 0.15,
                  wall_m: float = 0.004, open_top: bool = True, flaps: bool = True) -> Shape:
    """Corrugated carton. Open: a tray without lid, with its four flaps folded out at the top
    (``flaps``); closed: a sealed carton with two hand holes in the short sides."""
    L, W, H, w = length_m, width_m, height_m, wall_m
    need(3 * w < min(L, W, H), "cardboard_box", "wall_m", "too thick for the size")
    if not open_top:
        outer = mk.rounded_box((L, W, H), min(0.002, w / 2), segments=1)
        inner = mk.box((L - 2 * w, W - 2 * w, H - 2 * w), max_len=max(0.015, min(L, W, H) / 6))
        holes = []
        for sx in (1, -1):
            hh = mk.extrude(mk.rounded_rect(0.08 * min(1.0, W / 0.2), 0.025, 0.0124), 4 * w)
            hh.apply_transform(np.array([[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]]))
            hh.apply_translation([sx * L / 2, 0, 0.3 * H])
            holes.append(hh)
        return finish(mk.difference(outer, [inner, *holes], tolerance=0.3 * w))
    ml = max(0.015, min(L, W, H) / 6)
    parts = [mk.box((L, W, w), center=(0, 0, w / 2), max_len=ml),
             mk.box((w, W, H), center=(L / 2 - w / 2, 0, H / 2), max_len=ml),
             mk.box((w, W, H), center=(-L / 2 + w / 2, 0, H / 2), max_len=ml),
             mk.box((L - 2 * w, w, H), center=(0, W / 2 - w / 2, H / 2), max_len=ml),
             mk.box((L - 2 * w, w, H), center=(0, -W / 2 + w / 2, H / 2), max_len=ml)]
    if flaps:
        a = math.radians(35.0)
        hf = W / 2 - 0.002
        for sgn in (1, -1):
            # long sides: hinge along x at y = +-W/2, tilted outwards about x
            f = mk.box((L - 0.002, w, hf), center=(0, -sgn * w / 2, hf / 2), max_len=ml)
            f.apply_transform(trimesh.transformations.rotation_matrix(-sgn * a, [1, 0, 0]))
            f.apply_translation([0, sgn * W / 2, H - 0.0015])
            parts.append(f)
            # short sides: hinge along y at x = +-L/2, tilted outwards about y
            f = mk.box((w, W - 0.002, hf), center=(-sgn * w / 2, 0, hf / 2), max_len=ml)
            f.apply_transform(trimesh.transformations.rotation_matrix(sgn * a, [0, 1, 0]))
            f.apply_translation([sgn * L / 2, 0, H - 0.0015])
            parts.append(f)
    m = mk.union(parts, tolerance=0.3 * w)
    return finish(m, [p.vertices for p in parts])
