"""The Decision Transformer on the tiny build's expert trajectories: the training windows
against the export (returns-to-go, padding), a run stopped and resumed that ends where an
uninterrupted one does (bit for bit), the agent scored by ``fallgen evaluate`` (the same
actions for the same seed), and an export without the sensors it reads refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

SMALL = ("--set", "context=4", "--set", "embed=32", "--set", "layers=1", "--set", "heads=2",
         "--set", "batch_size=4", "--set", "eval_every=0", "--set", "checkpoint_every=2",
         "--set", "warmup_steps=2")
SENSORS = "rgb,depth,audio,pose,category_seg"


@pytest.fixture(scope="module")
def expert(tiny_dataset, tmp_path_factory, cli):
    out = tmp_path_factory.mktemp("expert")
    assert cli("export-expert", str(tiny_dataset), "-o", str(out), "--sensors",
                   SENSORS) == 0
    return out / "expert.h5"


def test_windows_hold_the_exports_returns_and_pad_at_the_start(expert, tmp_path):
    import h5py

    from fallgen.policies.dt_data import Windows, build_cache

    data = build_cache(expert, tmp_path / "cache", 44100)
    with h5py.File(expert, "r") as f:
        names = sorted(f["episodes"], key=int)
        for e, name in enumerate(names):
            g = f["episodes"][name]
            r = g["rewards"][()].astype(np.float64)
            s = int(data["start"][e])
            assert data["rtg"][s] == pytest.approx(r.sum(), abs=1e-4)
            assert data["rtg"][s + len(r) - 1] == pytest.approx(r[-1], abs=1e-5)
            assert np.array_equal(data["action"][s:s + len(r)], g["actions"][()])
            assert int(data["episode_id"][e]) == int(name)
    w = Windows(data, range(len(names)), context=4)
    s1 = int(data["start"][1])
    b = w.batch(np.array([s1 + 1, s1 + 3]))
    # the window ending at an episode's second state: two pads, then its first two states
    assert b["mask"].tolist() == [[False, False, True, True], [True, True, True, True]]
    assert b["t"][0].tolist() == [0, 0, 0, 1] and b["t"][1].tolist() == [0, 1, 2, 3]
    assert np.array_equal(b["rgb"][0, 2], data["rgb"][s1])
    assert np.array_equal(b["audio"][0, 3], data["audio"][1])


def test_dt_stopped_and_resumed_ends_where_one_run_does(tiny_dataset, expert, tmp_path, cli):
    import torch

    from fallgen.policies.runs import load_checkpoint, read_log

    a, b = tmp_path / "a", tmp_path / "b"
    common = ("--expert", str(expert), *SMALL)
    assert cli("train", "dt", str(tiny_dataset), "-o", str(a), "--budget", "4", *common) == 0
    assert cli("train", "dt", str(tiny_dataset), "-o", str(b), "--budget", "2", *common) == 0
    assert cli("train", "dt", str(tiny_dataset), "-o", str(b), "--budget", "4", "--expert",
               str(expert)) == 0
    ca = load_checkpoint(a / "checkpoints" / "ckpt-000004.pt", "dt")
    cb = load_checkpoint(b / "checkpoints" / "ckpt-000004.pt", "dt")
    for k, v in ca["state"]["model"].items():
        assert torch.equal(v, cb["state"]["model"][k]), k
    assert ca["state"]["sampler"] == cb["state"]["sampler"]
    c2 = load_checkpoint(a / "checkpoints" / "ckpt-000002.pt", "dt")
    assert any(not torch.equal(v, ca["state"]["model"][k])
               for k, v in c2["state"]["model"].items())  # training moved the weights
    la, lb = read_log(a / "log.csv"), read_log(b / "log.csv")
    assert [r["update"] for r in la] == [r["update"] for r in lb] == ["2", "4"]
    assert [r["loss"] for r in la] == [r["loss"] for r in lb]
    assert (a / "curve.png").stat().st_size > 1000

    # evaluated as every agent is; the same seed, the same actions
    outs = []
    for k in range(2):
        out = tmp_path / f"eval{k}"
        assert cli("evaluate", str(tiny_dataset), "--agent", str(a), "--split", "test",
                   "--workers", "1", "-o", str(out)) == 0
        outs.append([json.loads(x) for x in (out / "episodes.jsonl").read_text().splitlines()])
    assert len(outs[0]) == 2 and [e["actions"] for e in outs[0]] == \
        [e["actions"] for e in outs[1]]


def test_an_export_without_the_sensors_is_refused(tiny_dataset, tmp_path, cli, capsys):
    out = tmp_path / "poor"
    assert cli("export-expert", str(tiny_dataset), "-o", str(out), "--sensors", "pose",
               "--episodes", "0", "--split", "all") == 0
    capsys.readouterr()
    assert cli("train", "dt", str(tiny_dataset), "-o", str(tmp_path / "run"), "--expert",
               str(out / "expert.h5")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "expert.h5: sensors: lacks rgb" in err, err


def test_a_run_exports_a_seeded_subsample_of_the_split(tiny_dataset, tmp_path, cli):
    """``--set episodes=N``: the run exports N of the train split's episodes, those that
    ``SeedSequence(seed, spawn_key=(7,))`` draws from the sorted ids, and learns from them."""
    import h5py

    import fallgen.dataset

    train = sorted(fallgen.dataset.open(tiny_dataset).ids("train"))
    assert len(train) >= 2
    drawn = set()
    for seed in (0, 1, 2):
        run = tmp_path / f"s{seed}"
        assert cli("train", "dt", str(tiny_dataset), "-o", str(run), "--budget", "1",
                   "--seed", str(seed), "--set", "episodes=1", *SMALL) == 0
        with h5py.File(run / "expert" / "expert.h5", "r") as f:
            got = sorted(int(g.attrs["episode_id"]) for g in f["episodes"].values())
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(7,)))
        assert got == sorted(train[i] for i in rng.choice(len(train), 1, replace=False))
        assert np.load(run / "cache" / "episode_id.npy").tolist() == got
        drawn.add(got[0])
    assert len(drawn) == 2  # the seeds drew both episodes, not always the first
