"""Scores and pictures of the visual perception module (``fallgen vision-model eval``).

On a split's frames (:mod:`fallgen.learn.frames`: step 0, views along the expert's path and
from near the object):

- per-category IoU (pixels of all frames pooled) and their mean over the target categories
  that occur (in the truth or the prediction), and the ``other`` class's;
- ``found``: the share of frames where the fallen object shows at least
  :data:`FOUND_SHOWN_PIXELS` pixels within :data:`FOUND_WITHIN_M` m (horizontally) in which
  at least :data:`FOUND_PIXELS` of its own pixels are predicted as its category;
  ``found_visible`` the same over frames where it shows at least :data:`FOUND_PIXELS` pixels
  (what the judge calls visible) within 2 m; both by zone kind too;
- ``false_alarms``: the share of frames where the fallen object is not visible (fewer than
  :data:`FOUND_PIXELS` of its pixels) in which its category is predicted on at least
  :data:`FOUND_PIXELS` pixels (a distractor taken for it, or nothing taken for something);
- ``found_asked``, ``false_alarms_asked``: the same two with the object's category asked for
  (:meth:`VisionModel.scores`' ``asked``, at the model's ``ask_margin``): what the agent that
  knows which category it looks for (from the sound, or the category oracle) sees;
- the pixel confusion matrix (a PNG, rows the truth), a strip of views with the truth and the
  prediction side by side (a PNG), and the learning curve of training (a PNG and a CSV).
"""

from __future__ import annotations

import csv
import io
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from fallgen.learn.frames import CLASS_MASK, TARGET_BIT, FrameStore
from fallgen.learn.vision_model import (
    FOUND_PIXELS,
    FOUND_SHOWN_PIXELS,
    FOUND_WITHIN_M,
    VisionModel,
    full_size,
    labels_at,
)


def predict_store(model: VisionModel, store: FrameStore, device=None, batch: int = 8,
                  progress: Callable[[int], None] | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model's (best class, lead over ``other``) at half resolution for every frame of
    ``store`` (see :meth:`VisionModel.scores`), and the lead of each frame's own object
    class (its category asked for)."""
    n = len(store)
    h, w = (store.label.shape[1] + 1) // 2, (store.label.shape[2] + 1) // 2
    best = np.zeros((n, h, w), np.uint8)
    lead = np.zeros((n, h, w), np.float32)
    own = np.zeros((n, h, w), np.float32)
    for k in range(0, n, batch):
        sl = slice(k, min(k + batch, n))
        rgb, depth = np.asarray(store.rgb[sl]), np.asarray(store.depth[sl], np.float32)
        best[sl], lead[sl] = model.scores(rgb, depth, device)
        cls = np.maximum(store.meta["object_class"][sl], 1)[:, None]
        own[sl] = model.scores(rgb, depth, device, asked=cls)[1]
        if progress:
            progress(sl.stop - sl.start)
    return best, lead, own


def frame_scores(store: FrameStore, best: np.ndarray, lead: np.ndarray, margin: float,
                 n_classes: int, zones: Sequence[str] | None = None,
                 own: np.ndarray | None = None, ask_margin: float = 0.0) -> dict:
    """The scores of predictions (:func:`predict_store`) at ``margin`` against ``store``'s
    labels; ``zones`` (per frame, optional) for the found rates by zone kind; with ``own``
    (the lead of each frame's object class) also ``found_asked`` and ``false_alarms_asked``:
    the same counts when the object's category is asked for, at ``ask_margin``."""
    confusion = np.zeros((n_classes, n_classes), np.int64)
    found = visible = alarms = found_a = alarms_a = 0
    n_found = n_visible = n_alarm = 0
    by_zone: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0])
    meta = store.meta
    for i in range(len(store)):
        pred = full_size(labels_at(best[i], lead[i], margin))
        lab = np.asarray(store.label[i])
        cls = lab & CLASS_MASK
        confusion += np.bincount((cls.astype(np.int64) * n_classes + pred).ravel(),
                                 minlength=n_classes * n_classes).reshape(n_classes, n_classes)
        oc, op = int(meta["object_class"][i]), int(meta["object_pixels"][i])
        near = float(meta["distance_m"][i]) <= FOUND_WITHIN_M
        mine = (lab & TARGET_BIT) != 0
        hit = int(((pred == oc) & mine).sum()) >= FOUND_PIXELS
        asked = full_size((own[i] > ask_margin)[None].astype(np.uint8))[0] > 0 \
            if own is not None else None
        hit_a = asked is not None and int((asked & mine).sum()) >= FOUND_PIXELS
        if near and op >= FOUND_SHOWN_PIXELS:
            n_found += 1
            found += hit
            found_a += hit_a
            if zones is not None:
                z = by_zone[zones[i]]
                z[0], z[1], z[2] = z[0] + 1, z[1] + hit, z[2] + hit_a
        if near and op >= FOUND_PIXELS:
            n_visible += 1
            visible += hit
        if op < FOUND_PIXELS:
            n_alarm += 1
            alarms += int((pred == oc).sum()) >= FOUND_PIXELS
            alarms_a += asked is not None and int(asked.sum()) >= FOUND_PIXELS
    inter = np.diag(confusion).astype(float)
    union = confusion.sum(0) + confusion.sum(1) - inter
    iou = np.where(union > 0, inter / np.maximum(union, 1), np.nan)
    targets = iou[1:]
    nan = float("nan")
    out = {
        "frames": len(store), "margin": float(margin),
        "iou": iou, "miou": float(np.nanmean(targets)) if np.isfinite(targets).any() else 0.0,
        "found": found / n_found if n_found else nan, "found_frames": n_found,
        "found_visible": visible / n_visible if n_visible else nan,
        "visible_frames": n_visible,
        "false_alarms": alarms / n_alarm if n_alarm else nan,
        "false_alarm_frames": n_alarm,
        "found_by_zone_kind": {z: {"frames": a, "found": b / a} for z, (a, b, _) in
                               sorted(by_zone.items())},
        "confusion": confusion,
    }
    if own is not None:
        out.update({"ask_margin": float(ask_margin),
                    "found_asked": found_a / n_found if n_found else nan,
                    "false_alarms_asked": alarms_a / n_alarm if n_alarm else nan,
                    "found_asked_by_zone_kind": {z: {"frames": a, "found": c / a} for
                                                 z, (a, _, c) in sorted(by_zone.items())}})
    return out


def inference_ms(model: VisionModel, store: FrameStore, frames: int = 30) -> float:
    """Median milliseconds to segment one frame (batch of one, one torch thread, CPU)."""
    from fallgen.learn.runtime import session

    times = []
    with session(threads=1, deterministic=False):
        for i in range(min(frames + 3, len(store))):
            rgb, depth = np.asarray(store.rgb[i:i + 1]), np.asarray(store.depth[i:i + 1],
                                                                      np.float32)
            t = time.perf_counter()
            model.predict(rgb, depth, device="cpu")
            times.append(time.perf_counter() - t)
    return float(np.median(times[3:] or times)) * 1000


def evaluate(model: VisionModel, ds, store: FrameStore, device=None,
             progress: Callable[[int], None] | None = None) -> tuple[dict, dict]:
    """(scores.json's content, the arrays for the pictures: ``confusion``, ``best``,
    ``lead``) of ``model`` on ``store`` (frames of ``ds``)."""
    best, lead, own = predict_store(model, store, device=device, progress=progress)
    zone = {r["episode_id"]: r["zone_kind"] for r in ds.rows()}
    zones = [zone.get(int(e), "?") for e in store.meta["episode_id"]]
    sc = frame_scores(store, best, lead, model.margin, len(model.classes), zones, own,
                      model.ask_margin)
    iou = sc.pop("iou")
    confusion = sc.pop("confusion")
    sc["per_category_iou"] = {name: (None if not np.isfinite(v) else float(v))
                              for name, v in zip(model.classes[1:], iou[1:])}
    sc["other_iou"] = float(iou[0])
    sc["episodes"] = int(len(np.unique(store.meta["episode_id"])))
    sc["frames_by_kind"] = {"step0": int((store.meta["step"] == 0).sum()),
                            "path": int((store.meta["step"] > 0).sum()),
                            "look": int((store.meta["step"] < 0).sum())}
    sc["definitions"] = {
        "found": f"frames where the fallen object shows >= {FOUND_SHOWN_PIXELS} pixels within "
                 f"{FOUND_WITHIN_M:g} m: >= {FOUND_PIXELS} of its pixels predicted as its "
                 "category",
        "found_visible": f"the same over frames where it shows >= {FOUND_PIXELS} pixels within "
                         f"{FOUND_WITHIN_M:g} m",
        "false_alarms": f"frames where it shows < {FOUND_PIXELS} pixels: its category predicted "
                        f"on >= {FOUND_PIXELS} pixels",
        "found_asked": "found, its category asked for (the agent that knows what it looks "
                       "for): pixels where that category outscores other by the ask margin",
        "false_alarms_asked": "false alarms, its category asked for",
        "miou": "mean IoU over the target categories that occur in the truth or the "
                "prediction (pixels of all frames pooled)"}
    sc["inference_ms_per_frame_1_thread"] = inference_ms(model, store)
    sc["model"] = {"margin": model.margin, "ask_margin": model.ask_margin,
                   "manifest_sha256": model.manifest_sha256,
                   **{k: model.meta.get(k) for k in ("train_frames", "train_seconds", "loss",
                                                     "settings")}}
    return sc, {"confusion": confusion, "best": best, "lead": lead, "own": own}


# -- pictures -------------------------------------------------------------------------------------

def palette(n: int) -> np.ndarray:
    """(n, 3) uint8 colours: grey for ``other``, hues spread for the rest."""
    import cv2

    hsv = np.zeros((1, n, 3), np.uint8)
    hsv[0, :, 0] = (np.arange(n) * 180 * 7 // max(n, 1)) % 180
    hsv[0, :, 1], hsv[0, :, 2] = 230, 255
    out = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0]
    out[0] = (70, 70, 70)
    return out


def _paint(rgb: np.ndarray, labels: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """The view dimmed, classes other than 0 painted over it."""
    out = (rgb.astype(np.float32) * 0.45).astype(np.uint8)
    mask = labels > 0
    out[mask] = colours[labels[mask]]
    return out


def strip_png(model: VisionModel, store: FrameStore, best: np.ndarray, lead: np.ndarray,
              path: str | Path, rows: int = 8, size: int = 200) -> Path:
    """Up to ``rows`` views where the fallen object shows (the most pixels first, one per
    episode): the view, the truth and the prediction side by side."""
    import cv2

    from fallgen.world.preview import write_png

    meta = store.meta
    order = np.argsort(-meta["object_pixels"], kind="stable")
    chosen, eps = [], set()
    for i in order:
        if meta["object_pixels"][i] < FOUND_PIXELS or int(meta["episode_id"][i]) in eps:
            continue
        chosen.append(int(i))
        eps.add(int(meta["episode_id"][i]))
        if len(chosen) >= rows:
            break
    colours = palette(len(model.classes))
    lines = []
    for i in chosen or [0]:
        rgb = np.asarray(store.rgb[i])
        truth = np.asarray(store.label[i]) & CLASS_MASK
        pred = full_size(labels_at(best[i], lead[i], model.margin))
        tiles = [cv2.resize(t, (size, size), interpolation=cv2.INTER_NEAREST)
                 for t in (rgb, _paint(rgb, truth, colours), _paint(rgb, pred, colours))]
        line = np.concatenate(tiles, axis=1)
        name = model.classes[int(meta["object_class"][i])]
        cv2.putText(line, f"ep {int(meta['episode_id'][i])}: {name}, "
                    f"{int(meta['object_pixels'][i])} px, {float(meta['distance_m'][i]):.1f} m",
                    (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
        lines.append(line)
    head = np.full((22, lines[0].shape[1], 3), 255, np.uint8)
    cv2.putText(head, "view | truth | prediction", (4, 15), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                (0, 0, 0), 1, cv2.LINE_AA)
    return write_png(np.concatenate([head] + lines, axis=0), path)


def confusion_png(confusion: np.ndarray, classes: Sequence[str], path: str | Path) -> Path:
    """The pixel confusion matrix, rows the truth, normalised per row."""
    from fallgen.perception.audio_model import confusion_png as draw

    return draw(confusion, list(classes), "pixels", Path(path))


def write_log(history: Sequence[dict], path: str | Path) -> Path:
    """The learning curve as CSV (one row per epoch)."""
    from fallgen.atomic import write_text

    keys: list[str] = []
    for r in history:
        keys += [k for k in r if k not in keys]
    buf = io.StringIO()
    w = csv.DictWriter(buf, keys, lineterminator="\n")
    w.writeheader()
    for r in history:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return write_text(path, buf.getvalue())


def curve_png(history: Sequence[dict], path: str | Path, width: int = 640,
              height: int = 360) -> Path:
    """The learning curve: the training loss (its own scale, left) and the validation mIoU,
    found and false-alarm rates (0 to 1) by epoch."""
    import cv2

    from fallgen.world.preview import write_png

    img = np.full((height, width, 3), 255, np.uint8)
    x0, x1, y0, y1 = 50, width - 20, 30, height - 40
    cv2.rectangle(img, (x0, y0), (x1, y1), (0, 0, 0), 1)
    epochs = [r["epoch"] for r in history] or [1]
    span = max(max(epochs) - 1, 1)

    def xs(e: float) -> int:
        return int(x0 + (e - 1) / span * (x1 - x0)) if len(epochs) > 1 else (x0 + x1) // 2

    series = [("train_loss", (200, 0, 0), None), ("val_miou", (0, 120, 0), (0.0, 1.0)),
              ("val_found", (0, 0, 220), (0.0, 1.0)),
              ("val_false_alarms", (230, 130, 0), (0.0, 1.0))]
    for k, (name, colour, scale) in enumerate(series):
        pts = [(r["epoch"], r[name]) for r in history if name in r and np.isfinite(r[name])]
        if not pts:
            continue
        lo, hi = scale or (0.0, max(v for _, v in pts) * 1.05 or 1.0)
        poly = np.array([[xs(e), int(y1 - (v - lo) / max(hi - lo, 1e-12) * (y1 - y0))]
                         for e, v in pts], np.int32)
        cv2.polylines(img, [poly], False, colour, 2, cv2.LINE_AA)
        for p in poly:
            cv2.circle(img, tuple(int(c) for c in p), 3, colour, -1)
        label = name + (f" (0-{hi:.3g})" if scale is None else " (0-1)")
        cv2.putText(img, label, (x0 + 8 + 150 * k, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour,
                    1, cv2.LINE_AA)
    cv2.putText(img, "epoch", ((x0 + x1) // 2 - 20, height - 12), cv2.FONT_HERSHEY_SIMPLEX,
                0.45, (0, 0, 0), 1, cv2.LINE_AA)
    for e in epochs:
        cv2.putText(img, str(e), (xs(e) - 4, y1 + 15), cv2.FONT_HERSHEY_SIMPLEX, 0.35,
                    (0, 0, 0), 1, cv2.LINE_AA)
    return write_png(img, path)


__all__ = ["predict_store", "frame_scores", "evaluate", "inference_ms", "strip_png",
           "confusion_png", "curve_png", "write_log", "palette"]
