"""A worker's freed heap given back to the system between episodes (glibc's ``malloc_trim``),
only when its resident memory is high: an episode frees many arrays of a few hundred kB to a
few MB, and glibc keeps the holes."""

from __future__ import annotations

import ctypes
import ctypes.util
import os


def _malloc_trim():
    """glibc's ``malloc_trim``, or None on another C library."""
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):
        return None


_MALLOC_TRIM = _malloc_trim()


#: Resident memory (MB) above which a worker gives its freed heap back to the system before
#: the next episode. (Numba's runtime, for the expert's compiled search, holds ~120 MB of a
#: worker: at 768 MB a worker trimmed before nearly every episode, 4 s of system time a shard,
#: while the sound renderer kept 128 MB of modal models. With 32 MB of them, 800 MB leaves
#: the headroom 896 MB did: on 8 paper-size shards, 21 s of system time against 28 s, the
#: workers' peaks 874-877 MB against 960-1004 MB, the same bytes.)
TRIM_ABOVE_MB = 800


_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def resident_mb() -> float:
    """This process's resident memory in MB (Linux ``/proc``; 0 where there is none)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * _PAGE / 2 ** 20
    except (OSError, IndexError, ValueError):
        return 0.0


def trim_heap(above_mb: float = TRIM_ABOVE_MB) -> bool:
    """Give freed heap pages back to the system when the resident memory is above
    ``above_mb``; whether it did. An episode frees many arrays of a few hundred kB to a few MB
    (audio, modal models dropped from the renderer's budget) and glibc keeps the holes: never
    trimming, a worker grew by ~100 MB a shard. Trimming before every episode held a full
    build's workers at 754 MB but cost 266 s of system time over the build instead of 56 s
    (the pages given back are faulted in again by the next episode's arrays): only above the
    threshold, then (see :class:`HeapTrimmer`)."""
    if _MALLOC_TRIM is None or resident_mb() <= above_mb:
        return False
    _MALLOC_TRIM(0)
    return True


#: After a trim, the next one waits until the resident memory has grown this much (MB) above
#: what the trim left, or above ``TRIM_ABOVE_MB`` if that is higher.
TRIM_HYSTERESIS_MB = 64


class HeapTrimmer:
    """A worker's heap trims: :func:`trim_heap` above ``TRIM_ABOVE_MB`` or
    ``TRIM_HYSTERESIS_MB`` above the memory the last trim left, whichever is higher. Without
    the second bound, a worker whose memory after a trim plus one episode's arrays exceeds
    the threshold trims before every episode and faults the pages in again: in a full build
    whose workers were replaced every 4 shards, three of the eight 4-shard lifetimes faulted
    4.3-10.8 M pages, the others 0.2-0.8 M."""

    def __init__(self, above_mb: float = TRIM_ABOVE_MB,
                 hysteresis_mb: float = TRIM_HYSTERESIS_MB) -> None:
        self.above_mb, self.hysteresis_mb = above_mb, hysteresis_mb
        self.left_mb = 0.0  # resident memory after the last trim
        self.trims = 0

    def __call__(self) -> bool:
        if not trim_heap(max(self.above_mb, self.left_mb + self.hysteresis_mb)):
            return False
        self.left_mb = resident_mb()
        self.trims += 1
        return True


__all__ = ["HeapTrimmer", "TRIM_ABOVE_MB", "TRIM_HYSTERESIS_MB", "resident_mb", "trim_heap"]
