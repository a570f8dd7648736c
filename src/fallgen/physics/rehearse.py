"""The rehearsal phase: per room variant, trials per fall zone until enough events are kept.

One Parquet file per variant (``<out>/rehearsal/<variant>.parquet``), written atomically with a
sidecar of statistics (``.stats.json``); a rerun skips variants whose file exists unless
``force``. The sidecar holds the rehearsal's fingerprint (:func:`fingerprint`: the code, the
world's data files, MuJoCo's version, the root seed and the rehearsal config): a variant made
under another one is an error naming the file, not a variant to keep. The unit of work is a
variant, so any number of worker processes gives identical files.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import functools
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
from fallgen.errors import InputError
from fallgen.physics.drop import REASONS, run_trial
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
    #: what made it (:func:`fingerprint`)
    fingerprint: str = ""
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
                "fingerprint": self.fingerprint,
                "by_zone_kind": {k: dict(v) for k, v in sorted(self.by_zone_kind.items())},
                "by_category": {k: dict(v) for k, v in sorted(self.by_category.items())}}

    @staticmethod
    def from_dict(d: dict) -> RoomStats:
        s = RoomStats(d["variant"], d["trials"], Counter(d["reasons"]),
                      fingerprint=d.get("fingerprint", ""))
        s.by_zone_kind = {k: Counter(v) for k, v in d["by_zone_kind"].items()}
        s.by_category = {k: Counter(v) for k, v in d["by_category"].items()}
        return s


def rehearse_variant(world: World, variant_id: str, cfg: BuildConfig
                     ) -> tuple[list[FallEvent], RoomStats]:
    """All zones of one variant: trials 0, 1, ... until ``events_per_zone`` are kept."""
    variant = world.variant(variant_id)
    r = cfg.rehearse
    stats = RoomStats(variant_id, fingerprint=fingerprint(world, cfg))
    events: list[FallEvent] = []
    for zone in variant.zones:
        if not fnmatch.fnmatchcase(zone.id, r.zones):
            continue
        kept = 0
        for trial in range(r.max_trials_per_zone):
            out = run_trial(world, variant, zone, trial, r, cfg.root_seed)
            stats.add(zone.kind, out.category, out.reason)
            if out.event is not None:
                events.append(out.event)
                kept += 1
                if kept == r.events_per_zone:
                    break
    return events, stats


def fingerprint(world: World, cfg: BuildConfig) -> str:
    """What a variant's rehearsal depends on, hashed: the source of the physics and world
    packages, the world's data files (rooms, materials, object categories), MuJoCo's version,
    the root seed and the rehearsal config (all of it but ``rooms``, which picks variants)."""
    import mujoco

    return _fingerprint(str(world.root), mujoco.__version__, cfg.root_seed,
                        json.dumps({k: v for k, v in dataclasses.asdict(cfg.rehearse).items()
                                    if k != "rooms"}, sort_keys=True, default=str))


@functools.cache
def _fingerprint(root: str, mujoco_version: str, seed: int, rehearse: str) -> str:
    h = hashlib.sha256(json.dumps([mujoco_version, seed, rehearse]).encode())
    pkg = Path(__file__).parent.parent
    code = sorted([*pkg.glob("physics/*.py"), *pkg.glob("world/**/*.py")])
    data = sorted(p for d in ("rooms", "materials", "objects")
                  for p in (Path(root) / d).rglob("*") if p.is_file())
    for f in code:
        h.update(str(f.relative_to(pkg)).encode() + f.read_bytes())
    for f in data:
        h.update(str(f.relative_to(root)).encode() + f.read_bytes())
    return h.hexdigest()[:16]


def rehearsal_dir(cfg: BuildConfig, out: Path | None = None) -> Path:
    return (out or cfg.out) / "rehearsal"


def write_variant(path: Path, events: list[FallEvent], stats: RoomStats) -> None:
    buf = io.BytesIO()
    pq.write_table(to_table(events), buf, compression="zstd")
    write_text(path.with_suffix(".stats.json"), json.dumps(stats.as_dict(), indent=1,
                                                            sort_keys=True))
    write_bytes(path, buf.getvalue())  # last: its presence marks the variant done


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
             shard_index: int | None = None, num_shards: int | None = None) -> list[RoomStats]:
    """Rehearse the given variants (or those of ``shard_index`` of ``num_shards``, round robin)
    into ``out``; returns the stats of every variant (the skipped ones read back from their
    sidecar). ``workers`` > 1 or ``executor="ray"``: one variant per task."""
    out.mkdir(parents=True, exist_ok=True)
    todo, done = [], []
    for vid in select_units(list(variant_ids), shard_index, num_shards):
        p = out / f"{vid}.parquet"
        if p.exists() and p.with_suffix(".stats.json").exists() and not force:
            side = p.with_suffix(".stats.json")
            try:
                kept = RoomStats.from_dict(json.loads(side.read_text()))
            except (ValueError, KeyError, TypeError) as e:
                raise InputError(side, "<file>", f"not a rehearsal sidecar ({e})") from None
            if kept.fingerprint != fingerprint(world, cfg):
                raise InputError(side, "fingerprint", "rehearsed under another config, world "
                                 "or fallgen version; build into a new --out, or `fallgen "
                                 "rehearse --force` to rehearse it again")
            done.append(kept)
            if progress:
                progress(vid, None)
        else:
            todo.append(vid)
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
