"""The furnished room's acoustics: what the furniture adds to a shoebox.

Every furniture part of a room variant (the room file's parts, nothing else; not its decor: a
plant's leaves, a picture flat on a wall) is an acoustic object: a box (a cylinder is taken as
its bounding box's side and caps of its own area) whose exposed faces absorb with its
material's octave-band ``absorption`` (materials/objects.toml).
A face that rests on the floor or stands against a wall is not exposed, and it hides the floor
or wall behind it.

The late reverberation comes from the furnished room's total absorption and its mean free path:
the air's volume V' (the room less the parts' solid volume) and the furnished boundary S' (the
room's exposed walls, floor and ceiling plus every exposed furniture face), l = 4 V' / S'. The
renderer's reverberation time is Arau-Puchades' formula over that boundary (Acustica 65, 1988;
:meth:`FurnishedAcoustics.arau_rt60`): Eyring's for each pair of opposite faces (furniture
faces by the axis they look along), weighted geometrically by their areas. Chosen over
Eyring's over S' (:meth:`FurnishedAcoustics.rt60`; Kuttruff, Room Acoustics, 6th ed. 2017,
sec. 5.4) because home rooms put their absorption on one pair (a carpet or rug, upholstery low
down) under hard walls that reflect mostly specularly: there the energy left between the walls
decays more slowly than a diffuse field's. Measured against the ray tracer
(:mod:`fallgen.audio.raytrace`; tests/audio/test_furnished.py): a room absorbing only on its floor
with walls of scattering 0.1, rays 1.07-1.27 s (seeds), Arau 1.15 s, Eyring 0.63 s, Fitzroy
2.08 s; with diffuse walls rays 0.60 s and Eyring 0.63 s.

In the furnished variants the ray tracer's T30 at 500 Hz-1 kHz is 1.04-1.97 times this model's
RT60 (median 1.23; :data:`fallgen.audio.acoustics.RAYS_OVER_MODEL`). No closed form is
much closer: the rays over Eyring 1.09-2.40 (median 1.27), Sabine 1.01-2.17 (1.18), Fitzroy
0.99-1.69 (1.17, the least spread: 12 % in log against Arau's 15 %); every one ranks the
variants alike (Spearman 0.87-0.89 with the rays). Two causes, measured:
(1) the absorbers are irradiated less than the boundary's mean, which every statistical
formula assumes: with every face diffuse the rays still ring 2-36 % longer than Eyring over
the same boundary (median ~19 % over nine variants); in kitchen_galley-l1-m1 a rug under the
table and chairs takes 68 % of its alpha S, the curtains 74-78 %; in study_lounge-l1-m1 the
sofa's and armchairs' faces, facing each other, 87 %; (2) a field between hard parallel walls over an absorbing floor or ceiling
is not diffuse (kitchen_dining-l1-m1: all-diffuse rays 0.33 s = Eyring, with the surfaces'
scattering 0.51 s; study_lounge m2, study_office m1: 1.7-2.0 times the model). The model is
kept for rendering (cheap, and it ranks the rooms as the rays do); its deviation is the
reverberation goal's uncertainty, and the goal is judged on the rays.

The furniture also takes its share from the early reflections: a path of length r through the
furnished room meets furniture surfaces at a rate S_f / (4 V') per metre, each taking alpha_f of
the energy, which acts on the image sources (all but the direct sound) as a volume attenuation
m_f = A_f / (4 V') per metre (Kuttruff sec. 5.6, "scattering obstacles as a volume effect"),
so that the image sources and the late reverberation decay at the same rate where they meet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallgen.world.materials import OCTAVE_BANDS_HZ, MaterialLibrary


@dataclass(frozen=True, eq=False)
class Furnishing:
    """The furniture of a room variant as the acoustics sees it: one row per part (compared
    and hashed by identity: what is derived from it is kept per instance)."""

    names: tuple[str, ...]  # "<furniture id>/<part name>"
    center: np.ndarray  # (P, 3) room frame, m
    half: np.ndarray  # (P, 3) half sizes in the part's frame, m
    yaw: np.ndarray  # (P,) rad about +z
    absorption: np.ndarray  # (P, B)
    scattering: np.ndarray  # (P,)
    exposed_area: np.ndarray  # (P,) m^2 of faces open to the room
    #: (P, 3) the same by the room axis the faces look along (x, y, z)
    exposed_by_axis: np.ndarray
    #: (6,) m^2 of each room face (SHOEBOX_FACES order) that parts rest on or stand against
    covered: np.ndarray
    #: (P, 6) the open share of each face (+x, -x, +y, -y in the part's frame, bottom, top)
    face_open: np.ndarray | None = None

    @property
    def volume_m3(self) -> float:
        return float(np.prod(2 * self.half, axis=1).sum()) if len(self.names) else 0.0

    def absorption_area(self) -> np.ndarray:
        """(B,) equivalent absorption area of the exposed faces, m^2."""
        return (self.exposed_area[:, None] * self.absorption).sum(0)

    @staticmethod
    def empty(bands: int = len(OCTAVE_BANDS_HZ)) -> Furnishing:
        z = np.zeros((0, 3))
        return Furnishing((), z, z, np.zeros(0), np.zeros((0, bands)), np.zeros(0), np.zeros(0),
                          z, np.zeros(6))


def furnishing(variant, materials: MaterialLibrary, samples: int = 8) -> Furnishing:
    """The acoustic furniture of ``variant`` (a :class:`fallgen.world.rooms.RoomVariant`).

    A face's exposed share is measured on a ``samples`` x ``samples`` grid of points 1 cm in
    front of it: a point inside another part (a sofa's seat against its back, books on a
    board) or beyond a room face (a cabinet's back on the wall, a foot on the floor) is
    covered, and the latter covers that much of the room face."""
    lx, ly, lz = variant.size_m
    L = np.array([lx, ly, lz])
    rows = [(item, part) for item, part in variant.parts() if not part.decor]
    if not rows:
        return Furnishing.empty()
    center = np.array([p.box.center for _, p in rows], float)
    half = np.array([p.box.half for _, p in rows], float)
    yaw = np.array([p.box.yaw for _, p in rows], float)
    g = (np.arange(samples) + 0.5) / samples * 2 - 1  # face grid in [-1, 1]
    u, w = [a.ravel() for a in np.meshgrid(g, g, indexing="ij")]
    covered = np.zeros(6)
    areas, by_axis, shares = [], [], []
    # the other parts that can hold a point 1 cm in front of part k's faces (the rest hold
    # none of them: leaving them out of the test changes no verdict)
    near = parts_within(center, half, 0.05)
    for k, (item, part) in enumerate(rows):
        h = half[k]
        others = np.flatnonzero(near[k])
        if part.shape == "cylinder":
            r = h[0]
            side = 2 * math.pi * r * 2 * h[2]
            face = np.array([side / 4] * 4 + [math.pi * r * r] * 2)
        else:
            face = np.array([4 * h[1] * h[2]] * 2 + [4 * h[0] * h[2]] * 2
                            + [4 * h[0] * h[1]] * 2)
        open_area, share = np.zeros(6), np.zeros(6)
        for fi, (ax, sign) in enumerate(FACES):
            o = [a for a in range(3) if a != ax]
            local = np.zeros((len(u), 3))
            local[:, ax] = sign * (h[ax] + 0.01)
            local[:, o[0]] = u * h[o[0]]
            local[:, o[1]] = w * h[o[1]]
            pts = center[k] + to_room_frame(local, yaw[k])
            out_lo, out_hi = pts < 0, pts > L
            outside = (out_lo | out_hi).any(1)
            inside = inside_parts(pts, center[others], half[others], yaw[others]).any(1)
            free = ~outside & ~inside
            open_area[fi] = face[fi] * free.mean()
            share[fi] = free.mean()
            # the room faces this face rests on or stands against (SHOEBOX_FACES order)
            per_point = face[fi] / len(pts)
            for a in range(3):
                covered[2 * a] += per_point * out_lo[:, a].sum()
                covered[2 * a + 1] += per_point * out_hi[:, a].sum()
        areas.append(float(open_area.sum()))
        shares.append(share)
        fx = _faces_x(yaw[k], 0)  # the part's x faces look along the room's x
        by_axis.append((open_area[:2].sum() if fx else open_area[2:4].sum(),
                        open_area[2:4].sum() if fx else open_area[:2].sum(),
                        open_area[4:].sum()))
    mats = [materials.object(p.material) for _, p in rows]
    absorption = np.array([m.absorption for m in mats], float)
    areas = np.array(areas)
    # upholstery: its coefficients are per m^2 of the item's acoustical area (seating's way)
    seats: dict[str, list[int]] = {}
    for k, ((item, _), m) in enumerate(zip(rows, mats)):
        if m.absorption_per == "seating_area":
            seats.setdefault(item.id, []).append(k)
    items = {i.id: i for i, _ in rows}
    for item_id, ks in seats.items():
        exposed = areas[ks].sum()
        if exposed > 0:
            scale = acoustical_area_m2(items[item_id], (lx, ly)) / exposed
            absorption[ks] = np.minimum(absorption[ks] * scale, 1.0)
    return Furnishing(tuple(f"{i.id}/{p.name}" for i, p in rows), center, half, yaw,
                      absorption, np.array([m.scattering for m in mats], float), areas,
                      np.array(by_axis, float), covered, np.array(shares))


#: The strip along a seating area's free edges that absorbs with it (m): Beranek's
#: "acoustical area" (Concert Halls and Opera Houses, 2nd ed. 2004, after Kath & Kuhl 1965).
SEATING_EDGE_M = 0.5
#: A side of an item within this of a wall stands against it (not a free edge), m.
AGAINST_WALL_M = 0.1


def acoustical_area_m2(item, room_xy) -> float:
    """An upholstered item's acoustical area: its footprint plus SEATING_EDGE_M along each
    side of it that does not stand against a wall."""
    x, y, _, yaw = item.pose
    w, d = item.size[0], item.size[1]
    c, s = math.cos(yaw), math.sin(yaw)
    ux, uy = np.array([c, s]) * w / 2, np.array([-s, c]) * d / 2
    p = np.array([x, y])
    corners = [p - ux - uy, p + ux - uy, p + ux + uy, p - ux + uy]
    L = np.asarray(room_xy, float)
    free = 0.0
    for a, b in zip(corners, corners[1:] + corners[:1]):
        against = any((abs(a[ax] - wall) < AGAINST_WALL_M and abs(b[ax] - wall) < AGAINST_WALL_M)
                      for ax in range(2) for wall in (0.0, L[ax]))
        if not against:
            free += float(np.linalg.norm(b - a))
    return w * d + SEATING_EDGE_M * free



#: A part's six faces (+x, -x, +y, -y in its frame, bottom, top): the local axis each looks
#: along and which way.
FACES = ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, -1.0), (2, 1.0))


def to_room_frame(local: np.ndarray, yaw) -> np.ndarray:
    """Vectors in a part's frame (..., 3) rotated by ``yaw`` (broadcast) into the room's."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * local[..., 0] - s * local[..., 1], s * local[..., 0] + c * local[..., 1],
                     local[..., 2]], -1)


def in_part_frames(rel: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(N, P, 3) room-frame vectors (one per point and part) in the parts' frames (each
    rotated by -yaw_p about z)."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * rel[..., 0] + s * rel[..., 1], -s * rel[..., 0] + c * rel[..., 1],
                     rel[..., 2]], -1)


def parts_within(center: np.ndarray, half: np.ndarray, grow: float) -> np.ndarray:
    """(P, P) whether part j can hold a point within ``grow`` of part k (its box grown by
    ``grow``), j != k: their bounding spheres (about the centres, radius |half|) come within
    ``grow`` of each other. False: no such point lies inside part j (:func:`inside_parts`)."""
    radius = np.linalg.norm(half, axis=1)
    gap = np.linalg.norm(center[:, None] - center[None], axis=2)
    near = gap <= radius[:, None] + radius[None] + grow
    np.fill_diagonal(near, False)
    return near


def inside_parts(pts: np.ndarray, center: np.ndarray, half: np.ndarray, yaw: np.ndarray,
                 grow: float = 0.0) -> np.ndarray:
    """(N, P) whether each point lies inside each part (grown by ``grow``)."""
    local = in_part_frames(pts[:, None, :] - center[None], yaw)
    return (np.abs(local) < half[None] + grow).all(-1)


def slab_hits(p: np.ndarray, d: np.ndarray, center: np.ndarray, half: np.ndarray,
              yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the lines p[i] + t d[i] enter and leave each part: t_in, t_out (N, P; t_in >
    t_out: they miss it), the entry's per-axis parameters (N, P, 3) and d in the parts'
    frames (N, P, 3). A line parallel to a pair of faces is inside that slab or never."""
    lp = in_part_frames(p[:, None, :] - center[None], yaw)
    ld = in_part_frames(np.broadcast_to(d[:, None, :], lp.shape), yaw)
    h = half[None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-h - lp) / ld
        t2 = (h - lp) / ld
    flat = ld == 0
    inside = np.abs(lp) <= h
    lo = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    hi = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    return lo.max(-1), hi.min(-1), lo, ld


def _faces_x(yaw: float, axis: int) -> bool:
    """Whether the part's local x axis is (about) along the room's ``axis``: then its +-x
    faces face that way."""
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    return (c >= s) if axis == 0 else (s > c)


@dataclass(frozen=True)
class FurnishedAcoustics:
    """A shoebox's faces and its furniture: absorption areas, volume and mean free path,
    and the reverberation time they give."""

    size_m: tuple[float, float, float]
    wall_absorption: np.ndarray  # (6, B)
    furniture: Furnishing
    air_absorption_per_m: np.ndarray  # (B,)

    @property
    def volume_m3(self) -> float:
        """The furnished (free) volume: the room less the parts' solid volume."""
        return float(np.prod(self.size_m)) - self.furniture.volume_m3

    def wall_areas(self) -> np.ndarray:
        """(6,) exposed area of each room face."""
        lx, ly, lz = self.size_m
        full = np.array([ly * lz, ly * lz, lx * lz, lx * lz, lx * ly, lx * ly])
        return np.maximum(full - self.furniture.covered, 0.0)

    def surface_m2(self) -> float:
        return float(self.wall_areas().sum() + self.furniture.exposed_area.sum())

    def absorption_area(self) -> np.ndarray:
        """(B,) m^2: exposed walls plus exposed furniture faces (air not included)."""
        return self.wall_areas() @ self.wall_absorption + self.furniture.absorption_area()

    def mean_free_path_m(self) -> float:
        return 4 * self.volume_m3 / self.surface_m2()

    def rt60(self) -> np.ndarray:
        """(B,) Eyring's reverberation time of the furnished boundary and volume, s (the
        renderer uses :meth:`arau_rt60`)."""
        v, s = self.volume_m3, self.surface_m2()
        a = np.minimum(self.absorption_area() / s, 0.999999)
        return 0.161 * v / (-s * np.log1p(-a) + 4 * self.air_absorption_per_m * v)

    def axis_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """The boundary by the axis it faces (x, y, z): each pair of opposite room faces with
        the furniture faces looking that way; areas (3,) and absorption areas (3, B), m^2."""
        w = self.wall_areas()
        f = self.furniture
        s_i = np.array([w[0] + w[1], w[2] + w[3], w[4] + w[5]]) + f.exposed_by_axis.sum(0)
        a_i = np.stack([w[2 * i:2 * i + 2] @ self.wall_absorption[2 * i:2 * i + 2]
                        for i in range(3)]) + f.exposed_by_axis.T @ f.absorption
        return s_i, a_i

    def arau_rt60(self) -> np.ndarray:
        """(B,) Arau-Puchades' reverberation time (Acustica 65, 1988): Eyring's for each pair
        of opposite faces (x, y, z; furniture faces by the axis they look along), weighted
        geometrically by their areas, T = prod_i T_i^(S_i / S). For absorption concentrated
        on one pair (a carpeted floor under hard walls)."""
        v = self.volume_m3
        s_i, a_i = self.axis_pairs()
        s = s_i.sum()
        t = 1.0
        for i in range(3):
            al = np.minimum(a_i[i] / s_i[i], 0.999999)
            ti = 0.161 * v / (-s * np.log1p(-al) + 4 * self.air_absorption_per_m * v)
            t = t * ti ** (s_i[i] / s)
        return t

    def fitzroy_rt60(self) -> np.ndarray:
        """(B,) Fitzroy's (JASA 31, 1959): the three pairs' Eyring terms averaged by area,
        T = 0.161 V / S^2 sum_i S_i / (-ln(1 - alpha_i) + 4 m V / S)."""
        v = self.volume_m3
        s_i, a_i = self.axis_pairs()
        s = s_i.sum()
        m = 4 * self.air_absorption_per_m * v / s
        return 0.161 * v / s ** 2 * sum(
            s_i[i] / (-np.log1p(-np.minimum(a_i[i] / s_i[i], 0.999999)) + m) for i in range(3))

    def sabine_rt60(self) -> np.ndarray:
        v = self.volume_m3
        return 0.161 * v / (self.absorption_area() + 4 * self.air_absorption_per_m * v)

    def volume_attenuation_per_m(self) -> np.ndarray:
        """(B,) the furniture's take from a reflected path, per metre of it (intensity):
        -ln(1 - alpha_f) S_f / (4 V'), the rate at which a diffuse field's paths meet furniture
        faces times the energy each meeting takes."""
        f = self.furniture
        if not len(f.names):
            return np.zeros_like(self.air_absorption_per_m)
        take = -(f.exposed_area[:, None] * np.log1p(-np.minimum(f.absorption, 0.999))).sum(0)
        return take / (4 * self.volume_m3)
