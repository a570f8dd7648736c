"""The ``fallgen`` command line: a thin layer over the library.

Every command parses its arguments, calls a library function, shows progress or a table, and
maps bad input to a one-line ``error: FILE: FIELD: MESSAGE`` on stderr with exit code 2.

The commands live in one module per group, listed in :data:`GROUPS`; each module's
``register(app, console)`` adds its commands to :data:`app`. A new group is a module with a
``register`` function and one more line in :data:`GROUPS`.
"""

from __future__ import annotations

import importlib
import sys
from typing import Annotated

import typer

from fallgen import __version__
from fallgen.cli_common import console
from fallgen.errors import InputError

#: The command groups, in the order ``fallgen --help`` lists them.
GROUPS = (
    "fallgen.cli_world",  # rooms, objects, materials
    "fallgen.cli_sound",  # assets modes, sounds
    "fallgen.cli_build",  # rehearse, generate, build, finalize
    "fallgen.cli_dataset",  # validate, show, stats
    "fallgen.cli_benchmark",  # evaluate, export-expert, audio-model, table
    "fallgen.cli_train",  # train (the learned policies)
)

app = typer.Typer(
    name="fallgen",
    help="Generate the Fallen Objects audio-visual dataset, offline and deterministically.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


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


for _group in GROUPS:
    importlib.import_module(_group).register(app, console)


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
