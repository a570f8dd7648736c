"""One interaural-time-difference sign everywhere: ITD = the right ear's arrival time minus
the left ear's, > 0 when the source is on the left (the left ear hears first). The HRTF
(fallgen.audio.hrtf: Woodworth's formula, the spherical head) and the perception module's
features (fallgen.perception.audio_features) must agree on it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import fftconvolve

from fallgen.audio.hrtf import spherical_head, woodworth_itd
from fallgen.perception.audio_features import AudioFeatures

FS = 44100


def _heard(head, azimuth_deg: float) -> np.ndarray:
    """A decaying broadband (white noise) burst at 0.2 s through the spherical head's response
    from ``azimuth_deg`` (counter-clockwise from the front: +90 is the left), both ears (a
    tone's cross-correlation would repeat every period)."""
    az = math.radians(azimuth_deg)
    h = head.hrir[head.nearest(np.array([[math.cos(az), math.sin(az), 0.0]]))[0]]
    rng = np.random.default_rng(0)
    tau = np.arange(FS) / FS - 0.2
    burst = np.where(tau >= 0, rng.standard_normal(FS) * np.exp(-tau / 0.05), 0.0)
    noise = 1e-6 * rng.standard_normal((2, FS))
    return np.stack([fftconvolve(burst, h[e])[:FS] for e in (0, 1)]) + noise


@pytest.mark.parametrize("azimuth_deg", [60.0, -60.0])
def test_features_itd_has_woodworths_sign(azimuth_deg):
    """A source at azimuth +60 degrees (left) gives a positive ITD in every ITD feature, one
    at -60 a negative one. The cross-correlation ITDs are within 15 % (and a sample) of
    Woodworth's (a/c)(theta + sin theta) = 0.488 ms: the spherical head's broadband ITD is
    5-7 % below Woodworth's (audio/hrtf.py) and the features are whole samples (0.023 ms).
    The first-arrival differences are cruder (the shadowed ear's onset rises more slowly:
    0.59 and 0.79 ms here): their sign, and within a factor of two."""
    f = AudioFeatures(clip_samples=FS)
    x = f.extract(_heard(spherical_head(), azimuth_deg))
    want = woodworth_itd(math.radians(azimuth_deg)) * 1e3  # ms, > 0 on the left
    assert (want > 0) == (azimuth_deg > 0)
    for name in ("itd_4ms", "itd_12ms", "itd_50ms"):
        got = float(x[f.names.index(name)])
        assert got == pytest.approx(want, rel=0.15, abs=1e3 / FS), name
    for name in ("itd_onset5", "itd_onset10"):
        got = float(x[f.names.index(name)])
        assert 0.5 < got / want < 2.0, name


def test_feature_version_marks_the_sign():
    """Models trained on features of the old sign (version 4 and before) are refused: the
    features' version is 5 or more."""
    assert AudioFeatures().version >= 5
