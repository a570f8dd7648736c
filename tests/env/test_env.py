"""The environment (fallgen.env) on the tiny build: Gymnasium's checker, the dataset's own
step-0 views, the expert through the vector env, rewards and measures of hand-made sequences,
collisions, seeding, claims, rendering and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.env import SENSORS  # every sensor, oracles included

#: The success rule's "visible" (docs/benchmark.md): at least 4 pixels of the object in view
VISIBLE_PIXELS = 4

pytestmark = pytest.mark.xdist_group("tiny_build")


@pytest.fixture(scope="module")
def env(tiny_dataset):
    from fallgen.env import FallenObjectsEnv

    e = FallenObjectsEnv(tiny_dataset, sensors=SENSORS, render_mode="rgb_array")
    yield e
    e.close()


def test_gymnasium_env_checker_passes(tiny_dataset):
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env

    import fallgen.env

    e = gym.make(fallgen.env.ENV_ID, dataset=str(tiny_dataset), split="test", sensors=SENSORS,
                 render_mode="rgb_array", order="shuffle")
    try:
        check_env(e.unwrapped, skip_render_check=False)
    finally:
        e.close()


def test_reset_gives_the_datasets_own_step0_observation(env, tiny_dataset):
    import fallgen.dataset

    ds = fallgen.dataset.open(tiny_dataset)
    for eid in ds.ids():
        obs, info = env.reset(options={"episode_id": eid})
        ep = ds.get(eid)
        assert info == {"episode_id": eid, "step": 0, "moved": False}
        assert np.array_equal(obs["rgb"], ep["rgb"])
        assert np.array_equal(obs["depth"][..., 0].astype(np.float16),
                              ep["depth"].astype(np.float16))
        assert np.array_equal(obs["category_seg"][..., 0], ep["category_seg"])
        assert np.array_equal(obs["audio"], ep["audio"])
        assert env.category_labels[obs["object_category"]] == ep["category"]
        assert np.array_equal(obs["pose"], np.zeros(4, np.float32))
        # the object's position relative to the camera: its horizontal distance from the spawn
        d = env._room.object_distance_m(env.pose)
        assert math.hypot(*obs["object_position"][:2]) == pytest.approx(d, abs=1e-5)
        assert env.observation_space.contains(obs)


def _target_pixels(obs) -> int:
    """Pixels of the object's category in a view's category segmentation."""
    return int(np.sum(obs["category_seg"][..., 0] == int(obs["object_category"])))


def test_expert_actions_replayed_step_by_step(env, tiny_dataset):
    """The oracle's next action from the spawn on is the dataset's expert sequence; replaying
    it succeeds with SPL 1 and the stored SNA; the paper's reward adds up by hand."""
    import fallgen.dataset
    from fallgen.nav.agent import FORWARD

    ds = fallgen.dataset.open(tiny_dataset)
    for row in ds.rows():
        obs, _ = env.reset(options={"episode_id": row["episode_id"]})
        centre = env._room.centre[:2]
        total, expected = 0.0, 0.0
        shown = [_target_pixels(obs)]
        for k, a in enumerate(row["expert_actions"]):
            assert int(obs["expert_action"]) == a
            p0 = np.array(row["expert_poses"][k][:2])
            p1 = np.array(row["expert_poses"][k + 1][:2])
            obs, r, term, trunc, info = env.step(a)
            shown.append(_target_pixels(obs))
            total += r
            expected += -0.01
            if a == FORWARD and not np.array_equal(p0, p1):
                expected += np.sign(np.linalg.norm(p0 - centre) - np.linalg.norm(p1 - centre))
        assert term and not trunc
        expected += 10.0
        assert total == pytest.approx(expected, abs=1e-9)
        assert info["success"] and info["is_success"] and info["outcome"] == "found"
        assert info["spl"] == 1.0 and info["sna"] == pytest.approx(row["expert_sna"])
        assert info["path_length_m"] == row["expert_path_m"] == row["shortest_path_m"]
        assert info["step"] == len(row["expert_actions"])
        # the first view (0: the spawn's, k: after k actions) whose segmentation shows the
        # object's category in VISIBLE_PIXELS pixels or more (no distractor shares it)
        assert info["first_seen_step"] == next(k for k, n in enumerate(shown)
                                               if n >= VISIBLE_PIXELS), shown
        assert info["soft_spl"] == 1.0
        # the agent's pose in the spawn's frame, as the pose sensor has it
        x, y, h, t = row["expert_poses"][-1]
        s = row["spawn_x"], row["spawn_y"], row["spawn_yaw_rad"]
        dx, dy = x - s[0], y - s[1]
        c, si = math.cos(s[2]), math.sin(s[2])
        want = [dx * c + dy * si, -dx * si + dy * c]
        assert obs["pose"][:2] == pytest.approx(want, abs=1e-5)
        assert obs["pose"][3] == pytest.approx(math.radians(t))
        with pytest.raises(Exception, match="reset"):
            env.step(0)


def test_hand_made_sequences_give_hand_computed_spl_sna(env, tiny_dataset):
    """Two turns in place before the expert's actions: the same path (SPL 1), two more
    actions (SNA n* / (n + 2)); a 180 degree turn, a step out and back, then the expert:
    SPL l / (l + 0.5)."""
    import fallgen.dataset
    from fallgen.nav.agent import FORWARD, LEFT, RIGHT

    ds = fallgen.dataset.open(tiny_dataset)
    row = max(ds.rows(), key=lambda r: len(r["expert_actions"]))
    eid, acts = row["episode_id"], list(row["expert_actions"])
    n_star, l = row["fewest_actions"], row["shortest_path_m"]

    def play(seq):
        env.reset(options={"episode_id": eid})
        for a in seq:
            obs, r, term, trunc, info = env.step(a)
            if term or trunc:
                return info
        raise AssertionError("not ended")

    info = play([LEFT, RIGHT] + acts)
    assert info["success"] and info["spl"] == 1.0
    assert info["sna"] == pytest.approx(n_star / (len(acts) + 2))
    # out and back: only when the first step of the detour is free; find a heading that is
    env.reset(options={"episode_id": eid})
    for turns in range(12):
        env.reset(options={"episode_id": eid})
        for _ in range(turns):
            env.step(LEFT)
        _, _, _, _, i1 = env.step(FORWARD)
        if i1["moved"]:
            break
    else:
        pytest.skip("boxed in")
    back = [LEFT] * turns + [FORWARD] + [LEFT] * 6 + [FORWARD] + [RIGHT] * 6 + [RIGHT] * turns
    info = play(back + acts)
    assert info["success"] and info["path_length_m"] == pytest.approx(l + 0.5)
    assert info["spl"] == pytest.approx(l / (l + 0.5))
    assert info["sna"] == pytest.approx(n_star / (len(acts) + len(back)))


def test_a_collision_leaves_the_pose_and_costs_the_step(env):
    from fallgen.nav.agent import FORWARD

    env.reset(options={"episode_id": 0})
    for _ in range(60):  # walk straight until something stops the robot
        before = env.pose
        obs, r, term, trunc, info = env.step(FORWARD)
        if not info["moved"]:
            assert env.pose == before and r == pytest.approx(-0.01)
            assert not term and not trunc
            return
    pytest.fail("never blocked")


def test_geodesic_reward_telescopes(tiny_dataset):
    from fallgen.env import FallenObjectsEnv

    e = FallenObjectsEnv(tiny_dataset, sensors=("pose", "expert_action"), reward="geodesic")
    try:
        obs, _ = e.reset(options={"episode_id": 1})
        g0 = e._geo.distance(e.pose.xy)
        total, n = 0.0, 0
        while True:
            obs, r, term, trunc, info = e.step(int(obs["expert_action"]))
            total += r
            n += 1
            if term or trunc:
                break
        assert info["success"]
        assert total == pytest.approx(-0.01 * n + 10 + g0 - info["geodesic_distance_m"])
        assert g0 >= math.dist(e.episode.spawn.xy, e._room.centre[:2]) - 1e-9
    finally:
        e.close()


def test_two_claims_and_the_action_limit(tiny_dataset):
    from fallgen.env import FallenObjectsEnv
    from fallgen.nav.agent import FOUND, LEFT

    e = FallenObjectsEnv(tiny_dataset, sensors=("expert_action",), claims=2)
    try:
        obs, _ = e.reset(options={"episode_id": 2})
        obs, r, term, trunc, info = e.step(FOUND)  # from the spawn, 2 m away or more: wrong
        assert not term and not trunc and r == pytest.approx(-0.01)
        while True:
            obs, r, term, trunc, info = e.step(int(obs["expert_action"]))
            if term or trunc:
                break
        assert info["success"] and info["claims"] == 2 and info["spl"] == 1.0
        e.reset(options={"episode_id": 2})
        for k in range(200):
            obs, r, term, trunc, info = e.step(LEFT)
            assert (k == 199) == trunc and not term
        assert info["outcome"] == "timeout" and info["step"] == 200
    finally:
        e.close()
    e = FallenObjectsEnv(tiny_dataset, sensors=("pose",))
    try:
        e.reset(options={"episode_id": 2})
        _, _, term, _, info = e.step(FOUND)
        assert term and info["outcome"] == "wrong_found" and not info["success"]
    finally:
        e.close()


def test_the_spec_holds_the_action_limit(tiny_dataset):
    """gym.make's environment says its limit in its spec (what libraries read), and its
    TimeLimit ends the episode at the step the environment does: the 200th action, once."""
    import gymnasium as gym

    import fallgen.env
    from fallgen.nav.agent import LEFT

    e = gym.make(fallgen.env.ENV_ID, dataset=str(tiny_dataset), sensors=("pose",))
    try:
        assert e.spec.max_episode_steps == 200
        e.reset(options={"episode_id": 2})
        ends = []
        for k in range(200):
            _, _, term, trunc, info = e.step(LEFT)
            if term or trunc:
                ends.append((k, term, trunc))
        assert ends == [(199, False, True)] and info["outcome"] == "timeout"
    finally:
        e.close()


def test_same_seed_same_observations(tiny_dataset):
    from fallgen.env import FallenObjectsEnv

    def trajectory(seed):
        e = FallenObjectsEnv(tiny_dataset, sensors=("rgb", "depth", "pose"), order="shuffle")
        e.action_space.seed(seed)
        out = []
        try:
            for _ in range(3):
                obs, info = e.reset(seed=seed) if not out else e.reset()
                out.append((info["episode_id"], obs))
                for _ in range(8):
                    obs, r, term, trunc, info = e.step(e.action_space.sample())
                    out.append((info["episode_id"], obs, r))
                    if term or trunc:
                        break
        finally:
            e.close()
        return out

    a, b = trajectory(5), trajectory(5)
    assert [x[0] for x in a] == [x[0] for x in b]
    for x, y in zip(a, b):
        assert all(np.array_equal(x[1][k], y[1][k]) for k in x[1])
    # the seed chooses the order of a shuffled selection
    firsts = {trajectory_first(tiny_dataset, s) for s in range(6)}
    assert len(firsts) > 1


def trajectory_first(tiny_dataset, seed):
    from fallgen.env import FallenObjectsEnv

    e = FallenObjectsEnv(tiny_dataset, sensors=("pose",), order="shuffle")
    try:
        return e.reset(seed=seed)[1]["episode_id"]
    finally:
        e.close()


def test_selection_slices_and_bad_input(tiny_dataset):
    import fallgen.dataset
    from fallgen.env import FallenObjectsEnv
    from fallgen.env.source import select

    ds = fallgen.dataset.open(tiny_dataset)
    every = ds.ids()
    parts = [select(ds, rank=r, world_size=3) for r in range(3)]
    assert sorted(sum(parts, [])) == every and len(set(sum(parts, []))) == len(every)
    assert select(ds, "test", "study") == ds.ids("test", "study")
    for kwargs, match in (({"split": "nope"}, "split"), ({"room_kind": "garage"}, "room_kind"),
                          ({"episode_ids": [999]}, "no episode 999"),
                          ({"categories": ["unicorn"]}, "unicorn"),
                          ({"sensors": ("sonar",)}, "sensors"), ({"reward": "x"}, "reward")):
        with pytest.raises(ValueError, match=match):
            FallenObjectsEnv(tiny_dataset, **kwargs)
    with pytest.raises(FileNotFoundError):
        FallenObjectsEnv(tiny_dataset / "nowhere")
    e = FallenObjectsEnv(tiny_dataset, sensors=("pose",))
    try:
        with pytest.raises(ValueError, match="no episode 77"):
            e.reset(options={"episode_id": 77})
        e.reset()
        with pytest.raises(ValueError, match="action"):
            e.step(9)
    finally:
        e.close()


def test_a_room_that_differs_from_the_stored_one_is_refused(tiny_dataset, tmp_path):
    import shutil

    import h5py

    import fallgen.dataset
    from fallgen.env import FallenObjectsEnv

    copy = tmp_path / "ds"
    shutil.copytree(tiny_dataset, copy)
    ds = fallgen.dataset.open(copy)
    row = ds.row(0)
    with h5py.File(copy / row["media_file"], "r+") as f:
        occ = f["occupancy"][str(row["media_index"])]
        occ[0, 0, :] = 1 - occ[0, 0, :]
    e = FallenObjectsEnv(copy, sensors=("pose",))
    try:
        with pytest.raises(ValueError, match="occupancy"):
            e.reset(options={"episode_id": 0})
    finally:
        e.close()


def test_render_and_record_video(tiny_dataset, tmp_path):
    """The rendered frame is the agent's own view (the rgb it observes) beside the room from
    above; RecordVideo writes it."""
    import gymnasium as gym
    from gymnasium.wrappers import RecordVideo

    import fallgen.env

    pytest.importorskip("moviepy")
    e = gym.make(fallgen.env.ENV_ID, dataset=str(tiny_dataset), sensors=("rgb", "depth", "pose"),
                 render_mode="rgb_array")
    e = RecordVideo(e, str(tmp_path / "video"), episode_trigger=lambda k: True,
                    disable_logger=True)
    try:
        obs, _ = e.reset(seed=0)
        frame = e.render()
        assert frame.shape == (300, 600, 3) and frame.dtype == np.uint8
        assert np.array_equal(frame[:, :300], obs["rgb"])
        for _ in range(5):
            obs, *_ = e.step(1)
            frame = e.render()
            assert np.array_equal(frame[:, :300], obs["rgb"])
    finally:
        e.close()
    assert list((tmp_path / "video").glob("*.mp4"))


def test_expert_succeeds_everywhere_through_the_vector_env(tiny_dataset):
    """Two worker processes (shared memory), each its slice: every episode once, SR = SPL = 1."""
    import fallgen.dataset
    import fallgen.env

    from fallgen.env import NO_PLAN

    ids = fallgen.dataset.open(tiny_dataset).ids()
    vec = fallgen.env.make_vec(tiny_dataset, num_envs=2, sensors=("expert_action", "pose"))
    done: dict[int, dict] = {}
    played_by: dict[int, set] = {0: set(), 1: set()}
    try:
        obs, infos = vec.reset(seed=0)
        for _ in range(400):
            actions = np.asarray(obs["expert_action"])
            assert not (actions == NO_PLAN).any()
            obs, r, term, trunc, infos = vec.step(actions)
            for k in np.flatnonzero(term | trunc):
                eid = int(infos["episode_id"][k])
                played_by[int(k)].add(eid)
                done.setdefault(eid, {m: infos[m][k] for m in ("success", "spl")})
            if len(done) == len(ids):
                break
    finally:
        vec.close()
    assert sorted(done) == ids
    assert not played_by[0] & played_by[1]  # disjoint slices
    assert all(d["success"] and d["spl"] == 1.0 for d in done.values())


def test_async_stepping_plays_the_same_episodes_as_lockstep(tiny_dataset):
    """send/recv: each environment stepped as soon as it is done (one at a time, the other
    still stepping) follows the expert to the same outcomes, on the same episodes, as the
    lockstep step(); misuse is refused; step() after send() first waits for it."""
    import fallgen.dataset
    import fallgen.env

    ids = fallgen.dataset.open(tiny_dataset).ids()
    vec = fallgen.env.make_vec(tiny_dataset, num_envs=2, sensors=("expert_action", "pose"))
    done: dict[int, dict] = {}
    played_by: dict[int, list] = {0: [], 1: []}
    steps = {0: 0, 1: 0}
    try:
        obs, _ = vec.reset(seed=0)
        with pytest.raises(RuntimeError, match="send"):
            vec.recv()
        vec.send(obs["expert_action"], [0, 1])
        assert vec.pending == {0, 1}
        with pytest.raises(ValueError, match="already stepping"):
            vec.send([0], [1])
        while len(done) < len(ids):
            r = vec.recv()
            assert r.observations["pose"].shape == (len(r.env_ids), 4)
            for k, i in enumerate(r.env_ids):
                i = int(i)
                steps[i] += 1
                if r.terminations[k] or r.truncations[k]:
                    info = r.infos[k]
                    played_by[i].append(int(info["episode_id"]))
                    done.setdefault(int(info["episode_id"]),
                                    {m: info[m] for m in ("success", "spl")})
            # step only the first one back; the other is sent on its own later
            vec.send(r.observations["expert_action"][:1], r.env_ids[:1])
            if len(r.env_ids) > 1:
                vec.send(r.observations["expert_action"][1:], r.env_ids[1:])
            assert sum(steps.values()) < 800
        vec.recv(len(vec.pending))
        assert not vec.pending
        with pytest.raises(ValueError, match="action"):
            vec.send([9], [0])
        vec.send([1], [0])
        obs, *_ = vec.step(np.array([1, 1]))  # lockstep again: waits for what was sent first
        assert obs["pose"].shape == (2, 4) and not vec.pending
    finally:
        vec.close()
    assert sorted(done) == ids
    assert not set(played_by[0]) & set(played_by[1])
    assert all(d["success"] and d["spl"] == 1.0 for d in done.values())
    # the same slices as the lockstep env's (environment i: slice i of 2)
    for i in (0, 1):
        env = fallgen.env.FallenObjectsEnv(tiny_dataset, rank=i, world_size=2,
                                           sensors=("pose",))
        assert set(played_by[i]) <= set(env.ids)
        env.close()


def test_a_randomised_look_is_replayed(tiny_build, tiny_dataset, tmp_path):
    """A build with ``appearance_randomization`` (generated from the tiny build's rehearsal):
    its episodes' step-0 views differ from the plain build's in colour only, and the
    environment draws each episode's own look again (its reset gives the stored view)."""
    import shutil

    import fallgen.dataset
    from fallgen.cli import main
    from fallgen.env import FallenObjectsEnv

    base, cfg = tiny_build
    out = tmp_path / "looks"
    shutil.copytree(base / "one" / "rehearsal", out / "rehearsal")
    c = tmp_path / "looks.toml"
    c.write_text(cfg.read_text().replace('frames = "first"',
                                         'frames = "first"\nappearance_randomization = true'))
    with pytest.raises(SystemExit) as done:
        main(["generate", "-c", str(c), "--out", str(out), "--workers", "1"])
    assert not done.value.code
    plain, looks = fallgen.dataset.open(tiny_dataset), fallgen.dataset.open(out)
    assert looks.ids() == plain.ids()
    e = FallenObjectsEnv(out, sensors=("rgb", "category_seg"))
    try:
        for eid in looks.ids()[:3]:
            a, b = plain.get(eid), looks.get(eid)
            assert np.array_equal(a["category_seg"], b["category_seg"])
            assert not np.array_equal(a["rgb"], b["rgb"])
            obs, _ = e.reset(options={"episode_id": eid})
            assert np.array_equal(obs["rgb"], b["rgb"])
    finally:
        e.close()


def test_environment_refuses_a_dataset_heard_with_another_head(tiny_dataset, tmp_path):
    """hrtf= names the head the agent expects: the tiny build's (the measured SADIE head) is
    accepted by name and by the same file; the spherical head and another SOFA file are
    refused in one line naming both heads."""
    from fallgen.audio.heads import PACKAGED
    from fallgen.env import FallenObjectsEnv

    for same in ("sadie_ku100", str(PACKAGED)):
        FallenObjectsEnv(tiny_dataset, hrtf=same, sensors=("pose",)).close()
    other = tmp_path / "other.sofa"
    other.write_bytes(PACKAGED.read_bytes() + b"\0")  # another file: another head
    for wrong, named in (("sphere", "sphere"), (str(other), "other.sofa:")):
        with pytest.raises(ValueError) as e:
            FallenObjectsEnv(tiny_dataset, hrtf=wrong, sensors=("pose",))
        msg = str(e.value)
        assert "\n" not in msg and "sadie_ku100:" in msg and named in msg
    with pytest.raises(ValueError, match="hrtf="):
        FallenObjectsEnv(tiny_dataset, hrtf=str(tmp_path / "missing.sofa"), sensors=("pose",))
