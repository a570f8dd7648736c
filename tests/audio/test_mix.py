"""Binaural responses and the clip mix (fallgen.audio.mix)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fallgen.audio.hrtf import load_sofa, spherical_head
from fallgen.audio.mix import (FULL_SCALE_PA, DrySource, Listener, binaural_rir,
                               fast_level_db_spl, fast_max_db_spl, levels_db_spl, mix,
                               write_wav)
from fallgen.audio.room import RirSettings, RoomAcoustics

FS = 44100
SOFA = Path(__file__).resolve().parents[3] / "shared" / "data" / "hrtf" / "sadie_ku100_48k.sofa"
ROOM = RoomAcoustics((6.0, 4.0, 3.0), np.full((6, 7), 0.2), np.zeros(7))
HEAD = Listener(np.array([3.0, 2.0, 1.2]), yaw_rad=0.0)
SHORT = RirSettings(length_s=0.6)


@pytest.fixture(scope="module", params=["spherical", "ku100"])
def hrtf(request):
    if request.param == "spherical":
        return spherical_head()
    if not SOFA.exists():
        pytest.skip(f"{SOFA} not present")
    return load_sofa(SOFA)


def _direct(h, src, head=HEAD):
    n0 = int(np.linalg.norm(np.subtract(src, head.position)) / 343.0 * FS)
    return h[:, n0 - 60:n0 + 60]


def test_left_source_is_louder_and_earlier_in_the_left_ear(hrtf):
    src = (3.0, 3.5, 1.2)  # +y = the listener's left at yaw 0
    w = _direct(binaural_rir(ROOM, src, HEAD, hrtf, np.random.default_rng(0), SHORT), src)
    assert (w[0] ** 2).sum() > 4 * (w[1] ** 2).sum()  # > 6 dB
    assert np.argmax(np.abs(w[0])) < np.argmax(np.abs(w[1]))


def test_turning_the_head_swaps_the_ears(hrtf):
    """The same source heard after a 180 degree turn: left and right exchange."""
    src = (3.0, 3.5, 1.2)
    turned = Listener(HEAD.position, yaw_rad=np.pi)
    w = _direct(binaural_rir(ROOM, src, turned, hrtf, np.random.default_rng(0), SHORT), src)
    assert (w[1] ** 2).sum() > 4 * (w[0] ** 2).sum()


def test_source_in_front_is_symmetric(hrtf):
    src = (5.0, 2.0, 1.2)
    w = _direct(binaural_rir(ROOM, src, HEAD, hrtf, np.random.default_rng(0), SHORT), src)
    ild = 10 * np.log10((w[0] ** 2).sum() / (w[1] ** 2).sum())
    assert abs(ild) < 1.0
    assert np.argmax(np.abs(w[0])) == np.argmax(np.abs(w[1]))


def test_direct_sound_arrives_at_distance_over_c():
    """Delays count from the head centre: the frontal direct sound peaks at d / c."""
    src = (5.0, 2.0, 1.2)
    h = binaural_rir(ROOM, src, HEAD, spherical_head(), np.random.default_rng(0), SHORT)
    n0 = 2.0 / 343.0 * FS  # the first reflection (floor) arrives 3.1 m / c, 400 samples
    assert abs(int(np.argmax(np.abs(h[0, :350]))) - n0) <= 2
    assert np.abs(h[:, :int(n0) - 20]).max() < 0.05 * np.abs(h[0, :350]).max()  # nothing early


def _check_direct_sum(p, i0, distance_m, amplitude_pa):
    """The direct sound's samples sum to the click's over the distance (1/r, r in metres)."""
    n0 = i0 + int(distance_m / 343.0 * FS)
    got = p[:, n0 - 60:n0 + 60].sum(axis=1)
    np.testing.assert_allclose(got, amplitude_pa / distance_m, rtol=0.01)


def test_mix_units_headroom_and_determinism():
    rng = np.random.default_rng(0)
    click = np.zeros(FS)
    click[100] = 1.0  # 1 Pa at 1 m
    srcs = [DrySource(np.array([5.0, 2.0, 1.2]), click),
            DrySource(np.array([4.0, 3.0, 0.5]), 0.5 * np.roll(click, 2000))]
    hr = spherical_head()
    a = mix(ROOM, srcs, HEAD, hr, np.random.default_rng(3), SHORT)
    b = mix(ROOM, srcs, HEAD, hr, np.random.default_rng(3), SHORT)
    assert a.audio.dtype == np.float32 and a.audio.shape == (2, int(0.6 * FS))
    assert np.array_equal(a.audio, b.audio) and a.gain == 1.0
    p = a.pressure_pa()
    # the first click's direct sound, 2 m away, is 1 Pa x 1 m / 2 m: its samples (+-60 around
    # its arrival, before the floor's reflection at 3.1 m) sum to 0.5 Pa in each ear, the
    # spherical head's filters passing 0 Hz unchanged (within 1 %)
    _check_direct_sum(p, 100, 2.0, 1.0)
    with pytest.raises(AssertionError):  # a mix that lost the 1 / r law
        _check_direct_sum(2.0 * p, 100, 2.0, 1.0)
    loud = mix(ROOM, [DrySource(srcs[0].position, 1e4 * click)], HEAD, hr, rng, SHORT)
    assert loud.gain < 1.0 and np.abs(loud.audio).max() <= 0.99 + 1e-6
    # the recorded gain restores absolute pressure: 1e4 times the first click's direct sound
    assert np.abs(loud.pressure_pa()[:, :2000]).max() == pytest.approx(
        1e4 * np.abs(mix(ROOM, srcs[:1], HEAD, hr, rng, SHORT).pressure_pa()[:, :2000]).max(),
        rel=1e-3)
    assert FULL_SCALE_PA == 20.0


def test_single_precision_convolutions_match_double(monkeypatch):
    """The mix's float32 FFT convolutions stay within 1e-6 of the clip's peak of the float64
    ones, over a 2 s clip (its late response ~1 s) and sources that ring on."""
    import fallgen.audio.mix as mix_module

    t = np.arange(2 * FS) / FS
    ring = np.sin(2 * np.pi * 1234.5 * t) * np.exp(-3 * t)
    srcs = [DrySource(np.array([5.0, 2.0, 1.2]), ring),
            DrySource(np.array([1.0, 3.5, 0.1]), 0.3 * np.roll(ring, 5000))]
    settings = RirSettings(length_s=2.0)
    single = mix(ROOM, srcs, HEAD, spherical_head(), np.random.default_rng(5), settings)
    monkeypatch.setattr(mix_module, "CONVOLUTION_DTYPE", np.float64)
    double = mix(ROOM, srcs, HEAD, spherical_head(), np.random.default_rng(5), settings)
    assert single.gain == pytest.approx(double.gain, rel=1e-6)
    err = np.abs(single.pressure_pa() - double.pressure_pa()).max()
    assert 0 < err <= 1e-6 * np.abs(double.pressure_pa()).max()


def test_the_late_reverb_left_out_lies_100_db_under_the_clip(monkeypatch):
    """Convolved with the late reverb until its slowest band (0.48 s) has decayed 100 dB, a
    2 s clip of a source ringing on for seconds is the clip convolved with the whole 2 s to
    within 1e-5 of its peak; the part left out is not nothing (over 1e-7, float32's step)."""
    import fallgen.audio.mix as mix_module

    room = RoomAcoustics((6.0, 4.0, 3.0), np.full((6, 7), 0.2),
                         np.asarray([0.1, 0.3, 0.6, 1.0, 1.9, 5.8, 20.3]) * 1e-3)
    t = np.arange(2 * FS) / FS
    srcs = [DrySource(np.array([5.0, 2.0, 1.2]), np.sin(2 * np.pi * 1234.5 * t)
                      * np.exp(-3 * t))]
    settings = RirSettings(length_s=2.0)
    assert mix_module.late_length(room, 0.05, FS, 2 * FS) < 1.1 * FS
    cut = mix(room, srcs, HEAD, spherical_head(), np.random.default_rng(5), settings)
    monkeypatch.setattr(mix_module, "LATE_RANGE_DB", 1e4)
    whole = mix(room, srcs, HEAD, spherical_head(), np.random.default_rng(5), settings)
    err = np.abs(cut.pressure_pa() - whole.pressure_pa()).max()
    assert 1e-7 < err / np.abs(whole.pressure_pa()).max() <= 1e-5


def test_write_wav_roundtrip(tmp_path):
    import soundfile as sf

    clip = mix(ROOM, [DrySource(np.array([5.0, 2.0, 1.2]), np.r_[np.zeros(50), 1.0, np.zeros(FS)])],
               HEAD, spherical_head(), np.random.default_rng(0), SHORT)
    write_wav(tmp_path / "a.wav", clip)
    data, fs = sf.read(tmp_path / "a.wav", dtype="float32")
    assert fs == FS and data.shape == clip.audio.T.shape and np.array_equal(data, clip.audio.T)


#: IEC 61672-1:2013 table 4, F time weighting: a 4 kHz tone burst's maximum level relative to
#: the steady tone's, dB, with class 1's acceptance limits (burst duration s: reference, -, +).
IEC_F_BURSTS = [(0.2, -1.0, 0.5, 0.5), (0.002, -18.0, 1.5, 1.0), (0.00025, -27.0, 3.0, 1.0)]


def _burst(duration_s: float, fs: int) -> np.ndarray:
    """A 4 kHz tone burst of unit amplitude, a whole number of cycles from a zero crossing,
    after 10 ms of silence, followed by 0.5 s of silence."""
    t = np.arange(int(fs * 0.5)) / fs
    tone = np.where(t < duration_s, np.sin(2 * np.pi * 4000 * t), 0.0)
    return np.concatenate([np.zeros(int(0.01 * fs)), tone])


@pytest.mark.parametrize("fs", [48000, 44100])
@pytest.mark.parametrize("duration_s, ref_db, minus, plus", IEC_F_BURSTS)
def test_fast_time_weighting_tone_bursts(fs, duration_s, ref_db, minus, plus):
    """The F-time-weighted level's maximum for a 4 kHz burst, relative to the steady tone's
    level (its Leq, a sine's 0.5 Pa^2 per Pa^2 of amplitude), is IEC 61672-1's table 4 value
    within class 1's limits, and within 0.05 dB of the defining response 10 lg(1 -
    exp(-T_b / 0.125 s))."""
    steady = 10 * np.log10(0.5 / 4e-10)
    got = fast_max_db_spl(_burst(duration_s, fs)[None, :], fs) - steady
    assert ref_db - minus <= got <= ref_db + plus
    assert got == pytest.approx(10 * np.log10(1 - np.exp(-duration_s / 0.125)), abs=0.05)


def test_rectangular_window_is_not_the_fast_weighting():
    """The dataset's Leq over the loudest 125 ms window is not the F weighting: a 200 ms burst
    fills the window (0 dB), outside table 4's -1.0 +- 0.5 dB that the F weighting meets."""
    fs = 44100
    steady = 10 * np.log10(0.5 / 4e-10)
    x = _burst(0.2, fs)[None, :]
    assert levels_db_spl(x, fs)[1] - steady > -0.5
    assert -1.5 <= fast_max_db_spl(x, fs) - steady <= -0.5


def test_fast_time_weighting_decays_at_34_7_db_per_second():
    """After a steady tone stops the F-weighted level falls at 10 lg(e) / 0.125 s = 34.7 dB/s
    (IEC 61672-1: at least 25 dB/s), and during it stays at the tone's level."""
    fs = 44100
    t = np.arange(2 * fs) / fs
    x = np.where(t < 1.0, np.sin(2 * np.pi * 1000 * t), 0.0)
    level = fast_level_db_spl(x, fs)
    assert level[int(0.99 * fs)] == pytest.approx(10 * np.log10(0.5 / 4e-10), abs=0.05)
    i0, i1 = int(1.1 * fs), int(1.6 * fs)
    slope = (level[i1] - level[i0]) / ((i1 - i0) / fs)
    assert slope == pytest.approx(-10 * np.log10(np.e) / 0.125, rel=0.005)
