"""`fallgen generate`: shards from a rehearsal (one room kind each), the same bytes whatever the
worker count, resume by shard, one-line error without a rehearsal (in the ``tiny_build``
fixture, tests/conftest.py). Killed builds: tests/pipeline/test_integrity.py."""

from __future__ import annotations

import json
import shutil

import numpy as np
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
        assert r["event_attempts"] == len(json.loads(r["skipped_events"])) + 1
        with h5py.File(base / "one" / r["media_file"]) as f:
            assert f["audio"].shape[1:] == (2, 44100)
            assert f["rgb"][r["media_index"]].shape == (300, 300, 3)
            clip = f["audio"][r["media_index"]].astype(np.float64)
        # the stored levels are the stored clip's (the fall's own; the 30 dB(A) noise floor,
        # added after, moves a fall well above it by well under 1 dB): ear pressure =
        # audio / audio_gain * 20 Pa, peak and loudest rectangular 125 ms Leq of the louder ear
        p = clip / r["audio_gain"] * 20.0
        peak = 20 * np.log10(np.abs(p).max() / 2e-5)
        win = int(0.125 * 44100)
        c = np.cumsum(np.pad(p ** 2, ((0, 0), (1, 0))), axis=1)
        leq = 10 * np.log10(((c[:, win:] - c[:, :-win]) / win).max() / 4e-10)
        if r["audio_peak_db_spl"] > 60:
            assert peak == pytest.approx(r["audio_peak_db_spl"], abs=1.0)
            assert leq == pytest.approx(r["audio_leq_db_spl"], abs=1.0)
        assert r["audio_leq_db_spl"] < r["audio_peak_db_spl"]
    by_split = {}
    for r in rows:
        by_split.setdefault(r["split"], set()).add(r["event_id"])
    assert not by_split["train"] & by_split["test"]  # no fall event in two splits
    assert not by_split["train"] & by_split["validation"]


def test_same_bytes_whatever_the_worker_count(tiny_build, digest):
    base, _ = tiny_build
    dirs = ("data", "media", ".")
    assert digest(base / "one", dirs) == digest(base / "two", dirs)


def test_resume_redoes_only_missing_shards(tiny_build, tmp_path, cli, digest, monkeypatch):
    """... and compiles ahead (unless marked done) before making it, in this process too."""
    from fallgen.pipeline import generate as G

    ahead = []
    monkeypatch.setattr(G, "compile_ahead", lambda world, cfg, out, job, note=None:
                        ahead.append(job.name))
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
    assert ahead == ["train-00001-of-00002"]


def test_a_shard_loads_only_the_events_it_can_use(tiny_build):
    """Planning reads only ids and kinds; a shard's events are its episodes' events, its
    spares and their fallbacks, loaded from their own variants' files, and equal to the full
    load's."""
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
        assert len(ids) <= len(job.episodes) * MAX_EVENT_ATTEMPTS + len(job.spares)
        assert ids <= set(b.pools[(job.split, job.room_kind)]) | set(job.spares)
        assert set(job.spares) <= ids
        loaded = load_events(cfg, out, ids)
        assert [e.event_id for e in loaded] == sorted(ids)
        assert all(e == everything[e.event_id] for e in loaded)
    assert load_events(cfg, out, set()) == []


def test_a_pool_build_compiles_ahead_once_per_version_of_the_sources(tiny_build, world,
                                                                    monkeypatch, tmp_path):
    """Before its workers start, a build compiles its functions in a process of its own and
    marks them compiled for these sources; with the mark there it does not again."""
    from fallgen import jitcache
    from fallgen.config import load_config
    from fallgen.pipeline.generate import build_plan, compile_ahead

    base, cfg_file = tiny_build
    cfg, out = load_config(cfg_file), base / "one"
    marks = []
    monkeypatch.setattr(jitcache, "done_marker",
                        lambda name: marks.append(name) or tmp_path / f".{name}")
    job = build_plan(cfg, out, world).jobs[0]
    assert compile_ahead(world, cfg, out, job) is True
    assert (tmp_path / ".compiled-ahead-generate").exists()
    assert compile_ahead(world, cfg, out, job) is False
    assert marks == ["compiled-ahead-generate"] * 2


def test_heap_given_back_only_above_the_threshold(monkeypatch):
    from fallgen.pipeline import heap

    calls = []
    monkeypatch.setattr(heap, "_MALLOC_TRIM", calls.append)
    rss = heap.resident_mb()
    assert rss > 10  # this process's resident memory, read from /proc
    assert not heap.trim_heap(above_mb=rss + 10_000) and calls == []
    assert heap.trim_heap(above_mb=0) and calls == [0]


def test_heap_trimmer_waits_for_growth_above_what_a_trim_left(monkeypatch):
    from fallgen.pipeline import heap

    rss = iter([900, 850,  # above 896: trims, leaves 850
                905, 913,  # above 896 but not 64 MB above 850: no trim
                915, 820,  # 65 MB above 850: trims, leaves 820
                890, 897, 860])  # the threshold rules again: 897 trims
    calls = []
    monkeypatch.setattr(heap, "_MALLOC_TRIM", calls.append)
    monkeypatch.setattr(heap, "resident_mb", lambda: next(rss))
    t = heap.HeapTrimmer(above_mb=896, hysteresis_mb=64)
    assert [t() for _ in range(6)] == [True, False, False, True, False, True]
    assert t.trims == len(calls) == 3 and t.left_mb == 860


def test_a_shard_is_kept_only_as_it_was_written_by_the_same_inputs(tmp_path):
    """A shard's state against a stamp (what the build would make it from): missing, ok,
    stale (another fingerprint: which input differs is said), corrupt (its bytes changed, a
    file gone, no write record: e.g. a shard of another fallgen with other columns)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from fallgen.dataset.integrity import Stamp, record_path, shard_state
    from fallgen.dataset.schema import COLUMNS
    from fallgen.dataset.writer import ShardWriter

    base = {"build": "b", "config.generate.audio_s": 2.0, "code.nav": "n1"}
    stamp = Stamp(base)
    name = "train-00000-of-00001"
    assert shard_state(tmp_path, name, stamp).status == "missing"
    w = ShardWriter(tmp_path, "train", 0, 1, ("floor",), stamp)
    w.close([], [[0, [["e0", "inaudible"]]]])  # every episode dropped: still a shard
    assert shard_state(tmp_path, name, stamp).ok
    st = shard_state(tmp_path, name, Stamp({**base, "config.generate.audio_s": 1.0,
                                            "code.nav": "n2"}))
    assert st.status == "stale" and "config.generate.audio_s 2.0 -> 1.0" in st.reason
    assert "the code of fallgen.nav" in st.reason
    data = tmp_path / "data" / f"{name}.parquet"
    meta = pq.read_schema(data).metadata
    pq.write_table(pa.table({c: [] for c in list(COLUMNS)[:-1]}).replace_schema_metadata(meta),
                   data)
    st = shard_state(tmp_path, name, stamp)
    assert st.status == "corrupt" and f"data/{name}.parquet is " in st.reason  # its size
    record_path(tmp_path, name).unlink()
    assert shard_state(tmp_path, name, stamp).reason == "no record of what was written"
    (tmp_path / "media" / f"{name}.h5").unlink()
    data.unlink()
    assert shard_state(tmp_path, name, stamp).status == "missing"


def test_a_shard_accounts_for_the_time_of_attempts_given_up(tiny_build, tmp_path):
    """Every attempt's time is in the shard's timings: an episode whose events are all given
    up (here each after 1 s of planning, by its Skip's account) adds its attempts' seconds
    under ``skipped:<stage>``, and the episode is dropped."""
    from fallgen.config import load_config
    from fallgen.pipeline.episode import Skip
    from fallgen.pipeline.generate import build_plan, job_event_ids, load_events, make_shard

    base, cfg_file = tiny_build
    cfg, out = load_config(cfg_file), base / "one"
    b = build_plan(cfg, out)
    job = b.jobs[0]
    events = {e.event_id: e for e in load_events(cfg, out, job_event_ids(job, b.pools))}

    class GivesUp:
        labels = ("a",)
        calls = 0
        kept: set[str] = set()

        def retain_rooms(self, variant_ids):
            self.kept = set(variant_ids)

        def make(self, *args, **kwargs):
            self.calls += 1
            s = Skip("no_path", "test")
            s.timings_s = {"maps": 0.25, "planning": 1.0}
            raise s

    maker = GivesUp()
    res = make_shard(None, maker, cfg, job, events, b.pools, tmp_path, trim=lambda: False)
    assert res.episodes == 0 and res.skips["no_path"] == maker.calls > 0
    # the worker was told to keep only the rooms of the shard's events
    assert maker.kept == {e.room_variant for e in events.values()}
    assert res.skips["episode_dropped"] == len(job.episodes)
    assert dict(res.timings_s) == pytest.approx(
        {"skipped:maps": 0.25 * maker.calls, "skipped:planning": 1.0 * maker.calls})


def test_an_episode_whose_event_is_given_up_takes_its_shards_spares_first(tmp_path):
    """An episode whose event cannot be used tries its shard's spare events (those no episode
    plans) before the events planned for other episodes, and a spare tried is used up: a
    later episode does not try it again."""
    from types import SimpleNamespace

    from fallgen.pipeline.episode import Skip
    from fallgen.pipeline.generate import MAX_EVENT_ATTEMPTS, make_shard, shard_jobs
    from fallgen.pipeline.plan import plan, pools_of, spare_events

    events = [SimpleNamespace(event_id=f"k{i:03d}", room_kind="kitchen", room_variant="v")
              for i in range(20)]
    planned = plan(events, (4, 0, 0), root_seed=1)
    jobs = shard_jobs(planned, 4, spare_events(events, (4, 0, 0), 1))
    assert len(jobs) == 1
    job, pools = jobs[0], pools_of(planned)
    spares = list(job.spares)
    assert len(spares) == 16

    class GivesUp:
        labels = ("a",)
        asked: list[tuple[int, str]] = []

        def retain_rooms(self, variant_ids):
            pass

        def make(self, episode_id, event, *args, **kwargs):
            self.asked.append((episode_id, event.event_id))
            raise Skip("no_path", "test")

    maker = GivesUp()
    cfg = SimpleNamespace(root_seed=1, generate=SimpleNamespace(frames="first"))
    make_shard(None, maker, cfg, job, {e.event_id: e for e in events}, pools, tmp_path,
               trim=lambda: False)
    by_episode = [[e for i, e in maker.asked if i == p.episode_id] for p in job.episodes]
    own = [p.event_id for p in job.episodes]
    # the first takes its own event, then the first nine spares; the second its own, then the
    # last seven spares (none drawn and left untried), then the events planned after its own;
    # the others have no spare left
    assert by_episode[0] == [own[0], *spares[:MAX_EVENT_ATTEMPTS - 1]]
    assert by_episode[1][:8] == [own[1], *spares[MAX_EVENT_ATTEMPTS - 1:]]
    assert by_episode[1][8:] == [own[2], own[3]]
    assert by_episode[2] == [own[2], own[3], own[0], own[1]]
    assert all(len(t) == len(set(t)) for t in by_episode)


def test_shards_are_made_one_room_kind_after_the_other(tiny_build, world, tmp_path,
                                                       monkeypatch):
    """The plan lists each split's kinds in turn; a build makes all of one kind's shards
    before the other's (a worker keeps its rooms only for the kind it is on), each kind's in
    the plan's order."""
    from fallgen.config import load_config
    from fallgen.pipeline import generate as G

    base, cfg_file = tiny_build
    cfg, root = load_config(cfg_file), tmp_path / "ds"
    shutil.copytree(base / "one" / "rehearsal", root / "rehearsal")
    made = []
    monkeypatch.setattr(G, "compile_ahead", lambda *a, **k: False)
    monkeypatch.setattr(G, "_make_job", lambda world, maker, cfg, job, *a: made.append(job)
                        or G.ShardResult(job.name, 0))
    G.generate(world, cfg, root, workers=1)
    planned = G.build_plan(cfg, root, world).jobs
    kinds = [j.room_kind for j in planned]
    assert kinds != sorted(kinds) and len(set(kinds)) == 2  # interleaved in the plan
    assert [j.room_kind for j in made] == sorted(kinds)
    assert made == G.making_order(planned) == sorted(planned, key=lambda j: j.room_kind)
