"""Training a Stable-Baselines3 on-policy algorithm on the environment, in pieces (PPO, SAVi).

:func:`train_on_env` makes the vector env (:mod:`.vec`), the model (the caller's
``make_model``), restores the run's last checkpoint if there is one, and runs the
algorithm's own ``learn`` with :class:`LoopCallback`, which after each update (a rollout and
its optimisation) writes a row of ``log.csv``, every ``checkpoint_every`` updates a checkpoint
and the curve, and stops the run at a rollout's start once ``minutes`` have passed (after a
checkpoint: the next command goes on from there). The episodes' measures in the log are
those of the last :data:`WINDOW` episodes that ended (success, SPL, SNA, return, length).

A checkpoint holds the policy's and the optimiser's state, the timesteps and updates done,
the episode window, the wall time so far and the global generators' state
(:mod:`.runtime`); a resumed run restarts its environments (new episodes: their seeds are
drawn from the run's seed and the update count).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import Logger

from fallgen.policies.runs import CsvLog, Run, curve_png, load_checkpoint, read_log
from fallgen.learn.runtime import isolated_rng, rng_state, session, set_rng_state

#: Episodes the logged measures are averaged over.
WINDOW = 100
EPISODE_KEYS = ("success", "spl", "sna", "return", "length")
TRAIN_KEYS = ("policy_gradient_loss", "value_loss", "entropy_loss", "approx_kl",
              "clip_fraction", "explained_variance")
FIELDS = ("update", "timesteps", "wall_s", "steps_per_s", "episodes") + EPISODE_KEYS + \
    TRAIN_KEYS


@dataclass
class OnPolicySettings:
    """What PPO and SAVi share: the environments, the rollouts, PPO's optimisation, the
    budget. ``envs``: worker processes (0: one environment in this process);
    ``timesteps``: the run's budget (environment steps, all environments together)."""

    envs: int = 2
    n_steps: int = 64
    batch_size: int = 64
    n_epochs: int = 4
    learning_rate: float = 2.5e-4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    timesteps: int = 100_000
    checkpoint_every: int = 10
    split: str = "train"
    room_kind: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class LoopCallback(BaseCallback):
    """Logs, checkpoints and stops a run (module docstring)."""

    def __init__(self, run: Run, log: CsvLog, save: Callable[["LoopCallback"], None],
                 every: int, deadline: float, update: int, wall_s: float,
                 window: list[dict[str, float]], episodes: int, title: str,
                 on_update: Callable[[Any], dict[str, float]] | None = None,
                 progress: Callable[[str, int, int], None] | None = None,
                 total: int = 0) -> None:
        """``on_update(model)``: called at each rollout's end (the rollout in the model's
        buffer, before the update); what it returns goes into the update's row.
        ``progress("timesteps", done, total)`` after each update."""
        super().__init__()
        self.run, self.log, self.save_fn, self.every = run, log, save, max(1, int(every))
        self.deadline, self.update, self.wall_s0 = deadline, int(update), float(wall_s)
        self.window: deque[dict[str, float]] = deque(window, maxlen=WINDOW)
        self.episodes = int(episodes)
        self.title, self.on_update = title, on_update
        self.progress, self.total = progress, int(total)
        self.stopped = False
        self._first = True
        self._t0 = time.monotonic()
        self._rollout_t0 = self._t0
        self._rollout_steps0 = 0
        self._saved_at = -1
        self.saved_timesteps = 0
        self._from_rollout: dict[str, float] = {}

    @property
    def wall_s(self) -> float:
        return self.wall_s0 + time.monotonic() - self._t0

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"]):
            if done and "episode" in info:
                self.window.append({"success": float(info.get("success", False)),
                                    "spl": float(info.get("spl", 0.0)),
                                    "sna": float(info.get("sna", 0.0)),
                                    "return": float(info["episode"]["r"]),
                                    "length": float(info["episode"]["l"])})
                self.episodes += 1
        return not self.stopped

    def _finish_update(self) -> None:
        """After an update: its row, and a checkpoint when due."""
        self.update += 1
        now = time.monotonic()
        steps = self.model.num_timesteps - self._rollout_steps0
        row: dict[str, Any] = {"update": self.update, "timesteps": self.model.num_timesteps,
                               "wall_s": round(self.wall_s, 2),
                               "steps_per_s": steps / max(now - self._rollout_t0, 1e-9),
                               "episodes": self.episodes}
        for k in EPISODE_KEYS:
            row[k] = float(np.mean([w[k] for w in self.window])) if self.window else float("nan")
        values = self.model.logger.name_to_value
        for k in TRAIN_KEYS:
            row[k] = float(values.get("train/" + k, float("nan")))
        row.update(self._from_rollout)
        self._from_rollout = {}
        self.log.append(row)
        if self.progress is not None:
            self.progress("timesteps", int(self.model.num_timesteps), self.total)
        if self.update % self.every == 0 or time.monotonic() >= self.deadline:
            self.checkpoint()

    def checkpoint(self) -> None:
        if self._saved_at == self.update:
            return
        self.save_fn(self)
        self._saved_at = self.update
        self.saved_timesteps = self.model.num_timesteps
        draw_curve(self.run, self.title)

    def _on_rollout_start(self) -> None:
        if not self._first:
            self._finish_update()
        self._first = False
        self._rollout_t0 = time.monotonic()
        self._rollout_steps0 = self.model.num_timesteps
        if time.monotonic() >= self.deadline:
            self.checkpoint()
            self.stopped = True  # the rollout's first step ends the run (not counted)

    def _on_rollout_end(self) -> None:
        if self.on_update is not None:  # the rollout is in the buffer (until the next)
            self._from_rollout = self.on_update(self.model)

    def _on_training_end(self) -> None:
        if not self.stopped:  # the budget is spent: the last update's row and checkpoint
            self._finish_update()
            self.checkpoint()


def draw_curve(run: Run, title: str) -> None:
    rows = read_log(run.log_path) if run.log_path.exists() else []
    curve_png(run.curve_path, rows, "timesteps",
              [("success, SPL (last 100 episodes)", ("success", "spl")),
               ("return (last 100 episodes)", ("return",)),
               ("episode length (last 100 episodes)", ("length",)),
               ("losses", ("value_loss", "policy_gradient_loss"))], title)


def train_on_env(kind: str, dataset: str | Path, run: Run, cfg: Mapping[str, Any],
                 digest: str, make_model: Callable[[Any, Any], Any], *, seed: int = 0,
                 device: str = "cpu", minutes: float | None = None, threads: int = 1,
                 n_actions: int | None = None, env_kwargs: Mapping[str, Any] | None = None,
                 extra_state: Callable[[Any], dict] | None = None,
                 load_extra: Callable[[Any, dict], None] | None = None,
                 on_update: Callable[[Any], dict[str, float]] | None = None,
                 wrap_venv: Callable[[Any], Any] | None = None,
                 progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Train (or go on training) the run's model on ``dataset`` (module docstring); what the
    run reached: updates, timesteps, wall seconds, the last checkpoint.
    ``progress(step, done, total)`` after each update."""
    from fallgen.learn.runtime import resolve_device
    from fallgen.policies.vec import Sb3VecEnv, training_envs

    dev = resolve_device(device)
    last = run.latest()
    ck = load_checkpoint(last, kind, digest) if last is not None else None
    update = int(ck["update"]) if ck else 0
    log = CsvLog(run.log_path, FIELDS + tuple(_extra_fields(on_update)), update if ck else None)
    deadline = time.monotonic() + (float("inf") if minutes is None else 60.0 * minutes)
    with session(threads), isolated_rng(seed):
        venv = Sb3VecEnv(training_envs(dataset, int(cfg["envs"]), cfg["split"],
                                       room_kind=cfg.get("room_kind"),
                                       **dict(env_kwargs or {})), n_actions)
        try:
            if wrap_venv is not None:
                venv = wrap_venv(venv)
            venv.seed(int(np.random.SeedSequence([seed, update]).generate_state(1)[0] >> 1))
            model = make_model(venv, dev)
            model.set_logger(Logger(None, []))
            if ck:
                model.policy.load_state_dict(ck["state"]["policy"])
                model.policy.optimizer.load_state_dict(ck["state"]["optimizer"])
                model.num_timesteps = int(ck["timesteps"])
                if load_extra is not None:
                    load_extra(model, ck["state"])
                set_rng_state(ck["rng"])

            def save(cb: LoopCallback) -> None:
                state = {"policy": model.policy.state_dict(),
                         "optimizer": model.policy.optimizer.state_dict()}
                if extra_state is not None:
                    state.update(extra_state(model))
                run.save(cb.update, {"kind": kind, "manifest_sha256": digest,
                                     "dataset": str(Path(dataset).resolve()),
                                     "config": dict(cfg), "timesteps": model.num_timesteps,
                                     "wall_s": cb.wall_s, "window": list(cb.window),
                                     "episodes": cb.episodes,
                                     "state": state, "rng": rng_state()})

            cb = LoopCallback(run, log, save, int(cfg["checkpoint_every"]), deadline, update,
                              float(ck["wall_s"]) if ck else 0.0,
                              list(ck["window"]) if ck else [],
                              int(ck["episodes"]) if ck else 0, _title(kind, dataset, cfg),
                              on_update, progress, int(cfg["timesteps"]))
            remaining = int(cfg["timesteps"]) - model.num_timesteps
            if remaining > 0:
                model.learn(remaining, callback=cb, reset_num_timesteps=False)
            # a run stopped at a rollout's first step: the checkpoint is of the step before
            steps = cb.saved_timesteps if cb.stopped else model.num_timesteps
            return {"updates": cb.update, "timesteps": steps,
                    "wall_s": cb.wall_s, "stopped": cb.stopped, "done": remaining <= 0 or
                    model.num_timesteps >= int(cfg["timesteps"]),
                    "checkpoint": str(run.latest())}
        finally:
            venv.close()


def _extra_fields(on_update) -> tuple[str, ...]:
    return tuple(getattr(on_update, "fields", ()))


def _title(kind: str, dataset, cfg: Mapping[str, Any]) -> str:
    """A curve's title: the kind, the dataset and the rooms it learned on when not all."""
    rooms = cfg.get("room_kind")
    return f"{kind} on {dataset}" + (f" ({rooms} rooms)" if rooms else "")


__all__ = ["OnPolicySettings", "LoopCallback", "train_on_env", "draw_curve", "FIELDS",
           "WINDOW"]
