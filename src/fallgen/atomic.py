"""Atomic, durable file writes: a temporary name in the same directory, then ``os.replace``.

No partial file ever sits under a final name, whatever kills the process; the file's bytes are
flushed to disk before the rename and the directory entry after it (:func:`commit`), so a
power cut leaves either the old file or the whole new one.

Tests break writes on purpose with ``FALLGEN_FAULT=MODE:K`` (:func:`fault_point`): the K-th
write of the process (a commit, an atomic write, an episode added to a shard) ends it
(``exit``: ``os._exit``, as a kill would) or fails as a full disk would (``enospc``).

Files get the permissions any other file the user makes gets (``0o666`` less the umask):
``tempfile.mkstemp`` makes its file ``0o600``, which on a shared cluster file system would hide
a dataset from everyone but its builder.
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

#: environment variable of :func:`fault_point`
FAULT_ENV = "FALLGEN_FAULT"
_WRITES = [0]


def fault_point(path: str | Path) -> None:
    """Where a write can be made to fail (``FALLGEN_FAULT=exit:K`` or ``enospc:K``: the K-th
    call in this process ends it, or raises ENOSPC for ``path``); nothing otherwise."""
    spec = os.environ.get(FAULT_ENV)
    if not spec:
        return
    mode, _, k = spec.partition(":")
    _WRITES[0] += 1
    if _WRITES[0] != int(k or 1):
        return
    if mode == "exit":
        os._exit(137)
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


def umask() -> int:
    """The process's umask, read without changing it where Linux tells it
    (``/proc/self/status``, kernels >= 4.7), else by setting and restoring it."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_mode() -> int:
    """The mode a new regular file gets: ``0o666`` less the umask."""
    return 0o666 & ~umask()


def fsync_dir(path: str | Path) -> None:
    """Make a rename or a new entry in directory ``path`` durable (no-op where directories
    cannot be opened, e.g. Windows)."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def commit(tmp: str | Path, path: str | Path) -> Path:
    """Rename the finished temporary file ``tmp`` to ``path``, durably: its bytes are synced
    first, the directory's entry after. On failure ``tmp`` is removed and ``path`` is as it
    was."""
    tmp, path = Path(tmp), Path(path)
    try:
        fault_point(path)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)  # a failed commit leaves no temporary behind
        raise
    fsync_dir(path.parent)
    return path


def write_bytes(path: str | Path, data: bytes) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), file_mode())
            fault_point(path)
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        fsync_dir(path.parent)
    except BaseException as e:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(e, OSError) and not e.filename:  # a failed write names its file
            raise named(e, path) from None
        raise
    return path


def named(e: OSError, path: str | Path) -> OSError:
    """``e`` as an OSError naming ``path`` (a full disk reported without a file name: by a
    write, or by a library's own writer)."""
    code = e.errno
    if code is None and "No space left" in str(e):
        code = errno.ENOSPC
    return OSError(code or errno.EIO, e.strerror or os.strerror(code) if code else str(e),
                   str(path))


def write_text(path: str | Path, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))
