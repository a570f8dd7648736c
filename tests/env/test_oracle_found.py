"""FallenObjectsEnv(oracle_found=True): the episode ends in success after the first action that
leaves the object within 2 m (horizontally) and in view, and only then. Judged here on
hand-made poses with a full segmentation render and the distance to the object's centre."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

VISIBLE_PIXELS = 4  # the success rule's "in view"
SUCCESS_M = 2.0


def _rule(env, pose) -> tuple[bool, bool]:
    """(within 2 m, in view) of ``pose``, judged without the environment's own shortcuts: the
    horizontal distance to the object's centre and the object's pixels in a full render."""
    room = env._room
    near = math.hypot(pose.x - room.centre[0], pose.y - room.centre[1]) <= SUCCESS_M
    view = room.camera.render(room.data, pose, "all")
    return near, view.pixels_of("obj:target") >= VISIBLE_PIXELS


def _hand_made_poses(row):
    """The expert's last pose (it claims there), the same place facing away, and the same
    heading stepped back 0.25 m at a time (farther than 2 m, often still in view)."""
    from fallgen.nav.agent import HEADING_VECTORS, Pose

    x, y, h, t = row["expert_poses"][-1]
    goal = Pose(float(x), float(y), int(h), int(t))
    poses = [goal, replace(goal, heading=(goal.heading + 6) % 12)]
    back = -HEADING_VECTORS[goal.heading]
    for k in (3, 6, 9, 12):
        poses.append(replace(goal, x=float(x + 0.25 * k * back[0]),
                             y=float(y + 0.25 * k * back[1])))
    return poses


def test_oracle_found_ends_exactly_when_the_rule_holds(tiny_dataset):
    """Each hand-made pose is reached by one turn to the left from the pose one heading to its
    right (a turn moves nothing): the episode ends in success with the success reward exactly
    when the pose is within 2 m with the object in view; without the option it never ends."""
    import fallgen.dataset
    from fallgen.env import FallenObjectsEnv
    from fallgen.nav.agent import LEFT

    ds = fallgen.dataset.open(tiny_dataset)
    oracle = FallenObjectsEnv(tiny_dataset, sensors=("pose",), oracle_found=True)
    plain = FallenObjectsEnv(tiny_dataset, sensors=("pose",))
    kinds = set()
    try:
        for row in list(ds.rows())[::2]:
            eid = row["episode_id"]
            oracle.reset(options={"episode_id": eid})
            for pose in _hand_made_poses(row):
                oracle._walk.pose = replace(pose, heading=(pose.heading - 1) % 12)
                near, seen = want = _rule(oracle, pose)
                kinds.add(want)
                obs, r, term, trunc, info = oracle.step(LEFT)
                assert oracle.pose == pose and not trunc
                assert term == (near and seen), (eid, pose, want)
                if not term:
                    assert r == pytest.approx(-0.01) and "success" not in info
                    continue
                assert r == pytest.approx(-0.01 + 10.0)
                assert info["success"] and info["outcome"] == "found" and info["claims"] == 0
                oracle.reset(options={"episode_id": eid})
                # without the option the same turn is only a turn
                plain.reset(options={"episode_id": eid})
                plain._walk.pose = replace(pose, heading=(pose.heading - 1) % 12)
                obs, r, term, trunc, info = plain.step(LEFT)
                assert not term and not trunc and r == pytest.approx(-0.01)
    finally:
        oracle.close()
        plain.close()
    # the poses tried the rule both ways: near and seen, near and unseen, far and seen
    assert {(True, True), (True, False), (False, True)} <= kinds, kinds


def test_the_experts_path_without_found_ends_in_success(tiny_dataset):
    """The expert's actions without its final ``found``: the oracle ends the episode on the
    path, in success, with SPL 1 (no success pose is nearer than the expert's) and SNA 1."""
    import fallgen.dataset
    from fallgen.env import FallenObjectsEnv
    from fallgen.nav.agent import FOUND

    ds = fallgen.dataset.open(tiny_dataset)
    env = FallenObjectsEnv(tiny_dataset, sensors=("pose",), oracle_found=True)
    try:
        for row in list(ds.rows())[1::2]:
            acts = [a for a in row["expert_actions"] if a != FOUND]
            env.reset(options={"episode_id": row["episode_id"]})
            for k, a in enumerate(acts):
                obs, r, term, trunc, info = env.step(a)
                near, seen = _rule(env, env.pose)
                assert term == (near and seen)
                if term:
                    break
            assert term and info["success"] and info["claims"] == 0
            assert info["spl"] == 1.0 and info["sna"] == 1.0
            assert info["step"] == k + 1 <= len(acts)
            assert np.isfinite(info["distance_to_object_m"]) and \
                info["distance_to_object_m"] <= SUCCESS_M
    finally:
        env.close()


def test_the_random_walk_with_the_oracle_moves_and_ends_only_by_the_rule(tiny_dataset,
                                                                        tmp_path, cli):
    """``RandomAgent(oracle_found=True)`` scored by ``fallgen evaluate``: it never claims (only
    the five moves), every episode it wins ends on a pose where the rule holds (its last
    pose, replayed, is within 2 m with the object in view), and every other runs to the
    action limit."""
    import json

    from fallgen.env import FallenObjectsEnv
    from fallgen.nav.agent import MAX_ACTIONS

    out = tmp_path / "rw"
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--workers", "1", "--agent",
               "fallgen.agents.random_agent:RandomAgent", "--agent-kwargs",
               '{"oracle_found": true}', "-o", str(out)) == 0
    eps = [json.loads(x) for x in (out / "episodes.jsonl").read_text().splitlines()]
    assert eps and all(max(e["actions"]) < 5 and e["claims"] == 0 for e in eps)
    env = FallenObjectsEnv(tiny_dataset, sensors=("pose",))
    try:
        for e in eps:
            env.reset(options={"episode_id": e["episode_id"]})
            for a in e["actions"]:
                env.step(a)
            near, seen = _rule(env, env.pose)
            assert e["success"] == (near and seen)
            assert e["success"] or len(e["actions"]) == MAX_ACTIONS
    finally:
        env.close()
