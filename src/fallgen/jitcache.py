"""Where Numba keeps fallgen's compiled functions: a directory named by a digest of every
source file of the package and of where it lies (``$FALLGEN_CACHE/numba/<digest>``).

Numba's own cache (``cache=True``, beside each source file by default) is keyed by the source
file of the compiled function alone. A function compiles in the functions it calls from other
modules and reads their module constants as literals, so after an edit to one of those
(``vision/sight.py``'s ``MARGIN``, say) the cached code of an unchanged module
(``vision/region.py``) kept running the old value: a rerun of the same commit on another
machine, or from a fresh clone, could then decide differently (a fall proven hidden on one,
given up at a search limit on the other). With the directory named by the whole package's
sources, any edit compiles everything again on first use (a few seconds a process), and a
result never depends on what a machine compiled before.

:func:`configure` is called by ``fallgen/__init__`` before anything imports Numba; a
``NUMBA_CACHE_DIR`` set by the user is left alone. Directories of other sources not used for
:data:`KEEP_S` are removed when a new one is made.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import time
from pathlib import Path

#: A cache directory of other sources whose last change is older than this is removed when a
#: new one is made (seconds: a week).
KEEP_S = 7 * 24 * 3600.0


def source_digest(package_dir: Path) -> str:
    """A digest of every ``.py`` file under ``package_dir``: their paths and bytes, and where
    the package lies. Numba finds a function's compiled code by its file's full path, so two
    checkouts of the same sources cannot share it: each gets its own directory (and its own
    :func:`done_marker`, which would otherwise say compiled what the other checkout compiled)."""
    h = hashlib.blake2b(digest_size=8)
    h.update(str(package_dir.resolve()).encode() + b"\0")
    for p in sorted(package_dir.rglob("*.py")):
        if "__pycache__" in p.parts:
            continue
        h.update(p.relative_to(package_dir).as_posix().encode() + b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def cache_dir(package_dir: Path, root: Path) -> Path:
    """The compiled-code directory under ``root`` for the sources in ``package_dir``."""
    return root / "numba" / source_digest(package_dir)


def configure(package_dir: Path | None = None) -> Path | None:
    """Point Numba's cache at :func:`cache_dir` of fallgen's sources (of ``package_dir``);
    returns it, or None when the user set ``NUMBA_CACHE_DIR`` or it cannot be written (a
    read-only home: Numba then keeps its own cache, which would fail the import there)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    from fallgen.cache import cache_root

    here = cache_dir(package_dir or Path(__file__).resolve().parent, cache_root())
    new = not here.exists()
    try:
        here.mkdir(parents=True, exist_ok=True)
        probe = here / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError:
        return None
    if new:
        _prune(here.parent, keep=here.name)
    os.environ["NUMBA_CACHE_DIR"] = str(here)
    numba = sys.modules.get("numba")
    if numba is not None:  # imported before fallgen: its config has read the environment
        numba.core.config.CACHE_DIR = str(here)
    return here


def done_marker(name: str, package_dir: Path | None = None) -> Path | None:
    """A file in Numba's cache directory whose presence records that ``name`` was done for
    these sources (a build compiling its functions ahead of its workers, say): named by the
    sources' digest too, so that it also holds in a directory the user set. None where Numba
    has no cache directory set (it cannot keep what would be done)."""
    d = os.environ.get("NUMBA_CACHE_DIR")
    if not d:
        return None
    return Path(d) / f".{name}-{source_digest(package_dir or Path(__file__).resolve().parent)}"


def _prune(parent: Path, keep: str) -> None:
    """Remove the other sources' directories under ``parent`` not changed for KEEP_S."""
    if not parent.is_dir():
        return
    now = time.time()
    for d in parent.iterdir():
        try:
            if d.name != keep and d.is_dir() and now - d.stat().st_mtime > KEEP_S:
                shutil.rmtree(d, ignore_errors=True)
        except OSError:  # another process removed it first
            pass


__all__ = ["KEEP_S", "cache_dir", "configure", "done_marker", "source_digest"]
