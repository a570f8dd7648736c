"""The environment's vector env as Stable-Baselines3 takes one.

:func:`training_envs` makes ``n`` environments of a split with the compact observations
(:class:`fallgen.env.wrappers.CompactObservation`, applied in each worker: only the small
arrays cross processes), each on its own slice of the episodes and in its own shuffled order
(``fallgen.env.make_vec``; ``n = 0``: one environment in this process, Gymnasium's
``SyncVectorEnv``). :class:`Sb3VecEnv` adapts a Gymnasium vector env with same-step autoreset
to Stable-Baselines3's ``VecEnv``: an ended episode's last observation and measures in its
``info`` (``terminal_observation``, ``TimeLimit.truncated``, ``is_success``, ``spl``, ...) and
its return and length as a ``Monitor`` would give them (``episode``). ``n_actions`` < 6 offers
the policy only the first actions (5: the moves, without ``found``: the oracle's).
"""

from __future__ import annotations

import functools
import time
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


def training_envs(dataset: str | Path, n: int, split: str | None = "train", *,
                  room_kind: str | None = None, sensors=None, wrapper: Any = None,
                  **env_kwargs: Any):
    """A Gymnasium vector env (same-step autoreset) of ``n`` workers (0: in this process) of
    the compact environment (``wrapper``: another picklable wrapper, made in each worker),
    episodes shuffled; ``env_kwargs`` go to the environment."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    from fallgen.env.fallen_objects import FallenObjectsEnv
    from fallgen.env.vector import make_vec, wrapped
    from fallgen.env.wrappers import CompactObservation
    from fallgen.policies import SENSORS

    kw = dict(sensors=tuple(sensors or SENSORS), order="shuffle", room_kind=room_kind,
              **env_kwargs)
    wrapper = wrapper or CompactObservation
    if n <= 0:
        make = functools.partial(FallenObjectsEnv, str(dataset), split, **kw)
        return SyncVectorEnv([functools.partial(wrapped, make, wrapper)],
                             autoreset_mode=AutoresetMode.SAME_STEP)
    return make_vec(dataset, n, split, autoreset_mode=AutoresetMode.SAME_STEP,
                    wrapper=wrapper, **kw)


def _item(info: dict[str, Any], i: int) -> dict[str, Any]:
    """Environment ``i``'s entries of a vector env's info dict (arrays with ``_key`` masks)."""
    out = {}
    for k, v in info.items():
        if k.startswith("_"):
            continue
        mask = info.get("_" + k)
        if mask is not None and not mask[i]:
            continue
        out[k] = v[i].item() if isinstance(v, np.ndarray) and v.dtype != object else v[i]
    return out


class Sb3VecEnv(VecEnv):
    """A Gymnasium vector env (``autoreset_mode=SAME_STEP``) as Stable-Baselines3's VecEnv."""

    def __init__(self, venv: Any, n_actions: int | None = None) -> None:
        self.venv = venv
        act = venv.single_action_space
        if n_actions is not None:
            if not 1 <= n_actions <= act.n:
                raise ValueError(f"n_actions={n_actions}: 1..{act.n}")
            act = spaces.Discrete(int(n_actions))
        super().__init__(venv.num_envs, venv.single_observation_space, act)
        self._next_seeds: list[int] | None = None
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(self.num_envs, np.int64)
        self._start = time.monotonic()
        self._actions: np.ndarray | None = None

    def seed(self, seed: int | None = None) -> list[int | None]:
        """The seeds the next reset gives the environments (``seed + i``)."""
        if seed is None:
            return [None] * self.num_envs
        self._next_seeds = [int(seed) + i for i in range(self.num_envs)]
        return list(self._next_seeds)

    def reset(self):
        obs, _ = self.venv.reset(seed=self._next_seeds)
        self._next_seeds = None
        self._returns[:] = 0
        self._lengths[:] = 0
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, np.int64).reshape(self.num_envs)
        if hasattr(self.venv, "step_async"):  # worker processes: they step meanwhile
            self.venv.step_async(self._actions)

    def step_wait(self):
        if hasattr(self.venv, "step_wait"):
            obs, rewards, terminated, truncated, info = self.venv.step_wait()
        else:
            obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = np.logical_or(terminated, truncated)
        self._returns += rewards
        self._lengths += 1
        infos: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            d: dict[str, Any] = {}
            if dones[i]:
                d.update(_item(info["final_info"], i))
                d["terminal_observation"] = info["final_obs"][i]
                d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                d["episode"] = {"r": float(self._returns[i]), "l": int(self._lengths[i]),
                                "t": round(time.monotonic() - self._start, 6)}
                self._returns[i] = 0.0
                self._lengths[i] = 0
            infos.append(d)
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise NotImplementedError("the environments' attributes are set where they are made")

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list[Any]:
        values = self.venv.call(method_name, *args, **kwargs)
        return [values[i] for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


__all__ = ["Sb3VecEnv", "training_envs"]
