"""The ambient noise floor of a quiet home, at the two ears.

No room is silent: a fridge, ventilation, traffic through the windows. Quiet homes measure
~25-35 dB(A) (WHO, Guidelines for Community Noise, 1999: 30 dB(A) for undisturbed sleep;
night-time levels in bedrooms of 20-35 dB(A) in surveys), so a fall too faint to rise above
that says nothing, and an agent trained on digital silence meets a noise floor first thing on
a real robot. The default floor here is 30 dB(A).

Spectrum: the "neutral" background of ANSI/ASA S12.2 (Room Criterion, RC Mark II), levels
falling 5 dB per octave with frequency, band-limited to 20 Hz - 16 kHz (smooth edges). Between
the ears the field is diffuse: the two ears' noise has the diffuse-field coherence of two points
``EAR_SPACING_M`` apart, sin(k d) / (k d) (coherent at low frequency, independent above ~1 kHz).
Level: the A-weighted (IEC 61672-1) equivalent level over the clip, the mean of both ears'
powers, set exactly. Drawn from the episode's generator: reproducible.
"""

from __future__ import annotations

import functools
import math

import numpy as np

#: Default ambient level, dB(A) re 20 uPa.
DEFAULT_NOISE_DB_A = 30.0
#: Spectral slope of the neutral background (ANSI/ASA S12.2 RC Mark II), dB per octave.
SLOPE_DB_PER_OCTAVE = -5.0
BAND_HZ = (20.0, 16000.0)
#: Distance between the ears (twice the spherical head's radius).
EAR_SPACING_M = 0.175
C_AIR = 343.0


def a_weighting_db(f_hz: np.ndarray) -> np.ndarray:
    """IEC 61672-1 A-weighting (dB; 0 at 1 kHz; -inf at 0 Hz)."""
    f2 = np.asarray(f_hz, float) ** 2
    with np.errstate(divide="ignore"):
        ra = (12194.0 ** 2 * f2 ** 2) / ((f2 + 20.6 ** 2) * np.sqrt((f2 + 107.7 ** 2)
                                          * (f2 + 737.9 ** 2)) * (f2 + 12194.0 ** 2))
        return 20 * np.log10(ra) + 2.0


@functools.lru_cache(maxsize=8)
def _a_weights(n: int, sample_rate: int) -> np.ndarray:
    """Per one-sided bin of an ``n``-sample spectrum: its A-weighting (power) times its
    Parseval count (the bins but DC and Nyquist count twice); read-only."""
    f = np.fft.rfftfreq(n, 1.0 / sample_rate)
    twice = np.full(len(f), 2.0)
    twice[0] = 1.0
    if n % 2 == 0:
        twice[-1] = 1.0
    w = 10 ** (a_weighting_db(f) / 10) * twice
    w.flags.writeable = False
    return w


def _a_weighted_mean_square(spec: np.ndarray, n: int, sample_rate: int) -> float:
    """The A-weighted mean square (Pa^2) of (R, n // 2 + 1) one-sided spectra of R signals of
    ``n`` samples, the mean over the rows."""
    power = np.abs(spec) ** 2 * _a_weights(n, sample_rate)
    return float(np.sum(power)) / (len(spec) * n * n)


def db_a(pressure_pa: np.ndarray, sample_rate: int) -> float:
    """A-weighted equivalent level (dB(A)) of a (..., T) pressure signal over its length, the
    mean power of its rows."""
    p = np.atleast_2d(np.asarray(pressure_pa, float))
    ms = _a_weighted_mean_square(np.fft.rfft(p, axis=-1), p.shape[-1], sample_rate)
    return 10 * math.log10(max(ms, 1e-30) / 4e-10)


@functools.lru_cache(maxsize=8)
def _shaping(n: int, sample_rate: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per clip length: the spectrum's shape, the ears' coherence and the share of
    independent noise (read-only)."""
    f = np.fft.rfftfreq(n, 1.0 / sample_rate)
    lo, hi = BAND_HZ
    with np.errstate(divide="ignore"):
        shape = np.where(f > 0, (np.maximum(f, 1e-9) / 1000.0)
                         ** (SLOPE_DB_PER_OCTAVE / (20 * math.log10(2))), 0.0)
    # raised-cosine edges over an octave at each end of the band
    edge_lo = np.clip(np.log2(np.maximum(f, 1e-9) / lo), 0, 1)
    edge_hi = np.clip(np.log2(hi / np.maximum(f, 1e-9)), 0, 1)
    shape *= np.sin(0.5 * math.pi * edge_lo) ** 2 * np.sin(0.5 * math.pi * edge_hi) ** 2
    coh = np.sinc(2 * f * EAR_SPACING_M / C_AIR)  # sin(k d) / (k d)
    rest = np.sqrt(np.maximum(1 - coh ** 2, 0.0))
    for a in (shape, coh, rest):
        a.flags.writeable = False
    return shape, coh, rest


def ambient_noise(n: int, sample_rate: int, level_db_a: float, rng: np.random.Generator
                  ) -> np.ndarray:
    """(2, n) ear pressures (Pa, row 0 the left ear) of the ambient noise floor at
    ``level_db_a`` (see the module's doc)."""
    m = n // 2 + 1
    shape, coh, rest = _shaping(n, sample_rate)
    x = rng.standard_normal((2, m)) + 1j * rng.standard_normal((2, m))
    left = x[0]
    right = coh * x[0] + rest * x[1]
    spec = np.vstack([left, right]) * shape
    ms = _a_weighted_mean_square(spec, n, sample_rate)
    scale = math.sqrt(4e-10 * 10 ** (level_db_a / 10) / max(ms, 1e-300))
    return np.fft.irfft(spec * scale, n=n, axis=-1)
