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
        clip = r["audio"]
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
        # the held cues: the perception module's features of the step-0 clip
        from fallgen.perception.audio_features import AudioFeatures

        want_cues = AudioFeatures(int(raw.ds.row(eid)["sample_rate"]),
                                  clip.shape[-1]).extract(clip)
        assert np.array_equal(m["cues"], want_cues) and np.abs(want_cues).sum() > 0
        agent = stack_memory(mine[-4:], 4, mine[0]["audio"], m["goal_place"], want_cues)
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


def test_found_starts_at_its_prior_probability(tiny_dataset):
    """A new SAVi policy claims ``found`` with probability ``found_prior`` on any observation
    (the other five share the rest evenly): the softmax of its start, not the uniform 1/6."""
    import torch
    from stable_baselines3.common.vec_env import DummyVecEnv

    from fallgen.env import FallenObjectsEnv
    from fallgen.policies.savi import FOUND, TRAIN_SENSORS, make_model, settings
    from fallgen.policies.savi_parts import MemoryObservation

    cfg = settings({"memory": 2, "embed": 16, "heads": 2, "layers": 1,
                    "found_prior": 0.03}).to_dict() | {"n_categories": 64}
    venv = DummyVecEnv([lambda: MemoryObservation(
        FallenObjectsEnv(tiny_dataset, "test", sensors=TRAIN_SENSORS), 2)])
    try:
        model = make_model(cfg, venv, "cpu")
        obs = venv.reset()
        for _ in range(3):
            t, _ = model.policy.obs_to_tensor(obs)
            with torch.no_grad():
                p = model.policy.get_distribution(t).distribution.probs[0].numpy()
            assert p[FOUND] == pytest.approx(0.03, abs=1e-6)
            others = np.delete(p, FOUND)
            assert others == pytest.approx(np.full(5, 0.97 / 5), abs=1e-6)
            obs, *_ = venv.step(np.array([0]))
    finally:
        venv.close()
    with pytest.raises(ValueError, match="found_prior"):
        settings({"found_prior": 1.0})


def test_a_savi_run_from_before_the_cues_is_refused(tiny_dataset, tmp_path, cli, capsys):
    """A run whose settings lack found_prior (its goal descriptor read band energies) is
    refused with one line naming the field, when resumed and when evaluated."""
    from fallgen.policies.agent import load_run
    from fallgen.errors import InputError

    run = tmp_path / "savi"
    assert cli("train", "savi", str(tiny_dataset), "-o", str(run), "--budget", "16",
               *SMALL) == 0
    meta = json.loads((run / "run.json").read_text())
    del meta["config"]["found_prior"]
    (run / "run.json").write_text(json.dumps(meta))
    capsys.readouterr()
    assert cli("train", "savi", str(tiny_dataset), "-o", str(run), "--budget", "32",
               "--envs", "0") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "config.found_prior" in err[0]
    import torch

    ck_path = sorted((run / "checkpoints").glob("*.pt"))[-1]
    ck = torch.load(ck_path, weights_only=False)
    del ck["config"]["found_prior"]
    torch.save(ck, ck_path)
    with pytest.raises(InputError, match="found_prior"):
        load_run(run)
