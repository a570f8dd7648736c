"""bench/full_build.py (``make bench-full``) on a tiny config: it builds from scratch with a
pool of workers, validates, reports every worker's memory and the files' fingerprint, which is
that of the same config built by one process (the same bytes whatever the worker count), and
with ``--one-worker`` makes the generation again in one process and compares the bytes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.xdist_group("tiny_build")
def test_full_build_bench_reports_a_valid_build_and_its_fingerprint(tiny_build, tmp_path):
    sys.path.insert(0, str(REPO / "bench"))
    try:
        from full_build import fingerprint
    finally:
        sys.path.remove(str(REPO / "bench"))
    from fallgen.dataset.manifest import read_manifest

    base, cfg = tiny_build
    out = tmp_path / "b"
    r = subprocess.run([sys.executable, str(REPO / "bench" / "full_build.py"), "--config",
                        str(cfg), "--workers", "2", "--out", str(out), "--keep", "--one-worker"],
                       capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 0, r.stderr[-2000:]
    rep = json.loads(r.stdout.strip().splitlines()[-1])
    assert rep["valid"] and rep["generation"]["episodes"] == 6
    assert rep["fingerprint"] == fingerprint(read_manifest(base / "one"))
    assert rep["fingerprint"] == fingerprint(read_manifest(out))
    # the pool's workers (two at most; how it deals the units is its own business), each with
    # its peak
    assert all(1 <= len(rep[ph]["workers"]) <= 2 for ph in ("rehearsal", "generation"))
    assert all(100 < w["peak_rss_mb"] < 4096 for ph in ("rehearsal", "generation")
               for w in rep[ph]["workers"])
    assert rep["peak_worker_mb"] == max(w["peak_rss_mb"] for ph in ("rehearsal", "generation")
                                        for w in rep[ph]["workers"])
    assert rep["wall_min"]["total"] > 0 and rep["meets_goal"]
    # the generation again in one process: the same data and media files
    assert rep["one_worker"]["same_bytes"] and rep["one_worker"]["speedup_of_workers"] > 0
