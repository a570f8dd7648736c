"""The measured head against the spherical one, as the audio module hears them: two builds made
from one config that differ only in ``hrtf`` (``sadie_ku100``, the measured SADIE KU100, and
``sphere``, the spherical-head model), the same root seed, rehearsal and episodes; the audio
module (:mod:`fallgen.perception.audio_model`) trained on each build's train split with the same
seed and scored on the test episodes the two builds share (the same event and spawn): median
azimuth error, the lateral angle's error (front and back folded), the front/back confusion rate,
by room kind, and the paired differences with 95 % bootstrap intervals.

    python bench/hrtf_compare.py [--config configs/full.toml] [--train 1500]
        [--validation 100] [--test 500] [--workers 2] [--work build/hrtf] [--trees 300]
        [--seed 0] [--json build/hrtf.json]

The builds go to ``--work``/sadie_ku100 and ``--work``/sphere (resumed when rerun: the second
reuses the first's rehearsal, which does not depend on the head); ~2 x 10 min and 6 min of
rehearsal on 2 cores for the defaults.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from fallgen.dataset.reader import Dataset  # noqa: E402
from fallgen.perception.audio_features import relative_place  # noqa: E402
from fallgen.perception.audio_model import (AudioModel, angle_error_deg,  # noqa: E402
                                             dataset_features, evaluate, feature_matrix,
                                             front_back_flips)

HEADS = ("sadie_ku100", "sphere")
#: The scores kept from each evaluation, overall and by room kind.
KEYS = ("azimuth_median_error_deg", "lateral_median_error_deg", "front_back_confusion_rate",
        "category_top1", "distance_rank_correlation", "position_median_error_m")
BOOTSTRAP = 2000


def head_config(text: str, head: str, episodes: dict[str, int]) -> str:
    """The config ``text`` with its ``hrtf`` and ``episodes`` lines replaced (each must occur
    once)."""
    eps = ", ".join(f"{k} = {v}" for k, v in episodes.items())
    for pattern, line in ((r"^hrtf\s*=.*$", f'hrtf = "{head}"'),
                          (r"^episodes\s*=.*$", f"episodes = {{ {eps} }}")):
        text, n = re.subn(pattern, line, text, flags=re.M)
        if n != 1:
            raise SystemExit(f"{pattern!r} occurs {n} times in the config, not once")
    return text


def build(config: Path, out: Path, workers: int) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "fallgen", "build", "-c", str(config), "--out",
                    str(out), "--workers", str(workers)], check=True)
    return time.perf_counter() - t


def _key(row: dict) -> tuple:
    return (row["event_id"], round(row["spawn_x"], 6), round(row["spawn_y"], 6),
            row["spawn_heading"])


def _pick(scores: dict) -> dict:
    out = {k: scores[k] for k in KEYS if k in scores}
    out["prior"] = {k: scores["prior"][k] for k in KEYS if k in scores["prior"]}
    out["by_room_kind"] = {kind: {k: v[k] for k in ("episodes",) + KEYS if k in v}
                           for kind, v in scores["by_room_kind"].items()}
    return out


def _paired(a: np.ndarray, b: np.ndarray, stat, seed: int) -> dict:
    """stat(a) - stat(b) over the same episodes, with a 95 % percentile bootstrap interval
    (``scipy.stats.bootstrap``, the episodes resampled in pairs)."""
    from scipy.stats import bootstrap

    diff = float(stat(a) - stat(b))
    if np.array_equal(a, b):  # no spread to resample
        return {"difference": diff, "ci95": [diff, diff]}
    ci = bootstrap((a, b), lambda x, y, axis=-1: stat(x, axis=axis) - stat(y, axis=axis),
                   paired=True, vectorized=True, n_resamples=BOOTSTRAP,
                   confidence_level=0.95, method="percentile",
                   rng=np.random.default_rng(seed)).confidence_interval
    return {"difference": diff, "ci95": [float(ci.low), float(ci.high)]}


def compare(dirs: dict[str, Path], seed: int, trees: int) -> dict:
    from fallgen.world.library import load_world

    world = load_world(None)
    sets = {h: Dataset(d) for h, d in dirs.items()}
    for h, ds in sets.items():
        if (ds.hrtf or "").split(":")[0] != h:
            raise SystemExit(f"{dirs[h]}: heard with {ds.hrtf}, expected {h}")
    tests = {h: {_key(r): r for r in ds.rows("test")} for h, ds in sets.items()}
    common = sorted(set.intersection(*(set(t) for t in tests.values())))
    if not common:
        raise SystemExit("the builds share no test episode")
    out: dict = {"common_test_episodes": len(common), "heads": {}}
    errs: dict[str, np.ndarray] = {}
    flips: dict[str, np.ndarray] = {}
    for h, ds in sets.items():
        train = ds.rows("train")
        t = time.perf_counter()
        model = AudioModel.train(ds, train, seed=seed, trees=trees)
        rows = [tests[h][k] for k in common]
        X = feature_matrix(ds, rows, dataset_features(ds, rows))
        scores, _ = evaluate(model, ds, rows, train, world, X=X)
        est = model.predict_matrix(X)[2][:, 0]
        true = np.array([relative_place(r)[0] for r in rows])
        errs[h] = angle_error_deg(est, true)
        wrong, counted = front_back_flips(est, true)
        flips[h] = wrong.astype(float)
        kept = counted  # the same sources in both builds
        out["heads"][h] = dict(_pick(scores), train_episodes=len(train),
                               front_back_confusions=[int((wrong & counted).sum()),
                                                      int(counted.sum())],
                               model_s=round(time.perf_counter() - t, 1))
    a, b = HEADS
    out["sadie_minus_sphere"] = {
        "azimuth_median_error_deg": _paired(errs[a], errs[b], np.median, seed),
        "front_back_confusion_rate": _paired(flips[a][kept], flips[b][kept], np.mean, seed),
    }
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", type=Path, default=REPO / "configs" / "full.toml")
    ap.add_argument("--train", type=int, default=1500)
    ap.add_argument("--validation", type=int, default=100)
    ap.add_argument("--test", type=int, default=500)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--work", type=Path, default=REPO / "build" / "hrtf")
    ap.add_argument("--trees", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    episodes = {"train": args.train, "validation": args.validation, "test": args.test}
    text = args.config.read_text()
    dirs, wall = {}, {}
    for head in HEADS:
        out = args.work / head
        cfg = args.work / f"{head}.toml"
        cfg.parent.mkdir(parents=True, exist_ok=True)
        cfg.write_text(head_config(text, head, episodes))
        first = args.work / HEADS[0] / "rehearsal"
        if head != HEADS[0] and first.is_dir() and not (out / "rehearsal").exists():
            shutil.copytree(first, out / "rehearsal")  # the rehearsal does not hear the head
        wall[head] = round(build(cfg, out, args.workers) / 60, 2)
        dirs[head] = out
    result = {"bench": "hrtf_compare", "config": str(args.config.relative_to(REPO))
              if args.config.is_relative_to(REPO) else str(args.config),
              "episodes": episodes, "seed": args.seed, "trees": args.trees,
              "build_min": wall, **compare(dirs, args.seed, args.trees)}
    line = json.dumps(result, indent=1)
    print(line)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(line + "\n")


if __name__ == "__main__":
    main()
