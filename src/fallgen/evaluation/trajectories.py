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
- ``minari`` (``pip install 'fallgen[minari]'``): a Minari dataset (Farama's offline-RL
  format) at ``OUT/{dataset_id}``, loadable with ``MINARI_DATASETS_PATH=OUT`` and
  ``minari.load_dataset(dataset_id)``. Its episodes are Minari's own layout (each written by
  Minari), copied into its HDF5 file compressed as the ``hdf5`` export is (gzip, one chunk per
  step) and without the chunks that hold only zeros: the audio after step 0 (the environment
  gives the clip once) is not stored, and reads back as zeros. ``infos`` holds, at every step,
  the environment's ``episode_id``, ``step`` and ``moved``, and the episode's measures
  (:data:`fallgen.env.END_KEYS`: success, spl, sna, soft_spl, path length, ...), which the
  environment gives at the last step: before it they are NaN, -1, False or "" by type. Each
  episode's metadata (Minari's episode attributes) holds the dataset's episode id and its
  row's split, room, zone kind, category and material. Its environment spec recreates the
  environment (``dataset.recover_environment()``) from the dataset path as it was given
  (relative paths stay relative: run from the same directory). Images are stored raw
  (Minari's JPEG encoding is lossy). The dataset is made under a temporary name in ``OUT``
  and renamed to ``OUT/{dataset_id}`` when complete: a failed or killed export leaves no
  dataset behind, and an existing one is never overwritten.

An episode whose replay does not succeed is an error (the dataset and the environment
disagree), never a silent gap.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fallgen.errors import InputError

FORMATS = ("hdf5", "minari")
#: Row fields kept as attributes of an episode's group.
ROW_ATTRS = ("split", "room_kind", "room_variant", "zone_kind", "category", "audio_material",
             "event_id")
#: What the Minari export needs besides fallgen's own packages (Minari's HDF5 storage imports
#: Pillow without declaring it): module -> the pip requirement that provides it.
MINARI_MODULES = {"minari": "minari[hdf5]", "h5py": "h5py", "PIL": "pillow"}
#: Per-step arrays larger than this many elements are stored one chunk per step, compressed.
BIG = 64


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
    infos: list[dict[str, Any]]  # n + 1: the reset's info, then each step's


def replay_expert(env, episode_id: int) -> Trajectory:
    """The episode's stored ``expert_actions`` played through ``env``, every observation
    and ``info`` kept; ValueError if the replay does not end in success."""
    from fallgen.env.fallen_objects import END_KEYS

    obs, info = env.reset(options={"episode_id": int(episode_id)})
    row = env.episode.row
    steps: list[dict[str, np.ndarray]] = [obs]
    infos: list[dict[str, Any]] = [info]
    rewards, terms, truncs = [], [], []
    actions = [int(a) for a in row["expert_actions"]]
    for k, a in enumerate(actions):
        obs, r, term, trunc, info = env.step(a)
        steps.append(obs)
        infos.append(info)
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
                      {k: info[k] for k in END_KEYS if k != "is_success"}, infos)


def export_expert(dataset: str | Path, out: str | Path, ids: Sequence[int],
                  sensors: Sequence[str], fmt: str = "hdf5", dataset_id: str | None = None,
                  data_dir: str | Path | None = None,
                  progress: Callable[[int], None] | None = None) -> Path:
    """Write the expert trajectories of episodes ``ids`` with ``sensors``; the file or
    directory written. Raises :class:`~fallgen.errors.InputError` (one line naming the file
    or option) for what the user can fix: a format, a Minari dataset id that exists or is
    malformed, Minari not installed, an episode whose expert does not succeed."""
    from fallgen.env.fallen_objects import FallenObjectsEnv

    if fmt not in FORMATS:
        raise InputError("<command line>", "--format", f"{fmt!r}: one of {', '.join(FORMATS)}")
    out = Path(out)
    if fmt == "minari":
        dataset_id = dataset_id or "fallgen/expert-v0"
        _minari_preflight(out, dataset_id)
    env = FallenObjectsEnv(dataset, episode_ids=list(ids), sensors=tuple(sensors),
                           data_dir=data_dir)
    try:
        if fmt == "hdf5":
            return _write_hdf5(env, out, ids, progress)
        return _write_minari(env, Path(dataset), out, ids, dataset_id, data_dir, progress)
    except ValueError as e:
        if "expert actions do not succeed" in str(e):
            raise InputError(env.ds.root, "expert_actions", str(e)) from None
        raise
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
                    big = a.ndim > 1 and a[0].size > BIG
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


# --- Minari -----------------------------------------------------------------------------------

def _minari_preflight(out: Path, dataset_id: str) -> None:
    """Before any work: Minari and what its HDF5 storage imports are installed, the id is one
    Minari accepts, and ``OUT/{dataset_id}`` does not exist."""
    import importlib

    missing = []
    for mod, req in MINARI_MODULES.items():
        try:
            importlib.import_module(mod)
        except ImportError:
            missing.append(req)
    if missing:
        raise InputError("<command line>", "--format", "minari needs "
                         f"{', '.join(missing)}: pip install 'fallgen[minari]'")
    from minari.dataset.minari_dataset import parse_dataset_id

    try:
        parse_dataset_id(dataset_id)
    except ValueError as e:
        raise InputError("<command line>", "--dataset-id", str(e)) from None
    if (out / dataset_id).exists():
        raise InputError(out / dataset_id, "--dataset-id", "a dataset is already there (remove "
                         "it, or export under another id or --out)")


def _staging(out: Path, dataset_id: str) -> Path:
    """A fresh temporary directory in ``out`` for the dataset being made (the same file
    system: it is renamed into place); those left by exports no longer running are removed."""
    stem = "." + dataset_id.replace("/", "__") + ".tmp-"
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob(stem + "*"):
        pid = old.name[len(stem):]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(old, ignore_errors=True)
    tmp = out / f"{stem}{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    return tmp


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _infos(t: Trajectory) -> dict[str, Any]:
    """Minari's ``infos``: every key of any step's info at every one of the n + 1 steps; a key
    the environment gives only at the end is NaN, -1, False or "" (by its type) before."""
    keys: list[str] = []
    for info in t.infos:
        keys += [k for k in info if k not in keys]
    out: dict[str, Any] = {}
    for k in keys:
        last = next(info[k] for info in reversed(t.infos) if k in info)
        if isinstance(last, str):
            out[k] = [str(info.get(k, "")) for info in t.infos]
            continue
        if isinstance(last, (bool, np.bool_)):
            dtype, fill = bool, False
        elif isinstance(last, (int, np.integer)):
            dtype, fill = np.int64, -1
        else:
            dtype, fill = np.float64, np.nan
        out[k] = np.array([info.get(k, fill) for info in t.infos], dtype)
    return out


def _copy_compressed(src, dst) -> None:
    """Copy the HDF5 group ``src`` into the (new) group ``dst``: attributes, subgroups, and
    datasets, those with large per-step arrays one chunk per step, gzip-compressed, with only
    the chunks that are not all zeros written (a chunk never written reads back as zeros)."""
    import h5py

    for k, v in src.attrs.items():
        dst.attrs[k] = v
    for name, item in src.items():
        if isinstance(item, h5py.Group):
            _copy_compressed(item, dst.create_group(name, track_order=True))
            continue
        numeric = item.dtype.kind in "biuf"
        if not numeric or item.ndim == 0:
            src.copy(item, dst, name)
            continue
        per_step = int(np.prod(item.shape[1:], dtype=np.int64))
        chunks = (1, *item.shape[1:]) if per_step > BIG else True
        d = dst.create_dataset(name, shape=item.shape, dtype=item.dtype,
                               maxshape=item.maxshape, chunks=chunks, compression="gzip",
                               shuffle=True, fillvalue=np.zeros((), item.dtype),
                               track_times=False)
        if per_step > BIG:
            for i in range(item.shape[0]):
                row = item[i]
                if row.any():
                    d[i] = row
        else:
            d[...] = item[()]


def _write_minari(env, dataset: Path, out: Path, ids: Sequence[int], dataset_id: str,
                  data_dir: str | Path | None, progress) -> Path:
    import warnings

    import gymnasium as gym
    import h5py
    import minari
    from minari.data_collector import EpisodeBuffer
    from minari.dataset.minari_storage import MinariStorage

    import fallgen.env  # noqa: F401  (registers the environment's id)
    from fallgen.env import ENV_ID

    kwargs: dict[str, Any] = {"dataset": str(dataset), "episode_ids": [int(i) for i in ids],
                              "sensors": list(env.sensors)}
    if data_dir is not None:
        kwargs["data_dir"] = str(data_dir)
    registered = gym.spec(ENV_ID)
    spec = gym.envs.registration.EnvSpec(id=registered.id, entry_point=registered.entry_point,
                                         max_episode_steps=registered.max_episode_steps,
                                         kwargs=kwargs)
    staging = _staging(out.absolute(), dataset_id)
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(staging)
    try:
        with warnings.catch_warnings():  # no author, e-mail or code link: local data
            warnings.filterwarnings("ignore", "`(author|author_email|code_permalink)`",
                                    UserWarning)
            made = minari.create_dataset_from_buffers(
                dataset_id, [], env=spec, eval_env=spec,
                algorithm_name="fallgen expert (shortest path in the action lattice)",
                observation_space=env.observation_space, action_space=env.action_space,
                jpeg_encoding=False,
                description=f"Expert trajectories of {len(ids)} episodes of the fallgen "
                f"dataset {dataset}, replayed through {ENV_ID}.")
        data = Path(made.storage.data_path)
        (main,) = data.glob("*.hdf5")
        steps = 0
        b = h5py.File(main, "a", track_order=True)
        for k, eid in enumerate(ids):
            t = replay_expert(env, eid)
            buf = EpisodeBuffer(id=0, observations=t.observations, actions=t.actions,
                                rewards=list(t.rewards.astype(float)),
                                terminations=list(t.terminations),
                                truncations=list(t.truncations), infos=_infos(t))
            # Minari writes the episode (its own layout) into a scratch storage; the copy
            # into the dataset is compressed
            (staging / "scratch" / str(k)).mkdir(parents=True)
            scratch = MinariStorage.new(staging / "scratch" / str(k), env.observation_space,
                                        env.action_space, jpeg_encoding=False)
            scratch.update_episodes([buf])
            (one,) = Path(scratch.data_path).glob("*.hdf5")
            with h5py.File(one, "r") as a:
                g = b.create_group(f"episode_{k}", track_order=True)
                _copy_compressed(a["episode_0"], g)
                g.attrs["id"] = k
                g.attrs["episode_id"] = t.episode_id
                for key in ROW_ATTRS:
                    g.attrs[key] = t.row[key]
            shutil.rmtree(staging / "scratch" / str(k))
            steps += len(t.actions)
            if progress:
                progress(1)
        b.close()
        shutil.rmtree(staging / "scratch", ignore_errors=True)
        made.storage.update_metadata({"total_steps": steps, "total_episodes": len(ids),
                                      "dataset_size": made.storage.get_size()})
        return _publish(staging, out, dataset_id)
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = old
        shutil.rmtree(staging, ignore_errors=True)


def _publish(staging: Path, out: Path, dataset_id: str) -> Path:
    """Rename the finished dataset from ``staging`` to ``out/{dataset_id}`` (with its
    namespaces' metadata where ``out`` lacks it)."""
    from fallgen.atomic import fsync_dir

    target = out / dataset_id
    if target.exists():  # made meanwhile by another export
        raise InputError(target, "--dataset-id", "a dataset is already there")
    parts = Path(dataset_id).parts
    for n in range(1, len(parts)):  # the namespaces (directories above the dataset)
        src, dst = staging.joinpath(*parts[:n]), out.joinpath(*parts[:n])
        dst.mkdir(exist_ok=True)
        for f in src.glob("*.json"):
            if not (dst / f.name).exists():
                shutil.copy2(f, dst / f.name)
    os.replace(staging / dataset_id, target)
    fsync_dir(target.parent)
    return target


__all__ = ["FORMATS", "Trajectory", "replay_expert", "export_expert", "MINARI_MODULES"]
