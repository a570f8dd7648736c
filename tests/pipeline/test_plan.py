"""Planning: episodes split evenly between room kinds, events dealt to disjoint split pools,
ids in split-then-kind order, shards one kind each, the same plan for the same seed."""

from __future__ import annotations

import dataclasses
from collections import Counter
from types import SimpleNamespace

import pytest

from fallgen.pipeline.generate import shard_jobs
from fallgen.pipeline.plan import deal_spares, kind_counts, plan, pools_of, spare_events


def _events(n_kitchen: int, n_study: int):
    return [SimpleNamespace(event_id=f"k{i:03d}", room_kind="kitchen") for i in range(n_kitchen)] \
        + [SimpleNamespace(event_id=f"s{i:03d}", room_kind="study") for i in range(n_study)]


def test_each_split_is_half_kitchen_half_study_and_events_never_cross_splits():
    events = _events(40, 30)
    p = plan(events, (60, 10, 11), root_seed=3)
    assert [e.episode_id for e in p] == list(range(81))
    c = Counter((e.split, e.room_kind) for e in p)
    assert c == {("train", "kitchen"): 30, ("train", "study"): 30, ("validation", "kitchen"): 5,
                 ("validation", "study"): 5, ("test", "kitchen"): 6, ("test", "study"): 5}
    kind = {e.event_id: e.room_kind for e in events}
    assert all(kind[e.event_id] == e.room_kind for e in p)
    used = {s: {e.event_id for e in p if e.split == s} for s in ("train", "validation", "test")}
    assert not used["train"] & used["validation"] and not used["train"] & used["test"]
    assert not used["validation"] & used["test"]
    # split-then-kind order of ids; every event of a kind is in some pool
    order = [(e.split, e.room_kind) for e in p]
    assert order == sorted(order, key=lambda t: (("train", "validation", "test").index(t[0]), t[1]))
    pools = pools_of(p)
    assert sum(len(v) for k, v in pools.items() if k[1] == "kitchen") <= 40


def test_same_seed_same_plan_other_seed_other_plan_file_order_irrelevant():
    events = _events(20, 20)
    a = plan(events, (10, 4, 4), 1)
    assert plan(list(reversed(events)), (10, 4, 4), 1) == a
    assert plan(events, (10, 4, 4), 2) != a


def test_one_kind_only_and_too_few_events():
    p = plan(_events(5, 0), (4, 2, 2), 0)
    assert {e.room_kind for e in p} == {"kitchen"} and len(p) == 8
    with pytest.raises(ValueError, match="too few study fall events"):
        plan(_events(10, 2), (4, 2, 2), 0)
    assert kind_counts(5, ["kitchen", "study"]) == {"kitchen": 3, "study": 2}


def test_shards_hold_one_kind_and_are_numbered_across_kinds():
    p = plan(_events(30, 30), (10, 4, 4), 5)
    jobs = shard_jobs(p, 3)
    train = [j for j in jobs if j.split == "train"]
    assert [(j.index, j.count, j.room_kind, len(j.episodes)) for j in train] == [
        (0, 4, "kitchen", 3), (1, 4, "kitchen", 2), (2, 4, "study", 3), (3, 4, "study", 2)]
    for j in jobs:
        assert {e.room_kind for e in j.episodes} == {j.room_kind}
    assert sorted(e.episode_id for j in jobs for e in j.episodes) == list(range(18))


def test_every_event_is_planned_or_a_spare_and_each_spare_goes_to_one_shard():
    """A pool's events beyond its episodes are its spares: with the planned events they are
    every rehearsed event once, they keep to their kind, and the shards of a
    (split, kind) share them out in runs in proportion to their episodes."""
    events = _events(40, 30)
    episodes = (20, 6, 6)
    p = plan(events, episodes, 3)
    spares = spare_events(events, episodes, 3)
    planned = {e.event_id for e in p}
    every = [e for v in spares.values() for e in v]
    assert len(every) == len(set(every)) == 70 - len(planned) > 0
    assert not set(every) & planned
    kind = {e.event_id: e.room_kind for e in events}
    assert all(kind[e] == k for (_, k), v in spares.items() for e in v)
    jobs = shard_jobs(p, 4, spares)
    dealt = [e for j in jobs for e in j.spares]
    assert sorted(dealt) == sorted(every)
    assert all(set(j.spares) <= set(spares[(j.split, j.room_kind)]) for j in jobs)
    assert deal_spares(list("abcdefg"), [4, 4, 2]) == [("a", "b"), ("c", "d", "e"), ("f", "g")]
    assert deal_spares([], [3, 1]) == [(), ()]
    assert shard_jobs(p, 4) == [dataclasses.replace(j, spares=()) for j in jobs]
