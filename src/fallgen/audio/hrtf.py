"""Head-related transfer functions (HRTFs) for binaural room acoustics.

Conventions: head frame with x forward (nose), y left, z up; azimuth counter-clockwise from the
front (+90 degrees = left), elevation up from the horizontal plane. Ear 0 is the left ear, ear 1
the right one. An :class:`Hrtf` holds causal head-related impulse responses (HRIRs) on a set of
unique unit directions, each ear's propagation delay included, so that a source in direction ``d``
is rendered by convolving with ``hrir[nearest(d)]``.

Two sources of HRIRs:

- :func:`spherical_head`: the structural model of Brown & Duda (1998), "A structural model for
  binaural sound synthesis", IEEE Trans. Speech Audio Process. 6(5). A rigid sphere of radius
  ``a`` (0.0875 m), ears at azimuth +-100 degrees in the horizontal plane, c = 343 m/s. Per ear,
  with ``theta`` the angle between the source direction and the ear's axis:

  * head shadow ``H(w) = (1 + j alpha w / (2 w0)) / (1 + j w / (2 w0))``, ``w0 = c / a``,
    ``alpha = 1.05 + 0.95 cos(theta * 180/150)`` (+6 dB at high frequency facing the ear, -20 dB
    at 150 degrees; 1 at DC everywhere);
  * delay ``-(a/c) cos(theta)`` for ``theta < pi/2``, ``(a/c)(theta - pi/2)`` beyond, shifted
    by ``a/c`` plus ``MARGIN_SAMPLES`` so that every response is causal.

  Directions: a golden-angle (Fibonacci) spiral around the x axis, so that straight ahead and
  straight behind are grid points (exactly equal ears there). Each HRIR is made by frequency
  sampling ``H(w) exp(-j w delay)`` on a ``4 * taps`` rfft grid, raised-cosine tapered to zero
  over the top ``TAPER`` of the band (-6 dB at 0.8 Nyquist, 17.6 kHz at 44.1 kHz): a
  band-limited fractional delay whose kernel decays fast, so that less than 1e-4 of the energy
  comes before ``delay - MARGIN_SAMPLES``. It is cut to ``taps`` samples with a short fade-out;
  the DC gain is 1 within 0.3 % in the lit region, within 1.5 % behind the head (truncation).

  ITD caveat: with the ears at +-100 degrees the delay formula gives (a/c)(cos 10deg + 80deg in
  rad) = 607 us at azimuth 90, 7.4 % below Woodworth's (a/c)(pi/2 + 1) = 656 us
  (:func:`woodworth_itd`), as in Brown & Duda. The head-shadow filter's phase adds a group delay
  ``(1 - alpha) / (2 w0)`` per ear, so the low-frequency ITD is larger (837 us at 90 degrees,
  28 % above Woodworth; Kuhn's low-frequency limit for a sphere is 3 (a/c) = 765 us). The
  broadband cross-correlation ITD is ~620 us, 5-6 % below Woodworth. There is no pinna or
  torso: front and back, up and down sound alike.

- :func:`load_sofa`: a measured set from an AES69 SOFA file (SimpleFreeFieldHRIR, netCDF4 read
  with h5py), resampled to ``sample_rate``. ``ListenerView`` is assumed to be +x (not read);
  ``Data.Delay`` (samples) is applied as a whole-sample shift. Which receiver is the left ear
  comes from ``ReceiverPosition`` (SOFA's listener frame: x forward, y left, z up): the one with
  y > 0; a file whose receiver 0 is the right ear has its channels swapped, so that ear 0 is
  always the left one, and a file without ``ReceiverPosition``, or whose two receivers are not
  one on each side (y of opposite signs), is refused. Directions measured more than
  once (equal within ``MERGE_TOL``, e.g. the zenith at several azimuths) keep their first
  measurement. Every problem with the file raises :class:`~fallgen.errors.InputError`.

Interaural time difference (ITD), everywhere in fallgen (here, :func:`woodworth_itd`, the
perception module's features): the right ear's arrival time minus the left ear's. ITD > 0: the
source is on the left, the left ear hears it first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from scipy.signal import resample_poly
from scipy.spatial import SphericalVoronoi, cKDTree

from fallgen.errors import InputError

SPEED_OF_SOUND = 343.0
HEAD_RADIUS_M = 0.0875
EAR_AZIMUTH_DEG = 100.0  # Brown & Duda's ear positions, +-100 degrees
MARGIN_SAMPLES = 8  # extra delay: room for the pre-ringing of the band-limited onsets
TAPER = 0.4  # top fraction of the band over which the spectrum is tapered to 0 at Nyquist
MERGE_TOL = 1e-6  # unit vectors closer than this are one direction
_WEIGHT_POINTS = 20000  # Fibonacci points for the fallback solid-angle weights


@dataclass(frozen=True)
class Hrtf:
    """Head-related impulse responses on a set of directions.
    Head frame: x forward (nose), y left, z up. Ear 0 = left, ear 1 = right."""

    directions: np.ndarray  # (D, 3) float64 unit vectors, head frame, no two equal
    hrir: np.ndarray  # (D, 2, T) float64 at sample_rate, causal, including each ear's delay
    sample_rate: int
    name: str  # e.g. "spherical head (Brown-Duda 1998)" or the SOFA file name

    def nearest(self, dirs: np.ndarray) -> np.ndarray:
        """(N, 3) directions (any length > 0; normalised here) -> (N,) int indices of the
        nearest measured direction (max dot product; equivalently min chord distance)."""
        d = np.asarray(dirs, dtype=np.float64).reshape(-1, 3)
        n = np.linalg.norm(d, axis=1, keepdims=True)
        if not np.all(np.isfinite(n)) or np.any(n <= 0.0):
            raise ValueError("nearest: directions must be finite and of non-zero length")
        _, idx = cKDTree(self.directions).query(d / n)
        return np.asarray(idx, dtype=np.int64)

    def diffuse_field_power(self, nfft: int) -> np.ndarray:
        """(2, nfft // 2 + 1): mean over directions of |H_ear(f)|^2 (rfft of the HRIRs
        zero-padded to ``nfft``), weighted by the solid angle each direction stands for
        (spherical Voronoi cell areas; nearest-direction counts on a dense Fibonacci sphere when
        the directions do not span the sphere, e.g. a horizontal-plane-only set)."""
        if nfft < self.hrir.shape[-1]:
            raise ValueError(f"nfft {nfft} is shorter than the HRIRs ({self.hrir.shape[-1]})")
        w = solid_angle_weights(self.directions)
        out = np.zeros((2, nfft // 2 + 1))
        for s in range(0, len(w), 256):  # chunks bound the memory for long nfft
            spec = np.fft.rfft(self.hrir[s : s + 256], n=nfft, axis=-1)
            out += np.einsum("d,def->ef", w[s : s + 256], spec.real**2 + spec.imag**2)
        return out


def solid_angle_weights(directions: np.ndarray) -> np.ndarray:
    """(D,) weights summing to 1: the fraction of the sphere nearest to each direction."""
    u = np.asarray(directions, dtype=np.float64)
    try:
        area = SphericalVoronoi(u, 1.0, np.zeros(3), threshold=1e-6).calculate_areas()
    except (ValueError, RuntimeError):  # coplanar, too few or repeated points; QhullError
        area = np.full(len(u), np.nan)
    if np.all(np.isfinite(area)) and np.all(area >= 0) and abs(area.sum() - 4 * np.pi) < 1e-3:
        return area / area.sum()
    _, idx = cKDTree(u).query(fibonacci_sphere(_WEIGHT_POINTS))
    return np.bincount(idx, minlength=len(u)) / _WEIGHT_POINTS


def fibonacci_sphere(n: int) -> np.ndarray:
    """(n, 3) nearly uniform, distinct unit vectors on a golden-angle spiral whose axis is the
    x (front) axis, ends included: point 0 is exactly straight ahead, point n - 1 behind."""
    if n < 1:
        raise ValueError(f"need at least one direction, got {n}")
    i = np.arange(n)
    x = 1.0 - 2.0 * i / max(n - 1, 1)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(np.clip(1.0 - x * x, 0.0, None))
    return np.stack([x, r * np.cos(phi), r * np.sin(phi)], axis=1)


def woodworth_itd(azimuth_rad: float, radius_m: float = HEAD_RADIUS_M,
                  c: float = SPEED_OF_SOUND) -> float:
    """Woodworth's ray-model ITD (a/c)(theta + sin theta), for |theta| <= pi/2 (positive when the
    source is on the left, i.e. the left ear leads)."""
    return radius_m / c * (azimuth_rad + math.sin(azimuth_rad))


def spherical_head(sample_rate: int = 44100, radius_m: float = HEAD_RADIUS_M,
                   n_directions: int = 2048, taps: int = 64) -> Hrtf:
    """Brown-Duda spherical-head HRIRs on a Fibonacci sphere of ``n_directions`` (see the
    module docstring for the model and its ITD). ``taps`` must hold the longest delay plus
    margin and fade-out (64 suffices up to 48 kHz; use 128 at 96 kHz), else ValueError."""
    if sample_rate <= 0 or radius_m <= 0:
        raise ValueError(f"need sample_rate > 0 and radius_m > 0, got {sample_rate}, {radius_m}")
    fs, a, c = float(sample_rate), float(radius_m), SPEED_OF_SOUND
    dirs = fibonacci_sphere(n_directions)
    ear_az = math.radians(EAR_AZIMUTH_DEG)
    ears = np.array([[math.cos(ear_az), math.sin(ear_az), 0.0],
                     [math.cos(ear_az), -math.sin(ear_az), 0.0]])
    theta = np.arccos(np.clip(dirs @ ears.T, -1.0, 1.0))  # (D, 2)
    delay = np.where(theta < np.pi / 2, -np.cos(theta), theta - np.pi / 2) * (a / c)
    delay += a / c + MARGIN_SAMPLES / fs  # seconds, >= margin
    fade = max(4, taps // 8)
    if delay.max() * fs + MARGIN_SAMPLES + fade > taps:
        raise ValueError(f"taps={taps} too short for a {a} m head at {sample_rate} Hz")
    nfft = 4 * taps
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    w, w0 = 2 * np.pi * f, c / a
    alpha = 1.05 + 0.95 * np.cos(theta * (180.0 / 150.0))
    shadow = (1 + 1j * alpha[..., None] * w / (2 * w0)) / (1 + 1j * w / (2 * w0))
    x = np.clip((f / (fs / 2) - (1 - TAPER)) / TAPER, 0.0, 1.0)
    band = 0.5 * (1 + np.cos(np.pi * x))  # 1 below (1-TAPER) Nyquist, 0 at Nyquist
    spec = shadow * np.exp(-1j * w * delay[..., None]) * band
    h = np.fft.irfft(spec, n=nfft, axis=-1)[..., :taps]
    h[..., taps - fade:] *= 0.5 * (1 + np.cos(np.pi * (np.arange(fade) + 1) / fade))
    return Hrtf(dirs, np.ascontiguousarray(h), int(sample_rate),
                "spherical head (Brown-Duda 1998)")


def _attr(obj: h5py.HLObject, key: str, default: str = "") -> str:
    v = obj.attrs.get(key, default)
    if isinstance(v, np.ndarray):
        v = v.item() if v.size == 1 else default
    return (v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)).strip().lower()


def _read(f: h5py.File, path: str | Path, name: str) -> np.ndarray:
    if name not in f or not isinstance(f[name], h5py.Dataset):
        raise InputError(path, name, "required variable missing")
    try:
        v = np.asarray(f[name][()], dtype=np.float64)
    except (TypeError, ValueError, OSError) as e:
        raise InputError(path, name, f"not numeric: {e}") from e
    if not np.all(np.isfinite(v)):
        raise InputError(path, name, "contains NaN or infinite values")
    return v


def _unit_directions(f: h5py.File, path: str | Path, m: int) -> np.ndarray:
    name = "SourcePosition"
    pos = _read(f, path, name)
    if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] not in (1, m):
        raise InputError(path, name, f"shape {pos.shape}, expected ({m}, 3)")
    pos = np.broadcast_to(pos, (m, 3))
    return _to_unit(f, path, name, pos, "spherical")  # SimpleFreeFieldHRIR's default


def _to_unit(f: h5py.File, path: str | Path, name: str, pos: np.ndarray, default: str
             ) -> np.ndarray:
    """(K, 3) positions of variable ``name`` (its ``Type``: spherical azimuth, elevation,
    distance; or cartesian) as unit vectors in the listener's frame."""
    kind = _attr(f[name], "Type", default)
    if kind == "spherical":  # azimuth deg, elevation deg, distance
        unit = _attr(f[name], "Units", "degree")
        k = 1.0 if "rad" in unit.split(",")[0] else math.pi / 180.0
        az, el = pos[:, 0] * k, pos[:, 1] * k
        u = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    elif kind == "cartesian":
        n = np.linalg.norm(pos, axis=1, keepdims=True)
        if np.any(n <= 0.0):
            raise InputError(path, name, "a cartesian source position is at the origin")
        u = pos / n
    else:
        raise InputError(path, name, f"unknown Type {kind!r} (expected spherical or cartesian)")
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _left_receiver(f: h5py.File, path: str | Path, m: int) -> int:
    """Which of the two receivers (``Data.IR``'s R axis) is the left ear: the one whose
    ``ReceiverPosition`` lies on the listener's left (y > 0 in SOFA's listener frame, x
    forward, y left, z up); the other must lie on the right (y < 0) in every measurement."""
    name = "ReceiverPosition"
    if name not in f:
        raise InputError(path, name, "missing: which receiver is the left ear is unknown "
                         "(expected (2, 3) or (2, 3, 1) positions, y > 0 for the left ear)")
    pos = _read(f, path, name)
    if pos.ndim == 2:
        pos = pos[..., None]
    if pos.ndim != 3 or pos.shape[:2] != (2, 3) or pos.shape[2] not in (1, m):
        raise InputError(path, name, f"shape {pos.shape}, expected (2, 3, 1) or (2, 3, {m})")
    flat = np.moveaxis(pos, 2, 1).reshape(-1, 3)  # (2 * I, 3): receiver 0's, then 1's
    kind = _attr(f[name], "Type", "cartesian")
    if kind == "cartesian":
        y = flat[:, 1]
    else:
        y = _to_unit(f, path, name, flat, kind)[:, 1] * flat[:, 2]
    y = y.reshape(2, -1)
    if np.all(y[0] > 0) and np.all(y[1] < 0):
        return 0
    if np.all(y[0] < 0) and np.all(y[1] > 0):
        return 1
    raise InputError(path, name, f"receiver y = {np.round(y, 4).tolist()} m: need one ear on "
                     "the left (y > 0) and one on the right (y < 0)")


def load_sofa(path: str | Path, sample_rate: int = 44100) -> Hrtf:
    """Measured HRIRs from an AES69 SOFA file (SimpleFreeFieldHRIR), resampled to
    ``sample_rate``; repeated directions keep their first measurement."""
    if sample_rate <= 0:
        raise ValueError(f"sample_rate must be positive, got {sample_rate}")
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "", "file not found")
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise InputError(path, "", f"not a SOFA (netCDF4/HDF5) file: {e}") from e
    with f:
        ir = _read(f, path, "Data.IR")
        if ir.ndim != 3 or ir.shape[0] < 1 or ir.shape[2] < 1:
            raise InputError(path, "Data.IR", f"shape {ir.shape}, expected [M, R=2, N]")
        if ir.shape[1] != 2:
            raise InputError(path, "Data.IR", f"R = {ir.shape[1]} receivers, expected 2 ears")
        rate = _read(f, path, "Data.SamplingRate").ravel()
        if rate.size < 1 or np.any(rate != rate[0]) or rate[0] <= 0 or rate[0] % 1:
            raise InputError(path, "Data.SamplingRate",
                             f"{rate.tolist()}: need one whole number of Hz > 0")
        m = ir.shape[0]
        dirs = _unit_directions(f, path, m)
        left = _left_receiver(f, path, m)
        shift = np.zeros((m, 2), dtype=np.int64)
        if "Data.Delay" in f:
            dl = _read(f, path, "Data.Delay")
            if dl.ndim != 2 or dl.shape[0] not in (1, m) or dl.shape[1] != 2 or np.any(dl < 0):
                raise InputError(path, "Data.Delay", f"shape {dl.shape} or negative values")
            shift = np.broadcast_to(np.rint(dl).astype(np.int64), (m, 2))
    if left == 1:  # the file's receiver 0 is the right ear: ear 0 is the left one here
        ir, shift = ir[:, ::-1], shift[:, ::-1]
    if shift.any():  # whole-sample delays, applied at the file's rate
        out = np.zeros((m, 2, ir.shape[2] + int(shift.max())))
        for i, r in np.ndindex(m, 2):
            out[i, r, shift[i, r] : shift[i, r] + ir.shape[2]] = ir[i, r]
        ir = out
    # repeated directions: keep the first of each group (lowest index within MERGE_TOL)
    groups = cKDTree(dirs).query_ball_point(dirs, MERGE_TOL)
    keep = np.array([min(g) == i for i, g in enumerate(groups)])
    dirs, ir = dirs[keep], ir[keep]
    g = math.gcd(int(rate[0]), int(sample_rate))
    up, down = int(sample_rate) // g, int(rate[0]) // g
    if up != down:
        ir = resample_poly(ir, up, down, axis=-1)
    return Hrtf(np.ascontiguousarray(dirs), np.ascontiguousarray(ir, dtype=np.float64),
                int(sample_rate), path.name)
