"""Errors for bad user input: one line naming the file and the field."""

from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    """A user-supplied file (config, room, material, category, mesh) is malformed.

    ``str(err)`` is a single line ``FILE: FIELD: MESSAGE`` so that the CLI can print it as is
    and exit with code 2.
    """

    def __init__(self, file: str | Path, field: str, message: str) -> None:
        self.file = str(file)
        self.field = field
        self.message = " ".join(str(message).split())  # always one line
        super().__init__(str(self))

    def __str__(self) -> str:
        field = self.field or "<file>"
        return f"{self.file}: {field}: {self.message}"
