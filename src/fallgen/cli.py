"""The ``fallgen`` command line: a thin layer over the library.

Every command parses its arguments, calls a library function, shows progress or a table, and
maps bad input to a one-line ``error: FILE: FIELD: MESSAGE`` on stderr with exit code 2.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from fallgen import __version__
from fallgen.errors import InputError

app = typer.Typer(
    name="fallgen",
    help="Generate the Fallen Objects audio-visual dataset, offline and deterministically.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
rooms_app = typer.Typer(help="Room variants: list, check, draw, acoustics, export to MJCF.",
                        no_args_is_help=True)
objects_app = typer.Typer(help="Object categories: list, check.", no_args_is_help=True)
materials_app = typer.Typer(help="Object and surface materials.", no_args_is_help=True)
assets_app = typer.Typer(help="Precomputed assets (modal models).", no_args_is_help=True)
app.add_typer(rooms_app, name="rooms")
app.add_typer(assets_app, name="assets")
app.add_typer(objects_app, name="objects")
app.add_typer(materials_app, name="materials")

console = Console()
if not console.is_terminal:  # piped or captured: don't squeeze tables into 80 columns
    console.width = max(console.width, 160)

DataDir = Annotated[
    Optional[Path],
    typer.Option("--data-dir", help="Directory with materials/, objects/, rooms/ "
                 "(default: $FALLGEN_DATA, else the built-in data).", show_default=False),
]


def _version(value: bool) -> None:
    if value:
        import mujoco

        console.print(f"fallgen {__version__} (mujoco {mujoco.__version__})")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Show the version and exit.")] = False,
) -> None:
    """Generate the Fallen Objects audio-visual dataset, offline and deterministically."""


def _world(data_dir: Path | None):
    from fallgen.world.library import load_world

    return load_world(data_dir)


def _variants(world, pattern: str):
    vs = world.variants(pattern)
    if not vs:
        raise InputError("<command line>", "ROOM", f"no room variant matches {pattern!r} "
                         f"(try `fallgen rooms list`)")
    return vs


# --- the two phases and the whole build ----------------------------------------------------------

Config = Annotated[Path, typer.Option("--config", "-c", help="Build config (configs/*.toml).")]
Workers = Annotated[Optional[int], typer.Option(
    min=1, help="Worker processes (default: all cores; 1 runs in this process).",
    show_default=False)]
Out = Annotated[Optional[Path], typer.Option(help="Dataset directory (default: the config's "
                                             "build.out).")]
Executor = Annotated[str, typer.Option(help="'local' (a process pool) or 'ray' (one Ray task "
                                       "per unit; pip install 'fallgen[ray]').")]
RayAddress = Annotated[Optional[str], typer.Option(help="Ray cluster to join (default: start a "
                                                   "local one).")]
ShardIndex = Annotated[Optional[int], typer.Option(
    min=0, help="Run only units I, I+N, ... of the phase (Slurm: $SLURM_ARRAY_TASK_ID, "
    "Kubernetes: $JOB_COMPLETION_INDEX).")]
NumShards = Annotated[Optional[int], typer.Option(min=1, help="N for --shard-index.")]


def _workers(n: int | None) -> int:
    return n if n is not None else (os.cpu_count() or 1)


def _parallel(executor: str, shard_index, num_shards, ray_address: str | None) -> dict:
    """The keyword arguments that say where a phase runs (checked)."""
    from fallgen.pipeline.executor import EXECUTORS

    if executor not in EXECUTORS:
        raise InputError("<command line>", "--executor", f"{executor!r} is not one of "
                         f"{', '.join(EXECUTORS)}")
    if (shard_index is None) != (num_shards is None) or \
            (shard_index is not None and shard_index >= num_shards):
        raise InputError("<command line>", "--shard-index", "needs --num-shards N and "
                         "0 <= I < N")
    return {"executor": executor, "shard_index": shard_index, "num_shards": num_shards,
            "ray_address": ray_address}


def _run_rehearsal(cfg, world, rooms: str | None, workers: int, out: Path | None, force: bool,
                   parallel: dict) -> None:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
        TimeElapsedColumn

    from fallgen.physics.rehearse import rehearsal_dir, rehearse as run, summarize
    from fallgen.pipeline.executor import select_units

    vs = _variants(world, rooms or cfg.rehearse.rooms)
    dest = rehearsal_dir(cfg, out)
    total = len(select_units(vs, parallel["shard_index"], parallel["num_shards"]))
    with Progress(TextColumn("rehearse"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console) as bar:
        task = bar.add_task("", total=total)

        def tick(vid: str, stats: dict | None) -> None:
            note = "skipped (done)" if stats is None else \
                f"{stats['reasons'].get('kept', 0)}/{stats['trials']} kept"
            bar.update(task, advance=1, description=f"{vid}: {note}")

        stats = run(world, cfg, [v.id for v in vs], out=dest, workers=workers, force=force,
                    progress=tick, note=_note, **parallel)
    totals = summarize(stats)
    for title, table in (("zone kind", totals["zone_kind"]), ("category", totals["category"])):
        t = Table(title=f"rehearsal by {title}")
        for col in (title, "trials", "kept", "rate", "main rejections"):
            t.add_column(col)
        for key, c in sorted(table.items()):
            n = sum(c.values())
            rej = ", ".join(f"{r} {k}" for r, k in c.most_common() if r != "kept")[:60]
            t.add_row(key, str(n), str(c["kept"]), f"{c['kept'] / n:.0%}", rej)
        console.print(t)
    n = sum(s.trials for s in stats)
    k = sum(s.reasons["kept"] for s in stats)
    console.print(f"{k} events kept of {n} trials in {len(stats)} variants -> {dest}")
    _print_usage("rehearsal", [s.usage for s in stats])


def _note(line: str) -> None:
    console.print(line, markup=False, highlight=False, soft_wrap=True)


def _print_usage(phase: str, usages: list) -> None:
    """One line: the peak resident memory and CPU time of each process that did the phase's
    work in this run (a worker, or this process when it worked alone)."""
    from fallgen.pipeline.executor import per_process

    procs = per_process(usages)
    if procs:
        console.print(f"{phase}: {len(procs)} process{'es' if len(procs) > 1 else ''}, "
                      "peak memory " + ", ".join(f"{u.peak_rss_mb:.0f}" for u in procs)
                      + " MB, CPU " + ", ".join(f"{u.cpu_s:.0f}" for u in procs) + " s")


def _run_generation(cfg, config: Path, world, workers: int, out: Path | None,
                    parallel: dict, force: bool = False) -> None:
    from collections import Counter

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
        TimeElapsedColumn

    from fallgen.pipeline.executor import select_units
    from fallgen.pipeline.generate import build_plan, generate as run, missing_shards

    try:
        b = build_plan(cfg, out, world)
    except FileNotFoundError as e:
        raise InputError(config, "build.out", str(e)) from None
    n_shards = len(select_units(b.jobs, parallel["shard_index"], parallel["num_shards"]))
    skips: Counter = Counter()
    timings: Counter = Counter()
    usages: list = []
    made = 0
    with Progress(TextColumn("generate"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console) as bar:
        task = bar.add_task("", total=n_shards)

        def tick(r) -> None:
            nonlocal made
            made += r.episodes
            skips.update(r.skips)
            timings.update(r.timings_s)
            usages.append(r.usage)
            bar.update(task, advance=1, description=f"{r.name}: " + (
                "done before" if r.skipped_shard else f"{r.episodes} episodes"))

        run(world, cfg, out, workers=workers, progress=tick, b=b,
            modes_progress=lambda label: bar.update(task, description=f"modal model {label}"),
            force=force, note=_note, **parallel)
    dest = out or cfg.out
    size = sum(p.stat().st_size for d in ("data", "media") for p in (dest / d).glob("*")
               if p.is_file())
    console.print(f"{made} episodes in {n_shards} shards -> {dest}/data, {dest}/media: "
                  f"{size / 1e6:.1f} MB, {size / max(made, 1) / 1e3:.0f} kB per episode")
    left = missing_shards(cfg, dest, b)
    console.print(f"card {dest}/README.md, manifest {dest}/manifest.json" if not left else
                  f"{len(left)} shards of the build still missing (other shard indices); "
                  f"`fallgen finalize -c {config}` once they exist")
    if skips:
        console.print("events skipped: " + ", ".join(f"{k} {v}" for k, v in skips.most_common()))
    total = sum(timings.values())
    if total:
        console.print("time by stage: " + ", ".join(
            f"{k} {v:.1f} s ({v / total:.0%})" for k, v in timings.most_common()))
    _print_usage("generation", usages)


def _preflight(cfg, world, out: Path | None, build: bool = True) -> None:
    """Every check of the config, the world and the output directory, before any work."""
    from fallgen.dataset.integrity import preflight

    preflight(cfg, world, out, build)


def _config(config: Path, frames: str | None = None):
    import dataclasses

    from fallgen.config import load_config

    cfg = load_config(config)
    if frames is not None:
        if frames not in ("first", "trajectory"):
            raise InputError("<command line>", "--frames", "must be 'first' or 'trajectory'")
        cfg = dataclasses.replace(cfg, generate=dataclasses.replace(cfg.generate, frames=frames))
    return cfg


@app.command()
def rehearse(
    config: Config,
    rooms: Annotated[Optional[str], typer.Option(help="Glob(s) over variant ids, comma-separated "
                                                 "(default: the config's).")] = None,
    workers: Workers = None,
    out: Out = None,
    force: Annotated[bool, typer.Option(help="Redo variants that are already done.")] = False,
    executor: Executor = "local",
    ray_address: RayAddress = None,
    shard_index: ShardIndex = None,
    num_shards: NumShards = None,
    data_dir: DataDir = None,
) -> None:
    """Rehearsal phase: drop objects into every fall zone, keep those that settle inside it
    (one Parquet file per room variant; variants already done are kept)."""
    parallel = _parallel(executor, shard_index, num_shards, ray_address)
    cfg, world = _config(config), _world(data_dir)
    _preflight(cfg, world, out, build=False)
    _run_rehearsal(cfg, world, rooms, _workers(workers), out, force, parallel)


@app.command()
def generate(
    config: Config,
    workers: Workers = None,
    out: Out = None,
    frames: Annotated[Optional[str], typer.Option(
        help="'first' (the view at step 0) or 'trajectory' (also after every expert action); "
             "default: the config's.")] = None,
    executor: Executor = "local",
    ray_address: RayAddress = None,
    shard_index: ShardIndex = None,
    num_shards: NumShards = None,
    data_dir: DataDir = None,
    force: Annotated[bool, typer.Option(help="Make every shard (of this run) again.")] = False,
) -> None:
    """Generation phase: rehearsed falls -> episodes (spawn, binaural audio, first view, maps,
    expert trajectory), written as Parquet + HDF5 shards; shards that are what this build makes
    are kept (resume), any other is made again. The card and manifest are written when the
    last shard of the build exists."""
    parallel = _parallel(executor, shard_index, num_shards, ray_address)
    cfg, world = _config(config, frames), _world(data_dir)
    _preflight(cfg, world, out)
    _run_generation(cfg, config, world, _workers(workers), out, parallel, force)


@app.command()
def build(
    config: Config,
    workers: Workers = None,
    out: Out = None,
    executor: Executor = "local",
    ray_address: RayAddress = None,
    data_dir: DataDir = None,
) -> None:
    """Both phases on this machine (or a Ray cluster): rehearse every room variant of the
    config, then generate every shard, card and manifest. Reruns resume."""
    from fallgen.dataset.integrity import writer_lock

    parallel = _parallel(executor, None, None, ray_address)
    cfg, world = _config(config), _world(data_dir)
    _preflight(cfg, world, out)
    with writer_lock(out or cfg.out):
        _run_rehearsal(cfg, world, None, _workers(workers), out, False, parallel)
        _run_generation(cfg, config, world, _workers(workers), out, parallel)


@app.command()
def finalize(
    config: Config,
    out: Out = None,
    data_dir: DataDir = None,
) -> None:
    """Write the dataset card and manifest once every shard exists and checks (after a
    multi-machine build with --shard-index); exit 2 naming the missing shards otherwise."""
    from fallgen.pipeline.generate import finalize_build

    cfg = _config(config)
    try:
        path = finalize_build(cfg, out, world=_world(data_dir), note=_note)
    except FileNotFoundError as e:
        raise InputError(out or cfg.out, "data/", str(e)) from None
    console.print(f"{path.parent / 'README.md'}, {path}")


@app.command()
def validate(
    dataset: Annotated[Path, typer.Argument(help="A dataset directory (what generate wrote).")],
) -> None:
    """Check a dataset: checksums vs the manifest, shards, schemas, counts, media shapes and
    values, split disjointness, fall events. Exit 1 with the list of problems."""
    from fallgen.dataset.validate import validate as check

    problems = check(dataset)
    for p in problems:
        console.print(p, markup=False, soft_wrap=True)
    if problems:
        console.print(f"{len(problems)} problem(s) in {dataset}")
        raise typer.Exit(1)
    console.print(f"{dataset}: valid")


def _open(dataset: Path):
    import fallgen.dataset

    try:
        return fallgen.dataset.open(dataset)
    except FileNotFoundError as e:
        raise InputError(dataset, "data/", str(e).split(": ", 1)[-1]) from None


@app.command()
def show(
    dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
    episode: Annotated[int, typer.Argument(help="Episode id.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG to write.")] = Path("episode.png"),
    wav: Annotated[Optional[Path], typer.Option(help="Also write the binaural audio (stereo "
                                                "float WAV, ear pressure / 20 Pa).")] = None,
    data_dir: DataDir = None,
) -> None:
    """One picture of an episode: RGB, depth, segmentation, the room from above with the zone,
    object, spawn and expert path, and both ears' spectrograms."""
    from fallgen.dataset.show import show as draw

    ds = _open(dataset)
    try:
        path = draw(ds, episode, _world(data_dir), out, wav)
    except KeyError as e:
        raise InputError(dataset, "EPISODE", str(e).strip("'\"")) from None
    console.print(f"{path}" + (f", {wav}" if wav else ""))


@app.command()
def stats(
    dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
    json_out: Annotated[Optional[Path], typer.Option("--json", help="Also write the numbers "
                                                     "as JSON.")] = None,
) -> None:
    """Counts by split, room kind, category, material and zone kind; expert lengths; audio
    levels; and how the episodes' zone kinds compare with the rehearsed events'."""
    import json

    from fallgen.atomic import write_text
    from fallgen.dataset.stats import stats as compute, verdict

    s = compute(_open(dataset).root)
    console.print(f"{dataset}: {s['episodes']} episodes in {s['room_variants']} room variants, "
                  f"{s['dropped_episodes']} planned episodes dropped")
    t = Table("split", *sorted({k for v in s["by_split"].values() for k in v}), "total")
    kinds = t.columns[1:-1]
    for split, by in s["by_split"].items():
        t.add_row(split, *[str(by.get(str(c.header), 0)) for c in kinds], str(sum(by.values())))
    console.print(t)
    for key in ("category", "audio_material"):
        c = s[f"by_{key}"]
        console.print(f"{key} ({len(c)}): " + ", ".join(f"{k} {v}" for k, v in c.items()))
    e = s["expert"]
    console.print(f"expert: {e['actions']['mean']:.1f} actions on average (median "
                  f"{e['actions']['p50']:.0f}, max {e['actions']['max']:.0f}), path "
                  f"{e['path_m']['mean']:.2f} m on average; {e['episodes_that_look_up_or_down']}"
                  " episodes look up or down")
    for name, a in s["audio_db_spl"].items():
        if "n" in a:
            console.print(f"audio {name} dB SPL: " + ", ".join(
                f"{q} {a[q]:.1f}" for q in ("min", "p5", "p50", "p95", "max")))
    console.print("audio leq_125ms histogram (dB SPL: episodes): " + ", ".join(
        f"{k}: {v}" for k, v in s["audio_db_spl"]["leq_125ms_histogram"].items()))
    if s.get("audio_energy_by_material"):
        console.print("radiated / lost energy, median by audio material (median, max peak dB "
                      "SPL): " + ", ".join(
                          f"{k} {m['energy_ratio_p50']:.1e} ({m['peak_db_spl_p50']:.0f}, "
                          f"{m['peak_db_spl_max']:.0f})"
                          for k, m in s["audio_energy_by_material"].items()))
    if s.get("room_rt60_s"):
        r = s["room_rt60_s"]
        console.print(f"room RT60 over {r['variants']} variants, s (min / median / max): " +
                      ", ".join(f"{k} Hz {b['min']:.2f} / {b['p50']:.2f} / {b['max']:.2f}"
                                for k, b in r["by_band"].items()))
    t = Table("zone kind", "rehearsed", "share of events", "share of episodes", "ratio",
              "events skipped", "skip rate")
    for k, b in s["bias"].items():
        t.add_row(k, str(b["rehearsed_events"]), f"{b['rehearsed_share']:.1%}",
                  f"{b['episode_share']:.1%}", "-" if b["ratio"] is None else f"{b['ratio']:.2f}",
                  str(b["events_skipped"]),
                  "-" if b["skip_rate"] is None else f"{b['skip_rate']:.0%}")
    console.print(t)
    console.print(f"skips: {s['skips_by_reason'] or 'none'}; episodes on a fallback event: "
                  f"{s['episodes_on_a_fallback_event']}; spawns that already see the object: "
                  f"{s['spawn_sees_object']}")
    t = Table("goal", "measured", "bound", "met")
    for name, g in s["goals"].items():
        v = g["value"]
        shown = "-" if v is None else f"{v:.3g}" if isinstance(v, float) else \
            ", ".join(f"{x:.1f}" for x in v) if isinstance(v, list) else \
            ", ".join(f"{k} {x:+.1f}" for k, x in v.items()) if isinstance(v, dict) else str(v)
        t.add_row(name, shown, g["bound"], verdict(g))
    console.print(t)
    if json_out:
        write_text(json_out, json.dumps(s, indent=1) + "\n")
        console.print(f"{json_out}")


# --- rooms --------------------------------------------------------------------------------------

@rooms_app.command("list")
def rooms_list(
    pattern: Annotated[str, typer.Argument(help="Glob over variant or room ids.")] = "*",
    data_dir: DataDir = None,
) -> None:
    """List room variants: id, kind, size, furniture and zones."""
    world = _world(data_dir)
    t = Table(title=f"room variants ({world.root})")
    for col in ("id", "kind", "size (m)", "furniture", "zones", "floor", "walls"):
        t.add_column(col)
    vs = _variants(world, pattern)
    for v in vs:
        t.add_row(v.id, v.kind, " x ".join(f"{x:g}" for x in v.size_m), str(len(v.furniture)),
                  str(len(v.zones)), v.surfaces["floor"].name, v.surfaces["north"].name)
    console.print(t)
    kinds = {k: sum(v.kind == k for v in vs) for k in sorted({v.kind for v in vs})}
    console.print(f"{len(vs)} variants: " + ", ".join(f"{n} {k}" for k, n in kinds.items()))


@rooms_app.command("check")
def rooms_check(
    pattern: Annotated[str, typer.Argument(help="Glob over variant or room ids.")] = "*",
    data_dir: DataDir = None,
) -> None:
    """Check layouts geometrically (intersections, zone supports, navigability); exit 1 on problems."""
    from fallgen.world.validate import check_variant

    world = _world(data_dir)
    bad = 0
    for v in _variants(world, pattern):
        problems = check_variant(v)
        for p in problems:
            console.print(f"[red]{v.id}[/red]: {p}", highlight=False)
        bad += bool(problems)
    if bad:
        console.print(f"{bad} variant(s) with problems")
        raise typer.Exit(1)
    console.print("all variants ok")


@rooms_app.command("show")
def rooms_show(
    room: Annotated[str, typer.Argument(help="Variant id (or a glob; then -o is a directory).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="PNG file, or directory for a glob.")],
    data_dir: DataDir = None,
) -> None:
    """Draw a top-down plan of a variant with furniture and numbered fall zones."""
    from fallgen.world.preview import draw_variant, write_png

    world = _world(data_dir)
    vs = _variants(world, room)
    if len(vs) == 1 and out.suffix.lower() == ".png":
        targets = [(vs[0], out)]
    elif out.suffix:
        raise InputError("<command line>", "--out", f"{room!r} matches {len(vs)} variants: "
                         "give a directory, not a file")
    else:
        targets = [(v, out / f"{v.id}.png") for v in vs]
    images = [(draw_variant(v), p) for v, p in targets]  # draw everything before writing
    for img, p in images:
        write_png(img, p)
        console.print(f"wrote {p}")


def _acoustics_table(r) -> Table:
    """One variant's acoustics (:class:`fallgen.audio.acoustics.RoomReport`) as a table."""
    t = Table(title=f"{r.variant}: V {r.volume_m3:.1f} m^3, S {r.surface_m2:.1f} m^2 "
              f"({r.furniture_parts} furniture parts, {r.furniture_area_m2:.1f} m^2), "
              f"mean free path {r.mean_free_path_m:.2f} m")
    t.add_column("")
    for fc in r.bands_hz:
        t.add_column(f"{fc:g} Hz", justify="right")
    rows = [("RT60 model (Arau-Puchades), s", r.rt60_s), ("T30 rendered, s", r.t30_s),
            ("Eyring, s", r.eyring_s), ("Sabine, s", r.sabine_s),
            ("Fitzroy, s", r.fitzroy_s), ("bare room (Eyring), s", r.bare_eyring_s)]
    if r.raytrace_t30_s is not None:
        rows[2:2] = [("T30 ray tracer, s", r.raytrace_t30_s),
                     ("T20 ray tracer, s", r.raytrace_t20_s),
                     ("ray tracer T30 / model", r.rays_over_model)]
    rows += [("absorption area, m^2", r.absorption_area_m2),
             ("  of it furniture, m^2", r.furniture_absorption_m2)]
    for name, vals in rows:
        t.add_row(name, *[f"{x:.2f}" for x in vals])
    return t


def _acoustics_summary(reports, raytrace: bool) -> Table:
    """Many variants' acoustics, a row each."""
    t = Table(title=f"{len(reports)} variants: RT60 of the furnished room (model) and T30 "
              "of a rendered response, s")
    rays = ("rays T30 500 Hz-1 kHz", "rays T20", "rays / model") if raytrace else ()
    for col in ("variant", "V m^3", "mean free path m", "125 Hz", "500 Hz", "1 kHz",
                "4 kHz", "T30 500 Hz-1 kHz") + rays:
        t.add_column(col, justify="left" if col == "variant" else "right")
    for r in reports:
        row = [r.variant, f"{r.volume_m3:.1f}", f"{r.mean_free_path_m:.2f}",
               *[f"{r.rt60_s[b]:.2f}" for b in (0, 2, 3, 5)],
               f"{r.t30_s[2:4].mean():.2f}"]
        if raytrace:
            row += [f"{r.raytrace_t30_s[2:4].mean():.2f}", f"{r.raytrace_t20_s[2:4].mean():.2f}",
                    f"{r.rays_over_model[2:4].mean():.2f}"]
        t.add_row(*row)
    return t


@rooms_app.command("acoustics")
def rooms_acoustics(
    room: Annotated[str, typer.Argument(help="Variant id (or a glob).")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON (one object per variant; "
                                          "rt60_s: 7 values, 125 Hz to 8 kHz).")] = False,
    out: Annotated[Optional[Path], typer.Option(
        "-o", "--out", help="PNG of the decay curves (a directory for a glob).")] = None,
    raytrace: Annotated[bool, typer.Option(
        "--raytrace", help="Also trace rays through the furnished room, the reference (one "
        "variant: every band, ~1-4 min; several: 500 Hz and 1 kHz, ~5-70 s each) and judge "
        "the RT60 goal on them.")] = False,
    data_dir: DataDir = None,
) -> None:
    """A variant's furnished acoustics: RT60 per octave band (the renderer's model beside
    Eyring, Sabine, Fitzroy and the bare room) and T30 measured on a rendered response, the
    mean free path, the absorption; a PNG of the decay curves. With --raytrace the ray
    tracer's T30 and T20 beside them, their ratio to the model, and the RT60 goal's verdict
    on the rays."""
    import json

    from fallgen.audio.acoustics import MID_BANDS, decay_png, rays_goal_line, room_report

    world = _world(data_dir)
    vs = _variants(world, room)
    if out is not None and len(vs) > 1 and out.suffix:
        raise InputError("<command line>", "--out", f"{room!r} matches {len(vs)} variants: "
                         "give a directory, not a file")
    reports = [room_report(v, world.materials, raytrace=raytrace,
                           bands=None if len(vs) == 1 else MID_BANDS) for v in vs]
    for r in reports:
        if out is not None:
            decay_png(out if len(vs) == 1 and out.suffix else out / f"{r.variant}.png", r)
        if as_json:
            print(json.dumps(r.as_dict()))
    if len(reports) > 1 and not as_json:  # one row per variant
        console.print(_acoustics_summary(reports, raytrace))
    if len(reports) == 1 and not as_json:
        console.print(_acoustics_table(reports[0]))
    if raytrace and not as_json:
        console.print(rays_goal_line(reports))
    if out is not None and not as_json:
        console.print(f"wrote {len(reports)} PNG(s) under {out}")


@rooms_app.command("export")
def rooms_export(
    room: Annotated[str, typer.Argument(help="Variant id, e.g. kitchen_galley-l1-m1.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="MJCF file to write.")],
    data_dir: DataDir = None,
) -> None:
    """Write a variant as MJCF that MuJoCo's viewer loads (python -m mujoco.viewer --mjcf=FILE)."""
    from fallgen.atomic import write_text
    from fallgen.world.scene import to_mjcf

    world = _world(data_dir)
    vs = _variants(world, room)
    if len(vs) != 1:
        raise InputError("<command line>", "ROOM", f"{room!r} matches {len(vs)} variants; "
                         "export takes exactly one")
    write_text(out, to_mjcf(vs[0], world.materials))
    console.print(f"wrote {out}")


# --- objects ------------------------------------------------------------------------------------

@objects_app.command("list")
def objects_list(
    role: Annotated[Optional[str], typer.Option(help="target or occluder")] = None,
    data_dir: DataDir = None,
) -> None:
    """List object categories with their variants, materials, sizes and masses."""
    world = _world(data_dir)
    lib = world.categories
    t = Table(title="object categories")
    for col in ("category", "role", "variant", "materials", "size (mm)", "mass (g)"):
        t.add_column(col)
    for cat in lib:
        if role and cat.role != role:
            continue
        for v in cat.variants:
            g = lib.geometry(cat.id, v.name)
            masses = [lib.instance(cat.id, v.name, m).mass_kg * 1000 for m in v.materials]
            size = " x ".join(f"{x * 1000:.0f}" for x in sorted(g.extents, reverse=True))
            mass = f"{min(masses):.1f}" if len(masses) == 1 else \
                f"{min(masses):.1f}-{max(masses):.1f}"
            t.add_row(cat.id, cat.role, v.name, ", ".join(v.materials), size, mass)
    console.print(t)
    console.print(f"{len(lib.ids('target'))} target categories, "
                  f"{len(lib.ids('occluder'))} occluders")


@objects_app.command("show")
def objects_show(
    out: Annotated[Path, typer.Option("-o", "--out", help="PNG file to write.")],
    category: Annotated[Optional[list[str]], typer.Argument(help="Categories (default: all).")]
    = None,
    cols: Annotated[int, typer.Option(min=1, max=20, help="Tiles per row.")] = 8,
    data_dir: DataDir = None,
) -> None:
    """Render a contact sheet of object variants (needs headless GL: MUJOCO_GL=egl or osmesa)."""
    from fallgen.world.gallery import contact_sheet
    from fallgen.world.preview import write_png

    world = _world(data_dir)
    for c in category or []:
        if c not in world.categories:
            raise InputError("<command line>", "CATEGORY", f"unknown category {c!r}")
    write_png(contact_sheet(world.categories, category or None, cols), out)
    console.print(f"wrote {out}")


# --- materials ----------------------------------------------------------------------------------

@materials_app.command("list")
def materials_list(data_dir: DataDir = None) -> None:
    """List object materials (physical and modal constants) and surface materials (absorption)."""
    from fallgen.world.materials import OCTAVE_BANDS_HZ, load_materials
    from fallgen.paths import data_root

    mats = load_materials(data_root(data_dir) / "materials")
    t = Table(title="object materials")
    for col in ("name", "audio", "rho kg/m3", "E GPa", "nu", "eta", "friction", "solref"):
        t.add_column(col)
    for m in mats.objects.values():
        t.add_row(m.name, m.audio, f"{m.density_kg_m3:g}", f"{m.youngs_modulus_pa / 1e9:.3g}",
                  f"{m.poisson_ratio:g}", f"{m.loss_factor:g}", f"{m.friction_sliding:g}",
                  f"{m.contact_timeconst_s:g}/{m.contact_dampratio:g}")
    console.print(t)
    t = Table(title="surface materials: absorption per octave band")
    for col in ("name", *(f"{int(b)}" for b in OCTAVE_BANDS_HZ), "sounds like", "uses"):
        t.add_column(col)
    for s in mats.surfaces.values():
        t.add_row(s.name, *(f"{a:.2f}" for a in s.absorption), s.impact_material,
                  ",".join(s.uses))
    console.print(t)


# --- assets -------------------------------------------------------------------------------------

@assets_app.command("modes")
def assets_modes(
    workers: Workers = None,
    cache_dir: Annotated[Optional[Path], typer.Option(
        "--cache-dir", help="Modal cache (default: $FALLGEN_CACHE/modes or "
        "~/.cache/fallgen/modes).", show_default=False)] = None,
    data_dir: DataDir = None,
) -> None:
    """Solve and cache the vibration modes of every object shape, furniture part and floor or
    wall panel a build can need (each once; cached ones are skipped)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
        TimeElapsedColumn

    from fallgen.audio.catalog import jobs, precompute
    from fallgen.audio.modes import default_cache_dir

    world = _world(data_dir)
    total = len(jobs(world))
    with Progress(TextColumn("modes"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console) as progress:
        task = progress.add_task("", total=total)
        precompute(world, cache_dir=cache_dir, workers=_workers(workers),
                   on_done=lambda label: progress.update(task, advance=1, description=label))
    console.print(f"{total} modal models in {cache_dir or default_cache_dir()}")


@app.command()
def sounds(
    events: Annotated[Path, typer.Argument(help="A rehearsal Parquet file (fall events).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Directory for WAV and PNG files.")],
    limit: Annotated[int, typer.Option(min=1, help="How many events (from the first).")] = 3,
    seed: Annotated[int, typer.Option(help="Seed of the scrape/roll texture.")] = 0,
    binaural: Annotated[bool, typer.Option(
        help="Also render what a listener in the room hears (2-channel WAV, pressure / 20 Pa, "
             "and a spectrogram of the left ear).")] = False,
    listener: Annotated[str, typer.Option(
        help="Listener X,Y,Z (m, room frame) or 'centre': the room centre at 1.2 m, facing "
             "the object's resting place.")] = "centre",
    hrtf: Annotated[str, typer.Option(
        help="The head heard with: sadie_ku100 (measured), sphere (the spherical-head "
             "model) or a SOFA file (SimpleFreeFieldHRIR).")] = "sadie_ku100",
    data_dir: DataDir = None,
) -> None:
    """Render the dry (anechoic) sound of fall events: a float32 WAV in pascals at 1 m and a
    spectrogram PNG per event; with --binaural also the sound in the room at a listener's
    ears (image sources, late reverb, HRTF)."""
    from fallgen.audio.fall import FallRenderer
    from fallgen.audio.preview import spectrogram_png, write_wav
    from fallgen.physics.rehearse import read_events

    if not events.is_file():
        raise InputError(events, "<file>", "no such rehearsal file")
    try:
        evs = read_events(events)[:limit]
    except Exception as e:  # pyarrow raises several types for a bad file
        raise InputError(events, "<parquet>", f"not a fall-event file ({type(e).__name__})")
    world = _world(data_dir)
    r = FallRenderer(world)
    import numpy as np

    from fallgen.audio import mix as mix_mod
    from fallgen.audio.heads import load_hrtf
    from fallgen.audio.room import RirSettings, RoomAcoustics

    head_pos = _listener(listener)
    ears = None
    if binaural:
        ears = mix_mod.Binaural(load_hrtf(hrtf, r.s.sample_rate))
    for i, e in enumerate(evs):
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i,)))
        sources = r.render_sources(e, rng)
        p = np.sum([s.signal for s in sources], axis=0)
        stem = e.event_id.replace("/", "_")
        write_wav(out / f"{stem}.wav", p, r.s.sample_rate)
        spectrogram_png(out / f"{stem}.png", p, r.s.sample_rate,
                        f"{e.target.category} ({e.target.material}) in {e.zone_kind}")
        peak_db = 20 * np.log10(max(np.abs(p).max(), 1e-12) / 20e-6)
        msg = f"{stem}: {e.target.category}, {len(e.contacts)} contacts, " \
              f"peak {peak_db:.0f} dB SPL at 1 m"
        if ears is not None:
            room = RoomAcoustics.furnished(world.variant(e.room_variant), world.materials)
            pos = np.asarray(head_pos if head_pos is not None else
                             (*(np.asarray(room.size_m[:2]) / 2), 1.2), float)
            to = np.asarray(e.settle_pos, float) - pos
            head = mix_mod.Listener(pos, yaw_rad=float(np.arctan2(to[1], to[0])))
            clip = ears.mix(room, sources, head, np.random.default_rng(
                np.random.SeedSequence(seed, spawn_key=(i, 1))),
                RirSettings(sample_rate=r.s.sample_rate, length_s=r.s.length_s))
            mix_mod.write_wav(out / f"{stem}.binaural.wav", clip)
            spectrogram_png(out / f"{stem}.binaural.png", clip.pressure_pa()[0],
                            r.s.sample_rate, f"left ear at {np.round(pos, 2).tolist()}")
            msg += f"; binaural peak {20 * np.log10(max(np.abs(clip.pressure_pa()).max(), 1e-12) / 20e-6):.0f} dB SPL"
        console.print(msg)
    console.print(f"wrote {len(evs)} sounds to {out}")


def _listener(text: str):
    """'centre' -> None; 'X,Y,Z' -> (3,) floats (one-line error otherwise)."""
    if text == "centre":
        return None
    try:
        xyz = [float(v) for v in text.split(",")]
    except ValueError:
        xyz = []
    if len(xyz) != 3:
        raise typer.BadParameter("--listener must be 'centre' or X,Y,Z in metres")
    return xyz


# --- the benchmark: evaluate, export-expert (cli_benchmark.py) ---------------------------------

def _register_benchmark() -> None:
    from fallgen import cli_benchmark

    cli_benchmark.register(app, console)


_register_benchmark()


# --- entry point --------------------------------------------------------------------------------

def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: one-line errors and exit code 2 for bad input.

    Typer handles usage errors (exit 2) and ``--help`` itself; a data-file problem surfaces as
    an ``InputError`` from the library and is printed here as one line.
    """
    try:
        app(args=argv, prog_name="fallgen")
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    except Exception as e:  # a full disk, an unwritable directory, a corrupt file: one line
        from fallgen.dataset.integrity import one_line

        line = one_line(e)
        if line is None:
            raise
        print(f"error: {line}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
