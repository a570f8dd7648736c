"""Furniture in the way: occlusion and edge diffraction of the direct sound and the first
reflections.

A path (the direct sound, or a first-order reflection's two legs) that crosses a furniture part
is not cut: it bends around the part's nearest edge. Its detour delta (the shortest path from
one end to the other over a point of one of the part's twelve edges, less the straight line) is
a Fresnel number N = 2 delta f / c per octave band, and the band loses Maekawa's screen
attenuation in the form Kurze & Anderson fitted to it (Applied Acoustics 4, 1971):

    IL(N) = 5 + 20 log10( sqrt(2 pi N) / tanh(sqrt(2 pi N)) )  dB   (5 dB at grazing, N = 0)

capped at MAX_ATTENUATION_DB (beyond it the room's other paths carry the sound). A leg crossing
several parts loses the largest of their attenuations (one dominant edge; a second edge
would add less than its own screen's), the two legs of a reflection add theirs. A single edge of
a box is what the model takes: a path that has to go round two edges (over a thick cabinet)
is attenuated as if by the nearer one, so thick obstacles are under-attenuated rather than
over-attenuated.
"""

from __future__ import annotations

import math

import numpy as np

from fallgen.audio.furnished import Furnishing, slab_hits, to_room_frame

#: Above this the other paths of the room carry the sound (Maekawa's data reach ~24 dB).
MAX_ATTENUATION_DB = 24.0
#: Points per edge of a part where a path may bend (the detour's minimum over them).
EDGE_SAMPLES = 9


def maekawa_db(fresnel: np.ndarray) -> np.ndarray:
    """Kurze-Anderson's fit of Maekawa's screen attenuation at Fresnel number N >= 0 (dB);
    0 for N < 0 is not used here (an unblocked path is not attenuated at all)."""
    x = np.sqrt(2 * math.pi * np.maximum(np.asarray(fresnel, float), 1e-12))
    return np.minimum(5 + 20 * np.log10(x / np.tanh(x)), MAX_ATTENUATION_DB)


def crossings(a: np.ndarray, b: np.ndarray, f: Furnishing, margin: float = 1e-6
              ) -> np.ndarray:
    """(N, P) whether the segment a[i] -> b[i] passes through part p (an end inside a part
    counts as passing through only where the segment enters it past the end)."""
    t_in, t_out, _, _ = slab_hits(a, b - a, f.center, f.half, f.yaw)
    return (t_in <= t_out) & (t_out > margin) & (t_in < 1 - margin) & (t_in > margin)


def _edge_points(f: Furnishing, parts: np.ndarray) -> np.ndarray:
    """(len(parts), 12 * EDGE_SAMPLES, 3) points on the parts' edges, room frame."""
    s = (np.arange(EDGE_SAMPLES) + 0.5) / EDGE_SAMPLES * 2 - 1
    pts = []
    for ax in range(3):  # edges along local axis ax: the other two at +-1
        o = [k for k in range(3) if k != ax]
        for u in (-1.0, 1.0):
            for v in (-1.0, 1.0):
                p = np.zeros((EDGE_SAMPLES, 3))
                p[:, ax] = s
                p[:, o[0]] = u
                p[:, o[1]] = v
                pts.append(p)
    unit = np.concatenate(pts)  # (12 S, 3) in [-1, 1]^3
    h = f.half[parts][:, None, :] * 1.001
    loc = unit[None] * h
    return to_room_frame(loc, f.yaw[parts][:, None]) + f.center[parts][:, None, :]


def leg_attenuation_db(a: np.ndarray, b: np.ndarray, f: Furnishing,
                       bands_hz, c: float = 343.0, size_m=None) -> np.ndarray:
    """(N, B) attenuation (dB) of the legs a[i] -> b[i] by the parts they cross. With the
    room's ``size_m``, edges on (within 2 cm of) the floor, a wall or the ceiling are not
    ones a path can bend around."""
    out = np.zeros((len(a), len(bands_hz)))
    if not len(f.names) or not len(a):
        return out
    hit = crossings(a, b, f)
    rows, parts = np.nonzero(hit)
    if not len(rows):
        return out
    edges = _edge_points(f, parts)  # (K, E, 3)
    direct = np.linalg.norm(b[rows] - a[rows], axis=1)
    length = (np.linalg.norm(edges - a[rows][:, None], axis=2)
              + np.linalg.norm(edges - b[rows][:, None], axis=2))
    if size_m is not None:
        L = np.asarray(size_m, float)
        blocked = ((edges < 0.02) | (edges > L - 0.02)).any(-1)
        length = np.where(blocked, np.inf, length)
    detour = length.min(1) - direct
    detour = np.where(np.isfinite(detour), detour, 10.0)  # nowhere to bend: the cap
    fresnel = 2 * np.maximum(detour, 0.0)[:, None] * np.asarray(bands_hz)[None] / c
    il = maekawa_db(fresnel)  # (K, B)
    np.maximum.at(out, rows, il)
    return out


def path_gains(source: np.ndarray, listener: np.ndarray, images: np.ndarray,
               order: np.ndarray, size_m, f: Furnishing, bands_hz,
               c: float = 343.0) -> np.ndarray:
    """(N, B) amplitude factors of the arrivals from ``images`` (N, 3) of ``source``: the
    direct sound (order 0) and the first reflections (order 1, their two legs through the
    reflection point) lose the parts' diffraction attenuation; later ones are left alone
    (the furniture's statistical share acts on them)."""
    g = np.ones((len(images), len(bands_hz)))
    sel = np.flatnonzero(order <= 1)
    if not len(sel) or f is None or not len(f.names):
        return g
    src = np.asarray(source, float)
    lis = np.asarray(listener, float)
    L = np.asarray(size_m, float)
    legs, owner = [], []  # every leg of every path, and the path it belongs to
    for k, i in enumerate(sel):
        im = images[i]
        if order[i] == 0:
            legs.append((src, lis))
            owner.append(k)
        else:  # the wall it reflects on: the axis where the image left the room
            ax = int(np.argmax(np.abs(im - src)))
            wall = 0.0 if im[ax] < 0 else L[ax]
            t = (wall - im[ax]) / (lis[ax] - im[ax])
            q = im + t * (lis - im)
            legs += [(src, q), (q, lis)]
            owner += [k, k]
    leg_db = leg_attenuation_db(np.array([a for a, _ in legs]), np.array([b for _, b in legs]),
                                f, bands_hz, c, L)
    att = np.zeros((len(sel), len(bands_hz)))
    np.add.at(att, np.array(owner), leg_db)
    g[sel] = 10 ** (-np.minimum(att, MAX_ATTENUATION_DB) / 20)
    return g
