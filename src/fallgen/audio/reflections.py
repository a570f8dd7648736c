"""First-order reflections off furniture faces: table tops, counters, a cabinet's side, a
shelf's back.

Every open face of a part at least ``MIN_FACE_M2`` large is a mirror: the source's image in its
plane is heard where the source and the listener are both in front of it and the line from the
image to the listener meets the face inside its rectangle. The reflection keeps
sqrt(1 - alpha_b) of the amplitude per octave band (the part's material), and a finite face
reflects low frequencies less: below f_g = c a* / (2 (w cos theta)^2) along each of its two
sides w (a* = 2 d1 d2 / (d1 + d2), d1 and d2 the legs, theta the angle of incidence) it keeps
K = f / f_g of the energy, 3 dB per octave per side shorter than the first Fresnel zone, 6 dB
per octave below both f_g (:func:`specular_share`; Rindel, "Attenuation of sound reflections
due to diffraction", Nordic Acoustical Meeting 1986; Rindel, Applied Acoustics 19, 1986; as
Odeon and Arup's Strutt apply it, Delta L = 10 lg(K_a K_b)). Its two legs bend around other
parts in the way (:mod:`fallgen.audio.occlusion`).

A source resting on a face (an object on a table) is its own image there: the face doubles its
pressure, as the floor doubles a source on the floor.
"""

from __future__ import annotations

import functools

import numpy as np

from fallgen.audio.furnished import FACES, Furnishing, to_room_frame
from fallgen.audio.occlusion import MAX_ATTENUATION_DB, leg_attenuation_db

#: Faces smaller than this reflect too little, and too high up, to matter (m^2): a chair's
#: seat (0.2 m^2) and more.
MIN_FACE_M2 = 0.2
#: A face at least this open (not against a wall, the floor or another part) reflects.
MIN_OPEN_SHARE = 0.5
#: A source up to this far behind a face's plane counts as on it (contacts lie on surfaces).
ON_FACE_M = 0.02


def specular_share(freq_hz, side_m, cos_theta, a_star_m, c: float = 343.0) -> np.ndarray:
    """The share of a reflection's energy a face of side ``side_m`` keeps in the specular
    direction at ``freq_hz`` (broadcast): K = min(1, f / f_g), f_g = c a* / (2 (w cos
    theta)^2) (module docstring): 1 at a* = 0 (a source on the face), 0 at grazing
    incidence."""
    w = np.asarray(side_m, float) * np.asarray(cos_theta, float)
    num = 2 * np.asarray(freq_hz, float) * w * w  # f / f_g = num / (c a*)
    den = c * np.asarray(a_star_m, float)
    num, den = np.broadcast_arrays(num, den)
    return np.minimum(1.0, np.divide(num, den, out=np.ones(num.shape), where=den > 0))


@functools.lru_cache(maxsize=16)
def _faces(f: Furnishing) -> tuple:
    """Per candidate face: part index, centre, outward normal, the two in-plane unit axes and
    half sizes (room frame). A room's furniture is fixed: kept per Furnishing (by identity),
    not rebuilt for every sound source."""
    out = []
    if not len(f.names):
        return ()
    share = f.face_open if f.face_open is not None else np.ones((len(f.names), 6))
    for k in range(len(f.names)):
        c, h = f.center[k], f.half[k]
        axes = to_room_frame(np.eye(3), f.yaw[k])  # the part's x, y, z in the room
        for fi, (ax, sign) in enumerate(FACES):
            o = [a for a in range(3) if a != ax]
            area = 4 * h[o[0]] * h[o[1]]
            if area < MIN_FACE_M2 or share[k, fi] < MIN_OPEN_SHARE:
                continue
            n = sign * axes[ax]
            out.append((k, c + n * h[ax], n, axes[o[0]], axes[o[1]], h[o[0]], h[o[1]]))
    return tuple(out)


def furniture_images(source, listener, f: Furnishing, size_m, bands_hz,
                     c: float = 343.0) -> tuple[np.ndarray, np.ndarray]:
    """The first-order images of ``source`` in the furniture's faces heard at ``listener``:
    positions (K, 3) and per-band reflection gains (K, B) (absorption, finite size, other
    parts in the way); distance and air are the caller's."""
    s = np.asarray(source, float)
    lis = np.asarray(listener, float)
    bands = np.asarray(bands_hz, float)
    pos, gains, legs = [], [], []
    for k, p0, n, u, v, hu, hv in _faces(f):
        ds, dl = float((s - p0) @ n), float((lis - p0) @ n)
        if ds < -ON_FACE_M or dl <= 0.0:
            continue
        ds = max(ds, 0.0)
        image = s - 2 * ds * n
        t = ds / (ds + dl)  # where the line image -> listener crosses the plane
        q = image + t * (lis - image)
        if abs((q - p0) @ u) > hu or abs((q - p0) @ v) > hv:
            continue
        d1, d2 = float(np.linalg.norm(q - s)), float(np.linalg.norm(lis - q))
        total = d1 + d2
        cos_t = dl / max(d2, 1e-9)
        a_star = 2 * d1 * d2 / max(total, 1e-9)
        # finite size: K = f / f_g of the energy below f_g, per side (a source on the face,
        # a* = 0, keeps all of it)
        keep = specular_share(bands[:, None], [2 * hu, 2 * hv], cos_t, a_star, c).prod(1)
        g = np.sqrt((1.0 - f.absorption[k]) * keep)
        pos.append(image)
        gains.append(g)
        legs += [(s, q), (q, lis)]
    if not pos:
        return np.zeros((0, 3)), np.zeros((0, len(bands)))
    # both legs of every reflection bend around the parts in their way, traced at once
    att = leg_attenuation_db(np.array([a for a, _ in legs]), np.array([b for _, b in legs]),
                             f, bands, c, size_m)
    att = att[0::2] + att[1::2]
    return np.array(pos), np.array(gains) * 10 ** (-np.minimum(att, MAX_ATTENUATION_DB) / 20)
