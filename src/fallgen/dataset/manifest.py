"""``DATASET/manifest.json``: what a build is (config, versions, seed, counts, and ``build``: the
fingerprint every shard of it carries, with the inputs it hashes) and the sha256 of every file,
so a download can be checked (``fallgen validate``). Written last, atomically, with sorted keys
and no timestamps: the same build gives the same bytes. A build writes it only from shards it
has checked against their write records (:func:`fallgen.pipeline.generate.finalize_build`)."""

from __future__ import annotations

import hashlib
import json
import platform
from collections.abc import Callable
from pathlib import Path

import pyarrow.parquet as pq

from fallgen.atomic import write_text

MANIFEST = "manifest.json"
FORMAT_VERSION = 1
#: Directories whose files the manifest lists (and the card, README.md).
LISTED = ("data", "media", "rehearsal")
CARD = "README.md"


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def manifest_sha256(root: Path) -> str | None:
    """sha256 of ``root``'s ``manifest.json`` (None when it has none: an unfinished build)."""
    path = Path(root) / MANIFEST
    return sha256(path) if path.is_file() else None


def listed_files(root: Path) -> list[Path]:
    files = [p for d in LISTED for p in (root / d).glob("*")
             if p.is_file() and not p.name.endswith(".tmp") and not p.name.startswith(".")]
    return sorted(files + [root / CARD] if (root / CARD).is_file() else files)


def versions() -> dict[str, str]:
    import h5py
    import mujoco
    import numpy
    import pyarrow
    import scipy

    import fallgen

    return {"fallgen": fallgen.__version__, "mujoco": mujoco.__version__,
            "numpy": numpy.__version__, "scipy": scipy.__version__, "h5py": h5py.__version__,
            "pyarrow": pyarrow.__version__, "python": platform.python_version()}


def counts(root: Path) -> dict[str, int]:
    out: dict[str, int] = {}
    for p in sorted((root / "data").glob("*.parquet")):
        split = p.name.split("-")[0]
        out[split] = out.get(split, 0) + pq.read_metadata(p).num_rows
    return out


def write_manifest(root: Path, config_text: str, root_seed: int, settings: dict,
                   build: dict | None = None,
                   hash_of: Callable[[Path], dict] | None = None) -> Path:
    """``build``: the build's fingerprint and inputs; ``hash_of(path)``: a file's sha256 and
    size (default: read it now)."""
    entry = hash_of or (lambda p: {"sha256": sha256(p), "bytes": p.stat().st_size})
    files = {str(p.relative_to(root)): entry(p) for p in listed_files(root)}
    m = {"format_version": FORMAT_VERSION, "root_seed": root_seed, "versions": versions(),
         "config": config_text, "settings": settings, "episodes": counts(root), "files": files}
    if build is not None:
        m["build"] = build
    path = root / MANIFEST
    write_text(path, json.dumps(m, indent=1, sort_keys=True) + "\n")
    return path


def read_manifest(root: Path) -> dict:
    return json.loads((root / MANIFEST).read_text())
