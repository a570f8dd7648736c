"""Running agents on the episodes of a dataset: every selected episode exactly once, whatever
the number of worker processes, each episode's result depending only on the episode.

An agent is named by an :class:`AgentRef` (picklable, so that every worker makes its own): a
reference agent (``baseline``: ``expert``, ``random``, ``modular`` with its oracles), a factory
``module:function`` returning an object with ``reset()`` and ``act(obs)`` (see
:mod:`fallgen.agents.base`), or fixed action sequences (``actions``: re-scoring a file). Before
each episode the agent is reset with a seed drawn from ``SeedSequence(seed, spawn_key=
(episode_id,))``; the environment resets to the episode by its id. Workers take the episodes in
chunks; the results are sorted by id.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fallgen.nav.agent import ACTIONS

#: Episodes per unit of work handed to a worker (small: the workers stay evenly loaded).
CHUNK = 4
#: What each episode's line of ``episodes.jsonl`` holds from its row.
ROW_KEYS = ("split", "room_kind", "room_variant", "zone_kind", "category", "audio_material")


@dataclass(frozen=True)
class AgentRef:
    """Which agent: ``kind`` is ``baseline`` (``name``: expert, random, modular, objectgoal;
    ``oracles`` for modular and objectgoal, and in ``kwargs`` ``audio_model``: a model file,
    ``audio_top_k``, and ``vision_model``: a model file),
    ``factory`` (``name``: ``module:function``, called with ``kwargs``) or ``actions``
    (``actions``: episode id -> action sequence)."""

    kind: str
    name: str = ""
    oracles: tuple[str, ...] = ()
    kwargs: dict = field(default_factory=dict)
    actions: Mapping[int, tuple[int, ...]] | None = None

    def describe(self) -> str:
        if self.kind == "baseline":
            audio = "+audio" if self.kwargs.get("audio_model") else ""
            if self.kwargs.get("audio_top_k", 1) > 1:
                audio += f"(top {self.kwargs['audio_top_k']})"
            audio += "+vision" if self.kwargs.get("vision_model") else ""
            return self.name + audio + (f"[{'+'.join(self.oracles)}]" if self.oracles else "")
        if self.kind == "factory":
            return self.name
        return "actions"


class ReplayAgent:
    """Plays a fixed action sequence per episode (``fallgen evaluate --actions``); after its
    sequence ends it claims ``found`` (an episode must end: a claim out of reach fails)."""

    sensors = ("pose",)

    def __init__(self, actions: Mapping[int, Sequence[int]]) -> None:
        self.actions = actions
        self._queue: list[int] = []

    def start(self, episode_id: int) -> None:
        self._queue = list(self.actions[episode_id])[::-1]

    def reset(self) -> None:
        pass

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        return self._queue.pop() if self._queue else ACTIONS.index("found")


def load_factory(spec: str) -> Callable[..., Any]:
    """``module:function`` (or ``module:Class``, or ``path/to/file.py:Class``) -> the
    callable; ValueError naming what is wrong."""
    mod, sep, attr = spec.rpartition(":")
    if not sep or not mod or not attr:
        raise ValueError(f"{spec!r}: expected module:factory (e.g. mypkg.agents:make_agent)")
    try:
        if mod.endswith(".py"):
            module = _load_file(Path(mod))
        else:
            module = importlib.import_module(mod)
    except Exception as e:  # the user's module failed to load: one line, not a traceback
        raise ValueError(f"{spec!r}: cannot import {mod}: {type(e).__name__}: {e}") from None
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"{spec!r}: {mod} has no {attr}")
        obj = getattr(obj, part)
    if not callable(obj):
        raise ValueError(f"{spec!r}: {attr} is not callable")
    return obj


def _load_file(path: Path):
    """A module from a Python file (its directory on the import path while it loads)."""
    import importlib.util
    import sys

    if not path.is_file():
        raise ImportError(f"no file {path}")
    name = "_fallgen_agent_" + path.stem
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    sys.path.insert(0, str(path.resolve().parent))
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    finally:
        sys.path.remove(str(path.resolve().parent))
    return module


def make_agent(ref: AgentRef, category_labels: Sequence[str] = (),
               object_categories: Sequence[str] = ()) -> Any:
    """The agent ``ref`` names; the reference agents get the dataset's category table and the
    target categories."""
    if ref.kind == "baseline":
        from fallgen.agents import make_baseline

        return make_baseline(ref.name, category_labels, object_categories, ref.oracles,
                             **ref.kwargs)
    if ref.kind == "factory":
        agent = load_factory(ref.name)(**ref.kwargs)
        if not (callable(getattr(agent, "act", None)) and callable(getattr(agent, "reset", None))):
            raise ValueError(f"{ref.name!r}: made {type(agent).__name__}, which has no act(obs) "
                             "and reset()")
        return agent
    if ref.kind == "actions":
        return ReplayAgent(ref.actions or {})
    raise ValueError(f"unknown agent kind {ref.kind!r}")


def agent_seed(seed: int, episode_id: int) -> int:
    """The seed an agent gets for an episode (independent of workers and order)."""
    return int(np.random.SeedSequence(seed, spawn_key=(int(episode_id),)).generate_state(1)[0])


def play(env, agent, episode_id: int, seed: int = 0) -> dict[str, Any]:
    """One episode of ``agent`` in ``env``: its line of ``episodes.jsonl`` (row fields, the
    actions, the return and the final ``info`` measures)."""
    from fallgen.agents.base import reset_agent
    from fallgen.env.fallen_objects import END_KEYS

    obs, info = env.reset(options={"episode_id": int(episode_id)})
    if isinstance(agent, ReplayAgent):
        agent.start(int(episode_id))
    reset_agent(agent, agent_seed(seed, episode_id))
    actions: list[int] = []
    ret = 0.0
    n = len(ACTIONS)
    while True:
        a = agent.act(obs)
        try:
            a = int(a)
        except (TypeError, ValueError):
            raise ValueError(f"episode {episode_id}: the agent returned {a!r}, not an action "
                             f"index 0..{n - 1}") from None
        if not 0 <= a < n:
            raise ValueError(f"episode {episode_id}: the agent returned {a}, not an action "
                             f"index 0..{n - 1}")
        obs, reward, terminated, truncated, info = env.step(a)
        actions.append(a)
        ret += reward
        if terminated or truncated:
            break
    row = env.episode.row
    rec: dict[str, Any] = {"episode_id": int(episode_id)}
    rec.update({k: row[k] for k in ROW_KEYS})
    rec.update({k: info[k] for k in END_KEYS if k != "is_success"})
    rec.update({"steps": len(actions), "return": round(ret, 10), "actions": actions})
    return rec


# --- workers ------------------------------------------------------------------------------------

_STATE: dict[str, Any] = {}


def _make_env(dataset: str, ids: Sequence[int], ref: AgentRef, claims: int, reward: str,
              data_dir: str | None):
    """The agent, then an environment with the sensors it asks for (one world loaded)."""
    from fallgen.agents.base import agent_sensors
    from fallgen.env.fallen_objects import FallenObjectsEnv
    from fallgen.vision.camera import world_category_labels
    from fallgen.world.library import load_world

    world = load_world(data_dir)
    agent = make_agent(ref, world_category_labels(world), world.categories.ids("target"))
    env = FallenObjectsEnv(dataset, episode_ids=ids, sensors=agent_sensors(agent), claims=claims,
                           reward=reward, world=world,
                           oracle_found=bool(getattr(agent, "oracle_found", False)))
    return env, agent


def _init(dataset: str, ids: Sequence[int], ref: AgentRef, claims: int, reward: str,
          data_dir: str | None, seed: int) -> None:
    env, agent = _make_env(dataset, ids, ref, claims, reward, data_dir)
    _STATE.update(env=env, agent=agent, seed=seed)


def _work(chunk: Sequence[int]) -> list[dict[str, Any]]:
    s = _STATE
    return [play(s["env"], s["agent"], i, s["seed"]) for i in chunk]


def run_episodes(dataset: str | Path, ids: Sequence[int], ref: AgentRef, *, workers: int = 1,
                 claims: int = 1, reward: str = "paper", seed: int = 0,
                 data_dir: str | Path | None = None,
                 progress: Callable[[int], None] | None = None) -> list[dict[str, Any]]:
    """Play every episode of ``ids`` once with the agent ``ref``; their records, sorted by id.
    ``progress`` is called with the number of episodes each finished chunk held."""
    from fallgen.pipeline.executor import parallel_map

    ids = sorted(int(i) for i in ids)
    chunks = [ids[k:k + CHUNK] for k in range(0, len(ids), CHUNK)]
    args = (str(dataset), ids, ref, claims, reward, None if data_dir is None else str(data_dir),
            seed)
    out: list[dict[str, Any]] = []
    if workers <= 1 or len(chunks) <= 1:
        env, agent = _make_env(*args[:-1])
        try:
            for chunk in chunks:
                out += [play(env, agent, i, seed) for i in chunk]
                if progress:
                    progress(len(chunk))
        finally:
            env.close()
    else:
        for recs in parallel_map(_work, chunks, _init, args, min(workers, len(chunks))):
            out += recs
            if progress:
                progress(len(recs))
    return sorted(out, key=lambda r: r["episode_id"])


__all__ = ["AgentRef", "ReplayAgent", "load_factory", "make_agent", "agent_seed", "play",
           "run_episodes"]
