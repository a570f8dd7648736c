"""The floor: uniformly random actions, from a generator seeded per episode.

With ``oracle_found`` it draws from the five moves alone and the environment ends the episode
in success once the object is within reach and in view (the rule the paper gave its PPO
agent): the floor to compare an agent that has the oracle found with."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from fallgen.nav.agent import ACTIONS


class RandomAgent:
    sensors = ("pose",)  # it looks at nothing; the cheapest sensor keeps the env from rendering

    def __init__(self, seed: int = 0, oracle_found: bool = False) -> None:
        self._rng = np.random.default_rng(seed)
        self.oracle_found = bool(oracle_found)
        self._n = len(ACTIONS) - 1 if self.oracle_found else len(ACTIONS)

    def reset(self, seed: int | None = None) -> None:
        if seed is not None:
            self._rng = np.random.default_rng(seed)

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        return int(self._rng.integers(self._n))


__all__ = ["RandomAgent"]
