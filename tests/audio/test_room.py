"""Shoebox room impulse responses (fallgen.audio.room) against analytic references and
pyroomacoustics."""

from __future__ import annotations

import numpy as np
import pytest

from fallgen.audio.room import (KERNEL, Arrivals, RoomAcoustics, arrivals, band_weights,
                                completeness_time, image_sources, late_reverb, omni_rir,
                                render_arrivals, RirSettings)

FS = 44100
DIM = (6.0, 4.0, 3.0)
SRC, MIC = (1.5, 1.2, 1.4), (4.2, 2.6, 1.6)


def _uniform(alpha, air=False):
    return RoomAcoustics(DIM, np.full((6, 7), alpha), np.asarray(
        [0.1e-3, 0.3e-3, 0.6e-3, 1.0e-3, 1.9e-3, 5.8e-3, 20.3e-3]) * air)


def test_band_weights_sum_to_one():
    f = np.linspace(0, 22050, 4000)
    w = band_weights(f)
    assert np.allclose(w.sum(0), 1.0) and (w >= 0).all()
    assert w[3, np.argmin(abs(f - 1000))] == pytest.approx(1.0, abs=1e-3)


def test_image_count_and_mirror_positions():
    im = image_sources(_uniform(0.2), SRC, 2)
    # images of order <= k in 3-D: 1 + 6 + 18 (2k^2 + ... ) -> (2k+1)(2k^2+2k+3)/3 = 25 at k = 2
    assert len(im.order) == 25
    first = im.positions[im.order == 1]
    want = {(-1.5, 1.2, 1.4), (10.5, 1.2, 1.4), (1.5, -1.2, 1.4), (1.5, 6.8, 1.4),
            (1.5, 1.2, -1.4), (1.5, 1.2, 4.6)}
    assert {tuple(np.round(p, 6)) for p in first} == want
    assert np.allclose(im.gains[im.order == 1], np.sqrt(0.8))


def test_direct_path_delay_and_amplitude():
    """The direct sound arrives at d / c with amplitude 1 / d (pressure re 1 m)."""
    room = _uniform(0.999999)  # anechoic: only the direct path survives
    h = omni_rir(room, SRC, MIC, None, RirSettings(max_order=1, length_s=0.1), late=False)
    d = float(np.linalg.norm(np.subtract(SRC, MIC)))
    i = int(np.argmax(np.abs(h)))
    # fractional delay: the band-limited peak is within half a sample of d / c
    assert abs(i - d / 343.0 * FS) <= 0.5 + 1e-9
    assert h.sum() == pytest.approx(1.0 / d, rel=0.01)  # DC gain of the arrival
    assert np.abs(h).max() == pytest.approx(1.0 / d, rel=0.15)


def test_matches_pyroomacoustics_omni_ism():
    """Same room, materials, air absorption and order as pyroomacoustics' ISM: energy within
    1 dB and normalised cross-correlation >= 0.9 after alignment."""
    pra = pytest.importorskip("pyroomacoustics")
    absorb = {"east": 0.1, "west": 0.1, "north": 0.3, "south": 0.05, "floor": 0.4, "ceiling": 0.2}
    order = 6
    mats = {k: pra.Material(energy_absorption=v) for k, v in absorb.items()}
    r = pra.ShoeBox(list(DIM), fs=FS, materials=mats, max_order=order, air_absorption=False)
    r.add_source(list(SRC))
    r.add_microphone(list(MIC))
    r.compute_rir()
    ref = np.asarray(r.rir[0][0], float)
    faces = ("west", "east", "south", "north", "floor", "ceiling")
    room = RoomAcoustics(DIM, np.array([[absorb[f]] * 7 for f in faces]), np.zeros(7))
    ours = omni_rir(room, SRC, MIC, None, RirSettings(max_order=order, length_s=0.3), late=False)
    n = min(len(ref), len(ours))
    cc = np.correlate(ref[:n], ours[:n], mode="full")
    lag = int(np.argmax(cc)) - (n - 1)
    a, b = (ref[lag:n], ours[:n - lag]) if lag >= 0 else (ref[:n + lag], ours[-lag:n])
    m = min(len(a), len(b))
    a, b = a[:m], b[:m]
    ncc = float(a @ b / np.sqrt((a @ a) * (b @ b)))
    energy_db = 10 * np.log10((b @ b) / (a @ a))
    assert ncc >= 0.9, ncc
    assert abs(energy_db) < 1.0, energy_db


def _schroeder_t30(h):
    edc = np.cumsum((h ** 2)[::-1])[::-1]
    db = 10 * np.log10(edc / edc[0] + 1e-300)
    k = np.nonzero((db <= -5) & (db >= -35))[0]
    return -60 / np.polyfit(k / FS, db[k], 1)[0]


@pytest.mark.parametrize("alpha", [0.1, 0.25, 0.5])
def test_rt60_agrees_with_eyring(alpha):
    """Uniform absorption, no air: the Schroeder T30 of the rendered response (image sources
    and late reverb) is within 10 % of Eyring."""
    room = _uniform(alpha)
    h = omni_rir(room, SRC, MIC, np.random.default_rng(0), RirSettings(length_s=2.0))
    t30 = _schroeder_t30(h)
    assert t30 == pytest.approx(room.eyring_rt60()[3], rel=0.1), (t30, room.eyring_rt60()[3])


def test_late_reverb_joins_without_a_jump():
    """Averaged over source/listener pairs, the level just after the completeness time is
    within 2 dB of the image sources' level just before it; nothing is silent in between."""
    room = _uniform(0.05, air=True)
    rng = np.random.default_rng(1)
    steps = []
    for k in range(6):
        src = rng.uniform(0.3, np.subtract(DIM, 0.3))
        mic = rng.uniform(0.3, np.subtract(DIM, 0.3))
        tc = completeness_time(room, src, mic, 6)
        h = omni_rir(room, src, mic, np.random.default_rng(k))
        pre = h[int((tc - 0.02) * FS):int((tc - 0.0025) * FS)]
        post = h[int((tc + 0.0025) * FS):int((tc + 0.02) * FS)]
        steps.append(10 * np.log10((post ** 2).mean() / (pre ** 2).mean()))
        gap = h[int(tc * FS) - 200:int(tc * FS) + 200]
        assert (gap ** 2).mean() > 0.01 * (pre ** 2).mean()
    assert abs(np.mean(steps)) < 2.0, steps


def test_an_arrival_is_its_band_limited_fractional_delay():
    """Two arrivals with flat bands and flat ear spectra render as the real inverse DFT of
    e^(-2 pi i k (KERNEL / 2 + frac) / KERNEL) (a naive sum over bins, no FFT) placed at
    their whole-sample delays and added; one beyond the output is left out."""
    fs, n_out = 48000, 3000
    delays = np.array([(700 + 0.37) / fs, (705 + 0.81) / fs, (n_out + 10) / fs])
    arr = Arrivals(delays, np.array([[1.0] * 7, [0.5] * 7, [1.0] * 7]), np.zeros((3, 3)))
    h = render_arrivals(arr, n_out, fs, np.ones((3, 2, KERNEL // 2 + 1), complex))
    n = np.arange(KERNEL)[:, None]
    k = np.arange(KERNEL // 2 + 1)[None, :]
    twice = np.where((k == 0) | (k == KERNEL // 2), 1.0, 2.0)
    want = np.zeros(n_out + KERNEL)
    for (w, frac), a in zip(((700, 0.37), (705, 0.81)), (1.0, 0.5)):
        x = np.exp(-2j * np.pi * k * (KERNEL // 2 + frac) / KERNEL)
        kern = (twice * (x * np.exp(2j * np.pi * k * n / KERNEL)).real).sum(1) / KERNEL
        want[w:w + KERNEL] += a * kern
    want = want[KERNEL // 2:KERNEL // 2 + n_out]
    assert np.abs(h - want[None, :]).max() < 1e-12
    # the kernel peaks at the delay: between samples 700 and 701, nearer 700
    assert np.argmax(h[0]) == 700 and h[1].sum() == pytest.approx(1.5, rel=1e-9)


def test_a_shorter_late_reverb_is_the_start_of_the_longer_draw_for_draw():
    """Made for fewer samples with the noise drawn for the whole length, the late reverb is the
    whole one's start to the bit, and the generator is left where the whole one leaves it;
    drawn for its own length only, it is other noise."""
    room = _uniform(0.2, air=True)
    ears, level = np.ones((2, 513)), np.full(7, 1e-4)
    r_full, r_short, r_own = (np.random.default_rng(4) for _ in range(3))
    full = late_reverb(room, level, 0.05, 2 * FS, FS, r_full, ears)
    short = late_reverb(room, level, 0.05, FS // 2, FS, r_short, ears, noise_n=2 * FS)
    own = late_reverb(room, level, 0.05, FS // 2, FS, r_own, ears)
    assert np.array_equal(short, full[:, :FS // 2])
    assert r_short.random() == r_full.random()
    assert not np.allclose(own, short)


def test_deterministic_for_the_same_generator():
    room = _uniform(0.2, air=True)
    a = omni_rir(room, SRC, MIC, np.random.default_rng(5), RirSettings(length_s=0.5))
    b = omni_rir(room, SRC, MIC, np.random.default_rng(5), RirSettings(length_s=0.5))
    assert np.array_equal(a, b) and np.isfinite(a).all()


def test_source_outside_the_room_is_refused():
    with pytest.raises(ValueError):
        arrivals(_uniform(0.2), (7.0, 1.0, 1.0), MIC, 2)


def test_sabine_and_eyring_of_a_shoebox():
    """A 6 x 4 x 3 m shoebox absorbing 0.6 on its ceiling and 0.04 elsewhere (1 kHz, no
    air): Sabine's 0.161 V / A is pyroomacoustics' rt60_theory("sabine") within 0.5 % (its
    constant is 24 ln 10 / 343.2); Eyring's 0.161 V / (-S ln(1 - mean alpha)) is the hand
    value 0.597 s (V 72 m^3, S 108 m^2, mean alpha 0.1644). pyroomacoustics' "eyring" sums
    -S_i ln(1 - alpha_i) over the faces (Millington-Sette: 0.456 s here), another formula."""
    pra = pytest.importorskip("pyroomacoustics")
    wa = np.full((6, 7), 0.04)
    wa[5] = 0.6
    room = RoomAcoustics(DIM, wa, np.zeros(7))
    names = ("west", "east", "south", "north", "floor", "ceiling")
    ref = pra.ShoeBox(list(DIM), fs=FS, max_order=1, air_absorption=False,
                      materials={k: pra.Material(float(wa[i, 3])) for i, k in enumerate(names)})
    assert room.sabine_rt60()[3] == pytest.approx(ref.rt60_theory(formula="sabine"), rel=0.005)
    mean_alpha = (24 * 0.6 + 84 * 0.04) / 108
    assert room.eyring_rt60()[3] == pytest.approx(0.161 * 72 / (-108 * np.log(1 - mean_alpha)),
                                                  rel=1e-9)
    assert room.eyring_rt60()[3] == pytest.approx(0.597, abs=0.001)
