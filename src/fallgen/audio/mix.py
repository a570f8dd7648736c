"""What the agent hears: dry impact sounds through the room's binaural response, mixed.

Each :class:`DrySource` (a dry signal, pressure at 1 m, and where it sounds from) is convolved
with the binaural response from its position to the listener's head: the image sources up to the
completeness time, each through the HRTF of its direction in the head frame (x forward, y left,
z up; yaw counter-clockwise from the room's +x, pitch up), then the late reverb. The late field is
diffuse, so one realisation (level fitted at the loudest source) serves every source of the clip.

Output units: the ears' pressure in pascals divided by ``FULL_SCALE_PA`` (20 Pa, 120 dB SPL
peak: louder than any fall heard from a metre or more), as 2 x T float32. A clip that would
still exceed 1 is scaled down and the factor kept in ``gain`` (pressure = audio * FULL_SCALE_PA /
gain), so nothing ever clips and absolute levels stay recoverable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.signal import fftconvolve, oaconvolve

from fallgen.audio.ambient import ambient_noise
from fallgen.audio.hrtf import Hrtf
from fallgen.audio.room import (KERNEL, RirSettings, RoomAcoustics, early_arrivals,
                                fitted_late_level, late_reverb, render_arrivals)

FULL_SCALE_PA = 20.0
#: Largest |audio| a clip is allowed before it is scaled down (and ``gain`` < 1 recorded).
CEILING = 0.99
#: Precision of the mix's FFT convolutions. Single precision: their error is ~2e-7 of the
#: clip's peak (-133 dB; the clip itself is stored in float32), and they cost ~40 % less than
#: in double (2 s of audio with a 2 s late response: 11.4 ms against 17.8 ms).
CONVOLUTION_DTYPE = np.float32
#: The late reverb a clip's sources are convolved with ends once its slowest band has decayed
#: this much (dB) from its start (at the model RT60 it decays at). Its start lies below the
#: clip's peak: what is left out stayed within 1e-5 of the peak on 500 paper-size episodes
#: (9.5e-6 at most, 3-6e-7 in the median: float32's step). The noise the whole length would
#: take is drawn all the same (the part kept and everything drawn after it are the whole
#: length's).
LATE_RANGE_DB = 100.0


@dataclass(frozen=True)
class Listener:
    position: np.ndarray  # (3,) head centre, room frame, m
    yaw_rad: float = 0.0
    pitch_rad: float = 0.0

    def axes(self) -> np.ndarray:
        """(3, 3) columns: the head's forward, left and up unit vectors in the room frame."""
        cy, sy = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        cp, sp = math.cos(self.pitch_rad), math.sin(self.pitch_rad)
        fwd = np.array([cy * cp, sy * cp, sp])
        left = np.array([-sy, cy, 0.0])
        return np.column_stack([fwd, left, np.cross(fwd, left)])


@dataclass(frozen=True)
class DrySource:
    position: np.ndarray  # (3,) room frame, m
    signal: np.ndarray  # (T,) pressure at 1 m, Pa


@dataclass(frozen=True)
class BinauralClip:
    audio: np.ndarray  # (2, T) float32: ear pressure / FULL_SCALE_PA * gain; row 0 = left ear
    gain: float
    sample_rate: int
    noise_db_a: float = 0.0  # the ambient noise floor mixed in, dB(A) (0: none)
    #: (peak, loudest 125 ms Leq) dB SPL of the fall alone, before the noise floor was added
    #: (None: as :meth:`levels_db_spl`)
    fall_levels: tuple[float, float] | None = None

    def pressure_pa(self) -> np.ndarray:
        return self.audio.astype(float) * FULL_SCALE_PA / self.gain

    def levels_db_spl(self, window_s: float = 0.125) -> tuple[float, float]:
        """(peak, loudest ``window_s`` Leq) in dB SPL re 20 uPa of the clip (noise floor
        included), the louder ear of each (see :func:`levels_db_spl`)."""
        return levels_db_spl(self.pressure_pa(), self.sample_rate, window_s)

    def fast_max_db_spl(self) -> float:
        """The clip's maximum F-time-weighted level (IEC 61672-1, no frequency weighting),
        dB SPL, the louder ear (see :func:`fast_max_db_spl`)."""
        return fast_max_db_spl(self.pressure_pa(), self.sample_rate)


def levels_db_spl(p: np.ndarray, sample_rate: int, window_s: float = 0.125
                  ) -> tuple[float, float]:
    """(peak, loudest ``window_s`` Leq) in dB SPL of (2, T) ear pressures (Pa), the louder
    ear of each. The Leq is the mean square over a sliding rectangular window (125 ms: the
    length of a sound level meter's 'fast' time constant, but not its exponential weighting,
    :func:`fast_max_db_spl`): for a short impulse both are its energy over 0.125 s; for a
    sound that rings on, the F-weighted maximum is lower (2.4 dB for an exponential energy
    decay of time constant 0.1 s, i.e. a 1.4 s reverberation; 0.4 dB for a steady 200 ms
    burst, the window's 0 dB against IEC 61672-1's -1.0)."""
    peak = float(np.abs(p).max())
    n = max(1, min(p.shape[1], int(round(window_s * sample_rate))))
    c = np.cumsum(np.pad(p * p, ((0, 0), (1, 0))), axis=1)
    leq = float(((c[:, n:] - c[:, :-n]) / n).max())
    return (20 * np.log10(max(peak, 1e-12) / 20e-6), 10 * np.log10(max(leq, 1e-24) / 4e-10))


#: IEC 61672-1's F (fast) time weighting's time constant, s.
FAST_TAU_S = 0.125


def fast_level_db_spl(p: np.ndarray, sample_rate: int, tau_s: float = FAST_TAU_S
                      ) -> np.ndarray:
    """The time-weighted sound level of pressures ``p`` (Pa; (..., T)), dB SPL re 20 uPa, at
    every sample: IEC 61672-1's exponential time weighting, L(t) = 10 lg((1/tau) int p^2(x)
    exp(-(t - x) / tau) dx / p0^2), as the exact step response of the one-pole filter
    y[n] = a y[n-1] + (1 - a) p^2[n], a = exp(-1 / (fs tau)) (unit gain at DC: a steady
    signal's level is its Leq). tau = 0.125 s: F ('fast'); 1 s: S ('slow')."""
    from scipy.signal import lfilter

    a = math.exp(-1.0 / (sample_rate * tau_s))
    x = np.asarray(p, float)
    y = lfilter([1.0 - a], [1.0, -a], x * x, axis=-1)
    return 10 * np.log10(np.maximum(y, 1e-24) / 4e-10)


def fast_max_db_spl(p: np.ndarray, sample_rate: int) -> float:
    """L_Fmax: the maximum F-time-weighted level (:func:`fast_level_db_spl`) of (E, T) ear
    pressures (Pa), the louder ear, dB SPL (no frequency weighting: L_ZFmax)."""
    return float(fast_level_db_spl(p, sample_rate).max())


class Binaural:
    """Binaural rendering with one HRTF: its spectra on the arrival-kernel grid, its latency for
    a source in front (arrivals are advanced by it, so delays count from the head centre) and
    its diffuse-field power are computed once here."""

    def __init__(self, hrtf: Hrtf, late_frame: int = 1024) -> None:
        if hrtf.hrir.shape[-1] > KERNEL // 2:
            raise ValueError(f"HRIRs longer than {KERNEL // 2} taps are not supported")
        self.hrtf = hrtf
        self.spectra = np.fft.rfft(hrtf.hrir, KERNEL, axis=-1)  # (D, 2, KERNEL // 2 + 1)
        front = hrtf.nearest(np.array([[1.0, 0.0, 0.0]]))[0]
        self.latency = int(round(np.mean([np.argmax(np.abs(hrtf.hrir[front, e]))
                                          for e in (0, 1)])))
        self.late_frame = late_frame
        self.diffuse_power = hrtf.diffuse_field_power(late_frame)

    def early(self, room: RoomAcoustics, source, listener: Listener, settings: RirSettings
              ) -> tuple[np.ndarray, float, np.ndarray]:
        """(2, n) image-source part of the response (up to the completeness time, n covering
        it), that time, and the fitted late level (B,)."""
        fs = settings.sample_rate
        # a contact on the floor or a wall lies on the boundary: move it 1 cm inside
        source = np.clip(np.asarray(source, float), 0.01, np.asarray(room.size_m) - 0.01)
        arr, t_c = early_arrivals(room, source, listener.position, settings.max_order)
        idx = self.hrtf.nearest(arr.direction @ listener.axes())  # head-frame directions
        shifted = type(arr)(np.maximum(arr.delay_s - self.latency / fs, 0.0), arr.amplitude,
                            arr.direction)
        n = int(math.ceil((t_c + 0.01) * fs)) + KERNEL
        h = render_arrivals(shifted, n, fs, self.spectra[idx])
        return h, t_c, fitted_late_level(room, arr, t_c, fs)

    def late(self, room: RoomAcoustics, level: np.ndarray, t_c: float, n: int, fs: int,
             rng: np.random.Generator, noise_n: int | None = None) -> np.ndarray:
        return late_reverb(room, level, t_c, n, fs, rng, self.diffuse_power,
                           frame=self.late_frame, noise_n=noise_n)

    def rir(self, room: RoomAcoustics, source, listener: Listener, rng: np.random.Generator,
            settings: RirSettings = RirSettings()) -> np.ndarray:
        """(2, n) binaural response (early image sources and late reverb), ``length_s``."""
        fs = settings.sample_rate
        n = int(round(settings.length_s * fs))
        h, t_c, level = self.early(room, source, listener, settings)
        out = self.late(room, level, t_c, n, fs, rng)
        m = min(n, h.shape[1])
        out[:, :m] += h[:, :m]
        return out

    def mix(self, room: RoomAcoustics, sources: list[DrySource], listener: Listener,
            rng: np.random.Generator, settings: RirSettings = RirSettings(),
            noise_db_a: float = 0.0) -> BinauralClip:
        """The binaural clip (``length_s``) of ``sources`` heard by ``listener``, over an
        ambient noise floor of ``noise_db_a`` dB(A) (:mod:`fallgen.audio.ambient`; 0: none),
        drawn from ``rng`` after everything else."""
        fs = settings.sample_rate
        n = int(round(settings.length_s * fs))
        out = np.zeros((2, n))
        if not sources:
            return _clip(out, rng, noise_db_a, fs, n)
        loudest = max(range(len(sources)), key=lambda i: float(np.abs(sources[i].signal).max()))
        total = np.zeros(n)
        late_from = (0.0, np.zeros(len(room.bands_hz)))
        for i, s in enumerate(sources):
            sig = np.asarray(s.signal, float)[:n]
            total[:len(sig)] += sig
            h, t_c, level = self.early(room, s.position, listener, settings)
            if i == loudest:
                late_from = (t_c, level)
            # both ears in one call (the signal's transform is made once); the convolutions
            # run in single precision (see CONVOLUTION_DTYPE), the sum in double
            y = oaconvolve(sig[None, :].astype(CONVOLUTION_DTYPE), h.astype(CONVOLUTION_DTYPE),
                           axes=-1)[:, :n]
            out[:, :y.shape[1]] += y
        late = self.late(room, late_from[1], late_from[0], late_length(room, late_from[0], fs, n),
                         fs, rng, noise_n=n)
        out += fftconvolve(total[None, :].astype(CONVOLUTION_DTYPE),
                           late.astype(CONVOLUTION_DTYPE), axes=-1)[:, :n]
        return _clip(out, rng, noise_db_a, fs, n)


def late_length(room: RoomAcoustics, start_s: float, sample_rate: int, n: int) -> int:
    """Samples of the late reverb starting at ``start_s`` that a clip of ``n`` samples is
    convolved with: until its slowest band has decayed :data:`LATE_RANGE_DB`, at most
    ``n``."""
    t = start_s + LATE_RANGE_DB / 60.0 * float(np.max(room.rt60()))
    return min(n, int(math.ceil(t * sample_rate)))


def _clip(pressure: np.ndarray, rng: np.random.Generator, noise_db_a: float, fs: int,
          n: int) -> BinauralClip:
    """The clip of (2, n) ear pressures plus the noise floor, scaled down if it would clip."""
    fall = levels_db_spl(pressure, fs)
    if noise_db_a > 0:
        pressure = pressure + ambient_noise(n, fs, noise_db_a, rng)
    audio = pressure / FULL_SCALE_PA
    peak = float(np.abs(audio).max())
    gain = 1.0 if peak <= CEILING else CEILING / peak
    return BinauralClip((audio * gain).astype(np.float32), gain, fs, float(noise_db_a), fall)


def binaural_rir(room: RoomAcoustics, source, listener: Listener, hrtf: Hrtf,
                 rng: np.random.Generator, settings: RirSettings = RirSettings()) -> np.ndarray:
    """One binaural response (see :meth:`Binaural.rir`; keep a :class:`Binaural` to render
    many)."""
    return Binaural(hrtf).rir(room, source, listener, rng, settings)


def mix(room: RoomAcoustics, sources: list[DrySource], listener: Listener, hrtf: Hrtf,
        rng: np.random.Generator, settings: RirSettings = RirSettings(),
        noise_db_a: float = 0.0) -> BinauralClip:
    """One clip (see :meth:`Binaural.mix`; keep a :class:`Binaural` to render many)."""
    return Binaural(hrtf).mix(room, sources, listener, rng, settings, noise_db_a)


def write_wav(path: Path, clip: BinauralClip) -> None:
    """Write a clip as a 2-channel float WAV (left, right), written atomically."""
    import io

    import soundfile as sf

    from fallgen.atomic import write_bytes

    buf = io.BytesIO()
    sf.write(buf, clip.audio.T, clip.sample_rate, format="WAV", subtype="FLOAT")
    write_bytes(Path(path), buf.getvalue())
