"""The measured head fallgen ships and hears with by default (fallgen.audio.heads): the
SADIE KU100 SOFA file with its licence, its lateral cues against the file's documented ones
and Woodworth's ITD, the cached resampling, and what a build records of it."""

from __future__ import annotations

import hashlib
import math
import zipfile

import numpy as np
import pytest

from fallgen.audio.heads import MEASURED, PACKAGED, SPHERE, hrtf_id, hrtf_name, load_hrtf
from fallgen.audio.hrtf import HEAD_RADIUS_M, SPEED_OF_SOUND


def _ears(hrtf, azimuth_deg: float) -> tuple[float, float]:
    """(level difference dB, onset-time difference s: right minus left) of the direction
    nearest ``azimuth_deg`` in the horizontal plane; onsets at 10 % of each ear's peak."""
    a = math.radians(azimuth_deg)
    h = hrtf.hrir[hrtf.nearest(np.array([[math.cos(a), math.sin(a), 0.0]]))[0]]
    level = 10 * math.log10((h[0] ** 2).sum() / (h[1] ** 2).sum())
    onset = [int(np.argmax(np.abs(e) >= 0.1 * np.abs(e).max())) for e in h]
    return level, (onset[1] - onset[0]) / hrtf.sample_rate


def test_the_measured_head_hears_the_left_louder_and_earlier_in_channel_0(tmp_path,
                                                                          monkeypatch):
    """The SADIE KU100 at +90 degrees: the left ear (channel 0) 15 dB louder and 0.8 ms
    earlier, as the file's documentation says (within 5 dB and 0.25 ms; Woodworth's sphere
    gives 0.66 ms), mirrored at -90; straight ahead both ears alike (within 1.5 dB, 1 sample)."""
    monkeypatch.setenv("FALLGEN_CACHE", str(tmp_path))
    h = load_hrtf(MEASURED)
    assert h.sample_rate == 44100 and len(h.directions) > 1500
    woodworth = HEAD_RADIUS_M / SPEED_OF_SOUND * (math.pi / 2 + 1)
    level, itd = _ears(h, 90)
    assert 10 <= level <= 20 and abs(itd - 0.8e-3) <= 0.25e-3 and itd > 0.8 * woodworth
    mirror = _ears(h, -90)
    assert -20 <= mirror[0] <= -10 and abs(mirror[1] + 0.8e-3) <= 0.25e-3
    front = _ears(h, 0)
    assert abs(front[0]) <= 1.5 and abs(front[1]) <= 1 / h.sample_rate
    # the spherical head hears the side too, but without the pinna's front/back difference
    s = load_hrtf(SPHERE)
    assert _ears(s, 90)[0] > 3 and _ears(s, 90)[1] > 0


def test_a_resampled_head_is_cached_and_a_corrupt_entry_made_again(tmp_path, monkeypatch):
    monkeypatch.setenv("FALLGEN_CACHE", str(tmp_path))
    first = load_hrtf(MEASURED)
    entries = list((tmp_path / "hrtf").glob("*.npz"))
    assert len(entries) == 1
    again = load_hrtf(MEASURED)
    assert np.array_equal(first.hrir, again.hrir) and np.array_equal(first.directions,
                                                                     again.directions)
    entries[0].write_bytes(entries[0].read_bytes()[:100])  # truncated
    remade = load_hrtf(MEASURED)
    assert np.array_equal(first.hrir, remade.hrir)
    assert entries[0].stat().st_size > 1000


def test_hrtf_id_names_the_file_heard_with():
    digest = hashlib.sha256(PACKAGED.read_bytes()).hexdigest()
    assert hrtf_id(MEASURED) == f"sadie_ku100:{digest[:16]}"
    assert hrtf_id(SPHERE) == "sphere" and hrtf_name(hrtf_id(MEASURED)) == "sadie_ku100"


def test_the_package_carries_the_head_its_licence_and_the_citation(tmp_path):
    """A wheel built from the checkout holds the SOFA file, the Apache-2.0 licence it ships
    under and the README with the citation the licence's distributor asks for."""
    hatchling = pytest.importorskip("hatchling.builders.wheel")
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    wheel = next(iter(hatchling.WheelBuilder(str(root)).build(directory=str(tmp_path),
                                                              versions=["standard"])))
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        base = "fallgen/audio/hrtf_data/"
        assert {base + "sadie_ku100_48k.sofa", base + "LICENSE-SADIE", base + "README.md"} <= names
        assert b"Apache License" in z.read(base + "LICENSE-SADIE")
        assert b"Kearney" in z.read(base + "README.md")
        assert z.getinfo(base + "sadie_ku100_48k.sofa").file_size == PACKAGED.stat().st_size


@pytest.mark.xdist_group("tiny_build")
def test_a_default_build_records_the_measured_head(tiny_dataset):
    import fallgen.dataset

    ds = fallgen.dataset.open(tiny_dataset)
    assert ds.generate_settings()["hrtf"] == MEASURED
    assert ds.hrtf == hrtf_id(MEASURED)
