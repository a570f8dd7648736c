"""Generation speed: episodes per second on one core, split by stage. Prints one JSON line.

    python bench/generate_bench.py [--variant ID] [--episodes N]

Events: the first kept rehearsal trial of each zone of one variant. Every episode is made once
to load the modal models (a full build precomputes them with ``fallgen assets modes``), then
made again timed, stage by stage (maps = scene compile + occupancy, spawn, replay, audio, render,
planning), and the episodes are written as one shard (writing).
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from collections import Counter
from pathlib import Path

import fallgen  # noqa: F401  (pins BLAS threads and the GL backend before numpy/mujoco load)
from fallgen.audio.hrtf import spherical_head
from fallgen.audio.mix import Binaural
from fallgen.config import RehearseConfig
from fallgen.dataset.writer import row_of, write_shard
from fallgen.physics.drop import run_trial
from fallgen.pipeline.episode import EpisodeMaker, Skip
from fallgen.world.library import load_world


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="kitchen_galley-l1-m1")
    ap.add_argument("--episodes", type=int, default=12)
    args = ap.parse_args()
    world = load_world()
    v = world.variant(args.variant)
    events = []
    for t in range(3):
        for z in v.zones:
            o = run_trial(world, v, z, t, RehearseConfig(), 1)
            if o.event is not None and len(events) < args.episodes:
                events.append(o.event)
    maker = EpisodeMaker(world, Binaural(spherical_head()))
    skips: Counter = Counter()
    for i, e in enumerate(events):  # warm: modal models loaded or solved
        try:
            maker.make(i, e, 1)
        except Skip as s:
            skips[s.reason] += 1
    stages: Counter = Counter()
    made = []
    t0 = time.perf_counter()
    for i, e in enumerate(events):
        try:
            ep = maker.make(i, e, 1)
        except Skip:
            continue
        made.append(ep)
        stages.update(ep.timings_s)
    t_make = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        rows = [row_of(ep, "train", "media/x.h5", k, 1) for k, ep in enumerate(made)]
        data, media = write_shard(Path(d), "train", 0, 1, made, rows, maker.labels)
        stages["writing"] = time.perf_counter() - t
        size = data.stat().st_size + media.stat().st_size
    total = t_make + stages["writing"]
    n = max(len(made), 1)
    print(json.dumps({
        "bench": "generate", "machine": platform.node(), "variant": args.variant,
        "episodes": len(made), "skipped": dict(skips),
        "episodes_per_s_per_core": round(len(made) / total, 2),
        "ms_per_episode": {k: round(1e3 * s / n, 1) for k, s in stages.most_common()},
        "bytes_per_episode": int(size / n)}))


if __name__ == "__main__":
    main()
