"""bench/appearance.py (part of ``make bench``): flat, textured and randomised views of the same
poses, their detail share and per-view costs as one JSON line, which bench/report.py puts in
the headline."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_appearance_bench_reports_detail_and_costs(tmp_path):
    r = subprocess.run([sys.executable, str(REPO / "bench" / "appearance.py"), "--views", "3"],
                       capture_output=True, text=True, env=dict(os.environ), cwd=REPO)
    assert r.returncode == 0, r.stderr[-2000:]
    line = r.stdout.strip().splitlines()[-1]
    rep = json.loads(line)
    assert rep["views"] == 3 and set(rep) >= {"flat", "textured", "randomised"}
    for tag in ("flat", "textured", "randomised"):
        assert all(rep[tag][k] > 0 for k in ("rgb_ms_per_view", "depth_seg_ms_per_view",
                                             "scene_and_camera_ms")), rep[tag]
    assert rep["textured"]["detail_mean"] > rep["flat"]["detail_mean"]
    (tmp_path / "bench-appearance.json").write_text(line + "\n")
    out = subprocess.run([sys.executable, str(REPO / "bench" / "report.py"), str(tmp_path)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    head = json.loads((tmp_path / "bench.json").read_text())["headline"]
    assert head["view_textured_detail_mean"] == rep["textured"]["detail_mean"]
    assert head["view_flat_depth_seg_ms_per_view"] == rep["flat"]["depth_seg_ms_per_view"]
