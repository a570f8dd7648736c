"""Observations along the expert's trajectories, for imitation learning (behaviour cloning,
Decision Transformer): each selected episode's ``expert_actions`` replayed through the
environment, every step's observation kept.

Two formats:

- ``hdf5`` (h5py only): ``OUT/expert.h5`` with a group per episode, ``episodes/{id}/``:
  ``observations/{sensor}`` (n + 1, ...) (the observation before each action and after the
  last), ``actions`` (n,) int64, ``rewards`` (n,) float32, ``terminations`` / ``truncations``
  (n,) bool, and the episode's row fields and measures as attributes; file attributes: the
  dataset, its manifest hash, the sensors, ``actions`` and ``category_labels`` (JSON).
  Gzip-compressed, one chunk per step.
- ``minari`` (``pip install minari``): a Minari dataset (Farama's offline-RL format) at
  ``OUT/{dataset_id}``, loadable with ``MINARI_DATASETS_PATH=OUT`` and
  ``minari.load_dataset(dataset_id)``; its environment spec recreates the environment
  (``dataset.recover_environment()``); images are stored raw (Minari's JPEG encoding is lossy).

An episode whose replay does not succeed is an error (the dataset and the environment
disagree), never a silent gap.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

FORMATS = ("hdf5", "minari")
#: Row fields kept as attributes of an episode's group.
ROW_ATTRS = ("split", "room_kind", "room_variant", "zone_kind", "category", "audio_material",
             "event_id")


@dataclass
class Trajectory:
    episode_id: int
    observations: dict[str, np.ndarray]  # sensor -> (n + 1, ...)
    actions: np.ndarray  # (n,) int64
    rewards: np.ndarray  # (n,) float32
    terminations: np.ndarray  # (n,) bool
    truncations: np.ndarray  # (n,) bool
    row: dict[str, Any]
    measures: dict[str, Any]


def replay_expert(env, episode_id: int) -> Trajectory:
    """The episode's stored ``expert_actions`` played through ``env``, every observation
    kept; ValueError if the replay does not end in success."""
    from fallgen.env.fallen_objects import END_KEYS

    obs, _ = env.reset(options={"episode_id": int(episode_id)})
    row = env.episode.row
    steps: list[dict[str, np.ndarray]] = [obs]
    rewards, terms, truncs = [], [], []
    info: dict[str, Any] = {}
    actions = [int(a) for a in row["expert_actions"]]
    for k, a in enumerate(actions):
        obs, r, term, trunc, info = env.step(a)
        steps.append(obs)
        rewards.append(r)
        terms.append(term)
        truncs.append(trunc)
        if (term or trunc) and k != len(actions) - 1:
            break
    if not info.get("success") or len(rewards) != len(actions):
        raise ValueError(f"episode {episode_id}: its expert actions do not succeed in the "
                         f"environment ({info.get('outcome', 'not ended')} after "
                         f"{len(rewards)} of {len(actions)} actions)")
    stacked = {k: np.stack([np.asarray(o[k]) for o in steps]) for k in steps[0]}
    return Trajectory(int(episode_id), stacked, np.asarray(actions, np.int64),
                      np.asarray(rewards, np.float32), np.asarray(terms, bool),
                      np.asarray(truncs, bool), row,
                      {k: info[k] for k in END_KEYS if k != "is_success"})


def export_expert(dataset: str | Path, out: str | Path, ids: Sequence[int],
                  sensors: Sequence[str], fmt: str = "hdf5", dataset_id: str | None = None,
                  data_dir: str | Path | None = None,
                  progress: Callable[[int], None] | None = None) -> Path:
    """Write the expert trajectories of episodes ``ids`` with ``sensors``; the file or
    directory written."""
    from fallgen.env.fallen_objects import FallenObjectsEnv

    if fmt not in FORMATS:
        raise ValueError(f"format {fmt!r}: one of {', '.join(FORMATS)}")
    env = FallenObjectsEnv(dataset, episode_ids=list(ids), sensors=tuple(sensors),
                           data_dir=data_dir)
    try:
        if fmt == "hdf5":
            return _write_hdf5(env, Path(out), ids, progress)
        return _write_minari(env, Path(out), ids, dataset_id, progress)
    finally:
        env.close()


def _write_hdf5(env, out: Path, ids: Sequence[int], progress) -> Path:
    import h5py

    from fallgen.atomic import commit
    from fallgen.evaluation.scores import manifest_hash
    from fallgen.nav.agent import ACTIONS

    out.mkdir(parents=True, exist_ok=True)
    path = out / "expert.h5"
    tmp = out / "expert.h5.tmp"
    try:
        with h5py.File(tmp, "w", track_order=True) as f:
            f.attrs["dataset"] = str(env.ds.root.resolve())
            f.attrs["manifest_sha256"] = manifest_hash(env.ds.root) or ""
            f.attrs["sensors"] = json.dumps(list(env.sensors))
            f.attrs["actions"] = json.dumps(list(ACTIONS))
            f.attrs["category_labels"] = json.dumps(list(env.category_labels))
            eps = f.create_group("episodes", track_order=True)
            for eid in ids:
                t = replay_expert(env, eid)
                g = eps.create_group(str(t.episode_id))
                obs = g.create_group("observations")
                for k, a in t.observations.items():
                    big = a.ndim > 1 and a[0].size > 64
                    obs.create_dataset(k, data=a, chunks=(1, *a.shape[1:]) if big else None,
                                       compression="gzip" if big else None,
                                       shuffle=big, track_times=False)
                for k in ("actions", "rewards", "terminations", "truncations"):
                    g.create_dataset(k, data=getattr(t, k), track_times=False)
                g.attrs["episode_id"] = t.episode_id
                for k in ROW_ATTRS:
                    g.attrs[k] = t.row[k]
                for k, v in t.measures.items():
                    g.attrs[k] = v
                if progress:
                    progress(1)
        commit(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def _write_minari(env, out: Path, ids: Sequence[int], dataset_id: str | None,
                  progress) -> Path:
    import os
    import warnings

    try:
        import minari
        from minari.data_collector import EpisodeBuffer
    except ImportError:
        raise ValueError("--format minari needs Minari: pip install 'minari[hdf5]'") from None
    import gymnasium as gym

    import fallgen.env  # noqa: F401  (registers the environment's id)
    from fallgen.env import ENV_ID

    dataset_id = dataset_id or "fallgen/expert-v0"
    out.mkdir(parents=True, exist_ok=True)
    kwargs = {"dataset": str(env.ds.root.resolve()), "episode_ids": [int(i) for i in ids],
              "sensors": list(env.sensors)}
    spec = gym.spec(ENV_ID)
    spec = gym.envs.registration.EnvSpec(id=spec.id, entry_point=spec.entry_point,
                                         kwargs=kwargs)
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(out)
    try:
        made = None
        for k, eid in enumerate(ids):
            t = replay_expert(env, eid)
            buf = EpisodeBuffer(id=k, observations=t.observations, actions=t.actions,
                                rewards=list(t.rewards.astype(float)),
                                terminations=list(t.terminations),
                                truncations=list(t.truncations),
                                infos={"episode_id": np.full(len(t.actions) + 1, t.episode_id)})
            if made is None:
                with warnings.catch_warnings():  # no author, e-mail or code link: local data
                    warnings.filterwarnings("ignore", "`(author|author_email|code_permalink)`",
                                            UserWarning)
                    made = _create(minari, dataset_id, buf, spec, env, ids, ENV_ID)
            else:
                made.storage.update_episodes([buf])
            if progress:
                progress(1)
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = old
    return out / dataset_id


def _create(minari, dataset_id: str, buf, spec, env, ids: Sequence[int], env_id: str):
    return minari.create_dataset_from_buffers(
        dataset_id, [buf], env=spec, eval_env=spec,
        algorithm_name="fallgen expert (shortest path in the action lattice)",
        observation_space=env.observation_space, action_space=env.action_space,
        jpeg_encoding=False,
        description=f"Expert trajectories of {len(ids)} episodes of the fallgen dataset "
        f"{env.ds.root.resolve()}, replayed through {env_id}.")


__all__ = ["FORMATS", "Trajectory", "replay_expert", "export_expert"]
