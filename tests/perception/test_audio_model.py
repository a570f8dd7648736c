"""The auditory perception module (fallgen.perception): features of a clip, a model trained and
scored end to end on the tiny build, and the refusals of a model file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fallgen.perception.audio_features import AudioFeatures, relative_place

pytestmark = pytest.mark.xdist_group("tiny_build")

FS = 44100


def _click(delay_s: float, itd_s: float = 0.0, gain_l: float = 1.0, gain_r: float = 1.0,
           n: int = FS) -> np.ndarray:
    """A decaying 2 kHz burst at ``delay_s``, reaching the right ear ``itd_s`` later."""
    t = np.arange(n) / FS
    out = np.zeros((2, n))
    for ear, (lag, g) in enumerate(((0.0, gain_l), (itd_s, gain_r))):
        tau = t - delay_s - lag
        out[ear] = g * np.where(tau >= 0, np.sin(2 * np.pi * 2000 * tau) * np.exp(-tau / 0.05),
                                0.0)
    rng = np.random.default_rng(0)
    return out + 1e-6 * rng.standard_normal(out.shape)


def test_features_hear_direction_level_and_onset():
    f = AudioFeatures(clip_samples=FS)
    names = f.names
    a = f.extract(_click(0.2, itd_s=0.0005, gain_r=0.5))  # from the left: right ear later
    b = f.extract(_click(0.2, itd_s=-0.0005, gain_l=0.5))  # from the right
    c = f.extract(_click(0.5))
    assert a.shape == (len(names),) and a.dtype == np.float32
    itd, ild, onset = names.index("itd_4ms"), names.index("ild_onset_db"), names.index("onset_s")
    # ITD > 0: the left ear hears first (fallgen.audio.hrtf's convention)
    assert a[itd] == pytest.approx(0.5, abs=0.05) and b[itd] == pytest.approx(-0.5, abs=0.05)
    for level in ("itd_onset5", "itd_onset10"):  # the ears' first arrivals, 0.5 ms apart
        k = names.index(level)
        assert a[k] == pytest.approx(0.5, abs=0.05) and b[k] == pytest.approx(-0.5, abs=0.05)
        assert c[k] == pytest.approx(0.0, abs=0.03)
    assert a[ild] == pytest.approx(20 * math.log10(2), abs=0.5)
    assert b[ild] == pytest.approx(-20 * math.log10(2), abs=0.5)
    assert abs(a[onset] - 0.2) < 0.01 and abs(c[onset] - 0.5) < 0.01
    # the spectrum peaks in the band holding 2 kHz, in both ears
    bin_2k = int(round(2000 * f.frame / FS))
    band_2k = int(np.argmax(f._mel[:, bin_2k]))
    for ear in "lr":
        mel = [names.index(f"mel_{ear}{k}") for k in range(f.n_mels)]
        assert abs(int(np.argmax(c[mel])) - band_2k) <= 1
    assert np.array_equal(f.extract(_click(0.2)), f.extract(_click(0.2)))
    with pytest.raises(ValueError, match="shape"):
        f.extract(np.zeros((2, FS // 2)))
    assert AudioFeatures.from_dict(f.to_dict()) == f


def test_relative_place():
    row = {"settle_pos": (3.0, 4.0, 0.1), "spawn_x": 1.0, "spawn_y": 2.0,
           "spawn_yaw_rad": math.pi / 2}
    az, d = relative_place(row)
    assert d == pytest.approx(math.hypot(2, 2))
    assert az == pytest.approx(-math.pi / 4)  # heading north, the object north-east: right


def test_train_and_eval_end_to_end(tiny_dataset, tmp_path, cli):
    """``fallgen audio-model train`` on the tiny build's train split and ``eval`` on its test
    split: a model file, scores against the prior and chance, confusion PNGs; the model
    predicts for a clip; a model file whose clips differ from the dataset's is refused in one
    line, and so is a file that is not a model."""
    from fallgen.dataset.reader import Dataset
    from fallgen.errors import InputError
    from fallgen.perception.audio_model import AudioModel, check_features

    model = tmp_path / "audio.model"
    out = tmp_path / "eval"
    assert cli("audio-model", "train", str(tiny_dataset), "-o", str(model), "--trees",
               "20") == 0
    assert cli("audio-model", "eval", str(tiny_dataset), "-m", str(model), "-o", str(out)) == 0
    scores = json.loads((out / "scores.json").read_text())
    for key in ("category_top1", "category_top5", "material_top1", "azimuth_median_error_deg",
                "distance_rank_correlation", "position_median_error_m"):
        assert key in scores
    assert 0.0 <= scores["category_top1"] <= scores["category_top5"] <= 1.0
    assert set(scores["prior"]) >= {"category_top1", "azimuth_median_error_deg"}
    assert scores["by_zone_kind"] and scores["by_distance"]
    assert (out / "confusion_category.png").stat().st_size > 1000
    assert (out / "confusion_material.png").stat().st_size > 1000

    ds = Dataset(tiny_dataset)
    m = AudioModel.load(model)
    row = ds.rows("test")[0]
    p = m.predict(ds.arrays(row, ("audio",))["audio"])
    assert p.category in p.categories and abs(p.category_p.sum() - 1) < 1e-6
    assert p.distance_m > 0 and -math.pi <= p.azimuth_rad <= math.pi
    # the same seed, the same model's predictions
    again = tmp_path / "again.model"
    assert cli("audio-model", "train", str(tiny_dataset), "-o", str(again), "--trees",
               "20") == 0
    q = AudioModel.load(again).predict(ds.arrays(row, ("audio",))["audio"])
    assert np.array_equal(p.category_p, q.category_p) and p.distance_m == q.distance_m

    import dataclasses

    other = dataclasses.replace(m.features, sample_rate=22050)
    with pytest.raises(InputError, match="features.sample_rate"):
        check_features(ds, ds.rows("test"), other, model)
    m.features = other
    m.save(tmp_path / "other.model")
    assert cli("audio-model", "eval", str(tiny_dataset), "-m", str(tmp_path / "other.model"),
               "-o", str(out)) == 2
    bad = tmp_path / "bad.model"
    bad.write_bytes(b"not a model")
    with pytest.raises(InputError, match="bad.model"):
        AudioModel.load(bad)
    assert cli("audio-model", "eval", str(tiny_dataset), "-m", str(bad), "-o", str(out)) == 2
    assert cli("audio-model", "train", str(tiny_dataset), "-o", str(model), "--split",
               "nope") == 2
