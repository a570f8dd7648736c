"""The visual perception module's jobs, without a command line: draw the frames, train, save
(:func:`train_model`); draw a split's frames, score, draw the pictures (:func:`score_model`).
Used by ``fallgen vision-model`` and ``fallgen table``. Progress goes to
``progress(step, done, total)``, messages to ``log(line)``."""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

Step = Callable[[str, int, int], None]


def _ticker(progress: Step | None, name: str, total: int) -> Callable[[int], None] | None:
    if progress is None:
        return None
    done = [0]
    progress(name, 0, total)

    def tick(n: int) -> None:
        done[0] += n
        progress(name, done[0], total)

    return tick


def subsample_rows(rows: Sequence[dict], n: int, seed: int, salt: int) -> list[dict]:
    """``n`` of ``rows`` (all when ``n`` is 0 or not smaller), drawn without replacement from
    ``SeedSequence(seed, spawn_key=(salt,))``, in episode order."""
    rows = sorted(rows, key=lambda r: r["episode_id"])
    if n <= 0 or n >= len(rows):
        return list(rows)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(salt,)))
    keep = np.sort(rng.choice(len(rows), n, replace=False))
    return [rows[i] for i in keep]


def train_model(ds, out: Path, rows: Sequence[dict], val_rows: Sequence[dict], settings,
                device: str, workers: int, cache: Path | None, data_dir: Path | None,
                progress: Step | None = None, log: Callable[[str], None] | None = None,
                meta: dict | None = None):
    """Collect the frames, train, save the model (atomically) with its learning curve (CSV
    and PNG beside it: ``OUT.log.csv``, ``OUT.curve.png``); the model. ``cache``: where the
    frames are kept (reused when they match), else a temporary directory removed after."""
    from fallgen.learn.frames import collect
    from fallgen.learn.vision_eval import curve_png, write_log
    from fallgen.learn.vision_train import Progress, train
    from fallgen.world.library import load_world

    targets = load_world(data_dir).categories.ids("target")
    out.parent.mkdir(parents=True, exist_ok=True)
    root = Path(cache) if cache else Path(tempfile.mkdtemp(prefix=".vision-frames-",
                                                           dir=out.parent))
    say = log or (lambda _: None)
    try:
        t0 = time.perf_counter()
        store = collect(ds, rows, root / "train", settings.spec, targets, workers, data_dir,
                        progress=_ticker(progress, "frames (train)", len(rows)))
        val = None
        if val_rows:
            val = collect(ds, val_rows, root / "validation", settings.spec, targets, workers,
                          data_dir, progress=_ticker(progress, "frames (validation)",
                                                     len(val_rows)))
        frames_s = time.perf_counter() - t0

        def epoch(r: dict) -> None:
            say(f"epoch {r['epoch']}: loss {r['train_loss']:.4f}"
                + (f", validation mIoU {r['val_miou']:.3f}, found {r['val_found']:.2f}, "
                   f"false alarms {r['val_false_alarms']:.2f}" if "val_miou" in r else "")
                + f" ({r['seconds']:.0f} s)")

        model = train(ds, store, val, settings, device, Progress(
            step=(lambda k, total: progress("train", k, total)) if progress else None,
            epoch=epoch))
    finally:
        if not cache:
            shutil.rmtree(root, ignore_errors=True)
    model.meta.update({"dataset": str(ds.root), "frames_seconds": frames_s,
                       "train_episodes": len(rows), "val_frames": len(val) if val else 0,
                       **(meta or {})})
    model.save(out)
    write_log(model.meta["history"], out.with_suffix(".log.csv"))
    curve_png(model.meta["history"], out.with_suffix(".curve.png"))
    return model


def score_model(model, ds, rows: Sequence[dict], out: Path, device: str, workers: int,
                seed: int, data_dir: Path | None, progress: Step | None = None) -> dict:
    """Draw ``rows``' frames (as the model was trained: its views per episode), score the
    model on them and write the pictures into ``out``; the scores."""
    from fallgen.learn.frames import FrameSpec, collect
    from fallgen.learn.vision_eval import confusion_png, evaluate, strip_png
    from fallgen.world.library import load_world

    spec_d = model.meta.get("settings", {}).get("spec", {})
    spec = FrameSpec(int(spec_d.get("path", 1)), int(spec_d.get("look", 1)), seed)
    targets = [c for c in model.classes[1:]]
    out.mkdir(parents=True, exist_ok=True)
    load_world(data_dir)  # the world data must load before any worker starts
    root = Path(tempfile.mkdtemp(prefix=".vision-frames-", dir=out))
    try:
        store = collect(ds, rows, root, spec, targets, workers, data_dir,
                        progress=_ticker(progress, "frames", len(rows)))
        scores, arrays = evaluate(model, ds, store, device,
                                  progress=_ticker(progress, "segment", len(store)))
        confusion_png(arrays["confusion"], model.classes, out / "confusion.png")
        strip_png(model, store, arrays["best"], arrays["lead"], out / "strip.png")
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return scores


__all__ = ["subsample_rows", "train_model", "score_model"]
