"""Room impulse responses of a shoebox: image sources for the early part, statistical late reverb.

Frame: the room's, x in [0, Lx], y in [0, Ly], z in [0, Lz] (floor at z = 0); faces in
``SHOEBOX_FACES`` order (west x = 0, east x = Lx, south y = 0, north y = Ly, floor, ceiling).

Early part (image-source method, Allen and Berkley 1979): along each axis an image is
``(1 - 2p) s + 2 n L`` (p in {0, 1}), reflected |n - p| times on the low wall and |n| times on the
high one; its gain in octave band b is prod_walls sqrt(1 - alpha_wall,b)^count, times 1 / r
spreading and air absorption exp(-m_b r / 2); it arrives at r / c, with its exact fractional
delay. Amplitudes are relative to the pressure at 1 m (the dry sounds' reference distance), so
the direct path of a source 2 m away has gain 0.5.

Per-band gains become a spectrum through complementary octave-band weights (raised-cosine in
log frequency between adjacent centres, summing to 1 at every frequency); each arrival is
rendered in the frequency domain (gain spectrum x fractional delay x, for binaural, the HRTF of its
direction), so there is no sinc truncation and no per-band filter bank.

Late part: the image sources are used up to the time ``t_c`` by which every image of the chosen
order has arrived (the nearest image of the next order). After ``t_c`` the response is Gaussian
noise whose power in band b decays as exp(-13.82 t / T_b) with T_b the room's reverberation time
(:meth:`RoomAcoustics.rt60`: Eyring's for a bare shoebox, Arau-Puchades' for a furnished one; air
absorption included); its level is fitted to the image sources' own band energy just before
``t_c``, so the two join without a gap or jump. For two ears the noise is shaped per ear by the
HRTF's diffuse-field power and given the interaural coherence of a diffuse field,
sinc(2 pi f d / c) with d the ear distance. The noise comes from the caller's generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from fallgen.audio.furnished import FurnishedAcoustics, Furnishing, furnishing
from fallgen.audio.occlusion import path_gains
from fallgen.audio.phasors import powers
from fallgen.audio.reflections import furniture_images
from fallgen.world.materials import OCTAVE_BANDS_HZ
from fallgen.world.rooms import SHOEBOX_FACES, Shoebox

C_SOUND = 343.0  # m/s, 20 C
#: Air absorption, intensity attenuation per metre in each octave band (ISO 9613-1, 20 C,
#: 30-50 % relative humidity; the same table as pyroomacoustics).
AIR_ABSORPTION_PER_M = (0.1e-3, 0.3e-3, 0.6e-3, 1.0e-3, 1.9e-3, 5.8e-3, 20.3e-3)
#: Default image-source order: over all 64 room variants and 50 random source/listener pairs
#: each, the lowest order whose completeness time reaches the perceptual mixing time
#: 20 V / S + 12 ms (Lindau et al., JAES 2012) is 4 in the median, 5 at the 95th percentile and
#: 6 at most (``python bench/room_bench.py``): 6 covers every pair.
DEFAULT_ORDER = 6
#: Samples of each arrival's kernel (its fractional delay, band shaping and HRIR), centred.
KERNEL = 1024


@dataclass(frozen=True, eq=False)
class RoomAcoustics:
    """A shoebox's size and the octave-band absorption of its six faces, and the furniture in
    it (:mod:`fallgen.audio.furnished`; None: a bare room)."""

    size_m: tuple[float, float, float]
    absorption: np.ndarray  # (6, B) in SHOEBOX_FACES order
    air_absorption_per_m: np.ndarray = field(default_factory=lambda: np.asarray(AIR_ABSORPTION_PER_M))
    bands_hz: tuple[float, ...] = OCTAVE_BANDS_HZ
    c: float = C_SOUND
    furniture: Furnishing | None = None

    @staticmethod
    def from_shoebox(box: Shoebox, air: bool = True) -> RoomAcoustics:
        a = np.asarray(box.absorption(), float)
        return RoomAcoustics(tuple(map(float, box.size_m)), a,
                             np.asarray(AIR_ABSORPTION_PER_M) * (1.0 if air else 0.0))

    @staticmethod
    def furnished(variant, materials) -> RoomAcoustics:
        """The room of a :class:`~fallgen.world.rooms.RoomVariant` with its furniture."""
        bare = RoomAcoustics.from_shoebox(variant.shoebox())
        return RoomAcoustics(bare.size_m, bare.absorption, bare.air_absorption_per_m,
                             furniture=furnishing(variant, materials))

    def furnished_model(self) -> FurnishedAcoustics:
        return FurnishedAcoustics(self.size_m, np.asarray(self.absorption, float),
                                  self.furniture or Furnishing.empty(len(self.bands_hz)),
                                  np.asarray(self.air_absorption_per_m, float))

    def rt60(self) -> np.ndarray:
        """(B,) the reverberation time the late reverb decays with: Eyring's for a bare room,
        Arau-Puchades' over the furnished boundary and volume for a furnished one."""
        if self.furniture is None:
            return self.eyring_rt60()
        return self.furnished_model().arau_rt60()

    def image_attenuation_per_m(self) -> np.ndarray:
        """(B,) intensity attenuation per metre of a reflected path: air, and the furniture's
        take (:meth:`FurnishedAcoustics.volume_attenuation_per_m`)."""
        air = np.asarray(self.air_absorption_per_m, float)
        if self.furniture is None:
            return air
        return air + self.furnished_model().volume_attenuation_per_m()

    @property
    def volume_m3(self) -> float:
        """The air's volume (the furnished room's: less the furniture's)."""
        if self.furniture is not None:
            return self.furnished_model().volume_m3
        return float(np.prod(self.size_m))

    def face_areas(self) -> np.ndarray:
        lx, ly, lz = self.size_m
        return np.array([ly * lz, ly * lz, lx * lz, lx * lz, lx * ly, lx * ly])

    def mean_absorption(self) -> np.ndarray:
        """(B,) area-weighted mean absorption coefficient."""
        s = self.face_areas()
        return (s[:, None] * self.absorption).sum(0) / s.sum()

    def eyring_rt60(self) -> np.ndarray:
        """(B,) RT60 = 0.161 V / (-S ln(1 - mean alpha) + 4 m V), seconds, of the bare
        shoebox."""
        v, s = float(np.prod(self.size_m)), self.face_areas().sum()
        a = np.minimum(self.mean_absorption(), 0.999999)
        return 0.161 * v / (-s * np.log1p(-a) + 4 * self.air_absorption_per_m * v)

    def sabine_rt60(self) -> np.ndarray:
        v, s = float(np.prod(self.size_m)), self.face_areas().sum()
        return 0.161 * v / (s * self.mean_absorption() + 4 * self.air_absorption_per_m * v)


@dataclass(frozen=True)
class ImageSources:
    positions: np.ndarray  # (N, 3) room frame
    gains: np.ndarray  # (N, B) wall reflections only
    order: np.ndarray  # (N,) number of reflections


def _axis_images(s: float, L: float, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = np.arange(-k, k + 1)
    n, p = np.repeat(n, 2), np.tile([0, 1], len(n))
    coord = (1 - 2 * p) * s + 2 * n * L
    low, high = np.abs(n - p), np.abs(n)
    keep = low + high <= k
    return coord[keep], low[keep], high[keep]


def image_sources(room: RoomAcoustics, source, max_order: int) -> ImageSources:
    """All images of ``source`` up to ``max_order`` reflections (the direct path included)."""
    src = np.asarray(source, float)
    if np.any(src <= 0) or np.any(src >= np.asarray(room.size_m)):
        raise ValueError(f"source {src.tolist()} is not inside the room {room.size_m}")
    ax = [_axis_images(src[i], room.size_m[i], max_order) for i in range(3)]
    ix, iy, iz = np.meshgrid(*[np.arange(len(a[0])) for a in ax], indexing="ij")
    ix, iy, iz = ix.ravel(), iy.ravel(), iz.ravel()
    counts = np.stack([ax[0][1][ix], ax[0][2][ix], ax[1][1][iy], ax[1][2][iy],
                       ax[2][1][iz], ax[2][2][iz]], axis=1)  # (N, 6) SHOEBOX_FACES order
    order = counts.sum(1)
    keep = order <= max_order
    counts, order = counts[keep], order[keep]
    pos = np.stack([ax[0][0][ix[keep]], ax[1][0][iy[keep]], ax[2][0][iz[keep]]], axis=1)
    logb = 0.5 * np.log(np.maximum(1.0 - np.asarray(room.absorption, float), 1e-12))
    return ImageSources(pos, np.exp(counts @ logb), order)


def completeness_time(room: RoomAcoustics, source, listener, max_order: int) -> float:
    """Time (s) before which every arrival has order <= ``max_order``: the first arrival of
    order ``max_order + 1``."""
    return early_arrivals(room, source, listener, max_order)[1]


def band_weights(freqs_hz: np.ndarray, bands_hz=OCTAVE_BANDS_HZ) -> np.ndarray:
    """(B, F) complementary weights: raised-cosine crossovers in log2 f between adjacent
    centres (one octave apart), flat beyond the outer centres; they sum to 1 at every f."""
    f = np.maximum(np.asarray(freqs_hz, float), 1e-9)
    x = np.clip(np.log2(f / bands_hz[0]), 0.0, len(bands_hz) - 1.0)  # band position
    w = np.zeros((len(bands_hz), len(f)))
    lo = np.minimum(np.floor(x).astype(int), len(bands_hz) - 2)
    t = x - lo
    cols = np.arange(len(f))
    w[lo, cols] = np.cos(np.pi / 2 * t) ** 2
    w[lo + 1, cols] = np.sin(np.pi / 2 * t) ** 2
    return w


@dataclass(frozen=True)
class Arrivals:
    """Image-source arrivals at a listener: delay (s), per-band amplitude (1/r, air, walls) and
    the direction each comes from (unit vectors, room frame, listener -> image)."""

    delay_s: np.ndarray  # (N,)
    amplitude: np.ndarray  # (N, B)
    direction: np.ndarray  # (N, 3)


def arrivals(room: RoomAcoustics, source, listener, max_order: int,
             until_s: float | None = None) -> Arrivals:
    return _arrivals(room, image_sources(room, source, max_order), listener, until_s, source)


def early_arrivals(room: RoomAcoustics, source, listener, max_order: int
                   ) -> tuple[Arrivals, float]:
    """The arrivals before the completeness time, and that time (one image-source pass of
    order ``max_order + 1`` serves both)."""
    im = image_sources(room, source, max_order + 1)
    nxt = im.order == max_order + 1
    d = np.linalg.norm(im.positions[nxt] - np.asarray(listener, float), axis=1)
    t_c = float(d.min()) / room.c
    early = ImageSources(im.positions[~nxt], im.gains[~nxt], im.order[~nxt])
    return _arrivals(room, early, listener, t_c, source), t_c


#: A source on a surface (a fall's contact) is lifted this much off it before the furniture's
#: occlusion is traced, so that the part it rests on stands in the way of paths through it.
SOURCE_LIFT_M = 0.015


def _arrivals(room: RoomAcoustics, im: ImageSources, listener, until_s: float | None,
              source=None) -> Arrivals:
    """The arrivals of the images ``im`` at ``listener``. In a furnished room (and with the
    ``source`` the images are of) the reflections lose the furniture's statistical share, the
    direct sound and the first reflections bend around parts in their way
    (:mod:`fallgen.audio.occlusion`), and the furniture's large faces add their own first
    reflections (:mod:`fallgen.audio.reflections`)."""
    lis = np.asarray(listener, float)
    pos, gains, order = im.positions, im.gains, im.order
    if room.furniture is not None and source is not None:
        lifted = np.asarray(source, float) + (0.0, 0.0, SOURCE_LIFT_M)
        gains = gains * path_gains(lifted, lis, pos, order, room.size_m, room.furniture,
                                   room.bands_hz, room.c)
        # mirrored where it is (a source on a table top is its own image there: doubled)
        f_pos, f_gains = furniture_images(np.asarray(source, float), lis, room.furniture,
                                          room.size_m, room.bands_hz, room.c)
        pos = np.concatenate([pos, f_pos])
        gains = np.concatenate([gains, f_gains])
        order = np.concatenate([order, np.ones(len(f_pos), order.dtype)])
    v = pos - lis
    r = np.maximum(np.linalg.norm(v, axis=1), 1e-3)
    amp = gains / r[:, None] * np.exp(-0.5 * np.outer(r, room.air_absorption_per_m))
    if room.furniture is not None:  # the furniture's take from the reflected paths
        extra = room.image_attenuation_per_m() - np.asarray(room.air_absorption_per_m, float)
        amp = amp * np.where((order > 0)[:, None], np.exp(-0.5 * np.outer(r, extra)), 1.0)
    t = r / room.c
    keep = np.ones(len(t), bool) if until_s is None else t < until_s
    return Arrivals(t[keep], amp[keep], (v / r[:, None])[keep])


def render_arrivals(arr: Arrivals, n_out: int, sample_rate: int, ear_spectra: np.ndarray,
                    bands_hz=OCTAVE_BANDS_HZ) -> np.ndarray:
    """(E, n_out) response: every arrival's band gains (as a spectrum through
    :func:`band_weights`), exact fractional delay and ``ear_spectra`` (N, E, KERNEL // 2 + 1:
    each arrival's HRTF per ear, its own delay included), as one KERNEL-long zero-phase kernel
    per arrival and ear, added at its whole-sample delay. (Omnidirectional responses:
    :func:`render_omni`.)"""
    E = ear_spectra.shape[1]
    out = np.zeros((E, n_out + KERNEL))
    if len(arr.delay_s) == 0:
        return out[:, KERNEL // 2:KERNEL // 2 + n_out]
    f = np.fft.rfftfreq(KERNEL, 1.0 / sample_rate)
    W = band_weights(f, bands_hz)  # (B, F)
    pos = arr.delay_s * sample_rate
    whole = np.floor(pos).astype(np.int64)
    frac = pos - whole
    # bin k (f_k = k fs / KERNEL) delays by the fraction, e^(-2 pi i frac k / KERNEL), and
    # centres the zero-phase kernel in its KERNEL samples, e^(-i pi k) = (-1)^k: the powers
    # of one factor per arrival
    spec = (arr.amplitude @ W) * powers(-np.exp(-2j * np.pi * frac / KERNEL), len(f))
    spec = spec[:, None, :] * ear_spectra
    k = np.fft.irfft(spec, KERNEL, axis=-1)  # (N, E, KERNEL)
    _add_kernels(out, k, whole, n_out)  # at their whole-sample delays (offset KERNEL / 2)
    return out[:, KERNEL // 2:KERNEL // 2 + n_out]


@njit(cache=True)
def _add_kernels(out: np.ndarray, k: np.ndarray, whole: np.ndarray, n_out: int) -> None:
    """out[e, w_i + j] += k[i, e, j] for every arrival i whose whole-sample delay w_i is
    within ``n_out``, in the arrivals' order."""
    for i in range(len(whole)):
        w = whole[i]
        if w >= n_out:
            continue
        for e in range(k.shape[1]):
            for j in range(k.shape[2]):
                out[e, w + j] += k[i, e, j]


#: Taps of the windowed-sinc fractional delay of the omnidirectional renderer.
SINC_TAPS = 32


def render_omni(arr: Arrivals, n_out: int, sample_rate: int, bands_hz=OCTAVE_BANDS_HZ
                ) -> np.ndarray:
    """(n_out,) omnidirectional response: per band an impulse train (each arrival a
    Blackman-windowed sinc at its fractional delay, SINC_TAPS long), then the bands weighted by
    :func:`band_weights` in one FFT. Cheaper than :func:`render_arrivals` for thousands of
    arrivals (B x N x SINC_TAPS instead of N x KERNEL work)."""
    pos = arr.delay_s * sample_rate
    whole = np.floor(pos).astype(int)
    j = np.arange(-SINC_TAPS // 2 + 1, SINC_TAPS // 2 + 1)
    t = j[None, :] - (pos - whole)[:, None]  # (N, taps): tap time minus the arrival time
    k = np.sinc(t) * (0.42 + 0.5 * np.cos(np.pi * t / (SINC_TAPS / 2))
                      + 0.08 * np.cos(2 * np.pi * t / (SINC_TAPS / 2)))
    idx = whole[:, None] + j[None, :] + SINC_TAPS  # offset so that early taps stay >= 0
    ok = (idx >= 0) & (idx < n_out + 2 * SINC_TAPS)
    size = n_out + 2 * SINC_TAPS
    nfft = int(2 ** math.ceil(math.log2(size)))
    f = np.fft.rfftfreq(nfft, 1.0 / sample_rate)
    W = band_weights(f, bands_hz)
    spec = np.zeros(len(f), complex)
    for b in range(len(bands_hz)):
        r = np.bincount(idx[ok], (k * arr.amplitude[:, b:b + 1])[ok], minlength=size)[:size]
        spec += np.fft.rfft(r, nfft) * W[b]
    return np.fft.irfft(spec, nfft)[SINC_TAPS:SINC_TAPS + n_out]


def band_energy(arr: Arrivals, t0: float, t1: float) -> np.ndarray:
    """(B,) sum of squared band amplitudes of the arrivals in [t0, t1)."""
    sel = (arr.delay_s >= t0) & (arr.delay_s < t1)
    return (arr.amplitude[sel] ** 2).sum(0)


def late_reverb(room: RoomAcoustics, level: np.ndarray, start_s: float, n_out: int,
                sample_rate: int, rng: np.random.Generator,
                ear_power: np.ndarray | None = None, ear_distance_m: float = 0.175,
                frame: int = 1024, noise_n: int | None = None) -> np.ndarray:
    """(E, n_out) decaying noise from ``start_s``: in band b its power per sample is
    level_b exp(-13.82 (t - start_s) / T_b) (T_b: :meth:`RoomAcoustics.rt60`), faded in over
    5 ms at ``start_s``.
    Built frame by frame in the STFT domain (sqrt-Hann frames, 50 % overlap). ``ear_power``
    (E, frame // 2 + 1): each ear's diffuse-field HRTF power; two ears get the diffuse-field
    interaural coherence. ``noise_n``: the noise is drawn for that many samples (at least
    ``n_out``; default ``n_out``): a response made shorter is the start of the longer one,
    and ``rng`` is left where the longer one leaves it."""
    E = 1 if ear_power is None else ear_power.shape[0]
    hop = frame // 2
    n_frames = int(math.ceil((n_out + frame) / hop)) + 1
    n_drawn = int(math.ceil((max(n_out, noise_n or 0) + frame) / hop)) + 1
    f = np.fft.rfftfreq(frame, 1.0 / sample_rate)
    W2 = band_weights(f, room.bands_hz) ** 2
    W2 /= W2.sum(0, keepdims=True)  # power-complementary
    rt = room.rt60()
    t = (np.arange(n_frames) * hop - hop) / sample_rate  # frame centres (first frame at -hop)
    tt = np.maximum(t - start_s, 0.0)
    vb = np.asarray(level, float)[None, :] * np.exp(-13.82 * tt[:, None] / rt[None, :])  # (T, B)
    P = (vb @ W2) * frame  # (T, F): power per bin giving that variance per sample
    shape = (n_frames, len(f))
    X = np.empty((E,) + shape, np.complex64)  # single precision: noise needs no more
    drawn = (E, n_drawn, len(f))
    X.real = rng.standard_normal(drawn, dtype=np.float32)[:, :n_frames]
    X.imag = rng.standard_normal(drawn, dtype=np.float32)[:, :n_frames]
    X /= math.sqrt(2)
    if E == 2:
        g = np.sinc(2 * f * ear_distance_m / room.c)  # np.sinc(x) = sin(pi x) / (pi x)
        X[1] = (g * X[0] + np.sqrt(np.maximum(1 - g ** 2, 0.0)) * X[1]).astype(np.complex64)
    X *= np.sqrt(P).astype(np.float32)[None]
    if ear_power is not None:
        X *= np.sqrt(ear_power).astype(np.float32)[:, None, :]
    X[..., 0] = X[..., 0].real
    X[..., -1] = X[..., -1].real
    win = np.sqrt(np.hanning(frame + 1)[:frame])
    x = np.fft.irfft(X, frame, axis=-1) * win  # (E, T, frame)
    # overlap-add at 50 %: each hop is the second half of one frame plus the first of the next
    out = np.zeros((E, n_frames + 1, hop))
    out[:, :-1] += x[:, :, :hop]
    out[:, 1:] += x[:, :, hop:]
    out = out.reshape(E, -1)
    # frame i is centred on buffer sample i hop + frame / 2, i.e. on time t_i = (i - 1) hop
    off = hop + frame // 2
    out = out[:, off:off + n_out]
    # faded in over 5 ms about start_s: sin^2 of the ramp (0 before it, 1 after it, where the
    # product is the same as with the whole-length gain, negative zeros included)
    i0 = min(n_out, max(0, int(math.floor((start_s - 0.0025) * sample_rate)) - 1))
    i1 = min(n_out, max(i0, int(math.ceil((start_s + 0.0025) * sample_rate)) + 2))
    n = np.arange(i0, i1) / sample_rate
    fade = np.clip((n - start_s) / 0.005 + 0.5, 0.0, 1.0)
    out[:, :i0] *= 0.0
    out[:, i0:i1] *= np.sin(np.pi / 2 * fade) ** 2
    return out


def eyring_density(room: RoomAcoustics, t_s: float) -> np.ndarray:
    """(B,) expected squared-amplitude density per second of a diffuse field's arrivals at time
    t (1/r amplitudes): 4 pi c / V exp(-13.82 t / T_b)."""
    return 4 * math.pi * room.c / room.volume_m3 * np.exp(-13.82 * t_s / room.rt60())


def fitted_late_level(room: RoomAcoustics, arr: Arrivals, t_c: float, sample_rate: int,
                      window_s: float = 0.02) -> np.ndarray:
    """(B,) late-reverb power per sample at ``t_c``: the image sources' band energy in the
    ``window_s`` before it, carried to ``t_c`` by the Eyring decay (the analytic diffuse level
    when fewer than 10 arrivals fall in the window)."""
    t0 = max(t_c - window_s, 0.0)
    sel = (arr.delay_s >= t0) & (arr.delay_s < t_c)
    rt = room.rt60()
    if sel.sum() < 10:
        return eyring_density(room, t_c) / sample_rate
    e = band_energy(arr, t0, t_c)  # energy in the window
    # integral over the window of exp(-13.82 (t - t_c) / T)
    k = 13.82 / rt
    span = t_c - t0
    integral = (np.exp(k * span) - 1) / k
    return e / integral / sample_rate


@dataclass(frozen=True)
class RirSettings:
    max_order: int = DEFAULT_ORDER
    sample_rate: int = 44100
    length_s: float = 2.0


def omni_rir(room: RoomAcoustics, source, listener, rng: np.random.Generator | None,
             settings: RirSettings = RirSettings(), late: bool = True) -> np.ndarray:
    """(n,) omnidirectional response at ``listener`` (pressure relative to 1 m from the
    source): image sources up to the completeness time, then (``late``) the fitted late
    reverb; without ``late`` every image of the order is kept."""
    fs = settings.sample_rate
    n = int(round(settings.length_s * fs))
    if not late:
        return render_omni(arrivals(room, source, listener, settings.max_order), n, fs,
                           room.bands_hz)
    arr, t_c = early_arrivals(room, source, listener, settings.max_order)
    if rng is None:
        raise ValueError("the late reverb needs a generator")
    level = fitted_late_level(room, arr, t_c, fs)
    out = late_reverb(room, level, t_c, n, fs, rng)[0]
    n_early = min(n, int(math.ceil((t_c + 0.01) * fs)))  # the image sources end at t_c
    out[:n_early] += render_omni(arr, n_early, fs, room.bands_hz)
    return out


__all__ = ["SHOEBOX_FACES", "RoomAcoustics", "image_sources", "arrivals", "omni_rir",
           "late_reverb", "band_weights", "completeness_time", "RirSettings"]
