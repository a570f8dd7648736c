"""``fallgen evaluate`` and ``fallgen export-expert`` on the tiny build: the same files with 1
and 2 workers, the expert at 1.0, the random agent far below, re-scoring action files, user
agents by module:factory, the summary's contents, bad input, and the exported trajectories."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


def test_expert_scores_one_and_workers_do_not_change_the_files(tiny_dataset, tmp_path, cli, capsys):
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "expert", "-o",
               str(tmp_path / "one"), "--workers", "1") == 0
    table = capsys.readouterr().out
    assert "expert" in table and "Modular Planning" in table and "1.000" in table
    # a user agent by module:factory (the expert again), in 2 worker processes
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--agent",
               "fallgen.agents.expert:ExpertAgent", "-o", str(tmp_path / "two"),
               "--workers", "2") == 0
    a = (tmp_path / "one" / "episodes.jsonl").read_bytes()
    assert a == (tmp_path / "two" / "episodes.jsonl").read_bytes()
    recs = [json.loads(line) for line in a.decode().splitlines()]
    assert [r["episode_id"] for r in recs] == list(range(6))
    assert all(r["success"] and r["spl"] == 1.0 for r in recs)
    s = json.loads((tmp_path / "one" / "summary.json").read_text())
    assert s["success"] == s["spl"] == 1.0 and s["n"] == 6 and s["ci95"]["success"] == [1, 1]
    assert len(s["manifest_sha256"]) == 64 and s["agent"] == "expert"
    assert set(s["by_room_kind"]) == {"kitchen", "study"}
    assert sum(v["n"] for v in s["by_zone_kind"].values()) == 6
    assert s["outcomes"] == {"found": 6, "wrong_found": 0, "timeout": 0}
    # re-scoring the actions the expert took gives the same lines
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--actions",
               str(tmp_path / "one" / "episodes.jsonl"), "-o", str(tmp_path / "re"),
               "--workers", "1") == 0
    assert (tmp_path / "re" / "episodes.jsonl").read_bytes() == a


def test_random_agent_is_the_floor_and_cross_scene_selects_rooms(tiny_dataset, tmp_path, cli):
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "random", "-o",
               str(tmp_path / "r"), "--workers", "2", "--claims", "2", "--seed", "3") == 0
    s = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert s["success"] <= 0.5 and s["claims"] == 2
    again = tmp_path / "r2"
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "random", "-o",
               str(again), "--workers", "1", "--claims", "2", "--seed", "3") == 0
    assert (again / "episodes.jsonl").read_bytes() == \
        (tmp_path / "r" / "episodes.jsonl").read_bytes()
    assert cli("evaluate", str(tiny_dataset), "--cross-scene", "kitchen_to_study", "--baseline",
               "expert", "-o", str(tmp_path / "x"), "--workers", "1") == 0
    s = json.loads((tmp_path / "x" / "summary.json").read_text())
    assert list(s["by_room_kind"]) == ["study"] and s["selection"]["split"] == "test"


def test_hand_written_action_file(tiny_dataset, tmp_path, cli):
    import fallgen.dataset

    ds = fallgen.dataset.open(tiny_dataset)
    rows = ds.rows("test")
    # the expert's actions for one, a wrong claim for the other
    run = {str(rows[0]["episode_id"]): rows[0]["expert_actions"], str(rows[1]["episode_id"]): [5]}
    f = tmp_path / "run.json"
    f.write_text(json.dumps(run))
    assert cli("evaluate", str(tiny_dataset), "--actions", str(f), "-o", str(tmp_path / "o"),
               "--workers", "1") == 0
    recs = [json.loads(x) for x in (tmp_path / "o" / "episodes.jsonl").read_text().splitlines()]
    assert [r["success"] for r in recs] == [True, False]
    assert recs[1]["outcome"] == "wrong_found" and recs[1]["steps"] == 1
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["success"] == 0.5 and s["sna"] == pytest.approx(recs[0]["sna"] / 2)


@pytest.mark.parametrize("args, field", [
    (["--baseline", "expert", "-o", "{t}/o", "--episodes", "999"], "--episodes"),
    (["--agent", "no.such.module:make", "-o", "{t}/o"], "--agent"),
    (["--agent", "fallgen.agents:nothing_here", "-o", "{t}/o"], "--agent"),
    (["--baseline", "expert", "--agent", "fallgen.agents.expert:ExpertAgent", "-o", "{t}/o"],
     "--agent"),
    (["--baseline", "wizard", "-o", "{t}/o"], "--baseline"),
    (["--baseline", "modular", "--oracles", "telepathy", "-o", "{t}/o"], "--oracles"),
    (["--baseline", "expert", "--split", "holdout", "-o", "{t}/o"], "--split"),
    (["--actions", "{t}/missing.json", "-o", "{t}/o"], "actions"),
])
def test_bad_input_is_one_line_and_exit_2(tiny_dataset, tmp_path, cli, capsys, args, field):
    args = [a.format(t=tmp_path) for a in args]
    assert cli("evaluate", str(tiny_dataset), *args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and len(err.splitlines()) == 1 and field in err
    assert not (tmp_path / "o").exists()


def test_unknown_dataset_and_incomplete_action_file(tiny_dataset, tmp_path, cli, capsys):
    assert cli("evaluate", str(tmp_path / "nothing"), "--baseline", "expert", "-o",
               str(tmp_path / "o")) == 2
    assert "data/" in capsys.readouterr().err
    f = tmp_path / "part.json"
    f.write_text(json.dumps({"4": [5]}))  # the test split has two episodes
    assert cli("evaluate", str(tiny_dataset), "--actions", str(f), "--split", "test", "-o",
               str(tmp_path / "o")) == 2
    assert "no actions for episode" in capsys.readouterr().err


def test_export_expert_hdf5_and_minari(tiny_dataset, tmp_path, cli):
    import h5py

    import fallgen.dataset

    ds = fallgen.dataset.open(tiny_dataset)
    assert cli("export-expert", str(tiny_dataset), "-o", str(tmp_path / "h"), "--split", "all",
               "--sensors", "rgb,depth,pose,expert_action") == 0
    with h5py.File(tmp_path / "h" / "expert.h5") as f:
        assert sorted(int(k) for k in f["episodes"]) == ds.ids()
        for row in ds.rows():
            g = f["episodes"][str(row["episode_id"])]
            n = len(row["expert_actions"])
            assert list(g["actions"][()]) == row["expert_actions"]
            assert g["observations/rgb"].shape == (n + 1, 300, 300, 3)
            assert np.array_equal(g["observations/rgb"][0], ds.get(row["episode_id"])["rgb"])
            # the oracle saw the expert's own next action at every step
            assert list(g["observations/expert_action"][:n]) == row["expert_actions"]
            assert g["terminations"][-1] and not g["terminations"][:-1].any()
            assert g.attrs["success"] and g.attrs["category"] == row["category"]
    minari = pytest.importorskip("minari")
    assert cli("export-expert", str(tiny_dataset), "-o", str(tmp_path / "m"), "--episodes", "0,3",
               "--format", "minari", "--sensors", "rgb,pose") == 0
    import os

    os.environ["MINARI_DATASETS_PATH"] = str(tmp_path / "m")
    try:
        d = minari.load_dataset("fallgen/expert-v0")
        eps = list(d.iterate_episodes())
        assert d.total_episodes == 2
        assert list(eps[1].actions) == ds.row(3)["expert_actions"]
        assert eps[1].observations["rgb"].shape[0] == len(eps[1].actions) + 1
        assert np.array_equal(eps[0].observations["rgb"][0], ds.get(0)["rgb"])
    finally:
        del os.environ["MINARI_DATASETS_PATH"]
