"""The Minari export (fallgen export-expert --format minari) on the tiny build: the same
observations as the HDF5 export, compressed, the step-0 clip stored once, the measures in
``infos``, a relative dataset path in the recovered environment, made whole or not at all."""

from __future__ import annotations

import json
import math
import os
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

SENSORS = "rgb,depth,audio,pose"
ID = "fallgen/expert-v0"


@pytest.fixture
def minari_path(monkeypatch):
    """Set MINARI_DATASETS_PATH for the duration of a test."""
    def use(path):
        monkeypatch.setenv("MINARI_DATASETS_PATH", str(path))
    return use


@pytest.fixture(scope="module")
def exports(tiny_dataset, tmp_path_factory):
    """Both exports of every episode, the dataset given as a path relative to the directory
    the export runs in."""
    pytest.importorskip("minari")
    from fallgen.cli import main

    base = tmp_path_factory.mktemp("exports")
    cwd = os.getcwd()
    os.chdir(tiny_dataset.parent)
    try:
        for fmt, out in (("hdf5", base / "h"), ("minari", base / "m")):
            with pytest.raises(SystemExit) as done:
                main(["export-expert", tiny_dataset.name, "-o", str(out), "--split", "all",
                      "--sensors", SENSORS, "--format", fmt])
            assert not done.value.code
    finally:
        os.chdir(cwd)
    return base


def _main_file(root):
    (f,) = (root / ID / "data").glob("*.hdf5")
    return f


def test_minari_holds_the_hdf5_exports_observations_and_measures(exports, tiny_dataset,
                                                                 minari_path):
    import h5py
    import minari

    import fallgen.dataset

    ds = fallgen.dataset.open(tiny_dataset)
    minari_path(exports / "m")
    d = minari.load_dataset(ID)
    assert d.total_episodes == len(ds.ids())
    with h5py.File(exports / "h" / "expert.h5") as h:
        for ep, eid in zip(d.iterate_episodes(), ds.ids()):
            g = h["episodes"][str(eid)]
            n = len(ds.row(eid)["expert_actions"])
            assert list(ep.actions) == list(g["actions"][()]) == ds.row(eid)["expert_actions"]
            for k in SENSORS.split(","):
                assert np.array_equal(ep.observations[k], g["observations"][k][()]), k
            # the clip at step 0 (the dataset's own), zeros after
            assert np.array_equal(ep.observations["audio"][0], ds.get(eid)["audio"])
            assert not ep.observations["audio"][1:].any()
            info = ep.infos
            assert list(info["episode_id"]) == [eid] * (n + 1)
            assert list(info["step"]) == list(range(n + 1))
            for k in ("success", "spl", "sna", "soft_spl", "path_length_m", "fewest_actions",
                      "claims"):
                assert info[k][-1] == pytest.approx(g.attrs[k]), k
            assert info["success"][-1] and not info["success"][:-1].any()
            assert all(math.isnan(x) for x in info["spl"][:-1])
            assert info["outcome"][-1] in (b"found", "found")
    meta = list(d.storage.get_episode_metadata(range(d.total_episodes)))
    assert [m["episode_id"] for m in meta] == ds.ids()
    assert [m["category"] for m in meta] == [ds.row(i)["category"] for i in ds.ids()]


def test_minari_is_compressed_and_stores_the_clip_once(exports):
    """At most twice the HDF5 export's bytes; the audio of an episode holds one allocated
    chunk (step 0) whatever its length, the images one per step."""
    import h5py

    m, h = _main_file(exports / "m").stat().st_size, (exports / "h" / "expert.h5").stat().st_size
    assert m <= 2 * h, (m, h)
    with h5py.File(_main_file(exports / "m")) as f:
        for name, g in f.items():
            audio, rgb = g["observations/audio"], g["observations/rgb"]
            assert audio.compression == "gzip" and audio.shape[0] > 2
            assert audio.id.get_num_chunks() == 1
            assert rgb.id.get_num_chunks() == rgb.shape[0]
    meta = json.loads((exports / "m" / ID / "data" / "metadata.json").read_text())
    assert meta["total_episodes"] == 6 and meta["jpeg_encoding"] is False


def test_recovered_environment_opens_the_dataset_by_its_relative_path(exports, tiny_dataset,
                                                                      minari_path, monkeypatch):
    import minari

    import fallgen.dataset

    minari_path(exports / "m")
    d = minari.load_dataset(ID)
    spec = json.loads((exports / "m" / ID / "data" / "metadata.json").read_text())["env_spec"]
    assert json.loads(spec)["kwargs"]["dataset"] == tiny_dataset.name  # as given: relative
    monkeypatch.chdir(tiny_dataset.parent)
    env = d.recover_environment()
    try:
        assert env.spec.max_episode_steps == 200
        eid = fallgen.dataset.open(tiny_dataset).ids()[0]
        obs, _ = env.reset(options={"episode_id": eid})
        ep = next(d.iterate_episodes([0]))
        assert np.array_equal(obs["rgb"], ep.observations["rgb"][0])
    finally:
        env.close()


def test_a_failed_export_leaves_nothing_and_the_retry_succeeds(tiny_dataset, tmp_path,
                                                              minari_path):
    """An export that fails after its first episode leaves no dataset and no temporary
    directory; the same export again makes the whole dataset."""
    pytest.importorskip("minari")
    import minari

    from fallgen.evaluation.trajectories import export_expert

    out = tmp_path / "m"
    calls = []

    def fail_second(n):
        calls.append(n)
        if len(calls) == 2:
            raise RuntimeError("killed")

    with pytest.raises(RuntimeError, match="killed"):
        export_expert(tiny_dataset, out, [0, 1, 2], ("pose",), "minari", ID,
                      progress=fail_second)
    assert list(out.iterdir()) == []
    export_expert(tiny_dataset, out, [0, 1, 2], ("pose",), "minari", ID)
    assert sorted(p.name for p in out.iterdir()) == ["fallgen"]
    minari_path(out)
    assert minari.load_dataset(ID).total_episodes == 3


def test_minari_refusals_are_one_line(tiny_dataset, tmp_path, cli, capsys, monkeypatch):
    """An existing dataset id, a malformed id and a missing Pillow: one line naming the
    option, exit 2, nothing written (the existing dataset untouched)."""
    pytest.importorskip("minari")
    out = tmp_path / "m"
    args = ["export-expert", str(tiny_dataset), "-o", str(out), "--episodes", "0",
            "--sensors", "pose", "--format", "minari"]
    assert cli(*args) == 0
    before = sorted(str(p.relative_to(out)) for p in out.rglob("*"))
    capsys.readouterr()
    assert cli(*args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "--dataset-id" in err and "\n" not in err
    assert "expert_actions" not in err
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == before
    assert cli(*args, "--dataset-id", "no version") == 2
    assert "--dataset-id" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "PIL", None)  # import PIL now fails
    assert cli(*args[:3], str(tmp_path / "n"), *args[4:]) == 2
    err = capsys.readouterr().err
    assert "pillow" in err and "fallgen[minari]" in err and "Traceback" not in err
    assert not (tmp_path / "n").exists()
