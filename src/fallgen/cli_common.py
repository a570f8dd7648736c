"""What every command group of the ``fallgen`` command line shares: the console, the common
options, and a few one-line helpers (the world, room variants, worker counts, a dataset)."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from fallgen.errors import InputError

console = Console()
if not console.is_terminal:  # piped or captured: don't squeeze tables into 80 columns
    console.width = max(console.width, 160)

DataDir = Annotated[
    Optional[Path],
    typer.Option("--data-dir", help="Directory with materials/, objects/, rooms/ "
                 "(default: $FALLGEN_DATA, else the built-in data).", show_default=False),
]
Workers = Annotated[Optional[int], typer.Option(
    min=1, help="Worker processes (default: all cores; 1 runs in this process).",
    show_default=False)]


def load_world_dir(data_dir: Path | None):
    """The world (materials, objects, rooms) of ``data_dir`` (default: $FALLGEN_DATA, else the
    built-in data)."""
    from fallgen.world.library import load_world

    return load_world(data_dir)


def variants(world, pattern: str):
    """The room variants ``pattern`` matches; none is a one-line error."""
    vs = world.variants(pattern)
    if not vs:
        raise InputError("<command line>", "ROOM", f"no room variant matches {pattern!r} "
                         f"(try `fallgen rooms list`)")
    return vs


def n_workers(n: int | None) -> int:
    """``--workers``, or every core."""
    return n if n is not None else (os.cpu_count() or 1)


def open_dataset(dataset: Path):
    """:func:`fallgen.dataset.open`, a missing dataset as a one-line error."""
    import fallgen.dataset

    try:
        return fallgen.dataset.open(dataset)
    except FileNotFoundError as e:
        raise InputError(dataset, "data/", str(e).split(": ", 1)[-1]) from None


@contextmanager
def step_bars(out: Console) -> Iterator[Callable[[str, int, int], None]]:
    """A progress bar per named step, drawn on ``out`` while the block runs: yields the
    ``progress(step, done, total)`` callback the library's long jobs take (a step's bar is
    made at its first call)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
        TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=out) as bar:
        tasks: dict[str, int] = {}

        def progress(step: str, done: int, total: int) -> None:
            if step not in tasks:
                tasks[step] = bar.add_task(step, total=total)
            bar.update(tasks[step], completed=done, total=total)

        yield progress


def note(line: str) -> None:
    """A line of the library's own (a remade shard, a refusal's reason), printed as is."""
    console.print(line, markup=False, highlight=False, soft_wrap=True)
