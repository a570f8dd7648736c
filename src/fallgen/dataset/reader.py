"""Reading a dataset: ``fallgen.dataset.open(path)`` and episodes as dicts of numpy arrays.

    import fallgen.dataset
    ds = fallgen.dataset.open("build/full")
    print(ds.splits, len(ds))
    for ep in ds.episodes("train"):
        ep["audio"]        # (2, T) float32, ear pressure / 20 Pa (times ep["audio_gain"])
        ep["rgb"]          # (300, 300, 3) uint8 at step 0; also depth, instance, category
        ep["occupancy"]    # (nx, ny) uint8, 0.1 m cells
        ep["expert_actions"], ep["category"], ep["settle_pos"], ...
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq

from fallgen.config import SPLITS

ARRAYS = ("audio", "rgb", "depth", "instance", "category")


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

    def rows(self, split: str | None = None) -> list[dict]:
        """Every episode's row (no arrays), in episode-id order."""
        out = [r for p in self.shards if split is None or p.name.startswith(f"{split}-")
               for r in pq.read_table(p).to_pylist()]
        return sorted(out, key=lambda r: r["episode_id"])

    def __len__(self) -> int:
        return sum(pq.read_metadata(p).num_rows for p in self.shards)

    def episode(self, row: dict) -> dict:
        """A row with its arrays (and trajectory frames, when the build has them)."""
        ep = dict(row)
        k = row["media_index"]
        with h5py.File(self.root / row["media_file"], "r") as f:
            for name in ARRAYS:
                ep[name] = f[name][k]
            ep["occupancy"] = f["occupancy"][str(k)][0]
            if "frames" in f and str(k) in f["frames"]:
                ep["frames"] = {n: d[()] for n, d in f["frames"][str(k)].items()}
        ep["depth"] = ep["depth"].astype(np.float32)
        return ep

    def episodes(self, split: str | None = None) -> Iterator[dict]:
        for row in self.rows(split):
            yield self.episode(row)

    def get(self, episode_id: int) -> dict:
        for row in self.rows():
            if row["episode_id"] == episode_id:
                return self.episode(row)
        raise KeyError(f"no episode {episode_id} in {self.root}")


def open_dataset(path: str | Path) -> Dataset:
    return Dataset(path)
