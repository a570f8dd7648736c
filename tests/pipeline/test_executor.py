"""Executors and multi-machine builds: the same bytes from a local pool, from Ray and from
separate --shard-index runs finished by `fallgen finalize`."""

from __future__ import annotations

import collections
import os
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


_INITS = {"n": 0}


def _count_init() -> None:
    _INITS["n"] += 1


def _who(x: int) -> tuple[int, int, int]:
    """The unit, the worker's pid and how many times init ran in it."""
    if x < 0:
        raise KeyError(f"unit {x}")
    return x, os.getpid(), _INITS["n"]


def test_local_pool_retires_workers_after_units_per_worker():
    out = list(parallel_map(_who, list(range(7)), _count_init, (), workers=2,
                            units_per_worker=2))
    assert [u for u, _, _ in out] == list(range(7))  # in unit order
    assert all(n == 1 for _, _, n in out)  # every worker process ran init once
    per_pid = collections.Counter(pid for _, pid, _ in out)
    assert max(per_pid.values()) <= 2 and len(per_pid) >= 4
    assert os.getpid() not in per_pid


def test_recycling_pool_raises_a_units_error_and_refuses_zero():
    with pytest.raises(KeyError, match="unit -1"):
        list(parallel_map(_who, [0, 1, -1, 3], _count_init, (), workers=2, units_per_worker=1))
    with pytest.raises(ValueError, match="units_per_worker"):
        list(parallel_map(_who, [0], _count_init, (), workers=1, units_per_worker=0))


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
