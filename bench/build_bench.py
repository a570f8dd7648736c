"""Whole-build speed on this machine, extrapolated to the paper-size build. Prints one JSON line.

    python bench/build_bench.py [--variants 4] [--workers 2] [--shards-per-worker 2]

A slice of ``configs/full.toml`` (the same rehearsal and generation settings) over ``--variants``
room variants (half kitchens, half study rooms, spread over the library), built with the real
command line in fresh processes:

1. ``fallgen rehearse`` with ``--workers`` processes: seconds per variant -> 64 variants;
2. ``fallgen generate`` of ``--workers`` x ``--shards-per-worker`` shards of the full build's
   size (250 episodes, one room kind each, as every shard of the full build), with 1 worker and
   with ``--workers`` (modal models warm: a tiny first run loads or solves the ones the events
   need, and the cache files are read once, so neither timed run meets a cold disk): episodes
   per second, the speed-up of ``--workers`` over 1 (goal >= 1.8x with 2), the same bytes from
   both, and the peak resident memory of the largest process (goal < 1 GB per worker). The
   runs alternate, 1 worker then ``--workers`` then ``--workers`` then 1 and so on
   (``--repeats`` pairs): the development VM's speed drifts by up to a third within minutes,
   and the speed-up is the ratio of the summed times (each pair's ratio is reported too). The
   shard is the unit of work: smaller ones would weigh a worker's fixed costs (its start, its
   first loads of every variant's models) more than a full build, where each worker makes 16.
   Two shards per worker by default, half of them kitchens: a kitchen shard costs ~35 % more
   than a study room's (longer searches for the object), so with one shard per worker the
   time with 2 workers is the kitchen shard's, and the ratio measures the imbalance of two
   shards rather than a build's throughput (a full build deals its 32 shards to the workers
   as they finish: its workers were idle ~3 % of its time). The 2-worker time still holds
   the workers' start (imports, world, first loads: ~2 s of ~47 s on the development VM),
   which a full build pays once for 16 shards a worker, so this ratio reads lower than a
   build's: 1.75x here against 2.06x for the full build's generation phase (684 s with 1
   worker, 332 s with 2, the same files; ``bench/full_build.py --one-worker``);
3. the extrapolated full build (64 variants, 8000 episodes) = rehearsal + generation, against the
   original's ~8 hours (ThreeDWorld, reported in the paper's repository; not runnable here).

Modal models are solved once per machine (``fallgen assets modes``) and cached; the cold cost of
that step is timed separately with ``--cold-modes`` (slow).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from full_build import GOAL_S  # bench/, beside this script: the paper-size build's goal

REPO = Path(__file__).resolve().parents[1]
ORIGINAL_S = 8 * 3600.0
FULL_VARIANTS, FULL_EPISODES = 64, 8000


def _measure(cmd: list[str], env: dict) -> tuple[float, float]:
    """(wall seconds, peak RSS in MB of the largest process of the command's tree)."""
    probe = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
             "r = subprocess.run(sys.argv[1:]); dt = time.perf_counter() - t; "
             "print('BENCH', dt, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
             "sys.exit(r.returncode)")
    out = subprocess.run([sys.executable, "-c", probe, *cmd], env=env, capture_output=True,
                         text=True)
    if out.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{out.stderr[-3000:]}")
    m = re.search(r"BENCH (\S+) (\d+)", out.stdout)
    return float(m[1]), int(m[2]) / 1024


def _digest(root: Path) -> str:
    h = hashlib.sha256()
    for d in ("data", "media"):
        for p in sorted((root / d).glob("*")):
            h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()


def _rooms(n: int) -> list[str]:
    from fallgen.world.library import load_world

    vs = load_world().variants("*")
    out = []
    for kind in ("kitchen", "study"):
        mine = [v.id for v in vs if v.kind == kind]
        k = max(1, n // 2)
        out += [mine[i * len(mine) // k] for i in range(k)]
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", type=int, default=4)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--shards-per-worker", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=2,
                    help="pairs of generation runs (1 worker and --workers), alternating")
    ap.add_argument("--cold-modes", action="store_true",
                    help="also time `fallgen assets modes` into an empty cache")
    args = ap.parse_args()
    fallgen = [sys.executable, "-m", "fallgen"]
    env = dict(os.environ)
    rooms = _rooms(args.variants)
    full = (REPO / "configs" / "full.toml").read_text()
    per_shard = int(re.search(r"episodes_per_shard = (\d+)", full)[1])
    # as many shards of each room kind (the planner deals a split's episodes evenly to them)
    shards = 2 * math.ceil(args.workers * args.shards_per_worker / 2)
    episodes = shards * per_shard

    def sliced(n: int) -> str:
        return full.replace('rooms = "*"', f'rooms = "{",".join(rooms)}"').replace(
            "episodes = { train = 6000, validation = 1000, test = 1000 }",
            f"episodes = {{ train = {n}, validation = 0, test = 0 }}")

    report: dict = {"bench": "build", "machine": platform.node(), "cpus": os.cpu_count(),
                    "rooms": rooms, "episodes": episodes, "shards": shards,
                    "workers": args.workers}
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        cfg = d / "slice.toml"
        cfg.write_text(sliced(episodes).replace('out = "build/full"', f'out = "{d / "a"}"'))
        warm = d / "warm.toml"
        warm.write_text(sliced(2).replace('out = "build/full"', f'out = "{d / "w"}"'))
        t, rss = _measure(fallgen + ["rehearse", "-c", str(cfg), "--workers",
                                     str(args.workers)], env)
        report["rehearse"] = {"wall_s": round(t, 1), "s_per_variant": round(t / len(rooms), 2),
                              "peak_rss_mb": round(rss)}
        (d / "w").mkdir()
        os.symlink(d / "a" / "rehearsal", d / "w" / "rehearsal")
        # warm-up: solves and caches every modal model these events need (if one is missing),
        # then reads every cached model once (the page cache)
        _measure(fallgen + ["generate", "-c", str(warm), "--workers", str(args.workers)], env)
        from fallgen.audio.modes import default_cache_dir

        for p in default_cache_dir().glob("*.npz"):
            p.read_bytes()
        runs: dict[int, list[tuple[float, float, str]]] = {1: [], args.workers: []}
        for r in range(args.repeats):
            for w in ((1, args.workers) if r % 2 == 0 else (args.workers, 1)):
                out = d / f"g{r}-{w}"
                out.mkdir()
                os.symlink(d / "a" / "rehearsal", out / "rehearsal")
                t, rss = _measure(fallgen + ["generate", "-c", str(cfg), "--out", str(out),
                                             "--workers", str(w)], env)
                runs[w].append((t, rss, _digest(out)))
                if (w, r) != (1, 0):
                    shutil.rmtree(out / "data"), shutil.rmtree(out / "media")
        from fallgen.dataset.manifest import read_manifest

        first = d / "g0-1"
        made = sum(read_manifest(first)["episodes"].values())
        size = sum(p.stat().st_size for x in ("data", "media") for p in (first / x).glob("*"))
        t1 = sum(t for t, _, _ in runs[1])
        tn = sum(t for t, _, _ in runs[args.workers])
        report["generate"] = {
            "episodes_made": made,
            "one_worker": {"wall_s": [round(t, 1) for t, _, _ in runs[1]],
                           "episodes_per_s": round(made * args.repeats / t1, 3),
                           "peak_rss_mb": round(max(m for _, m, _ in runs[1]))},
            f"{args.workers}_workers": {
                "wall_s": [round(t, 1) for t, _, _ in runs[args.workers]],
                "episodes_per_s": round(made * args.repeats / tn, 3),
                "peak_rss_mb_largest_process": round(max(m for _, m, _ in runs[args.workers]))},
            "speedup": round(t1 / tn, 2),
            "speedup_per_pair": [round(a[0] / b[0], 2)
                                 for a, b in zip(runs[1], runs[args.workers])],
            "same_bytes": len({h for v in runs.values() for _, _, h in v}) == 1,
            "bytes_per_episode": int(size / max(made, 1))}
    if args.cold_modes:
        with tempfile.TemporaryDirectory() as c:
            t, _ = _measure(fallgen + ["assets", "modes", "--workers", str(args.workers)],
                            {**env, "FALLGEN_CACHE": c})
            report["modal_models_cold_s"] = round(t, 1)
    rehearse_full = report["rehearse"]["s_per_variant"] * FULL_VARIANTS
    gen_full = FULL_EPISODES / report["generate"][f"{args.workers}_workers"]["episodes_per_s"]
    total = rehearse_full + gen_full + report.get("modal_models_cold_s", 0.0)
    report["full_build_extrapolated"] = {
        "rehearse_min": round(rehearse_full / 60, 1), "generate_min": round(gen_full / 60, 1),
        "modal_models_min": round(report.get("modal_models_cold_s", 0.0) / 60, 1),
        "total_min": round(total / 60, 1), "goal_min": GOAL_S / 60,
        "speedup_vs_original_8h": round(ORIGINAL_S / total, 1)}
    print(json.dumps(report))


if __name__ == "__main__":
    main()
