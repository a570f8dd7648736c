"""The Object-Goal baseline: five candidate categories per episode (the true one among them,
the same for the same seed), the modular agent's search for any of them without audio, and
``fallgen evaluate --baseline objectgoal`` with its refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


def test_candidates_hold_the_true_category_and_depend_only_on_the_seed(world):
    from fallgen.agents.objectgoal import CANDIDATES, candidate_categories

    targets = world.categories.ids("target")
    assert CANDIDATES == 5
    firsts, draws = set(), set()
    for seed in range(40):
        true = targets[seed % len(targets)]
        c = candidate_categories(true, targets, seed)
        assert len(c) == len(set(c)) == 5 and true in c and set(c) <= set(targets)
        assert c == candidate_categories(true, targets, seed)
        assert c == candidate_categories(true, list(reversed(targets)), seed)  # a set
        firsts.add(c[0] == true)
        draws.add(frozenset(candidate_categories(targets[0], targets, seed)))
    assert firsts == {True, False}  # shuffled: the true one is not always first
    assert len(draws) > 30  # the seed draws the others
    with pytest.raises(ValueError, match="candidates"):
        candidate_categories(targets[0], targets[:3], 0)


def test_the_agent_looks_for_its_candidates_without_audio(tiny_dataset, world):
    from fallgen.agents import make_baseline
    from fallgen.agents.objectgoal import ObjectGoalAgent, candidate_categories
    from fallgen.env import FallenObjectsEnv
    from fallgen.evaluation.runner import agent_seed, play
    from fallgen.vision.camera import world_category_labels

    labels, targets = world_category_labels(world), world.categories.ids("target")
    agent = make_baseline("objectgoal", labels, targets, ("segmentation",))
    assert isinstance(agent, ObjectGoalAgent)
    assert "audio" not in agent.sensors and "object_position" not in agent.sensors
    assert {"category_seg", "object_category", "depth"} <= set(agent.sensors)
    env = FallenObjectsEnv(tiny_dataset, sensors=agent.sensors, world=world)
    try:
        for i in env.ids[:3]:
            rec = play(env, agent, i, seed=5)
            true = env.episode.row["category"]
            assert agent.told == candidate_categories(true, targets, agent_seed(5, i))
            assert true in agent.told
            assert sorted(labels[k] for k in agent.target_idx) == sorted(agent.told)
            assert play(env, agent, i, seed=5)["actions"] == rec["actions"]
    finally:
        env.close()
    for bad in (("location",), ("category",)):
        with pytest.raises(ValueError, match="Object-Goal"):
            ObjectGoalAgent(labels, targets, oracles=bad)
    with pytest.raises(ValueError, match="eyes"):
        ObjectGoalAgent(labels, targets)
    with pytest.raises(ValueError, match="audio"):
        make_baseline("objectgoal", labels, targets, ("segmentation",), audio_model="x")


def test_evaluate_objectgoal(tiny_dataset, tmp_path, cli, capsys):
    out = tmp_path / "og"
    assert cli("evaluate", str(tiny_dataset), "--baseline", "objectgoal", "--oracles",
               "segmentation", "--split", "all", "--workers", "1", "-o", str(out)) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["agent"] == "objectgoal[segmentation]" and s["n"] == 6
    recs = [json.loads(x) for x in (out / "episodes.jsonl").read_text().splitlines()]
    assert np.mean([r["success"] for r in recs]) == pytest.approx(s["success"])
    capsys.readouterr()
    for args in (("--oracles", "segmentation,location"), ("--oracles", "none"),
                 ("--oracles", "segmentation", "--audio-model", str(out / "summary.json"))):
        assert cli("evaluate", str(tiny_dataset), "--baseline", "objectgoal", *args,
                   "-o", str(tmp_path / "x")) == 2, args
        assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()
