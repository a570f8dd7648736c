"""The dataset on disk (tiny_build fixture): manifest and reader round trip, the card and its
Hugging Face configs, validate catching each corruption, stats and show."""

from __future__ import annotations

import json
import shutil
from collections import Counter

import numpy as np
import pyarrow.parquet as pq
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


def test_manifest_reader_round_trip(tiny_build):
    import h5py

    import fallgen.dataset

    base, _ = tiny_build
    root = base / "one"
    m = json.loads((root / "manifest.json").read_text())
    assert set(m["versions"]) >= {"fallgen", "mujoco", "numpy"} and m["root_seed"] == 7
    ds = fallgen.dataset.open(root)
    assert sum(m["episodes"].values()) == len(ds) == 6
    assert set(m["files"]) == {str(p.relative_to(root)) for d in ("data", "media", "rehearsal")
                               for p in (root / d).iterdir()} | {"README.md"}
    assert ds.splits == ["train", "validation", "test"]
    eps = list(ds.episodes("train"))
    assert [e["episode_id"] for e in eps] == [0, 1]
    ep = eps[0]
    assert isinstance(ep["category"], str) and ep["category_seg"].dtype == np.int16
    assert ep["audio"].shape == (2, 44100) and ep["audio"].dtype == np.float32
    assert ep["rgb"].shape == (300, 300, 3) and ep["depth"].dtype == np.float32
    assert ep["occupancy"].ndim == 2 and ep["expert_actions"][-1] == 5
    assert ds.actions[ep["expert_actions"][-1]] == "found"
    assert ep["category"] in ds.category_labels
    with h5py.File(root / ep["media_file"]) as f:  # the reader returns what was written
        assert np.array_equal(f["audio"][ep["media_index"]], ep["audio"])
        assert np.array_equal(f["category"][ep["media_index"]], ep["category_seg"])
    assert ds.get(ep["episode_id"])["event_id"] == ep["event_id"]
    study = ds.rows("test", room_kind="study")
    assert len(study) == 1 and study[0]["room_kind"] == "study"
    with pytest.raises(KeyError):
        ds.get(99)


def test_reader_index_finds_each_episode_reading_one_shard(tiny_build, monkeypatch):
    import stat

    import fallgen.dataset

    base, _ = tiny_build
    root = base / "one"
    ds = fallgen.dataset.open(root)
    rows = ds.rows()
    assert ds.ids() == [r["episode_id"] for r in rows]
    assert ds.ids("test") == [r["episode_id"] for r in rows if r["split"] == "test"]
    kitchens = [r for r in rows if r["room_kind"] == "kitchen"]
    assert ds.ids(room_kind="kitchen") == [r["episode_id"] for r in kitchens]
    cat = rows[0]["category"]
    assert ds.ids(categories=[cat]) == [r["episode_id"] for r in rows if r["category"] == cat]
    # a lookup reads the shard that holds the episode, and only it
    read = []
    real = pq.read_table
    monkeypatch.setattr(pq, "read_table", lambda p, *a, **k: read.append(p) or real(p, *a, **k))
    ds = fallgen.dataset.open(root)
    ds.index  # noqa: B018 (the index reads a few columns of every shard once)
    read.clear()
    for r in rows:
        assert ds.row(r["episode_id"]) == r
    assert sorted({str(p) for p in read}) == sorted({str(root / "data" / p.name) for p in
                                                      ds.shards})
    assert len(read) == len(ds.shards)  # each shard once: the rows are kept
    a = ds.arrays(rows[0], ("audio", "occupancy"))
    ep = ds.get(rows[0]["episode_id"])
    assert np.array_equal(a["audio"], ep["audio"]) and np.array_equal(a["occupancy"],
                                                                      ep["occupancy"])
    assert 99 not in ds and rows[0]["episode_id"] in ds
    # every file of the dataset is readable by others as the umask allows (not 0600)
    for p in list((root / "data").iterdir()) + list((root / "media").iterdir()) + \
            [root / "manifest.json", root / "README.md"]:
        assert stat.S_IMODE(p.stat().st_mode) & 0o044 == 0o644 & 0o044 & ~_umask(), p


def _umask() -> int:
    from fallgen.atomic import umask

    return umask()


def _front_matter(text: str) -> dict:
    import yaml

    assert text.startswith("---\n")
    return yaml.safe_load(text.split("---\n")[1])


def test_card_declares_the_splits_and_the_cross_scene_configs(tiny_build):
    import glob

    from fallgen.dataset.schema import COLUMNS

    base, _ = tiny_build
    root = base / "one"
    text = (root / "README.md").read_text()
    meta = _front_matter(text)
    configs = {c["config_name"]: {d["split"]: d["path"] for d in c["data_files"]}
               for c in meta["configs"]}
    assert set(configs) == {"default", "kitchen_to_study", "study_to_kitchen"}

    def files(paths) -> set[str]:
        paths = [paths] if isinstance(paths, str) else paths
        return {str(p.relative_to(root)) for g in paths for p in map(__import__("pathlib").Path,
                glob.glob(str(root / g)))}

    def kinds(paths) -> set[str]:
        return {k for f in files(paths)
                for k in pq.read_table(root / f, columns=["room_kind"]).column(0).to_pylist()}

    all_rows = {s: files(configs["default"][s]) for s in ("train", "validation", "test")}
    assert sum(len(v) for v in all_rows.values()) == len(list((root / "data").glob("*")))
    for name, (src, dst) in {"kitchen_to_study": ("kitchen", "study"),
                             "study_to_kitchen": ("study", "kitchen")}.items():
        c = configs[name]
        assert kinds(c["train"]) == kinds(c["validation"]) == {src}
        assert kinds(c["test"]) == {dst}
        assert files(c["test"]) <= all_rows["test"] and files(c["train"]) <= all_rows["train"]
    for column in COLUMNS:  # every field is explained
        assert f"`{column}`" in text
    assert "@inproceedings" in text and "kitchen_to_study" in text


def _damage(root, damage: str) -> None:
    if damage == "flip_parquet_byte":
        p = root / "data" / "train-00000-of-00002.parquet"
        b = bytearray(p.read_bytes())
        b[len(b) // 2] ^= 0x40
        p.write_bytes(bytes(b))
    elif damage == "truncate_h5":
        p = root / "media" / "train-00001-of-00002.h5"
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    elif damage == "missing_shard":
        (root / "data" / "validation-00000-of-00002.parquet").unlink()
    elif damage == "manifest_count":
        m = json.loads((root / "manifest.json").read_text())
        m["episodes"]["train"] += 1
        (root / "manifest.json").write_text(json.dumps(m))
    elif damage == "extra_file":
        shutil.copy(root / "data" / "test-00000-of-00002.parquet",
                    root / "data" / "test-00002-of-00003.parquet")
    elif damage == "missing_manifest":
        (root / "manifest.json").unlink()
    elif damage == "edited_card":
        p = root / "README.md"
        p.write_text(p.read_text().replace("kitchen_to_study", "kitchen_to_kitchen"))


@pytest.mark.parametrize("damage", ["flip_parquet_byte", "truncate_h5", "missing_shard",
                                    "manifest_count", "extra_file", "missing_manifest",
                                    "edited_card"])
def test_validate_catches_corruption(tiny_build, tmp_path, damage, cli):
    from fallgen.dataset.validate import validate

    base, _ = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    assert cli("validate", str(root)) == 0
    _damage(root, damage)
    problems = validate(root)
    assert problems, damage
    assert all("\n" not in p and str(root) in p for p in problems)
    assert cli("validate", str(root)) == 1


def test_validate_accounts_for_dropped_episodes(tiny_build, tmp_path):
    """A planned episode no event could make leaves a gap in the ids, recorded in its shard's
    metadata; validate accepts the gap only when it is recorded."""
    import pyarrow as pa

    from fallgen.dataset.card import finalize
    from fallgen.dataset.manifest import read_manifest
    from fallgen.dataset.validate import validate

    base, cfg = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    p = root / "data" / "train-00001-of-00002.parquet"  # episode 1 (study)
    t = pq.read_table(p)
    rows = t.to_pylist()
    meta = json.loads(t.schema.metadata[b"fallgen"])
    gone = rows[0]["episode_id"]
    assert gone == 1
    empty = pa.table({"episode_id": pa.array([], pa.int64())})
    m = read_manifest(root)

    def write(dropped) -> list[str]:
        meta["dropped"] = dropped
        pq.write_table(empty.replace_schema_metadata({"fallgen": json.dumps(meta)}), p)
        finalize(root, m["config"], m["root_seed"], m["settings"], build=m["build"])
        return validate(root)

    assert any("contiguous" in s for s in write([]))
    assert write([[gone, [["x", "no_path"]]]]) == []


def test_stats_counts_and_bias(tiny_build, tmp_path, cli):
    from fallgen.dataset.stats import HARD_MATERIALS, stats

    base, _ = tiny_build
    s = stats(base / "one")
    assert s["episodes"] == 6 and s["room_variants"] == 2
    assert list(s["by_split"]) == ["train", "validation", "test"]
    assert s["by_split"]["train"] == {"kitchen": 1, "study": 1}
    assert sum(s["by_category"].values()) == sum(s["by_zone_kind"].values()) == 6
    assert s["expert"]["actions"]["n"] == 6 and s["expert"]["actions"]["min"] >= 2
    rows = [r for p in sorted((base / "one" / "data").glob("*.parquet"))
            for r in pq.read_table(p).to_pylist()]
    peaks = [r["audio_peak_db_spl"] for r in rows]
    assert s["audio_db_spl"]["peak"]["p50"] == pytest.approx(float(np.percentile(peaks, 50)))
    assert sum(s["audio_db_spl"]["leq_125ms_histogram"].values()) == 6
    mats = s["audio_energy_by_material"]
    assert {k: m["episodes"] for k, m in mats.items()} == s["by_audio_material"]
    for name, m in mats.items():
        mine = [r for r in rows if r["audio_material"] == name]
        assert m["energy_ratio_p50"] == pytest.approx(
            float(np.median([r["audio_energy_ratio"] for r in mine])))
        assert m["peak_db_spl_max"] == pytest.approx(max(r["audio_peak_db_spl"] for r in mine))
    ratios = [m["energy_ratio_p50"] for m in mats.values()]
    assert ratios == sorted(ratios, reverse=True)  # the most efficient radiators first
    # each row names the surface its event's first impact struck, as the rehearsal recorded it
    from fallgen.physics.events import from_table
    events = {e.event_id: e for p in (base / "one" / "rehearsal").glob("*.parquet")
              for e in from_table(pq.read_table(p))}
    for r in rows:
        impacts = sorted((c for c in events[r["event_id"]].contacts if c.kind == "impact"),
                         key=lambda c: c.time_s)
        assert r["first_impact_surface"] == impacts[0].material_other, r["event_id"]
    hard = s["goals"]["energy_ratio_median_hard"]
    assert hard["ok"] is None and hard["n"] == sum(
        r["audio_material"] in HARD_MATERIALS and r["first_impact_surface"] in HARD_MATERIALS
        for r in rows)  # too few hard impacts in 6 episodes to judge
    rehearsed = sum(b["rehearsed_events"] for b in s["bias"].values())
    assert rehearsed == sum(pq.read_metadata(p).num_rows
                            for p in (base / "one" / "rehearsal").glob("*.parquet"))
    assert sum(b["episode_share"] for b in s["bias"].values()) == pytest.approx(1.0)
    falls = Counter(r["event_id"] for r in rows)
    assert s["distinct_falls"] == len(falls)
    assert s["episodes_sharing_a_fall"] == sum(n for n in falls.values() if n > 1)
    assert cli("stats", str(base / "one"), "--json", str(tmp_path / "s.json")) == 0
    assert json.loads((tmp_path / "s.json").read_text())["episodes"] == 6


def test_show_writes_a_picture_and_the_binaural_wav(tiny_build, tmp_path, cli):
    import cv2
    import soundfile as sf

    base, _ = tiny_build
    png, wav = tmp_path / "ep.png", tmp_path / "ep.wav"
    assert cli("show", str(base / "one"), "4", "-o", str(png), "--wav", str(wav)) == 0
    img = cv2.imread(str(png))
    assert img.shape[0] > 900 and img.shape[1] > 1100
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 1000  # pictures, not a blank canvas
    audio, rate = sf.read(wav)
    assert rate == 44100 and audio.shape == (44100, 2)
    import fallgen.dataset

    ep = fallgen.dataset.open(base / "one").get(4)
    assert np.allclose(audio.T, ep["audio"], atol=1e-7)
    assert cli("show", str(base / "one"), "99", "-o", str(png)) == 2  # one-line error
    assert cli("show", str(tmp_path), "0", "-o", str(png)) == 2


def test_shard_writer_streams_and_leaves_nothing_half_written(tmp_path):
    """Episodes go to the temporary media file as they are added; close() needs one row per
    episode and renames; abort() removes the temporary file; no final name exists before
    close()."""
    from types import SimpleNamespace

    import h5py

    from fallgen.dataset.writer import ShardWriter

    def episode(k):
        view = SimpleNamespace(rgb=np.full((4, 4, 3), k, np.uint8),
                               depth=np.full((4, 4), k, np.float32),
                               instance=np.full((4, 4), k, np.int16),
                               category=np.full((4, 4), k, np.int16))
        return SimpleNamespace(audio=SimpleNamespace(audio=np.full((2, 8), k, np.float32)),
                               view=view, grid=SimpleNamespace(occupied=np.eye(3, dtype=bool)),
                               frames=())

    w = ShardWriter(tmp_path, "train", 0, 1, ("a", "b"))
    assert [w.add(episode(k)) for k in range(3)] == [0, 1, 2]
    assert not w.media.exists() and not w.data.exists()
    with pytest.raises(ValueError):
        w.close([{"episode_id": 0}])
    w.abort()
    assert list(tmp_path.rglob("*.h5*")) == []
    w = ShardWriter(tmp_path, "train", 0, 1, ("a", "b"))
    for k in range(3):
        w.add(episode(k))
    data, media = w.close([{"episode_id": k} for k in range(3)])
    with h5py.File(media) as h5:
        assert h5["rgb"].shape == (3, 4, 4, 3) and h5["rgb"].chunks == (1, 4, 4, 3)
        assert [int(h5["audio"][k, 0, 0]) for k in range(3)] == [0, 1, 2]
        assert h5["depth"].dtype == np.float16 and sorted(h5["occupancy"]) == ["0", "1", "2"]
    assert pq.read_table(data).num_rows == 3


def test_the_build_settings_come_back_from_the_manifest(tiny_build):
    """What the environment reads to look as the dataset does (``appearance``): the
    manifest's [generate] settings; a dataset without a manifest has none."""
    import shutil

    from fallgen.dataset.reader import open_dataset

    base, _ = tiny_build
    g = open_dataset(base / "one").generate_settings()
    assert g["appearance"] is True and g["audio_s"] == 1.0
    bare = base / "no_manifest"
    shutil.copytree(base / "one" / "data", bare / "data")
    assert open_dataset(bare).generate_settings() == {}
