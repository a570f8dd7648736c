"""Does PPO's policy starve the simulator? An environment step inside PPO's rollout against a
bare environment step. Prints one JSON line.

    python bench/policy_bench.py [--dataset build/smoke] [--envs 2] [--steps 256] [--n-steps 64]

1. bare: one environment in this process as ``fallgen train ppo`` makes it (the compact
   observations of rgb, depth, category segmentation, audio and pose; the oracle found; the
   paper's reward), random moves (seeded), ``--steps`` steps: milliseconds a step (``step``
   alone, resets apart);
2. in PPO's rollout: ``fallgen train ppo``'s own setup (``--envs`` worker processes through
   ``make_vec``, sb3-contrib's RecurrentPPO with the run's default settings but ``n_steps``),
   learning ``--steps`` steps per environment: the environment's ``step`` timed inside each
   worker (resets apart), and its ratio to the bare step (the goal: <= 1.5: the policy and
   the other workers do not starve the simulator of the cores); each rollout timed from its
   start to its end (the updates apart): milliseconds a vector step (every environment
   stepping once, in parallel, then the policy choosing their next actions: Stable-Baselines3
   does one after the other) and the bare step's share of it (how busy a worker is),
   environment steps a second in the rollouts and overall;
3. the policy alone: milliseconds of its forward pass for ``--envs`` observations.

Torch on one thread (as ``fallgen train`` runs it). The machine's load average is printed:
the environments and the policy share its cores with whatever else runs.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

REPO = Path(__file__).resolve().parents[1]


class StepTimer(gym.Wrapper):
    """The compact environment, each ``step`` timed (``times``, seconds)."""

    def __init__(self, env: gym.Env) -> None:
        from fallgen.env.wrappers import CompactObservation

        super().__init__(CompactObservation(env))
        self.times: list[float] = []

    def step(self, action):
        t = time.perf_counter()
        out = self.env.step(action)
        self.times.append(time.perf_counter() - t)
        return out


def bare(dataset: Path, steps: int) -> dict:
    from fallgen.env import FallenObjectsEnv
    from fallgen.policies import SENSORS

    env = StepTimer(FallenObjectsEnv(dataset, "train", sensors=SENSORS, order="shuffle",
                                     oracle_found=True))
    rng = np.random.default_rng(0)
    try:
        env.reset(seed=0)
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(int(rng.integers(0, 5)))
            if term or trunc:
                env.reset()
        dt = float(np.sum(env.times))
    finally:
        env.close()
    return {"steps": steps, "ms_per_step": round(1000 * dt / steps, 2),
            "steps_per_s": round(steps / dt, 1)}


def in_rollout(dataset: Path, envs: int, steps: int, n_steps: int) -> dict:
    import torch
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.logger import Logger

    from fallgen.policies import ppo
    from fallgen.learn.runtime import isolated_rng, session
    from fallgen.policies.vec import Sb3VecEnv, training_envs

    class Timer(BaseCallback):
        def __init__(self):
            super().__init__()
            self.rollouts: list[float] = []
            self.vector_steps = 0

        def _on_rollout_start(self):
            self._t = time.perf_counter()

        def _on_step(self):
            self.vector_steps += 1
            return True

        def _on_rollout_end(self):
            self.rollouts.append(time.perf_counter() - self._t)

    cfg = ppo.settings({"n_steps": n_steps, "envs": envs}).to_dict()
    with session(1), isolated_rng(0):
        venv = Sb3VecEnv(training_envs(dataset, envs, "train", oracle_found=True,
                                       reward="paper", wrapper=StepTimer), ppo.N_MOVES)
        try:
            model = ppo.make_model(cfg, venv, torch.device("cpu"))
            model.set_logger(Logger(None, []))  # no SB3-* log directory in the temp dir
            timer = Timer()
            t = time.perf_counter()
            model.learn(steps * max(envs, 1), callback=timer)
            total = time.perf_counter() - t
            # the policy alone, on the last observations
            obs = model._last_obs  # noqa: SLF001 (SB3's own, read only)
            states = model._last_lstm_states.pi  # noqa: SLF001
            starts = torch.zeros(max(envs, 1))
            t = time.perf_counter()
            for _ in range(50):
                with torch.no_grad():
                    model.policy.predict(obs, state=tuple(s.numpy() for s in states),
                                         episode_start=starts.numpy())
            forward_ms = 1000 * (time.perf_counter() - t) / 50
            worker_steps = np.concatenate([np.asarray(x) for x in venv.get_attr("times")])
        finally:
            venv.close()
    rollout_s = sum(timer.rollouts)
    vsteps = len(timer.rollouts) * n_steps
    n = max(envs, 1)
    return {"envs": envs, "n_steps": n_steps, "rollouts": len(timer.rollouts),
            "env_ms_per_step_in_workers": round(1000 * float(worker_steps.mean()), 2),
            "ms_per_vector_step": round(1000 * rollout_s / vsteps, 2),
            "env_steps_per_s_in_rollouts": round(vsteps * n / rollout_s, 1),
            "env_steps_per_s_overall": round(steps * n / total, 1),
            "update_s": round((total - rollout_s) / max(len(timer.rollouts), 1), 2),
            "policy_forward_ms": round(forward_ms, 2)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--dataset", type=Path, default=REPO / "build" / "smoke")
    ap.add_argument("--envs", type=int, default=2)
    ap.add_argument("--steps", type=int, default=256)
    ap.add_argument("--n-steps", type=int, default=64)
    a = ap.parse_args()
    import fallgen  # noqa: F401  (pins BLAS and OpenMP threads before numpy's first use)

    b = bare(a.dataset, a.steps)
    r = in_rollout(a.dataset, a.envs, a.steps, a.n_steps)
    print(json.dumps({"machine": platform.processor() or platform.machine(),
                      "cores": os.cpu_count(), "load_average": os.getloadavg(),
                      "dataset": str(a.dataset), "bare": b, "ppo_rollout": r,
                      "ratio_env_step_in_rollout_to_bare":
                          round(r["env_ms_per_step_in_workers"] / b["ms_per_step"], 2),
                      "goal": "<= 1.5",
                      "ratio_vector_step_to_bare_step":
                          round(r["ms_per_vector_step"] / b["ms_per_step"], 2),
                      "worker_busy_share":
                          round(r["env_ms_per_step_in_workers"] / r["ms_per_vector_step"],
                                2)}))


if __name__ == "__main__":
    main()
