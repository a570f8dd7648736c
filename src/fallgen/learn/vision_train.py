"""Training the visual perception module (:mod:`fallgen.learn.vision_model`).

Random crops of the frames (:mod:`fallgen.learn.frames`), half of them around a target
category's pixels where the frame has any, flipped left-right and jittered in brightness and
contrast; AdamW with a warm-up and a cosine decay. The object is a few hundred pixels of 90 000
(often a few dozen), so the loss is a focal loss (Lin et al. 2017; gamma :data:`FOCAL_GAMMA`:
pixels already right weigh little) with class weights ``min((f_other / f_class) ** 0.5,
MAX_WEIGHT)`` from the training labels' pixel frequencies. After each epoch the validation
frames give the learning curve (mIoU, found, false alarms); at the end they choose the margins by
which a target category must outscore ``other``, of the best of all the targets and of a
category asked for (each the one that finds the most objects while the false alarms stay
under :data:`FALSE_ALARM_GOAL`).

Deterministic on the CPU for a seed and a thread count: weights from a seeded generator, batches
and crops from ``SeedSequence(seed)``, ``torch.use_deterministic_algorithms`` while it runs.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from fallgen.learn import require_torch
from fallgen.learn.frames import CLASS_MASK, TARGET_BIT, FrameSpec, FrameStore, class_table
from fallgen.learn.nets import NetConfig
from fallgen.learn.vision_eval import frame_scores, predict_store
from fallgen.learn.vision_model import VisionModel, to_input

FOCAL_GAMMA = 2.0
MAX_WEIGHT = 25.0
#: the validation false-alarm rate the margin is chosen under
FALSE_ALARM_GOAL = 0.08
#: margins tried on the validation frames
MARGINS = (-2.0, -1.5, -1.0, -0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0)


@dataclass(frozen=True)
class TrainSettings:
    """What :func:`train` does (the defaults fit the paper-size build's training in an hour
    on the 2-core VM: 4000 episodes' 24000 frames drawn in ~10 min on one core, 6000 steps of
    0.27-0.38 s): ``frames`` at most (the train split's episodes subsampled,
    seeded, to fit), each episode's views (``spec``), ``epochs`` over them in batches of
    ``batch`` crops of ``crop`` pixels, learning rate ``lr``; ``val_episodes`` validation
    episodes for the learning curve and the margin; ``seed``; ``threads`` for torch (one:
    torch's OpenMP threads spin while they wait for each other, so a second one pays only on
    an idle core; on the shared 2-core VM a step of 16 crops of 160 px took 190 ms on one
    thread and 3.5 s on two, 0.26 s with ``OMP_WAIT_POLICY=PASSIVE``)."""

    frames: int = 24000
    spec: FrameSpec = FrameSpec()
    epochs: int = 4
    batch: int = 16
    crop: int = 160  # even: each half-resolution score stands for a 2 x 2 block
    lr: float = 3e-3
    weight_decay: float = 1e-4
    focus: float = 0.5
    widths: tuple[int, int, int, int] = (16, 32, 64, 128)
    val_episodes: int = 100
    seed: int = 0
    threads: int = 1

    def to_dict(self) -> dict:
        d = asdict(self)
        d["spec"] = self.spec.to_dict()
        d["widths"] = list(self.widths)
        return d


def class_weights(store: FrameStore, n_classes: int, sample: int = 2000) -> np.ndarray:
    """The loss's class weights from the pixel frequencies of (up to ``sample`` evenly spaced)
    frames: ``min((f_other / f_class) ** 0.5, MAX_WEIGHT)``, 1 for ``other``."""
    idx = np.linspace(0, len(store) - 1, min(sample, len(store))).astype(int)
    counts = np.zeros(n_classes, np.int64)
    for i in idx:
        counts += np.bincount((store.label[i] & CLASS_MASK).ravel(), minlength=n_classes)
    f = counts / max(counts.sum(), 1)
    w = np.full(n_classes, MAX_WEIGHT)
    seen = f > 0
    w[seen] = np.minimum(np.sqrt(f[0] / f[seen]), MAX_WEIGHT)
    w[0] = 1.0
    return w.astype(np.float32)


def batch(store: FrameStore, idx: Sequence[int], rng: np.random.Generator, crop: int,
          focus: float) -> tuple[np.ndarray, np.ndarray]:
    """(inputs (B, 4, crop, crop), classes (B, crop, crop) int64) of frames ``idx``: random
    crops, with probability ``focus`` around a pixel of the fallen object where it shows (else
    of any target category, where one shows: a large distractor would otherwise draw most of
    them), flipped left-right half the time, brightness and contrast jittered."""
    H, W = store.label.shape[1:]
    xs = np.empty((len(idx), 4, crop, crop), np.float32)
    ys = np.empty((len(idx), crop, crop), np.int64)
    for k, i in enumerate(idx):
        full = np.asarray(store.label[i])
        lab = full & CLASS_MASK
        hot: np.ndarray | tuple = ()
        if rng.random() < focus:
            hot = np.flatnonzero(full & TARGET_BIT)
            if not len(hot):
                hot = np.flatnonzero(lab)
        if len(hot):
            p = int(hot[rng.integers(len(hot))])
            cy, cx = divmod(p, W)
            y0 = int(np.clip(cy - rng.integers(crop // 8, crop - crop // 8), 0, H - crop))
            x0 = int(np.clip(cx - rng.integers(crop // 8, crop - crop // 8), 0, W - crop))
        else:
            y0, x0 = int(rng.integers(H - crop + 1)), int(rng.integers(W - crop + 1))
        y0, x0 = y0 - y0 % 2, x0 - x0 % 2  # the 2 x 2 blocks of the scores as at inference
        sl = (slice(y0, y0 + crop), slice(x0, x0 + crop))
        x = to_input(store.rgb[i][sl][None], store.depth[i][sl][None])[0]
        y = lab[sl]
        if rng.random() < 0.5:
            x, y = x[:, :, ::-1], y[:, ::-1]
        gain, shift = rng.uniform(0.8, 1.2), rng.uniform(-0.3, 0.3)
        x[:3] = x[:3] * gain + shift
        xs[k], ys[k] = x, y
    return xs, ys


def focal_loss(logits, target, weights, gamma: float = FOCAL_GAMMA):
    """Class-weighted focal loss (Lin et al. 2017) of half-resolution scores (B, C, h, w)
    against full-resolution classes (B, 2h, 2w), normalised by the weights of the pixels:
    each score stands for its 2 x 2 block of pixels (as the label map is doubled), so the
    loss is summed over the block's four pixels (the same as upsampling the scores, at a
    quarter of the cost)."""
    logp = logits.log_softmax(1)
    total = wsum = 0.0
    for dy in (0, 1):
        for dx in (0, 1):
            t = target[:, dy::2, dx::2]
            lp = logp.gather(1, t[:, None])[:, 0]
            w = weights[t]
            total = total + (-w * (1 - lp.exp()).pow(gamma) * lp).sum()
            wsum = wsum + w.sum()
    return total / wsum


@dataclass
class Progress:
    """Callbacks of :func:`train`: ``step(done, total)`` per batch, ``epoch(record)`` per
    epoch (the learning curve's row)."""

    step: Callable[[int, int], None] | None = None
    epoch: Callable[[dict], None] | None = None


def train(ds, train_store: FrameStore, val_store: FrameStore | None, settings: TrainSettings,
          device: str | None = None, progress: Progress | None = None) -> VisionModel:
    """Train a :class:`VisionModel` on ``train_store``'s frames (of ``ds``); the learning
    curve and the margin from ``val_store``'s."""
    torch = require_torch()
    progress = progress or Progress()
    from fallgen.dataset.manifest import manifest_sha256
    from fallgen.learn.nets import SegNet
    from fallgen.learn.runtime import init_weights, keep_heap, resolve_device, session

    dev = resolve_device(device)
    keep_heap()
    classes, _ = class_table(ds.category_labels, train_store.info["targets"])
    config = NetConfig(len(classes), 4, tuple(settings.widths))
    s = settings
    with session(s.threads):
        net = SegNet(config)
        init_weights(net, s.seed)
        net = net.to(dev).to(memory_format=torch.channels_last)
        weights = torch.from_numpy(class_weights(train_store, len(classes))).to(dev)
        opt = torch.optim.AdamW(net.parameters(), lr=s.lr, weight_decay=s.weight_decay)
        n = len(train_store)
        per_epoch = max(1, n // s.batch)
        total = per_epoch * s.epochs
        warm = max(1, min(300, total // 20))

        def lr_at(k: int) -> float:
            if k < warm:
                return s.lr * (k + 1) / warm
            t = (k - warm) / max(1, total - warm)
            return s.lr * (0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * t)))

        rng = np.random.default_rng(np.random.SeedSequence(s.seed, spawn_key=(7,)))
        history: list[dict] = []
        model = VisionModel(config, {}, classes, tuple(ds.category_labels),
                            manifest_sha256(ds.root) or "", 0.0,
                            {"settings": s.to_dict(), "device": str(dev)})
        k = 0
        t_start = time.perf_counter()
        for epoch in range(s.epochs):
            net.train()
            order = rng.permutation(n)
            run_loss = 0.0
            t0 = time.perf_counter()
            for b in range(per_epoch):
                idx = np.sort(order[b * s.batch:(b + 1) * s.batch])
                x, y = batch(train_store, idx, rng, s.crop, s.focus)
                xt = torch.from_numpy(x).to(dev).contiguous(memory_format=torch.channels_last)
                yt = torch.from_numpy(y).to(dev)
                for g in opt.param_groups:
                    g["lr"] = lr_at(k)
                loss = focal_loss(net(xt), yt, weights)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                run_loss += float(loss.detach())
                k += 1
                if progress.step:
                    progress.step(k, total)
            record = {"epoch": epoch + 1, "train_loss": run_loss / per_epoch,
                      "lr": lr_at(k - 1), "seconds": time.perf_counter() - t0}
            model.set_state({kk: v.detach().cpu().clone()
                             for kk, v in net.state_dict().items()})
            if val_store is not None and len(val_store):
                best, lead, own = predict_store(model, val_store, device=dev)
                sc = frame_scores(val_store, best, lead, 0.0, len(classes), own=own)
                record.update({"val_miou": sc["miou"], "val_found": sc["found"],
                               "val_false_alarms": sc["false_alarms"],
                               "val_found_asked": sc["found_asked"],
                               "val_false_alarms_asked": sc["false_alarms_asked"]})
            history.append(record)
            if progress.epoch:
                progress.epoch(record)
        model.meta.update({"history": history, "train_frames": n,
                           "train_seconds": time.perf_counter() - t_start,
                           "class_weights": weights.cpu().tolist(),
                           "loss": f"focal (gamma {FOCAL_GAMMA}) with class weights "
                                   f"min((f_other / f_class) ** 0.5, {MAX_WEIGHT:g})"})
        if val_store is not None and len(val_store):
            model.margin, model.ask_margin, model.meta["margins"] = \
                choose_margin(model, val_store, device=dev)
    return model


def choose_margin(model: VisionModel, store: FrameStore, device=None
                  ) -> tuple[float, float, list[dict]]:
    """The margins (of :data:`MARGINS`) that find the fallen object in the most of
    ``store``'s frames while its false alarms stay under :data:`FALSE_ALARM_GOAL` (the
    largest margin when none does): one for the best of all the targets, one for its
    category asked for; and every margin's rates."""

    best, lead, own = predict_store(model, store, device=device)
    rows = []
    for m in MARGINS:
        sc = frame_scores(store, best, lead, m, len(model.classes), own=own, ask_margin=m)
        rows.append({"margin": m, "found": sc["found"], "false_alarms": sc["false_alarms"],
                     "found_visible": sc["found_visible"], "found_asked": sc["found_asked"],
                     "false_alarms_asked": sc["false_alarms_asked"]})

    def pick(found: str, alarms: str) -> float:
        ok = [r for r in rows if r[alarms] <= FALSE_ALARM_GOAL]
        return float(max(ok, key=lambda r: (r[found], -r["margin"]))["margin"] if ok
                     else rows[-1]["margin"])

    return pick("found", "false_alarms"), pick("found_asked", "false_alarms_asked"), rows


__all__ = ["TrainSettings", "Progress", "train", "class_weights", "batch", "focal_loss",
           "choose_margin", "FOCAL_GAMMA", "MAX_WEIGHT", "FALSE_ALARM_GOAL", "MARGINS"]
