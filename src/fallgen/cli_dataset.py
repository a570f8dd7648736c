"""The dataset commands: ``validate``, ``show`` (one episode drawn) and ``stats``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from fallgen.cli_common import DataDir, console, load_world_dir, open_dataset
from fallgen.errors import InputError

commands = typer.Typer()


def register(app: typer.Typer, *_) -> None:
    """Add these commands to the ``fallgen`` app."""
    app.add_typer(commands)


@commands.command()
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


@commands.command()
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

    ds = open_dataset(dataset)
    try:
        path = draw(ds, episode, load_world_dir(data_dir), out, wav)
    except KeyError as e:
        raise InputError(dataset, "EPISODE", str(e).strip("'\"")) from None
    console.print(f"{path}" + (f", {wav}" if wav else ""))


@commands.command()
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

    s = compute(open_dataset(dataset).root)
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
                  f"{s['episodes_on_a_fallback_event']}; distinct falls: {s['distinct_falls']} "
                  f"({s['episodes_sharing_a_fall']} episodes share one); spawns that already "
                  f"see the object: {s['spawn_sees_object']}")
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

