"""The visual module's part of ``fallgen table`` (:mod:`fallgen.evaluation.table`): the
module trained once (or given), scored on Table 1's test episodes' frames, its section of
``table.md``, and where the rows that see with it fail (success by zone kind and by
category, beside the same agent with ground-truth segmentation).

Everything torch needs is imported inside :func:`vision_module`, which returns None without
torch (the rows that need the module are then left out).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: rows compared by zone kind, in this order (those the table ran)
FAILURE_ROWS = ("objectgoal", "modular_av", "modular_audio_seg", "modular_av_obj",
                "modular_audio_seg_obj")
#: (learned row, the same agent with ground-truth segmentation) compared by category
CATEGORY_PAIRS = (("modular_av", "modular_audio_seg"),
                  ("modular_av_obj", "modular_audio_seg_obj"))


@dataclass
class VisionPart:
    """The module used by the rows (``path``), what its training took (``meta``), its
    scores on the test episodes' frames and the steps' seconds."""

    path: Path
    meta: dict
    scores: dict
    timings: dict[str, float] = field(default_factory=dict)


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None


def vision_module(ds, out: Path, models: Path, sha: str, test_ids: Sequence[int], seed: int,
                  frames: int, epochs: int, device: str, workers: int, data_dir,
                  log: Callable[[str], None], progress, given: Path | None = None
                  ) -> VisionPart | None:
    """The visual module: ``given`` (a model file of this dataset), else trained once into
    ``models`` (kept when a model for the same dataset and settings is there; its frames kept
    under ``models/vision-frames`` until it is made, so an interrupted run draws them once);
    scored on the test episodes' frames into ``out/vision`` (kept likewise). None without
    torch."""
    try:
        from fallgen.learn.frames import FrameSpec
        from fallgen.learn.vision_jobs import score_model, subsample_rows, train_model
        from fallgen.learn.vision_model import VisionModel
        from fallgen.learn.vision_train import TrainSettings
    except ImportError as e:
        log(f"visual module: {e}; its rows are left out")
        return None
    import shutil

    from fallgen.atomic import write_text
    from fallgen.dataset.manifest import sha256 as file_sha256
    from fallgen.errors import InputError

    model = None
    if given is not None:
        path = Path(given)
        model = VisionModel.load(path)
        model.check_dataset(ds, path)
        log(f"vision model: {path} (given)")
    else:
        path = models / "vision.model"
        spec = FrameSpec(seed=seed)
        settings = TrainSettings(frames=frames, spec=spec, epochs=epochs, seed=seed)
        if path.is_file():
            try:
                m = VisionModel.load(path)
                if m.manifest_sha256 == sha and m.meta.get("settings") == settings.to_dict():
                    model = m
                    log(f"vision model: kept {path}")
            except InputError:
                pass
        if model is None:
            rows = subsample_rows(ds.rows("train"), max(1, frames // spec.per_episode), seed,
                                  11)
            val_rows = subsample_rows(ds.rows("validation"), settings.val_episodes, seed, 12) \
                if "validation" in ds.splits else []
            cache = models / "vision-frames"
            model = train_model(ds, path, rows, val_rows, settings, device, workers, cache,
                                data_dir, progress, log, meta={"split": "train"})
            shutil.rmtree(cache, ignore_errors=True)
            log(f"vision model: {model.meta['train_frames']} frames of {len(rows)} train "
                f"episodes -> {path}")
    meta = {k: model.meta.get(k) for k in ("train_frames", "train_episodes", "frames_seconds",
                                           "train_seconds", "loss", "device", "settings")}
    meta["margin"], meta["ask_margin"] = model.margin, model.ask_margin
    # the model's own time (drawing its frames and training), whether made now or kept
    timings = {"vision model": float(model.meta.get("frames_seconds") or 0.0)
               + float(model.meta.get("train_seconds") or 0.0)}
    t0 = time.perf_counter()
    model_sha = file_sha256(path)
    scores_path = out / "vision" / "scores.json"
    scores = _read_json(scores_path)
    ids = sorted(int(i) for i in test_ids)
    if scores is not None and scores.get("model_sha256") == model_sha and \
            scores.get("episode_ids") == ids:
        log("vision scores: kept")
    else:
        rows = [ds.row(i) for i in ids]
        scores = score_model(model, ds, rows, out / "vision", device, workers, seed, data_dir,
                             progress)
        scores.update({"model_sha256": model_sha, "episode_ids": ids,
                       "wall_s": round(time.perf_counter() - t0, 1)})
        write_text(scores_path, json.dumps(scores, indent=1) + "\n")
    timings["vision scores"] = float(scores.get("wall_s", 0.0))
    return VisionPart(path, meta, scores, timings)


def vision_lines(v: Mapping, m: Mapping) -> list[str]:
    """table.md's section on the visual module: its scores ``v`` and training ``m`` (empty
    when it was not used)."""
    if not v:
        return []
    fmt = "{:.3f}".format
    zones = ", ".join(f"{z} {d['found']:.2f} ({d['frames']})"
                      for z, d in v.get("found_by_zone_kind", {}).items())
    return ["## The visual module on the test episodes' frames", "",
            f"Trained on {m.get('train_frames')} frames of {m.get('train_episodes')} train "
            f"episodes ({(m.get('frames_seconds') or 0) / 60:.1f} min drawing them, "
            f"{(m.get('train_seconds') or 0) / 60:.1f} min training on {m.get('device')}; "
            f"{m.get('loss')}; margins {m.get('margin')}, asked {m.get('ask_margin')}); scored "
            f"on {v['frames']} frames of {v['episodes']} test episodes (step 0, views along the "
            "expert's path and of the object from 0.5-2 m). Found: >= 4 of the object's pixels "
            "labelled with its category where it shows >= 50 px within 2 m; false alarms: its "
            "category on >= 4 px where it is not visible; asked: the network asked for the "
            "object's category alone (what the agent does when it knows what it looks for).", "",
            "| mIoU (31 targets) | found | false alarms | found, asked | false alarms, asked | "
            "found (>= 4 px within 2 m) | inference (1 thread) |",
            "|---|---|---|---|---|---|---|",
            f"| {fmt(v['miou'])} | {fmt(v['found'])} ({v['found_frames']}) | "
            f"{fmt(v['false_alarms'])} ({v['false_alarm_frames']}) | "
            f"{fmt(v.get('found_asked', float('nan')))} | "
            f"{fmt(v.get('false_alarms_asked', float('nan')))} | "
            f"{fmt(v['found_visible'])} ({v['visible_frames']}) | "
            f"{v['inference_ms_per_frame_1_thread']:.1f} ms |",
            "", f"Found by zone kind: {zones or '-'}.", ""]


def failure_lines(results: Mapping[str, dict], labels: Mapping[str, str],
                  worst: int = 8) -> list[str]:
    """table.md's section on where the rows with the visual module fail: success by zone
    kind (the rows of :data:`FAILURE_ROWS` that ran), and the categories where the learned
    eyes lose the most episodes against ground-truth segmentation (:data:`CATEGORY_PAIRS`)."""
    keys = [k for k in FAILURE_ROWS if k in results]
    if not any(k in results for k, _ in CATEGORY_PAIRS):
        return []
    zones = sorted({z for k in keys for z in results[k].get("by_zone_kind", {})})
    out = ["## Where the rows with the visual module fail", "",
           "Success (episodes) by the zone kind where the object came to rest:", "",
           "| row | " + " | ".join(zones) + " |", "|---|" + "---|" * len(zones)]
    for k in keys:
        z = results[k].get("by_zone_kind", {})
        out.append(f"| {labels.get(k, k)} | " + " | ".join(
            f"{z[n]['success']:.2f} ({z[n]['n']})" if n in z else "-" for n in zones) + " |")
    for learned, truth in CATEGORY_PAIRS:
        if learned not in results or truth not in results:
            continue
        a = results[learned].get("by_category", {})
        b = results[truth].get("by_category", {})
        # most episodes lost first (a category of one episode does not lead the list)
        gaps = sorted(((a[c]["success"] - b[c]["success"]) * a[c]["n"], c)
                      for c in a if c in b)
        cells = [f"{c} {b[c]['success']:.2f} -> {a[c]['success']:.2f} ({a[c]['n']})"
                 for _, c in gaps[:worst]]
        out += ["", f"Categories where {labels.get(learned, learned)} loses most against "
                f"{labels.get(truth, truth)} (success with ground truth -> learned, "
                f"episodes): " + ("; ".join(cells) or "-") + "."]
    return out + [""]


__all__ = ["VisionPart", "vision_module", "vision_lines", "failure_lines", "FAILURE_ROWS",
           "CATEGORY_PAIRS"]
