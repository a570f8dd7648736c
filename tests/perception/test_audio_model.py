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


def _direct_and_room(direct_gain: float, reflection: tuple[float, float] | None = None,
                     n: int = FS) -> np.ndarray:
    """A click (one sample, ``direct_gain``, both ears) at 0.2 s, an optional reflection
    (delay s, gain) of it, and a diffuse tail: white noise from 10 ms on, decaying at 60 dB in
    0.5 s, the same in every call (the room's field does not depend on where the source is)."""
    t = np.arange(n) / FS
    rng = np.random.default_rng(1)
    out = 1e-3 * rng.standard_normal((2, n)) * np.exp(-3 * np.log(10) * (t - 0.21) / 0.5) \
        * (t >= 0.21)
    k = int(0.2 * FS)
    out[:, k] += direct_gain
    if reflection is not None:
        out[:, k + int(round(reflection[0] * FS))] += reflection[1] * direct_gain
    return out


def test_direct_to_reverberant_ratio_against_its_definition():
    """The broadband ratio is the energies' ratio written out here (no noise floor to take
    off: the tail is the only late sound); twice as far (half the direct pressure), the ratio
    falls by 20 log10 2 = 6.02 dB, the inverse-square law, in every band; a reflection 8 ms
    after the direct sound 10 dB below it is found at 8 ms and -10 dB."""
    f = AudioFeatures(clip_samples=FS)
    names = f.names
    near, far = f.extract(_direct_and_room(0.02)), f.extract(_direct_and_room(0.01))
    x = _direct_and_room(0.02)
    k = int(0.2 * FS)
    direct = (x[:, k - int(0.0005 * FS):k + int(0.003 * FS)] ** 2).sum()
    late = (x[:, k + int(0.02 * FS):k + int(0.05 * FS)] ** 2).sum()
    drr = names.index("drr_bb_3ms_20_50ms")
    assert near[drr] == pytest.approx(math.log10(direct / late), abs=0.01)
    for i, name in enumerate(names):
        if name.startswith("drr_bb"):
            assert 10 * (near[i] - far[i]) == pytest.approx(20 * math.log10(2), abs=0.1), name
    # the band-passed click's energy rings on past the 3 ms window below 1 kHz: only the bands
    # the windows hold whole follow the law to 0.3 dB
    for band in ("1000hz", "2000hz"):
        for i, name in enumerate(names):
            if name.startswith(f"drr_{band}"):
                assert 10 * (near[i] - far[i]) == pytest.approx(6.02, abs=0.3), name
    r = f.extract(_direct_and_room(0.02, reflection=(0.008, 10 ** (-10 / 20))))
    assert r[names.index("reflection_ms")] == pytest.approx(8.0, abs=0.1)
    assert r[names.index("reflection_db")] == pytest.approx(-10.0, abs=1.0)
    # without the reflection the strongest later arrival (the band-pass's own ring, the
    # tail) is well below it
    assert near[names.index("reflection_db")] < r[names.index("reflection_db")] - 3


def test_relative_place():
    row = {"settle_pos": (3.0, 4.0, 0.1), "spawn_x": 1.0, "spawn_y": 2.0,
           "spawn_yaw_rad": math.pi / 2}
    az, d = relative_place(row)
    assert d == pytest.approx(math.hypot(2, 2))
    assert az == pytest.approx(-math.pi / 4)  # heading north, the object north-east: right


def test_room_context_by_hand():
    """What the room-centre prior knows, for a listener at (1, 1) in a 4 m x 6 m room facing
    +y: the centre (2, 3) is sqrt(5) m away, at atan2(2, 1) - 90 degrees (to its right)."""
    from fallgen.perception.audio_model import room_context_at

    c = room_context_at((4.0, 6.0, 2.5), (1.0, 1.0), math.pi / 2)
    az = math.atan2(2.0, 1.0) - math.pi / 2
    assert c == pytest.approx([math.sqrt(5.0), math.cos(az), math.sin(az), 4.0, 6.0, 24.0])
    assert c[2] < 0  # right of the heading


def test_front_back_confusions_by_hand():
    """A reversal is an estimate across the ears' axis from the truth (front for back);
    sources within 15 degrees of the axis are not counted; the mirror image of every
    estimate about the axis (pi - azimuth) is a reversal wherever one is counted."""
    from fallgen.perception.audio_model import front_back_confusions

    deg = np.radians
    true = deg(np.array([0.0, 0.0, 30.0, 170.0, 85.0, -100.0, -60.0]))
    est = deg(np.array([170.0, 80.0, 150.0, -175.0, 95.0, -80.0, -60.0]))
    # counted: all but 85 (5 degrees off the axis) and -100 (10 degrees off it)
    # reversals: 0 -> 170, 30 -> 150; not: 0 -> 80, 170 -> -175, -60 -> -60
    assert front_back_confusions(est, true) == (2, 5)
    wrong, n = front_back_confusions(np.pi - true, true)
    assert wrong == n == 5
    assert front_back_confusions(true, true) == (0, 5)


def _truth_place(row: dict, where=None) -> tuple[float, float]:
    """Azimuth (rad, counter-clockwise from the spawn heading) and distance (m) of ``where``
    (default: where the object came to rest) from the agent's spawn, written out here."""
    x, y = (row["settle_pos"][0], row["settle_pos"][1]) if where is None else where
    dx, dy = x - row["spawn_x"], y - row["spawn_y"]
    return math.atan2(dy, dx) - row["spawn_yaw_rad"], math.hypot(dx, dy)


def _angle_deg(a: float, b: float) -> float:
    d = (a - b) % (2 * math.pi)
    return math.degrees(min(d, 2 * math.pi - d))


def _topk_bounds(p: np.ndarray, classes, truth: str, k: int) -> tuple[float, float]:
    """Whether ``truth`` is among the ``k`` most probable classes: (1, 1) or (0, 0), or (0, 1)
    where ties at the k-th probability leave it to the sort order."""
    if truth not in classes:
        return 0.0, 0.0
    q = p[list(classes).index(truth)]
    above, tied = int(np.sum(p > q)), int(np.sum(p == q))
    return float(above + tied <= k), float(above < k)


def _check_scores(scores, model, ds, rows, train_rows, world):
    """An eval's scores recomputed here from the model's own predictions for each clip and
    from the rows: category top-1 / top-5 and material top-1 (ties at the cut allowed either
    way), the azimuth's median error; and the no-audio prior: the train split's most frequent
    category and material (any of those tied for most frequent), the room's centre as where
    the fall was (its median azimuth error)."""
    from collections import Counter

    preds = [model.predict(ds.arrays(r, ("audio",))["audio"]) for r in rows]
    for key, k, field, classes in (("category_top1", 1, "category", "categories"),
                                   ("category_top5", 5, "category", "categories"),
                                   ("material_top1", 1, "audio_material", "materials")):
        lo = np.mean([_topk_bounds(p.category_p if field == "category" else p.material_p,
                                   getattr(p, classes), r[field], k)[0]
                      for p, r in zip(preds, rows)])
        hi = np.mean([_topk_bounds(p.category_p if field == "category" else p.material_p,
                                   getattr(p, classes), r[field], k)[1]
                      for p, r in zip(preds, rows)])
        assert lo - 1e-9 <= scores[key] <= hi + 1e-9, (key, scores[key], lo, hi)
    az = [_angle_deg(p.azimuth_rad, _truth_place(r)[0]) for p, r in zip(preds, rows)]
    assert scores["azimuth_median_error_deg"] == pytest.approx(float(np.median(az)), abs=1e-6)
    # front/back: the estimate ahead of the ears' axis where the truth is behind it, or the
    # other way round, over the sources more than 15 degrees off that axis
    counted = [(p, r) for p, r in zip(preds, rows)
               if abs(math.cos(_truth_place(r)[0])) >= math.sin(math.radians(15))]
    flips = [(math.cos(p.azimuth_rad) > 0) != (math.cos(_truth_place(r)[0]) > 0)
             for p, r in counted]
    if counted:
        assert scores["front_back_confusion_rate"] == pytest.approx(float(np.mean(flips)))
    for kind in {r["room_kind"] for r in rows}:
        mine = [a for a, r in zip(az, rows) if r["room_kind"] == kind]
        assert scores["by_room_kind"][kind]["episodes"] == len(mine)
        assert scores["by_room_kind"][kind]["azimuth_median_error_deg"] == \
            pytest.approx(float(np.median(mine)), abs=1e-6)
    prior = scores["prior"]
    for key, field in (("category_top1", "category"), ("material_top1", "audio_material")):
        counts = Counter(r[field] for r in train_rows)
        top = max(counts.values())
        options = [np.mean([r[field] == c for r in rows]) for c, n in counts.items()
                   if n == top]
        assert any(prior[key] == pytest.approx(o) for o in options), (key, prior[key], options)
    centre_err = []
    for r in rows:
        lx, ly, _ = world.variant(r["room_variant"]).size_m
        centre_err.append(_angle_deg(_truth_place(r, (lx / 2, ly / 2))[0], _truth_place(r)[0]))
    assert prior["azimuth_median_error_deg"] == pytest.approx(float(np.median(centre_err)),
                                                              abs=1e-6)
    # the distance told the room: the model's prediction for each clip given where its agent
    # stood in a room of that size, ranked against the truth; the prior, told the same, is
    # the room's centre
    from scipy.stats import spearmanr

    from fallgen.perception.audio_model import room_context_at

    told = [model.predict(ds.arrays(r, ("audio",))["audio"], room_context_at(
        world.variant(r["room_variant"]).size_m, (r["spawn_x"], r["spawn_y"]),
        r["spawn_yaw_rad"])).distance_m for r in rows]
    true = [_truth_place(r)[1] for r in rows]
    centre = [_truth_place(r, tuple(np.asarray(world.variant(r["room_variant"]).size_m[:2])
                                    / 2))[1] for r in rows]
    for key, est, d in (("distance_rank_correlation_told_room", told, scores),
                        ("distance_rank_correlation", centre, prior),
                        ("distance_rank_correlation_told_room", centre, prior)):
        # (nan under 3 falls or a constant estimate: no ranking)
        want = spearmanr(est, true).statistic if len(est) > 2 and len(set(est)) > 1 \
            else float("nan")
        assert d[key] == pytest.approx(want, abs=1e-9, nan_ok=True), key


def test_train_and_eval_end_to_end(tiny_dataset, tmp_path, cli):
    """``fallgen audio-model train`` on the tiny build's train split and ``eval`` on its test
    split: the scores are the model's own predictions scored against the truth, the prior
    the train split's frequencies and the room's centre (recomputed here); on its training
    clips the model names every category, which the prior cannot; confusion PNGs; the model
    predicts for a clip; a model file whose clips differ from the dataset's is refused in one
    line, and so is a file that is not a model."""
    import copy

    from fallgen.dataset.reader import Dataset
    from fallgen.errors import InputError
    from fallgen.perception.audio_model import AudioModel, check_features
    from fallgen.world.library import load_world

    model = tmp_path / "audio.model"
    out = tmp_path / "eval"
    assert cli("audio-model", "train", str(tiny_dataset), "-o", str(model), "--trees",
               "20") == 0
    assert cli("audio-model", "eval", str(tiny_dataset), "-m", str(model), "-o", str(out)) == 0
    scores = json.loads((out / "scores.json").read_text())
    ds = Dataset(tiny_dataset)
    m = AudioModel.load(model)
    world = load_world(None)
    test_rows, train_rows = ds.rows("test"), ds.rows("train")
    assert scores["episodes"] == len(test_rows)
    _check_scores(scores, m, ds, test_rows, train_rows, world)
    # the check rejects a report off by one episode's category, or by 10 degrees of prior
    wrong = copy.deepcopy(scores)
    wrong["category_top1"] = scores["category_top1"] + 1 / len(test_rows) \
        if scores["category_top1"] < 1 else 0.5
    with pytest.raises(AssertionError):
        _check_scores(wrong, m, ds, test_rows, train_rows, world)
    wrong = copy.deepcopy(scores)
    wrong["prior"]["azimuth_median_error_deg"] += 10.0
    with pytest.raises(AssertionError):
        _check_scores(wrong, m, ds, test_rows, train_rows, world)
    assert scores["by_zone_kind"] and scores["by_distance"]
    assert sum(v["episodes"] for v in scores["by_zone_kind"].values()) == len(test_rows)
    assert (out / "confusion_category.png").stat().st_size > 1000
    assert (out / "confusion_material.png").stat().st_size > 1000
    # on its own training clips the trees (grown to single clips) name every category; the
    # prior, one category for all, only as many as the most frequent one holds
    mine = tmp_path / "eval-train"
    assert cli("audio-model", "eval", str(tiny_dataset), "-m", str(model), "--split", "train",
               "-o", str(mine)) == 0
    on_train = json.loads((mine / "scores.json").read_text())
    _check_scores(on_train, m, ds, train_rows, train_rows, world)
    assert on_train["category_top1"] == 1.0
    if len({r["category"] for r in train_rows}) > 1:
        assert on_train["prior"]["category_top1"] < 1.0

    row = test_rows[0]
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
