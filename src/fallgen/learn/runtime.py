"""Where and how a learned module or policy runs: the device, determinism, threads, seeded
weights, random numbers kept apart.

A training or inference job runs inside :func:`session`, which sets torch's thread count and
``torch.use_deterministic_algorithms`` for its duration and restores both afterwards. Our own
random numbers come from generators made from the job's seed (``torch.Generator`` for weights,
``numpy.random.Generator`` from a ``SeedSequence`` for data order and crops), never from torch's
or numpy's global state, so a job on the CPU with the same seed and thread count repeats
bit for bit. Stable-Baselines3 and torch's module initialisers draw from the global
generators; :func:`isolated_rng` seeds those for the duration of a job and puts back what they
were afterwards, and a policy's checkpoint stores their state (:func:`rng_state`) so that a
resumed run restores it.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import random
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np

from fallgen.learn import require_torch

DEVICES = ("cpu", "cuda")


def default_device() -> str:
    """``cpu``: what every command uses unless told otherwise (see :func:`resolve_device`)."""
    return "cpu"


def resolve_device(name: str | None):
    """A ``torch.device`` for ``name`` (``cpu``, ``cuda`` or ``cuda:N``; None: cpu);
    ValueError for an unknown name or a CUDA device that is not present."""
    torch = require_torch()
    name = (name or default_device()).strip().lower()
    kind = name.split(":", 1)[0]
    if kind not in DEVICES:
        raise ValueError(f"device {name!r}: cpu or cuda")
    if kind == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device {name!r}: no CUDA device here (torch {torch.__version__})")
    return torch.device(name)


def keep_heap() -> None:
    """Ask glibc's allocator to keep freed memory for reuse (large blocks from the heap, not
    returned to the system). A CPU training loop frees and allocates the same large tensors
    every step; with the default settings each is a fresh ``mmap`` whose pages fault in again,
    which made a step of the segmentation network 3-5 times slower on a 2-core VM. A no-op
    off glibc."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return
    m_trim_threshold, m_top_pad, m_mmap_threshold = -1, -2, -3
    libc.mallopt(m_mmap_threshold, 32 << 20)
    libc.mallopt(m_trim_threshold, 1 << 30)
    libc.mallopt(m_top_pad, 64 << 20)


@contextlib.contextmanager
def session(threads: int | None = None, deterministic: bool = True) -> Iterator[None]:
    """Run a job with ``threads`` intra-op threads (None: as it is) and, with
    ``deterministic``, ``torch.use_deterministic_algorithms(True)``; both as they were after."""
    torch = require_torch()
    old_threads = torch.get_num_threads()
    old_det = torch.are_deterministic_algorithms_enabled()
    old_warn = torch.is_deterministic_algorithms_warn_only_enabled()
    try:
        if threads is not None and threads != old_threads:
            torch.set_num_threads(max(1, int(threads)))
        if deterministic:
            torch.use_deterministic_algorithms(True, warn_only=True)
        yield
    finally:
        if torch.get_num_threads() != old_threads:
            torch.set_num_threads(old_threads)
        torch.use_deterministic_algorithms(old_det, warn_only=old_warn)


def init_weights(net, seed: int) -> None:
    """Initialise ``net``'s convolutions (He normal, fan out), batch normalisations (1, 0)
    and biases (0) from a generator seeded with ``seed``, in the modules' order."""
    torch = require_torch()
    from torch import nn

    g = torch.Generator().manual_seed(int(seed))
    with torch.no_grad():
        for m in net.modules():
            if isinstance(m, nn.Conv2d):
                fan_out = m.out_channels * m.kernel_size[0] * m.kernel_size[1] // m.groups
                m.weight.copy_(torch.randn(m.weight.shape, generator=g)
                               * math.sqrt(2.0 / fan_out))
                if m.bias is not None:
                    m.bias.zero_()
            elif isinstance(m, nn.BatchNorm2d):
                m.weight.fill_(1.0)
                m.bias.zero_()


def rng_state() -> dict[str, Any]:
    """The global generators' states (python, numpy, torch, CUDA where it runs), as plain
    values and tensors (``torch.load`` with ``weights_only=True`` reads them back)."""
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


__all__ = ["DEVICES", "default_device", "resolve_device", "keep_heap", "session",
           "init_weights", "rng_state", "set_rng_state", "isolated_rng"]
