"""fallgen.env.wrappers: the compact observations standard RL libraries take. The log-mel
features against a tone's power (Parseval) and the mel scale, the images against the
environment's own, Stable-Baselines3's checker (no warning) and a few PPO updates."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

SR = 44100
SENSORS = ("rgb", "depth", "audio", "pose", "category_seg", "object_category")


def _htk_centres(bands: int, fmin: float, fmax: float) -> np.ndarray:
    m = np.linspace(2595 * np.log10(1 + fmin / 700), 2595 * np.log10(1 + fmax / 700), bands + 2)
    return (700 * (10 ** (m / 2595) - 1))[1:-1]


@pytest.mark.parametrize("freq", [440.0, 1000.0, 4000.0])
def test_log_mel_of_a_tone_holds_its_power_in_its_band(freq):
    """A sine of amplitude A in the left ear, silence in the right: the left bands' powers add
    up to A^2 / 2, the loudest band is the one whose mel centre lies nearest the tone, and the
    silent ear's features are all 0."""
    from fallgen.env.wrappers import BANDS, DB_CEIL, DB_FLOOR, FMAX_HZ, FMIN_HZ, band_power, \
        log_mel

    a = 0.01
    t = np.arange(SR) / SR
    clip = np.stack([a * np.sin(2 * np.pi * freq * t), np.zeros(SR)]).astype(np.float32)
    p = band_power(clip, SR)
    assert p.shape == (2, BANDS)
    assert p[0].sum() == pytest.approx(a * a / 2, rel=0.01)
    assert np.all(p[1] == 0)
    centres = _htk_centres(BANDS, FMIN_HZ, FMAX_HZ)
    assert int(np.argmax(p[0])) == int(np.argmin(np.abs(centres - freq)))
    f = log_mel(clip, SR)
    assert f.shape == (2 * BANDS,) and f.dtype == np.float32
    assert np.all(f[BANDS:] == 0)
    # the loudest band's feature is its level on the DB_FLOOR..DB_CEIL scale
    db = 10 * np.log10(p[0].max())
    assert f[:BANDS].max() == pytest.approx((db - DB_FLOOR) / (DB_CEIL - DB_FLOOR), abs=1e-6)


def test_compact_observations_are_the_environments_own_made_small(tiny_dataset):
    """The same episode through the bare environment and the wrapper: the 84 x 84 images keep
    the view's mean colour and mean depth (areas averaged; depth in 10 m / 255 levels), the
    segmentation holds the view's categories + 1, the audio is the step-0 clip's log-mel
    features, held after step 0 (or those of the silent clip without hold_audio), pose as is."""
    from fallgen.env import FallenObjectsEnv
    from fallgen.env.wrappers import CompactObservation, log_mel

    raw = FallenObjectsEnv(tiny_dataset, sensors=SENSORS)
    held = CompactObservation(FallenObjectsEnv(tiny_dataset, sensors=SENSORS))
    loose = CompactObservation(FallenObjectsEnv(tiny_dataset, sensors=("audio",)),
                               hold_audio=False)
    try:
        for eid in raw.ids[:3]:
            r, _ = raw.reset(options={"episode_id": eid})
            c, _ = held.reset(options={"episode_id": eid})
            assert held.observation_space.contains(c)
            assert c["rgb"].shape == (84, 84, 3)
            assert np.abs(c["rgb"].mean(axis=(0, 1)) - r["rgb"].mean(axis=(0, 1))).max() < 1.0
            metres = np.minimum(r["depth"], 10.0).mean()
            assert abs(c["depth"].mean() * 10.0 / 255 - metres) < 10.0 / 255
            cats = set(np.unique(r["category_seg"]) + 1)
            # every category in view is in the compact view (none is lost to the reduction)
            assert set(np.unique(c["category_seg"])) == cats and len(cats) > 1
            sr = int(raw.ds.row(eid)["sample_rate"])
            assert np.array_equal(c["audio"], log_mel(r["audio"], sr))
            assert c["audio"].max() > 0.1
            assert np.array_equal(c["pose"], r["pose"]) and c["object_category"] == \
                r["object_category"]
            r, *_ = raw.step(1)
            c2, *_ = held.step(1)
            assert not r["audio"].any()  # the bare environment's audio after step 0
            assert np.array_equal(c2["audio"], c["audio"])
            loose.reset(options={"episode_id": eid})
            q, *_ = loose.step(1)
            assert not q["audio"].any()  # silence: every band at 0
    finally:
        raw.close()
        held.close()
        loose.close()


def _warnings_of_check_env(env) -> list[str]:
    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    return [str(w.message) for w in caught]


def test_stable_baselines3_check_env_passes_without_warnings(tiny_dataset):
    pytest.importorskip("stable_baselines3")
    from fallgen.env import FallenObjectsEnv
    from fallgen.env.wrappers import compact_env

    env = compact_env(tiny_dataset, "test", sensors=SENSORS)
    try:
        assert env.spec.max_episode_steps == 200
        assert _warnings_of_check_env(env) == []
    finally:
        env.close()
    bare = FallenObjectsEnv(tiny_dataset, "test", sensors=SENSORS)
    try:  # the bare environment's float depth, int16 segmentation and (2, T) clip
        said = _warnings_of_check_env(bare)
        assert any("depth" in w for w in said) and any("audio" in w for w in said)
    finally:
        bare.close()


def test_a_few_ppo_updates(tiny_dataset):
    """Stable-Baselines3's PPO with its default MultiInputPolicy on the compact observations:
    two rollouts of 32 steps, two epochs each (4 gradient passes); the policy changes, and it
    is small (a CNN per image, not a layer over the raw clip)."""
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO

    from stable_baselines3.common.logger import Logger

    from fallgen.env.wrappers import compact_env

    env = compact_env(tiny_dataset, "train", sensors=("rgb", "depth", "audio", "pose"),
                      order="shuffle")
    try:
        model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=16, n_epochs=2, seed=0,
                    device="cpu")
        model.set_logger(Logger(None, []))  # no log directory of its own in the temp dir
        before = [p.detach().clone() for p in model.policy.parameters()]
        model.learn(64)
        assert model.num_timesteps == 64 and model._n_updates == 4
        after = list(model.policy.parameters())
        assert any(not torch.equal(a, b) for a, b in zip(before, after))
        assert sum(p.numel() for p in after) < 5_000_000
    finally:
        env.close()


def _rarest_by_blocks(labels: np.ndarray, size: int) -> np.ndarray:
    """The reduction written out cell by cell: the label of the block with the fewest pixels
    in the whole image (ties: the smaller; 0 only when nothing else is there)."""
    h, w = labels.shape
    counts = {int(v): int((labels == v).sum()) for v in np.unique(labels)}
    out = np.zeros((size, size), np.uint8)
    for i in range(size):
        for j in range(size):
            block = labels[i * h // size:(i + 1) * h // size, j * w // size:(j + 1) * w // size]
            present = sorted({int(v) for v in np.unique(block)} - {0},
                             key=lambda v: (counts[v], v))
            out[i, j] = present[0] if present else 0
    return out


def test_the_segmentation_keeps_small_objects_and_is_the_rarest_label_per_block():
    """The compact segmentation against the rule written out block by block, on random label
    images of a few large regions with small objects on them; a one-pixel object anywhere
    shows (the nearest pixel misses most), and a view of nothing but 0 stays 0."""
    from fallgen.env.wrappers import rarest_label_resize

    rng = np.random.default_rng(3)
    for trial in range(6):
        img = np.repeat(np.repeat(rng.integers(1, 5, (6, 6)), 50, 0), 50, 1).astype(np.uint8)
        img[rng.random((300, 300)) < 0.02] = 0  # holes of nothing
        for k in range(8):  # small objects, 1 to 6 pixels a side
            y, x, a = rng.integers(0, 294), rng.integers(0, 294), rng.integers(1, 7)
            img[y:y + a, x:x + a] = 10 + k
        got = rarest_label_resize(img, 84)
        assert np.array_equal(got, _rarest_by_blocks(img, 84)), trial
        assert set(np.unique(img)) - {0} == set(np.unique(got)) - {0}  # every label shows
    missed = 0
    for y, x in rng.integers(0, 300, (40, 2)):
        img = np.full((300, 300), 3, np.uint8)
        img[y, x] = 7
        assert (rarest_label_resize(img, 84) == 7).sum() == 1
        missed += not (img[(np.arange(84) * 300 + 150) // 84][:, (np.arange(84) * 300 + 150)
                                                             // 84] == 7).any()
    assert missed > 30  # the nearest pixel would have lost most of them
    assert not rarest_label_resize(np.zeros((300, 300), np.uint8), 84).any()

