"""How the rooms look: detail share and cost of 300 x 300 RGB views, flat colours
against textures and shadows, side by side on the same poses; a before/after PNG.

    python bench/appearance.py [--views 64] [--seed 0] [--png docs/appearance.png]

Poses: ``--views`` random free positions of the robot (clearance >= its radius, any of the
12 headings, tilt 0, as at step 0) over the 64 variants, drawn from ``--seed``; flat colours,
textured, and textured in a look of each view's own (appearance randomisation: its textures
drawn anew, so the scene's cost includes drawing them). Per view: the RGB pass, the depth and
segmentation pass, and making the scene and its camera. Detail share:
the share of pixels whose grey level varies by more than 3 (standard deviation) in a 5 x 5
window. Prints one JSON line.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

import fallgen  # noqa: E402,F401  (GL backend and BLAS threads before numpy / mujoco)
import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from fallgen.nav.agent import HEADINGS, AgentSpec, Pose  # noqa: E402
from fallgen.nav.occupancy import occupancy  # noqa: E402
from fallgen.vision.camera import EgoCamera  # noqa: E402
from fallgen.vision.gl import GLContext  # noqa: E402
from fallgen.vision.textures import detail_share  # noqa: E402
from fallgen.world.library import load_world  # noqa: E402
from fallgen.world.scene import LOOK, PhysicsSettings, build_scene  # noqa: E402

FLAT = PhysicsSettings(collision_meshes=False)
#: the before/after pictures: (variant, pose)
SHOWN = [("kitchen_dining-l1-m2", Pose(1.6, 1.2, 1, 0)),
         ("study_lounge-l1-m1", Pose(4.3, 3.6, 8, 0))]


def _free_poses(world, rng: np.random.Generator, n: int) -> list[tuple[str, Pose]]:
    variants = world.variants()
    radius = AgentSpec().radius_m
    out = []
    for k in range(n):
        v = variants[int(rng.integers(len(variants)))]
        scene = build_scene(v, world.materials, settings=FLAT)
        grid = occupancy(scene)
        free = np.argwhere(grid.clearance >= radius)
        i, j = free[int(rng.integers(len(free)))]
        r = grid.resolution
        out.append((v.id, Pose(float((i + 0.5) * r), float((j + 0.5) * r),
                               int(rng.integers(HEADINGS)), 0)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--png", type=Path, default=None)
    args = ap.parse_args()
    world = load_world(REPO)
    poses = _free_poses(world, np.random.default_rng(args.seed), args.views)
    ctx = GLContext(300)
    result: dict[str, dict] = {}
    for tag, settings in (("flat", FLAT), ("textured", LOOK), ("randomised", None)):
        shares, render_s, scene_s, depth_s = [], 0.0, 0.0, 0.0
        for k, (vid, pose) in enumerate(poses):
            t0 = time.perf_counter()
            look = settings or dataclasses.replace(LOOK, look_seed=args.seed * 1000 + k)
            scene = build_scene(world.variant(vid), world.materials, settings=look)
            d = scene.data()
            mujoco.mj_forward(scene.model, d)
            cam = EgoCamera(scene, context=ctx)
            t1 = time.perf_counter()
            rgb = cam.render(d, pose, "rgb").rgb
            t2 = time.perf_counter()
            cam.render(d, pose, "depth")  # depth and segmentation: one pass
            depth_s += time.perf_counter() - t2
            cam.close()
            shares.append(detail_share(rgb))
            render_s += t2 - t1
            scene_s += t1 - t0
        s = np.array(shares)
        result[tag] = {"detail_mean": round(float(s.mean()), 3),
                       "detail_p10": round(float(np.percentile(s, 10)), 3),
                       "rgb_ms_per_view": round(1000 * render_s / len(poses), 1),
                       "depth_seg_ms_per_view": round(1000 * depth_s / len(poses), 1),
                       "scene_and_camera_ms": round(1000 * scene_s / len(poses), 1)}
    if args.png is not None:
        rows = []
        for vid, pose in SHOWN:
            pair = []
            for settings in (FLAT, LOOK):
                scene = build_scene(world.variant(vid), world.materials, settings=settings)
                d = scene.data()
                mujoco.mj_forward(scene.model, d)
                cam = EgoCamera(scene, context=ctx)
                pair.append(cam.render(d, pose, "rgb").rgb)
                cam.close()
            rows.append(np.hstack(pair))
        args.png.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(args.png), cv2.cvtColor(np.vstack(rows), cv2.COLOR_RGB2BGR))
    ctx.close()
    print(json.dumps({"views": len(poses), "seed": args.seed, **result}))


if __name__ == "__main__":
    main()
