"""Which head a build hears with: the names a config may give its ``hrtf``, and the HRTF each
stands for.

- ``"sadie_ku100"`` (:data:`MEASURED`, every config's default): the SADIE database's Neumann
  KU100 dummy head, 1555 measured directions (``fallgen/audio/hrtf_data``: the SOFA file, its
  Apache-2.0 licence and the citation it asks for). It has the pinna's spectral cues that tell
  front from back, which the spherical head lacks.
- ``"sphere"`` (:data:`SPHERE`): Brown & Duda's spherical-head model
  (:func:`fallgen.audio.hrtf.spherical_head`).
- a path: any SOFA file (SimpleFreeFieldHRIR).

A SOFA file is resampled to the build's rate once and kept in ``$FALLGEN_CACHE/hrtf``, keyed by
the file's sha256 and the rate (a corrupt entry is made again). :func:`hrtf_id` names what a
build heard with, for its manifest: ``sphere`` or the file's name and sha256.
"""

from __future__ import annotations

import hashlib
import io
from pathlib import Path

import numpy as np

from fallgen.atomic import write_bytes
from fallgen.audio.hrtf import Hrtf, load_sofa, spherical_head
from fallgen.cache import CORRUPT_ENTRY, cache_root

MEASURED = "sadie_ku100"
SPHERE = "sphere"
NAMES = (MEASURED, SPHERE)
#: The packaged measured head.
PACKAGED = Path(__file__).resolve().parent / "hrtf_data" / "sadie_ku100_48k.sofa"
#: The format of a cached, resampled HRTF (made again when it changes).
CACHE_VERSION = 1


def sofa_file(spec: str) -> Path | None:
    """The SOFA file ``spec`` names (None for the spherical head)."""
    if spec == SPHERE:
        return None
    if spec == MEASURED:
        return PACKAGED
    return Path(spec)


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def hrtf_id(spec: str) -> str:
    """What ``spec`` heard with: ``sphere``, or ``NAME:SHA256`` of its SOFA file (the first
    16 hex digits; NAME ``sadie_ku100`` for the packaged head, else the file's name)."""
    path = sofa_file(spec)
    if path is None:
        return SPHERE
    name = MEASURED if spec == MEASURED else path.name
    return f"{name}:{_sha256(path)[:16]}"


def hrtf_name(identity: str) -> str:
    """The name part of an :func:`hrtf_id` (``sphere``, ``sadie_ku100``, a file's name)."""
    return identity.split(":", 1)[0]


def load_hrtf(spec: str, sample_rate: int = 44100) -> Hrtf:
    """The HRTF ``spec`` names, at ``sample_rate`` (a SOFA file's resampling cached)."""
    path = sofa_file(spec)
    if path is None:
        return spherical_head(sample_rate)
    entry = cache_root() / "hrtf" / f"{_sha256(path)[:24]}-{int(sample_rate)}-v{CACHE_VERSION}.npz"
    if entry.exists():
        try:
            with np.load(entry) as z:
                return Hrtf(z["directions"], z["hrir"], int(z["sample_rate"]), str(z["name"]))
        except CORRUPT_ENTRY:
            entry.unlink(missing_ok=True)  # made again
    hrtf = load_sofa(path, sample_rate)
    buf = io.BytesIO()
    np.savez(buf, directions=hrtf.directions, hrir=hrtf.hrir,
             sample_rate=np.int64(hrtf.sample_rate), name=np.str_(hrtf.name))
    write_bytes(entry, buf.getvalue())
    return hrtf


__all__ = ["MEASURED", "SPHERE", "NAMES", "PACKAGED", "hrtf_id", "hrtf_name", "load_hrtf",
           "sofa_file"]
