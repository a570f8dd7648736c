"""The build commands: ``rehearse`` and ``generate`` (the two phases), ``build`` (both),
``finalize`` (the card and manifest of a build made on many machines)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from fallgen.cli_common import DataDir, Workers, console, load_world_dir, n_workers, note, variants
from fallgen.errors import InputError

commands = typer.Typer()


def register(app: typer.Typer, *_) -> None:
    """Add these commands to the ``fallgen`` app."""
    app.add_typer(commands)


Config = Annotated[Path, typer.Option("--config", "-c", help="Build config (configs/*.toml).")]
Out = Annotated[Optional[Path], typer.Option(help="Dataset directory (default: the config's "
                                             "build.out).")]
Executor = Annotated[str, typer.Option(help="'local' (a process pool) or 'ray' (one Ray task "
                                       "per unit; pip install 'fallgen\\[ray]').")]
RayAddress = Annotated[Optional[str], typer.Option(help="Ray cluster to join (default: start a "
                                                   "local one).")]
ShardIndex = Annotated[Optional[int], typer.Option(
    min=0, help="Run only units I, I+N, ... of the phase (Slurm: $SLURM_ARRAY_TASK_ID, "
    "Kubernetes: $JOB_COMPLETION_INDEX).")]
NumShards = Annotated[Optional[int], typer.Option(min=1, help="N for --shard-index.")]


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

    vs = variants(world, rooms or cfg.rehearse.rooms)
    dest = rehearsal_dir(cfg, out)
    total = len(select_units(vs, parallel["shard_index"], parallel["num_shards"]))
    with Progress(TextColumn("rehearse"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console) as bar:
        task = bar.add_task("", total=total)

        def tick(vid: str, stats: dict | None) -> None:
            done = "skipped (done)" if stats is None else \
                f"{stats['reasons'].get('kept', 0)}/{stats['trials']} kept"
            bar.update(task, advance=1, description=f"{vid}: {done}")

        stats = run(world, cfg, [v.id for v in vs], out=dest, workers=workers, force=force,
                    progress=tick, note=note, **parallel)
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
            force=force, note=note, **parallel)
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


@commands.command()
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
    cfg, world = _config(config), load_world_dir(data_dir)
    _preflight(cfg, world, out, build=False)
    _run_rehearsal(cfg, world, rooms, n_workers(workers), out, force, parallel)


@commands.command()
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
    cfg, world = _config(config, frames), load_world_dir(data_dir)
    _preflight(cfg, world, out)
    _run_generation(cfg, config, world, n_workers(workers), out, parallel, force)


@commands.command()
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
    cfg, world = _config(config), load_world_dir(data_dir)
    _preflight(cfg, world, out)
    with writer_lock(out or cfg.out):
        _run_rehearsal(cfg, world, None, n_workers(workers), out, False, parallel)
        _run_generation(cfg, config, world, n_workers(workers), out, parallel)


@commands.command()
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
        path = finalize_build(cfg, out, world=load_world_dir(data_dir), note=note)
    except FileNotFoundError as e:
        raise InputError(out or cfg.out, "data/", str(e)) from None
    console.print(f"{path.parent / 'README.md'}, {path}")

