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


#: The environment's goals (docs/performance.md; bench/env_bench.py's docstring): rgb + depth
#: at >= 100 steps a second on one core, 2 workers >= 1.8x one, a worker under 1 GB
GOAL_STEPS_PER_S, GOAL_SPEEDUP, GOAL_WORKER_MB = 100.0, 1.8, 1024.0
#: TDW's Magnebot environment: ~4-7 actions a second (shared/design/benchmark.md, published)
TDW_ACTIONS_PER_S = (4.0, 7.0)


def _check_env_report(rep: dict) -> None:
    """The report's numbers agree with each other and with the goals, recomputed here: a
    rate is the inverse of the time per step (both rounded), a speed-up the ratio of the two
    rates, the verdict the goals applied to the numbers, the ratio to TDW the rate over its
    published 7 and 4 actions a second."""
    for name in ("rgb_depth", "basic", "oracles"):
        for r in (rep[name], rep[name + "_no_cache"]):
            assert r["steps_per_s"] == pytest.approx(1000 / r["ms_per_step"], rel=0.01), r
            assert r["steps_per_s_with_resets"] <= r["steps_per_s"], r
        assert rep[name + "_no_cache"]["cache_served"] == 0
        assert 0 < rep[name]["cache_served"] < 1
    for key, mode in (("vector", "async"), ("vector_lockstep", "lockstep")):
        v = rep[key]
        assert v["mode"] == mode
        assert v["speedup"] == pytest.approx(v["two_workers_steps_per_s"]
                                             / v["one_worker_steps_per_s"], abs=0.011), v
        assert min(v["pairs"]) - 0.011 <= v["speedup"] <= max(v["pairs"]) + 0.011, v
        assert 50 < v["peak_worker_mb"] < 4096
        assert all(0 < b <= 1.2 for b in v["two_workers_busy"]) and 0 < v["main_busy"] <= 1.2
    rate = rep["rgb_depth"]["steps_per_s"]
    assert rep["meets_goals"] == (rate >= GOAL_STEPS_PER_S
                                  and rep["vector"]["speedup"] >= GOAL_SPEEDUP
                                  and rep["vector"]["peak_worker_mb"] < GOAL_WORKER_MB)
    assert rep["ratio_vs_tdw_published"] == pytest.approx(
        [rate / TDW_ACTIONS_PER_S[1], rate / TDW_ACTIONS_PER_S[0]], abs=0.051)


@pytest.mark.xdist_group("tiny_build")
def test_env_bench_reports_rates_speedup_and_memory(tiny_build):
    base, _ = tiny_build
    r = subprocess.run([sys.executable, str(REPO / "bench" / "env_bench.py"), "--dataset",
                        str(base / "one"), "--steps", "120", "--vec-steps", "60",
                        "--repeats", "1"], capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 0, r.stderr[-2000:]
    rep = json.loads(r.stdout.strip().splitlines()[-1])
    _check_env_report(rep)
    # the check rejects a flipped verdict, a speed-up that is not the rates' ratio, a rate
    # that is not the time per step's inverse and a ratio to TDW's other figure
    for path, value in ((("meets_goals",), not rep["meets_goals"]),
                        (("vector", "speedup"), rep["vector"]["speedup"] + 0.5),
                        (("rgb_depth", "steps_per_s"), rep["rgb_depth"]["steps_per_s"] * 1.5),
                        (("ratio_vs_tdw_published",), [x * 7 / 4 for x in
                                                       rep["ratio_vs_tdw_published"]])):
        bad = json.loads(json.dumps(rep))
        node = bad
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
        with pytest.raises(AssertionError):
            _check_env_report(bad)
