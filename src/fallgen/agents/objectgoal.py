"""The Object-Goal baseline (the paper's Table 1; Chaplot et al. 2020's semantic exploration):
visual semantic navigation with no audio, told that one of five candidate categories has
fallen.

It is the modular agent (:class:`fallgen.agents.modular.ModularAgent`: a map from its own
depth, frontier exploration, a semantic goal from what it sees) with no goal predictor, so no
idea where to look, and eyes that are a :class:`fallgen.agents.modular.Detector` (the learned
visual module, :class:`fallgen.agents.vision_detector.VisionDetector`) or the ``segmentation``
oracle. Each episode it is told five candidate categories (:func:`candidate_categories`): the
fallen object's and four others drawn from the other target categories, in a shuffled order,
from a generator keyed by the episode (the seed ``fallgen evaluate`` gives the agent for it:
``SeedSequence(seed, spawn_key=(episode_id,))``), never from global state. It reads the true
category once, from the ``object_category`` sensor at step 0, only to make that list.

Its heuristic for which object fell (the paper's baseline had one too): after a first look
around (as the modular agent does), it takes any object of a candidate category it sees for the
fallen one, goes to the one it has seen with the most pixels (the first seen of equals; a
better seen one found on the way replaces it) and claims it from within reach; with more than
one claim allowed (``fallgen evaluate --claims``), a wrong claim sends it to the next. A
fallen object bears no mark of its fall in a still room, so a candidate in view is as good a
guess as any: what the agent lacks against the modular planner is where to look and which of
the five it is, both of which the sound tells.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence

import numpy as np

from fallgen.agents.modular import Detector, ModularAgent
from fallgen.nav.agent import AgentSpec

#: how many categories the agent is told (one of them right)
CANDIDATES = 5
#: the only oracle it takes (its eyes, in place of a detector)
OBJECTGOAL_ORACLES = ("segmentation",)


def candidate_categories(true_category: str, targets: Collection[str], seed: int,
                         k: int = CANDIDATES) -> tuple[str, ...]:
    """``true_category`` and ``k - 1`` other categories of ``targets``, shuffled; drawn from
    ``numpy.random.default_rng(SeedSequence(seed))``."""
    others = sorted(set(targets) - {true_category})
    if len(others) < k - 1:
        raise ValueError(f"{len(others) + 1} target categories: fewer than {k} candidates")
    rng = np.random.default_rng(np.random.SeedSequence(int(seed)))
    chosen = [true_category] + [others[i] for i in rng.choice(len(others), k - 1,
                                                                replace=False)]
    return tuple(chosen[i] for i in rng.permutation(k))


class ObjectGoalAgent(ModularAgent):
    """Object-Goal: the modular agent without audio, looking for any of five candidate
    categories (see the module's doc). ``oracles``: empty (a ``detector`` is then needed) or
    ``("segmentation",)``."""

    def __init__(self, category_labels: Sequence[str], object_categories: Collection[str],
                 oracles: Collection[str] = (), detector: Detector | None = None,
                 spec: AgentSpec = AgentSpec(), candidates: int = CANDIDATES) -> None:
        bad = sorted(set(oracles) - set(OBJECTGOAL_ORACLES))
        if bad:
            raise ValueError(f"oracle {bad[0]!r}: Object-Goal takes only "
                             f"{', '.join(OBJECTGOAL_ORACLES)}")
        if detector is None and "segmentation" not in oracles:
            raise ValueError("Object-Goal needs eyes: a detector (a vision model) or the "
                             "segmentation oracle")
        self.targets = tuple(sorted(object_categories))
        self.k = int(candidates)
        self.seed = 0
        self.told: tuple[str, ...] = ()
        super().__init__(category_labels, object_categories, oracles=tuple(oracles),
                         predictor=None, detector=detector, spec=spec)
        self.sensors = tuple(self.sensors) + ("object_category",)

    def reset(self, seed: int | None = None) -> None:  # noqa: D401 - the Agent protocol
        """A new episode; ``seed`` (from ``fallgen evaluate``: keyed by the episode) draws
        its candidates."""
        self.seed = 0 if seed is None else int(seed)
        self.told = ()
        super().reset()

    def _start(self, obs: Mapping[str, np.ndarray]) -> None:
        true = self.labels[int(obs["object_category"])]
        self.told = candidate_categories(true, self.targets, self.seed, self.k)
        self.target_idx = np.array(sorted(self.labels.index(c) for c in self.told
                                          if c in self.labels), np.int64)
        super()._start(obs)


__all__ = ["ObjectGoalAgent", "candidate_categories", "CANDIDATES", "OBJECTGOAL_ORACLES"]
