"""Planning a build: which episode ids exist, their split, room kind and fall event.

Each split's episodes are divided evenly between the room kinds present in the rehearsal
(kitchen, study), the remainder to the first kinds, so the cross-scene splits of the paper
(train on kitchens, test on study rooms, and the reverse) are the kind-halves of the standard
splits: no episode is made twice, and they stay disjoint in fall events.

Episode ids run 0 .. N-1 over the splits in ``SPLITS`` order (train first) and, within a split,
over the kinds in sorted order. The rehearsed events of each kind (sorted by id, so the plan does
not depend on file order) are shuffled once with the root seed and dealt to the splits in
proportion to their episode counts, so no event is shared between splits; within a (split,
kind), episode k uses its pool's events in turn (k mod the pool size: with more episodes than
events an event returns with a new spawn and a new sound texture). The events a pool holds
beyond its episodes (the spares) are dealt to the (split, kind)'s shards, each its own run: an
episode whose event cannot be used takes its shard's next spare, so episodes share a fall only
once a shard has run out of them. Each episode then draws everything else from its own
generator (``episode_rng``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from fallgen.config import SPLITS


class EventLike(Protocol):
    """What planning reads of a fall event (a FallEvent, or generate's EventRef)."""

    event_id: str
    room_kind: str


#: spawn_key of the plan's own shuffle (episode generators use (episode_id,) keys).
PLAN_KEY = 2 ** 32 - 1


@dataclass(frozen=True)
class PlannedEpisode:
    episode_id: int
    split: str
    room_kind: str
    event_id: str


def _deal(order: list[str], wanted: tuple[int, ...], kind: str) -> list[list[str]]:
    """``order`` dealt to the splits in proportion to ``wanted`` (at least one event for a
    split that has episodes)."""
    total = sum(wanted)
    need = [k for k, n in enumerate(wanted) if n]
    if len(order) < len(need):
        raise ValueError(f"too few {kind} fall events ({len(order)}) for "
                         f"{len(need)} splits with {kind} episodes")
    pools, start = [], 0
    for k, n in enumerate(wanted):
        if n == 0:
            pools.append([])
            continue
        later = sum(1 for m in wanted[k + 1:] if m)
        share = len(order) - start - later if not later else \
            max(1, min(round(len(order) * n / total), len(order) - start - later))
        pools.append(order[start:start + share])
        start += share
    return pools


def kind_counts(n: int, kinds: list[str]) -> dict[str, int]:
    """``n`` episodes divided evenly between ``kinds`` (remainder to the first)."""
    return {k: n // len(kinds) + (1 if i < n % len(kinds) else 0) for i, k in enumerate(kinds)}


def plan(events: Sequence[EventLike], episodes: tuple[int, ...], root_seed: int
         ) -> list[PlannedEpisode]:
    """The build's episodes from its events (anything with ``event_id`` and ``room_kind``)."""
    pools, per_kind = _dealt(events, episodes, root_seed)
    out, eid = [], 0
    for split, counts in zip(SPLITS, per_kind):
        for kind in sorted(counts):
            pool = pools[(split, kind)]
            for k in range(counts[kind]):
                out.append(PlannedEpisode(eid, split, kind, pool[k % len(pool)]))
                eid += 1
    return out


def spare_events(events: Sequence[EventLike], episodes: tuple[int, ...], root_seed: int
                 ) -> dict[tuple[str, str], list[str]]:
    """Each (split, kind)'s events that :func:`plan` deals to it but gives no episode (its
    pool holds more events than it has episodes), in pool order: what an episode whose own
    event cannot be used takes first, so that no two episodes share a fall while any is left
    (:func:`deal_spares` gives each shard its own)."""
    pools, per_kind = _dealt(events, episodes, root_seed)
    return {(split, kind): pools[(split, kind)][counts[kind]:]
            for split, counts in zip(SPLITS, per_kind) for kind in sorted(counts)}


def deal_spares(spares: Sequence[str], sizes: Sequence[int]) -> list[tuple[str, ...]]:
    """``spares`` cut into consecutive runs in proportion to ``sizes`` (the episodes of each
    of a split's shards of one kind): every spare goes to exactly one shard."""
    total, out, done = sum(sizes), [], 0
    for n in sizes:
        a = len(spares) * done // total if total else 0
        done += n
        b = len(spares) * done // total if total else 0
        out.append(tuple(spares[a:b]))
    return out


def _dealt(events: Sequence[EventLike], episodes: tuple[int, ...], root_seed: int
           ) -> tuple[dict[tuple[str, str], list[str]], list[dict[str, int]]]:
    """Each (split, kind)'s pool of events and each split's episodes per kind."""
    if not events:
        raise ValueError("no fall events to make episodes from")
    ids = sorted(e.event_id for e in events)
    if len(set(ids)) != len(ids):
        raise ValueError("duplicate fall event ids")
    kind_of = {e.event_id: e.room_kind for e in events}
    kinds = sorted(set(kind_of.values()))
    per_kind = [kind_counts(n, kinds) for n in episodes]
    rng = np.random.default_rng(np.random.SeedSequence(root_seed, spawn_key=(PLAN_KEY,)))
    pools: dict[tuple[str, str], list[str]] = {}
    for kind in kinds:
        mine = [i for i in ids if kind_of[i] == kind]
        order = [mine[i] for i in rng.permutation(len(mine))]
        wanted = tuple(c[kind] for c in per_kind)
        for split, pool in zip(SPLITS, _deal(order, wanted, kind)):
            pools[(split, kind)] = pool
    return pools, per_kind


def pools_of(planned: list[PlannedEpisode]) -> dict[tuple[str, str], list[str]]:
    """Each (split, kind)'s events in first-use order: where an unusable event's episode looks
    for another (same split, same kind: shards stay one room kind)."""
    pools: dict[tuple[str, str], list[str]] = {}
    for p in planned:
        pool = pools.setdefault((p.split, p.room_kind), [])
        if p.event_id not in pool:
            pool.append(p.event_id)
    return pools
