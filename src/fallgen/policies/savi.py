"""SAVi (Chen et al. 2021, semantic audio-visual navigation), the paper's third learned row.

Two stages, as published:

1. the audio goal descriptor (:class:`fallgen.policies.savi_parts.GoalDescriptor`: the fallen
   object's category and place from the auditory perception module's cues of the step-0
   clip) learned from the train split's clips against that module's targets (category,
   place), ``goal_epochs`` full-batch steps (its scores before and after, on train and
   validation, in ``RUN/goal.json``);
2. the policy: the memory of the last ``memory`` steps' observations (each through the shared
   encoder, :mod:`.encoder`, with a learned embedding of its age) and a token of the goal
   descriptor's estimate (category probabilities and place, detached) go through a
   transformer; the goal token's and the current step's outputs feed the actor and the critic.
   Trained with PPO (Stable-Baselines3, the paper's reward, all six actions: the agent claims
   ``found`` itself); after each rollout the descriptor's place is fine-tuned on its clips
   against each episode's true place (``goal_finetune_steps`` Adam steps at
   ``goal_finetune_lr``, a tenth of the first stage's: a rollout holds a few episodes; its
   error in metres is in the log).

Simplifications, stated: the memory holds observations and encodes them again at each step
(SAVi's scene memory keeps embeddings from an encoder trained first and frozen); 8 steps of
memory on a CPU (SAVi: 150). The actor's ``found`` starts at probability ``found_prior`` (the
bias of its logit; the other five share the rest): at the uniform 1/6, an untrained policy
ends its episodes after ~6 actions with a wrong claim. Neither start has learned on the
paper-size build: both runs came to claim within a few actions (docs/policies.md).

Defaults, for 2 CPU cores (``fallgen train savi``): 2 environment workers, 128-step rollouts
(minibatches of 128), discount 0.995, GAE λ 0.98 and entropy bonus 0.02 (PPO's, which carry a
late success back over a long search: :mod:`.ppo`), ``found`` at 0.01, memory 8, embeddings of
128, 2 blocks of 4 heads, a budget of :data:`DEFAULT_TIMESTEPS` steps in at most 3 h.
The paper's scale on a GPU: ``--device cuda --set envs=10 --set n_steps=150
--set memory=150 --set n_epochs=2 --set batch_size=300 --set timesteps=10000000`` (SAVi:
150-step rollouts, two epochs an update, Adam 2.5e-4, trained to convergence).
"""

from __future__ import annotations

import json
import math
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

from fallgen.errors import InputError
from fallgen.nav.agent import ACTIONS
from fallgen.policies import SENSORS
from fallgen.policies.encoder import FEATURES_DIM, IMAGE_KEYS, ObservationEncoder, compactor
from fallgen.policies.runs import apply_overrides
from fallgen.perception.audio_features import AudioFeatures
from fallgen.policies.savi_parts import FRAME_KEYS, N_CUES, GoalDescriptor, memory_space, \
    memory_wrapper, pretrain_goal, stack_memory
from fallgen.policies.sb3_loop import OnPolicySettings, train_on_env

DEFAULT_TIMESTEPS = 60_000
DEFAULT_MINUTES = 180.0
#: The ``found`` action's index.
FOUND = ACTIONS.index("found")
#: The environment sensors SAVi's training reads (object_position: the place's label only).
TRAIN_SENSORS = SENSORS + ("object_position",)


@dataclass
class SaviSettings(OnPolicySettings):
    """:class:`~fallgen.policies.sb3_loop.OnPolicySettings`, the memory, the transformer and
    the goal descriptor's two stages."""

    n_steps: int = 128
    batch_size: int = 128
    gamma: float = 0.995
    gae_lambda: float = 0.98
    ent_coef: float = 0.02
    found_prior: float = 0.01
    memory: int = 8
    embed: int = 128
    layers: int = 2
    heads: int = 4
    goal_epochs: int = 300
    goal_lr: float = 1e-3
    goal_finetune_steps: int = 4
    goal_finetune_lr: float = 1e-4
    timesteps: int = DEFAULT_TIMESTEPS


def settings(overrides: Mapping[str, Any] | None = None) -> SaviSettings:
    s = apply_overrides(SaviSettings(), overrides)
    if s.embed % s.heads:
        raise ValueError(f"embed={s.embed}: a multiple of heads={s.heads}")
    if not 0.0 < s.found_prior < 1.0:
        raise ValueError(f"found_prior={s.found_prior}: a probability in (0, 1)")
    return s


class SaviExtractor(BaseFeaturesExtractor):
    """Memory and goal -> features (the module docstring's second stage)."""

    def __init__(self, observation_space: spaces.Dict, n_categories: int = 64,
                 embed: int = 128, layers: int = 2, heads: int = 4) -> None:
        super().__init__(observation_space, 2 * embed)
        self.memory = int(observation_space["valid"].shape[0])
        self.encoder = ObservationEncoder()
        self.goal = GoalDescriptor(n_categories)
        self.frame = nn.Linear(FEATURES_DIM, embed)
        self.age = nn.Embedding(self.memory, embed)
        self.goal_in = nn.Linear(n_categories + 2, embed)
        self.heads = heads
        layer = nn.TransformerEncoderLayer(embed, heads, 4 * embed, 0.0, batch_first=True,
                                           norm_first=True)
        self.blocks = nn.TransformerEncoder(layer, layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(embed)

    def forward(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        b, m = obs["valid"].shape
        flat = {}
        for k in IMAGE_KEYS:  # (B, M, H, W, C) -> (B M, C, H, W)
            x = obs[k]
            flat[k] = x.reshape(b * m, *x.shape[2:]).permute(0, 3, 1, 2)
        flat["pose"] = obs["pose"].reshape(b * m, -1)
        flat["audio"] = obs["audio"].repeat_interleave(m, dim=0)
        frames = self.frame(self.encoder(flat)).reshape(b, m, -1)
        ages = torch.arange(m - 1, -1, -1, device=frames.device)
        frames = frames + self.age(ages)[None]
        with torch.no_grad():
            logits, place = self.goal(obs["cues"])
        goal = self.goal_in(torch.cat([torch.softmax(logits, -1), place], -1))[:, None]
        x = torch.cat([goal, frames], 1)
        valid = torch.cat([torch.ones(b, 1, device=x.device), obs["valid"].float()], 1) > 0.5
        n = m + 1
        allowed = valid[:, None, :] | torch.eye(n, dtype=torch.bool, device=x.device)[None]
        bias = torch.zeros(b, n, n, device=x.device).masked_fill(~allowed, -1e9)
        h = self.norm(self.blocks(x, mask=bias.repeat_interleave(self.heads, dim=0)))
        return torch.cat([h[:, 0], h[:, -1]], -1)


def policy_kwargs(cfg: Mapping[str, Any]) -> dict[str, Any]:
    return dict(features_extractor_class=SaviExtractor,
                features_extractor_kwargs=dict(n_categories=int(cfg["n_categories"]),
                                               embed=int(cfg["embed"]),
                                               layers=int(cfg["layers"]),
                                               heads=int(cfg["heads"])),
                normalize_images=False, net_arch=[])


def require_cues(cfg: Mapping[str, Any], path: Any) -> None:
    """InputError (naming ``path`` and the field) for the settings of a run from before the
    goal descriptor read the clip's cues (they have no ``found_prior``)."""
    if "found_prior" not in cfg:
        raise InputError(path, "config.found_prior", "a SAVi run from before its goal "
                         "descriptor read the clip's cues; train another run (-o)")


def found_bias(prior: float, actions: int = len(ACTIONS)) -> float:
    """The ``found`` logit's bias that makes its probability ``prior`` when the other
    ``actions - 1`` logits are 0."""
    return math.log(prior * (actions - 1) / (1.0 - prior))


def make_model(cfg: Mapping[str, Any], venv, device):
    from stable_baselines3 import PPO

    model = PPO("MultiInputPolicy", venv, n_steps=int(cfg["n_steps"]),
               batch_size=int(cfg["batch_size"]), n_epochs=int(cfg["n_epochs"]),
               learning_rate=float(cfg["learning_rate"]), gamma=float(cfg["gamma"]),
               gae_lambda=float(cfg["gae_lambda"]), clip_range=float(cfg["clip_range"]),
               ent_coef=float(cfg["ent_coef"]), vf_coef=float(cfg["vf_coef"]),
               max_grad_norm=float(cfg["max_grad_norm"]), policy_kwargs=policy_kwargs(cfg),
               device=device, verbose=0)
    with torch.no_grad():  # zero weights (SB3: orthogonal, gain 0.01): the prior exactly
        net = model.policy.action_net
        net.weight.zero_()
        net.bias.zero_()
        net.bias[FOUND] = found_bias(float(cfg["found_prior"]))
    return model


class GoalFinetune:
    """After each rollout (before its update): the descriptor's place fine-tuned on the
    rollout's clips against their episodes' true places; the error before it (m) for the
    log."""

    fields = ("goal_error_m",)

    def __init__(self, steps: int, lr: float) -> None:
        self.steps, self.lr = int(steps), float(lr)
        self.opt: torch.optim.Optimizer | None = None
        self.pending_state: dict | None = None

    def optimizer(self, goal: GoalDescriptor) -> torch.optim.Optimizer:
        if self.opt is None:
            self.opt = torch.optim.Adam(goal.parameters(), lr=self.lr)
            if self.pending_state is not None:
                self.opt.load_state_dict(self.pending_state)
        return self.opt

    def __call__(self, model) -> dict[str, float]:
        from fallgen.policies.savi_parts import PLACE_SCALE_M

        goal = model.policy.features_extractor.goal
        obs = model.rollout_buffer.observations
        dev = model.device
        x = torch.as_tensor(obs["cues"].reshape(-1, obs["cues"].shape[-1]), device=dev)
        y = torch.as_tensor(obs["goal_place"].reshape(-1, 2), device=dev)
        with torch.no_grad():
            err = float(torch.linalg.norm(goal(x)[1] - y, dim=1).mean()) * PLACE_SCALE_M
        opt = self.optimizer(goal)
        for _ in range(self.steps):
            opt.zero_grad(set_to_none=True)
            nn.functional.mse_loss(goal(x)[1], y).backward()
            opt.step()
        return {"goal_error_m": err}


def train(dataset: str | Path, run, cfg: Mapping[str, Any], digest: str, *, seed: int = 0,
          device: str = "cpu", minutes: float | None = DEFAULT_MINUTES,
          threads: int = 1, progress: Callable[[str, int, int], None] | None = None
          ) -> dict[str, Any]:
    """Train (or go on training) SAVi on ``dataset`` (module docstring)."""
    from fallgen.dataset.reader import Dataset
    from fallgen.learn.runtime import isolated_rng, resolve_device, session

    cfg = dict(cfg)
    require_cues(cfg, run.meta_path)
    cfg["n_categories"] = len(Dataset(dataset).category_labels)
    fine = GoalFinetune(int(cfg["goal_finetune_steps"]), float(cfg["goal_finetune_lr"]))
    pretrained = None
    if run.latest() is None:  # the first stage, once
        with session(threads), isolated_rng(seed + 1):
            goal = GoalDescriptor(cfg["n_categories"]).to(resolve_device(device))
            report = pretrain_goal(goal, dataset, cfg["split"], cfg.get("room_kind"),
                                   int(cfg["goal_epochs"]), float(cfg["goal_lr"]), seed,
                                   resolve_device(device))
        pretrained = goal.state_dict()
        (run.root / "goal.json").write_text(json.dumps(report, indent=1) + "\n")

    def make(venv, dev):
        model = make_model(cfg, venv, dev)
        if pretrained is not None:
            model.policy.features_extractor.goal.load_state_dict(pretrained)
        return model

    def extra_state(model) -> dict:
        return {"goal_optimizer": fine.optimizer(model.policy.features_extractor.goal)
                .state_dict()}

    def load_extra(model, state: dict) -> None:
        fine.pending_state = state.get("goal_optimizer")

    return train_on_env("savi", dataset, run, cfg, digest, make, seed=seed, device=device,
                        minutes=minutes, threads=threads,
                        env_kwargs={"reward": "paper", "sensors": TRAIN_SENSORS,
                                    "wrapper": memory_wrapper(int(cfg["memory"]))},
                        extra_state=extra_state, load_extra=load_extra, on_update=fine,
                        progress=progress)


class SaviAgent:
    """A trained SAVi policy as a ``fallgen evaluate`` agent: the environment's observations
    made compact and kept for the memory, actions drawn with the episode's seed
    (``deterministic``: the most likely)."""

    sensors = SENSORS

    def __init__(self, checkpoint: Mapping[str, Any], deterministic: bool = False,
                 device: Any = "cpu", path: Any = "checkpoint") -> None:
        from stable_baselines3.common.policies import MultiInputActorCriticPolicy

        cfg = checkpoint["config"]
        require_cues(cfg, path)
        self.m = int(cfg["memory"])
        self.compact = compactor(int(cfg["sample_rate"]))
        self.cue_features = None
        space = memory_space(self.compact.spaces | {"audio": spaces.Box(
            0.0, 1.0, (128,), np.float32)}, self.m)
        self.policy = MultiInputActorCriticPolicy(space, spaces.Discrete(len(ACTIONS)),
                                                  lambda _: float(cfg["learning_rate"]),
                                                  **policy_kwargs(cfg))
        self.policy.load_state_dict(checkpoint["state"]["policy"])
        self.policy.to(device).eval()
        self.device, self.deterministic = device, deterministic
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self.frames: deque[dict[str, np.ndarray]] = deque(maxlen=self.m)
        self.audio: np.ndarray | None = None
        self.cues = np.zeros(N_CUES, np.float32)

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        c = self.compact(obs, first=self.audio is None)
        if self.audio is None:
            self.audio = c["audio"]
            clip = np.asarray(obs["audio"])
            if self.cue_features is None or self.cue_features.clip_samples != clip.shape[-1]:
                self.cue_features = AudioFeatures(sample_rate=int(self.compact.sample_rate),
                                                  clip_samples=int(clip.shape[-1]))
            self.cues = self.cue_features.extract(clip)
        self.frames.append({k: c[k] for k in FRAME_KEYS})
        mem = stack_memory(list(self.frames), self.m, self.audio, np.zeros(2, np.float32),
                           self.cues)
        t = {k: torch.as_tensor(v[None], device=self.device) for k, v in mem.items()}
        with torch.no_grad():
            p = self.policy.get_distribution(t).distribution.probs[0].double().cpu().numpy()
        if self.deterministic:
            return int(np.argmax(p))
        return int(self.rng.choice(len(p), p=p / p.sum()))


__all__ = ["SaviSettings", "SaviExtractor", "SaviAgent", "settings", "train", "make_model",
           "DEFAULT_TIMESTEPS", "DEFAULT_MINUTES", "TRAIN_SENSORS"]
