"""Appliances and gadgets: calculator, music player, toaster, headphones, watch, pen.

Things with electronics inside are closed shells whose wall thickness is chosen so that
volume x density gives a realistic mass (the inside is not modelled); where the real object
has an opening (a reset pin-hole, a headphone jack, toaster slots) it connects the inside to
the outside, so the mesh is one closed surface.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import Point
from shapely.geometry import box as sbox

from fallgen.world import meshkit as mk
from fallgen.world.shapes._core import Shape, finish, need, shape
from fallgen.world.shell import THIN_WALL_M, ThinShell


def _rot_y(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.asarray(points) @ np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _shell_slab(size: tuple[float, float, float], corner: float, edge: float, wall: float):
    L, W, H = size
    outer = mk.rounded_slab((L, W, H), corner, edge)
    inner = mk.rounded_slab((L - 2 * wall, W - 2 * wall, H - 2 * wall), max(corner - wall, 1e-4),
                            min(max(edge - wall, 1e-4), max(corner - wall, 1e-4)))
    return outer, inner


@shape("calculator", key_rows=(0, 10), key_cols=(0, 8))
def calculator(*, length_m: float = 0.155, width_m: float = 0.08, thickness_m: float = 0.016,
               wall_m: float = 0.003, key_rows: int = 7, key_cols: int = 5) -> Shape:
    """Pocket calculator: a closed plastic shell (``wall_m`` stands in for the internals) with
    a recessed display, a grid of raised keys and a reset pin-hole in the back."""
    L, W, H = length_m, width_m, thickness_m
    need(2.5 * wall_m < H, "calculator", "wall_m", "too thick for the thickness")
    need(W > 0.03 and L > 0.05, "calculator", "width_m", "too small for display and keys")
    outer, inner = _shell_slab((L, W, H), min(0.008, W / 5), min(0.003, H / 3), wall_m)
    disp = mk.rounded_box((0.24 * L, 0.8 * W, 0.002), 0.0008, segments=2,
                          center=(0.3 * L, 0.0, H / 2))
    hole = mk.rounded_cylinder(0.001, 3 * wall_m, segments=12, center=(0.0, 0.0, -H / 2))
    body = mk.difference(outer, [inner, disp, hole])
    parts = [body]
    if key_rows and key_cols:
        x0, x1 = -0.45 * L, 0.12 * L
        pitch_x, pitch_y = (x1 - x0) / key_rows, 0.84 * W / key_cols
        kx, ky = 0.72 * pitch_x, 0.75 * pitch_y
        for i in range(key_rows):
            for j in range(key_cols):
                c = (x0 + pitch_x * (i + 0.5), -0.42 * W + pitch_y * (j + 0.5), H / 2 + 0.0004)
                parts.append(mk.rounded_slab((kx, ky, 0.0024), min(0.0015, kx / 3), 0.0005,
                                             corner_segments=2, edge_segments=1, max_len=0.05,
                                             center=c))
        body = mk.union(parts)
    return finish(body)


@shape("music_player")
def music_player(*, length_m: float = 0.1035, width_m: float = 0.0618,
                 thickness_m: float = 0.0105, wall_m: float = 0.004,
                 wheel_diameter_m: float = 0.038, corner_radius_m: float = 0.009) -> Shape:
    """iPod-style player: a rounded slab shell with a screen recess, a click-wheel groove and a
    headphone jack (the opening into the shell) in the top edge."""
    L, W, H = length_m, width_m, thickness_m
    need(2.5 * wall_m < H, "music_player", "wall_m", "too thick for the thickness")
    need(wheel_diameter_m < 0.9 * W, "music_player", "wheel_diameter_m", "wider than the body")
    need(2 * corner_radius_m < W, "music_player", "corner_radius_m", "too large")
    outer, inner = _shell_slab((L, W, H), corner_radius_m, min(0.003, H / 3), wall_m)
    ring = Point(0, 0).buffer(wheel_diameter_m / 2, quad_segs=10).difference(
        Point(0, 0).buffer(wheel_diameter_m / 2 - 0.0012, quad_segs=10))
    groove = mk.extrude(ring, 0.0008)
    groove.apply_translation([-0.2 * L, 0.0, H / 2])
    sl = 0.9 * (L / 2 - 0.2 * L - wheel_diameter_m / 2) + 0.2 * L
    screen = mk.rounded_box((max(0.4 * L, sl), 0.85 * W, 0.0006), 0.0002, segments=1,
                            center=(L / 2 - 0.004 - max(0.4 * L, sl) / 2, 0.0, H / 2))
    jack = mk.rounded_cylinder(0.00175, 2 * wall_m + 0.004, segments=16)
    jack.apply_transform(np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1.0]]))
    jack.apply_translation([L / 2, 0.3 * W, 0.0])
    body = mk.difference(outer, [inner, groove, screen, jack], tolerance=1e-4)
    return finish(body)


@shape("toaster", slots=(1, 4))
def toaster(*, length_m: float = 0.28, width_m: float = 0.17, height_m: float = 0.19,
            wall_m: float = 0.0008, slots: int = 2, slot_length_m: float = 0.13,
            slot_width_m: float = 0.032) -> Shape:
    """Pop-up toaster: a sheet shell with rounded ends, ``slots`` bread slots cut through the
    top, a lever and a browning knob on one end."""
    L, W, H = length_m, width_m, height_m
    need(slot_length_m < 0.85 * L, "toaster", "slot_length_m", "too long for the body")
    need(slots * slot_width_m < 0.7 * W, "toaster", "slot_width_m", "slots do not fit the width")
    corner = min(0.035, 0.3 * W)
    outer, inner = _shell_slab((L, W, H), corner, 0.008, wall_m)
    cuts = [inner]
    pitch = W / slots
    for i in range(slots):
        y = -W / 2 + pitch * (i + 0.5)
        c = mk.extrude(mk.rounded_rect(slot_length_m, slot_width_m, 0.006), 0.03)
        c.apply_translation([0.0, y, H / 2])
        cuts.append(c)
    body = mk.difference(outer, cuts, tolerance=0.3 * wall_m)
    lever = mk.rounded_box((0.016, 0.032, 0.012), 0.003, segments=2,
                           center=(L / 2 + 0.006, 0.0, 0.2 * H))
    knob = mk.rounded_cylinder(0.012, 0.016, edge_radius=0.003, segments=24)
    knob.apply_transform(np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1.0]]))
    knob.apply_translation([L / 2 + 0.004, 0.0, -0.2 * H])
    body = mk.union([body, lever, knob], tolerance=0.3 * wall_m)
    shell = ThinShell("box", (L, W, H), wall_m) if wall_m <= THIN_WALL_M else None
    return finish(body, shell=shell)


@shape("headphones")
def headphones(*, cup_diameter_m: float = 0.084, cup_depth_m: float = 0.036,
               shell_m: float = 0.0025, head_width_m: float = 0.15, band_height_m: float = 0.16,
               band_width_m: float = 0.03, band_thickness_m: float = 0.007) -> Shape:
    """Over-ear headphones as worn (band up): two hollow ear cups with cushion rings facing each
    other and an elliptic headband whose narrowed ends plug into the cup tops."""
    R, d, w = cup_diameter_m / 2, cup_depth_m, shell_m
    need(2.5 * w < d, "headphones", "shell_m", "too thick for the cup depth")
    need(head_width_m > 2 * d, "headphones", "head_width_m", "cups would overlap")
    rs = R - 0.004  # shell radius; the cushion sticks out by 4 mm
    zr = d - 0.012  # shell rim (local z: 0 at the back, d at the cushion face)
    outer = mk.fillet_polyline(np.array([[0.0, 0.0], [rs - 0.004, 0.0], [rs, 0.01], [rs, zr]]),
                               [0, 0.006, 0.004, 0])
    shell = mk.hollow_section(outer, w, rim_radius=0.0)
    rin = 0.55 * R
    cush = sbox(rin, zr - 0.003, R, d)
    cush = cush.union(sbox(-R, zr - 0.003, -rin, d)).buffer(-0.004, quad_segs=3).buffer(0.004, quad_segs=3)
    sec = mk.round_section(shell.union(cush), fillet=0.0015, arc_segments=3)
    cup = mk.Lathe(mk.half_section(sec), 32, min_len=4e-4).mesh()
    X = head_width_m / 2 + d  # x of the cup backs
    cups = []
    for side in (1, -1):
        v = _rot_y(np.asarray(cup.vertices), -side * math.pi / 2) + [side * X, 0.0, 0.0]
        c = cup.copy()
        c.vertices = v
        if c.volume < 0:
            c.invert()
        cups.append(c)
    xa = X - 0.55 * d
    za = math.sqrt(max(rs**2 - 0.006**2, 0.0)) - 0.6 * w
    t = np.linspace(0.0, np.pi, 41)
    path = np.column_stack([xa * np.cos(t), np.zeros_like(t), za + band_height_m * np.sin(t)])
    u = np.abs(np.cos(t))
    hw = band_width_m / 2 * (1 - 0.6 * mk.smoothstep(u, 0.5, 0.98))
    band = mk.sweep(path, hw, band_thickness_m / 2, exponent=3.0, ring=20, caps="flat")
    m = mk.union([cups[0], cups[1], band.mesh], tolerance=0.3 * w)
    pieces = [np.asarray(cups[0].vertices), np.asarray(cups[1].vertices), *band.pieces(6)]
    return finish(m, pieces)


@shape("watch")
def watch(*, case_diameter_m: float = 0.038, case_thickness_m: float = 0.0105,
          strap_width_m: float = 0.019, strap_thickness_m: float = 0.0032,
          strap_length_m: float = 0.072) -> Shape:
    """Wristwatch lying on its back: turned case with bezel, domed crystal and crown; two flat
    straps (bracelet) leaving the lugs and curving down to the table."""
    R, H = case_diameter_m / 2, case_thickness_m
    need(strap_width_m < 1.2 * case_diameter_m, "watch", "strap_width_m", "wider than the case")
    need(strap_thickness_m < 0.6 * H, "watch", "strap_thickness_m", "thicker than the case")
    prof = np.array([[0.0, 0.0], [0.8 * R, 0.0], [R, 0.25 * H], [R, 0.72 * H],
                     [0.97 * R, 0.82 * H], [0.82 * R, 0.86 * H], [0.0, H]])
    prof = mk.fillet_polyline(prof, [0, 0.001, 0.001, 0.0008, 0.0004, 0.0004, 0])
    case = mk.Lathe.solid(prof, 48, min_len=1e-4).mesh()
    crown = mk.rounded_cylinder(0.002, 0.005, edge_radius=0.0006, segments=16)
    crown.apply_transform(np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1.0]]))
    crown.apply_translation([R + 0.0015, 0.0, 0.5 * H])
    parts = [case, crown]
    straps = []
    z0 = 0.45 * H
    for side in (1, -1):
        y = np.linspace(0.6 * R, R + strap_length_m, 24)
        z = strap_thickness_m / 2 + (z0 - strap_thickness_m / 2) * (1 - mk.smoothstep(y, R, R + 0.025))
        path = np.column_stack([np.zeros_like(y), side * y, z])
        s = mk.sweep(path, strap_width_m / 2, strap_thickness_m / 2, normal=(1, 0, 0),
                     exponent=6.0, ring=20, caps="round", cap_length=strap_thickness_m / 2)
        straps.append(s)
        parts.append(s.mesh)
    m = mk.union(parts, tolerance=1e-4)
    pieces = [np.vstack([case.vertices, crown.vertices])]
    for s in straps:
        pieces += s.pieces(2)
    return finish(m, pieces)


@shape("pen")
def pen(*, length_m: float = 0.145, diameter_m: float = 0.0085, wall_m: float = 0.0012,
        cap: bool = True, cap_length_m: float = 0.05, clip: bool = True) -> Shape:
    """Pen lying along x. With ``cap``: a tube open at the back end, the front covered by a
    wider cap (ballpoint). Without: a click pen, closed back with a push button, conical front
    with the tip opening. ``clip`` adds a pocket clip on top."""
    L, r = length_m, diameter_m / 2
    need(2.5 * wall_m < r, "pen", "wall_m", "too thick for the diameter")
    need(cap_length_m < 0.6 * L, "pen", "cap_length_m", "must be under 60% of the length")
    ri = r - wall_m
    if cap:
        rc = r + 0.0007
        zc = L - cap_length_m
        outer = np.array([[0.0, 0.0], [r, 0.0], [r, zc], [rc, zc], [rc, L - 0.002],
                          [0.7 * rc, L], [0.0, L]])
        outer = mk.fillet_polyline(outer, [0, 0.0004, 0.0002, 0.0003, 0.0015, 0.001, 0])
        sec = mk.solid_section(outer).difference(sbox(-ri, -0.01, ri, L - 0.012))
    else:
        zt = L - 0.02
        outer = np.array([[0.0, 0.0], [0.45 * r, 0.0], [0.45 * r, 0.005], [r, 0.0055], [r, zt],
                          [0.0012, L], [0.0, L]])
        outer = mk.fillet_polyline(outer, [0, 0.0006, 0.0002, 0.0005, 0.003, 0, 0])
        sec = mk.solid_section(outer).difference(sbox(-ri, 0.009, ri, zt - 0.002)).difference(
            sbox(-0.0007, zt - 0.003, 0.0007, L + 0.01))
        sec = sec.difference(mk.solid_section([[0.0, zt - 0.006], [ri, zt - 0.006], [ri, zt - 0.002],
                                                [0.0011, L - 0.004], [0.0, L - 0.004]]))
        rc = r
    sec = mk.round_section(sec, fillet=0.0003, arc_segments=2)
    body = mk.Lathe(mk.half_section(sec), 24, min_len=1e-4).mesh()
    parts = [body]
    if clip:
        z_top = L - 0.003 if cap else 0.0075  # starts inside the solid cap or back wall
        sgn = -1.0 if cap else 1.0
        zs = z_top + sgn * np.array([0.0, 0.003, 0.006, 0.02, 0.034, 0.04])
        xs = np.array([0.5 * rc, rc + 0.0008, rc + 0.0012, rc + 0.0011, rc + 0.0009, rc + 0.0006])
        path = np.column_stack([xs, np.zeros_like(xs), zs])
        clip_m = mk.sweep(path, 0.0016, 0.0005, normal=(0, 1, 0), exponent=4.0, ring=12,
                          caps="round").mesh
        parts.append(clip_m)
    m = mk.union(parts, tolerance=2e-4) if len(parts) > 1 else body
    # lying along x, clip on top
    m.vertices = np.asarray(m.vertices) @ np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    if m.volume < 0:
        m.invert()
    return finish(m)
