"""Dry (anechoic) impact sound from modal models: pressure in pascals at 1 m, free field.

An impulse J at a surface point x along the surface normal n, delivered as a Hertz-long force
pulse of duration t_c, drives mode i (angular frequency w_i, loss factor eta, decay rate
d_i = eta w_i / 2) to q_i(t) = (phi_i(x) . n) J S(w_i t_c) / w_d,i e^(-d_i t) sin(w_d,i t), with
S the pulse's normalised spectrum (1 for short pulses, small above ~1.5 / t_c). Each mode
radiates p_i(t) = R_i q_i(t), with R_i the pressure at 1 m per unit modal displacement, the
smaller of two classical estimates from the mode's surface motion (normal displacement times
area at the surface nodes):

- compact source (ka << 1): monopole + dipole, p = rho0 w^2 / (4 pi r) sqrt(Q^2 + k^2 |D|^2 / 3),
  Q = sum(a . phi) the net volume displacement, D = sum((a . phi)(x - c)) its first moment;
- large source: every surface element radiates with efficiency 1,
  p = rho0 c w sqrt(sum(|a| (n . phi)^2) / (4 pi)) / r.

No normalisation anywhere: a faster or heavier impact is louder in absolute terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fallgen.audio.hertz import half_sine_spectrum
from fallgen.audio.modes import ModalModel

RHO_AIR = 1.204  # kg/m^3 at 20 C
C_AIR = 343.0  # m/s
REFERENCE_DISTANCE_M = 1.0
#: Modes are rendered until they have decayed by this much.
DECAY_FLOOR_DB = 80.0


@dataclass(frozen=True)
class SoundingBody:
    """One body that rings: its modes (scaled to its material and size) and what sets its
    damping and contact stiffness."""

    modes: ModalModel
    loss_factor: float
    youngs_modulus_pa: float
    poisson_ratio: float
    mass_kg: float
    contact_radius_m: float

    @cached_property
    def _radiation(self) -> np.ndarray:
        return radiation_factors(self.modes)

    def radiation(self) -> np.ndarray:
        """R_i: pressure (Pa) at 1 m per metre of modal displacement, per mode (computed once
        per body)."""
        return self._radiation


def radiation_factors(m: ModalModel, r: float = REFERENCE_DISTANCE_M) -> np.ndarray:
    Q, D, A = m.surface_moments()
    w = m.omega
    k = w / C_AIR
    p_low = RHO_AIR * w ** 2 / (4 * math.pi * r) * np.sqrt(Q ** 2 + k ** 2 * (D ** 2).sum(1) / 3)
    p_high = RHO_AIR * C_AIR * w * np.sqrt(A / (4 * math.pi)) / r
    return np.minimum(p_low, p_high)


@dataclass(frozen=True)
class ModalHit:
    """An impulse on a body: when, where (body frame), along which unit direction (body frame;
    None = the surface normal there), how strong, and how long the force pulse lasts."""

    time_s: float
    point: np.ndarray
    impulse_ns: float
    duration_s: float
    direction: np.ndarray | None = None


def rigid_body_pressure(volume_m3: float, mass_kg: float, hits: list[ModalHit], n_out: int,
                        sample_rate: int, r: float = REFERENCE_DISTANCE_M) -> np.ndarray:
    """"Acceleration noise": a body jerked by a contact force radiates as a dipole,
    p(t) = rho0 (1.5 V) / (4 pi c r) da/dt / sqrt(3) (a sphere with its added mass, RMS over
    directions like the modal part), with
    a(t) = F(t) / m and F a half-sine pulse of the hit's impulse and duration. This is most of
    the sound of a non-resonant body (a cushion, a foam ball) and the click of a hard one."""
    out = np.zeros(n_out)
    k = RHO_AIR * 1.5 * volume_m3 / (4 * math.pi * C_AIR * r) / mass_kg / math.sqrt(3)
    for hit in hits:
        tc = max(hit.duration_s, 1.0 / sample_rate)
        i0 = int(round(hit.time_s * sample_rate))
        n = max(2, int(math.ceil(tc * sample_rate)) + 1)
        if i0 >= n_out or hit.impulse_ns <= 0:
            continue
        t = np.arange(n) / sample_rate
        on = t <= tc
        # dF/dt of F = (pi J / (2 tc)) sin(pi t / tc), band-limited by sampling at the pulse
        dF = np.where(on, (math.pi * hit.impulse_ns / (2 * tc)) * (math.pi / tc)
                      * np.cos(math.pi * t / tc), 0.0)
        if tc * sample_rate < 4:  # shorter than the sample grid: keep the net zero, scale down
            dF = dF * (tc * sample_rate / 4)
        m = min(n, n_out - i0)
        out[i0:i0 + m] += k * dF[:m]
    return out


#: Samples per block of the modal synthesis.
BLOCK = 512
#: A mode is dropped once it has decayed DECAY_FLOOR_DB below its own peak (and no hit is left).
PRUNE = 10 ** (-DECAY_FLOOR_DB / 20)


def modal_sum(z: np.ndarray, c: np.ndarray, idx: np.ndarray, g: np.ndarray, n_out: int,
              block: int = BLOCK) -> np.ndarray:
    """sum_i c_i Im(sum_h g_hi z_i^(n - n_h)) over samples n >= n_h: damped sinusoids started
    by impulses, computed block by block from each mode's complex state (one small matrix
    product per block for all live modes; after the last hit a mode that has decayed by
    DECAY_FLOOR_DB below its own peak is dropped).

    ``z``: (M,) per-sample complex factor e^((-d + i w_d) T); ``c``: (M,) output weights;
    ``idx``: (H,) start samples; ``g``: (H, M) real gains."""
    out = np.zeros(n_out)
    order = np.argsort(idx, kind="stable")
    idx, g = idx[order], g[order] * c[None, :]
    live = c != 0
    z, idx_ok = z[live], idx < n_out
    idx, g = idx[idx_ok], g[idx_ok][:, live]
    if len(z) == 0 or len(idx) == 0:
        return out
    k = np.arange(block)
    Z = z[:, None] ** k[None, :]  # (M, B)
    zB = z ** block
    s = np.zeros(len(z), complex)  # state at the start of the block (already weighted by c)
    peak = np.zeros(len(z))
    h, H = 0, len(idx)
    b0 = int(idx[0]) // block * block
    while b0 < n_out:
        L = min(block, n_out - b0)
        h1 = int(np.searchsorted(idx, b0 + L, side="left"))
        act = np.nonzero(s)[0]
        y = (s[act] @ Z[act, :L]).imag if len(act) else np.zeros(L)
        carry = 0.0
        if h1 > h:
            o = idx[h:h1] - b0
            gh = g[h:h1]  # (m, M)
            for j in range(h1 - h):
                y[o[j]:] += (gh[j] @ Z[:, :L - o[j]]).imag
            carry = (gh * (z[None, :] ** (block - o)[:, None])).sum(0)
            h = h1
        out[b0:b0 + L] = y
        s = s * zB + carry
        a = np.abs(s)
        np.maximum(peak, a, out=peak)
        if h >= H:  # no more hits: drop modes that have died away
            s[a < PRUNE * peak] = 0.0
        if h >= H and not s.any():
            break
        b0 += block
    return out


def render(body: SoundingBody, hits: list[ModalHit], length_s: float,
           sample_rate: int = 44100, volume_m3: float | None = None) -> np.ndarray:
    """Pressure at 1 m (Pa, float64) of ``body`` ringing from ``hits``, ``length_s`` long.

    Each mode's response to a hit is e^(-d t) sin(w_d t) / w_d exactly at the samples (what an
    impulse-invariant two-pole resonator computes), summed over modes and hits by
    :func:`modal_sum`. With ``volume_m3`` the body's rigid-body acceleration noise is added."""
    n_out = int(round(length_s * sample_rate))
    out = np.zeros(n_out)
    if volume_m3 is not None:
        out += rigid_body_pressure(volume_m3, body.mass_kg, hits, n_out, sample_rate)
    m = body.modes
    nyq = 0.45 * sample_rate * 2 * math.pi
    keep = (m.omega > 2 * math.pi * 20) & (m.omega < nyq)
    if not keep.any() or not hits:
        return out
    w = m.omega[keep]
    d = body.loss_factor * w / 2
    wd = w * np.sqrt(np.maximum(1 - (body.loss_factor / 2) ** 2, 1e-6))
    R = body.radiation()[keep]
    # modal impulses per hit (sparse: a hit is one sample per mode)
    idx, gains = [], []
    for hit in hits:
        i0 = int(round(hit.time_s * sample_rate))
        if i0 >= n_out or hit.impulse_ns <= 0:
            continue
        node = m.nearest(hit.point)
        phi = m.shapes[node][:, keep].astype(float)  # (3, n)
        n = m.normal(node) if hit.direction is None else np.asarray(hit.direction, float)
        idx.append(i0)
        gains.append((n @ phi) * hit.impulse_ns * half_sine_spectrum(w, hit.duration_s))
    if not idx:
        return out
    idx_a, g = np.asarray(idx), np.asarray(gains)  # (H,), (H, n)
    T = 1.0 / sample_rate
    z = np.exp((-d + 1j * wd) * T)
    out += modal_sum(z, R / wd, idx_a, g, n_out)
    return out
