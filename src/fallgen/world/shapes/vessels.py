"""Turned (lathe) objects: vessels, bottles, glasses, cans, mills, candles.

Hollow vessels are one closed revolved profile with a real wall thickness, so that the mesh
volume times the material density is the object's mass. Open containers (cup, bowl, vase,
jug, wineglass) collide through wall sectors, a base and the handle; closed or narrow-necked
ones (bottle, can, mills, candles) through their convex hull.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
import trimesh
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry import box as sbox

from fallgen.world import meshkit as mk
from fallgen.world.shapes._core import Shape, finish, need, shape
from fallgen.world.shell import THIN_WALL_M, ThinShell


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def _wall_at(section: Polygon, z: float) -> tuple[float, float]:
    """Inner and outer radius of the outermost wall of a half section at height ``z``."""
    inter = section.intersection(LineString([(0.0, z), (10.0, z)]))
    segs = [g for g in getattr(inter, "geoms", [inter]) if g.length > 0]
    if not segs:
        raise ValueError(f"no wall at z = {z:.4f} m")
    seg = max(segs, key=lambda g: g.bounds[2])
    return seg.bounds[0], seg.bounds[2]


def _outer_normal(section: Polygon, z: float, dz: float = 1e-3) -> np.ndarray:
    r1 = _wall_at(section, z - dz)[1]
    r2 = _wall_at(section, z + dz)[1]
    n = np.array([1.0, -(r2 - r1) / (2.0 * dz)])
    return n / np.linalg.norm(n)


def _rotate_z(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.asarray(points) @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def side_handle(section: Polygon, z_top: float, z_bottom: float, reach: float,
                half_width: float, half_height: float, *, angle: float = 0.0,
                stations: int = 28, exponent: float = 2.5) -> mk.Sweep:
    """A D-shaped handle on the outer wall of a lathe section, at azimuth ``angle``.

    The handle is a cubic Bezier tube leaving the wall along its normal at ``z_top`` and
    ``z_bottom`` and reaching ``reach`` beyond the wall; its flat ends sit in the middle of the
    wall, so the union with the vessel never pokes into the cavity. Cross-section: ``half_width``
    across (tangential), ``half_height`` in the handle's plane.
    """
    ends = []
    for z in (z_top, z_bottom):
        ri, ro = _wall_at(section, z)
        ends.append((np.array([(ri + ro) / 2.0, z]), _outer_normal(section, z), ro))
    (p0, n0, ro0), (p3, n3, ro3) = ends
    k = (reach + max(ro0 - p0[0], ro3 - p3[0])) / 0.75
    p1, p2 = p0 + n0 * k, p3 + n3 * k
    t = np.linspace(0.0, 1.0, 400)[:, None]
    bez = (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t**2 * p2 + t**3 * p3
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(bez, axis=0), axis=1))])
    u = np.linspace(0.0, s[-1], stations + 1)
    pts = np.column_stack([np.interp(u, s, bez[:, 0]), np.zeros(len(u)), np.interp(u, s, bez[:, 1])])
    sw = mk.sweep(pts, half_width, half_height, normal=(0, 1, 0), exponent=exponent, caps="flat",
                  ring=20)
    return mk.Sweep(_rotate_z(sw.rings.reshape(-1, 3), angle).reshape(sw.rings.shape),
                    _rotate_z(sw.start, angle), _rotate_z(sw.end, angle))


def _vessel(lathe: mk.Lathe, *, tol: float, handle: mk.Sweep | None = None,
            handle_pieces: int = 3, warp=None) -> Shape:
    """Mesh + collision of an open vessel: wall sectors, base, optional handle."""
    body = lathe.mesh()
    pieces = lathe.pieces(tol, reserve=handle_pieces if handle is not None else 0,
                          with_mesh_vertices=warp is not None)
    if warp is not None:
        body = mk.warp(body, warp)
        pieces = [warp(p) for p in pieces]
    if handle is not None:
        body = mk.union([body, handle.mesh])
        pieces += handle.pieces(handle_pieces)
    return finish(body, pieces)


def _vessel_wall(t: np.ndarray, r_bottom: float, r_top: float, height: float,
                 bulge: float) -> np.ndarray:
    return np.column_stack([r_bottom + (r_top - r_bottom) * t + 4.0 * bulge * t * (1.0 - t),
                            height * t])


# ---------------------------------------------------------------------------------------------
# open vessels
# ---------------------------------------------------------------------------------------------
@shape("cup", bulge_m=(-0.02, 0.03))
def cup(*, height_m: float = 0.095, outer_diameter_m: float = 0.082,
        base_diameter_m: float = 0.078, bulge_m: float = 0.0, wall_m: float = 0.004,
        bottom_m: float = 0.006, handle: bool = True, handle_reach_m: float = 0.026,
        handle_width_m: float = 0.013, handle_thickness_m: float = 0.007) -> Shape:
    """Cup or mug: a turned shell (straight, tapered or bellied wall) with an optional handle.

    ``bulge_m`` pushes the middle of the wall out (tea cups) or in.
    """
    need(2.5 * wall_m < base_diameter_m / 2, "cup", "wall_m", "too thick for the base diameter")
    need(bottom_m < 0.5 * height_m, "cup", "bottom_m", "must be under half the height")
    need(handle_thickness_m < 0.5 * handle_reach_m + wall_m, "cup", "handle_thickness_m",
         "too thick for the handle reach")
    t = np.linspace(0.0, 1.0, 14)
    wall = _vessel_wall(t, base_diameter_m / 2, outer_diameter_m / 2, height_m, bulge_m)
    outer = mk.fillet_polyline(np.vstack([[0.0, 0.0], wall]),
                               [0.0, min(0.004, base_diameter_m / 8)] + [0.0] * len(t[1:]))
    lathe = mk.Lathe.hollow(outer, wall_m, bottom=bottom_m, rim_radius=0.45 * wall_m,
                            fillet=min(0.004, 0.25 * height_m), segments=48,
                            min_len=min(3e-4, wall_m / 3))
    h = None
    if handle:
        h = side_handle(lathe.section, 0.80 * height_m, 0.26 * height_m, handle_reach_m,
                        handle_width_m / 2, handle_thickness_m / 2)
    return _vessel(lathe, tol=max(0.002, wall_m), handle=h)


@shape("bowl")
def bowl(*, diameter_m: float = 0.15, height_m: float = 0.065, foot_diameter_m: float = 0.07,
         wall_m: float = 0.005, bottom_m: float = 0.006) -> Shape:
    """Bowl: a quarter-ellipse wall on a flat foot (cereal, soup, salad bowls)."""
    R, rb, H = diameter_m / 2, foot_diameter_m / 2, height_m
    need(rb < R, "bowl", "foot_diameter_m", "must be less than diameter_m")
    need(2.5 * wall_m < H, "bowl", "wall_m", "too thick for the height")
    phi = np.linspace(0.0, math.pi / 2, 16)
    wall = np.column_stack([rb + (R - rb) * np.sin(phi), H * (1.0 - np.cos(phi))])
    outer = np.vstack([[0.0, 0.0], wall])
    lathe = mk.Lathe.hollow(outer, wall_m, bottom=bottom_m, rim_radius=0.45 * wall_m,
                            fillet=0.004, segments=48, min_len=min(3e-4, wall_m / 3))
    return _vessel(lathe, tol=max(0.002, 0.8 * wall_m))


@shape("vase")
def vase(*, height_m: float = 0.25, base_diameter_m: float = 0.08,
         body_diameter_m: float = 0.12, neck_diameter_m: float = 0.06,
         mouth_diameter_m: float = 0.075, body_height_m: float = 0.095,
         neck_height_m: float = 0.20, wall_m: float = 0.005, bottom_m: float = 0.008) -> Shape:
    """Vase: a smooth (PCHIP) outline through base, belly (at ``body_height_m``), neck (at
    ``neck_height_m``) and mouth."""
    need(0 < body_height_m < neck_height_m < height_m, "vase", "neck_height_m",
         "need 0 < body_height_m < neck_height_m < height_m")
    need(2.5 * wall_m < min(neck_diameter_m, base_diameter_m) / 2, "vase", "wall_m",
         "too thick for the neck or base")
    zs = [0.0, body_height_m, neck_height_m, height_m]
    rs = [base_diameter_m / 2, body_diameter_m / 2, neck_diameter_m / 2, mouth_diameter_m / 2]
    wall = mk.pchip_curve(zs, rs, 28)
    outer = mk.fillet_polyline(np.vstack([[0.0, 0.0], wall]),
                               [0.0, 0.004] + [0.0] * len(wall[1:]))
    lathe = mk.Lathe.hollow(outer, wall_m, bottom=bottom_m, rim_radius=0.45 * wall_m,
                            fillet=0.004, segments=40, min_len=min(3e-4, wall_m / 3))
    return _vessel(lathe, tol=max(0.003, wall_m))


@shape("wineglass")
def wineglass(*, height_m: float = 0.20, bowl_height_m: float = 0.10,
              bowl_diameter_m: float = 0.085, rim_diameter_m: float = 0.068,
              stem_diameter_m: float = 0.008, foot_diameter_m: float = 0.075,
              foot_thickness_m: float = 0.003, wall_m: float = 0.0014) -> Shape:
    """Stemmed glass (wine, champagne): foot, stem and bowl in one closed revolved shell."""
    H, hb = height_m, bowl_height_m
    Rb, Rr, rs, Rf = bowl_diameter_m / 2, rim_diameter_m / 2, stem_diameter_m / 2, foot_diameter_m / 2
    need(hb < H - 0.02, "wineglass", "bowl_height_m", "leaves no room for stem and foot")
    need(rs < Rb and rs < Rf, "wineglass", "stem_diameter_m", "must be thinner than bowl and foot")
    need(Rr <= Rb, "wineglass", "rim_diameter_m", "must not exceed bowl_diameter_m")
    zb = H - hb  # bottom of the bowl
    zc = zb + 0.55 * hb  # widest point
    # lower bowl: quarter ellipse from the stem to the widest point; upper: narrowing to the rim
    phi0 = math.asin(min(0.999, rs / Rb))
    phi = np.linspace(phi0, math.pi / 2, 14)
    # scaled so that the ellipse meets the stem exactly at z = zb
    lower = np.column_stack([Rb * np.sin(phi), zc - (zc - zb) * np.cos(phi) / math.cos(phi0)])
    s = np.linspace(0.0, 1.0, 9)[1:]
    upper = np.column_stack([Rb + (Rr - Rb) * s**2, zc + (H - zc) * s])
    tf = foot_thickness_m
    foot = [[0.0, 0.0], [Rf, 0.0], [Rf, tf * 0.6], [0.55 * Rf, tf], [rs * 1.8, tf + 0.006]]
    outer = np.vstack([foot, [[rs, tf + 0.015], [rs, zb - 0.008]], lower, upper])
    outer = mk.fillet_polyline(outer, [0, 0.0008, 0.0, 0.0, 0.006, 0.006, 0.0]
                               + [0.0] * (len(outer) - 7))
    lathe = mk.Lathe.hollow(outer, wall_m, floor_z=zb + 2.5 * wall_m, rim_radius=0.45 * wall_m,
                            fillet=0.003, segments=40, min_len=min(3e-4, wall_m / 3))
    return _vessel(lathe, tol=0.003)


@shape("jug", spout_m=(0.0, 0.05))
def jug(*, height_m: float = 0.20, base_diameter_m: float = 0.10, body_diameter_m: float = 0.12,
        neck_diameter_m: float = 0.095, mouth_diameter_m: float = 0.105,
        wall_m: float = 0.0045, bottom_m: float = 0.007, spout_m: float = 0.014,
        handle_reach_m: float = 0.032, handle_width_m: float = 0.018,
        handle_thickness_m: float = 0.009) -> Shape:
    """Jug / pitcher: bellied turned shell, a pulled-out pouring lip (``spout_m``) at +x and a
    handle at -x."""
    H = height_m
    need(2.5 * wall_m < base_diameter_m / 2, "jug", "wall_m", "too thick for the base")
    zs = [0.0, 0.35 * H, 0.78 * H, H]
    rs = [base_diameter_m / 2, body_diameter_m / 2, neck_diameter_m / 2, mouth_diameter_m / 2]
    wall = mk.pchip_curve(zs, rs, 24)
    outer = mk.fillet_polyline(np.vstack([[0.0, 0.0], wall]), [0.0, 0.004] + [0.0] * len(wall[1:]))
    lathe = mk.Lathe.hollow(outer, wall_m, bottom=bottom_m, rim_radius=0.45 * wall_m,
                            fillet=0.004, segments=40, min_len=min(3e-4, wall_m / 3))
    h = side_handle(lathe.section, 0.84 * H, 0.30 * H, handle_reach_m, handle_width_m / 2,
                    handle_thickness_m / 2, angle=math.pi)
    z0 = 0.70 * H

    def spout(v: np.ndarray) -> np.ndarray:
        v = v.copy()
        th = np.arctan2(v[:, 1], v[:, 0])
        w = np.exp(-((th / 0.42) ** 2)) * mk.smoothstep(v[:, 2], z0, H) ** 2
        r = np.hypot(v[:, 0], v[:, 1])
        scale = np.where(r > 0, (r + spout_m * w) / np.maximum(r, 1e-12), 1.0)
        v[:, 0] *= scale
        v[:, 1] *= scale
        v[:, 2] += 0.25 * spout_m * w
        return v

    return _vessel(lathe, tol=max(0.003, wall_m), handle=h, warp=spout)


# ---------------------------------------------------------------------------------------------
# closed or narrow vessels (convex hull collision)
# ---------------------------------------------------------------------------------------------
@shape("bottle", punt_m=(0.0, 0.03), bead_m=(0.0, 0.01), bead_offset_m=(0.0, 0.2))
def bottle(*, height_m: float = 0.30, diameter_m: float = 0.076, neck_diameter_m: float = 0.029,
           neck_length_m: float = 0.085, shoulder_length_m: float = 0.065, wall_m: float = 0.0035,
           punt_m: float = 0.025, bead_m: float = 0.0015, bead_height_m: float = 0.011,
           bead_offset_m: float = 0.0) -> Shape:
    """Bottle (wine, beer, PET): body, S-shaped shoulder, neck with a bead ring ``bead_offset_m``
    below the mouth, and a domed punt ``punt_m`` deep in the base. Open mouth."""
    H, R, rn = height_m, diameter_m / 2, neck_diameter_m / 2
    zb = H - neck_length_m - shoulder_length_m
    need(zb > punt_m + 0.01, "bottle", "shoulder_length_m", "neck and shoulder leave no body")
    need(rn < R, "bottle", "neck_diameter_m", "must be less than diameter_m")
    need(2.5 * wall_m < rn, "bottle", "wall_m", "too thick for the neck")
    need(bead_offset_m + bead_height_m < neck_length_m, "bottle", "bead_offset_m",
         "bead must sit on the neck")
    rr = 0.8 * R
    phi = np.linspace(0.0, math.pi / 2, 8)
    base = np.column_stack([rr * np.sin(phi), punt_m * np.cos(phi)]) if punt_m > 0 else \
        np.array([[0.0, 0.0], [rr, 0.0]])
    s = np.linspace(0.0, 1.0, 12)
    shoulder = np.column_stack([rn + (R - rn) * (1 + np.cos(np.pi * s)) / 2,
                                zb + shoulder_length_m * s])
    zt = H - bead_offset_m  # top of the bead ring
    if bead_m == 0:
        neck = [[rn, H]]
    else:
        neck = [[rn, zt - bead_height_m - 0.0015], [rn + bead_m, zt - bead_height_m],
                [rn + bead_m, zt]]
        if bead_offset_m > 0:  # a flange below the mouth (PET support ring), then the finish
            neck += [[rn, zt - 0.0008], [rn, H]]
    outer = np.vstack([base, [[R, 0.0]], shoulder, neck])
    radii = np.zeros(len(outer))
    radii[len(base) - 1] = 0.004 if punt_m > 0 else 0.0
    radii[len(base)] = min(0.008, 0.3 * R)
    outer = mk.fillet_polyline(outer, radii)
    lathe = mk.Lathe.hollow(outer, wall_m, rim_radius=0.45 * wall_m,
                            segments=36 if wall_m > 0.001 else 32, min_len=min(5e-4, wall_m / 3))
    # a thin (PET) bottle's body below the shoulder, held round by the base and the shoulder
    shell = ThinShell.cylinder(R, zb, wall_m, (0.0, 0.0, zb / 2)) if wall_m <= THIN_WALL_M \
        else None
    return finish(lathe.mesh(), shell=shell)


@shape("soda_can")
def soda_can(*, diameter_m: float = 0.0662, height_m: float = 0.1222,
             lid_diameter_m: float = 0.0543, side_wall_m: float = 0.00012,
             end_wall_m: float = 0.0003, dome_m: float = 0.010, opened: bool = True) -> Shape:
    """Drink can (12 oz / 355 ml by default): necked body, domed base with a standing ring,
    lid recessed in its seam; thin aluminium shell (sides ``side_wall_m``, ends ``end_wall_m``).
    ``opened`` cuts the drinking opening in the lid (the empty can of the benchmark)."""
    R, H, rl = diameter_m / 2, height_m, lid_diameter_m / 2
    need(rl < R, "soda_can", "lid_diameter_m", "must be less than diameter_m")
    need(end_wall_m >= side_wall_m, "soda_can", "end_wall_m", "must be at least side_wall_m")
    rring = 0.74 * R
    phi = np.linspace(0.0, math.pi / 2, 10)
    dome = np.column_stack([0.93 * rring * np.sin(phi), 0.0015 + dome_m * np.cos(phi)])
    outer = np.vstack([
        dome,
        [[rring, 0.0], [rring + 0.002, 0.0], [R, 0.012], [R, H - 0.014],
         [rl + 0.0015, H - 0.0045], [rl + 0.0005, H - 0.0006], [rl - 0.0005, H],
         [rl - 0.0018, H - 0.0005], [rl - 0.0022, H - 0.006], [rl - 0.0035, H - 0.0062],
         [0.0, H - 0.0062]]])
    radii = np.zeros(len(outer))
    k = len(dome)
    radii[k - 1] = 0.001
    radii[k] = 0.0015
    radii[k + 1] = 0.0015
    radii[k + 2] = 0.004
    radii[k + 3] = 0.004
    radii[k + 4] = 0.002
    radii[k + 5:k + 8] = 0.0005
    outer = mk.fillet_polyline(outer, radii, max_step_deg=30)
    solid = mk.solid_section(outer)
    dz = end_wall_m - side_wall_m
    er = solid.buffer(-side_wall_m, quad_segs=2)
    cav = er.intersection(affinity.translate(er, yoff=dz)).intersection(affinity.translate(er, yoff=-dz))
    cav = mk.half_section(mk._single_polygon(cav, "can cavity"))
    inner = mk.section_profile(cav, min_len=5e-5)
    outer = np.asarray(shapely.simplify(LineString(outer), 5e-5).coords)
    inner = np.asarray(shapely.simplify(LineString(inner), 5e-5).coords)
    seg = 36
    out_m = mk.revolve(outer, seg, max_len=0.01)
    in_m = mk.revolve(inner, seg, max_len=0.01)
    in_m.invert()
    can = trimesh.util.concatenate([out_m, in_m])
    if opened:
        # tear-drop opening between the centre (tab rivet) and the seam
        drop = shapely.union_all([Point(0.72 * rl, 0.0).buffer(0.26 * rl, quad_segs=6),
                                  Point(0.36 * rl, 0.0).buffer(0.15 * rl, quad_segs=4)]).convex_hull
        hole = mk.extrude(drop, 0.006, max_len=0.004)
        hole.apply_translation([0.0, 0.0, H - 0.0062])
        can = mk.difference(can, hole, tolerance=0.3 * side_wall_m)
    # the straight side wall between the base's and the neck's seams, held round by the ends
    z0, z1 = 0.012, H - 0.014
    shell = ThinShell.cylinder(R, z1 - z0, side_wall_m, (0.0, 0.0, (z0 + z1) / 2)) \
        if side_wall_m <= THIN_WALL_M else None
    return finish(can, shell=shell)


@shape("pepper_mill")
def pepper_mill(*, height_m: float = 0.22, diameter_m: float = 0.058,
                waist_diameter_m: float = 0.044, head_diameter_m: float = 0.056,
                knob_diameter_m: float = 0.018) -> Shape:
    """Turned wooden pepper mill (solid): base, waisted body, grooved crown, finial knob."""
    H, R = height_m, diameter_m / 2
    need(waist_diameter_m <= diameter_m, "pepper_mill", "waist_diameter_m", "must not exceed diameter_m")
    need(knob_diameter_m < head_diameter_m, "pepper_mill", "knob_diameter_m", "must be less than head_diameter_m")
    zh = 0.74 * H  # crown (grinding head) starts
    body = mk.pchip_curve([0.0, 0.12 * H, 0.45 * H, zh - 0.012],
                          [R, R * 0.97, waist_diameter_m / 2, head_diameter_m / 2 * 0.93], 20)
    rh = head_diameter_m / 2
    kt = H - knob_diameter_m
    head = mk.pchip_curve([zh, zh + 0.35 * (kt - zh), kt - 0.006, kt],
                          [rh, rh * 1.0, rh * 0.55, knob_diameter_m * 0.3], 10)
    phi = np.linspace(-math.pi / 2 + 0.5, math.pi / 2, 10)
    kr = knob_diameter_m / 2
    knob = np.column_stack([kr * np.cos(phi), kt + kr + kr * np.sin(phi)])
    prof = np.vstack([[[0.0, 0.0]], body, [[rh * 0.90, zh - 0.006], [rh * 0.90, zh - 0.003]],
                      head, knob[:-1], [[0.0, H]]])
    radii = np.zeros(len(prof))
    radii[1] = 0.003
    prof = mk.fillet_polyline(prof, radii)
    return finish(mk.Lathe.solid(prof, 48).mesh())


@shape("pepper_grinder")
def pepper_grinder(*, height_m: float = 0.125, diameter_m: float = 0.056,
                   cap_height_m: float = 0.035, cap_diameter_m: float = 0.054,
                   wall_m: float = 0.0025, bottom_m: float = 0.007,
                   outlet_diameter_m: float = 0.008) -> Shape:
    """Jar grinder: straight body with a shoulder, a wide grinding cap on top and a small
    outlet hole through it (so the hollow body is open)."""
    H, R, Rc, hc = height_m, diameter_m / 2, cap_diameter_m / 2, cap_height_m
    need(hc < 0.6 * H, "pepper_grinder", "cap_height_m", "must be under 60% of the height")
    need(outlet_diameter_m / 2 < Rc - 3 * wall_m, "pepper_grinder", "outlet_diameter_m", "too large")
    zc = H - hc
    outer = np.array([[0.0, 0.0], [R, 0.0], [R, zc - 0.012], [0.86 * R, zc - 0.003],
                      [0.86 * R, zc], [Rc, zc], [Rc, H], [0.0, H]])
    outer = mk.fillet_polyline(outer, [0, 0.004, 0.006, 0.002, 0, 0.001, 0.004, 0])
    solid = mk.solid_section(outer)
    ri = 0.86 * R - wall_m
    cav = sbox(-ri, bottom_m, ri, zc - 0.012)
    cav = cav.union(mk.solid_section([[0.0, zc - 0.03], [R - wall_m, zc - 0.03],
                                      [R - wall_m, zc - 0.016], [ri, zc - 0.006],
                                      [ri, H - 3 * wall_m], [0.0, H - 3 * wall_m]]))
    ro = outlet_diameter_m / 2
    cav = cav.union(sbox(-ro, H - 3.5 * wall_m, ro, H + 0.01))
    sec = mk.round_section(solid.difference(cav), fillet=0.002, rim_radius=0.0005)
    lathe = mk.Lathe(mk.half_section(sec), 40, min_len=4e-4)
    return finish(lathe.mesh())


@shape("candle", tip_fraction=(0.0, 0.3))
def candle(*, diameter_m: float = 0.022, height_m: float = 0.25, top_diameter_m: float = 0.019,
           tip_fraction: float = 0.06, edge_radius_m: float = 0.001,
           wick_diameter_m: float = 0.0015, wick_length_m: float = 0.01) -> Shape:
    """Candle: taper (``top_diameter_m`` < ``diameter_m``, a rounded tip over ``tip_fraction``
    of the height) or pillar / tealight (equal diameters, no tip), with a wick on top."""
    R, rt, H = diameter_m / 2, top_diameter_m / 2, height_m
    need(rt <= R, "candle", "top_diameter_m", "must not exceed diameter_m")
    need(wick_diameter_m < rt, "candle", "wick_diameter_m", "must be thinner than the top")
    need(2 * edge_radius_m < min(rt, H / 2), "candle", "edge_radius_m", "too large")
    body_h = H - wick_length_m
    zt = body_h * (1.0 - tip_fraction)
    if tip_fraction > 0:
        phi = np.linspace(0.0, math.pi / 2, 7)[1:]
        tip = np.column_stack([rt * np.cos(phi) + (wick_diameter_m / 2) * np.sin(phi) * 0,
                               zt + (body_h - zt) * np.sin(phi)])
        tip = tip[tip[:, 0] > wick_diameter_m / 2 * 1.5]
        top = np.vstack([[[rt, zt]], tip, [[wick_diameter_m / 2 * 1.5, body_h]]])
    else:
        top = np.array([[rt, body_h], [wick_diameter_m / 2 * 1.5, body_h]])
    rw = wick_diameter_m / 2
    prof = np.vstack([[[0.0, 0.0], [R, 0.0]], top,
                      [[rw, body_h], [rw, H - rw], [0.0, H]]])
    radii = np.zeros(len(prof))
    radii[1] = edge_radius_m
    if tip_fraction == 0:
        radii[2] = edge_radius_m
    prof = mk.fillet_polyline(prof, radii, max_step_deg=30)
    return finish(mk.Lathe.solid(prof, 24 if diameter_m < 0.03 else 48, min_len=1e-4).mesh())
