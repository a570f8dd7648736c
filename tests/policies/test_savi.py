"""SAVi on the tiny build: the memory observation against hand-stacked frames and the true
place against the episode's row, the goal descriptor's first stage, a few PPO updates with
the online fine-tuning, a resumed run that goes on, and ``fallgen evaluate --agent RUN``
with the agent's own memory equal to the wrapper's."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.xdist_group("tiny_build")

SMALL = ("--envs", "0", "--set", "n_steps=16", "--set", "batch_size=16", "--set", "n_epochs=1",
         "--set", "checkpoint_every=1", "--set", "memory=3", "--set", "embed=32",
         "--set", "heads=2", "--set", "layers=1", "--set", "goal_epochs=200")


def test_memory_holds_the_last_steps_and_the_true_place(tiny_dataset):
    """Three steps into an episode with memory 4: one padded slot, then the compact views in
    order; the label is the object's place in the spawn's frame (its row's settle position,
    azimuth from the spawn's heading), held; the agent stacks the same memory itself."""
    from fallgen.env import FallenObjectsEnv
    from fallgen.env.wrappers import CompactObservation
    from fallgen.perception.audio_features import relative_place
    from fallgen.policies import SENSORS
    from fallgen.policies.encoder import compactor
    from fallgen.policies.savi import TRAIN_SENSORS
    from fallgen.policies.savi_parts import PLACE_SCALE_M, MemoryObservation, stack_memory

    mem = MemoryObservation(FallenObjectsEnv(tiny_dataset, "test", sensors=TRAIN_SENSORS), 4)
    plain = CompactObservation(FallenObjectsEnv(tiny_dataset, "test", sensors=TRAIN_SENSORS))
    raw = FallenObjectsEnv(tiny_dataset, "test", sensors=SENSORS)
    try:
        eid = mem.unwrapped.ids[0]
        m, _ = mem.reset(options={"episode_id": eid})
        p, _ = plain.reset(options={"episode_id": eid})
        r, _ = raw.reset(options={"episode_id": eid})
        conv = compactor(int(raw.ds.row(eid)["sample_rate"]))
        mine = [conv(r, first=True)]
        seen = [p]
        for a in (1, 0, 2):
            m, *_ = mem.step(a)
            p, *_ = plain.step(a)
            r, *_ = raw.step(a)
            seen.append(p)
            mine.append(conv(r))
        assert m["valid"].tolist() == [1, 1, 1, 1]
        for k in ("rgb", "depth", "category_seg", "pose"):
            assert np.array_equal(m[k], np.stack([s[k] for s in seen[-4:]])), k
        az, d = relative_place(mem.unwrapped.episode.row)
        want = np.array([d * math.cos(az), d * math.sin(az)]) / PLACE_SCALE_M
        assert m["goal_place"] == pytest.approx(want, abs=0.05 / PLACE_SCALE_M)
        agent = stack_memory(mine[-4:], 4, mine[0]["audio"], m["goal_place"])
        for k in m:
            assert np.array_equal(agent[k], m[k]), k
        m, _ = mem.reset(options={"episode_id": eid})
        assert m["valid"].tolist() == [0, 0, 0, 1] and not m["rgb"][:3].any()
    finally:
        mem.close()
        plain.close()
        raw.close()


def test_savi_trains_resumes_and_is_evaluated(tiny_dataset, tmp_path, cli):
    from fallgen.policies.runs import load_checkpoint, read_log

    run = tmp_path / "savi"
    assert cli("train", "savi", str(tiny_dataset), "-o", str(run), "--budget", "32",
               *SMALL) == 0
    goal = json.loads((run / "goal.json").read_text())
    # the first stage learned the train split's clips
    assert goal["train"]["category_accuracy"] == 1.0
    assert goal["train"]["place_error_m"] < goal["train_before"]["place_error_m"]
    rows = read_log(run / "log.csv")
    assert [r["update"] for r in rows] == ["1", "2"]
    assert all(math.isfinite(float(r["goal_error_m"])) for r in rows)
    c2 = load_checkpoint(run / "checkpoints" / "ckpt-000002.pt", "savi")
    steps = [float(s["step"]) for s in c2["state"]["goal_optimizer"]["state"].values()]
    assert steps and max(steps) == 2 * 4  # two rollouts' fine-tuning, 4 steps each
    assert cli("train", "savi", str(tiny_dataset), "-o", str(run), "--budget", "48",
               "--envs", "0") == 0
    c3 = load_checkpoint(run / "checkpoints" / "ckpt-000003.pt", "savi")
    assert c3["timesteps"] == 48
    assert max(float(s["step"]) for s in c3["state"]["goal_optimizer"]["state"].values()) \
        == 3 * 4
    assert read_log(run / "log.csv")[:2] == rows
    out = tmp_path / "eval"
    assert cli("evaluate", str(tiny_dataset), "--agent", str(run), "--split", "test",
               "--workers", "1", "-o", str(out)) == 0
    eps = [json.loads(x) for x in (out / "episodes.jsonl").read_text().splitlines()]
    assert len(eps) == 2 and all(e["steps"] >= 1 for e in eps)
