"""Many environments at once: ``make_vec`` (Gymnasium's ``AsyncVectorEnv``, one process and one
GL context per environment, observations in shared memory)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

from gymnasium.vector import AsyncVectorEnv


def make_vec(dataset: str | Path, num_envs: int = 2, split: str | None = None, *,
             context: str = "spawn", shared_memory: bool = True,
             autoreset_mode: Any = None, rank: int = 0, world_size: int = 1,
             **kwargs: Any) -> AsyncVectorEnv:
    """``num_envs`` environments of ``dataset`` in worker processes (``context``: ``"spawn"``
    or ``"forkserver"``; a forked process would inherit the parent's GL state). Environment i
    takes slice ``rank * num_envs + i`` of ``world_size * num_envs`` of the selection, so the
    environments of one machine, and those of ``world_size`` machines each given its
    ``rank``, replay disjoint episodes. ``kwargs`` go to
    :class:`~fallgen.env.fallen_objects.FallenObjectsEnv` (sensors, reward, claims, ...);
    ``autoreset_mode``: Gymnasium's (default ``NEXT_STEP``)."""
    if num_envs < 1:
        raise ValueError(f"num_envs={num_envs}: at least 1")
    if context not in ("spawn", "forkserver"):
        raise ValueError(f"context={context!r}: spawn or forkserver (not fork: the GL context "
                         "must be made in the worker)")
    from fallgen.env.fallen_objects import FallenObjectsEnv

    fns = [functools.partial(FallenObjectsEnv, str(dataset), split, rank=rank * num_envs + i,
                             world_size=world_size * num_envs, **kwargs)
           for i in range(num_envs)]
    extra = {} if autoreset_mode is None else {"autoreset_mode": autoreset_mode}
    return AsyncVectorEnv(fns, shared_memory=shared_memory, context=context, **extra)


__all__ = ["make_vec"]
