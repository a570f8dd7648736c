"""bench/env_bench.py on the tiny build: it runs, reports each measure, and its numbers are
consistent (a cache serves some steps; without one, none)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.xdist_group("tiny_build")
def test_env_bench_reports_rates_speedup_and_memory(tiny_build):
    base, _ = tiny_build
    r = subprocess.run([sys.executable, str(REPO / "bench" / "env_bench.py"), "--dataset",
                        str(base / "one"), "--steps", "120", "--vec-steps", "60",
                        "--repeats", "1"], capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 0, r.stderr[-2000:]
    rep = json.loads(r.stdout.strip().splitlines()[-1])
    for name in ("rgb_depth", "basic", "oracles"):
        assert rep[name]["steps_per_s"] > 0 and rep[name + "_no_cache"]["cache_served"] == 0
    assert 0 < rep["rgb_depth"]["cache_served"] < 1
    for key, mode in (("vector", "async"), ("vector_lockstep", "lockstep")):
        v = rep[key]
        assert v["mode"] == mode
        assert v["one_worker_steps_per_s"] > 0 and v["two_workers_steps_per_s"] > 0
        assert 50 < v["peak_worker_mb"] < 4096
        assert all(0 < b <= 1.2 for b in v["two_workers_busy"]) and 0 < v["main_busy"] <= 1.2
    assert len(rep["ratio_vs_tdw_published"]) == 2 and isinstance(rep["meets_goals"], bool)
