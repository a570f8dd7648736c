"""The learned audio module as the modular agent's goal predictor: its estimate lies in the
spawn's frame (x forward, y left), it steers the agent, ``fallgen evaluate --audio-model``
runs it end to end, and ``fallgen table`` makes both tables on the tiny build."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


@pytest.fixture(scope="module")
def memorised(tiny_dataset):
    """An audio model of every tiny episode whose place model recalls each training clip's
    place exactly (trees grown on all of them, without bootstrap): a predictor that tells
    the truth, through the adapter's own frame conversion."""
    from sklearn.ensemble import ExtraTreesRegressor

    from fallgen.dataset.reader import Dataset
    from fallgen.perception.audio_model import AudioModel, feature_matrix, place_targets

    ds = Dataset(tiny_dataset)
    rows = ds.rows()
    model = AudioModel.train(ds, rows, seed=0, trees=20)
    X = feature_matrix(ds, rows, model.features)
    place = place_targets(rows)
    Y = np.column_stack([np.cos(place[:, 0]), np.sin(place[:, 0]), np.log(place[:, 1])])
    exact = ExtraTreesRegressor(n_estimators=5, bootstrap=False, random_state=0)
    exact.fit(X[:, model.features.spatial], Y[:, :2])
    far = ExtraTreesRegressor(n_estimators=5, bootstrap=False, random_state=0).fit(X, Y[:, 2])
    return ds, rows, dataclasses.replace(model, place_model=exact, distance_model=far)


def test_the_estimate_is_the_heard_place_in_the_spawn_frame(memorised):
    from fallgen.agents.audio_goal import AudioGoalPredictor
    from fallgen.perception.audio_features import relative_place

    ds, rows, model = memorised
    top3 = AudioGoalPredictor(model, top_k=3, radius_m=0.7)
    assert top3.sensors == ("audio",) and top3.radius_m == 0.7
    assert AudioGoalPredictor(model).radius_m == model.position_error_m
    for r in rows:
        est = top3.predict({"audio": ds.arrays(r, ("audio",))["audio"]})
        az, d = relative_place(r)
        assert np.allclose(est.position, d * np.array([np.cos(az), np.sin(az)]), atol=1e-6)
        assert est.category == r["category"]  # the classifier recalls its training clips
        assert est.categories[0] == est.category and len(est.categories) == \
            min(3, len(model.category_model.classes_))
    with pytest.raises(ValueError, match="top_k"):
        AudioGoalPredictor(model, top_k=0)


def test_a_truthful_audio_estimate_leads_the_agent_to_the_object(memorised, tiny_dataset):
    """With the memorised model as its predictor, the agent with segmentation and no
    category or location oracle finds nearly every object: it goes where the clip says and
    looks for the category the clip says."""
    from fallgen.agents.audio_goal import AudioGoalPredictor
    from fallgen.agents.modular import ModularAgent
    from fallgen.env import FallenObjectsEnv
    from fallgen.evaluation.runner import play
    from fallgen.world.library import load_world

    _, _, model = memorised
    world = load_world(None)
    probe = FallenObjectsEnv(tiny_dataset, sensors=("pose",), world=world)
    labels, ids = probe.category_labels, probe.ids
    probe.close()
    agent = ModularAgent(labels, world.categories.ids("target"), oracles=("segmentation",),
                         predictor=AudioGoalPredictor(model, radius_m=0.3))
    assert "audio" in agent.sensors and "object_position" not in agent.sensors
    env = FallenObjectsEnv(tiny_dataset, sensors=agent.sensors, world=world)
    try:
        recs = [play(env, agent, i) for i in ids]
    finally:
        env.close()
    assert sum(r["success"] for r in recs) >= len(recs) - 1, [r["outcome"] for r in recs]


def _labels(tiny_dataset, world):
    from fallgen.env import FallenObjectsEnv

    probe = FallenObjectsEnv(tiny_dataset, sensors=("pose",), world=world)
    try:
        return probe.category_labels
    finally:
        probe.close()


def test_evaluate_with_an_audio_model_end_to_end(tiny_dataset, tmp_path, cli):
    model, out = tmp_path / "audio.model", tmp_path / "run"
    assert cli("audio-model", "train", str(tiny_dataset), "-o", str(model), "--trees",
               "10") == 0
    args = ("evaluate", str(tiny_dataset), "--baseline", "modular", "--oracles",
            "segmentation", "--audio-model", str(model), "--split", "all", "--workers", "1")
    assert cli(*args, "-o", str(out)) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["agent"] == "modular+audio[segmentation]" and s["n"] == 6
    recs = [json.loads(x) for x in (out / "episodes.jsonl").read_text().splitlines()]
    assert s["success"] == pytest.approx(sum(r["success"] for r in recs) / len(recs))
    # the command line played the agent the library composes: the modular agent with the
    # model file's predictor as its goal, seeded as evaluate seeds it (the same actions,
    # played here in this process); without the predictor it acts otherwise
    from fallgen.agents.audio_goal import AudioGoalPredictor
    from fallgen.agents.modular import ModularAgent
    from fallgen.env import FallenObjectsEnv
    from fallgen.evaluation.runner import play
    from fallgen.perception.audio_model import AudioModel
    from fallgen.world.library import load_world

    world = load_world(None)
    mine = ModularAgent(_labels(tiny_dataset, world), world.categories.ids("target"),
                        oracles=("segmentation",),
                        predictor=AudioGoalPredictor(AudioModel.load(model)))
    blind = ModularAgent(_labels(tiny_dataset, world), world.categories.ids("target"),
                         oracles=("segmentation",))
    env = FallenObjectsEnv(tiny_dataset, sensors=mine.sensors, world=world)
    try:
        for r in recs[:2]:
            assert play(env, mine, r["episode_id"])["actions"] == r["actions"]
        assert any(play(env, blind, r["episode_id"])["actions"] != r["actions"]
                   for r in recs[:2])
    finally:
        env.close()
    assert cli(*args, "--audio-top-k", "3", "-o", str(tmp_path / "top3")) == 0
    s3 = json.loads((tmp_path / "top3" / "summary.json").read_text())
    assert s3["agent"] == "modular+audio(top 3)[segmentation]"
    # refusals, in one line: an audio model for another agent, a file that is no model
    assert cli("evaluate", str(tiny_dataset), "--baseline", "expert", "--audio-model",
               str(model), "-o", str(tmp_path / "x")) == 2
    bad = tmp_path / "bad.model"
    bad.write_bytes(b"no model")
    assert cli("evaluate", str(tiny_dataset), "--baseline", "modular", "--audio-model",
               str(bad), "-o", str(tmp_path / "y")) == 2
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_table_on_the_tiny_build(tiny_dataset, tmp_path, cli):
    """Both tables on the tiny build (two test episodes): every row of Table 1 run and
    written, Table 2's where the tiny build has test episodes and a model of the room kind;
    the expert at 1; a rerun keeps the rows and writes the same table; the models and audio
    scores are there."""
    from fallgen.evaluation.table import rows_table1, rows_table2, subsample

    out = tmp_path / "table"
    assert cli("table", str(tiny_dataset), "-o", str(out), "--trees", "10", "--workers",
               "1", "--vision-frames", "9", "--vision-epochs", "1") == 0
    md = (out / "table.md").read_text()
    data = json.loads((out / "table.json").read_text())
    ran = set(data["results"])
    for row in rows_table1() + [r for r in rows_table2() if r.key in ran]:
        assert row.key in ran, row.key
        assert (out / "rows" / row.key / "episodes.jsonl").is_file()
        assert row.label in md
    assert data["results"]["expert"]["success"] == 1.0
    for row in rows_table2():  # a room kind's rows, where the tiny build has its episodes
        if row.key in ran:
            assert set(data["results"][row.key]["by_room_kind"]) == {row.episodes}
    assert "all_on_test" in data["audio"]
    assert (out / "audio" / "confusion_category.png").is_file()
    assert "0.93 / 0.83 / 0.80" in md  # the paper's numbers beside ours
    before = {p: p.stat().st_mtime_ns for p in (out / "rows").rglob("summary.json")}
    assert cli("table", str(tiny_dataset), "-o", str(out), "--trees", "10", "--workers",
               "1", "--vision-frames", "9", "--vision-epochs", "1") == 0
    assert {p: p.stat().st_mtime_ns for p in (out / "rows").rglob("summary.json")} == before
    assert json.loads((out / "table.json").read_text())["results"] == data["results"]
    assert "vision" in data and (out / "vision" / "strip.png").is_file()
    assert data["vision_training"]["settings"]["epochs"] == 1  # what make report prints
    assert data["results"]["objectgoal"]["agent"] == "objectgoal+vision"
    # a different audio model (more trees) is made again, and the rows that use it run again
    # (those with the visual module are left out with --no-vision: their files stay as they
    # were, and the table leaves them out)
    assert cli("table", str(tiny_dataset), "-o", str(out), "--trees", "11", "--workers",
               "1", "--no-vision") == 0
    after = {p: p.stat().st_mtime_ns for p in (out / "rows").rglob("summary.json")}
    for p, t in after.items():
        agent = json.loads(p.read_text())["agent"]
        assert (t != before[p]) == ("audio" in agent and "vision" not in agent), p
    no_vision = json.loads((out / "table.json").read_text())
    assert not {"objectgoal", "modular_av", "modular_av_obj"} & set(no_vision["results"])
    # a row made by other agent code (its summary's code digest differs) is run again
    stale = out / "rows" / "random" / "summary.json"
    summary = json.loads(stale.read_text())
    assert summary["code_digest"]
    stale.write_text(json.dumps(dict(summary, code_digest="made-by-other-code")))
    before = {p: p.stat().st_mtime_ns for p in (out / "rows").rglob("summary.json")}
    assert cli("table", str(tiny_dataset), "-o", str(out), "--trees", "11", "--workers",
               "1", "--no-vision") == 0
    after = {p: p.stat().st_mtime_ns for p in (out / "rows").rglob("summary.json")}
    assert {p for p in after if after[p] != before[p]} == {stale}
    assert json.loads(stale.read_text())["code_digest"] == summary["code_digest"]
    # the subsample: seeded, sorted, a subset; everything when asked for as many or more
    ids = list(range(100, 160))
    a = subsample(ids, 10, 0, 1)
    assert a == subsample(ids, 10, 0, 1) == sorted(a) and set(a) <= set(ids) and len(a) == 10
    assert a != subsample(ids, 10, 1, 1) and subsample(ids, 0, 0, 1) == ids
    assert cli("table", str(tmp_path / "nowhere"), "-o", str(out)) == 2
