"""Merge the JSON lines the benchmarks wrote (build/bench-*.json) into one report,
build/bench.json, with the headline ratios on top. Used by `make bench`.

    python bench/report.py build
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def _last_json(path: Path) -> dict | None:
    for line in reversed(path.read_text().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            return json.loads(line)
    return None


def main() -> None:
    d = Path(sys.argv[1] if len(sys.argv) > 1 else "build")
    parts = {p.stem.removeprefix("bench-"): _last_json(p)
             for p in sorted(d.glob("bench-*.json"))
             if not p.name.endswith(".provenance.json")}  # what made them: provenance.py
    parts = {k: v for k, v in parts.items() if v}
    head: dict = {}
    b = parts.get("build", {})
    if b:
        full = b["full_build_extrapolated"]
        gen = b["generate"]
        head["full_build_min_extrapolated"] = full["total_min"]
        head["full_build_goal_min"] = full["goal_min"]
        head["speedup_vs_original_8h"] = full["speedup_vs_original_8h"]
        head["generate_speedup_workers"] = gen["speedup"]
        head["generate_same_bytes_1_vs_n_workers"] = gen["same_bytes"]
        head["bytes_per_episode"] = gen["bytes_per_episode"]
    f = parts.get("full", {})
    if f:  # `make bench-full`: the paper-size build itself, measured
        head["full_build_min_measured"] = f["wall_min"]["total"]
        head["full_build_meets_goal"] = f["meets_goal"]
        head["full_build_peak_worker_mb"] = f["peak_worker_mb"]
        head["full_build_machine"] = f["machine"]["cpu"]
        if "one_worker" in f:
            head["full_build_generate_speedup_workers"] = f["one_worker"]["speedup_of_workers"]
            head["full_build_same_bytes_1_vs_n_workers"] = f["one_worker"]["same_bytes"]
    e = parts.get("env", {})
    if e:  # the benchmark's environment
        head["env_steps_per_s_rgb_depth"] = e["rgb_depth"]["steps_per_s"]
        head["env_steps_per_s_rgb_depth_no_cache"] = e["rgb_depth_no_cache"]["steps_per_s"]
        head["env_vector_speedup_2_workers"] = e["vector"]["speedup"]
        head["env_vector_speedup_2_workers_lockstep"] = e["vector_lockstep"]["speedup"]
        head["env_peak_worker_mb"] = e["vector"]["peak_worker_mb"]
        head["env_ratio_vs_tdw_published"] = e["ratio_vs_tdw_published"]
    a = parts.get("appearance", {})
    if a:  # how the rooms look: flat colours against textures, per 300 px view
        for tag in ("flat", "textured"):
            for k in ("detail_mean", "detail_p10", "rgb_ms_per_view", "depth_seg_ms_per_view"):
                if k in a.get(tag, {}):
                    head[f"view_{tag}_{k}"] = a[tag][k]
    for name in ("impact", "room"):
        r = parts.get(name, {})
        head.update({f"{name}_{k}": v for k, v in r.items()
                     if "ratio" in k or k.startswith("speedup")})
    report = {"headline": head, "benchmarks": parts}
    out = d / "bench.json"
    out.write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps(head, indent=1))
    print(f"-> {out}")


if __name__ == "__main__":
    main()
