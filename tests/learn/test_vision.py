"""The visual perception module on the tiny build: frames with their truth, training that
repeats bit for bit, a model file that saves, loads and refuses what is not its own, scores
that count what they say, the command line end to end, and a model that memorised the tiny
build's frames as the modular agent's eyes."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

torch = pytest.importorskip("torch")

pytestmark = pytest.mark.xdist_group("tiny_build")

#: what the memorising model is trained on and with: every tiny episode's step-0 view, 4
#: views along its expert's path and 10 from near the object; ~600 crops of 64 px
MEMO_SPEC = dict(path=4, look=10, seed=0)
MEMO_TRAIN = dict(epochs=54, batch=8, crop=64, lr=0.01, focus=0.9, widths=(8, 16, 32, 64),
                  seed=0, threads=1)


@pytest.fixture(scope="module")
def store(tiny_dataset, tmp_path_factory):
    """Frames of every tiny episode (:data:`MEMO_SPEC`)."""
    from fallgen.dataset.reader import Dataset
    from fallgen.learn.frames import FrameSpec, collect
    from fallgen.world.library import load_world

    ds = Dataset(tiny_dataset)
    targets = load_world(None).categories.ids("target")
    out = tmp_path_factory.mktemp("frames") / "all"
    return ds, collect(ds, ds.rows(), out, FrameSpec(**MEMO_SPEC), targets, workers=1)


@pytest.fixture(scope="module")
def memorised(store, tmp_path_factory):
    """A small network trained on :func:`store`'s frames until it knows them; its file."""
    from fallgen.learn.frames import FrameSpec
    from fallgen.learn.vision_train import TrainSettings, train

    ds, frames = store
    model = train(ds, frames, None, TrainSettings(frames=len(frames),
                                                  spec=FrameSpec(**MEMO_SPEC), **MEMO_TRAIN))
    path = tmp_path_factory.mktemp("model") / "memorised.model"
    model.save(path)
    return model, path


def test_frames_carry_their_truth(store):
    """Each episode gives its step-0 view (the dataset's own arrays), its path views (the
    last pose first) and its look views; labels are the class table's with the fallen
    object's own pixels marked; the meta counts those pixels."""
    from fallgen.learn.frames import CLASS_MASK, TARGET_BIT, class_table

    ds, frames = store
    rows = ds.rows()
    assert len(frames) == sum(1 + min(4, len(r["expert_poses"]) - 1) + 10 for r in rows)
    classes, lut = class_table(ds.category_labels, frames.info["targets"])
    assert classes[0] == "other" and len(classes) == 32
    for r in rows:
        sel = np.flatnonzero(frames.meta["episode_id"] == r["episode_id"])
        steps = frames.meta["step"][sel]
        assert steps[0] == 0 and steps[1] == len(r["expert_poses"]) - 1
        assert (steps < 0).sum() == 10
        a = ds.arrays(r, ("rgb", "category"))
        i = sel[0]
        assert np.array_equal(frames.rgb[i], a["rgb"])
        assert np.array_equal(frames.label[i] & CLASS_MASK, lut[a["category"] + 1])
        cls = classes.index(r["category"])
        for k in sel:
            lab = np.asarray(frames.label[k])
            mine = (lab & TARGET_BIT) != 0
            assert int(mine.sum()) == frames.meta["object_pixels"][k]
            assert np.all(lab[mine] & CLASS_MASK == cls)
            assert frames.meta["object_class"][k] == cls
    # the look views face the object from near: most of them show it
    look = frames.meta["step"] < 0
    assert (frames.meta["object_pixels"][look] >= 4).mean() > 0.5


def _subset(frames, n):
    from fallgen.learn.frames import FrameStore

    return FrameStore(frames.root, frames.rgb[:n], frames.depth[:n], frames.label[:n],
                      {k: v[:n] for k, v in frames.meta.items()}, frames.info)


def test_training_repeats_bit_for_bit_and_the_model_saves_and_loads(store, tmp_path):
    from fallgen.errors import InputError
    from fallgen.learn.frames import FrameSpec
    from fallgen.learn.vision_model import VisionModel
    from fallgen.learn.vision_train import TrainSettings, train

    ds, frames = store
    few = _subset(frames, 16)
    s = TrainSettings(frames=16, spec=FrameSpec(**MEMO_SPEC), epochs=2, batch=4, crop=64,
                      widths=(8, 16, 32, 64), val_episodes=0, seed=3, threads=1)
    a = train(ds, few, None, s)
    b = train(ds, few, None, s)
    c = train(ds, few, None, dataclasses.replace(s, seed=4))
    assert a.state.keys() == b.state.keys()
    assert all(torch.equal(a.state[k], b.state[k]) for k in a.state)
    assert not all(torch.equal(a.state[k], c.state[k]) for k in a.state)
    assert len(a.meta["history"]) == 2 and a.meta["train_frames"] == 16
    # the weights moved from their initialisation: the steps were taken
    from fallgen.learn.nets import SegNet
    from fallgen.learn.runtime import init_weights

    net = SegNet(a.config)
    init_weights(net, 3)
    assert not torch.equal(net.stem.conv.weight, a.state["stem.conv.weight"])
    # predictions: the same twice, and the same from the file
    rgb, depth = np.asarray(frames.rgb[:3]), np.asarray(frames.depth[:3], np.float32)
    p = a.predict(rgb, depth)
    assert p.shape == (3, 300, 300) and p.dtype == np.uint8
    assert np.array_equal(p, a.predict(rgb, depth))
    path = a.save(tmp_path / "a.model")
    back = VisionModel.load(path)
    assert back.classes == a.classes and back.config == a.config
    assert back.manifest_sha256 == a.manifest_sha256 != ""
    assert back.meta["settings"] == s.to_dict()
    assert all(torch.equal(back.state[k], a.state[k]) for k in a.state)
    assert np.array_equal(back.predict(rgb, depth), p)
    best, lead = back.scores(rgb, depth)
    assert np.array_equal(p, np.where(lead > back.margin, best, 0).repeat(2, 1).repeat(2, 2))
    # what is not a model: one InputError naming the file
    bad = tmp_path / "bad.model"
    bad.write_bytes(b"not a model")
    for f in (bad, tmp_path / "missing.model"):
        with pytest.raises(InputError, match=str(f.name)):
            VisionModel.load(f)
    half = tmp_path / "half.model"
    half.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(InputError):
        VisionModel.load(half)
    other = tmp_path / "other.model"
    torch.save({"format": "something-else"}, other)
    with pytest.raises(InputError, match="format"):
        VisionModel.load(other)


def test_scores_count_what_they_claim(store):
    """On the frames with their labels made of 2 x 2 blocks (what a half-resolution
    prediction can draw exactly): predictions of the truth itself score IoU 1 for every
    category, find every object and raise no false alarm; predictions of nothing find none;
    the object's category painted everywhere is a false alarm in every frame where the
    object is not visible; a lead no larger than the margin is ``other``."""
    from fallgen.learn.frames import CLASS_MASK, TARGET_BIT, FrameStore
    from fallgen.learn.vision_eval import frame_scores

    _, frames = store
    half = np.asarray(frames.label)[:, ::2, ::2]
    label = half.repeat(2, 1).repeat(2, 2)
    meta = dict(frames.meta)
    meta["object_pixels"] = ((label & TARGET_BIT) != 0).sum((1, 2))
    blocks = FrameStore(frames.root, frames.rgb, frames.depth, label, meta, frames.info)
    cls = (half & CLASS_MASK).astype(np.uint8)
    lead = np.where(cls > 0, 1.0, -1.0).astype(np.float32)
    n_cls = 32
    truth = frame_scores(blocks, cls, lead, 0.0, n_cls)
    shown = (meta["object_pixels"] >= 50) & (meta["distance_m"] <= 2.0)
    hidden = meta["object_pixels"] < 4
    assert truth["found_frames"] == int(shown.sum()) > 0
    assert truth["false_alarm_frames"] == int(hidden.sum()) > 0
    assert truth["found"] == truth["found_visible"] == 1.0 and truth["false_alarms"] == 0.0
    present = np.unique(cls)
    assert truth["miou"] == 1.0 and np.all(truth["iou"][present] == 1.0)
    assert np.all(np.isnan(np.delete(truth["iou"], present)))
    assert truth["confusion"].sum() == label.size
    nothing = frame_scores(blocks, cls, -lead, 0.0, n_cls)
    assert nothing["found"] == 0.0 and nothing["miou"] == 0.0
    assert nothing["iou"][0] == (cls == 0).sum() / cls.size
    everywhere = np.broadcast_to(meta["object_class"][:, None, None], cls.shape)
    alarm = frame_scores(blocks, everywhere.astype(np.uint8), np.ones_like(lead), 0.0, n_cls)
    assert alarm["false_alarms"] == 1.0 and alarm["found"] == 1.0
    assert frame_scores(blocks, cls, lead, 1.0, n_cls)["found"] == 0.0
    # the category asked for: its own lead is the truth's where the object's class is, the
    # opposite elsewhere; painted everywhere it alarms wherever the object is hidden
    own = np.where(cls == meta["object_class"][:, None, None], 1.0, -1.0).astype(np.float32)
    asked = frame_scores(blocks, cls, lead, 0.0, n_cls, own=own, ask_margin=0.0)
    assert asked["found_asked"] == 1.0 and asked["false_alarms_asked"] == 0.0
    assert asked["found"] == truth["found"] and asked["miou"] == truth["miou"]
    loud = frame_scores(blocks, cls, lead, 0.0, n_cls, own=np.ones_like(own), ask_margin=0.0)
    assert loud["false_alarms_asked"] == 1.0
    assert frame_scores(blocks, cls, lead, 0.0, n_cls, own=own,
                        ask_margin=1.0)["found_asked"] == 0.0


def test_asking_for_categories_reads_their_own_scores(memorised, store):
    """``asked``: the best of the given classes and its lead over ``other``, whatever the
    other classes score; all the targets asked for is the plain rule."""
    from fallgen.learn.vision_model import to_input

    model, _ = memorised
    _, frames = store
    rgb, depth = np.asarray(frames.rgb[:2]), np.asarray(frames.depth[:2], np.float32)
    x = torch.from_numpy(to_input(rgb, depth)).contiguous(memory_format=torch.channels_last)
    with torch.inference_mode():
        y = model.network()(x).numpy()
    best, lead = model.scores(rgb, depth)
    every = np.arange(1, len(model.classes))
    b2, l2 = model.scores(rgb, depth, asked=every)
    assert np.array_equal(best, b2) and np.allclose(lead, l2)
    c = int(frames.meta["object_class"][0])
    b3, l3 = model.scores(rgb, depth, asked=[c])
    assert np.all(b3 == c) and np.allclose(l3, y[:, c] - y[:, 0], atol=1e-5)
    pair = [c, 1 if c != 1 else 2]
    b4, l4 = model.scores(rgb, depth, asked=np.array([pair, pair]))
    top = np.where(y[:, pair[0]] >= y[:, pair[1]], pair[0], pair[1])
    assert np.array_equal(b4, top)
    assert np.allclose(l4, np.maximum(y[:, pair[0]], y[:, pair[1]]) - y[:, 0], atol=1e-5)


def test_a_memorised_model_lets_the_modular_agent_find_nearly_every_object(memorised,
                                                                           tiny_dataset):
    """The network that memorised the tiny build's frames, as the agent's eyes (with the
    category and location oracles, so what it sees decides when it claims): nearly every
    object is found, each by a claim the detector prompted (before the last action, where
    the agent would claim anyway)."""
    from fallgen.agents.modular import ModularAgent
    from fallgen.agents.vision_detector import VisionDetector
    from fallgen.env import FallenObjectsEnv
    from fallgen.evaluation.runner import play
    from fallgen.nav.agent import MAX_ACTIONS
    from fallgen.vision.camera import world_category_labels
    from fallgen.world.library import load_world

    model, _ = memorised
    world = load_world(None)
    det = VisionDetector(model)
    assert det.sensors == ("rgb", "depth")
    agent = ModularAgent(world_category_labels(world), world.categories.ids("target"),
                         oracles=("category", "location"), detector=det)
    assert {"rgb", "depth"} <= set(agent.sensors) and "category_seg" not in agent.sensors
    env = FallenObjectsEnv(tiny_dataset, sensors=agent.sensors, world=world)
    try:
        recs = [play(env, agent, i) for i in env.ids]
    finally:
        env.close()
    found = [r for r in recs if r["success"]]
    assert len(found) >= len(recs) - 1, [(r["outcome"], r["steps"]) for r in recs]
    assert all(r["steps"] < MAX_ACTIONS - 1 for r in found)
    # the label map is in the dataset's category table, as the oracle's
    obs = {"rgb": np.zeros((300, 300, 3), np.uint8), "depth": np.ones((300, 300, 1), np.float32)}
    seg = det.segment(obs)
    assert seg.shape == (300, 300) and seg.min() >= -1
    assert set(np.unique(seg)) <= {-1} | {model.category_labels.index(c)
                                          for c in model.classes[1:]}


def test_the_command_line_trains_scores_and_plays(tiny_dataset, memorised, tmp_path, cli,
                                                  capsys):
    model = tmp_path / "v.model"
    assert cli("vision-model", "train", str(tiny_dataset), "-o", str(model), "--frames", "9",
               "--epochs", "1", "--crop", "64", "--batch", "4", "--val-episodes", "1",
               "--path-views", "1", "--look-views", "1",
               "--workers", "1", "--threads", "1", "--seed", "1") == 0
    assert model.with_suffix(".log.csv").is_file() and model.with_suffix(".curve.png").is_file()
    from fallgen.dataset.manifest import manifest_sha256
    from fallgen.learn.vision_model import VisionModel

    m = VisionModel.load(model)
    assert m.manifest_sha256 == manifest_sha256(tiny_dataset)
    assert m.meta["settings"]["seed"] == 1 and m.meta["train_episodes"] == 2
    assert m.meta["device"] == "cpu" and len(m.meta["history"]) == 1
    assert "val_found" in m.meta["history"][0]
    out = tmp_path / "eval"
    assert cli("vision-model", "eval", str(tiny_dataset), "-m", str(model), "-o", str(out),
               "--workers", "1") == 0
    s = json.loads((out / "scores.json").read_text())
    assert len(s["per_category_iou"]) == 31 and s["episodes"] == 2
    assert s["frames"] == sum(s["frames_by_kind"].values()) and s["frames_by_kind"]["step0"] == 2
    for k in ("miou", "found", "found_visible", "false_alarms",
              "inference_ms_per_frame_1_thread"):
        assert k in s
    assert (out / "confusion.png").is_file() and (out / "strip.png").is_file()
    # evaluate with the memorised model as the eyes (category and location given)
    _, memo = memorised
    run = tmp_path / "run"
    assert cli("evaluate", str(tiny_dataset), "--baseline", "modular", "--oracles",
               "category,location", "--vision-model", str(memo), "--split", "all",
               "--episodes", "1,2", "--workers", "1", "-o", str(run)) == 0
    summary = json.loads((run / "summary.json").read_text())
    assert summary["agent"] == "modular+vision[category+location]"
    assert summary["success"] == 1.0
    capsys.readouterr()
    # refusals, one line each, nothing written: not a model, another dataset's model, a
    # model beside the segmentation oracle, Object-Goal without eyes
    bad = tmp_path / "bad.model"
    bad.write_bytes(b"no model")
    alien = tmp_path / "alien.model"
    m.manifest_sha256 = "0" * 64
    m.save(alien)
    base = ("evaluate", str(tiny_dataset), "--split", "all", "--workers", "1")
    cases = [(("--baseline", "modular", "--vision-model", str(bad)), "bad.model"),
             (("--baseline", "modular", "--vision-model", str(alien)), "manifest_sha256"),
             (("--baseline", "modular", "--oracles", "segmentation", "--vision-model",
               str(model)), "--vision-model"),
             (("--baseline", "objectgoal"), "--vision-model"),
             (("--baseline", "expert", "--vision-model", str(model)), "--vision-model")]
    for k, (args, what) in enumerate(cases):
        assert cli(*base, *args, "-o", str(tmp_path / f"x{k}")) == 2, args
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and what in err, (args, err)
        assert not (tmp_path / f"x{k}").exists()
    assert cli("vision-model", "eval", str(tiny_dataset), "-m", str(alien), "-o",
               str(tmp_path / "y")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "manifest_sha256" in err


def test_fallgen_works_without_torch(tiny_dataset, tmp_path):
    """Without torch the package imports, the agents and the table load, and the vision
    commands refuse in one line saying how to install it."""
    code = f"""
import sys
sys.modules["torch"] = None   # import torch now raises ImportError
import fallgen.agents, fallgen.agents.objectgoal, fallgen.evaluation.table, fallgen.learn
import fallgen.agents.vision_detector, fallgen.cli_vision
from fallgen.cli import main
try:
    main(["vision-model", "train", {str(tiny_dataset)!r}, "-o", {str(tmp_path / 'm')!r}])
except SystemExit as e:
    print("exit", e.code)
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert r.stdout.strip().splitlines()[-1] == "exit 2", r.stdout + r.stderr
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and "fallgen[learn]" in err[0], r.stderr
