"""The ambient noise floor (audio/ambient.py): the level set exactly in dB(A), the neutral
-5 dB/octave spectrum, diffuse-field coherence between the ears, reproducible from the
generator; mixed under a fall's clip without clipping."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import coherence, welch

from fallgen.audio.ambient import a_weighting_db, ambient_noise, db_a

FS = 44100
#: ANSI/ASA S12.2 (RC Mark II): the neutral background falls 5 dB per octave
NEUTRAL_SLOPE_DB_PER_OCTAVE = -5.0
#: twice the mean adult head radius, 8.75 cm (Brown & Duda's spherical head; Algazi et al.
#: 2001, the CIPIC heads)
EAR_SPACING_M = 0.175
#: IEC 61672-1:2013 table 3, A-weighting at the nominal third-octave frequencies (dB)
IEC_A_THIRDS = {25: -44.7, 31.5: -39.4, 40: -34.6, 50: -30.2, 63: -26.2, 80: -22.5,
                100: -19.1, 125: -16.1, 160: -13.4, 200: -10.9, 250: -8.6, 315: -6.6,
                400: -4.8, 500: -3.2, 630: -1.9, 800: -0.8, 1000: 0.0, 1250: 0.6, 1600: 1.0,
                2000: 1.2, 2500: 1.3, 3150: 1.2, 4000: 1.0, 5000: 0.5, 6300: -0.1, 8000: -1.1,
                10000: -2.5, 12500: -4.3, 16000: -6.6, 20000: -9.3}


def band_sum_db_a(p: np.ndarray, fs: int) -> float:
    """The A-weighted level as a sound level meter with a third-octave analyser sums it: the
    power in each third-octave band (exact centres 1000 * 2^(k/3), edges 2^(+-1/6) around
    them; Parseval over the FFT) weighted by IEC 61672-1's tabulated value for the band, the
    mean over the rows (ears)."""
    p = np.atleast_2d(p)
    spec = np.abs(np.fft.rfft(p, axis=-1)) ** 2 / p.shape[-1] ** 2
    spec[:, 1:] *= 2.0
    f = np.fft.rfftfreq(p.shape[-1], 1.0 / fs)
    total = 0.0
    for k, a_db in zip(range(-16, 14), IEC_A_THIRDS.values()):
        fc = 1000.0 * 2 ** (k / 3)
        band = (f >= fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))
        total += spec[:, band].sum() / len(p) * 10 ** (a_db / 10)
    return 10 * np.log10(total / 4e-10)


def test_a_weighting_matches_the_iec_table():
    # IEC 61672-1 table 3 (nominal, dB)
    table = {31.5: -39.4, 63: -26.2, 125: -16.1, 250: -8.6, 500: -3.2, 1000: 0.0,
             2000: 1.2, 4000: 1.0, 8000: -1.1, 16000: -6.6}
    got = a_weighting_db(np.array(list(table)))
    assert np.allclose(got, list(table.values()), atol=0.15)


@pytest.mark.parametrize("level", [25.0, 30.0, 42.5])
def test_level_is_set_exactly_and_reproducible(level):
    a = ambient_noise(2 * FS, FS, level, np.random.default_rng(3))
    assert a.shape == (2, 2 * FS)
    assert db_a(a, FS) == pytest.approx(level, abs=1e-9)
    # measured independently, with the standard's tabulated weights band by band
    assert band_sum_db_a(a, FS) == pytest.approx(level, abs=0.1)
    with pytest.raises(AssertionError):  # a floor 1 dB off would be seen
        assert band_sum_db_a(a * 10 ** (1 / 20), FS) == pytest.approx(level, abs=0.1)
    assert np.array_equal(a, ambient_noise(2 * FS, FS, level, np.random.default_rng(3)))
    assert not np.array_equal(a, ambient_noise(2 * FS, FS, level, np.random.default_rng(4)))


def test_spectrum_falls_five_db_per_octave_and_ears_are_diffuse():
    a = ambient_noise(8 * FS, FS, 30.0, np.random.default_rng(0))
    f, p = welch(a[0], FS, nperseg=8192)
    level = {fc: 10 * np.log10(p[(f >= fc / 2 ** 0.5) & (f < fc * 2 ** 0.5)].sum())
             for fc in (125, 250, 500, 1000, 2000, 4000)}
    # octave bands: band power ~ bandwidth (x2 per octave, +3 dB) times the density slope
    steps = [level[2 * fc] - level[fc] for fc in (125, 250, 500, 1000, 2000)]
    assert np.allclose(steps, NEUTRAL_SLOPE_DB_PER_OCTAVE + 10 * np.log10(2), atol=1.0)
    f, c = coherence(a[0], a[1], FS, nperseg=4096)
    for fc in (60, 250, 500, 2000):
        want = np.sinc(2 * fc * EAR_SPACING_M / 343.0) ** 2
        assert float(np.interp(fc, f, c)) == pytest.approx(want, abs=0.08)


def test_the_clip_carries_the_floor_before_the_fall_and_never_clips():
    from fallgen.audio.hrtf import spherical_head
    from fallgen.audio.mix import Binaural, DrySource, Listener
    from fallgen.audio.room import RirSettings, RoomAcoustics

    from fallgen.audio.room import OCTAVE_BANDS_HZ

    rm = RoomAcoustics((5.0, 4.0, 2.7), np.full((6, len(OCTAVE_BANDS_HZ)), 0.2))
    sig = np.zeros(FS)
    sig[FS // 2] = 50.0  # a very loud click half a second in: the clip is scaled down
    src = [DrySource(np.array([1.0, 1.0, 0.5]), sig)]
    head = Listener(np.array([3.0, 2.0, 1.1]))
    settings = RirSettings(3, FS, 1.0)
    b = Binaural(spherical_head())
    clip = b.mix(rm, src, head, np.random.default_rng(1), settings, noise_db_a=30.0)
    quiet = b.mix(rm, src, head, np.random.default_rng(1), settings)
    assert clip.noise_db_a == 30.0 and clip.gain < 1 and np.abs(clip.audio).max() <= 0.99 + 1e-6
    # the fall's own levels are those of the clip without the floor
    assert clip.fall_levels == pytest.approx(quiet.levels_db_spl(), abs=1e-6)
    before = clip.pressure_pa()[:, : FS // 2 - 200]
    assert db_a(before, FS) == pytest.approx(30.0, abs=1.0)
    assert band_sum_db_a(before, FS) == pytest.approx(30.0, abs=1.0)
    # without the floor, digital silence (the FFT convolutions' rounding: below 0 dB SPL)
    assert quiet.noise_db_a == 0.0 and db_a(quiet.pressure_pa()[:, : FS // 2 - 200], FS) < 0
