"""The Decision Transformer's data: the expert's trajectories made compact, and windows of them.

The trajectories are ``fallgen export-expert``'s HDF5 file (``expert.h5``: every step's
observation along each episode's expert actions). :func:`expert_file` checks a given file
against the dataset (its manifest hash, its sensors) or exports the train split into the run.
:func:`build_cache` converts it once into ``RUN/cache/`` (numpy files, memory-mapped): per
state (the observation before each action) the compact rgb, depth, segmentation and pose
(:class:`fallgen.env.wrappers.Compactor`), the action, the return-to-go (the sum of the paper's
rewards from that step on) and the step's index; per episode the step-0 clip's log-mel bands
and where its states start. :class:`Windows` draws training windows: the ``context`` states
up to a step drawn uniformly from the chosen episodes' steps, left-padded at an episode's
start (as the agent's context is at the start of an episode).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fallgen.errors import InputError
from fallgen.policies import SENSORS

IMAGE_SHAPES = {"rgb": (84, 84, 3), "depth": (84, 84, 1), "category_seg": (84, 84, 1)}
CACHE_FORMAT = "fallgen-dt-cache/2"
#: the spawn key of the generator that draws the exported episodes (``episodes`` > 0)
EXPORT_SALT = 7


def expert_file(dataset: str | Path, digest: str, run_root: Path, given: str | Path | None,
                split: str = "train", room_kind: str | None = None, episodes: int = 0,
                seed: int = 0, progress: Callable[[str, int, int], None] | None = None
                ) -> Path:
    """The expert trajectories to train on: ``given`` (checked: made from ``dataset``, with
    the sensors the policy reads), or ``RUN/expert/expert.h5``, exported here if missing:
    the split's episodes of ``room_kind``, or ``episodes`` of them drawn with ``seed`` (0:
    all); ``progress(step, done, total)``."""
    import h5py

    if given is None:
        path = run_root / "expert" / "expert.h5"
        if not path.exists():
            from fallgen.dataset.reader import Dataset
            from fallgen.env.source import select
            from fallgen.evaluation.table import subsample
            from fallgen.evaluation.trajectories import export_expert

            ids = subsample(select(Dataset(dataset), split, room_kind), episodes, seed,
                            EXPORT_SALT)
            done = [0]

            def tick(n: int) -> None:
                done[0] += n
                if progress is not None:
                    progress("expert trajectories", done[0], len(ids))

            export_expert(dataset, path.parent, ids, SENSORS, progress=tick)
    else:
        path = Path(given)
        if path.is_dir():
            path = path / "expert.h5"
        if not path.is_file():
            raise InputError(path, "<file>", "no such file (fallgen export-expert makes it)")
    try:
        with h5py.File(path, "r") as f:
            made_from = str(f.attrs.get("manifest_sha256", ""))
            sensors = json.loads(f.attrs.get("sensors", "[]"))
            n = len(f["episodes"])
    except (OSError, KeyError, ValueError) as e:
        raise InputError(path, "<file>", f"not an export-expert HDF5 file ({e})") from None
    if made_from != digest:
        raise InputError(path, "manifest_sha256", f"exported from another dataset "
                         f"({made_from[:12] or 'none'}; {dataset} has {digest[:12]})")
    missing = [s for s in SENSORS if s not in sensors]
    if missing:
        raise InputError(path, "sensors", f"lacks {', '.join(missing)} (export with --sensors "
                         f"{','.join(SENSORS)})")
    if n == 0:
        raise InputError(path, "episodes", "no episode")
    return path


def _npy(path: Path, shape: tuple[int, ...], dtype) -> np.ndarray:
    return np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=shape)


def build_cache(h5_path: Path, cache: Path, sample_rate: int,
                progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Convert the trajectories (module docstring) into ``cache`` unless it already holds
    this file's; the arrays, memory-mapped. ``progress(step, done, total)``."""
    import h5py

    from fallgen.policies.encoder import compactor

    st = h5_path.stat()
    key = {"format": CACHE_FORMAT, "file": str(h5_path.resolve()), "size": st.st_size,
           "mtime_ns": st.st_mtime_ns, "sample_rate": int(sample_rate)}
    key_path = cache / "key.json"
    if key_path.exists() and json.loads(key_path.read_text()) == key:
        return load_cache(cache)
    cache.mkdir(parents=True, exist_ok=True)
    key_path.unlink(missing_ok=True)
    with h5py.File(h5_path, "r") as f:
        eps = f["episodes"]
        names = sorted(eps, key=int)
        lengths = [int(eps[n]["actions"].shape[0]) for n in names]
        n = sum(lengths)
        arr = {k: _npy(cache / f"{k}.npy", (n, *s), np.uint8) for k, s in IMAGE_SHAPES.items()}
        arr["pose"] = _npy(cache / "pose.npy", (n, 4), np.float32)
        arr["audio"] = _npy(cache / "audio.npy", (len(names), 128), np.float32)
        for k, dt in (("action", np.int64), ("rtg", np.float32), ("t", np.int64),
                      ("episode", np.int64)):
            arr[k] = _npy(cache / f"{k}.npy", (n,), dt)
        start = np.zeros(len(names), np.int64)
        ids = np.zeros(len(names), np.int64)
        at = 0
        for e, name in enumerate(names):
            g = eps[name]
            obs = g["observations"]
            acts = g["actions"][()]
            rewards = g["rewards"][()].astype(np.float64)
            k = len(acts)
            conv = compactor(sample_rate)
            for s in range(k):
                c = conv({key_: obs[key_][s] for key_ in SENSORS}, first=s == 0)
                for key_ in IMAGE_SHAPES:
                    arr[key_][at + s] = c[key_]
                arr["pose"][at + s] = c["pose"]
                if s == 0:
                    arr["audio"][e] = c["audio"]
            arr["action"][at:at + k] = acts
            arr["rtg"][at:at + k] = np.cumsum(rewards[::-1])[::-1]
            arr["t"][at:at + k] = np.arange(k)
            arr["episode"][at:at + k] = e
            start[e], ids[e] = at, int(g.attrs["episode_id"])
            at += k
            if progress is not None:
                progress("compact trajectories", e + 1, len(names))
    np.save(cache / "start.npy", start)
    np.save(cache / "episode_id.npy", ids)
    for a in arr.values():
        a.flush()
    del arr
    tmp = key_path.with_suffix(".tmp")
    tmp.write_text(json.dumps(key))
    os.replace(tmp, key_path)
    return load_cache(cache)


def load_cache(cache: Path) -> dict[str, np.ndarray]:
    names = list(IMAGE_SHAPES) + ["pose", "audio", "action", "rtg", "t", "episode", "start",
                                  "episode_id"]
    return {k: np.load(cache / f"{k}.npy", mmap_mode="r") for k in names}


def split_episodes(n: int, holdout: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train, held-out) episode indices: a ``holdout`` fraction drawn with ``seed`` (none
    when that is less than one episode, or it would leave none to train on)."""
    order = np.random.default_rng(np.random.SeedSequence([seed, 1])).permutation(n)
    k = int(holdout * n)
    if k >= n:
        k = n - 1
    return np.sort(order[k:]), np.sort(order[:k])


class Windows:
    """Training windows of ``context`` states from the episodes ``episodes`` of ``data``."""

    def __init__(self, data: dict[str, np.ndarray], episodes: Sequence[int], context: int
                 ) -> None:
        self.data, self.context = data, int(context)
        starts = np.asarray(data["start"])
        n = len(data["action"])
        ends = np.append(starts[1:], n)
        eps = np.asarray(episodes, np.int64)
        #: every state of the chosen episodes (a window ends at one, drawn uniformly)
        self.steps = np.concatenate([np.arange(starts[e], ends[e]) for e in eps]) \
            if len(eps) else np.zeros(0, np.int64)

    def __len__(self) -> int:
        return len(self.steps)

    def batch(self, ends: np.ndarray) -> dict[str, np.ndarray]:
        """The windows ending at states ``ends``: images (B, K, ...), pose, the episode's
        audio, action, rtg, t and a mask (B, K) of the real (not padded) states."""
        d, k = self.data, self.context
        ends = np.asarray(ends, np.int64)
        idx = ends[:, None] - np.arange(k - 1, -1, -1)[None]
        ep = np.asarray(d["episode"])[ends]
        first = np.asarray(d["start"])[ep]
        mask = idx >= first[:, None]
        idx = np.where(mask, idx, ends[:, None])  # padding: any real row, masked out
        flat = idx.ravel()
        order = np.argsort(flat, kind="stable")
        take = np.empty_like(order)
        take[order] = np.arange(len(order))
        out: dict[str, np.ndarray] = {}
        for key in list(IMAGE_SHAPES) + ["pose", "action", "rtg", "t"]:
            rows = np.asarray(d[key][flat[order]])[take]  # sorted reads from the memory map
            out[key] = rows.reshape(*idx.shape, *rows.shape[1:])
        out["audio"] = np.repeat(np.asarray(d["audio"])[ep][:, None], k, axis=1)
        out["mask"] = mask
        for key in ("action", "rtg", "t"):
            out[key] = np.where(mask, out[key], 0)
        return out

    def sample(self, rng: np.random.Generator, batch_size: int) -> dict[str, np.ndarray]:
        return self.batch(self.steps[rng.integers(0, len(self.steps), batch_size)])


__all__ = ["expert_file", "build_cache", "load_cache", "split_episodes", "Windows"]
