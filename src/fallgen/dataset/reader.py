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

Random access (``ds.get(episode_id)``, ``ds.row(episode_id)``, ``ds.ids(...)``) goes through an
index of every episode (:attr:`Dataset.index`: id, split, room kind, category, zone kind and
where its row is), made from a few columns of each shard the first time it is needed; a lookup
then reads one shard.
"""

from __future__ import annotations

import json
from collections import OrderedDict
from collections.abc import Collection, Iterator
from functools import cached_property
from pathlib import Path

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from fallgen.config import SPLITS
from fallgen.dataset.manifest import MANIFEST

#: HDF5 array -> key in an episode dict
ARRAYS = {"audio": "audio", "rgb": "rgb", "depth": "depth", "instance": "instance_seg",
          "category": "category_seg"}
#: Columns of the index (besides ``shard`` and ``row``, where the episode's row is).
INDEX_COLUMNS = ("episode_id", "split", "room_kind", "room_variant", "zone_kind", "category",
                 "audio_material")
#: Shards whose rows are kept in memory after a lookup (a 250-episode shard: ~1 MB).
SHARDS_KEPT = 4


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

    @cached_property
    def _manifest(self) -> dict:
        """The manifest (read once), or {} for a dataset without one."""
        path = self.root / MANIFEST
        return json.loads(path.read_text()) if path.is_file() else {}

    def generate_settings(self) -> dict:
        """The ``[generate]`` settings the dataset was built with (its manifest's), or {} where
        the manifest has none."""
        return dict(self._manifest.get("settings", {}).get("generate", {}))

    @property
    def hrtf(self) -> str | None:
        """What its clips were heard with (:func:`fallgen.audio.heads.hrtf_id`: ``sphere`` or
        ``NAME:SHA256``), or None where the manifest does not say."""
        built = self._manifest.get("build", {})
        inputs = built.get("inputs", built) if isinstance(built, dict) else {}
        hrtf = inputs.get("hrtf") if isinstance(inputs, dict) else None
        if hrtf:
            return str(hrtf)
        spec = self.generate_settings().get("hrtf")
        return "sphere" if spec in ("", "sphere") else None

    @property
    def root_seed(self) -> int | None:
        """The root seed the dataset was built from (its manifest's), or None without one."""
        seed = self._manifest.get("root_seed")
        return None if seed is None else int(seed)

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

    def arrays(self, row: dict, names: Collection[str] = ("audio",)) -> dict[str, np.ndarray]:
        """Only the named arrays of an episode (HDF5 names: ``audio``, ``rgb``, ``depth``,
        ``instance``, ``category``, ``occupancy``), without reading the others."""
        k = row["media_index"]
        path = self.root / row["media_file"]
        if not path.is_file():
            raise FileNotFoundError(f"{path}: missing (episode {row['episode_id']})")
        out = {}
        with h5py.File(path, "r") as f:
            for name in names:
                out[name] = f["occupancy"][str(k)][0] if name == "occupancy" else f[name][k]
        return out

    def episodes(self, split: str | None = None, room_kind: str | None = None
                 ) -> Iterator[dict]:
        for row in self.rows(split, room_kind):
            yield self.episode(row)

    @cached_property
    def index(self) -> pa.Table:
        """One row per episode, sorted by id: :data:`INDEX_COLUMNS`, then ``shard`` (into
        :attr:`shards`) and ``row`` (within it)."""
        parts = []
        for k, p in enumerate(self.shards):
            t = pq.read_table(p, columns=list(INDEX_COLUMNS)) if pq.read_metadata(p).num_rows \
                else None
            if t is None:
                continue
            n = t.num_rows
            parts.append(t.append_column("shard", pa.array(np.full(n, k, np.int32)))
                          .append_column("row", pa.array(np.arange(n, dtype=np.int32))))
        if not parts:
            return pa.table({c: pa.array([], pa.string()) for c in INDEX_COLUMNS}
                            | {"episode_id": pa.array([], pa.int64()),
                               "shard": pa.array([], pa.int32()), "row": pa.array([], pa.int32())})
        return pa.concat_tables(parts).sort_by("episode_id")

    @cached_property
    def _where(self) -> dict[int, tuple[int, int]]:
        t = self.index
        return dict(zip(t["episode_id"].to_pylist(),
                        zip(t["shard"].to_pylist(), t["row"].to_pylist())))

    def ids(self, split: str | None = None, room_kind: str | None = None,
            categories: Collection[str] | None = None,
            zone_kinds: Collection[str] | None = None) -> list[int]:
        """Episode ids, sorted, of the split, room kind, categories and zone kinds given."""
        t = self.index
        for col, want in (("split", split), ("room_kind", room_kind)):
            if want is not None:
                t = t.filter(pc.equal(t[col], want))
        for col, want in (("category", categories), ("zone_kind", zone_kinds)):
            if want is not None:
                t = t.filter(pc.is_in(t[col], value_set=pa.array(sorted(want), pa.string())))
        return t["episode_id"].to_pylist()

    def __contains__(self, episode_id: int) -> bool:
        return int(episode_id) in self._where

    def _shard_table(self, k: int) -> pa.Table:
        cache = self.__dict__.setdefault("_tables", OrderedDict())
        t = cache.get(k)
        if t is None:
            t = cache[k] = pq.read_table(self.shards[k])
            while len(cache) > SHARDS_KEPT:
                cache.popitem(last=False)
        cache.move_to_end(k)
        return t

    def row(self, episode_id: int) -> dict:
        """The episode's row (no arrays); KeyError when there is no such episode."""
        where = self._where.get(int(episode_id))
        if where is None:
            raise KeyError(f"no episode {episode_id} in {self.root}")
        k, r = where
        return self._shard_table(k).slice(r, 1).to_pylist()[0]

    def get(self, episode_id: int) -> dict:
        """The episode with its arrays (reads one shard's rows and one chunk of its media)."""
        return self.episode(self.row(episode_id))


def open_dataset(path: str | Path) -> Dataset:
    return Dataset(path)
