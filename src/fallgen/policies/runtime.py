"""Where and how a policy trains: the device, the thread count, and random numbers kept apart.

Our own code draws from generators made from the run's seed (``numpy.random.Generator``,
``torch.Generator``). Stable-Baselines3 and torch's module initialisers draw from the global
generators; :func:`isolated_rng` seeds those for the duration of a job and puts back what
they were afterwards, so that a run repeats for a seed and leaves the caller's state as it
found it. A checkpoint stores their state (:func:`rng_state`) and a resumed run restores it.
"""

from __future__ import annotations

import contextlib
import random
from collections.abc import Iterator
from typing import Any

import numpy as np

DEVICES = ("cpu", "cuda")


def require_torch():
    """The torch module, or ImportError saying how to install it."""
    try:
        import torch
    except ImportError:
        raise ImportError("the learned policies need torch: pip install 'fallgen[learn]'") \
            from None
    return torch


def resolve_device(name: str | None) -> Any:
    """A ``torch.device`` for ``name`` (``cpu``, ``cuda``, ``cuda:N``; None: cpu); ValueError
    for another name or a CUDA device that is not here."""
    torch = require_torch()
    name = (name or "cpu").strip().lower()
    if name.split(":", 1)[0] not in DEVICES:
        raise ValueError(f"device {name!r}: cpu or cuda")
    if name.startswith("cuda") and not torch.cuda.is_available():
        raise ValueError(f"device {name!r}: no CUDA device here (torch {torch.__version__})")
    return torch.device(name)


def rng_state() -> dict[str, Any]:
    """The global generators' states, as plain values and tensors (``torch.load`` with
    ``weights_only=True`` reads them back)."""
    torch = require_torch()
    kind, keys, pos, has_gauss, gauss = np.random.get_state()
    state = {"torch": torch.get_rng_state(),
             "numpy": {"keys": torch.from_numpy(keys.astype(np.int64)), "pos": int(pos),
                       "has_gauss": int(has_gauss), "gauss": float(gauss)},
             "python": [list(random.getstate()[1]), random.getstate()[0]]}
    if torch.cuda.is_available() and torch.cuda.is_initialized():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def set_rng_state(state: dict[str, Any]) -> None:
    """Put back what :func:`rng_state` returned."""
    torch = require_torch()
    torch.set_rng_state(state["torch"])
    n = state["numpy"]
    np.random.set_state(("MT19937", n["keys"].numpy().astype(np.uint32), n["pos"],
                         n["has_gauss"], n["gauss"]))
    internal, version = state["python"]
    random.setstate((version, tuple(internal), None))
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])


@contextlib.contextmanager
def isolated_rng(seed: int | None) -> Iterator[None]:
    """The global generators (python, numpy, torch) seeded from ``seed`` while the block runs
    (None: left as they are), and as they were before it afterwards."""
    saved = rng_state()
    try:
        if seed is not None:
            ss = np.random.SeedSequence(int(seed))
            a, b, c = (int(x) for x in ss.generate_state(3))
            random.seed(a)
            np.random.seed(b)
            require_torch().manual_seed(c)
        yield
    finally:
        set_rng_state(saved)


@contextlib.contextmanager
def session(threads: int | None = 1, deterministic: bool = True) -> Iterator[None]:
    """``threads`` intra-op threads (None: as it is) and deterministic algorithms while the
    block runs; both as they were afterwards."""
    torch = require_torch()
    old_threads = torch.get_num_threads()
    old_det = torch.are_deterministic_algorithms_enabled()
    old_warn = torch.is_deterministic_algorithms_warn_only_enabled()
    try:
        if threads is not None:
            torch.set_num_threads(max(1, int(threads)))
        if deterministic:
            torch.use_deterministic_algorithms(True, warn_only=True)
        yield
    finally:
        torch.set_num_threads(old_threads)
        torch.use_deterministic_algorithms(old_det, warn_only=old_warn)


__all__ = ["DEVICES", "require_torch", "resolve_device", "rng_state", "set_rng_state",
           "isolated_rng", "session"]
