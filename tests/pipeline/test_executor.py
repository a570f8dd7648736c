"""Executors and multi-machine builds: the same bytes from a local pool, from Ray and from
separate --shard-index runs finished by `fallgen finalize`."""

from __future__ import annotations

import shutil

import pytest

from fallgen.pipeline.executor import parallel_map, select_units


def test_select_units_round_robin():
    units = list(range(10))
    parts = [select_units(units, i, 3) for i in range(3)]
    assert parts == [[0, 3, 6, 9], [1, 4, 7], [2, 5, 8]]
    assert sorted(sum(parts, [])) == units
    assert select_units(units, None, None) == units
    with pytest.raises(ValueError):
        select_units(units, 3, 3)


def _square(x: int) -> int:
    return x * x + _OFFSET["v"]


_OFFSET = {"v": 0}


def _set_offset(v: int) -> None:
    _OFFSET["v"] = v


def test_local_pool_runs_init_once_per_worker_and_keeps_order():
    assert list(parallel_map(_square, [1, 2, 3], _set_offset, (10,), workers=2)) == [11, 14, 19]
    with pytest.raises(ValueError, match="unknown executor"):
        list(parallel_map(_square, [1], _set_offset, (0,), 1, executor="dask"))


def _refuse(x: int) -> int:
    from fallgen.errors import InputError

    raise InputError(f"file{x}.sofa", "Data.IR", "not two ears")


def test_a_workers_input_error_reaches_the_parent_whole():
    """An InputError raised in a worker is the parent's one-line error, not a TypeError from
    rebuilding it (a missing HRTF file with 2 workers ended in a traceback)."""
    from fallgen.errors import InputError

    with pytest.raises(InputError) as e:
        list(parallel_map(_refuse, [3], _set_offset, (0,), workers=1))
    assert str(e.value) == "file3.sofa: Data.IR: not two ears"


@pytest.mark.xdist_group("tiny_build")
def test_shard_index_runs_then_finalize_give_the_same_bytes(tiny_build, tmp_path, cli, digest):
    base, cfg = tiny_build
    root = tmp_path / "multi"
    # rehearsal split over two "array tasks" (one room variant each)
    for i in (0, 1):
        assert cli("rehearse", "-c", str(cfg), "--out", str(root), "--workers", "1",
                   "--shard-index", str(i), "--num-shards", "2") == 0
        assert len(list((root / "rehearsal").glob("*.parquet"))) == i + 1
    assert digest(root, ("rehearsal",)) == digest(base / "one", ("rehearsal",))
    # generation over three tasks; the manifest appears only with the last shard
    for i in (0, 1, 2):
        assert not (root / "manifest.json").exists()
        assert cli("finalize", "-c", str(cfg), "--out", str(root)) == 2  # shards missing
        assert cli("generate", "-c", str(cfg), "--out", str(root), "--workers", "1",
                   "--shard-index", str(i), "--num-shards", "3") == 0
    assert cli("finalize", "-c", str(cfg), "--out", str(root)) == 0
    dirs = ("data", "media", "rehearsal", ".")
    assert digest(root, dirs) == digest(base / "one", dirs)
    assert cli("generate", "-c", str(cfg), "--shard-index", "3", "--num-shards", "3") == 2


@pytest.mark.xdist_group("tiny_build")
def test_ray_executor_gives_the_same_bytes(tiny_build, tmp_path, cli, digest):
    pytest.importorskip("ray")
    base, cfg = tiny_build
    root = tmp_path / "ray"
    shutil.copytree(base / "one" / "rehearsal", root / "rehearsal")
    assert cli("generate", "-c", str(cfg), "--out", str(root), "--executor", "ray",
               "--workers", "2") == 0
    dirs = ("data", "media", ".")
    assert digest(root, dirs) == digest(base / "one", dirs)


def _usage_after(mb: int):
    import numpy as np

    from fallgen.pipeline.executor import process_usage

    block = np.ones(mb * 2 ** 20 // 8)  # touched: resident
    assert block.sum() > 0
    return process_usage()


def test_process_usage_reports_each_workers_peak_memory():
    """Each unit's result carries its process's usage; per_process keeps every worker's last
    report, and a worker that held 200 MB once reports a peak above that ever after."""
    import os

    from fallgen.pipeline.executor import ProcessUsage, per_process, process_usage

    me = process_usage()
    # against the kernel's own counts: VmHWM (kB) in /proc, CPU seconds from os.times()
    hwm = next(int(line.split()[1]) for line in open("/proc/self/status")
               if line.startswith("VmHWM:")) / 1024
    t = os.times()
    assert me.pid == os.getpid()
    assert me.peak_rss_mb == pytest.approx(hwm, rel=0.05)
    assert me.cpu_s == pytest.approx(t.user + t.system, abs=0.5)
    got = list(parallel_map(_usage_after, [200, 1, 1, 1], _set_offset, (0,), workers=2))
    procs = per_process(got)
    # one entry per worker that took a unit (how the pool deals them is its own business)
    assert [u.pid for u in procs] == list(dict.fromkeys(u.pid for u in got))
    assert len(procs) <= 2 and me.pid not in {u.pid for u in procs}
    big = got[0]
    assert big.peak_rss_mb > 200
    # the worker that held 200 MB: its last report still has that peak
    assert next(u for u in procs if u.pid == big.pid).peak_rss_mb >= big.peak_rss_mb
    # the last report of a process wins; units done before this run (None) are left out
    a = ProcessUsage("h", 1, 100.0, 1.0)
    b = ProcessUsage("h", 1, 150.0, 2.0)
    c = ProcessUsage("other", 1, 50.0, 1.0)
    assert per_process([a, None, b, c, a]) == [b, c]
