"""What an agent is to ``fallgen evaluate``: the :class:`Agent` protocol.

    class MyAgent:
        sensors = ("rgb", "depth", "audio", "pose")   # optional: what it observes
        def reset(self, seed=None): ...               # a new episode (seed: optional)
        def act(self, obs) -> int: ...                 # an action index (fallgen.nav.agent.ACTIONS)

``sensors`` (optional, default ``fallgen.env.BASIC_SENSORS``) names the observations the agent
needs, oracle sensors included (``fallgen.env.ORACLE_SENSORS``); the environment renders only
those. ``reset`` is called before each episode; if it takes a ``seed`` argument it gets one
derived from the evaluation's seed and the episode id, so an agent that draws random numbers
from it acts the same whatever the worker count or the episode order.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

#: the modular agent's oracle switches (``fallgen evaluate --oracles``)
ORACLES = ("segmentation", "category", "location")


@runtime_checkable
class Agent(Protocol):
    def reset(self) -> None: ...

    def act(self, obs: Mapping[str, np.ndarray]) -> int: ...


def agent_sensors(agent: Any) -> tuple[str, ...]:
    """The sensors ``agent`` declares (``fallgen.env.BASIC_SENSORS`` when it declares none)."""
    from fallgen.env.fallen_objects import BASIC_SENSORS

    s = getattr(agent, "sensors", None)
    return tuple(s) if s else BASIC_SENSORS


def reset_agent(agent: Any, seed: int) -> None:
    """Call ``agent.reset``, with ``seed`` when it takes one."""
    try:
        params = inspect.signature(agent.reset).parameters
    except (TypeError, ValueError):
        params = {}
    if "seed" in params or any(p.kind == p.VAR_KEYWORD for p in params.values()):
        agent.reset(seed=seed)
    else:
        agent.reset()


__all__ = ["Agent", "ORACLES", "agent_sensors", "reset_agent"]
