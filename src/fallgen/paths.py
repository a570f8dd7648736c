"""Where the data directories (materials, objects, rooms, configs) are found.

Order: an explicit directory (``--data-dir``), the ``FALLGEN_DATA`` environment variable, the
repository checkout this package runs from (editable installs), then the copy a wheel carries in
``fallgen/_data``.
"""

from __future__ import annotations

import os
from pathlib import Path

DATA_SUBDIRS = ("materials", "objects", "rooms")


def _is_data_root(p: Path) -> bool:
    return all((p / d).is_dir() for d in DATA_SUBDIRS)


def data_root(explicit: str | Path | None = None) -> Path:
    """The directory holding ``materials/``, ``objects/`` and ``rooms/``."""
    from fallgen.errors import InputError

    if explicit is not None:
        p = Path(explicit)
        if not _is_data_root(p):
            raise InputError(p, "<dir>", f"not a fallgen data directory (needs {', '.join(DATA_SUBDIRS)})")
        return p
    env = os.environ.get("FALLGEN_DATA")
    if env:
        p = Path(env)
        if not _is_data_root(p):
            raise InputError(p, "FALLGEN_DATA", "not a fallgen data directory")
        return p
    here = Path(__file__).resolve().parent
    for candidate in (here.parent.parent, here / "_data"):
        if _is_data_root(candidate):
            return candidate
    raise InputError(here, "<install>", "cannot find the fallgen data directories; set FALLGEN_DATA")
