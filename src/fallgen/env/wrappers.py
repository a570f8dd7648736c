"""Observations standard RL libraries take as they are (Stable-Baselines3, CleanRL, RLlib).

:class:`FallenObjectsEnv`'s own observations are the dataset's: 300 x 300 images, depth in
float32 metres, the segmentation as int16 category indices and the binaural clip as (2, T)
float32 samples. A library's default policy flattens what is not an 8-bit image: PPO's
``MultiInputPolicy`` made a first layer of 53 M parameters of the (2, 88200) clip, the depth and
the segmentation (1.8 steps a second, 2 GB). :class:`CompactObservation` gives:

- ``rgb``: (size, size, 3) uint8, the view resized (pixel areas averaged);
- ``depth``: (size, size, 1) uint8, metres resized the same way, then ``depth_max_m`` (10 m)
  over 255 levels (3.9 cm a level; farther is 255);
- ``audio``: (2 * bands,) float32 in [0, 1], the clip's log-mel band energies
  (:func:`log_mel`), left ear first: each band's mean power over the clip in dB re the clip's
  unit (ear pressure / 20 Pa times the row's gain: 0 dB is 120 dB SPL at gain 1), -160 dB to
  -40 dB mapped to 0..1 (the smoke build's bands lie between -145 and -55 dB). With
  ``hold_audio`` (default) the step-0 clip's features are kept for the whole episode (the fall
  is heard once; a policy without memory would otherwise forget it after the first step);
- ``category_seg``: (size, size, 1) uint8, the category index + 1 (0: nothing), where the
  environment gives it: each cell (the view cut into size x size blocks of 3 or 4 pixels a
  side) holds the rarest category it covers, the one with the fewest pixels in the whole view
  (:func:`rarest_label_resize`), so an object of a few pixels survives the reduction (the
  nearest pixel lost the fallen object in a third of the expert's claim views, where it shows
  13 pixels at the median);
- ``pose``, ``object_category``, ``object_position``, ``expert_action``: as they are.

Images are 8-bit with bounds 0..255 and channels last, so Stable-Baselines3's ``check_env``
passes without a warning and its ``MultiInputPolicy`` puts a CNN on each image::

    from stable_baselines3 import PPO
    from fallgen.env.wrappers import compact_env

    env = compact_env("build/smoke", split="train", sensors=("rgb", "depth", "audio", "pose"))
    PPO("MultiInputPolicy", env, n_steps=256).learn(1024)

That policy has 1.8 M parameters and learns at 13.5 env steps a second (rollouts and updates
together, ``bench/env_bench.py --ppo``; 2-core Intel Xeon VM under a load of 6) with torch on
one thread, which it gets when ``fallgen`` is imported before torch (``OMP_NUM_THREADS=1``);
two threads on the same two busy cores made it 2.2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

#: Side of the resized images (the Atari convention most CNN policies are made for).
SIZE = 84
#: Depth that maps to 255 (farther is 255 too): 3.9 cm a level.
DEPTH_MAX_M = 10.0
#: Mel bands per ear.
BANDS = 64
#: Band levels (dB re the clip's unit) from DB_FLOOR to DB_CEIL map to 0..1.
DB_FLOOR, DB_CEIL = -160.0, -40.0
FMIN_HZ, FMAX_HZ = 50.0, 16000.0
N_FFT = 1024
#: Observation keys passed through unchanged.
PASSED = ("pose", "object_category", "object_position", "expert_action")


def mel_filters(sample_rate: int, bands: int = BANDS, n_fft: int = N_FFT,
                fmin_hz: float = FMIN_HZ, fmax_hz: float = FMAX_HZ) -> np.ndarray:
    """(bands, n_fft // 2 + 1) triangular filters with centres evenly spaced on the mel scale
    (HTK: 2595 log10(1 + f / 700)), each 1 at its centre and 0 at its neighbours' centres, so
    that between the first and the last centre they sum to 1 at every frequency (the bands'
    powers add up to the power there)."""
    fmax_hz = min(fmax_hz, sample_rate / 2)
    mel = lambda f: 2595.0 * np.log10(1.0 + np.asarray(f) / 700.0)  # noqa: E731
    hz = lambda m: 700.0 * (10.0 ** (np.asarray(m) / 2595.0) - 1.0)  # noqa: E731
    edges = hz(np.linspace(mel(fmin_hz), mel(fmax_hz), bands + 2))
    f = np.fft.rfftfreq(n_fft, 1.0 / sample_rate)
    lo, mid, hi = edges[:-2, None], edges[1:-1, None], edges[2:, None]
    up = (f[None] - lo) / (mid - lo)
    down = (hi - f[None]) / (hi - mid)
    return np.clip(np.minimum(up, down), 0.0, None)


def band_power(clip: np.ndarray, sample_rate: int, bands: int = BANDS,
               n_fft: int = N_FFT) -> np.ndarray:
    """(channels, bands) mean power of each mel band over the clip ((channels, T) samples):
    Hann-windowed frames hopping by half a frame, each bin's power scaled so that a frame's
    bins add up to its windowed mean square (Parseval), averaged over the frames, then
    weighted by :func:`mel_filters` (a sine of amplitude A inside the bands' range adds up to
    A^2 / 2 over them)."""
    x = np.asarray(clip, np.float64)
    if x.ndim != 2:
        raise ValueError(f"clip of shape {x.shape}: expected (channels, samples)")
    if x.shape[1] < n_fft:
        x = np.pad(x, ((0, 0), (0, n_fft - x.shape[1])))
    w = np.hanning(n_fft + 1)[:-1]  # periodic
    frames = np.lib.stride_tricks.sliding_window_view(x, n_fft, axis=1)[:, ::n_fft // 2]
    spec = np.abs(np.fft.rfft(frames * w, axis=-1)) ** 2
    scale = np.full(n_fft // 2 + 1, 2.0)
    scale[0] = scale[-1] = 1.0
    power = (spec * scale).mean(axis=1) / (n_fft * np.sum(w ** 2))
    return power @ mel_filters(sample_rate, bands, n_fft).T


def log_mel(clip: np.ndarray, sample_rate: int, bands: int = BANDS) -> np.ndarray:
    """(channels * bands,) float32 in [0, 1]: the dB of :func:`band_power` from
    :data:`DB_FLOOR` (0; silence too) to :data:`DB_CEIL` (1), the first channel's bands
    first."""
    db = 10.0 * np.log10(np.maximum(band_power(clip, sample_rate, bands), 1e-30))
    return np.clip((db - DB_FLOOR) / (DB_CEIL - DB_FLOOR), 0.0, 1.0).astype(np.float32).ravel()


def _block_starts(n: int, size: int) -> np.ndarray:
    """The first source index of each of ``size`` blocks that cut ``n`` indices evenly."""
    return (np.arange(size) * n) // size


def rarest_label_resize(labels: np.ndarray, size: int) -> np.ndarray:
    """(H, W) uint8 labels -> (size, size): each output cell, a block of the partition of the
    image into size x size blocks (``floor(i H / size)`` to ``floor((i + 1) H / size)``),
    holds the label of its block that has the fewest pixels in the whole image (ties: the
    smaller label); label 0 (nothing) only where a block holds nothing else. Every source
    pixel lies in one block, so a label that shows anywhere shows in the output."""
    h, w = labels.shape
    if h < size or w < size:
        raise ValueError(f"labels {h} x {w}: smaller than the output's {size}")
    counts = np.bincount(labels.ravel(), minlength=256).astype(np.int64)
    counts[0] = h * w + 1  # nothing loses to any label
    order = np.lexsort((np.arange(256), counts))  # rank -> label, rarest first
    rank = np.empty(256, np.uint8)
    rank[order] = np.arange(256, dtype=np.uint8)
    r = rank[labels]
    r = np.minimum.reduceat(r, _block_starts(h, size), axis=0)
    r = np.minimum.reduceat(r, _block_starts(w, size), axis=1)
    return order[r].astype(np.uint8)


class Compactor:
    """The conversion :class:`CompactObservation` applies, without an environment: for an agent
    that is handed the environment's own observations (``fallgen evaluate``) and must see
    what it was trained on. ``spaces_in``: the environment's observation spaces (key -> space);
    ``sample_rate`` of the clips (needed with ``audio``); the rest as
    :class:`CompactObservation`. Call it with each observation, ``first=True`` for a reset's
    (the held audio features are replaced then)."""

    def __init__(self, spaces_in: dict[str, spaces.Space], sample_rate: int | None = None,
                 size: int = SIZE, depth_max_m: float = DEPTH_MAX_M, bands: int = BANDS,
                 hold_audio: bool = True) -> None:
        if size < 8 or depth_max_m <= 0 or bands < 1:
            raise ValueError(f"size={size} (>= 8), depth_max_m={depth_max_m} (> 0), "
                             f"bands={bands} (>= 1)")
        self.size, self.depth_max_m, self.bands = int(size), float(depth_max_m), int(bands)
        self.hold_audio = hold_audio
        self.sample_rate = None if sample_rate is None else int(sample_rate)
        if "audio" in spaces_in and self.sample_rate is None:
            raise ValueError("audio: the clips' sample_rate is needed")
        seg = spaces_in.get("category_seg")
        if seg is not None and seg.high.max() + 1 > 255:
            raise ValueError(f"{int(seg.high.max()) + 1} categories: more than a uint8 "
                             "segmentation holds")
        image = spaces.Box(0, 255, (self.size, self.size, 1), np.uint8)
        made = {"rgb": spaces.Box(0, 255, (self.size, self.size, 3), np.uint8),
                "depth": image, "category_seg": image,
                "audio": spaces.Box(0.0, 1.0, (2 * self.bands,), np.float32)}
        out = {}
        for k, s in spaces_in.items():
            if k in made:
                out[k] = made[k]
            elif k in PASSED:
                out[k] = s
            else:
                raise ValueError(f"observation {k!r}: CompactObservation knows "
                                 f"{', '.join(list(made) + list(PASSED))}")
        #: the compact observations' spaces (key -> space, in the environment's order)
        self.spaces = out
        self._held: np.ndarray | None = None

    def _image(self, a: np.ndarray) -> np.ndarray:
        r = cv2.resize(a, (self.size, self.size), interpolation=cv2.INTER_AREA)
        return r if r.ndim == 3 else r[..., None]

    def _audio(self, clip: np.ndarray, first: bool) -> np.ndarray:
        if not self.hold_audio:
            return log_mel(clip, self.sample_rate, self.bands)
        if first or self._held is None:
            self._held = log_mel(clip, self.sample_rate, self.bands)
        return self._held.copy()

    def __call__(self, obs: dict[str, Any], first: bool = False) -> dict[str, Any]:
        """The compact form of one of the environment's observations (``first``: a reset's)."""
        out: dict[str, Any] = {}
        for k in self.spaces:
            v = obs[k]
            if k == "rgb":
                out[k] = self._image(v)
            elif k == "depth":
                d = np.minimum(v[..., 0], self.depth_max_m)
                d = self._image(d)[..., 0] / self.depth_max_m * 255.0
                out[k] = np.rint(d).astype(np.uint8)[..., None]
            elif k == "category_seg":
                out[k] = rarest_label_resize((v[..., 0] + 1).astype(np.uint8),
                                             self.size)[..., None]
            elif k == "audio":
                out[k] = self._audio(v, first)
            else:
                out[k] = v
        return out


class CompactObservation(gym.Wrapper):
    """A :class:`~fallgen.env.fallen_objects.FallenObjectsEnv` (or a wrapper of it) with the
    observations of the module's list: small 8-bit images, the clip as log-mel features.
    ``size``: the images' side; ``depth_max_m``: depth at level 255; ``bands``: mel bands
    per ear; ``hold_audio``: the step-0 clip's features at every step of the episode (the
    conversion itself is :class:`Compactor`)."""

    def __init__(self, env: gym.Env, size: int = SIZE, depth_max_m: float = DEPTH_MAX_M,
                 bands: int = BANDS, hold_audio: bool = True) -> None:
        super().__init__(env)
        inner = env.observation_space
        if not isinstance(inner, spaces.Dict):
            raise TypeError("CompactObservation wraps the Fallen Objects environment's Dict "
                            "observations")
        rate = None
        if "audio" in inner.spaces:
            base = env.unwrapped
            ids = getattr(base, "ids", None)
            rate = int(base.ds.row(ids[0])["sample_rate"]) if ids else 44100
        self.compactor = Compactor(dict(inner.spaces), rate, size, depth_max_m, bands,
                                   hold_audio)
        c = self.compactor
        self.size, self.depth_max_m, self.bands = c.size, c.depth_max_m, c.bands
        self.hold_audio, self.sample_rate = hold_audio, rate
        self.observation_space = spaces.Dict(c.spaces)

    def observation(self, obs: dict[str, Any], first: bool = False) -> dict[str, Any]:
        """The compact form of one of the environment's observations (``first``: a reset's)."""
        return self.compactor(obs, first)

    def reset(self, **kwargs: Any) -> tuple[dict[str, Any], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        return self.observation(obs, first=True), info

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self.observation(obs), reward, terminated, truncated, info


def compact_env(dataset: str | Path, split: str | None = None, *, size: int = SIZE,
                depth_max_m: float = DEPTH_MAX_M, bands: int = BANDS, hold_audio: bool = True,
                **env_kwargs: Any) -> CompactObservation:
    """``gymnasium.make("fallgen/FallenObjects-v0", ...)`` (its 200-step limit in its spec)
    wrapped in :class:`CompactObservation`; ``env_kwargs`` go to the environment (sensors,
    reward, claims, ...). Picklable as a factory for a library's subprocess vector env:
    ``functools.partial(compact_env, "build/smoke", "train")``."""
    import fallgen.env

    env = gym.make(fallgen.env.ENV_ID, dataset=str(dataset), split=split, **env_kwargs)
    return CompactObservation(env, size, depth_max_m, bands, hold_audio)


__all__ = ["CompactObservation", "Compactor", "compact_env", "rarest_label_resize", "log_mel",
           "band_power", "mel_filters", "SIZE", "DEPTH_MAX_M", "BANDS", "DB_FLOOR", "DB_CEIL"]
