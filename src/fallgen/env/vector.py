"""Many environments at once: ``make_vec`` gives a :class:`VectorEnv`, Gymnasium's
``AsyncVectorEnv`` (one process and one GL context per environment, observations in shared
memory) that can also step asynchronously.

``step(actions)`` is Gymnasium's: every environment steps, and the call returns when the
slowest has. Our steps cost ~0.1 ms when the view is cached (turning back, tilting back) and
~8-10 ms when it is rendered, so in lockstep a worker whose view was cached waits most of the
step for the other (2 workers: 1.15x one on a 2-core machine, a random walk).
``send(actions, env_ids)`` / ``recv()`` (EnvPool's interface; Habitat's variable-experience
rollouts work the same way) step only the environments named and return those that have
finished, so no worker waits for another: 2 workers then give ~1.9x one.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.vector import AsyncVectorEnv


@dataclass(frozen=True)
class Ready:
    """What :meth:`VectorEnv.recv` returns: the environments whose steps finished (``env_ids``,
    ascending) and, in the same order, their observations (each key batched along axis 0,
    copies), rewards, terminations, truncations and ``info`` dicts."""

    env_ids: np.ndarray
    observations: dict[str, np.ndarray]
    rewards: np.ndarray
    terminations: np.ndarray
    truncations: np.ndarray
    infos: tuple[dict[str, Any], ...]


class VectorEnv(AsyncVectorEnv):
    """``AsyncVectorEnv`` plus asynchronous stepping: :meth:`send` starts steps of some
    environments, :meth:`recv` returns the ones that finished. An environment that ended is
    reset by its next step (Gymnasium's ``NEXT_STEP`` autoreset: that step's action is not
    used, its observation is the new episode's first); so is it with ``step``. Do not mix:
    ``step``, ``reset`` and ``close`` first wait for the steps sent (their results are lost)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        # before the workers start: AsyncVectorEnv's __del__ closes what a failed start left,
        # and closing drains the steps pending
        self._pending: set[int] = set()
        if not kwargs.get("shared_memory", True):
            raise ValueError("send/recv need shared_memory=True")
        super().__init__(*args, **kwargs)

    def send(self, actions: Any, env_ids: Any) -> None:
        """Start one step of each environment in ``env_ids`` (none of them may be stepping)
        with the matching action of ``actions``."""
        self._assert_is_running()
        ids = [int(i) for i in np.atleast_1d(env_ids)]
        acts = list(np.atleast_1d(actions))
        if len(ids) != len(acts):
            raise ValueError(f"{len(acts)} actions for {len(ids)} environments")
        bad = [i for i in ids if not 0 <= i < self.num_envs or i in self._pending]
        if bad or len(set(ids)) != len(ids):
            raise ValueError(f"env_ids {bad or ids}: each in 0..{self.num_envs - 1}, once, "
                             "and not already stepping")
        for i, a in zip(ids, acts):
            if not self.single_action_space.contains(a):
                raise ValueError(f"action {a!r} is not in {self.single_action_space}")
        for i, a in zip(ids, acts):
            self.parent_pipes[i].send(("step", a))
            self._pending.add(i)

    def recv(self, min_envs: int = 1, timeout: float | None = None) -> Ready:
        """Wait until at least ``min_envs`` of the steps sent have finished (all of them if
        fewer are pending) and return every one that has. TimeoutError after ``timeout``
        seconds with fewer."""
        self._assert_is_running()
        if not self._pending:
            raise RuntimeError("recv() without a step sent (send() first)")
        need = min(max(1, int(min_envs)), len(self._pending))
        pipes = {self.parent_pipes[i]: i for i in self._pending}
        done: list[int] = []
        results: dict[int, Any] = {}
        successes: list[bool] = []
        while len(done) < need:
            ready = wait(list(pipes), timeout)
            if not ready:
                raise TimeoutError(f"recv() timed out after {timeout} s")
            # and what else has finished meanwhile
            ready += [p for p in pipes if p not in ready and p.poll()]
            for pipe in ready:
                i = pipes.pop(pipe)
                ret, ok = pipe.recv()
                self._pending.discard(i)
                successes.append(ok)
                if ok:
                    results[i] = ret
                    done.append(i)
        self._raise_if_errors(successes + [True] * (self.num_envs - len(successes)))
        ids = np.array(sorted(done), np.int64)
        obs = {k: v[ids] for k, v in self.observations.items()}  # copies (fancy index)
        return Ready(ids, obs,
                     np.array([results[i][1] for i in ids], np.float64),
                     np.array([results[i][2] for i in ids], bool),
                     np.array([results[i][3] for i in ids], bool),
                     tuple(results[i][4] for i in ids))

    @property
    def pending(self) -> frozenset[int]:
        """The environments stepping now (sent, not yet received)."""
        return frozenset(self._pending)

    def _drain(self) -> None:
        while self._pending and not self.closed:
            try:
                self.recv(len(self._pending))
            except TimeoutError:
                break

    def step_async(self, actions: Any) -> None:
        self._drain()
        super().step_async(actions)

    def reset_async(self, *args: Any, **kwargs: Any) -> None:
        self._drain()
        super().reset_async(*args, **kwargs)

    def close_extras(self, timeout: float | None = None, terminate: bool = False) -> None:
        if not terminate:
            try:
                self._drain()
            except Exception:  # a worker failed: close what is left
                terminate = True
        self._pending.clear()
        super().close_extras(timeout, terminate)


def wrapped(make: Any, wrapper: Any) -> Any:
    """``wrapper(make())``: an environment made in a worker and wrapped there (picklable with
    picklable arguments)."""
    return wrapper(make())


def make_vec(dataset: str | Path, num_envs: int = 2, split: str | None = None, *,
             context: str = "spawn", autoreset_mode: Any = None, rank: int = 0,
             world_size: int = 1, wrapper: Any = None, **kwargs: Any) -> VectorEnv:
    """``num_envs`` environments of ``dataset`` in worker processes (``context``: ``"spawn"``
    or ``"forkserver"``; a forked process would inherit the parent's GL state). Environment i
    takes slice ``rank * num_envs + i`` of ``world_size * num_envs`` of the selection, so the
    environments of one machine, and those of ``world_size`` machines each given its
    ``rank``, replay disjoint episodes. ``kwargs`` go to
    :class:`~fallgen.env.fallen_objects.FallenObjectsEnv` (sensors, reward, claims, ...);
    ``autoreset_mode``: Gymnasium's (default ``NEXT_STEP``). ``wrapper``: a picklable callable
    applied to each environment in its worker (e.g. :class:`fallgen.env.wrappers.
    CompactObservation`: only the small observations cross to this process)."""
    if num_envs < 1:
        raise ValueError(f"num_envs={num_envs}: at least 1")
    if context not in ("spawn", "forkserver"):
        raise ValueError(f"context={context!r}: spawn or forkserver (not fork: the GL context "
                         "must be made in the worker)")
    from fallgen.env.fallen_objects import FallenObjectsEnv

    fns = [functools.partial(FallenObjectsEnv, str(dataset), split, rank=rank * num_envs + i,
                             world_size=world_size * num_envs, **kwargs)
           for i in range(num_envs)]
    if wrapper is not None:
        fns = [functools.partial(wrapped, f, wrapper) for f in fns]
    extra = {} if autoreset_mode is None else {"autoreset_mode": autoreset_mode}
    return VectorEnv(fns, shared_memory=True, context=context, **extra)


__all__ = ["make_vec", "VectorEnv", "Ready"]
