"""An acoustic ray tracer through a furnished shoebox: the reference for its reverberation.

Sound particles (rays) leave a point in every direction (uniformly on the sphere) with unit
energy in each octave band and travel at c. At a room face or a furniture part's face a ray
loses the face's absorption alpha_b and is reflected diffusely (Lambert's cosine law) with
probability equal to the face's scattering coefficient, specularly otherwise; air takes
exp(-m_b s) over a path s. The sound energy left in the room at time t is the sum of the rays'
energies: its decay is the room's energy decay curve (the Schroeder integral of a diffuse
field's impulse response has the same slope), and its T30 (the -5 to -35 dB slope, times 2) is
the reverberation time (ISO 3382-2). Vectorised over rays; the generator is the caller's.

Furniture parts are oriented boxes (:class:`fallgen.audio.furnished.Furnishing`); rays start
outside every part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallgen.audio.furnished import Furnishing, inside_parts, slab_hits, to_room_frame

C_SOUND = 343.0


@dataclass(frozen=True)
class EnergyDecay:
    """The energy in the room (relative to the start) per band on a time grid."""

    t_s: np.ndarray  # (T,)
    energy: np.ndarray  # (T, B)

    def db(self) -> np.ndarray:
        return 10 * np.log10(np.maximum(self.energy / self.energy[:1], 1e-30))

    def t30(self) -> np.ndarray:
        """(B,) reverberation time from the decay's -5 to -35 dB range (a least-squares
        line), s; nan where it never reaches -35 dB."""
        return decay_time(self.t_s, self.db())


def decay_time(t: np.ndarray, db: np.ndarray, top: float = -5.0, bottom: float = -35.0
               ) -> np.ndarray:
    """(B,) 60 dB decay time of the least-squares line through each column of ``db`` (T, B)
    between ``top`` and ``bottom`` dB below its start (T30 by default)."""
    out = np.full(db.shape[1], np.nan)
    for b in range(db.shape[1]):
        d = db[:, b] - db[0, b]
        i0 = np.argmax(d <= top)
        below = np.flatnonzero(d <= bottom)
        if d[i0] > top or not len(below) or below[0] - i0 < 3:
            continue
        sel = slice(i0, below[0] + 1)
        slope = np.polyfit(t[sel], d[sel], 1)[0]
        if slope < 0:
            out[b] = -60.0 / slope
    return out


def trace_decay(size_m, wall_absorption: np.ndarray, wall_scattering: np.ndarray,
                furniture: Furnishing, air_absorption_per_m: np.ndarray,
                rng: np.random.Generator, n_rays: int = 3000, t_max_s: float = 1.5,
                dt_s: float = 0.002, source=None, c: float = C_SOUND) -> EnergyDecay:
    """The energy decay of the furnished shoebox ``size_m`` (faces in SHOEBOX_FACES order:
    ``wall_absorption`` (6, B), ``wall_scattering`` (6,)), rays from ``source`` (default: a
    random free point per ray)."""
    L = np.asarray(size_m, float)
    wa = np.asarray(wall_absorption, float)
    ws = np.asarray(wall_scattering, float)
    air = np.asarray(air_absorption_per_m, float)
    B = wa.shape[1]
    n_t = int(math.ceil(t_max_s / dt_s)) + 1
    grid_e = np.zeros((n_t, B))
    # start points
    if source is None:
        pos = _free_points(L, furniture, n_rays, rng)
    else:
        pos = np.tile(np.asarray(source, float), (n_rays, 1))
    d = rng.standard_normal((n_rays, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    e = np.ones((n_rays, B))
    t = np.zeros(n_rays)
    alive = np.arange(n_rays)
    floor_e = 1e-7  # a ray below -70 dB in every band is dropped
    while len(alive):
        p, v = pos[alive], d[alive]
        # the room's faces: the exit distance along each axis
        with np.errstate(divide="ignore", invalid="ignore"):
            tw = np.where(v > 0, (L - p) / v, np.where(v < 0, -p / v, np.inf))
        axis = np.argmin(tw, axis=1)
        dist = tw[np.arange(len(p)), axis]
        face = 2 * axis + (v[np.arange(len(p)), axis] > 0)  # west/east, south/north, floor/ceil
        normal = np.zeros_like(p)
        normal[np.arange(len(p)), axis] = np.where(v[np.arange(len(p)), axis] > 0, -1.0, 1.0)
        absb = wa[face]
        scat = ws[face]
        if len(furniture.names):
            tb, nb, part = _hit_boxes(p, v, furniture)
            closer = tb < dist
            dist = np.where(closer, tb, dist)
            normal[closer] = nb[closer]
            absb = np.where(closer[:, None], furniture.absorption[part], absb)
            scat = np.where(closer, furniture.scattering[part], scat)
        dist = np.maximum(dist, 1e-9)
        t0 = t[alive]
        t1 = t0 + dist / c
        _accumulate(grid_e, t0, t1, e[alive], air, c, dt_s)
        e_new = e[alive] * np.exp(-np.outer(dist, air)) * (1.0 - absb)
        pos_new = p + v * dist[:, None] + normal * 1e-7
        # reflection: Lambert with probability scat, specular otherwise
        spec = v - 2 * (v * normal).sum(1, keepdims=True) * normal
        diff = _lambert(normal, rng)
        dnew = np.where((rng.random(len(p)) < scat)[:, None], diff, spec)
        pos[alive], d[alive], e[alive], t[alive] = pos_new, dnew, e_new, t1
        keep = (t1 < t_max_s) & (e_new.max(1) > floor_e)
        alive = alive[keep]
    return EnergyDecay(np.arange(n_t) * dt_s, grid_e / n_rays)


def _accumulate(grid: np.ndarray, t0: np.ndarray, t1: np.ndarray, e: np.ndarray,
                air: np.ndarray, c: float, dt: float) -> None:
    """Add each ray's energy at every grid time inside its segment [t0, t1)."""
    k0 = np.ceil(t0 / dt - 1e-9).astype(int)
    k1 = np.minimum(np.ceil(t1 / dt - 1e-9).astype(int), len(grid))
    n = np.maximum(k1 - k0, 0)
    if not n.sum():
        return
    ray = np.repeat(np.arange(len(t0)), n)
    k = np.repeat(k0, n) + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n))
    s = (k * dt - t0[ray]) * c  # path travelled within the segment
    val = e[ray] * np.exp(-np.outer(s, air))
    np.add.at(grid, k, val)


def _lambert(normal: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Cosine-weighted directions about each unit ``normal``."""
    n = len(normal)
    u1, u2 = rng.random(n), rng.random(n)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u1)], 1)
    a = np.where(np.abs(normal[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    t1 = np.cross(normal, a)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(normal, t1)
    return local[:, :1] * t1 + local[:, 1:2] * t2 + local[:, 2:] * normal


def _hit_boxes(p: np.ndarray, v: np.ndarray, f: Furnishing
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The nearest entry into a furniture part along each ray: distance (inf: none), the
    face's outward normal (room frame) and the part's index."""
    t_in, t_out, lo, lv = slab_hits(p, v, f.center, f.half, f.yaw)
    hit = (t_in <= t_out) & (t_in > 1e-9)
    t_in = np.where(hit, t_in, np.inf)
    part = np.argmin(t_in, axis=1)
    rows = np.arange(len(p))
    dist = t_in[rows, part]
    ax = np.argmax(lo[rows, part], axis=1)  # the entry face's axis (part frame)
    sign = -np.sign(lv[rows, part, ax])
    nl = np.zeros((len(p), 3))
    nl[rows, ax] = sign
    return dist, to_room_frame(nl, f.yaw[part]), part


def _free_points(L: np.ndarray, f: Furnishing, n: int, rng: np.random.Generator
                 ) -> np.ndarray:
    """``n`` uniform points of the room outside every part (and 5 cm from its faces)."""
    out = np.zeros((0, 3))
    while len(out) < n:
        q = rng.random((2 * n, 3)) * (L - 0.1) + 0.05
        if len(f.names):
            q = q[~inside_parts(q, f.center, f.half, f.yaw, grow=0.05).any(1)]
        out = np.concatenate([out, q])
    return out[:n]
