"""Rehearsal speed: trials per second on one core, and its cost relative to raw MuJoCo stepping
of the same drops (compiled model, initial state set, ``mj_step`` for the same number of steps,
nothing else). Prints one JSON line.

    python bench/rehearse_bench.py [--variant ID] [--trials-per-zone N]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import mujoco

from fallgen.config import RehearseConfig
from fallgen.physics.drop import PHYSICS, _instance, _scene_objects, run_trial
from fallgen.world.library import load_world
from fallgen.world.scene import build_scene


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="kitchen_galley-l1-m1")
    ap.add_argument("--trials-per-zone", type=int, default=2)
    args = ap.parse_args()
    world = load_world()
    for c in world.categories:  # build every geometry once, outside the timing
        for v in c.variants:
            world.categories.geometry(c.id, v.name)
    variant = world.variant(args.variant)
    cfg = RehearseConfig()
    t0 = time.perf_counter()
    outcomes = [run_trial(world, variant, z, t, cfg, 1) for z in variant.zones
                for t in range(args.trials_per_zone)]
    t_rehearse = time.perf_counter() - t0
    kept = [o.event for o in outcomes if o.event is not None]
    # Raw stepping of the kept drops: compile, set the start state, step the same count.
    t_compile = t_step = 0.0
    steps = 0
    for e in kept:
        objs = _scene_objects(world, _instance(world, e.target), e.start_pos, e.start_quat,
                              e.distractors, e.occluders)
        t = time.perf_counter()
        scene = build_scene(variant, world.materials, objs, settings=PHYSICS)
        t_compile += time.perf_counter() - t
        m = scene.model
        d = mujoco.MjData(m)
        adr = m.jnt_dofadr[m.body_jntadr[scene.object_body["target"]]]
        d.qvel[adr:adr + 3], d.qvel[adr + 3:adr + 6] = e.start_linvel, e.start_angvel
        t = time.perf_counter()
        mujoco.mj_step(m, d, nstep=e.steps)
        t_step += time.perf_counter() - t
        steps += e.steps
    n = len(outcomes)
    # Rehearsal cost per kept event vs raw stepping per kept event (the bench goal: <= 1.5x).
    per_kept = t_rehearse / max(len(kept), 1)
    raw = t_step / max(len(kept), 1)
    print(json.dumps({
        "bench": "rehearse", "machine": platform.node(), "mujoco": mujoco.__version__,
        "variant": args.variant, "trials": n, "kept": len(kept),
        "trials_per_s": round(n / t_rehearse, 2),
        "kept_per_s": round(len(kept) / t_rehearse, 2),
        "raw_step_us": round(1e6 * t_step / max(steps, 1), 2),
        "raw_s_per_drop": round(raw, 4),
        "compile_s_per_drop": round(t_compile / max(len(kept), 1), 4),
        "rehearsal_over_raw_stepping": round(per_kept / raw, 2) if raw else None,
        "rehearsal_over_raw_stepping_plus_compile": round(
            per_kept / (raw + t_compile / max(len(kept), 1)), 2) if raw else None,
    }))


if __name__ == "__main__":
    main()
