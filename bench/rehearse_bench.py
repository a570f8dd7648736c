"""Rehearsal speed: trials per second on one core, and its cost relative to raw MuJoCo stepping
of the same drops. Prints one JSON line.

"Raw stepping" = compile nothing, set the start state, ``mj_step`` the same number of steps in
one C call, nothing else. Two ratios:

- ``over_raw_all_drops``: the whole rehearsal (draws, distractor settling, compiles, settle
  checks, contact recording, rejected trials) over raw stepping of every target drop it ran,
  kept or not (the same drops);
- ``over_raw_kept_drops``: the same cost per kept event over raw stepping of the kept drops only
  (what an event costs compared with simulating just it).

    python bench/rehearse_bench.py [--variant ID] [--trials-per-zone N]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import mujoco

import fallgen.physics.drop as drop
from fallgen.config import RehearseConfig
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

    drops = []  # (objects, linvel, angvel, steps of the first pass, kept?)
    simulate = drop._simulate

    def spy(world_, variant_, objs, linvel, angvel, criteria, max_steps=None, **kw):
        out = simulate(world_, variant_, objs, linvel, angvel, criteria, max_steps, **kw)
        drops.append([objs, linvel, angvel, out[0].steps, False])
        return out

    drop._simulate = spy
    t0 = time.perf_counter()
    outcomes = []
    for z in variant.zones:
        fits = drop.zone_fits(world, z)  # once per zone, as the rehearsal finds them
        for t in range(args.trials_per_zone):
            o = drop.run_trial(world, variant, z, t, cfg, 1, fits)
            if o.event is not None:
                drops[-1][4] = True
            outcomes.append(o)
    t_rehearse = time.perf_counter() - t0
    drop._simulate = simulate
    kept = sum(o.event is not None for o in outcomes)

    t_compile = t_all = t_kept = 0.0
    steps = 0
    for objs, linvel, angvel, n, is_kept in drops:
        t = time.perf_counter()
        scene = build_scene(variant, world.materials, objs, settings=drop.PHYSICS)
        t_compile += time.perf_counter() - t
        m, d = scene.model, scene.data()
        adr = m.jnt_dofadr[m.body_jntadr[scene.object_body["target"]]]
        d.qvel[adr:adr + 3], d.qvel[adr + 3:adr + 6] = linvel, angvel
        t = time.perf_counter()
        mujoco.mj_step(m, d, nstep=n)
        dt = time.perf_counter() - t
        t_all += dt
        t_kept += dt if is_kept else 0.0
        steps += n
    n = len(outcomes)
    print(json.dumps({
        "bench": "rehearse", "machine": platform.node(), "mujoco": mujoco.__version__,
        "variant": args.variant, "trials": n, "kept": kept,
        "trials_per_s": round(n / t_rehearse, 2), "kept_per_s": round(kept / t_rehearse, 2),
        "raw_step_us": round(1e6 * t_all / max(steps, 1), 2),
        "compile_ms_per_scene": round(1000 * t_compile / max(len(drops), 1), 2),
        "over_raw_all_drops": round(t_rehearse / t_all, 2) if t_all else None,
        "over_raw_all_drops_plus_compile": round(t_rehearse / (t_all + t_compile), 2),
        "over_raw_kept_drops": round(t_rehearse / t_kept, 2) if t_kept else None,
    }))


if __name__ == "__main__":
    main()
