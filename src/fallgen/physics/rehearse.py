"""The rehearsal phase: per room variant, trials per fall zone until enough events are kept.

One Parquet file per variant (``<out>/rehearsal/<variant>.parquet``), written atomically with a
sidecar of statistics (``.stats.json``). The sidecar holds what made the file (its inputs: the
code, the world's data files it reads, the versions, the root seed and the rehearsal config;
:func:`fingerprint` is their part common to every variant) and the file's sha256, with a
checksum of its own. A rerun keeps a variant whose file is what its sidecar records and was made
from the same inputs (:func:`fallgen.dataset.integrity.rehearsal_state`); one made under other
inputs is an error naming the file and the difference (``force`` rehearses it again), one whose
bytes changed (or has no sidecar) is rehearsed again. The unit of work is a variant, so any
number of worker processes gives identical files. Rehearsing anything makes the dataset
directory unfinished (its manifest and card are removed: the shards made from the old events
are made again by the next ``generate``).
"""

from __future__ import annotations

import fnmatch
import hashlib
import io
import json
import os
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow.parquet as pq

from fallgen.atomic import write_bytes, write_text
from fallgen.config import BuildConfig
from fallgen.dataset import integrity
from fallgen.errors import InputError
from fallgen.physics.drop import REASONS, run_trial, zone_fits
from fallgen.physics.events import FallEvent, from_table, to_table
from fallgen.pipeline.executor import ProcessUsage, parallel_map, process_usage, select_units
from fallgen.world.library import World, load_world


@dataclass
class RoomStats:
    variant: str
    trials: int = 0
    reasons: Counter = field(default_factory=Counter)
    by_zone_kind: dict[str, Counter] = field(default_factory=dict)
    by_category: dict[str, Counter] = field(default_factory=dict)
    #: what made it (:func:`fingerprint`, and every input: :func:`integrity.rehearsal_stamp`)
    fingerprint: str = ""
    inputs: dict = field(default_factory=dict, compare=False)
    #: the process that rehearsed it, when it was done in this run (not written to the sidecar)
    usage: ProcessUsage | None = field(default=None, compare=False)

    def add(self, zone_kind: str, category: str, reason: str) -> None:
        self.trials += 1
        self.reasons[reason] += 1
        self.by_zone_kind.setdefault(zone_kind, Counter())[reason] += 1
        if category:
            self.by_category.setdefault(category, Counter())[reason] += 1

    def as_dict(self) -> dict:
        return {"variant": self.variant, "trials": self.trials, "reasons": dict(self.reasons),
                "fingerprint": self.fingerprint, "inputs": self.inputs,
                "by_zone_kind": {k: dict(v) for k, v in sorted(self.by_zone_kind.items())},
                "by_category": {k: dict(v) for k, v in sorted(self.by_category.items())}}

    @staticmethod
    def from_dict(d: dict) -> RoomStats:
        s = RoomStats(d["variant"], d["trials"], Counter(d["reasons"]),
                      fingerprint=d.get("fingerprint", ""), inputs=d.get("inputs", {}))
        s.by_zone_kind = {k: Counter(v) for k, v in d["by_zone_kind"].items()}
        s.by_category = {k: Counter(v) for k, v in d["by_category"].items()}
        return s


def rehearse_variant(world: World, variant_id: str, cfg: BuildConfig
                     ) -> tuple[list[FallEvent], RoomStats]:
    """All zones of one variant: trials 0, 1, ... until ``events_per_zone`` are kept."""
    variant = world.variant(variant_id)
    r = cfg.rehearse
    stats = RoomStats(variant_id, fingerprint=fingerprint(world, cfg),
                      inputs=integrity.rehearsal_stamp(world, cfg, variant_id).inputs)
    events: list[FallEvent] = []
    for zone in variant.zones:
        if not fnmatch.fnmatchcase(zone.id, r.zones):
            continue
        kept = 0
        fits = zone_fits(world, zone)
        for trial in range(r.max_trials_per_zone):
            out = run_trial(world, variant, zone, trial, r, cfg.root_seed, fits)
            stats.add(zone.kind, out.category, out.reason)
            if out.event is not None:
                events.append(out.event)
                kept += 1
                if kept == r.events_per_zone:
                    break
    return events, stats


def fingerprint(world: World, cfg: BuildConfig) -> str:
    """What every variant's rehearsal depends on, hashed: the source of the physics and world
    packages, the world's material and category files, fallgen's and its libraries' versions,
    the root seed and the rehearsal config (all of it but ``rooms``, which picks variants). A
    variant's own room file is in its sidecar's inputs."""
    return integrity.rehearsal_fingerprint(world, cfg)


def rehearsal_dir(cfg: BuildConfig, out: Path | None = None) -> Path:
    return (out or cfg.out) / "rehearsal"


def write_variant(path: Path, events: list[FallEvent], stats: RoomStats) -> None:
    """The events, and first their sidecar: the stats, what made them and the file's sha256
    and size (with a checksum of its own)."""
    buf = io.BytesIO()
    pq.write_table(to_table(events), buf, compression="zstd")
    data = buf.getvalue()
    record = {**stats.as_dict(), "parquet": {"sha256": hashlib.sha256(data).hexdigest(),
                                             "bytes": len(data)}}
    write_text(path.with_suffix(".stats.json"), integrity.checked_json(record))
    write_bytes(path, data)  # last: its presence marks the variant done


def read_events(path: str | Path) -> list[FallEvent]:
    return from_table(pq.read_table(path))


# --- workers ------------------------------------------------------------------------------------

_WORLD: World | None = None


def _init_worker(data_root: str) -> None:
    global _WORLD
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORLD = load_world(data_root)


def _work(args: tuple[str, BuildConfig, str]) -> tuple[str, dict, ProcessUsage]:
    variant_id, cfg, out_dir = args
    assert _WORLD is not None
    events, stats = rehearse_variant(_WORLD, variant_id, cfg)
    write_variant(Path(out_dir) / f"{variant_id}.parquet", events, stats)
    return variant_id, stats.as_dict(), process_usage()


def rehearse(world: World, cfg: BuildConfig, variant_ids: Iterable[str], *, out: Path,
             workers: int = 1, force: bool = False,
             progress: Callable[[str, dict | None], None] | None = None,
             executor: str = "local", ray_address: str | None = None,
             shard_index: int | None = None, num_shards: int | None = None,
             note: Callable[[str], None] | None = None) -> list[RoomStats]:
    """Rehearse the given variants (or those of ``shard_index`` of ``num_shards``, round robin)
    into ``out`` (a dataset's ``rehearsal/``: the dataset directory is held for writing,
    :func:`fallgen.dataset.integrity.writer_lock`); returns the stats of every variant (the
    kept ones read back from their sidecar). ``workers`` > 1 or ``executor="ray"``: one variant
    per task. ``note`` gets a line for each variant rehearsed again."""
    part = None if shard_index is None else f"rehearse-{shard_index}-of-{num_shards}"
    with integrity.writer_lock(out.parent, part):
        return _rehearse(world, cfg, variant_ids, out, workers, force, progress, executor,
                         ray_address, shard_index, num_shards, note)


def _rehearse(world, cfg, variant_ids, out, workers, force, progress, executor, ray_address,
              shard_index, num_shards, note) -> list[RoomStats]:
    out.mkdir(parents=True, exist_ok=True)
    todo, done = [], []
    for vid in select_units(list(variant_ids), shard_index, num_shards):
        p = out / f"{vid}.parquet"
        side = p.with_suffix(".stats.json")
        state = integrity.rehearsal_state(p, integrity.rehearsal_stamp(world, cfg, vid))
        if state.ok and not force:
            done.append(RoomStats.from_dict(json.loads(side.read_text())))
            if progress:
                progress(vid, None)
        elif state.status == "stale" and not force:
            raise InputError(side, "fingerprint", f"rehearsed under another config, world or "
                             f"fallgen version ({state.reason}); build into a new --out, or "
                             "`fallgen rehearse --force` to rehearse it again")
        else:
            if note and state.status != "missing":
                note(f"{p.name}: rehearsed again ("
                     f"{'--force' if state.ok else state.status + ': ' + state.reason})")
            todo.append(vid)
    if todo:  # the shards made from the old events are made again; no finished build till then
        integrity.unfinalize(out.parent)
    results: list[RoomStats] = []
    if executor == "local" and min(workers, len(todo)) <= 1:  # in this process
        for vid in todo:
            events, stats = rehearse_variant(world, vid, cfg)
            write_variant(out / f"{vid}.parquet", events, stats)
            stats.usage = process_usage()
            results.append(stats)
            if progress:
                progress(vid, stats.as_dict())
    else:
        for vid, d, usage in parallel_map(_work, [(v, cfg, str(out)) for v in todo],
                                          _init_worker, (str(world.root),),
                                          min(workers, len(todo)), executor, ray_address):
            stats = RoomStats.from_dict(d)
            stats.usage = usage
            results.append(stats)
            if progress:
                progress(vid, d)
    return done + results


def summarize(stats: list[RoomStats]) -> dict[str, dict[str, Counter]]:
    """Totals per zone kind and per category (trials and reasons)."""
    by_kind: dict[str, Counter] = {}
    by_cat: dict[str, Counter] = {}
    for s in stats:
        for k, c in s.by_zone_kind.items():
            by_kind.setdefault(k, Counter()).update(c)
        for k, c in s.by_category.items():
            by_cat.setdefault(k, Counter()).update(c)
    assert all(r in REASONS for c in by_kind.values() for r in c)
    return {"zone_kind": by_kind, "category": by_cat}
