"""SAVi's parts: the audio goal descriptor and its first stage, and the observation memory.

:class:`GoalDescriptor`: from the step-0 clip's cues, the fallen object's category (logits
over the dataset's category table) and where it fell in the spawn's frame (forward, left,
over :data:`PLACE_SCALE_M`). The cues are those of the auditory perception module
(:class:`fallgen.perception.audio_features.AudioFeatures`: the spectrum of each ear, the
interaural time and level differences of the direct sound, the decay, the echoes, the
direct-to-reverberant ratios), standardised with the train split's mean and spread (kept in
the descriptor). Band energies alone (the policy's ``audio``) carry no interaural time
difference: a descriptor on them placed the paper-size build's validation falls 2.87 m off
(median), against 3.27 m untrained. :func:`pretrain_goal` is the first stage: it is trained
on the train split's clips against their episodes' category and place, the targets the
auditory perception module (:mod:`fallgen.perception.audio_model`) learns, and scored on the
validation split; the policy's training then fine-tunes its place with the true place of
each episode it plays.

:class:`MemoryObservation`: the compact observations (:class:`fallgen.env.wrappers.
CompactObservation`) of the last ``memory`` steps, oldest first, for the transformer memory:
``rgb``, ``depth``, ``category_seg`` (M, 84, 84, C), ``pose`` (M, 4), ``valid`` (M,) (1 for a
step of this episode, 0 for the padding before its first), the held ``audio`` (128,), the
held ``cues`` (F,) of the step-0 clip (raw, as :meth:`AudioFeatures.extract` gives them), and
``goal_place`` (2,): the object's true place in the spawn's frame over
:data:`PLACE_SCALE_M` (from the oracle ``object_position`` at step 0), a training label the
policy never reads.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces
from torch import nn

from fallgen.env.wrappers import CompactObservation
from fallgen.perception.audio_features import AudioFeatures

#: Places are learned over this scale (rooms are a few metres across).
PLACE_SCALE_M = 10.0
FRAME_KEYS = ("rgb", "depth", "category_seg", "pose")


#: Cues per clip (the default :class:`AudioFeatures`' names).
N_CUES = len(AudioFeatures().names)


class GoalDescriptor(nn.Module):
    """(B, F) raw cues -> (category logits (B, n), place (B, 2)); the cues are standardised
    with ``shift`` and ``scale`` (buffers, set from the first stage's clips by
    :meth:`fit_scaling`)."""

    def __init__(self, n_categories: int, cues: int = N_CUES, hidden: int = 256) -> None:
        super().__init__()
        self.register_buffer("shift", torch.zeros(cues))
        self.register_buffer("scale", torch.ones(cues))
        self.body = nn.Sequential(nn.Linear(cues, hidden), nn.ReLU(),
                                  nn.Linear(hidden, hidden), nn.ReLU())
        self.category = nn.Linear(hidden, n_categories)
        self.place = nn.Linear(hidden, 2)

    def fit_scaling(self, x: torch.Tensor) -> None:
        """Standardise with ``x``'s mean and spread (a constant cue is left as it is)."""
        x = x.float()
        sd = x.std(0) if len(x) > 1 else torch.ones_like(x[0])
        self.shift.copy_(x.mean(0))
        self.scale.copy_(torch.where(sd > 1e-6, sd, torch.ones_like(sd)))

    def forward(self, cues: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.body((cues.float() - self.shift) / self.scale)
        return self.category(h), self.place(h)


def clip_targets(dataset: str | Path, split: str, room_kind: str | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cues (N, F), category index (N,), place (N, 2) / PLACE_SCALE_M) of the split's
    episodes (their step-0 clips, as the environment gives them)."""
    from fallgen.dataset.reader import Dataset
    from fallgen.perception.audio_features import relative_place
    from fallgen.perception.audio_model import dataset_features, feature_matrix

    ds = Dataset(dataset)
    labels = list(ds.category_labels)
    rows = [ds.row(i) for i in ds.ids(split, room_kind)]
    x = feature_matrix(ds, rows, dataset_features(ds, rows)) if rows \
        else np.zeros((0, N_CUES), np.float32)
    cat = np.array([labels.index(r["category"]) for r in rows], np.int64)
    place = np.array([[d * np.cos(az), d * np.sin(az)] for az, d in map(relative_place, rows)],
                     np.float32).reshape(-1, 2) / PLACE_SCALE_M
    return x, cat, place


def goal_loss(goal: GoalDescriptor, x, cat, place, with_category: bool = True):
    logits, p = goal(x)
    loss = nn.functional.mse_loss(p, place)
    if with_category:
        loss = loss + nn.functional.cross_entropy(logits, cat)
    return loss


def goal_scores(goal: GoalDescriptor, x, cat, place) -> dict[str, float]:
    """Category accuracy and the median place error (m)."""
    if len(x) == 0:
        return {"category_accuracy": float("nan"), "place_error_m": float("nan")}
    with torch.no_grad():
        logits, p = goal(x)
    err = torch.linalg.norm(p - place, dim=1) * PLACE_SCALE_M
    return {"category_accuracy": float((logits.argmax(1) == cat).float().mean()),
            "place_error_m": float(err.median())}


def pretrain_goal(goal: GoalDescriptor, dataset: str | Path, split: str,
                  room_kind: str | None, epochs: int, lr: float, seed: int,
                  device: Any = "cpu") -> dict[str, Any]:
    """The first stage (module docstring): full-batch Adam for ``epochs`` on the split's
    clips; the scores on it and on the validation split (when there is one) before and
    after."""
    from fallgen.dataset.reader import Dataset

    def tensors(split_name):
        x, c, p = clip_targets(dataset, split_name, room_kind)
        return (torch.as_tensor(x, device=device), torch.as_tensor(c, device=device),
                torch.as_tensor(p, device=device))

    train = tensors(split)
    val = tensors("validation") if "validation" in Dataset(dataset).splits else None
    goal.fit_scaling(train[0])
    out: dict[str, Any] = {"episodes": int(len(train[0])),
                           "train_before": goal_scores(goal, *train)}
    if val is not None:
        out["validation_before"] = goal_scores(goal, *val)
    opt = torch.optim.Adam(goal.parameters(), lr=lr)
    for _ in range(int(epochs)):
        opt.zero_grad(set_to_none=True)
        goal_loss(goal, *train).backward()
        opt.step()
    out["train"] = goal_scores(goal, *train)
    if val is not None:
        out["validation"] = goal_scores(goal, *val)
    out["validation_episodes"] = 0 if val is None else int(len(val[0]))
    return out


class MemoryObservation(gym.Wrapper):
    """The compact observations of the last ``memory`` steps (module docstring); wraps the
    environment itself (it makes the compact observations, and needs the ``object_position``
    sensor for the label)."""

    def __init__(self, env: gym.Env, memory: int = 8) -> None:
        super().__init__(env)
        if memory < 1:
            raise ValueError(f"memory={memory}: at least 1")
        self.memory = int(memory)
        compact = CompactObservation(env)
        self.compactor = compact.compactor
        inner = compact.observation_space
        if "object_position" not in inner.spaces:
            raise ValueError("MemoryObservation needs the object_position sensor (the label)")
        self.cues = AudioFeatures(sample_rate=int(compact.sample_rate),
                                  clip_samples=int(env.observation_space["audio"].shape[-1]))
        self.observation_space = memory_space(inner, self.memory)
        self._frames: deque[dict[str, np.ndarray]] = deque(maxlen=self.memory)
        self._audio = np.zeros(inner["audio"].shape, np.float32)
        self._cues = np.zeros(N_CUES, np.float32)
        self._goal = np.zeros(2, np.float32)

    def _obs(self) -> dict[str, np.ndarray]:
        return stack_memory(list(self._frames), self.memory, self._audio, self._goal,
                            self._cues)

    def reset(self, **kwargs: Any):
        raw, info = self.env.reset(**kwargs)
        obs = self.compactor(raw, first=True)
        self._frames.clear()
        self._frames.append({k: obs[k] for k in FRAME_KEYS})
        self._audio = obs["audio"]
        self._cues = self.cues.extract(raw["audio"])
        self._goal = (np.asarray(obs["object_position"][:2], np.float32) / PLACE_SCALE_M)
        return self._obs(), info

    def step(self, action: Any):
        raw, reward, terminated, truncated, info = self.env.step(action)
        obs = self.compactor(raw)
        self._frames.append({k: obs[k] for k in FRAME_KEYS})
        return self._obs(), reward, terminated, truncated, info


def memory_space(compact: spaces.Dict | Mapping[str, spaces.Space], memory: int
                 ) -> spaces.Dict:
    """The observation space of :class:`MemoryObservation` over compact spaces ``compact``."""
    out: dict[str, spaces.Space] = {}
    for k in FRAME_KEYS:
        s = compact[k]
        out[k] = spaces.Box(np.broadcast_to(s.low, (memory, *s.shape)).copy(),
                            np.broadcast_to(s.high, (memory, *s.shape)).copy(),
                            dtype=s.dtype)
    out["valid"] = spaces.Box(0, 1, (memory,), np.uint8)
    out["audio"] = compact["audio"]
    out["cues"] = spaces.Box(-np.inf, np.inf, (N_CUES,), np.float32)
    lim = np.float32(64.0 / PLACE_SCALE_M)
    out["goal_place"] = spaces.Box(-lim, lim, (2,), np.float32)
    return spaces.Dict(out)


def stack_memory(frames: Sequence[Mapping[str, np.ndarray]], memory: int,
                 audio: np.ndarray, goal: np.ndarray, cues: np.ndarray
                 ) -> dict[str, np.ndarray]:
    """The memory observation of ``frames`` (oldest first, at most ``memory``), zeros before
    them."""
    pad = memory - len(frames)
    out: dict[str, np.ndarray] = {}
    for k in FRAME_KEYS:
        a = np.stack([f[k] for f in frames])
        if pad:
            a = np.concatenate([np.zeros((pad, *a.shape[1:]), a.dtype), a])
        out[k] = a
    out["valid"] = np.concatenate([np.zeros(pad, np.uint8), np.ones(len(frames), np.uint8)])
    out["audio"] = np.asarray(audio, np.float32)
    out["cues"] = np.asarray(cues, np.float32)
    out["goal_place"] = np.asarray(goal, np.float32)
    return out


def memory_wrapper(memory: int):
    """A picklable ``env -> MemoryObservation(env, memory)`` for the vector env's workers."""
    import functools

    return functools.partial(MemoryObservation, memory=memory)


__all__ = ["GoalDescriptor", "MemoryObservation", "memory_space", "stack_memory",
           "memory_wrapper", "pretrain_goal", "clip_targets", "goal_loss", "goal_scores",
           "PLACE_SCALE_M", "FRAME_KEYS", "N_CUES"]
