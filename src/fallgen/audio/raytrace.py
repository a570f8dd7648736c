"""An acoustic ray tracer through a furnished shoebox: the reference for its reverberation.

Sound particles (rays) leave a point in every direction (uniformly on the sphere) with unit
energy in each octave band and travel at c. At a room face or a furniture part's face a ray
loses the face's absorption alpha_b and is reflected diffusely (Lambert's cosine law) with
probability equal to the face's scattering coefficient, specularly otherwise; air takes
exp(-m_b s) over a path s. The sound energy left in the room at time t is the sum of the rays'
energies, a diffuse receiver's squared impulse response; its Schroeder backward integral is the
energy decay curve and its T30 (the -5 to -35 dB slope, times 2) the reverberation time, as
ISO 3382-2 defines them. Compiled (numba), a ray at a time: the start points, directions
and a seed per ray for its reflections' own generator (splitmix64) come from the caller's
generator, so a trace is reproducible.

Finite faces scatter (``bands_hz`` given): a furniture face is a mirror only above the
frequency where its size spans the first Fresnel zone. Below Rindel's f_g = c a* / (2 (w cos
theta)^2) along each of its sides w, the specular reflection keeps K = f / f_g of the energy
(3 dB per octave per small side: Rindel, Applied Acoustics 19, 1986, as Odeon and Arup's
Strutt apply it, Delta L = 10 lg(K_a K_b)); the rest leaves diffusely (Christensen & Rindel's
reflection-based scattering, Forum Acusticum 2005: 1 - s = (1 - s_surface) K_a K_b). a* = 2 d1
d2 / (d1 + d2) with d1 the ray's path to the face and d2 the room's mean free path, the
expected next leg (:func:`fallgen.audio.reflections.specular_share`, the first reflections'
law). Room faces (2.4-6 m) keep their surfaces' own scattering. As the scattering then
depends on the band, each band's rays are traced on their own.

Checked (tests/audio/test_raytrace.py, test_furnished.py): Eyring within 10 % in uniform
diffuse rooms; pyroomacoustics' ray tracer within 3 % in a shoebox absorbing on its ceiling,
all-Lambert (0.57 against 0.55 s) and all-mirror (3.0 against 3.05 s).

Furniture parts are oriented boxes (:class:`fallgen.audio.furnished.Furnishing`); rays start
outside every part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from fallgen.audio.furnished import FurnishedAcoustics, Furnishing, inside_parts

C_SOUND = 343.0
#: A ray whose energy fell below this in every band it carries is dropped (-70 dB).
FLOOR_ENERGY = 1e-7


@dataclass(frozen=True)
class EnergyDecay:
    """The energy in the room (relative to the start) per band on a time grid; a band that was
    not traced is nan."""

    t_s: np.ndarray  # (T,)
    energy: np.ndarray  # (T, B)

    def db(self) -> np.ndarray:
        """(T, B) the Schroeder energy decay curves, dB re their start (ISO 3382-2)."""
        e = np.cumsum(self.energy[::-1], axis=0)[::-1]
        with np.errstate(invalid="ignore", divide="ignore"):
            return 10 * np.log10(np.maximum(e / e[:1], 1e-30))

    def t30(self) -> np.ndarray:
        """(B,) reverberation time from the decay curve's -5 to -35 dB range (a
        least-squares line), s; nan where it never reaches -35 dB or was not traced."""
        out = np.full(self.energy.shape[1], np.nan)
        traced = np.isfinite(self.energy).all(0)
        out[traced] = decay_time(self.t_s, self.db()[:, traced])
        return out


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
                dt_s: float = 0.002, source=None, c: float = C_SOUND,
                bands_hz=None, bands=None) -> EnergyDecay:
    """The energy decay of the furnished shoebox ``size_m`` (faces in SHOEBOX_FACES order:
    ``wall_absorption`` (6, B), ``wall_scattering`` (6,)), rays from ``source`` (default: a
    random free point per ray). With ``bands_hz`` (the B band centres) furniture faces also
    scatter by diffraction (module docstring) and each band of ``bands`` (indices; default
    all) is traced with ``n_rays`` rays of its own, the others left nan; without, the
    surfaces' coefficients alone, every band on the same rays."""
    L = np.asarray(size_m, float)
    wa = np.asarray(wall_absorption, float)
    ws = np.asarray(wall_scattering, float)
    air = np.asarray(air_absorption_per_m, float)
    B = wa.shape[1]
    n_t = int(math.ceil(t_max_s / dt_s)) + 1
    if bands_hz is None:
        grid = _trace(L, wa, ws, furniture, furniture.absorption, air, rng, n_rays, n_t, dt_s,
                      source, c, None, 0.0)
        return EnergyDecay(np.arange(n_t) * dt_s, grid)
    mfp = FurnishedAcoustics(tuple(L), wa, furniture, air).mean_free_path_m()
    grid = np.full((n_t, B), np.nan)
    for b in (range(B) if bands is None else bands):
        grid[:, b:b + 1] = _trace(L, wa[:, b:b + 1], ws, furniture,
                                  furniture.absorption[:, b:b + 1], air[b:b + 1], rng, n_rays,
                                  n_t, dt_s, source, c, float(bands_hz[b]), mfp)
    return EnergyDecay(np.arange(n_t) * dt_s, grid)


def _trace(L: np.ndarray, wa: np.ndarray, ws: np.ndarray, furniture: Furnishing,
           fa: np.ndarray, air: np.ndarray, rng: np.random.Generator, n_rays: int, n_t: int,
           dt_s: float, source, c: float, freq_hz: float | None, mfp: float) -> np.ndarray:
    """(n_t, B) energy per grid time of ``n_rays`` rays carrying the bands of ``wa`` (6, B)
    and ``fa`` (the parts' absorption, (P, B)); furniture faces scatter by diffraction at
    ``freq_hz`` (None: not). The start points and directions come from ``rng``, and so does
    a seed per ray for the compiled tracer's own generator (splitmix64) of its reflections."""
    if source is None:
        pos = _free_points(L, furniture, n_rays, rng)
    else:
        pos = np.tile(np.asarray(source, float), (n_rays, 1))
    d = rng.standard_normal((n_rays, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    seeds = rng.integers(0, 2 ** 63, n_rays, dtype=np.uint64)
    f = furniture

    def arr(x, *shape):
        return np.ascontiguousarray(x, float).reshape(shape) if shape else \
            np.ascontiguousarray(x, float)

    n_p = len(f.names)
    grid = _trace_kernel(
        arr(L), arr(wa), arr(ws), arr(f.center, n_p, 3), arr(f.half, n_p, 3),
        arr(np.cos(f.yaw)), arr(np.sin(f.yaw)), arr(fa, n_p, wa.shape[1]), arr(f.scattering),
        arr(air), pos, d, seeds, n_t, dt_s, c, -1.0 if freq_hz is None else float(freq_hz),
        mfp, FLOOR_ENERGY)
    return grid / n_rays


@njit(cache=True)
def _uniform(state: np.ndarray) -> float:
    """The next uniform in [0, 1) of a splitmix64 generator whose state is ``state[0]``."""
    state[0] += np.uint64(0x9E3779B97F4A7C15)
    z = state[0]
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return float(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def _trace_kernel(L, wa, ws, center, half, cyaw, syaw, fa, fs, air, pos0, dir0, seeds, n_t,
                  dt, c, freq, mfp, floor_e):
    """Every ray in turn: the nearest room or part face along it, its energy added to the
    grid over the segment, the face's absorption taken, then a Lambert (probability: the
    face's scattering, with its diffraction share at ``freq`` > 0 for a part's face) or a
    specular reflection."""
    n_rays, n_b, n_p = pos0.shape[0], wa.shape[1], center.shape[0]
    grid = np.zeros((n_t, n_b))
    t_max = (n_t - 1) * dt
    e = np.empty(n_b)
    state = np.zeros(1, np.uint64)
    p, v, n = np.empty(3), np.empty(3), np.empty(3)
    for r in range(n_rays):
        state[0] = seeds[r]
        for i in range(3):
            p[i], v[i] = pos0[r, i], dir0[r, i]
        e[:] = 1.0
        t = 0.0
        while True:
            # the room's faces
            dist, axis = np.inf, 0
            for i in range(3):
                if v[i] > 0:
                    di = (L[i] - p[i]) / v[i]
                elif v[i] < 0:
                    di = -p[i] / v[i]
                else:
                    continue
                if di < dist:
                    dist, axis = di, i
            face = 2 * axis + (1 if v[axis] > 0 else 0)
            n[:] = 0.0
            n[axis] = -1.0 if v[axis] > 0 else 1.0
            part, p_axis, p_sign = -1, 0, 0.0
            # the parts: slab test in each part's frame
            for k in range(n_p):
                cx, sx = cyaw[k], syaw[k]
                rx, ry, rz = p[0] - center[k, 0], p[1] - center[k, 1], p[2] - center[k, 2]
                lp0, lp1, lp2 = cx * rx + sx * ry, -sx * rx + cx * ry, rz
                lv0, lv1, lv2 = cx * v[0] + sx * v[1], -sx * v[0] + cx * v[1], v[2]
                t_in, t_out, ax_in, sg_in = -np.inf, np.inf, 0, 0.0
                ok = True
                for i in range(3):
                    lp = lp0 if i == 0 else (lp1 if i == 1 else lp2)
                    lv = lv0 if i == 0 else (lv1 if i == 1 else lv2)
                    h = half[k, i]
                    if lv == 0.0:
                        if abs(lp) > h:
                            ok = False
                            break
                        continue
                    t1, t2 = (-h - lp) / lv, (h - lp) / lv
                    lo, hi = (t1, t2) if t1 < t2 else (t2, t1)
                    if lo > t_in:
                        t_in, ax_in, sg_in = lo, i, (-1.0 if lv > 0 else 1.0)
                    if hi < t_out:
                        t_out = hi
                if ok and t_in <= t_out and t_in > 1e-9 and t_in < dist:
                    dist, part, p_axis, p_sign = t_in, k, ax_in, sg_in
            if part >= 0:
                ln = np.zeros(3)
                ln[p_axis] = p_sign
                cx, sx = cyaw[part], syaw[part]
                n[0], n[1], n[2] = cx * ln[0] - sx * ln[1], sx * ln[0] + cx * ln[1], ln[2]
                scat = fs[part]
                if freq > 0:  # the face's diffraction (Rindel's f_g along both sides)
                    d1 = max(dist, 1e-3)
                    a_star = 2 * d1 * mfp / (d1 + mfp)
                    cos = abs(v[0] * n[0] + v[1] * n[1] + v[2] * n[2])
                    keep = 1.0
                    for i in range(3):
                        if i != p_axis:
                            w = 2 * half[part, i] * cos
                            keep *= min(1.0, 2 * freq * w * w / (c * a_star))
                    scat = 1.0 - (1.0 - scat) * keep
            else:
                scat = ws[face]
            dist = max(dist, 1e-9)
            t1 = t + dist / c
            # the energy at every grid time inside [t, t1)
            k0 = int(np.ceil(t / dt - 1e-9))
            k1 = min(int(np.ceil(t1 / dt - 1e-9)), n_t)
            for kk in range(k0, k1):
                s = (kk * dt - t) * c
                for b in range(n_b):
                    grid[kk, b] += e[b] * np.exp(-air[b] * s)
            top = 0.0
            for b in range(n_b):
                a = fa[part, b] if part >= 0 else wa[face, b]
                e[b] *= np.exp(-air[b] * dist) * (1.0 - a)
                top = max(top, e[b])
            for i in range(3):
                p[i] += v[i] * dist + n[i] * 1e-7
            if _uniform(state) < scat:  # Lambert about n
                u1, u2 = _uniform(state), _uniform(state)
                rr, phi = np.sqrt(u1), 2 * np.pi * u2
                ax0 = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
                ta = np.cross(n, ax0)
                ta /= np.sqrt(ta[0] ** 2 + ta[1] ** 2 + ta[2] ** 2)
                tb = np.cross(n, ta)
                zc = np.sqrt(1 - u1)
                for i in range(3):
                    v[i] = rr * np.cos(phi) * ta[i] + rr * np.sin(phi) * tb[i] + zc * n[i]
            else:
                dot = v[0] * n[0] + v[1] * n[1] + v[2] * n[2]
                for i in range(3):
                    v[i] -= 2 * dot * n[i]
            t = t1
            if t1 >= t_max or top <= floor_e:
                break
    return grid


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
