"""The Decision Transformer (Chen et al. 2021) on the expert's trajectories (the paper's row).

Each of the last ``context`` (20) steps gives three tokens: its return-to-go (a linear
embedding of the paper's return from that step on, over ``return_scale``), its state (the
shared encoder, :mod:`.encoder`, then a linear map) and its action (an embedding); a learned
embedding of the step's index in the episode is added to each. The 3 x 20 tokens go through a
small GPT (pre-norm transformer blocks with causal attention, plain torch) and the action is
predicted from each state's token (cross-entropy against the expert's). Trained offline on
``fallgen export-expert``'s trajectories of the train split (:mod:`.dt_data`) with AdamW
(1e-4, linear warm-up), a held-out tenth of the episodes for the validation loss; every
``eval_every`` steps the checkpoint is played on ``eval_episodes`` validation episodes of the
environment (success, SPL, SNA in the log and the curve).

Acting (``fallgen evaluate``): the agent is not told its rewards, so the return-to-go it
conditions on starts at the train split's 90th percentile of the expert's returns and falls
each step by the expert's mean reward per step (never below the smallest return-to-go in the
data); the action is drawn from the predicted distribution with the episode's seed
(``deterministic``: the most likely). Each observation is encoded once and kept for the
context.

Defaults, for 2 CPU cores (``fallgen train dt``): embeddings of 128, 3 blocks of 4 heads,
batches of 16 windows of 20 steps, :data:`DEFAULT_STEPS` gradient steps in at most 60 min
(:data:`DEFAULT_MINUTES`), a checkpoint every 250 steps. The paper's scale on a GPU:
``--device cuda --set batch_size=64 --set steps=100000 --set embed=128 --set layers=3``
(Chen et al.'s Atari settings: context 30 there, 20 here as in the paper).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from fallgen.nav.agent import ACTIONS, MAX_ACTIONS
from fallgen.policies import SENSORS
from fallgen.policies.encoder import FEATURES_DIM, ObservationEncoder, compactor, to_tensors
from fallgen.policies.runs import CsvLog, Run, apply_overrides, curve_png, load_checkpoint, \
    read_log
from fallgen.learn.runtime import isolated_rng, resolve_device, rng_state, session, \
    set_rng_state

DEFAULT_STEPS = 3000
DEFAULT_MINUTES = 60.0
FIELDS = ("update", "samples", "wall_s", "steps_per_s", "loss", "accuracy", "val_loss",
          "val_accuracy", "lr", "success", "spl", "sna", "eval_episodes")


@dataclass
class DtSettings:
    """The model, the optimisation and the budget (``steps``: gradient steps)."""

    context: int = 20
    embed: int = 128
    layers: int = 3
    heads: int = 4
    dropout: float = 0.1
    batch_size: int = 16
    learning_rate: float = 1e-4
    weight_decay: float = 1e-4
    warmup_steps: int = 500
    steps: int = DEFAULT_STEPS
    checkpoint_every: int = 250
    eval_every: int = 1000
    eval_episodes: int = 8
    holdout: float = 0.1
    return_scale: float = 20.0
    split: str = "train"
    room_kind: str | None = None
    #: how many of the split's episodes to export and learn from (0: all), a seeded subsample
    episodes: int = 0

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def settings(overrides: Mapping[str, Any] | None = None) -> DtSettings:
    s = apply_overrides(DtSettings(), overrides)
    if s.embed % s.heads:
        raise ValueError(f"embed={s.embed}: a multiple of heads={s.heads}")
    return s


class DecisionTransformer(nn.Module):
    """Return-to-go, state and action tokens of ``context`` steps -> action logits per state."""

    def __init__(self, cfg: Mapping[str, Any]) -> None:
        super().__init__()
        d, self.context = int(cfg["embed"]), int(cfg["context"])
        self.heads = int(cfg["heads"])
        self.encoder = ObservationEncoder()
        self.state = nn.Linear(FEATURES_DIM, d)
        self.rtg = nn.Linear(1, d)
        self.action = nn.Embedding(len(ACTIONS), d)
        self.time = nn.Embedding(MAX_ACTIONS + 1, d)
        self.norm = nn.LayerNorm(d)
        self.drop = nn.Dropout(float(cfg["dropout"]))
        layer = nn.TransformerEncoderLayer(d, self.heads, 4 * d, float(cfg["dropout"]),
                                           activation="gelu", batch_first=True,
                                           norm_first=True)
        self.blocks = nn.TransformerEncoder(layer, int(cfg["layers"]),
                                            enable_nested_tensor=False)
        self.head = nn.Sequential(nn.LayerNorm(d), nn.Linear(d, len(ACTIONS)))

    def embed_states(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """(N, ...) compact observations (images channels first) -> (N, FEATURES_DIM)."""
        return self.encoder(obs)

    def forward(self, feats: torch.Tensor, rtg: torch.Tensor, actions: torch.Tensor,
                t: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """feats (B, K, FEATURES_DIM), rtg (B, K) scaled, actions, t (B, K) long, mask (B, K)
        bool (real states) -> (B, K, actions) logits from each state's token."""
        b, k = rtg.shape
        te = self.time(t.clamp(0, MAX_ACTIONS))
        tokens = torch.stack([self.rtg(rtg[..., None]) + te, self.state(feats) + te,
                              self.action(actions) + te], dim=2).reshape(b, 3 * k, -1)
        x = self.drop(self.norm(tokens))
        n = 3 * k
        causal = torch.ones(n, n, dtype=torch.bool, device=x.device).tril()
        real = mask.repeat_interleave(3, dim=1)  # (B, 3K)
        allowed = causal[None] & real[:, None, :]
        allowed = allowed | torch.eye(n, dtype=torch.bool, device=x.device)[None]
        bias = torch.zeros(b, n, n, device=x.device).masked_fill(~allowed, -1e9)
        bias = bias.repeat_interleave(self.heads, dim=0)
        h = self.blocks(x, mask=bias)
        return self.head(h.reshape(b, k, 3, -1)[:, :, 1])


def _batch_tensors(batch: Mapping[str, np.ndarray], device) -> dict[str, torch.Tensor]:
    b, k = batch["mask"].shape
    flat = {key: batch[key].reshape(b * k, *batch[key].shape[2:])
            for key in ("rgb", "depth", "category_seg", "pose", "audio")}
    out = to_tensors(flat, device)
    out.update({key: torch.as_tensor(batch[key], device=device)
                for key in ("action", "t", "mask")})
    out["rtg"] = torch.as_tensor(batch["rtg"], dtype=torch.float32, device=device)
    return out


def _step_loss(model: DecisionTransformer, t: Mapping[str, torch.Tensor], scale: float
               ) -> tuple[torch.Tensor, float, int]:
    b, k = t["mask"].shape
    obs = {key: t[key] for key in ("rgb", "depth", "category_seg", "pose", "audio")}
    feats = model.embed_states(obs).reshape(b, k, -1)
    logits = model(feats, t["rtg"] / scale, t["action"], t["t"], t["mask"])
    m = t["mask"]
    loss = nn.functional.cross_entropy(logits[m], t["action"][m])
    right = int((logits[m].argmax(-1) == t["action"][m]).sum())
    return loss, right, int(m.sum())


def _return_stats(data: Mapping[str, np.ndarray], episodes: np.ndarray) -> dict[str, float]:
    starts = np.asarray(data["start"])
    rtg = np.asarray(data["rtg"])
    firsts = rtg[starts[episodes]]
    n_steps = len(data["action"])
    ends = np.append(starts[1:], n_steps)
    lengths = (ends - starts)[episodes]
    return {"target_return": float(np.percentile(firsts, 90)),
            "step_reward": float(firsts.sum() / max(lengths.sum(), 1)),
            "min_rtg": float(rtg.min())}


def train(dataset: str | Path, run: Run, cfg: Mapping[str, Any], digest: str, *,
          seed: int = 0, device: str = "cpu", minutes: float | None = DEFAULT_MINUTES,
          threads: int = 1, expert: str | Path | None = None,
          progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Train (or go on training) the Decision Transformer of ``run`` (module docstring);
    ``progress(step, done, total)`` for the export, the conversion and the gradient steps."""
    from fallgen.policies.dt_data import Windows, build_cache, expert_file, split_episodes

    dev = resolve_device(device)
    h5 = expert_file(dataset, digest, run.root, expert, cfg["split"], cfg.get("room_kind"),
                     int(cfg.get("episodes", 0)), seed, progress)
    data = build_cache(h5, run.root / "cache", int(cfg["sample_rate"]), progress)
    train_eps, held_eps = split_episodes(len(data["start"]), float(cfg["holdout"]), seed)
    k = int(cfg["context"])
    windows, held = Windows(data, train_eps, k), Windows(data, held_eps, k)
    stats = _return_stats(data, train_eps)
    last = run.latest()
    ck = load_checkpoint(last, "dt", digest, device=dev) if last is not None else None
    step = int(ck["update"]) if ck else 0
    log = CsvLog(run.log_path, FIELDS, step if ck else None)
    deadline = time.monotonic() + (math.inf if minutes is None else 60.0 * minutes)
    total = int(cfg["steps"])
    bs, scale = int(cfg["batch_size"]), float(cfg["return_scale"])
    with session(threads), isolated_rng(seed):
        model = DecisionTransformer(cfg).to(dev)
        opt = torch.optim.AdamW(model.parameters(), lr=float(cfg["learning_rate"]),
                                weight_decay=float(cfg["weight_decay"]))
        warm = max(1, int(cfg["warmup_steps"]))
        sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda s: min(1.0, (s + 1) / warm))
        rng = np.random.default_rng(np.random.SeedSequence([seed, 2]))
        wall0 = 0.0
        if ck:
            model.load_state_dict(ck["state"]["model"])
            opt.load_state_dict(ck["state"]["optimizer"])
            sched.load_state_dict(ck["state"]["scheduler"])
            rng.bit_generator.state = ck["state"]["sampler"]
            set_rng_state(ck["rng"])
            wall0 = float(ck["wall_s"])
        # a fixed set of held-out windows for the validation loss
        held_batch = held.batch(held.steps[np.linspace(0, len(held) - 1, min(len(held), 64))
                                           .astype(np.int64)]) if len(held) else None
        t0 = time.monotonic()
        acc = {"loss": 0.0, "right": 0, "n": 0, "steps": 0, "t": time.monotonic()}
        every = max(1, int(cfg["checkpoint_every"]))

        def save() -> Path:
            state = {"model": model.state_dict(), "optimizer": opt.state_dict(),
                     "scheduler": sched.state_dict(), "sampler": rng.bit_generator.state}
            return run.save(step, {"kind": "dt", "manifest_sha256": digest,
                                   "dataset": str(Path(dataset).resolve()),
                                   "config": dict(cfg), "returns": stats,
                                   "wall_s": wall0 + time.monotonic() - t0,
                                   "timesteps": step * bs, "state": state,
                                   "rng": rng_state()})

        def log_row(evaluated: dict[str, float]) -> None:
            row: dict[str, Any] = {"update": step, "samples": step * bs,
                                   "wall_s": round(wall0 + time.monotonic() - t0, 2),
                                   "steps_per_s": acc["steps"] / max(
                                       time.monotonic() - acc["t"], 1e-9),
                                   "loss": acc["loss"] / max(acc["steps"], 1),
                                   "accuracy": acc["right"] / max(acc["n"], 1),
                                   "lr": sched.get_last_lr()[0], **evaluated}
            if held_batch is not None:
                model.eval()
                with torch.no_grad():
                    loss, right, n = _step_loss(model, _batch_tensors(held_batch, dev), scale)
                model.train()
                row.update(val_loss=float(loss), val_accuracy=right / max(n, 1))
            log.append(row)
            acc.update(loss=0.0, right=0, n=0, steps=0, t=time.monotonic())

        stopped = False
        model.train()
        while step < total:
            if time.monotonic() >= deadline:
                stopped = True
                break
            batch = _batch_tensors(windows.sample(rng, bs), dev)
            loss, right, n = _step_loss(model, batch, scale)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            nn.utils.clip_grad_norm_(model.parameters(), 0.25)
            opt.step()
            sched.step()
            step += 1
            if progress is not None:
                progress("gradient steps", step, total)
            acc["loss"] += loss.item()
            acc["right"] += right
            acc["n"] += n
            acc["steps"] += 1
            ev_every = int(cfg["eval_every"])
            due_eval = ev_every > 0 and int(cfg["eval_episodes"]) > 0 and \
                (step % ev_every == 0 or step == total)
            if step % every == 0 or step == total or due_eval:
                path = save()
                log_row(evaluate_checkpoint(dataset, path, int(cfg["eval_episodes"]), seed)
                        if due_eval else {})
                _draw(run, dataset)
        if stopped and (run.latest() is None or int(run.latest().stem[5:]) != step):
            save()
            if acc["steps"]:
                log_row({})
            _draw(run, dataset)
    return {"updates": step, "timesteps": step, "wall_s": wall0 + time.monotonic() - t0,
            "done": step >= total, "stopped": stopped, "checkpoint": str(run.latest())}


def evaluate_checkpoint(dataset: str | Path, checkpoint: Path, n: int, seed: int
                        ) -> dict[str, float]:
    """The checkpoint played on the first ``n`` validation episodes (test when the build has
    no validation split): mean success, SPL, SNA."""
    from fallgen.dataset.reader import Dataset
    from fallgen.evaluation.runner import AgentRef, run_episodes

    ds = Dataset(dataset)
    split = "validation" if "validation" in ds.splits else "test"
    ids = ds.ids(split)[:n]
    ref = AgentRef("factory", "fallgen.policies.agent:load_run",
                   kwargs={"run": str(checkpoint)})
    recs = run_episodes(dataset, ids, ref, workers=1, seed=seed)
    return {"success": float(np.mean([r["success"] for r in recs])),
            "spl": float(np.mean([r["spl"] for r in recs])),
            "sna": float(np.mean([r["sna"] for r in recs])), "eval_episodes": len(recs)}


def _draw(run: Run, dataset) -> None:
    curve_png(run.curve_path, read_log(run.log_path), "update",
              [("cross-entropy (train, held out)", ("loss", "val_loss")),
               ("action accuracy (train, held out)", ("accuracy", "val_accuracy")),
               ("validation episodes: success, SPL", ("success", "spl"))],
              f"dt on {dataset}")


class DtAgent:
    """A trained Decision Transformer as a ``fallgen evaluate`` agent (module docstring)."""

    sensors = SENSORS

    def __init__(self, checkpoint: Mapping[str, Any], deterministic: bool = False,
                 device: Any = "cpu", target_return: float | None = None) -> None:
        cfg = checkpoint["config"]
        self.model = DecisionTransformer(cfg)
        self.model.load_state_dict(checkpoint["state"]["model"])
        self.model.to(device).eval()
        self.device, self.deterministic = device, deterministic
        self.k, self.scale = int(cfg["context"]), float(cfg["return_scale"])
        r = checkpoint["returns"]
        self.target = float(r["target_return"] if target_return is None else target_return)
        self.step_reward, self.min_rtg = float(r["step_reward"]), float(r["min_rtg"])
        self.compact = compactor(int(cfg["sample_rate"]))
        self.rng = np.random.default_rng(0)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self.t = 0
        self.feats: list[torch.Tensor] = []  # the context's encoded observations
        self.actions: list[int] = []  # and the actions taken after all but the last

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        c = self.compact(obs, first=self.t == 0)
        dev = self.device
        with torch.no_grad():
            self.feats.append(self.model.embed_states(to_tensors(c, dev, batched=False))[0])
            del self.feats[:-self.k]
            m = len(self.feats)
            steps = list(range(self.t + 1 - m, self.t + 1))
            rtg = [max(self.target - s * self.step_reward, self.min_rtg) / self.scale
                   for s in steps]
            acts = (self.actions[-(m - 1):] if m > 1 else []) + [0]  # the last is not read
            logits = self.model(torch.stack(self.feats)[None],
                                torch.tensor([rtg], dtype=torch.float32, device=dev),
                                torch.tensor([acts], device=dev),
                                torch.tensor([steps], device=dev),
                                torch.ones(1, m, dtype=torch.bool, device=dev))
            p = torch.softmax(logits[0, -1].double(), -1).cpu().numpy()
        a = int(np.argmax(p)) if self.deterministic else int(self.rng.choice(len(p),
                                                                            p=p / p.sum()))
        self.actions = (self.actions + [a])[-self.k:]
        self.t += 1
        return a


__all__ = ["DtSettings", "DecisionTransformer", "DtAgent", "settings", "train",
           "evaluate_checkpoint", "DEFAULT_STEPS", "DEFAULT_MINUTES"]
