"""The paper-size build itself, timed on this machine. Prints one JSON line.

    python bench/full_build.py [--config configs/full.toml] [--workers N] [--out DIR] [--keep]
                               [--one-worker]

Runs what ``make dataset`` runs, as the library calls behind ``fallgen build`` (rehearsal of
every room variant, then every shard: modal models the events need and are not cached yet are
solved first, inside the generation phase's time, and counted), into a fresh ``--out`` (default: a
directory under ``build/``, removed afterwards unless ``--keep``), then validates it. Reports:

- the wall time of each phase and of the whole build, against the 10-minute goal and the
  original's ~8 hours;
- the CPU time (user + system) of this process and of the workers, and each worker's peak
  resident memory (goal < 1 GB), phase by phase;
- how many modal models had to be solved (0: the cache was warm);
- the episodes, bytes, skip counts and the time by stage;
- with ``--one-worker``, the generation phase made again by one process from the same
  rehearsal (the build's own throughput with 1 worker against ``--workers``: goal >= 1.8x with
  2), and whether its data and media files are the same bytes;
- a fingerprint of the files (sha256 over the manifest's per-file hashes of the data, media
  and rehearsal files): two builds of the same code and settings have the same fingerprint,
  whatever the machine's speed or the worker count;
- the machine (CPU model, cores) and the versions: this VM's speed drifts by a third within
  minutes and differs more between days, so a time means little without them.

This takes a while (44 minutes on the 2-core development VM at its last run, twice that with
``--one-worker``) and ~6 GB of disk (12 GB with ``--one-worker``); it is not part of ``make
bench`` (``make bench-full`` runs it with ``--one-worker`` and ``bench/report.py`` merges it).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import resource
import shutil
import sys
import time
from collections import Counter
from pathlib import Path

from provenance import cpu_model  # bench/, beside this script

REPO = Path(__file__).resolve().parents[1]
ORIGINAL_S = 8 * 3600.0
GOAL_S = 10 * 60.0
GOAL_WORKER_MB = 1024.0


def _cpu(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def file_hashes(manifest: dict, dirs=("data", "media", "rehearsal")) -> dict[str, str]:
    """The manifest's sha256 of every file in ``dirs``, by path."""
    return {k: v["sha256"] for k, v in manifest["files"].items() if k.split("/", 1)[0] in dirs}


def fingerprint(manifest: dict) -> str:
    """sha256 over the sorted (path, sha256) of the data, media and rehearsal files."""
    h = hashlib.sha256()
    for k, sha in sorted(file_hashes(manifest).items()):
        h.update(f"{k} {sha}\n".encode())
    return h.hexdigest()


def _workers(usages) -> list[dict]:
    from fallgen.pipeline.executor import per_process

    return [{"peak_rss_mb": round(u.peak_rss_mb), "cpu_s": round(u.cpu_s, 1)}
            for u in per_process(usages) if u.pid != os.getpid()]


def _one_worker(world, cfg, out: Path, t_workers: float, manifest: dict) -> dict:
    """The generation phase again, in this process alone, from ``out``'s rehearsal."""
    from fallgen.dataset.manifest import read_manifest
    from fallgen.pipeline.generate import generate

    one = out.with_name(out.name + "-1w")
    if one.exists():
        shutil.rmtree(one)
    one.mkdir(parents=True)
    (one / "rehearsal").symlink_to(out / "rehearsal")
    t = time.perf_counter()
    shards = generate(world, cfg, one, workers=1)
    wall = time.perf_counter() - t
    mine = file_hashes(read_manifest(one), ("data", "media"))
    theirs = file_hashes(manifest, ("data", "media"))
    shutil.rmtree(one)
    # this process made every shard (its peak also covers what it held before)
    return {"generate_min": round(wall / 60, 2), "shards": len(shards),
            "speedup_of_workers": round(wall / t_workers, 2),
            "same_bytes": bool(mine) and mine == theirs,
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--config", type=Path, default=REPO / "configs" / "full.toml")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--out", type=Path, default=REPO / "build" / "bench-full")
    ap.add_argument("--keep", action="store_true", help="keep the dataset it built")
    ap.add_argument("--one-worker", action="store_true",
                    help="then generate again with one process, for the speed-up of --workers")
    args = ap.parse_args()

    import fallgen  # noqa: F401  (pins BLAS and the rasteriser's threads before numpy/mujoco)
    import mujoco
    import numpy as np

    from fallgen.config import load_config
    from fallgen.dataset.manifest import read_manifest
    from fallgen.dataset.validate import validate
    from fallgen.physics.rehearse import rehearsal_dir, rehearse
    from fallgen.pipeline.generate import generate
    from fallgen.world.library import load_world

    cfg = load_config(args.config)
    out = args.out.resolve()
    if out.exists():
        shutil.rmtree(out)  # from scratch, as `make dataset` on a fresh machine
    report: dict = {
        "bench": "full_build", "config": str(args.config), "workers": args.workers,
        "machine": {"node": platform.node(), "cpu": cpu_model(), "cores": os.cpu_count(),
                    "python": platform.python_version()},
        "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__}}
    t_start = time.perf_counter()
    cpu_self, cpu_children = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN)
    world = load_world()
    vids = [v.id for v in world.variants(cfg.rehearse.rooms)]
    t0 = time.perf_counter()
    stats = rehearse(world, cfg, vids, out=rehearsal_dir(cfg, out), workers=args.workers)
    t1 = time.perf_counter()
    solved: list[str] = []  # modal models the events need and the cache lacks: solved first
    shards = generate(world, cfg, out, workers=args.workers, modes_progress=solved.append)
    t2 = time.perf_counter()
    wall = t2 - t_start
    cpu = (_cpu(resource.RUSAGE_SELF) - cpu_self) + (_cpu(resource.RUSAGE_CHILDREN)
                                                     - cpu_children)
    problems = validate(out)
    manifest = read_manifest(out)
    skips: Counter = Counter()
    stages: Counter = Counter()
    for r in shards:
        skips.update(r.skips)
        stages.update(r.timings_s)
    size = sum(p.stat().st_size for d in ("data", "media") for p in (out / d).glob("*"))
    made = sum(manifest["episodes"].values())
    rehearse_workers = _workers(s.usage for s in stats)
    generate_workers = _workers(r.usage for r in shards)
    peaks = [w["peak_rss_mb"] for w in rehearse_workers + generate_workers]
    report.update({
        "wall_min": {"total": round(wall / 60, 2), "rehearse": round((t1 - t0) / 60, 2),
                     "generate": round((t2 - t1) / 60, 2)},
        "goal_min": GOAL_S / 60, "meets_goal": wall < GOAL_S,
        "speedup_vs_original_8h": round(ORIGINAL_S / wall, 1),
        "cpu_s": round(cpu, 1), "cpu_use": round(cpu / wall, 2),
        "modal_models_solved": len(solved),
        "rehearsal": {"variants": len(stats), "trials": sum(s.trials for s in stats),
                      "kept": sum(s.reasons["kept"] for s in stats),
                      "workers": rehearse_workers},
        "generation": {"episodes": made, "shards": len(shards), "skips": dict(skips),
                       "stage_s": {k: round(v, 1) for k, v in stages.most_common()},
                       "workers": generate_workers},
        "peak_worker_mb": max(peaks) if peaks else None,
        "meets_worker_memory_goal": bool(peaks) and max(peaks) < GOAL_WORKER_MB,
        "main_process_peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "bytes": size, "bytes_per_episode": int(size / max(made, 1)),
        "valid": not problems, "problems": problems[:5],
        "fingerprint": fingerprint(manifest)})
    if args.one_worker:
        report["one_worker"] = _one_worker(world, cfg, out, t2 - t1, manifest)
    if not args.keep:
        shutil.rmtree(out)
    print(json.dumps(report))
    sys.exit(0 if not problems else 1)


if __name__ == "__main__":
    main()
