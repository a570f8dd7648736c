"""Which episodes of a built dataset an environment replays, and what it loads for each.

A selection is a split, a room kind (the cross-scene halves), categories and explicit episode
ids, intersected; worker ``rank`` of ``world_size`` keeps every ``world_size``-th of the sorted
ids from ``rank`` on, so the workers' slices are disjoint and together cover the selection.

For an episode the environment needs its row (spawn, object, expert references), its step-0
audio clip, the occupancy grid it was generated with (a check that the world data is the same)
and its fall event's settled objects (the dataset's ``rehearsal/`` files; the contacts are not
read).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from fallgen.dataset.reader import Dataset
from fallgen.nav.agent import Pose
from fallgen.physics.events import SCHEMA, FallEvent, from_table

#: Rehearsal files (one per room variant) whose events are kept in memory.
VARIANTS_KEPT = 8
ROOM_KINDS = ("kitchen", "study")
#: The cross-scene configurations of the dataset card: name -> (train room kind, test room kind)
CROSS_SCENE = {"kitchen_to_study": ("kitchen", "study"), "study_to_kitchen": ("study", "kitchen")}


@dataclass(frozen=True)
class EpisodeData:
    """What the environment replays of one episode."""

    row: dict
    event: FallEvent
    audio: np.ndarray  # (2, T) float32, the step-0 clip as stored
    occupancy: np.ndarray  # (nx, ny) uint8, as stored

    @property
    def episode_id(self) -> int:
        return int(self.row["episode_id"])

    @property
    def spawn(self) -> Pose:
        r = self.row
        return Pose(float(r["spawn_x"]), float(r["spawn_y"]), int(r["spawn_heading"]), 0)


def check_hrtf(ds: Dataset, hrtf: str) -> None:
    """ValueError in one line when ``ds``'s clips were heard with another head than ``hrtf``
    (``sphere``, ``sadie_ku100`` or a SOFA file; compared by :func:`fallgen.audio.heads.hrtf_id`,
    the file's content). A dataset that does not record its head is not refused."""
    from fallgen.audio.heads import hrtf_id

    try:
        want = hrtf_id(str(hrtf))
    except (OSError, ValueError) as e:
        raise ValueError(f"hrtf={hrtf!r}: {e}") from None
    def content(identity: str) -> str:  # the file's hash (a file's name may differ)
        return identity.split(":", 1)[-1]

    if ds.hrtf is not None and content(ds.hrtf) != content(want):
        raise ValueError(f"{ds.root}: hrtf: the dataset's clips were heard with {ds.hrtf}, "
                         f"not {want} (hrtf={hrtf!r})")


def select(ds: Dataset, split: str | None = None, room_kind: str | None = None,
           categories: Collection[str] | None = None,
           episode_ids: Sequence[int] | None = None, rank: int = 0,
           world_size: int = 1) -> list[int]:
    """The sorted episode ids of the selection, this worker's slice of them. ValueError for
    an unknown split, room kind or category, an episode id not in the dataset, or a slice
    that is empty."""
    if not 0 <= rank < world_size:
        raise ValueError(f"rank {rank} of world_size {world_size}: need 0 <= rank < world_size")
    if split is not None and split not in ds.splits:
        raise ValueError(f"split {split!r} not in {ds.root} (splits: {', '.join(ds.splits)})")
    if room_kind is not None and room_kind not in ROOM_KINDS:
        raise ValueError(f"room_kind {room_kind!r}: one of {', '.join(ROOM_KINDS)}")
    if categories is not None:
        known = set(ds.index["category"].to_pylist())
        unknown = sorted(set(categories) - known)
        if unknown:
            raise ValueError(f"no episode of category {unknown[0]!r} in {ds.root}")
    ids = ds.ids(split, room_kind, categories)
    if episode_ids is not None:
        missing = [int(i) for i in episode_ids if int(i) not in ds]
        if missing:
            raise ValueError(f"no episode {missing[0]} in {ds.root}")
        wanted = {int(i) for i in episode_ids}
        ids = [i for i in ids if i in wanted]
    ids = ids[rank::world_size]
    if not ids:
        raise ValueError(f"no episode of {ds.root} is selected (split={split}, "
                         f"room_kind={room_kind}, categories={categories}, "
                         f"episode_ids={episode_ids}, rank {rank} of {world_size})")
    return ids


class EpisodeSource:
    """Loads episodes of a dataset for replay (keeps the events of recent room variants)."""

    def __init__(self, ds: Dataset) -> None:
        self.ds = ds
        self._events: OrderedDict[str, dict[str, FallEvent]] = OrderedDict()

    def load(self, episode_id: int) -> EpisodeData:
        row = self.ds.row(episode_id)
        arrays = self.ds.arrays(row, ("audio", "occupancy"))
        return EpisodeData(row, self.event(row["room_variant"], row["event_id"]),
                           np.asarray(arrays["audio"], np.float32),
                           np.asarray(arrays["occupancy"]))

    def event(self, variant: str, event_id: str) -> FallEvent:
        events = self._events.get(variant)
        if events is None:
            events = self._events[variant] = self._read(variant)
            while len(self._events) > VARIANTS_KEPT:
                self._events.popitem(last=False)
        self._events.move_to_end(variant)
        ev = events.get(event_id)
        if ev is None:
            raise KeyError(f"{self._file(variant)}: no fall event {event_id!r}")
        return ev

    def _file(self, variant: str) -> Path:
        return self.ds.root / "rehearsal" / f"{variant}.parquet"

    def _read(self, variant: str) -> dict[str, FallEvent]:
        path = self._file(variant)
        if not path.is_file():
            raise FileNotFoundError(f"{path}: missing (the episodes of {variant} replay its "
                                    "fall events)")
        names = [n for n in SCHEMA.names if n != "contacts"]
        t = pq.read_table(path, columns=[n for n in names if n in pq.read_schema(path).names])
        # the contacts are the sound's business: an empty list each
        empty = pa.array([[]] * t.num_rows, SCHEMA.field("contacts").type)
        t = t.append_column("contacts", empty)
        ids = pc.unique(t["event_id"]).to_pylist()
        return {e.event_id: e for e in from_table(t)} if len(ids) == t.num_rows else \
            _duplicate(path)


def _duplicate(path: Path):
    raise ValueError(f"{path}: event_id: duplicate fall event ids")


__all__ = ["EpisodeData", "EpisodeSource", "select", "CROSS_SCENE", "ROOM_KINDS"]
