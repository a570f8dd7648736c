"""Reference agents of the benchmark, and the protocol every agent follows (:mod:`.base`).

- ``expert``: the environment's shortest-path oracle (SR = SPL = 1 on every episode);
- ``random``: uniform random actions (the floor);
- ``modular``: the paper's modular planning agent (a map from depth and segmentation, A*,
  frontier exploration), with oracle switches ``segmentation``, ``category``, ``location``,
  the learned audio module as its goal predictor (:mod:`.audio_goal`) and the learned visual
  module as its eyes (:mod:`.vision_detector`) where they are off;
- ``objectgoal``: the paper's Object-Goal baseline (:mod:`.objectgoal`): the same mapping,
  eyes and frontier exploration with no audio, told five candidate categories.

:func:`make_baseline` (:mod:`.baselines`) makes them by name. The submodules import from
:mod:`.base`, never from this package, so nothing here imports back.
"""

from __future__ import annotations

from fallgen.agents.base import ORACLES, Agent, agent_sensors, reset_agent
from fallgen.agents.baselines import BASELINES, make_baseline

__all__ = ["Agent", "BASELINES", "ORACLES", "make_baseline", "agent_sensors", "reset_agent"]
