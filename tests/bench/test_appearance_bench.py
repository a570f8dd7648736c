"""bench/appearance.py (part of ``make bench``): flat, textured and randomised views of the same
poses, their detail share and per-view costs as one JSON line, which bench/report.py puts in
the headline."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def _detail_share(rgb: np.ndarray) -> float:
    """The detail share of a view, written out here: the share of pixels whose grey level
    (ITU-R BT.601 luma) has a standard deviation above 3 in its 5 x 5 neighbourhood (edges
    mirrored)."""
    from scipy.ndimage import uniform_filter

    g = np.round(rgb.astype(float) @ np.array([0.299, 0.587, 0.114]))
    mu = uniform_filter(g, 5, mode="mirror")
    var = uniform_filter(g * g, 5, mode="mirror") - mu * mu
    return float((np.sqrt(np.maximum(var, 0.0)) > 3.0).mean())


def _views_detail(views: int, seed: int) -> dict[str, float]:
    """The mean detail share of the bench's poses (its own pose draw), flat and textured,
    rendered here."""
    import importlib.util

    import mujoco

    from fallgen.vision.camera import EgoCamera
    from fallgen.world.library import load_world
    from fallgen.world.scene import LOOK, build_scene

    spec = importlib.util.spec_from_file_location("appearance_bench",
                                                  REPO / "bench" / "appearance.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    world = load_world(REPO)
    poses = bench._free_poses(world, np.random.default_rng(seed), views)
    out = {}
    for tag, settings in (("flat", bench.FLAT), ("textured", LOOK)):
        shares = []
        for vid, pose in poses:
            scene = build_scene(world.variant(vid), world.materials, settings=settings)
            d = scene.data()
            mujoco.mj_forward(scene.model, d)
            cam = EgoCamera(scene)
            try:
                shares.append(_detail_share(cam.render(d, pose, "rgb").rgb))
            finally:
                cam.close()
        out[tag] = float(np.mean(shares))
    return out


def _check_appearance_report(rep: dict, detail: dict[str, float], wall_s: float) -> None:
    """The bench's detail shares are those of its views rendered and measured here (its
    rounding to 0.001, the luma's rounding), and its per-view costs fit in the time the run
    took."""
    for tag, want in detail.items():
        assert rep[tag]["detail_mean"] == pytest.approx(want, abs=0.005), (tag, want)
    spent = sum(rep[tag][k] for tag in ("flat", "textured", "randomised")
                for k in ("rgb_ms_per_view", "depth_seg_ms_per_view", "scene_and_camera_ms"))
    assert 0 < spent * rep["views"] / 1000 < wall_s, (spent, wall_s)
    assert all(rep[tag][k] > 0 for tag in ("flat", "textured", "randomised")
               for k in ("rgb_ms_per_view", "depth_seg_ms_per_view", "scene_and_camera_ms"))


def test_appearance_bench_reports_detail_and_costs(tmp_path):
    t = time.perf_counter()
    r = subprocess.run([sys.executable, str(REPO / "bench" / "appearance.py"), "--views", "3"],
                       capture_output=True, text=True, env=dict(os.environ), cwd=REPO)
    wall = time.perf_counter() - t
    assert r.returncode == 0, r.stderr[-2000:]
    line = r.stdout.strip().splitlines()[-1]
    rep = json.loads(line)
    assert rep["views"] == 3 and rep["seed"] == 0
    assert set(rep) >= {"flat", "textured", "randomised"}
    detail = _views_detail(3, 0)
    _check_appearance_report(rep, detail, wall)
    assert rep["textured"]["detail_mean"] > rep["flat"]["detail_mean"]
    # the check rejects swapped detail shares and costs longer than the run
    bad = json.loads(line)
    bad["flat"]["detail_mean"], bad["textured"]["detail_mean"] = \
        rep["textured"]["detail_mean"], rep["flat"]["detail_mean"]
    with pytest.raises(AssertionError):
        _check_appearance_report(bad, detail, wall)
    bad = json.loads(line)
    bad["flat"]["rgb_ms_per_view"] = 1000 * wall
    with pytest.raises(AssertionError):
        _check_appearance_report(bad, detail, wall)
    (tmp_path / "bench-appearance.json").write_text(line + "\n")
    out = subprocess.run([sys.executable, str(REPO / "bench" / "report.py"), str(tmp_path)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    head = json.loads((tmp_path / "bench.json").read_text())["headline"]
    assert head["view_textured_detail_mean"] == rep["textured"]["detail_mean"]
    assert head["view_flat_depth_seg_ms_per_view"] == rep["flat"]["depth_seg_ms_per_view"]
