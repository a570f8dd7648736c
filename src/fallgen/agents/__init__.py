"""Reference agents of the benchmark, and the protocol every agent follows (:mod:`.base`).

- ``expert``: the environment's shortest-path oracle (SR = SPL = 1 on every episode);
- ``random``: uniform random actions (the floor);
- ``modular``: the paper's modular planning agent (a map from depth and segmentation, A*,
  frontier exploration), with oracle switches ``segmentation``, ``category``, ``location``,
  and the learned audio module as its goal predictor (:mod:`.audio_goal`) where they are off.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

from fallgen.agents.base import Agent, agent_sensors, reset_agent

BASELINES = ("expert", "random", "modular")
ORACLES = ("segmentation", "category", "location")


def make_baseline(name: str, category_labels: Sequence[str] = (),
                  object_categories: Collection[str] = (),
                  oracles: Collection[str] | None = None, audio_model: str | None = None,
                  audio_top_k: int = 1):
    """The reference agent ``name``; ``category_labels`` (the dataset's segmentation table)
    and ``object_categories`` (the target categories) for the modular agent, with ``oracles``
    (None: all three; empty: none) and an audio model file (``fallgen audio-model train``)
    as its goal predictor (``audio_top_k`` categories taken for the object)."""
    if name == "expert":
        from fallgen.agents.expert import ExpertAgent

        return ExpertAgent()
    if name == "random":
        from fallgen.agents.random_agent import RandomAgent

        return RandomAgent()
    if audio_model and name != "modular":
        raise ValueError(f"an audio model is for the modular agent, not {name!r}")
    if name == "modular":
        from fallgen.agents.modular import ModularAgent

        oracles = ORACLES if oracles is None else tuple(oracles)
        predictor = None
        if audio_model:
            from fallgen.agents.audio_goal import AudioGoalPredictor

            predictor = AudioGoalPredictor(audio_model, top_k=audio_top_k)
        return ModularAgent(category_labels, object_categories, oracles=oracles,
                            predictor=predictor)
    raise ValueError(f"unknown baseline {name!r}: {', '.join(BASELINES)}")


__all__ = ["Agent", "BASELINES", "ORACLES", "make_baseline", "agent_sensors", "reset_agent"]
