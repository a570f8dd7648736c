"""The floor: uniformly random actions, from a generator seeded per episode."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from fallgen.nav.agent import ACTIONS


class RandomAgent:
    sensors = ("pose",)  # it looks at nothing; the cheapest sensor keeps the env from rendering

    def __init__(self, seed: int = 0) -> None:
        self._rng = np.random.default_rng(seed)

    def reset(self, seed: int | None = None) -> None:
        if seed is not None:
            self._rng = np.random.default_rng(seed)

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        return int(self._rng.integers(len(ACTIONS)))


__all__ = ["RandomAgent"]
