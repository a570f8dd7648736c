"""`fallgen generate`: shards from a rehearsal (one room kind each), the same bytes whatever the
worker count, resume by shard and after kill -9, one-line error without a rehearsal (in the
``tiny_build`` fixture, tests/conftest.py)."""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


def test_shards_rows_and_media(tiny_build):
    import h5py
    import pyarrow.parquet as pq

    from fallgen.dataset.schema import COLUMNS

    base, _ = tiny_build
    names = sorted(p.name for p in (base / "one" / "data").glob("*.parquet"))
    assert names == [f"{s}-0000{i}-of-00002.parquet" for s in ("test", "train", "validation")
                     for i in (0, 1)]
    rows = [r for n in names for r in pq.read_table(base / "one" / "data" / n).to_pylist()]
    assert sorted(r["episode_id"] for r in rows) == list(range(len(rows)))
    assert len(rows) == 6 and all(list(r) == list(COLUMNS) for r in rows)
    for n in names:  # one room kind per shard, kitchens first
        kinds = {r["room_kind"] for r in pq.read_table(base / "one" / "data" / n).to_pylist()}
        assert kinds == ({"kitchen"} if "-00000-" in n else {"study"})
    for r in rows:
        assert r["expert_spl"] == pytest.approx(1.0) and r["expert_actions"][-1] == 5
        poses = r["expert_poses"]
        assert len(poses) == len(r["expert_actions"]) + 1
        assert poses[0] == [r["spawn_x"], r["spawn_y"], r["spawn_heading"], 0.0]
        assert poses[-1] == pytest.approx([r["goal_x"], r["goal_y"], r["goal_heading"],
                                          r["goal_tilt_deg"]], abs=1e-9)
        assert 30 < r["audio_leq_db_spl"] < r["audio_peak_db_spl"] < 140
        assert r["event_attempts"] == len(json.loads(r["skipped_events"])) + 1
        with h5py.File(base / "one" / r["media_file"]) as f:
            assert f["audio"].shape[1:] == (2, 44100)
            assert f["rgb"][r["media_index"]].shape == (300, 300, 3)
    by_split = {}
    for r in rows:
        by_split.setdefault(r["split"], set()).add(r["event_id"])
    assert not by_split["train"] & by_split["test"]  # no fall event in two splits
    assert not by_split["train"] & by_split["validation"]


def test_same_bytes_whatever_the_worker_count(tiny_build, digest):
    base, _ = tiny_build
    dirs = ("data", "media", ".")
    assert digest(base / "one", dirs) == digest(base / "two", dirs)


def test_resume_redoes_only_missing_shards(tiny_build, tmp_path, cli, digest):
    base, cfg = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    before = digest(root)
    victim = root / "data" / "train-00001-of-00002.parquet"
    victim.unlink()
    keep = root / "data" / "train-00000-of-00002.parquet"
    mtime = keep.stat().st_mtime_ns
    assert cli("generate", "-c", str(cfg), "--out", str(root)) == 0
    assert victim.exists() and keep.stat().st_mtime_ns == mtime
    assert digest(root) == before


def _final_files_whole(root: Path) -> None:
    """Every file under a final name is complete: Parquet readable, HDF5 openable."""
    import h5py
    import pyarrow.parquet as pq

    for p in (root / "data").glob("*.parquet"):
        pq.read_table(p)
        assert (root / "media" / p.name.replace(".parquet", ".h5")).exists()
    for p in (root / "media").glob("*.h5"):
        with h5py.File(p, "r") as f:
            assert "audio" in f


def test_kill_9_at_random_points_then_resume_gives_the_same_bytes(tiny_build, tmp_path, cli,
                                                                  digest):
    """A real `fallgen generate` process is killed (SIGKILL) at random moments, three times;
    after each kill nothing partial sits under a final name, and rerunning the same command
    finishes the build with the bytes of an uninterrupted one."""
    base, cfg = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one" / "rehearsal", root / "rehearsal")
    cmd = [sys.executable, "-m", "fallgen", "generate", "-c", str(cfg), "--out", str(root)]
    env = dict(os.environ)  # the fixture's warm modal cache
    rng = random.Random()
    delays = []
    for _ in range(3):
        delay = rng.uniform(1.0, 8.0)
        delays.append(round(delay, 2))
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
        time.sleep(delay)
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        _final_files_whole(root)
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert done.returncode == 0, (delays, done.stderr[-2000:])
    dirs = ("data", "media", ".")
    assert digest(root, dirs) == digest(base / "one", dirs), f"killed after {delays} s"
    assert cli("validate", str(root)) == 0


def test_a_shard_loads_only_the_events_it_can_use(tiny_build):
    """Planning reads only ids and kinds; a shard's events are its episodes' events and their
    fallbacks, loaded from their own variants' files, and equal to the full load's."""
    from fallgen.pipeline.generate import (MAX_EVENT_ATTEMPTS, build_plan, event_refs,
                                           job_event_ids, load_events)

    from fallgen.config import load_config

    base, cfg_file = tiny_build
    cfg, out = load_config(cfg_file), base / "one"
    everything = {e.event_id: e for e in load_events(cfg, out)}
    refs = event_refs(cfg, out)
    assert [r.event_id for r in refs] == sorted(everything)
    assert all(everything[r.event_id].room_kind == r.room_kind for r in refs)
    b = build_plan(cfg, out)
    for job in b.jobs:
        ids = job_event_ids(job, b.pools)
        assert {p.event_id for p in job.episodes} <= ids
        assert len(ids) <= len(job.episodes) * MAX_EVENT_ATTEMPTS
        assert all(i in b.pools[(job.split, job.room_kind)] for i in ids)
        loaded = load_events(cfg, out, ids)
        assert [e.event_id for e in loaded] == sorted(ids)
        assert all(e == everything[e.event_id] for e in loaded)
    assert load_events(cfg, out, set()) == []


def test_heap_given_back_only_above_the_threshold(monkeypatch):
    from fallgen.pipeline import generate as G

    calls = []
    monkeypatch.setattr(G, "_MALLOC_TRIM", calls.append)
    rss = G._resident_mb()
    assert rss > 10  # this process's resident memory, read from /proc
    assert not G._trim_heap(above_mb=rss + 10_000) and calls == []
    assert G._trim_heap(above_mb=0) and calls == [0]


def test_heap_trimmer_waits_for_growth_above_what_a_trim_left(monkeypatch):
    from fallgen.pipeline import generate as G

    rss = iter([900, 850,  # above 896: trims, leaves 850
                905, 913,  # above 896 but not 64 MB above 850: no trim
                915, 820,  # 65 MB above 850: trims, leaves 820
                890, 897, 860])  # the threshold rules again: 897 trims
    calls = []
    monkeypatch.setattr(G, "_MALLOC_TRIM", calls.append)
    monkeypatch.setattr(G, "_resident_mb", lambda: next(rss))
    t = G.HeapTrimmer(above_mb=896, hysteresis_mb=64)
    assert [t() for _ in range(6)] == [True, False, False, True, False, True]
    assert t.trims == len(calls) == 3 and t.left_mb == 860


def test_resuming_into_another_versions_shards_is_an_error(tmp_path):
    """A shard whose rows have other columns (made by another fallgen) is not kept as done:
    resuming would mix two versions' episodes; one line naming the file and 'columns'."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from fallgen.dataset.schema import COLUMNS
    from fallgen.errors import InputError
    from fallgen.pipeline.generate import ShardJob

    job = ShardJob("train", 0, 1, "kitchen", ())
    assert not job.done(tmp_path)
    (tmp_path / "data").mkdir()
    path = tmp_path / "data" / f"{job.name}.parquet"
    pq.write_table(pa.table({c: [] for c in list(COLUMNS)[:-1]}), path)
    with pytest.raises(InputError, match="columns") as e:
        job.done(tmp_path)
    assert str(path) in str(e.value) and "\n" not in str(e.value)
    pq.write_table(pa.table({c: pa.array([], pa.null()) for c in COLUMNS}), path)
    assert job.done(tmp_path)
    # a shard whose every episode was dropped, as ShardWriter writes it, is done too (the
    # check refused it, so a build with such a shard could not finish)
    from fallgen.dataset.writer import ShardWriter

    path.unlink()
    w = ShardWriter(tmp_path, "train", 0, 1, ("floor",))
    w.close([], [[0, [["e0", "inaudible"]]]])
    assert job.done(tmp_path)
