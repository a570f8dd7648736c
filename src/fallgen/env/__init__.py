"""The benchmark's environment: an agent acts in the episodes of a built dataset.

    import gymnasium as gym
    import fallgen.env                       # registers fallgen/FallenObjects-v0

    env = gym.make("fallgen/FallenObjects-v0", dataset="build/full", split="test")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

    vec = fallgen.env.make_vec("build/full", num_envs=2, split="train")
    vec.send(actions, env_ids); ready = vec.recv()   # or vec.step(actions), in lockstep

See :mod:`fallgen.env.fallen_objects` for the observations, actions, reward and judging.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from fallgen.env.fallen_objects import (BASIC_SENSORS, END_KEYS, NO_PLAN, ORACLE_SENSORS,
                                        SENSORS, FallenObjectsEnv)
from fallgen.env.vector import Ready, VectorEnv, make_vec
from fallgen.nav.agent import MAX_ACTIONS

ENV_ID = "fallgen/FallenObjects-v0"

if ENV_ID not in registry:
    # the environment truncates itself after MAX_ACTIONS; the spec says so too (libraries read
    # spec.max_episode_steps), and gym.make's TimeLimit truncates at the same step
    register(id=ENV_ID, entry_point="fallgen.env.fallen_objects:FallenObjectsEnv",
             max_episode_steps=MAX_ACTIONS)

__all__ = ["ENV_ID", "FallenObjectsEnv", "make_vec", "VectorEnv", "Ready", "SENSORS",
           "BASIC_SENSORS", "ORACLE_SENSORS", "NO_PLAN", "END_KEYS"]
