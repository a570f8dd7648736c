"""`fallgen generate`: shards from a rehearsal, the same bytes whatever the worker count, resume
by shard, one-line error without a rehearsal."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

from fallgen.cli import main

CONFIG = """
[build]
root_seed = 7
out = "{out}"

[rehearse]
rooms = "kitchen_galley-l1-m1"
zones = "z0[0-5]"
events_per_zone = 1
max_trials_per_zone = 4
drop_height_m = [1.5, 2.8]
push_speed_mps = 0.15
spin_radps = 2.0
settle_lin_mps = 0.01
settle_ang_radps = 0.1
settle_hold_s = 0.25
timeout_s = 6.0

[generate]
episodes = {{ train = 3, validation = 1, test = 1 }}
frames = "first"
hrtf = ""
audio_s = 1.0
image_source_order = 3
episodes_per_shard = 2
"""


def _run(*args) -> int:
    try:
        main(list(args))
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def _digest(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for d in ("data", "media") for p in sorted((root / d).glob("*"))}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    import os

    base = tmp_path_factory.mktemp("gen")
    os.environ.setdefault("FALLGEN_CACHE", str(base / "cache"))
    cfg = base / "tiny.toml"
    cfg.write_text(CONFIG.format(out=base / "one"))
    assert _run("generate", "-c", str(cfg)) == 2  # no rehearsal yet: one-line error
    assert _run("rehearse", "-c", str(cfg)) == 0
    shutil.copytree(base / "one" / "rehearsal", base / "two" / "rehearsal")
    assert _run("generate", "-c", str(cfg)) == 0
    assert _run("generate", "-c", str(cfg), "--out", str(base / "two"), "--workers", "2") == 0
    return base, cfg


def test_shards_rows_and_media(built):
    import h5py
    import pyarrow.parquet as pq

    base, _ = built
    names = sorted(p.name for p in (base / "one" / "data").glob("*.parquet"))
    assert names == ["test-00000-of-00001.parquet", "train-00000-of-00002.parquet",
                     "train-00001-of-00002.parquet", "validation-00000-of-00001.parquet"]
    rows = [r for n in names for r in pq.read_table(base / "one" / "data" / n).to_pylist()]
    assert sorted(r["episode_id"] for r in rows) == list(range(len(rows)))
    assert len(rows) >= 4
    for r in rows:
        assert r["expert_spl"] == pytest.approx(1.0) and r["expert_actions"][-1] == 5
        with h5py.File(base / "one" / r["media_file"]) as f:
            assert f["audio"].shape[1:] == (2, 44100)
            assert f["rgb"][r["media_index"]].shape == (300, 300, 3)
    train = {r["event_id"] for r in rows if r["split"] == "train"}
    test = {r["event_id"] for r in rows if r["split"] == "test"}
    assert not train & test  # no fall event in two splits


def test_same_bytes_whatever_the_worker_count(built):
    base, _ = built
    assert _digest(base / "one") == _digest(base / "two")


def test_resume_redoes_only_missing_shards(built):
    base, cfg = built
    before = _digest(base / "one")
    victim = base / "one" / "data" / "train-00001-of-00002.parquet"
    victim.unlink()
    keep = base / "one" / "data" / "train-00000-of-00002.parquet"
    mtime = keep.stat().st_mtime_ns
    assert _run("generate", "-c", str(cfg)) == 0
    assert victim.exists() and keep.stat().st_mtime_ns == mtime
    assert _digest(base / "one") == before


def test_manifest_reader_round_trip(built):
    import json

    import h5py
    import numpy as np

    import fallgen.dataset

    base, _ = built
    root = base / "one"
    m = json.loads((root / "manifest.json").read_text())
    assert set(m["versions"]) >= {"fallgen", "mujoco", "numpy"} and m["root_seed"] == 7
    assert sum(m["episodes"].values()) == len(fallgen.dataset.open(root))
    assert all(k.startswith(("data/", "media/", "rehearsal/")) for k in m["files"])
    ds = fallgen.dataset.open(root)
    assert ds.splits == ["train", "validation", "test"]
    eps = list(ds.episodes("train"))
    assert [e["episode_id"] for e in eps] == sorted(e["episode_id"] for e in eps)
    ep = eps[0]
    assert ep["audio"].shape == (2, 44100) and ep["audio"].dtype == np.float32
    assert ep["rgb"].shape == (300, 300, 3) and ep["depth"].dtype == np.float32
    assert ep["occupancy"].ndim == 2 and ep["expert_actions"][-1] == 5
    with h5py.File(root / ep["media_file"]) as f:  # the reader returns what was written
        assert np.array_equal(f["audio"][ep["media_index"]], ep["audio"])
    assert ds.get(ep["episode_id"])["event_id"] == ep["event_id"]


@pytest.mark.parametrize("damage", ["flip_parquet_byte", "truncate_h5", "missing_shard",
                                    "manifest_count", "extra_file"])
def test_validate_catches_corruption(built, tmp_path, damage):
    import json

    base, _ = built
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    assert _run("validate", str(root)) == 0
    if damage == "flip_parquet_byte":
        p = root / "data" / "train-00000-of-00002.parquet"
        b = bytearray(p.read_bytes())
        b[len(b) // 2] ^= 0x40
        p.write_bytes(bytes(b))
    elif damage == "truncate_h5":
        p = root / "media" / "train-00001-of-00002.h5"
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    elif damage == "missing_shard":
        (root / "data" / "validation-00000-of-00001.parquet").unlink()
    elif damage == "manifest_count":
        m = json.loads((root / "manifest.json").read_text())
        m["episodes"]["train"] += 1
        (root / "manifest.json").write_text(json.dumps(m))
    elif damage == "extra_file":
        shutil.copy(root / "data" / "test-00000-of-00001.parquet",
                    root / "data" / "test-00001-of-00002.parquet")
    from fallgen.dataset.validate import validate

    problems = validate(root)
    assert problems, damage
    assert all("\n" not in p for p in problems)
    assert _run("validate", str(root)) == 1
