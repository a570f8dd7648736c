"""The sound commands: ``assets modes`` (every shape's vibration modes, solved and cached) and
``sounds`` (fall events rendered dry and, with ``--binaural``, heard in the room)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from fallgen.cli_common import DataDir, Workers, console, load_world_dir, n_workers
from fallgen.errors import InputError

commands = typer.Typer()
assets = typer.Typer(help="Precomputed assets (modal models).", no_args_is_help=True)
commands.add_typer(assets, name="assets")


def register(app: typer.Typer, *_) -> None:
    """Add these commands to the ``fallgen`` app."""
    app.add_typer(commands)


# --- assets -------------------------------------------------------------------------------------

@assets.command("modes")
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

    world = load_world_dir(data_dir)
    total = len(jobs(world))
    with Progress(TextColumn("modes"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console) as progress:
        task = progress.add_task("", total=total)
        precompute(world, cache_dir=cache_dir, workers=n_workers(workers),
                   on_done=lambda label: progress.update(task, advance=1, description=label))
    console.print(f"{total} modal models in {cache_dir or default_cache_dir()}")


@commands.command()
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
    world = load_world_dir(data_dir)
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
            heard = 20 * np.log10(max(np.abs(clip.pressure_pa()).max(), 1e-12) / 20e-6)
            msg += f"; binaural peak {heard:.0f} dB SPL"
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

