"""The per-machine cache of derived assets (``$FALLGEN_CACHE``, default ``~/.cache/fallgen``).

Two kinds of entries, each a ``.npz`` named by a hash of everything it is computed from, written
atomically, and recomputed when missing or unreadable:

- ``modes/``: reference modal models (:mod:`fallgen.audio.modes`);
- ``geometry/``: procedural object geometry (:mod:`fallgen.world.objects`), keyed by the shape,
  its parameters and the source of the shape generators, so that editing a generator can never
  serve a stale mesh.

Deleting the directory is always safe; results do not depend on whether an entry was cached.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

#: what reading a corrupt or truncated ``.npz`` entry raises (numpy's zip reader raises
#: BadZipFile for a bad CRC or a damaged directory, EOFError or ValueError for a short file,
#: KeyError for a missing array): such an entry is removed and recomputed
CORRUPT_ENTRY = (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile)


def cache_root() -> Path:
    env = os.environ.get("FALLGEN_CACHE")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "fallgen"
