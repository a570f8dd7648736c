"""``fallgen vision-model train`` / ``eval``: the visual perception module
(:mod:`fallgen.learn`), registered on the main app by :mod:`fallgen.cli_benchmark`."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from fallgen.errors import InputError

DEVICE_HELP = "cpu (default) or cuda (when present)."


def open_dataset(dataset: Path):
    from fallgen.dataset.reader import Dataset

    try:
        return Dataset(dataset)
    except FileNotFoundError as e:
        raise InputError(dataset, "data/", str(e).split(": ", 1)[-1]) from None


def split_rows(ds, split: str, room_kind: str | None = None, option: str = "--split"
               ) -> list[dict]:
    if split not in ds.splits:
        raise InputError("<command line>", option, f"{split!r}: the dataset has "
                         f"{', '.join(ds.splits) or 'no split'}")
    rows = ds.rows(split, room_kind)
    if not rows:
        raise InputError("<command line>", "--room-kind", f"no {room_kind} episode in the "
                         f"{split} split")
    return rows


def load_model(path: Path, ds=None):
    """The vision model in ``path`` checked against ``ds`` (one-line refusals)."""
    try:
        from fallgen.learn.vision_model import VisionModel
    except ImportError as e:
        raise InputError("<command line>", "--vision-model", str(e)) from None
    model = VisionModel.load(path)
    if ds is not None:
        model.check_dataset(ds, path)
    return model


def device_name(device: str) -> str:
    """``--device`` checked: ``cpu`` (without asking torch), ``cuda`` or ``cuda:N`` when
    present; a one-line refusal otherwise."""
    if device.strip().lower() == "cpu":
        return "cpu"
    try:
        from fallgen.learn.runtime import resolve_device

        return str(resolve_device(device))
    except (ImportError, ValueError) as e:
        raise InputError("<command line>", "--device", str(e)) from None


class Bars:
    """Rich progress bars fed by ``progress(step, done, total)`` (one bar per step)."""

    def __init__(self, console: Console) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                            TimeElapsedColumn(), TimeRemainingColumn(), console=console)
        self.tasks: dict[str, int] = {}

    def __enter__(self) -> Bars:
        self.bar.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.bar.__exit__(*exc)

    def __call__(self, step: str, done: int, total: int) -> None:
        if step not in self.tasks:
            self.tasks[step] = self.bar.add_task(step, total=total)
        self.bar.update(self.tasks[step], completed=done, total=total)


def register(app: typer.Typer, console: Console) -> None:
    vision_app = typer.Typer(help="The visual perception module: segmentation of the target "
                             "categories from RGB-D, trained on a build's train split, scored "
                             "on another.", no_args_is_help=True)
    app.add_typer(vision_app, name="vision-model")

    @vision_app.command("train")
    def vision_train(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
        out: Annotated[Path, typer.Option("--out", "-o", help="The model file to write "
                                          "(its learning curve beside it: .log.csv, "
                                          ".curve.png).")],
        frames: Annotated[int, typer.Option(
            min=1, help="Frames at most: the train split's episodes are subsampled (seeded) "
            "to fit, each giving its step-0 view, --path-views and --look-views.")] = 24000,
        epochs: Annotated[int, typer.Option(min=1, help="Passes over the frames.")] = 4,
        path_views: Annotated[int, typer.Option(
            min=0, help="Views along each expert path (its last pose first).")] = 2,
        look_views: Annotated[int, typer.Option(
            min=0, help="Views of the object from 0.5-2 m, facing it.")] = 3,
        crop: Annotated[int, typer.Option(min=32, max=300, help="Training crop side (even).")
                        ] = 160,
        batch: Annotated[int, typer.Option(min=1, help="Crops per step.")] = 16,
        lr: Annotated[float, typer.Option(help="Peak learning rate (AdamW).")] = 3e-3,
        val_episodes: Annotated[int, typer.Option(
            min=0, help="Validation episodes for the learning curve and the margin (0: "
            "none).")] = 100,
        split: Annotated[str, typer.Option(help="The split it learns from.")] = "train",
        room_kind: Annotated[Optional[str], typer.Option(help="kitchen or study only.")] = None,
        device: Annotated[str, typer.Option(help=DEVICE_HELP)] = "cpu",
        seed: Annotated[int, typer.Option(help="Seeds the weights, the frames and the "
                                          "batches.")] = 0,
        threads: Annotated[int, typer.Option(
            min=1, help="torch threads while training (a second one pays only on an idle "
            "core: OpenMP's threads spin while they wait).")] = 1,
        workers: Annotated[Optional[int], typer.Option(
            min=1, help="Processes drawing the frames (default: all cores).",
            show_default=False)] = None,
        keep_frames: Annotated[Optional[Path], typer.Option(
            help="Keep the frames in this directory (reused when they match); default: a "
            "temporary directory, removed.")] = None,
        data_dir: Annotated[Optional[Path], typer.Option(
            "--data-dir", help="World data the dataset was built with (default: built-in).",
            show_default=False)] = None,
    ) -> None:
        """Train the segmentation network on a split's step-0 views and views along the
        expert's paths; save it with its settings and the dataset's manifest hash."""
        try:
            from fallgen.learn.frames import FrameSpec
            from fallgen.learn.vision_train import TrainSettings
        except ImportError as e:
            raise InputError("<command line>", "vision-model", str(e)) from None
        if crop % 2:
            raise InputError("<command line>", "--crop", f"{crop}: an even number")
        from fallgen.learn.vision_jobs import subsample_rows

        ds = open_dataset(dataset)
        dev = device_name(device)
        spec = FrameSpec(path_views, look_views, seed)
        rows = split_rows(ds, split, room_kind)
        rows = subsample_rows(rows, max(1, frames // spec.per_episode), seed, 11)
        val_rows = subsample_rows(ds.rows("validation", room_kind), val_episodes, seed, 12) \
            if val_episodes and "validation" in ds.splits else []
        settings = TrainSettings(frames=frames, spec=spec, epochs=epochs, batch=batch,
                                 crop=crop, lr=lr, val_episodes=val_episodes, seed=seed,
                                 threads=threads)
        from fallgen.learn.vision_jobs import train_model

        with Bars(console) as bars:
            model = train_model(ds, out, rows, val_rows, settings, dev,
                                workers or (os.cpu_count() or 1), keep_frames, data_dir, bars,
                                console.print, meta={"split": split, "room_kind": room_kind})
        m = model.meta
        console.print(f"vision model on {m['train_frames']} frames of {len(rows)} {split} "
                      f"episodes ({m['frames_seconds'] / 60:.1f} min drawing them, "
                      f"{m['train_seconds'] / 60:.1f} min training, {dev}); margins "
                      f"{model.margin:g} (asked {model.ask_margin:g}) -> {out}, "
                      f"{out.with_suffix('.log.csv')}, "
                      f"{out.with_suffix('.curve.png')}")

    @vision_app.command("eval")
    def vision_eval(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
        model_path: Annotated[Path, typer.Option("--model", "-m", help="A model file "
                                                 "(fallgen vision-model train).")],
        out: Annotated[Path, typer.Option("--out", "-o", help="Directory for scores.json, "
                                          "confusion.png and strip.png.")],
        split: Annotated[str, typer.Option(help="The split it is scored on.")] = "test",
        room_kind: Annotated[Optional[str], typer.Option(help="kitchen or study only.")
                             ] = None,
        episodes: Annotated[int, typer.Option(
            min=0, help="Episodes (a seeded subsample; 0: all).")] = 0,
        device: Annotated[str, typer.Option(help=DEVICE_HELP)] = "cpu",
        seed: Annotated[int, typer.Option(help="Seeds the subsample and the views.")] = 0,
        workers: Annotated[Optional[int], typer.Option(
            min=1, help="Processes drawing the frames (default: all cores).",
            show_default=False)] = None,
        data_dir: Annotated[Optional[Path], typer.Option(
            "--data-dir", help="World data the dataset was built with (default: built-in).",
            show_default=False)] = None,
    ) -> None:
        """Score a model on a split's frames: IoU per category and their mean, the fallen
        object found where it shows, false alarms where it does not; a confusion matrix and
        a strip of predictions beside the truth."""
        ds = open_dataset(dataset)
        model = load_model(model_path, ds)
        dev = device_name(device)
        from fallgen.learn.vision_jobs import subsample_rows

        rows = subsample_rows(split_rows(ds, split, room_kind), episodes, seed, 13)
        from fallgen.learn.vision_jobs import score_model

        with Bars(console) as bars:
            scores = score_model(model, ds, rows, out, dev, workers or (os.cpu_count() or 1),
                                 seed, data_dir, bars)
        scores.update({"split": split, "room_kind": room_kind, "model": str(model_path)})
        from fallgen.atomic import write_text

        write_text(out / "scores.json", json.dumps(scores, indent=1) + "\n")
        t = Table(title=f"vision model on {scores['frames']} frames of {len(rows)} {split} "
                  "episodes")
        for col in ("measure", "value", "frames"):
            t.add_column(col)
        t.add_row("mIoU (31 targets)", f"{scores['miou']:.3f}", "")
        t.add_row("found (>= 50 px within 2 m)", f"{scores['found']:.3f}",
                  str(scores["found_frames"]))
        t.add_row("found (>= 4 px within 2 m)", f"{scores['found_visible']:.3f}",
                  str(scores["visible_frames"]))
        t.add_row("false alarms (not visible)", f"{scores['false_alarms']:.3f}",
                  str(scores["false_alarm_frames"]))
        t.add_row("found, its category asked for", f"{scores['found_asked']:.3f}",
                  str(scores["found_frames"]))
        t.add_row("false alarms, its category asked for",
                  f"{scores['false_alarms_asked']:.3f}", str(scores["false_alarm_frames"]))
        t.add_row("inference, 1 thread", f"{scores['inference_ms_per_frame_1_thread']:.1f} ms",
                  "")
        console.print(t)
        console.print(f"-> {out / 'scores.json'}, confusion.png, strip.png")


__all__ = ["register", "load_model", "Bars"]
