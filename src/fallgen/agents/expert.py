"""The expert: follows the environment's ``expert_action`` oracle (the shortest plan from the
current pose; from the spawn, the dataset's own expert actions). It scores SR = 1 and SPL = 1
on every episode of a dataset: an episode it fails is a bug."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from fallgen.nav.agent import LEFT


class ExpertAgent:
    sensors = ("expert_action",)

    def reset(self) -> None:
        pass

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        from fallgen.env.fallen_objects import NO_PLAN

        a = int(obs["expert_action"])
        return LEFT if a == NO_PLAN else a  # no plan from here (never seen): look around


__all__ = ["ExpertAgent"]
