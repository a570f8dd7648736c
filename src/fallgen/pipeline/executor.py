"""Where the units of a phase (room variants to rehearse, shards to generate) run.

- ``local``: a pool of long-lived spawned processes (default: all cores); each runs ``init`` once
  (loads the world, the modal models, the renderer) and then takes whole units.
- ``ray``: one Ray task per unit on an existing cluster (``ray.init(address=...)``) or a local
  one (``address=None``). Each Ray worker process runs ``init`` once, the first time a task of
  this build reaches it, and keeps the state for the next tasks. Install with
  ``pip install 'fallgen[ray]'``; Ray is imported only here, only when asked for. On a cluster,
  the data directory and the output directory must be the same paths on every node (a shared
  file system).

Output does not depend on the executor: a unit's result depends only on the unit (its seed),
and BLAS is pinned to one thread in every worker.

For many machines without Ray, ``select_units(units, index, count)`` gives the units of one
Slurm array task or Kubernetes indexed job (``--shard-index I --num-shards N``).

A unit's result carries :func:`process_usage` of the process that made it (peak resident memory,
CPU time so far), so a build can report what each worker used (:func:`per_process`).
"""

from __future__ import annotations

import copyreg
import multiprocessing
import os
import platform
import resource
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any, TypeVar

from fallgen.errors import InputError

U = TypeVar("U")
EXECUTORS = ("local", "ray")

# A worker's InputError (a bad mesh, an HRTF file that is not one) reaches the parent as itself:
# pickled by its args alone it could not be rebuilt there, and the parent died of a TypeError
copyreg.pickle(InputError, lambda e: (InputError, (e.file, e.field, e.message)))
#: environment of every worker: one BLAS thread (bit-identical sums) and headless GL
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              # Mesa's CPU rasteriser (llvmpipe) rasterises in the calling thread: no thread of
              # its own to hand every draw to (see fallgen/__init__.py)
              "LP_NUM_THREADS": "0",
              "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


@dataclass(frozen=True)
class ProcessUsage:
    """What one process had used when it reported: its peak resident memory and CPU time."""

    host: str
    pid: int
    peak_rss_mb: float  # the process's high-water mark so far (getrusage ru_maxrss)
    cpu_s: float  # user + system time so far


def process_usage() -> ProcessUsage:
    """This process's usage so far (Linux reports ``ru_maxrss`` in kB, macOS in bytes)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    kb = r.ru_maxrss / 1024 if platform.system() == "Darwin" else r.ru_maxrss
    return ProcessUsage(platform.node(), os.getpid(), kb / 1024, r.ru_utime + r.ru_stime)


def per_process(usages: Iterable[ProcessUsage | None]) -> list[ProcessUsage]:
    """Each process's last report (peaks and CPU time only grow), in the order the processes
    first reported; ``None`` (a unit done before this run) is left out."""
    last: dict[tuple[str, int], ProcessUsage] = {}
    for u in usages:
        if u is None:
            continue
        key = (u.host, u.pid)
        prev = last.get(key)
        if prev is None or u.cpu_s >= prev.cpu_s:
            last[key] = u
    return list(last.values())


def select_units(units: Sequence[U], index: int | None, count: int | None) -> list[U]:
    """Units ``index``, ``index + count``, ... (round robin, so every index gets a similar mix
    of splits and room kinds); all of them when ``index`` is None."""
    if index is None and count is None:
        return list(units)
    if index is None or count is None or not 0 <= index < count:
        raise ValueError(f"--shard-index must be in [0, --num-shards) (got {index} of {count})")
    return list(units[index::count])


def parallel_map(work: Callable[[U], Any], units: Sequence[U], init: Callable[..., None],
                 init_args: tuple, workers: int, executor: str = "local",
                 ray_address: str | None = None) -> Iterator[Any]:
    """``work(unit)`` for every unit in worker processes that each ran ``init(*init_args)``
    once; yields results as units finish (``local``: in unit order). ``work`` and ``init``
    must be module-level functions."""
    if executor == "local":
        with ProcessPoolExecutor(max(1, workers), mp_context=multiprocessing.get_context("spawn"),
                                 initializer=_local_init, initargs=(init, init_args)) as ex:
            yield from ex.map(work, units)
    elif executor == "ray":
        yield from _ray_map(work, units, init, init_args, workers, ray_address)
    else:
        raise ValueError(f"unknown executor {executor!r} (one of {', '.join(EXECUTORS)})")


def _local_init(init: Callable[..., None], init_args: tuple) -> None:
    os.environ.update(WORKER_ENV)
    _exit_with_parent()
    init(*init_args)


def _exit_with_parent(period_s: float = 1.0) -> None:
    """A worker process ends when the process that started it is gone (killed by a signal,
    a scheduler's time limit): a ProcessPoolExecutor's workers would otherwise go on with
    their unit, and the next, as orphans."""
    import threading

    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(period_s)
            if os.getppid() != parent:
                os._exit(3)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


_RAY_READY: dict[str, Any] = {}


def _ray_task(init: Callable[..., None], init_args: tuple, work: Callable, unit: Any) -> Any:
    key = repr((init.__module__, init.__qualname__, init_args))
    if _RAY_READY.get("key") != key:  # first task of this build in this worker process
        init(*init_args)
        _RAY_READY["key"] = key
    return work(unit)


def _ray_map(work, units, init, init_args, workers, address) -> Iterator[Any]:
    try:
        import ray
    except ImportError:
        raise RuntimeError("--executor ray needs Ray: pip install 'fallgen[ray]'") from None
    started = False
    if not ray.is_initialized():
        kw: dict[str, Any] = {"runtime_env": {"env_vars": WORKER_ENV}, "include_dashboard": False,
                              "log_to_driver": False}
        if address is None:
            kw["num_cpus"] = max(1, workers)
        ray.init(address=address, **kw)
        started = True
    try:
        task = ray.remote(num_cpus=1, max_retries=2)(_ray_task)
        pending = [task.remote(init, init_args, work, u) for u in units]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        if started:
            ray.shutdown()


__all__ = ["parallel_map", "select_units", "EXECUTORS", "ProcessUsage", "process_usage",
           "per_process"]
