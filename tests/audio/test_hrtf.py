"""HRTFs: the Brown-Duda spherical head and a measured SOFA set (SADIE KU100) behave like heads."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.signal import correlate, correlation_lags, resample_poly

from fallgen.audio.heads import PACKAGED
from fallgen.audio.hrtf import (
    MARGIN_SAMPLES,
    Hrtf,
    load_sofa,
    solid_angle_weights,
    spherical_head,
    woodworth_itd,
)
from fallgen.errors import InputError

SOFA = PACKAGED  # the measured head shipped with fallgen
needs_sofa = pytest.mark.skipif(not SOFA.is_file(), reason=f"test HRTF {SOFA} is not available")


def unit(az_deg: float, el_deg: float = 0.0) -> np.ndarray:
    az, el = math.radians(az_deg), math.radians(el_deg)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def itd_s(h: np.ndarray, fs: int) -> float:
    """t_right - t_left (positive: the left ear leads) from the cross-correlation peak, with
    parabolic sub-sample interpolation."""
    c = correlate(h[1], h[0], "full")
    lags = correlation_lags(len(h[1]), len(h[0]))
    k = int(np.argmax(c))
    y0, y1, y2 = c[k - 1], c[k], c[k + 1]
    return (lags[k] + 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)) / fs


def ild_db(h: np.ndarray, fs: int, lo: float = 0.0, hi: float = math.inf) -> float:
    """Left over right energy in dB, in the band [lo, hi) Hz."""
    p = np.abs(np.fft.rfft(h, 4096, axis=-1)) ** 2
    f = np.fft.rfftfreq(4096, 1.0 / fs)
    band = (f >= lo) & (f < hi)
    return float(10 * np.log10(p[0, band].sum() / p[1, band].sum()))


def response(hrtf: Hrtf, az: float, el: float = 0.0) -> np.ndarray:
    return hrtf.hrir[hrtf.nearest(unit(az, el)[None])[0]]


@pytest.fixture(scope="module")
def head() -> Hrtf:
    return spherical_head()


@pytest.fixture(scope="module")
def ku100() -> Hrtf:
    if not SOFA.is_file():
        pytest.skip(f"test HRTF {SOFA} is not available")
    return load_sofa(SOFA)


def test_woodworth():
    assert woodworth_itd(0.0) == 0.0
    assert woodworth_itd(math.pi / 2) == pytest.approx(0.0875 / 343 * (math.pi / 2 + 1))
    assert woodworth_itd(math.pi / 2) == pytest.approx(656e-6, rel=1e-3)
    assert woodworth_itd(-0.5) == -woodworth_itd(0.5)


def test_spherical_head_structure(head):
    d, h = head.directions, head.hrir
    assert head.sample_rate == 44100 and d.shape == (2048, 3) and h.shape == (2048, 2, 64)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert len(np.unique(np.round(d, 9), axis=0)) == len(d)
    assert np.array_equal(head.nearest(d * 2.5), np.arange(len(d)))
    # DC gain 1 where the ear is lit, nearly 1 behind the head (truncated shadow tail)
    ears = np.array([unit(100.0), unit(-100.0)])
    lit = d @ ears.T > 0
    dc = h.sum(axis=-1)
    assert np.all(np.abs(dc[lit] - 1) < 0.005) and np.all(np.abs(dc - 1) < 0.02)
    # causal: nothing before the first MARGIN_SAMPLES of the earliest (facing) responses, and
    # the energy before each onset (first sample within 20 dB of the peak) minus the margin is tiny
    energy = (h**2).sum(axis=-1)
    onset = np.argmax(np.abs(h) > 0.1 * np.abs(h).max(axis=-1, keepdims=True), axis=-1)
    n = np.arange(h.shape[-1])
    pre = np.where(n < onset[..., None] - MARGIN_SAMPLES + 1, h**2, 0.0).sum(axis=-1)
    assert np.max(pre / energy) < 1e-4


def test_spherical_head_itd_matches_woodworth(head):
    itd = itd_s(response(head, 90.0), head.sample_rate)
    wood = woodworth_itd(math.pi / 2)
    # Brown-Duda's ears at +-100 degrees: delay formula 607 us (-7.4 %), measured ~620 us
    assert itd == pytest.approx(wood, rel=0.10)
    assert itd_s(response(head, -90.0), head.sample_rate) == pytest.approx(-wood, rel=0.10)


def assert_lateral(hrtf, az):
    """A source at +az (left) is louder and earlier in the left ear, at -az in the right;
    returns the two responses."""
    left, right = response(hrtf, az), response(hrtf, -az)
    fs = hrtf.sample_rate
    assert ild_db(left, fs) > 3.0 and itd_s(left, fs) > 100e-6
    assert ild_db(right, fs) < -3.0 and itd_s(right, fs) < -100e-6
    return left, right


@pytest.mark.parametrize("az", [30.0, 60.0, 90.0])
def test_spherical_head_lateral(head, az):
    left, right = assert_lateral(head, az)
    fs = head.sample_rate
    assert ild_db(left, fs) == pytest.approx(-ild_db(right, fs), abs=1.0)  # near mirror images


def test_spherical_head_front_is_balanced(head):
    h = response(head, 0.0)
    assert abs(itd_s(h, head.sample_rate)) < 5e-6
    assert abs(ild_db(h, head.sample_rate)) < 0.1


def brown_duda_ild_db(az_deg: float, lo: float, hi: float, fs: int = 44100) -> float:
    """Brown & Duda (1998)'s head shadow, written out: each ear's |H(w)|^2 with
    H = (1 + j alpha w / 2w0) / (1 + j w / 2w0), w0 = c / a, alpha = 1.05 + 0.95
    cos(theta 180/150) for theta the angle from the ear's axis (ears at +-100 degrees), summed
    over the band's bins of a 4096-point spectrum: left over right in dB."""
    f = np.fft.rfftfreq(4096, 1.0 / fs)
    f = f[(f >= lo) & (f < hi)]
    w, w0 = 2 * math.pi * f, 343.0 / 0.0875

    def power(ear_az: float) -> float:
        theta = math.radians(abs((az_deg - ear_az + 180) % 360 - 180))
        alpha = 1.05 + 0.95 * math.cos(theta * 180 / 150)
        return float((np.abs((1 + 1j * alpha * w / (2 * w0)) / (1 + 1j * w / (2 * w0))) ** 2)
                     .sum())

    return 10 * math.log10(power(100.0) / power(-100.0))


@pytest.mark.parametrize("az", [30.0, 60.0, 90.0])
def test_spherical_head_ild_is_brown_and_dudas_head_shadow(head, az):
    """The level difference per band is Brown & Duda's head-shadow filters' within 1 dB (the
    responses are cut to 64 taps and tapered near Nyquist); it grows with frequency."""
    h, fs = response(head, az), head.sample_rate
    for lo, hi in ((50, 1000), (1000, 4000), (4000, 16000)):
        assert ild_db(h, fs, lo, hi) == pytest.approx(brown_duda_ild_db(az, lo, hi), abs=1.0)
    assert ild_db(h, fs, 4000, 16000) > ild_db(h, fs, 50, 1000) + 5


@needs_sofa
def test_sofa_loads(ku100):
    d, h = ku100.directions, ku100.hrir
    assert ku100.sample_rate == 44100 and ku100.name == SOFA.name
    assert d.shape == (1550, 3)  # 1555 measured, the zenith 6 times: 5 repeats merged
    assert h.shape[:2] == (1550, 2) and h.shape[2] == math.ceil(256 * 147 / 160)
    assert h.dtype == np.float64 and np.all(np.isfinite(h))
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    gram = d @ d.T - 2 * np.eye(len(d))
    assert gram.max() < 1 - 1e-9  # no two directions equal


@needs_sofa
def test_sofa_repeated_zenith_keeps_first(ku100):
    with h5py.File(SOFA, "r") as f:
        pos, ir = f["SourcePosition"][()], f["Data.IR"][()]
    first = int(np.flatnonzero(pos[:, 1] == 90.0)[0])
    i = ku100.nearest(np.array([[0.0, 0.0, 1.0]]))[0]
    assert np.allclose(ku100.directions[i], [0, 0, 1], atol=1e-9)
    assert np.allclose(ku100.hrir[i], resample_poly(ir[first], 147, 160, axis=-1))


@needs_sofa
@pytest.mark.parametrize("az", [30.0, 60.0, 90.0])
def test_sofa_lateral(ku100, az):
    left, right = assert_lateral(ku100, az)
    fs = ku100.sample_rate
    if az == 90.0:  # the near ear: louder by more than 6 dB, 0.6-1.0 ms earlier
        assert ild_db(left, fs) > 6.0 and ild_db(right, fs) < -6.0
        assert 0.6e-3 < itd_s(left, fs) < 1.0e-3 and -1.0e-3 < itd_s(right, fs) < -0.6e-3


@needs_sofa
def test_sofa_front_is_balanced(ku100):
    h = response(ku100, 0.0)
    assert abs(itd_s(h, ku100.sample_rate)) < 25e-6 and abs(ild_db(h, ku100.sample_rate)) < 1.0


@needs_sofa
@pytest.mark.parametrize("az, el", [(0, 0), (90, 0), (180, 0), (270, 0), (45, 0), (0, 90)])
def test_sofa_nearest(ku100, az, el):
    want = unit(az, el)
    exact = ku100.nearest(3.0 * want[None])[0]
    assert np.allclose(ku100.directions[exact], want, atol=1e-9)
    # a query 1 degree off (the grid is coarser) still finds the measured direction
    assert ku100.nearest(unit(az + 1.0, min(el, 89.0))[None])[0] == exact


def _corrupt_copy(tmp_path: Path, edit) -> Path:
    out = tmp_path / "broken.sofa"
    shutil.copyfile(SOFA, out)
    with h5py.File(out, "r+") as f:
        edit(f)
    return out


def _replace(name, value):
    def edit(f):
        old = dict(f[name].attrs)
        del f[name]
        f[name] = value
        for k in ("Type", "Units"):
            if k in old:
                f[name].attrs[k] = old[k]
    return edit


@needs_sofa
@pytest.mark.parametrize("field, edit, words", [
    ("Data.IR", lambda f: f.__delitem__("Data.IR"), "missing"),
    ("Data.SamplingRate", lambda f: f.__delitem__("Data.SamplingRate"), "missing"),
    ("SourcePosition", lambda f: f.__delitem__("SourcePosition"), "missing"),
    ("Data.IR", _replace("Data.IR", np.zeros((1555, 3, 16))), "receivers"),
    ("Data.IR", _replace("Data.IR", np.zeros((1555, 256))), "shape"),
    ("Data.IR", _replace("Data.IR", np.full((1555, 2, 16), np.nan)), "NaN"),
    ("Data.SamplingRate", _replace("Data.SamplingRate", np.array([0.0])), "> 0"),
    ("SourcePosition", _replace("SourcePosition", np.zeros((7, 3))), "shape"),
    ("SourcePosition", lambda f: f["SourcePosition"].attrs.__setitem__("Type", b"polar"), "Type"),
])
def test_sofa_errors_name_the_variable(tmp_path, field, edit, words):
    with pytest.raises(InputError) as err:
        load_sofa(_corrupt_copy(tmp_path, edit))
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(tmp_path / "broken.sofa") + ": " + field + ": ")
    assert err.value.field == field and words in msg


def test_sofa_not_hdf5_or_missing(tmp_path):
    bad = tmp_path / "hrtf.sofa"
    bad.write_text("this is not netCDF\n")
    with pytest.raises(InputError) as err:
        load_sofa(bad)
    assert str(err.value).startswith(f"{bad}: <file>: ") and "\n" not in str(err.value)
    with pytest.raises(InputError, match="not found"):
        load_sofa(tmp_path / "absent.sofa")


@needs_sofa
def test_sofa_cartesian_positions(tmp_path, ku100):
    def to_cartesian(f):
        pos = f["SourcePosition"][()]
        az, el = np.radians(pos[:, 0]), np.radians(pos[:, 1])
        xyz = pos[:, 2:3] * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                                      np.sin(el)], axis=1)
        del f["SourcePosition"]
        f["SourcePosition"] = xyz
        f["SourcePosition"].attrs["Type"] = "cartesian"  # str here, bytes in the original
    cart = load_sofa(_corrupt_copy(tmp_path, to_cartesian))
    assert np.allclose(cart.directions, ku100.directions, atol=1e-12)
    assert np.array_equal(cart.hrir, ku100.hrir)


def test_diffuse_field_power_spherical_head(head):
    p = head.diffuse_field_power(1024)
    assert p.shape == (2, 513) and np.all(p > 0)
    f = np.fft.rfftfreq(1024, 1.0 / head.sample_rate)
    assert np.all(np.abs(10 * np.log10(p[:, f < 200])) < 1.0)
    assert np.allclose(p[0], p[1], rtol=0.05)  # the head is left-right symmetric
    with pytest.raises(ValueError):
        head.diffuse_field_power(32)  # shorter than the HRIRs


@needs_sofa
def test_diffuse_field_power_ku100(ku100):
    p = ku100.diffuse_field_power(512)
    assert p.shape == (2, 257) and np.all(p > 0) and np.all(np.isfinite(p))


def test_diffuse_field_power_weights_solid_angle():
    # a latitude-longitude grid, dense at the poles; only |elevation| >= 60 degrees responds:
    # the true diffuse-field power is the solid-angle fraction 1 - sin(60 deg) = 0.134
    el, az = np.meshgrid(np.arange(-85.0, 90.0, 10.0), np.arange(0.0, 360.0, 10.0))
    d = np.stack([unit(a, e) for a, e in zip(az.ravel(), el.ravel())])
    d = np.vstack([d, [[0, 0, 1], [0, 0, -1]]])
    h = np.zeros((len(d), 2, 8))
    h[np.abs(d[:, 2]) >= math.sin(math.radians(60)), :, 0] = 1.0
    p = Hrtf(d, h, 44100, "grid").diffuse_field_power(16)
    assert np.allclose(p, 1 - math.sin(math.radians(60)), rtol=0.05)
    assert np.mean(h[:, 0, 0]) > 0.25  # uniform weights would be far off
    # horizontal-plane-only sets (no Voronoi diagram): equal shares by nearest-point counting
    ring = np.stack([unit(a) for a in np.arange(0.0, 360.0, 30.0)])
    assert np.allclose(solid_angle_weights(ring), 1 / 12, rtol=0.05)


# --- which receiver is the left ear: a tiny SOFA file made here ------------------------------

#: the fixture's directions (azimuth, elevation), degrees: front, left, back, right, up, down
TINY_DIRECTIONS = [(0, 0), (90, 0), (180, 0), (270, 0), (0, 90), (0, -90)]


def tiny_sofa(path: Path, receivers: str = "left-right", position_type: str = "cartesian"
              ) -> Path:
    """A SimpleFreeFieldHRIR file of six directions and 16-tap responses, written with h5py:
    for a source direction u, the ear at y = +-0.09 m (y > 0: the left ear) hears an impulse
    of gain 1 + 0.8 u.e after a whole-sample ``Data.Delay`` of 4 (1 - u.e) samples (e the
    ear's side, +-y): the near ear louder and earlier. ``receivers``: "left-right" (receiver 0
    is the left ear), "right-left" (receiver 0 is the right ear: the data's channels, delays
    and ``ReceiverPosition`` all in that order), "missing" (no ``ReceiverPosition``) or
    "both-left" (both receivers at y > 0)."""
    side = {"left-right": (1, -1), "right-left": (-1, 1), "missing": (1, -1),
            "both-left": (1, 1)}[receivers]
    u = np.stack([unit(a, e) for a, e in TINY_DIRECTIONS])
    ir = np.zeros((len(u), 2, 16))
    delay = np.zeros((len(u), 2))
    for r, s in enumerate(side):
        ir[:, r, 0] = 1 + 0.8 * s * u[:, 1]
        delay[:, r] = np.rint(4 * (1 - s * u[:, 1]))
    with h5py.File(path, "w") as f:
        f.attrs["Conventions"] = "SOFA"
        f.attrs["SOFAConventions"] = "SimpleFreeFieldHRIR"
        f["Data.IR"] = ir
        f["Data.SamplingRate"] = np.array([44100.0])
        f["Data.Delay"] = delay
        f["SourcePosition"] = np.array([[a, e, 1.5] for a, e in TINY_DIRECTIONS], float)
        f["SourcePosition"].attrs["Type"] = "spherical"
        f["SourcePosition"].attrs["Units"] = "degree, degree, metre"
        if receivers != "missing":
            if position_type == "cartesian":
                pos = np.array([[[0.0], [0.09 * s], [0.0]] for s in side])
            else:  # azimuth 90 degrees: the left
                pos = np.array([[[90.0 * s], [0.0], [0.09]] for s in side])
            f["ReceiverPosition"] = pos
            f["ReceiverPosition"].attrs["Type"] = position_type
            f["ReceiverPosition"].attrs["Units"] = ("metre" if position_type == "cartesian"
                                                    else "degree, degree, metre")
    return path


@pytest.mark.parametrize("receivers, position_type", [
    ("left-right", "cartesian"), ("right-left", "cartesian"), ("right-left", "spherical")])
def test_sofa_receiver_zero_is_the_left_ear(tmp_path, receivers, position_type):
    """Whichever order the file stores its ears in, ear 0 of the loaded set is the left one
    (ReceiverPosition y > 0): a source on the left (azimuth 90) is louder and earlier in
    channel 0, one on the right in channel 1, and the front is balanced. The left ear leads
    by 8 samples at azimuth 90 (the file's own delays, 4 (1 -+ 1)): ITD > 0 on the left."""
    h = load_sofa(tiny_sofa(tmp_path / "tiny.sofa", receivers, position_type))
    left, right, front = (response(h, az) for az in (90.0, -90.0, 0.0))
    fs = h.sample_rate
    assert ild_db(left, fs) == pytest.approx(20 * math.log10(1.8 / 0.2), abs=0.1)
    assert ild_db(right, fs) == pytest.approx(-20 * math.log10(1.8 / 0.2), abs=0.1)
    assert itd_s(left, fs) == pytest.approx(8 / fs, abs=0.5 / fs)
    assert itd_s(right, fs) == pytest.approx(-8 / fs, abs=0.5 / fs)
    assert abs(ild_db(front, fs)) < 1e-9 and abs(itd_s(front, fs)) < 0.5 / fs


@pytest.mark.parametrize("receivers, words", [("missing", "missing"), ("both-left", "y > 0")])
def test_sofa_without_a_left_and_a_right_receiver_is_refused(tmp_path, receivers, words):
    """No ReceiverPosition, or two receivers on one side: which channel is the left ear is
    unknown, and the file is refused in one line naming the variable."""
    path = tiny_sofa(tmp_path / "tiny.sofa", receivers)
    with pytest.raises(InputError) as err:
        load_sofa(path)
    msg = str(err.value)
    assert err.value.field == "ReceiverPosition" and words in msg and "\n" not in msg
    assert msg.startswith(f"{path}: ReceiverPosition: ")
