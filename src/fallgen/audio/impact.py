"""Dry (anechoic) impact sound from modal models: pressure in pascals at 1 m, free field.

An impulse J at a surface point x along the surface normal n, delivered as a Hertz-long force
pulse of duration t_c, drives mode i (angular frequency w_i, loss factor eta, decay rate
d_i = eta w_i / 2) to q_i(t) = (phi_i(x) . n) J S(w_i t_c) / w_d,i e^(-d_i t) sin(w_d,i t), with
S the pulse's normalised spectrum (1 for short pulses, small above ~1.5 / t_c). Each mode
radiates p_i(t) = R_i q_i(t), with R_i the pressure at 1 m per unit modal displacement, the
smaller of two classical estimates from the mode's surface motion (normal displacement times
area at the surface nodes):

- compact source (ka << 1): monopole + dipole,
  p = rho0 w^2 / (4 pi r) sqrt(Q^2 + k^2 |DIPOLE_FACTOR D|^2 / 3), Q = sum(a . phi) the net
  volume displacement, D = sum((a . phi)(x - c)) its first moment; the fluid's reaction on
  the moving surface (its added mass) adds half of D for a sphere: the dipole is 1.5 D, exact
  for the oscillating rigid sphere (Morse & Ingard 1968, 7.2), the sphere's factor used for
  every body;
- large source: every surface element radiates with efficiency 1,
  p = rho0 c w sqrt(sum(|a| (n . phi)^2) / (4 pi)) / r.

What a mode radiates also damps it: its loss factor is the material's plus its radiation's
(:meth:`SoundingBody.loss_factors`; a ceramic jug's 10 kHz mode radiates at 1.4 times the
rate its material damps it, and without this it would have radiated 1.4 times the energy it
held).

No normalisation anywhere: a faster or heavier impact is louder in absolute terms.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fallgen.audio.coupling import ringing_gains
from fallgen.audio.hertz import half_sine_spectrum
from fallgen.audio.hits import Hit, ModalHit, impulse_table, pulse_table
from fallgen.audio.modal_model import ModalModel
from fallgen.audio.phasors import powers

RHO_AIR = 1.204  # kg/m^3 at 20 C
C_AIR = 343.0  # m/s
REFERENCE_DISTANCE_M = 1.0
#: Modes are rendered until they have decayed by this much.
DECAY_FLOOR_DB = 80.0


def radiated_energy_j(pressure_1m: np.ndarray, sample_rate: int,
                      r: float = REFERENCE_DISTANCE_M) -> float:
    """Acoustic energy (J) of a dry signal, pressure (Pa) at ``r`` taken as the same in every
    direction: 4 pi r^2 / (rho0 c) * integral of p^2 dt (the RMS over directions is what the
    radiation factors give, so this is the energy the modes radiate)."""
    p = np.asarray(pressure_1m, float)
    return float(4 * math.pi * r * r / (RHO_AIR * C_AIR) * np.dot(p, p) / sample_rate)


@dataclass(frozen=True)
class SoundingBody:
    """One body that rings: its modes (scaled to its material and size) and what sets its
    damping and contact stiffness."""

    modes: ModalModel
    loss_factor: float
    #: the Young's modulus an impact on its surface meets (its material's
    #: ``contact_modulus_pa``: across the grain for wood), for the Hertz contact
    contact_modulus_pa: float
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

    @cached_property
    def _loss_factors(self) -> np.ndarray:
        w = self.modes.omega
        with np.errstate(divide="ignore", invalid="ignore"):
            rad = np.where(w > 0, 4 * math.pi * REFERENCE_DISTANCE_M ** 2 * self.radiation() ** 2
                           / (RHO_AIR * C_AIR * np.maximum(w, 1e-30) ** 3), 0.0)
        return self.loss_factor + rad

    def loss_factors(self) -> np.ndarray:
        """Each mode's loss factor: the material's plus what its sound carries away,
        eta_rad = 4 pi r^2 R_i^2 / (rho0 c w_i^3) (a mass-normalised mode holding energy
        w^2 q^2 / 2 radiates 4 pi r^2 R^2 q^2 / (2 rho0 c) at r = 1 m), so that a mode radiates
        the share eta_rad / (eta + eta_rad) of what it is given, never more."""
        return self._loss_factors


#: The dipole strength of a compact body over the first moment of its volume displacement:
#: 1.5 for a sphere (the volume it moves plus half of it, its added mass).
DIPOLE_FACTOR = 1.5


def radiation_factors(m: ModalModel, r: float = REFERENCE_DISTANCE_M) -> np.ndarray:
    """R_i of each mode: the smaller of the compact estimate and efficiency 1 (tested
    against the exact spheres and Wallace's baffled plate in tests/audio/test_radiation.py)."""
    Q, D, A = m.surface_moments()
    w = m.omega
    k = w / C_AIR
    p_low = RHO_AIR * w ** 2 / (4 * math.pi * r) \
        * np.sqrt(Q ** 2 + k ** 2 * DIPOLE_FACTOR ** 2 * (D ** 2).sum(1) / 3)
    p_high = RHO_AIR * C_AIR * w * np.sqrt(A / (4 * math.pi)) / r
    return np.minimum(p_low, p_high)


def rigid_body_pressure(volume_m3: float, mass_kg: float, hits: Sequence[Hit], n_out: int,
                        sample_rate: int, r: float = REFERENCE_DISTANCE_M) -> np.ndarray:
    """"Acceleration noise": a body jerked by a contact force F(t) radiates as the rigid
    sphere of its volume (radius a = (3 V / 4 pi)^(1/3)) oscillating with its velocity U,
    exactly (Morse & Ingard 1968, section 7.2; RMS over directions like the modal part):

        P(s) = rho0 a^3 / (2 c r sqrt(3)) * s^2 U(s) * 2 / (tau^2 s^2 + 2 tau s + 2),

    tau = a / c, U = F / (m s), F a half-sine pulse of the hit's impulse and duration. Below
    ka ~ 1 this is the compact dipole, p = rho0 (1.5 V) / (4 pi c r) da/dt / sqrt(3) (the
    sphere with its added mass); above, the pressure follows the surface velocity,
    p -> rho0 c a U / (r sqrt(3)), instead of growing with frequency as the dipole's would (a
    1 kg ceramic jug jolted in a 0.1 ms Hertz contact made 145 dB at 1 m as a dipole). This is
    most of the sound of a non-resonant body (a cushion, a foam ball) and the click of a hard
    one. The force is sampled as the impulse each sample interval receives; the filter is the
    bilinear transform of P / F, prewarped at its corner omega_0 = sqrt(2) / tau."""
    from scipy.signal import lfilter

    force, first, stop = _pushed(hits, n_out, sample_rate)
    if stop <= first:
        return force
    fs = float(sample_rate)
    a = (3.0 * volume_m3 / (4.0 * math.pi)) ** (1.0 / 3.0)
    tau = a / C_AIR
    gain = RHO_AIR * a ** 3 / (2.0 * C_AIR * r * math.sqrt(3.0)) / mass_kg
    w0 = math.sqrt(2.0) / tau
    # prewarp: the digital corner where the analogue one is (when below Nyquist)
    warp = w0 / (2 * fs * math.tan(w0 / (2 * fs))) if w0 < 0.9 * math.pi * fs else 1.0
    tau_w = tau * warp
    # P / F = gain * 2 s / (tau^2 s^2 + 2 tau s + 2)
    bz, az = bilinear_2nd_order((gain * 2.0, 0.0), (tau_w ** 2, 2.0 * tau_w, 2.0), fs)
    # the response dies away geometrically (as rho^n, rho the poles' radius): it is filtered
    # until it is RIGID_TAIL_DB below its start after the last pushed sample, and is zero
    # after (run on, the recursion would carry subnormal numbers, < 1e-307 Pa, to the end)
    end = min(n_out, stop + decay_samples(az, RIGID_TAIL_DB))
    out = np.zeros(n_out)
    out[first:end] = lfilter(bz, az, force[first:end])
    return out


#: How far the rigid-body noise's filter is run down after the last pushed sample (dB): 600
#: dB, 10^-30 of its level, is far under float64's resolution of anything it is mixed with.
RIGID_TAIL_DB = 600.0


def bilinear_2nd_order(b: tuple[float, float], a: tuple[float, float, float],
                       fs: float) -> tuple[np.ndarray, np.ndarray]:
    """The bilinear transform (s = 2 fs (1 - z^-1) / (1 + z^-1)) of the analogue filter
    (b[0] s + b[1]) / (a[0] s^2 + a[1] s + a[2]): the digital (b, a), a[0] = 1, in closed
    form (what ``scipy.signal.bilinear`` gives, without its polynomial objects)."""
    k = 2.0 * fs
    b1, b0 = b
    a2, a1, a0 = a
    num = np.array([b1 * k + b0, 2.0 * b0, b0 - b1 * k])
    den = np.array([a2 * k * k + a1 * k + a0, 2.0 * (a0 - a2 * k * k),
                    a2 * k * k - a1 * k + a0])
    return num / den[0], den / den[0]


def decay_samples(a: np.ndarray, drop_db: float) -> int:
    """Samples in which the free response of the recursion with denominator ``a`` (second
    order, a[0] = 1) falls by ``drop_db`` at its poles' radius (the polynomial factor of a
    double pole is allowed for with a margin of twice the samples)."""
    disc = a[1] * a[1] - 4.0 * a[2]
    if disc < 0:  # complex pair: |p|^2 = a[2]
        rho = math.sqrt(a[2])
    else:
        rho = max(abs(-a[1] + math.sqrt(disc)), abs(-a[1] - math.sqrt(disc))) / 2.0
    if rho >= 1.0:
        return 1 << 62
    if rho <= 0.0:
        return 2
    return 2 * int(math.ceil(drop_db / 20.0 * math.log(10.0) / -math.log(rho))) + 2


def force_signal(hits: Sequence[Hit], n_out: int, sample_rate: int) -> np.ndarray:
    """The hits' half-sine force pulses (N; :meth:`ModalHit.force_pulses`), each sample the
    mean force over its interval (the impulse it receives times the rate: every pulse's impulse
    exactly, however short)."""
    return _pushed(hits, n_out, sample_rate)[0]


def _pushed(hits: Sequence[Hit], n_out: int, sample_rate: int) -> tuple[np.ndarray, int, int]:
    """:func:`force_signal`, and the samples its pulses touch: every force sample outside
    [first, stop) is zero (first = stop = 0 when none is pushed)."""
    fs = float(sample_rate)
    force = np.zeros(n_out)
    i0, J, tc = pulse_table(hits, n_out, sample_rate)
    if not len(J):
        return force, 0, 0
    tc = np.maximum(tc, 1e-9)
    n = np.ceil(tc * fs).astype(int) + 1  # sample intervals each pulse touches
    hit = np.repeat(np.arange(len(J)), n)  # every interval, pulse by pulse
    j = np.arange(len(hit)) - np.repeat(np.cumsum(n) - n, n)  # interval within its pulse
    Jh, th = J[hit], tc[hit]
    # the impulse delivered up to the interval's start and its end (the last: all of it)
    start = 0.5 * Jh * (1.0 - np.cos(math.pi * np.minimum(j / fs, th) / th))
    end = np.where(j == n[hit] - 1, Jh,
                   0.5 * Jh * (1.0 - np.cos(math.pi * np.minimum((j + 1) / fs, th) / th)))
    at = i0[hit] + j
    ok = at < n_out
    np.add.at(force, at[ok], (end - start)[ok] * fs)
    return force, int(i0.min()), int(min(n_out, at.max() + 1))


def plate_pressure(mass_per_area_kg_m2: float, hits: Sequence[Hit], n_out: int,
                   sample_rate: int, r: float = REFERENCE_DISTANCE_M,
                   coincidence_hz: float | None = None, loss_factor: float = 0.05,
                   stiffness_ratio: float = 1.0) -> np.ndarray:
    """What a floor, wall or ceiling radiates where it is hit: an infinite thin plate of
    ``mass_per_area`` m'' and bending stiffness B, driven by the hits' force F, radiates into
    the room (Rayleigh's integral of its response F / (B (1 + i eta) kappa^4 - m'' w^2) at
    kappa = k sin(theta); Cremer, Heckl & Petersson, Structure-Borne Sound, 3rd ed. 2005, ch. 7)

        |p(theta, w)| = rho0 |F(w)| / (2 pi m'' r) / |1 - (f / f_c)^2 sin^4(theta) (1 + i eta)|,

    f_c = ``coincidence_hz``: below it the plate's near field, rho0 F / (2 pi m'' r) in every
    direction; around and above it its free bending waves radiate too (up to ~+13 dB near
    f_c for eta = 0.05), and far above it the pressure falls as f_c / f. The directions'
    mean square (:func:`coincidence_gain`) is applied as a minimum-phase filter (causal);
    ``coincidence_hz`` None: the near field alone; ``stiffness_ratio`` < 1: an orthotropic
    plate (timber boards), f_c its stiff direction's. The room's image of the surface doubles a
    source on it, so the dry signal is half of that: the free-field monopole
    rho0 F / (4 pi m'' r) (times the gain) whose image makes the plate's pressure in the room.
    The energy a hit leaves in the plate travels away into the rest of the surface (its slow
    ringing, the whole floor's, is not rendered). A real surface is supported: below its
    lowest modes (a room's floor or wall, tens of Hz) it does not move as a whole, so the
    infinite plate's net push is high-passed at ``SURFACE_LOWEST_HZ`` (second order,
    causal)."""
    from scipy.signal import butter, fftconvolve, sosfilt

    k = RHO_AIR / (4 * math.pi * mass_per_area_kg_m2 * r)
    force = force_signal(hits, n_out, sample_rate)
    if not force.any():
        return force
    sos = butter(2, SURFACE_LOWEST_HZ, "highpass", fs=sample_rate, output="sos")
    out = k * sosfilt(sos, force)
    if coincidence_hz is not None:
        fir = coincidence_filter(float(coincidence_hz), float(loss_factor), int(sample_rate),
                                 stiffness_ratio=float(stiffness_ratio))
        i0 = int(np.flatnonzero(force)[0])  # causal: nothing before the first hit, exactly
        out[i0:] = fftconvolve(out[i0:], fir)[:n_out - i0]
    return out


def coincidence_gain(f: np.ndarray, coincidence_hz: float, loss_factor: float,
                     n_angles: int = 4000, stiffness_ratio: float = 1.0) -> np.ndarray:
    """Mean over the half space of |1 - (f / f_c)^2 sin^4(theta) (1 + i eta)|^-2: the point-
    driven infinite plate's radiated power over its near field's (1 below coincidence).

    ``stiffness_ratio`` r = D_y / D_x < 1: an orthotropic plate (Huffington's form), whose
    coincidence frequency depends on the azimuth phi of the direction,
    f_c(phi) = f_c / (cos^2 phi + sqrt(r) sin^2 phi) (f_c: along its stiff direction); the
    near field is the same (it depends on m'' alone), so the gain is the azimuths' mean of the
    isotropic one."""
    f = np.asarray(f, float)
    if stiffness_ratio == 1.0:
        return _isotropic_gain(f / coincidence_hz, loss_factor, n_angles)
    # the isotropic gain is a function of f / f_c alone: tabulated on a fine log grid of it
    # (0.1 % steps, ~25x finer than the coincidence peak's width at eta 0.05) and read for
    # every (frequency, azimuth)
    phi = (np.arange(64) + 0.5) / 64 * math.pi / 2
    fcs = coincidence_hz / (np.cos(phi) ** 2 + math.sqrt(stiffness_ratio) * np.sin(phi) ** 2)
    x = f[:, None] / fcs[None, :]
    pos = x > 0
    lo, hi = np.log(x[pos].min()) - 1e-3, np.log(x.max()) + 1e-3
    grid = np.linspace(lo, hi, max(int((hi - lo) / 1e-3), 2))
    g = _isotropic_gain(np.exp(grid), loss_factor, n_angles)
    out = np.ones_like(x)  # f = 0: the near field
    out[pos] = np.interp(np.log(x[pos]), grid, g)
    return out.mean(1)


def _isotropic_gain(x: np.ndarray, loss_factor: float, n_angles: int) -> np.ndarray:
    """:func:`coincidence_gain` of an isotropic plate at f / f_c = ``x``."""
    th = (np.arange(n_angles) + 0.5) / n_angles * math.pi / 2
    out = np.empty(x.shape)
    # a few hundred frequencies at a time: the whole (frequency, angle) table of a filter's
    # 2049 x 4000 points took ~260 MB at once (a worker's peak memory)
    for i in range(0, len(x), 128):
        a = x[i:i + 128, None] ** 2
        den = np.abs(1 - a * np.sin(th)[None, :] ** 4 * (1 + 1j * loss_factor)) ** 2
        out[i:i + 128] = (np.sin(th)[None, :] / den).sum(1) * (math.pi / 2 / n_angles)
    return out


@functools.lru_cache(maxsize=64)
def coincidence_filter(coincidence_hz: float, loss_factor: float, sample_rate: int,
                       n_fft: int = 4096, stiffness_ratio: float = 1.0) -> np.ndarray:
    """A causal (minimum-phase) FIR whose gain is sqrt(:func:`coincidence_gain`)."""
    from scipy.signal import minimum_phase

    f = np.fft.rfftfreq(n_fft, 1.0 / sample_rate)
    g2 = coincidence_gain(f, coincidence_hz, loss_factor, stiffness_ratio=stiffness_ratio)
    # a linear-phase filter of gain g2; its homomorphic minimum-phase version has gain ~sqrt
    lin = np.roll(np.fft.irfft(g2, n_fft), n_fft // 2) * np.hanning(n_fft)
    return minimum_phase(lin, method="homomorphic", n_fft=4 * n_fft)


#: Below this a room surface does not radiate (its lowest modes: a floor's or wall's span of a
#: few metres).
SURFACE_LOWEST_HZ = 30.0


#: Samples per block of the modal synthesis.
BLOCK = 256
#: After the last hit a mode is dropped once its amplitude is DECAY_FLOOR_DB below the peak
#: amplitude of the body's loudest mode (so far): what is left is inaudible under the rest of the
#: body's own sound, and a quiet mode need not ring out its whole decay.
PRUNE = 10 ** (-DECAY_FLOOR_DB / 20)


def modal_sum(z: np.ndarray, c: np.ndarray, idx: np.ndarray, g: np.ndarray, n_out: int,
              block: int = BLOCK, out: np.ndarray | None = None) -> np.ndarray:
    """sum_i c_i Im(sum_h g_hi z_i^(n - n_h)) over samples n >= n_h: damped sinusoids started
    by impulses, computed block by block from each mode's complex state (after the last hit a
    mode whose amplitude is DECAY_FLOOR_DB below the loudest mode's peak is dropped).

    A block with hits in it is one small matrix product per hit; the blocks where the modes
    only ring on (between hits and after the last) are taken :data:`CHUNK` at a time, every
    block's states from the one before (the same products, in the same order, as block by
    block) and all their samples in one real matrix product.

    ``z``: (M,) per-sample complex factor e^((-d + i w_d) T); ``c``: (M,) output weights;
    ``idx``: (H,) start samples; ``g``: (H, M) gains (real: an impulse's modal velocities;
    complex: a state, see :func:`render`); ``out``: (n_out,) the sum is added to it (and
    returned); None: a new array."""
    out = np.zeros(n_out) if out is None else out
    order = np.argsort(idx, kind="stable")
    idx, g = idx[order], g[order] * c[None, :]
    live = c != 0
    z, idx_ok = z[live], idx < n_out
    idx, g = idx[idx_ok], g[idx_ok][:, live]
    if len(z) == 0 or len(idx) == 0:
        return out
    Z = powers(z, block)  # (M, B): z^0 .. z^(B-1)
    zB = Z[:, -1] * z
    # Im(s Z) = Re(s) Im(Z) + Im(s) Re(Z): the free blocks' samples as one real product
    W = np.concatenate([Z.imag, Z.real])  # (2M, B)
    s = np.zeros(len(z), complex)  # state at the start of the block (already weighted by c)
    peak = np.zeros(len(z))
    h, H = 0, len(idx)
    b0 = int(idx[0]) // block * block
    while h < H and b0 < n_out:
        hit_block = int(idx[h]) // block * block
        if hit_block > b0:  # blocks without a hit before the next one
            s = _free_blocks(s, zB, W, out, b0, (hit_block - b0) // block, block, peak)
            b0 = hit_block
            continue
        L = min(block, n_out - b0)
        h1 = int(np.searchsorted(idx, b0 + L, side="left"))
        y = (s @ Z[:, :L]).imag
        o = idx[h:h1] - b0
        gh = g[h:h1]  # (m, M)
        for j in range(h1 - h):
            y[o[j]:] += (gh[j] @ Z[:, :L - o[j]]).imag
        carry = (gh * (Z[:, block - o - 1].T * z[None, :])).sum(0)  # z^(block - o)
        h = h1
        out[b0:b0 + L] += y
        s = s * zB + carry
        np.maximum(peak, np.abs(s), out=peak)
        b0 += block
    if b0 >= n_out:
        return out
    # After the last hit each mode only decays: its block count until it is DECAY_FLOOR_DB
    # below the loudest mode's peak is known, so modes are sorted by it and each block sums
    # those still alive.
    a = np.abs(s)
    thr = PRUNE * max(float(peak.max()), float(a.max()))
    with np.errstate(divide="ignore"):
        n_live = np.where(a > thr, np.ceil(np.log(thr / np.maximum(a, 1e-300))
                                           / np.log(np.abs(zB))), 0).astype(int)
    order = np.argsort(-n_live, kind="stable")
    s, zB, n_live = s[order], zB[order], n_live[order]
    W = W.reshape(2, -1, block)[:, order].reshape(-1, block)
    n_blocks = min(int(n_live.max(initial=0)), -(-(n_out - b0) // block))
    _free_blocks(s, zB, W, out, b0, n_blocks, block, None, n_live)
    return out


#: Free-ringing blocks of :func:`modal_sum` summed in one matrix product.
CHUNK = 32


def _free_blocks(s: np.ndarray, zB: np.ndarray, W: np.ndarray, out: np.ndarray, b0: int,
                 n_blocks: int, block: int, peak: np.ndarray | None,
                 n_live: np.ndarray | None = None) -> np.ndarray:
    """Add ``n_blocks`` blocks of freely ringing modes to ``out`` from sample ``b0`` (as
    far as it goes) and return the state after them. ``s``: (M,) the modes' states, ``zB``:
    their factor over a block, ``W``: (2M, B) [Im; Re] of their powers over a block; ``peak``
    (updated) takes every block's end state's magnitude; ``n_live`` (descending): mode i is
    summed in the first n_live[i] blocks only."""
    m = len(s)
    for k0 in range(0, n_blocks, CHUNK):
        a = b0 + k0 * block
        if a >= len(out):
            break
        K = min(CHUNK, n_blocks - k0)
        if n_live is not None:
            m = int(np.searchsorted(-n_live, -k0, side="left"))  # modes with n_live > k0
            if m == 0:
                break
        # the states at the start of each block and after the last: s, s zB, s zB^2, ...
        S = np.empty((K + 1, m), complex)
        S[0] = s[:m]
        S[1:] = zB[:m]
        np.multiply.accumulate(S, axis=0, out=S)
        P = S[:K]
        if n_live is not None:
            P = np.where(np.arange(k0, k0 + K)[:, None] < n_live[None, :m], P, 0)
        y = np.concatenate([P.real, P.imag], axis=1) @ np.concatenate(
            [W[:m], W[len(s):len(s) + m]])
        n = min(K * block, len(out) - a)
        out[a:a + n] += y.ravel()[:n]
        if peak is not None:
            np.maximum(peak, np.abs(S[1:]).max(0), out=peak)
        s = s.copy()
        s[:m] = S[K]
    return s


def render(body: SoundingBody, hits: Sequence[Hit], length_s: float,
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
    eta = body.loss_factors()[keep]
    d = eta * w / 2
    wd = w * np.sqrt(np.maximum(1 - (eta / 2) ** 2, 1e-6))
    R = body.radiation()[keep]
    # modal impulses per hit (sparse: a hit is one sample per mode); a train's impulses share
    # its point, direction and duration, so their gains differ by the impulse alone
    tab = impulse_table(hits, n_out, sample_rate)
    if not tab.items:
        return out
    # hits share few points (a scrape's bumps all land on its contact point): one nearest-node
    # search per distinct point
    first: dict[tuple[float, ...], int] = {}
    which = [first.setdefault(tuple(np.asarray(h.point, float).ravel()), len(first))
             for h in tab.items]
    nodes = m.nearest(np.array(list(first)))[which]
    n_dir = np.array([m.normal(nd) if h.direction is None else np.asarray(h.direction, float)
                      for nd, h in zip(nodes, tab.items)])  # (I, 3)
    phi = m.shapes[nodes][:, :, keep].astype(float) * m.shape_factor  # (I, 3, n)
    # the pulse spectrum depends on omega * duration only
    spectrum = half_sine_spectrum(w[None, :] * tab.duration[:, None], 1.0)
    g = np.einsum("hc,hcn->hn", n_dir, phi)[tab.item] * tab.impulse[:, None] \
        * spectrum[tab.item]
    coupled = [k for k, h in enumerate(tab.items)
               if isinstance(h, ModalHit) and h.modal_state is not None]
    if coupled:  # ringing from the state the contact left
        g = g.astype(complex)
        for k in coupled:
            q0, v0, _ = tab.items[k].modal_state
            g[tab.start[k]] = ringing_gains(q0[keep], v0[keep], wd, d)  # its one impulse
    T = 1.0 / sample_rate
    z = np.exp((-d + 1j * wd) * T)
    modal_sum(z, R / wd, tab.sample, g, n_out, out=out)
    return out
