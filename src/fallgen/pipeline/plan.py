"""Planning a build: which episode ids exist, their split and their fall event.

Episode ids run 0 .. N-1 over the splits in ``SPLITS`` order (train first). The rehearsed events
(sorted by id, so the plan does not depend on file order) are shuffled once with the root seed and
dealt to the splits in proportion to their episode counts, so no event is shared between
splits; within a split, episode k uses the split's events in turn (k mod the pool size: with more
episodes than events an event returns with a new spawn and a new sound texture). Each episode
then draws everything else from its own generator (``episode_rng``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallgen.config import SPLITS
from fallgen.physics.events import FallEvent

#: spawn_key of the plan's own shuffle (episode generators use (episode_id,) keys).
PLAN_KEY = 2 ** 32 - 1


@dataclass(frozen=True)
class PlannedEpisode:
    episode_id: int
    split: str
    event_id: str


def plan(events: list[FallEvent], episodes: tuple[int, ...], root_seed: int
         ) -> list[PlannedEpisode]:
    if not events:
        raise ValueError("no fall events to make episodes from")
    ids = sorted(e.event_id for e in events)
    if len(set(ids)) != len(ids):
        raise ValueError("duplicate fall event ids")
    rng = np.random.default_rng(np.random.SeedSequence(root_seed, spawn_key=(PLAN_KEY,)))
    order = [ids[i] for i in rng.permutation(len(ids))]
    total = sum(episodes)
    wanted = [n for n in episodes]
    # events per split in proportion to the episodes (at least one for a split that has any)
    pools, start = [], 0
    for k, n in enumerate(wanted):
        if n == 0:
            pools.append([])
            continue
        share = max(1, round(len(order) * n / total)) if k < len(wanted) - 1 else len(order) - start
        share = max(1, min(share, len(order) - start - sum(1 for m in wanted[k + 1:] if m)))
        pools.append(order[start:start + share])
        start += share
    out, eid = [], 0
    for split, n, pool in zip(SPLITS, wanted, pools):
        if n and not pool:
            raise ValueError(f"too few fall events ({len(order)}) for the {split} split")
        for k in range(n):
            out.append(PlannedEpisode(eid, split, pool[k % len(pool)]))
            eid += 1
    return out
