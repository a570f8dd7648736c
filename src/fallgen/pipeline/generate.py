"""The generation phase: rehearsed fall events -> episodes, written shard by shard.

Shards are the unit of work and of resumption: ``{split}-{i:05d}-of-{n:05d}`` holds the split's
episodes ``i * per_shard ..`` (in episode-id order); workers take whole shards, so output does
not depend on the worker count. A shard is kept only when it is what this build would make and
is whole (:mod:`fallgen.dataset.integrity`: its fingerprint, of the config, world, code and fall
events, is the build's, and its bytes are those recorded when it was written); any other is made
again. The rehearsal files are checked the same way first (one made under other inputs, or
changed since, is refused), shards of another plan are removed, and the card and the manifest
are written from the shards once every one of them checks (:func:`finalize_build`). One process
writes a dataset directory at a time (``--shard-index`` runs share it, one per index).

An episode whose event cannot be used (:class:`~fallgen.pipeline.episode.Skip`: the replay with
the agent diverged, no free spawn, no reachable pose sees the object) takes its shard's next
spare event (one its split's pool holds beyond the episodes, given to no other shard: no two
episodes share a fall while a spare is left), then the events after its own in the pool, up to
``MAX_EVENT_ATTEMPTS`` events; a spare tried is used up. The order is fixed by the shard's
episodes alone, so a shard is the same whoever makes it. The row records the event used and
the attempts, and the skip reasons are counted.
"""

from __future__ import annotations

import dataclasses
import glob
import itertools
import time
from collections import Counter
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from fallgen import jitcache
from fallgen.audio.heads import load_hrtf
from fallgen.audio.mix import Binaural
from fallgen.audio.room import RirSettings
from fallgen.config import SPLITS, BuildConfig
from fallgen.dataset import integrity
from fallgen.dataset.integrity import Stamp
from fallgen.dataset.card import finalize
from fallgen.dataset.schema import COLUMNS
from fallgen.dataset.writer import ShardWriter, row_of, shard_meta, shard_name
from fallgen.errors import InputError
from fallgen.physics.events import FallEvent, event_variant, from_table
from fallgen.physics.rehearse import rehearsal_dir
from fallgen.pipeline.episode import EpisodeMaker, Skip
from fallgen.pipeline.executor import ProcessUsage, parallel_map, process_usage, select_units
from fallgen.pipeline.heap import HeapTrimmer, trim_heap
from fallgen.pipeline.plan import PlannedEpisode, deal_spares, plan, pools_of, spare_events
from fallgen.world.library import World, load_world

MAX_EVENT_ATTEMPTS = 10


@dataclass
class ShardResult:
    """One shard's outcome. ``timings_s``: seconds by stage of every attempt, the episodes'
    (``audio``, ``planning``, ...), the writing of their rows and media (``writing``) and the
    attempts given up (``skipped:planning``, ...: an event with no path is found out only
    by a search)."""

    name: str
    episodes: int
    skips: Counter = field(default_factory=Counter)
    timings_s: Counter = field(default_factory=Counter)
    skipped_shard: bool = False  # already done
    usage: ProcessUsage | None = None  # of the process that made it, when it was done
    remade: str = ""  # why a shard that was there was made again ("" for a new one)


def _rehearsal_files(cfg: BuildConfig, out: Path | None) -> list[Path]:
    files = sorted(Path(f) for f in glob.glob(str(rehearsal_dir(cfg, out) / "*.parquet")))
    if not files:
        raise FileNotFoundError(f"no rehearsal files in {rehearsal_dir(cfg, out)}: run "
                                "`fallgen rehearse` first")
    return files


@dataclass(frozen=True)
class EventRef:
    """What planning needs of a fall event (its contacts stay on disk)."""

    event_id: str
    room_kind: str


def event_refs(cfg: BuildConfig, out: Path | None = None,
               files: list[Path] | None = None) -> list[EventRef]:
    """Every rehearsed event's id and room kind (of ``files``, default every rehearsal file),
    sorted by id (two columns read)."""
    refs = []
    for f in files if files is not None else _rehearsal_files(cfg, out):
        t = pq.read_table(f, columns=["event_id", "room_kind"])
        refs += [EventRef(i, k) for i, k in zip(t["event_id"].to_pylist(),
                                                  t["room_kind"].to_pylist())]
    return sorted(refs, key=lambda e: e.event_id)


def load_events(cfg: BuildConfig, out: Path | None = None,
                ids: Collection[str] | None = None) -> list[FallEvent]:
    """The rehearsed events (only those in ``ids``, reading only their variants' files, when
    given), sorted by id."""
    files = _rehearsal_files(cfg, out)
    if ids is not None:
        variants = {event_variant(i) for i in ids}
        files = [f for f in files if f.stem in variants]
        wanted = pa.array(sorted(ids), pa.string())
    events = []
    for f in files:
        t = pq.read_table(f)
        if ids is not None:
            t = t.filter(pc.is_in(t["event_id"], value_set=wanted))
        events += from_table(t)
    return sorted(events, key=lambda e: e.event_id)


def job_event_ids(job: ShardJob, pools: dict[tuple[str, str], list[str]]) -> set[str]:
    """Every event a shard can use: each planned episode's event, its spares and the
    fallbacks after each event in its pool."""
    return {e for p in job.episodes for e in _attempts(p, pools)} | set(job.spares)


def _tries(p: PlannedEpisode, pools: dict[tuple[str, str], list[str]],
           spares: Iterator[str]) -> Iterator[str]:
    """The events episode ``p`` tries, in order: its planned event, then the shard's spares
    not used up yet (``spares``: one iterator for the shard, advanced only as far as episodes
    need), then the ones after its event in its pool; ``MAX_EVENT_ATTEMPTS`` at most, none
    twice."""
    first, *after = _attempts(p, pools)
    yield first
    tried = {first}
    if len(tried) >= MAX_EVENT_ATTEMPTS:
        return
    for e in itertools.chain(spares, after):
        if e not in tried:
            tried.add(e)
            yield e
            if len(tried) >= MAX_EVENT_ATTEMPTS:  # before a spare is drawn that is not tried
                return


def _attempts(p: PlannedEpisode, pools: dict[tuple[str, str], list[str]]) -> list[str]:
    """The events episode ``p`` tries, in order: its planned event, then the ones after it in
    its split's pool (wrapping), ``MAX_EVENT_ATTEMPTS`` at most."""
    pool = pools[(p.split, p.room_kind)]
    first = pool.index(p.event_id)
    return [pool[(first + a) % len(pool)] for a in range(min(MAX_EVENT_ATTEMPTS, len(pool)))]


@dataclass(frozen=True)
class ShardJob:
    split: str
    index: int
    count: int
    room_kind: str
    episodes: tuple[PlannedEpisode, ...]
    #: events of the split's pool no episode plans, this shard's own (taken in turn by its
    #: episodes whose own event cannot be used)
    spares: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        return shard_name(self.split, self.index, self.count)


def making_order(jobs: list[ShardJob]) -> list[ShardJob]:
    """The order a build makes ``jobs`` in: one room kind's shards after the other's, each
    kind's in the plan's order. A worker keeps what it makes per room variant only for the
    kind of the shard it is on (:meth:`EpisodeMaker.retain_rooms`), so each change of kind
    makes that kind's rooms again (~0.12 s a variant); the plan lists each split's kinds in
    turn."""
    return sorted(jobs, key=lambda j: j.room_kind)


def shard_jobs(planned: list[PlannedEpisode], per_shard: int,
               spares: dict[tuple[str, str], list[str]] | None = None) -> list[ShardJob]:
    """Each split's episodes in shards of ``per_shard``, one room kind per shard (so the
    cross-scene splits are sets of whole files), numbered across the split's kinds; each
    (split, kind)'s ``spares`` (:func:`fallgen.pipeline.plan.spare_events`) dealt to its
    shards in proportion to their episodes."""
    jobs = []
    for split in SPLITS:
        eps = [p for p in planned if p.split == split]
        kinds = sorted({p.room_kind for p in eps})
        chunks = []
        for kind in kinds:
            mine = [p for p in eps if p.room_kind == kind]
            cut = [tuple(mine[i:i + per_shard]) for i in range(0, len(mine), per_shard)]
            extra = deal_spares((spares or {}).get((split, kind), []), [len(c) for c in cut])
            chunks += [(kind, c, x) for c, x in zip(cut, extra)]
        for i, (kind, chunk, extra) in enumerate(chunks):
            jobs.append(ShardJob(split, i, len(chunks), kind, chunk, extra))
    return jobs


def _maker(world: World, cfg: BuildConfig) -> EpisodeMaker:
    g = cfg.generate
    hrtf = load_hrtf(g.hrtf)
    return EpisodeMaker(world, Binaural(hrtf),
                        rir=RirSettings(g.image_source_order, 44100, g.audio_s),
                        noise_db_a=g.ambient_noise_db_a,
                        min_heard_peak_db_spl=g.min_heard_peak_db_spl,
                        appearance=g.appearance,
                        appearance_randomization=g.appearance_randomization)


def make_shard(world: World, maker: EpisodeMaker, cfg: BuildConfig, job: ShardJob,
               events: dict[str, FallEvent], pools: dict[tuple[str, str], list[str]], out: Path,
               trim: Callable[[], bool] | None = None, stamp: Stamp | None = None
               ) -> ShardResult:
    """Make and write one shard (the caller decides which shards to make: :func:`generate`);
    ``trim`` is called before every episode (a worker passes its
    :class:`~fallgen.pipeline.heap.HeapTrimmer`; default:
    :func:`fallgen.pipeline.heap.trim_heap`); ``stamp``: what makes it (:attr:`Build.stamps`),
    recorded with it."""
    trim = trim or trim_heap
    name = job.name
    res = ShardResult(name, 0)
    rows, dropped = [], []
    writer = ShardWriter(out, job.split, job.index, job.count, maker.labels, stamp)
    # a worker keeps per-variant rooms only for the variants this shard's events fall in (one
    # room kind's: a worker meets all 64 variants, ~1.6 MB each, over a paper-size build)
    maker.retain_rooms({e.room_variant for e in events.values()})
    spares = iter(job.spares)
    try:
        for p in job.episodes:
            trim()
            skipped: list[tuple[str, str]] = []
            for event_id in _tries(p, pools, spares):
                ev = events[event_id]
                try:
                    ep = maker.make(p.episode_id, ev, cfg.root_seed, cfg.generate.frames)
                except Skip as s:
                    res.skips[s.reason] += 1
                    res.timings_s.update({f"skipped:{k}": v for k, v in s.timings_s.items()})
                    skipped.append((ev.event_id, s.reason))
                    continue
                clock = time.perf_counter()
                rows.append(row_of(ep, p.split, f"media/{name}.h5", writer.add(ep),
                                   cfg.root_seed, skipped))
                res.timings_s.update(ep.timings_s)
                res.timings_s["writing"] += time.perf_counter() - clock
                break
            else:
                res.skips["episode_dropped"] += 1
                dropped.append([p.episode_id, [list(s) for s in skipped]])
        writer.close(rows, dropped)
    except BaseException:
        writer.abort()
        raise
    res.episodes = len(rows)
    return res


_STATE: dict = {}


def _init(root: str, cfg: BuildConfig, out: str) -> None:
    """A worker's state, made once: the world and the episode maker (modal models, HRTF)."""
    world = load_world(root)
    _STATE.update(world=world, maker=_maker(world, cfg), cfg=cfg, out=Path(out),
                  trim=HeapTrimmer())


def _make_job(world: World, maker: EpisodeMaker, cfg: BuildConfig, job: ShardJob,
              pools: dict[tuple[str, str], list[str]], out: Path,
              trim: Callable[[], bool], stamp: Stamp | None = None) -> ShardResult:
    """One shard, loading only the events it can use (all of a full build's events with
    their contacts would take ~700 MB in every worker)."""
    events = {e.event_id: e for e in load_events(cfg, out, job_event_ids(job, pools))}
    res = make_shard(world, maker, cfg, job, events, pools, out, trim, stamp)
    res.usage = process_usage()
    return res


def compile_ahead(world: World, cfg: BuildConfig, out: Path, job: ShardJob,
                  note: Callable[[str], None] | None = None) -> bool:
    """Compile every Numba function a shard's episodes can reach in a process of its own
    (:meth:`EpisodeMaker.compile_ahead` on ``job``'s first event), unless done before for
    these sources (:func:`fallgen.jitcache.done_marker`); whether it ran. A process that
    compiled them itself kept ~250 MB more at its peak (LLVM's, for the process's life) than
    one that loads them: 1248 instead of 990 MB a worker on the paper-size build."""
    marker = jitcache.done_marker("compiled-ahead-generate")
    if marker is None or marker.exists():
        return False
    if note:
        note("compiling the episodes' functions first, in a process of their own (once for "
             "this version of fallgen, about a minute)")
    list(parallel_map(_ahead, [job.episodes[0].event_id], _init,
                      (str(world.root), cfg, str(out)), 1))
    try:
        marker.touch()
    except OSError:  # a directory Numba can read but not write: compiled ahead each time
        pass
    return True


def _ahead(event_id: str) -> None:
    s = _STATE
    (event,) = load_events(s["cfg"], s["out"], {event_id})
    s["maker"].compile_ahead(event, s["cfg"].root_seed)


def _in_process(world: World, cfg: BuildConfig, jobs: list[ShardJob],
                pools: dict[tuple[str, str], list[str]], out: Path,
                stamps: dict[str, Stamp]) -> Iterator[ShardResult]:
    """The shards made one after another in this process, with one episode maker (its GL
    context closed at the end)."""
    maker, trim = _maker(world, cfg), HeapTrimmer()
    try:
        for job in jobs:
            yield _make_job(world, maker, cfg, job, pools, out, trim, stamps.get(job.name))
    finally:
        maker.close()


def _work(args: tuple[ShardJob, dict[tuple[str, str], list[str]], Stamp | None]
          ) -> ShardResult:
    job, pools, stamp = args
    s = _STATE
    return _make_job(s["world"], s["maker"], s["cfg"], job, pools, s["out"], s["trim"], stamp)


@dataclass(frozen=True)
class Build:
    """What a configuration makes: its events' plan, the shard jobs, the event pools, what
    makes each shard (its :class:`~fallgen.dataset.integrity.Stamp`), the rehearsal files'
    sha256 (by variant) and the inputs every shard shares."""

    jobs: list[ShardJob]
    pools: dict[tuple[str, str], list[str]]
    stamps: dict[str, Stamp] = field(default_factory=dict)
    rehearsal: dict[str, str] = field(default_factory=dict)
    common: dict = field(default_factory=dict)


def verified_rehearsal(world: World, cfg: BuildConfig, out: Path | None = None
                       ) -> dict[str, str]:
    """The rehearsal files of the config's room variants, each checked against what it was
    made from and the bytes written (:func:`fallgen.dataset.integrity.rehearsal_state`):
    variant -> sha256. The first file that is missing, made under other inputs, changed since
    it was written, or of a variant the config does not pick is an InputError naming it
    (FileNotFoundError when there is no rehearsal at all)."""
    d = rehearsal_dir(cfg, out)
    want = [v.id for v in world.variants(cfg.rehearse.rooms)]
    present = sorted(p.stem for p in d.glob("*.parquet"))
    if not present:
        raise FileNotFoundError(f"no rehearsal files in {d}: run `fallgen rehearse` first")
    extra = [v for v in present if v not in want]
    if extra:
        raise InputError(d / f"{extra[0]}.parquet", "rehearse.rooms", "not one of the "
                         f"config's room variants ({cfg.rehearse.rooms!r}); remove it and its "
                         ".stats.json, or build into another --out")
    shas = {}
    for vid in want:
        p = d / f"{vid}.parquet"
        st = integrity.rehearsal_state(p, integrity.rehearsal_stamp(world, cfg, vid))
        if st.status == "missing":
            raise InputError(p, "<file>", "not rehearsed yet: run `fallgen rehearse` (or "
                             "`fallgen build`)")
        if st.status == "stale":
            raise InputError(p.with_suffix(".stats.json"), "fingerprint", "rehearsed under "
                             f"another config, world or fallgen version ({st.reason}); "
                             "`fallgen rehearse --force` rehearses it again (the shards made "
                             "from it are then made again), or build into another --out")
        if st.status == "corrupt":
            raise InputError(p, "<file>", f"{st.reason}; `fallgen rehearse` (or `fallgen "
                             "build`) rehearses it again")
        shas[vid] = integrity.sha256(p)
    return shas


def build_plan(cfg: BuildConfig, out: Path | None = None, world: World | None = None
               ) -> Build:
    """The build's plan from its checked rehearsal files (:func:`verified_rehearsal`), and
    what makes each shard. ``world``: default the built-in data."""
    out = Path(out or cfg.out)
    world = world or load_world()
    shas = verified_rehearsal(world, cfg, out)
    d = rehearsal_dir(cfg, out)
    try:
        refs = event_refs(cfg, out, [d / f"{v}.parquet" for v in shas])
        planned = plan(refs, cfg.generate.episodes, cfg.root_seed)
        spares = spare_events(refs, cfg.generate.episodes, cfg.root_seed)
    except ValueError as e:
        raise InputError(d, "events", f"{e}; rehearse more (rehearse.zones, events_per_zone, "
                         "max_trials_per_zone) or ask for fewer episodes") from None
    jobs = shard_jobs(planned, cfg.generate.episodes_per_shard, spares)
    pools = pools_of(planned)
    common = integrity.build_inputs(world, cfg)
    stamps = {}
    for j in jobs:
        tried = [[p.episode_id, p.split, p.room_kind, _attempts(p, pools)] for p in j.episodes]
        tried.append(["spares", list(j.spares)])
        variants = {event_variant(e) for e in job_event_ids(j, pools)}
        stamps[j.name] = integrity.shard_stamp(world, common, j.name, tried, variants, shas)
    return Build(jobs, pools, stamps, shas, common)


def shard_states(out: Path, b: Build, jobs: list[ShardJob] | None = None
                 ) -> dict[str, integrity.State]:
    """Each shard's state against what the build makes (``ok``: keep it)."""
    return {j.name: integrity.shard_state(out, j.name, b.stamps.get(j.name))
            for j in (b.jobs if jobs is None else jobs)}


def missing_shards(cfg: BuildConfig, out: Path | None = None, b: Build | None = None,
                   world: World | None = None) -> list[str]:
    """The shards of the build that are not there as the build makes them."""
    out = Path(out or cfg.out)
    b = b or build_plan(cfg, out, world)
    return [n for n, st in shard_states(out, b).items() if not st.ok]


def _check_content(out: Path, job: ShardJob, stamp: Stamp) -> None:
    """What a shard's rows say against its plan: columns, episode ids (with the dropped
    ones), its own name and fingerprint; an InputError naming the file otherwise."""
    import h5py

    data, media = integrity.shard_files(out, job.name)
    try:
        t = pq.read_table(data)
        meta = shard_meta(t.schema) or {}
    except Exception as e:  # pyarrow raises several types for a broken file
        raise InputError(data, "<parquet>", f"unreadable ({type(e).__name__})") from None
    empty = t.num_rows == 0 and t.column_names == ["episode_id"]
    if t.column_names != list(COLUMNS) and not empty:
        raise InputError(data, "columns", "not the columns this fallgen writes")
    want = (job.split, job.index, job.count, stamp.fingerprint)
    if (meta.get("split"), meta.get("shard"), meta.get("num_shards"),
            meta.get("fingerprint")) != want:
        raise InputError(data, "fallgen", "its metadata names another shard or fingerprint")
    ids = t["episode_id"].to_pylist() + [d[0] for d in meta.get("dropped", [])]
    if sorted(ids) != [p.episode_id for p in job.episodes]:
        raise InputError(data, "episode_id", "not the episodes the plan gives this shard")
    with h5py.File(media, "r") as f:
        if f.attrs.get("fingerprint") != stamp.fingerprint:
            raise InputError(media, "fingerprint", "not the shard's fingerprint")


def finalize_build(cfg: BuildConfig, out: Path | None = None, b: Build | None = None,
                   world: World | None = None,
                   note: Callable[[str], None] | None = None) -> Path:
    """Write the card and the manifest from the shards once every shard of the build is there
    as the build makes it (after the array jobs of a multi-machine build): each is checked
    (its record, fingerprint and bytes; its columns, episode ids and metadata) before it is
    listed; shards of another plan are removed. Raises FileNotFoundError naming the shards
    missing or not as the build makes them."""
    out = Path(out or cfg.out)
    with integrity.writer_lock(out):
        b = b or build_plan(cfg, out, world)
        integrity.tidy(out, {j.name for j in b.jobs}, note)
        bad = [(n, st) for n, st in shard_states(out, b).items() if not st.ok]
        if bad:
            integrity.unfinalize(out)
            more = f" and {len(bad) - 3} more" if len(bad) > 3 else ""
            raise FileNotFoundError(f"{len(bad)} shards missing or not as this build makes "
                                    "them: " + ", ".join(
                                        n + ("" if st.status == "missing" else
                                             f" ({st.status}: {st.reason})")
                                        for n, st in bad[:3]) + more)
        for j in b.jobs:
            _check_content(out, j, b.stamps[j.name])
        return finalize(out, cfg.file.read_text(), cfg.root_seed,
                        {"generate": dataclasses.asdict(cfg.generate),
                         "rehearse": dataclasses.asdict(cfg.rehearse)},
                        build={"fingerprint": integrity.digest(b.common), "inputs": b.common},
                        hash_of=integrity.file_entry)


def precompute_modes(world: World, cfg: BuildConfig, out: Path | None = None, workers: int = 1,
                     on_done: Callable[[str], None] | None = None) -> int:
    """Solve (and cache) the modal models the build's events ask for that are not cached
    yet: every object of the events (targets, distractors, occluders), the furniture parts
    their falls hit and the rehearsed variants' surface panels (a part hit only because the
    agent stands in the way is solved when first needed). Returns how many were solved."""
    from fallgen.audio.catalog import jobs, missing, precompute

    files = _rehearsal_files(cfg, out)
    objects: set[tuple[str, str, str]] = set()
    parts: set[tuple[str, int]] = set()
    for f in files:
        t = pq.read_table(f, columns=["target", "distractors", "occluders", "contacts"])
        d = t.select(["target", "distractors", "occluders"]).to_pydict()
        specs = d["target"] + [p["object"] for col in ("distractors", "occluders")
                               for row in d[col] for p in row]
        objects.update((o["category"], o["variant"], o["material"]) for o in specs)
        hits = pc.list_flatten(t["contacts"])
        if len(hits):
            parts.update((f.stem, g) for g in
                         pc.unique(pc.struct_field(hits, "geom_other")).to_pylist())
    todo = missing(jobs(world, {f.stem for f in files}, objects, parts))
    if todo:
        precompute(world, workers=workers, on_done=on_done, todo=todo)
    return len(todo)


def generate(world: World, cfg: BuildConfig, out: Path | None = None, workers: int = 1,
             progress: Callable[[ShardResult], None] | None = None, *,
             executor: str = "local", ray_address: str | None = None,
             shard_index: int | None = None, num_shards: int | None = None,
             b: Build | None = None,
             modes_progress: Callable[[str], None] | None = None,
             force: bool = False, note: Callable[[str], None] | None = None
             ) -> list[ShardResult]:
    """Make every shard of the build (or of ``shard_index`` of ``num_shards``) that is not
    there as this build makes it (all of them with ``force``); then, when the whole build is
    there, (re)write the card and the manifest from it. Returns the per-shard results.
    ``workers`` > 1 or ``executor="ray"`` run shards in worker processes. On one machine (local
    executor, no shard index) the modal models the events need are solved first
    (:func:`precompute_modes`; ``modes_progress`` gets each one's label). ``b``: the build's
    plan when the caller has it already (it reads every rehearsal file). ``note`` gets a line
    for each shard made again and each shard removed (of another plan)."""
    out = Path(out or cfg.out)
    part = None if shard_index is None else f"generate-{shard_index}-of-{num_shards}"
    with integrity.writer_lock(out, part):
        b = b or build_plan(cfg, out, world)
        jobs = select_units(b.jobs, shard_index, num_shards)
        if part is None:
            integrity.tidy(out, {j.name for j in b.jobs}, note)
        else:
            integrity.remove_temporaries(out, [j.name for j in jobs])
        states = shard_states(out, b, jobs)
        todo = making_order([j for j in jobs if force or not states[j.name].ok])
        why = {j.name: ("--force" if states[j.name].ok else
                        f"{states[j.name].status}: {states[j.name].reason}") for j in todo
               if states[j.name].status != "missing"}
        if todo:
            integrity.unfinalize(out)  # no longer a finished build until every shard is back
        for name, reason in why.items():
            if note:
                note(f"{name}: made again ({reason})")
            integrity.discard_shard(out, name)
        making = {j.name for j in todo}
        done = [ShardResult(j.name, len(j.episodes), skipped_shard=True) for j in jobs
                if j.name not in making]
        if todo and executor == "local" and shard_index is None:
            # the modal models first, all cores on them: solving them inside the shard
            # workers as first needed cost each worker ~400 MB more at its peak
            precompute_modes(world, cfg, out, workers, on_done=modes_progress)
        if todo and executor == "local":  # this process or its workers then only load them
            compile_ahead(world, cfg, out, todo[0], note)
        if not todo:
            made = iter(done)
        elif executor == "local" and min(workers, len(todo)) <= 1:  # in this process
            made = itertools.chain(done, _in_process(world, cfg, todo, b.pools, out, b.stamps))
        else:
            made = itertools.chain(done, parallel_map(
                _work, [(j, b.pools, b.stamps.get(j.name)) for j in todo], _init,
                (str(world.root), cfg, str(out)), min(workers, len(todo)), executor,
                ray_address))
        results: list[ShardResult] = []
        for r in made:
            r.remade = why.get(r.name, "")
            results.append(r)
            if progress:
                progress(r)
        if part is None and not missing_shards(cfg, out, b):
            finalize_build(cfg, out, b, world, note)
    if part is not None and not missing_shards(cfg, out, b):
        try:  # the last array task finalizes, when no other is still writing
            finalize_build(cfg, out, b, world, note)
        except InputError as e:
            if e.field != "lock":
                raise
    return results


__all__ = ["generate", "shard_jobs", "making_order", "make_shard", "load_events", "event_refs",
           "job_event_ids", "finalize_build", "missing_shards", "build_plan",
           "verified_rehearsal", "shard_states"]
