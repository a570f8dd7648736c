"""PPO with the oracle ``found`` (the paper's Table 1 row, as SoundSpaces' AV-Nav trains it).

sb3-contrib's ``RecurrentPPO``: the shared encoder (:mod:`.encoder`) into one LSTM shared by
the actor and the critic (the paper: a GRU), linear heads; Adam at 2.5e-4, the clipped
objective, GAE. The environment ends an episode in success as soon as the object is within
2 m and in view (``oracle_found=True``) and pays the paper's reward (``reward="paper"``: +10
found, +1 a step closer, -1 farther, -0.01 a step); the policy chooses among the five moves
(the ``found`` action is the oracle's). ``fallgen evaluate`` scores it the same way (the agent
declares ``oracle_found``).

Defaults, for 2 CPU cores (``fallgen train ppo``): 2 environment workers, 128-step rollouts
each (256 steps an update), minibatches of 128, 4 epochs, LSTM of 256, discount 0.995 and GAE
lambda 0.98, entropy bonus 0.02, a budget of :data:`DEFAULT_TIMESTEPS` steps in at most 3 h
(:data:`DEFAULT_MINUTES`; at the ~13 steps/s the environment gives a CPU-rendered policy here,
3 h is ~140 k steps), a checkpoint every 10 updates. The long discount and lambda carry the
success's +10 back over a search that takes a random walk ~170 actions: with 0.99 and 0.95
(and 64-step rollouts, one worker) a run on the paper-size build learned to stop moving, each
move's immediate -1 outweighing a success credited only to its last ~20 actions; with these
it did not (docs/policies.md). The paper's scale on a GPU: ``--device cuda --set envs=16
--set n_steps=16 --set batch_size=128 --set timesteps=10000000`` on a machine with as many cores as
environments (the paper: 16-step rollouts per update, Adam 2.5e-4; SoundSpaces' AV-Nav ran 10
processes for ~10^7 steps).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.common.vec_env import VecTransposeImage

from fallgen.policies import SENSORS
from fallgen.policies.encoder import FEATURES_DIM, ObservationEncoder, compactor, to_tensors
from fallgen.policies.runs import apply_overrides
from fallgen.policies.sb3_loop import OnPolicySettings, train_on_env

#: The moves: the policy's actions (indices 0..4 of fallgen.nav.agent.ACTIONS).
N_MOVES = 5
DEFAULT_TIMESTEPS = 140_000
DEFAULT_MINUTES = 180.0


@dataclass
class PpoSettings(OnPolicySettings):
    """:class:`~fallgen.policies.sb3_loop.OnPolicySettings` and the LSTM's size, with PPO's
    own defaults for the credit of a late success (module docstring)."""

    n_steps: int = 128
    batch_size: int = 128
    gamma: float = 0.995
    gae_lambda: float = 0.98
    ent_coef: float = 0.02
    lstm_hidden: int = 256
    timesteps: int = DEFAULT_TIMESTEPS


def settings(overrides: Mapping[str, Any] | None = None) -> PpoSettings:
    """The default settings with ``overrides`` (name -> value, converted to each field's
    type); ValueError naming an unknown or malformed one."""
    return apply_overrides(PpoSettings(), overrides)


class EncoderExtractor(BaseFeaturesExtractor):
    """The shared encoder as Stable-Baselines3's features extractor (the observations come
    with the images channels first, 0..255 as stored: ``normalize_images=False``)."""

    def __init__(self, observation_space: spaces.Dict, bands: int = 64) -> None:
        super().__init__(observation_space, FEATURES_DIM)
        self.encoder = ObservationEncoder(bands)

    def forward(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        return self.encoder(obs)


def policy_kwargs(cfg: Mapping[str, Any]) -> dict[str, Any]:
    return dict(features_extractor_class=EncoderExtractor, normalize_images=False,
                lstm_hidden_size=int(cfg["lstm_hidden"]), n_lstm_layers=1, shared_lstm=True,
                enable_critic_lstm=False, net_arch=[])


def make_model(cfg: Mapping[str, Any], venv, device):
    from sb3_contrib import RecurrentPPO

    return RecurrentPPO("MultiInputLstmPolicy", venv, n_steps=int(cfg["n_steps"]),
                        batch_size=int(cfg["batch_size"]), n_epochs=int(cfg["n_epochs"]),
                        learning_rate=float(cfg["learning_rate"]), gamma=float(cfg["gamma"]),
                        gae_lambda=float(cfg["gae_lambda"]),
                        clip_range=float(cfg["clip_range"]), ent_coef=float(cfg["ent_coef"]),
                        vf_coef=float(cfg["vf_coef"]),
                        max_grad_norm=float(cfg["max_grad_norm"]),
                        policy_kwargs=policy_kwargs(cfg), device=device, verbose=0)


def train(dataset: str | Path, run, cfg: Mapping[str, Any], digest: str, *, seed: int = 0,
          device: str = "cpu", minutes: float | None = DEFAULT_MINUTES,
          threads: int = 1, progress: Callable[[str, int, int], None] | None = None
          ) -> dict[str, Any]:
    """Train (or go on training) PPO with the oracle found on ``dataset``'s train split."""
    return train_on_env("ppo", dataset, run, cfg, digest,
                        lambda venv, dev: make_model(cfg, venv, dev), seed=seed,
                        device=device, minutes=minutes, threads=threads, n_actions=N_MOVES,
                        env_kwargs={"oracle_found": True, "reward": "paper"},
                        progress=progress)


def compact_space(sample_rate: int) -> spaces.Dict:
    """The observation space the policy was made for (the compact observations, images
    channels first)."""
    from stable_baselines3.common.preprocessing import is_image_space

    return spaces.Dict({k: VecTransposeImage.transpose_space(s) if is_image_space(s) else s
                        for k, s in compactor(sample_rate).spaces.items()})


class PpoAgent:
    """A trained PPO policy as a ``fallgen evaluate`` agent: the environment's own
    observations made compact, the LSTM's state carried through the episode, actions drawn
    from the policy's distribution with the episode's seed (``deterministic``: the most
    likely). Scored with the oracle ``found`` (:attr:`oracle_found`)."""

    sensors = SENSORS
    oracle_found = True

    def __init__(self, checkpoint: Mapping[str, Any], deterministic: bool = False,
                 device: str = "cpu") -> None:
        from sb3_contrib.ppo_recurrent.policies import MultiInputLstmPolicy

        cfg = checkpoint["config"]
        self.sample_rate = int(cfg["sample_rate"])
        self.policy = MultiInputLstmPolicy(compact_space(self.sample_rate),
                                           spaces.Discrete(N_MOVES),
                                           lambda _: float(cfg["learning_rate"]),
                                           **policy_kwargs(cfg))
        self.policy.load_state_dict(checkpoint["state"]["policy"])
        self.policy.to(device).eval()
        self.device, self.deterministic = device, deterministic
        self.compact = compactor(self.sample_rate)
        self.rng = np.random.default_rng(0)
        self._state = None
        self._first = True

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        n = self.policy.lstm_actor.hidden_size
        z = torch.zeros(1, 1, n, device=self.device)
        self._state = (z, z.clone())
        self._first = True

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        c = self.compact(obs, first=self._first)
        t = to_tensors(c, self.device, batched=False)
        start = torch.tensor([1.0 if self._first else 0.0], device=self.device)
        self._first = False
        with torch.no_grad():
            dist, self._state = self.policy.get_distribution(t, self._state, start)
            p = dist.distribution.probs[0].double().cpu().numpy()
        if self.deterministic:
            return int(np.argmax(p))
        return int(self.rng.choice(len(p), p=p / p.sum()))


__all__ = ["PpoSettings", "PpoAgent", "settings", "train", "make_model", "EncoderExtractor",
           "N_MOVES", "DEFAULT_TIMESTEPS", "DEFAULT_MINUTES"]
