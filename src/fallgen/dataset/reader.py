"""Reading a dataset: ``fallgen.dataset.open(path)`` and episodes as dicts of numpy arrays.

    import fallgen.dataset
    ds = fallgen.dataset.open("build/full")
    print(ds.splits, len(ds))
    for ep in ds.episodes("test", room_kind="study"):   # the kitchen_to_study test split
        ep["audio"]         # (2, T) float32, ear pressure / 20 Pa (times ep["audio_gain"])
        ep["rgb"]           # (300, 300, 3) uint8 at step 0; ep["depth"] (300, 300) float32 m
        ep["category_seg"]  # (300, 300) int16 into ds.category_labels; ep["instance_seg"]
        ep["occupancy"]     # (nx, ny) uint8, 0.1 m cells
        ep["category"], ep["settle_pos"], ep["expert_actions"]  # the row's columns
    ds.actions              # names of the action indices in expert_actions

Row columns keep their names; the HDF5 arrays ``instance`` and ``category`` become
``instance_seg`` and ``category_seg`` (the row already has a ``category``: the object's).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from functools import cached_property
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq

from fallgen.config import SPLITS

#: HDF5 array -> key in an episode dict
ARRAYS = {"audio": "audio", "rgb": "rgb", "depth": "depth", "instance": "instance_seg",
          "category": "category_seg"}


class Dataset:
    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        if not (self.root / "data").is_dir():
            raise FileNotFoundError(f"{self.root}: no data/ directory (not a fallgen dataset)")
        self.shards = sorted((self.root / "data").glob("*.parquet"))

    @property
    def splits(self) -> list[str]:
        present = {p.name.split("-")[0] for p in self.shards}
        return [s for s in SPLITS if s in present] + sorted(present - set(SPLITS))

    def rows(self, split: str | None = None, room_kind: str | None = None) -> list[dict]:
        """Every episode's row (no arrays), in episode-id order; ``room_kind`` selects the
        cross-scene halves (e.g. train on "kitchen", test on "study")."""
        out = [r for p in self.shards if split is None or p.name.startswith(f"{split}-")
               for r in pq.read_table(p).to_pylist()
               if room_kind is None or r["room_kind"] == room_kind]
        return sorted(out, key=lambda r: r["episode_id"])

    def __len__(self) -> int:
        return sum(pq.read_metadata(p).num_rows for p in self.shards)

    def _attr(self, name: str) -> list[str]:
        for p in sorted((self.root / "media").glob("*.h5")):
            with h5py.File(p, "r") as f:
                return json.loads(f.attrs[name])
        return []

    @cached_property
    def category_labels(self) -> list[str]:
        """Names of the category segmentation values (one table for the whole dataset)."""
        return self._attr("category_labels")

    @cached_property
    def actions(self) -> list[str]:
        return self._attr("actions")

    def episode(self, row: dict) -> dict:
        """A row with its arrays (and trajectory frames, when the build has them)."""
        ep = dict(row)
        k = row["media_index"]
        with h5py.File(self.root / row["media_file"], "r") as f:
            for name, key in ARRAYS.items():
                ep[key] = f[name][k]
            ep["occupancy"] = f["occupancy"][str(k)][0]
            if "frames" in f and str(k) in f["frames"]:
                ep["frames"] = {n: d[()] for n, d in f["frames"][str(k)].items()}
        ep["depth"] = ep["depth"].astype(np.float32)
        return ep

    def episodes(self, split: str | None = None, room_kind: str | None = None
                 ) -> Iterator[dict]:
        for row in self.rows(split, room_kind):
            yield self.episode(row)

    def get(self, episode_id: int) -> dict:
        for row in self.rows():
            if row["episode_id"] == episode_id:
                return self.episode(row)
        raise KeyError(f"no episode {episode_id} in {self.root}")


def open_dataset(path: str | Path) -> Dataset:
    return Dataset(path)
