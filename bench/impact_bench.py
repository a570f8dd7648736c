"""Impact synthesis speed, side by side with TDW's PyImpact on comparable impacts.

    python bench/impact_bench.py [--pyimpact PYTHON] [--reps N]

Our side: the same six (object material, surface material, speed) cases as
``../shared/peers/pyimpact_bench.py``, each an object of that material (a real fallgen shape)
striking a floor panel of the surface material: Hertz pulse, every mode below 20 kHz of both
bodies, rigid-body noise, 2 s at 44.1 kHz. Modal models come from the cache (their one-time
solve is timed separately, as ``modal_solve_s``). With ``--pyimpact`` (the interpreter that
``../shared/peers/setup.sh pyimpact`` prints) PyImpact runs in the same invocation and the ratio
is reported. Then whole falls: the dry sound of ``--falls`` rehearsed falls (every contact of
both bodies, 2 s), timed per fall, per impact and per contact event. Prints one JSON line.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import subprocess
import time
from pathlib import Path

import numpy as np

from fallgen.audio.fall import PATCH_M
from fallgen.audio.shells import plate_model
from fallgen.audio.hertz import hertz_impact
from fallgen.audio.impact import ModalHit, SoundingBody, render
from fallgen.audio.modes import ModalSettings, modal_model
from fallgen.world.library import load_world

PEER = Path(__file__).resolve().parents[2] / "shared" / "peers" / "pyimpact_bench.py"
CASES = [  # (category, variant, material, surface material, speed m/s) ~ PyImpact's cases
    ("knife", "table", "metal", "wood_medium", 2.0),
    ("bottle", "wine", "glass", "ceramic", 3.0),
    ("bowl", "cereal", "ceramic", "wood_soft", 2.5),
    ("pen", "click", "plastic_hard", "wood_medium", 4.0),
    ("bookend", "wood", "wood_hard", "stone", 1.5),
    ("toy", "duck", "rubber", "wood_medium", 3.0),
]


def _whole_falls(world, n: int, variant_id: str = "kitchen_galley-l1-m1") -> dict:
    """Render the whole dry sound (every contact, both bodies, 2 s) of ``n`` rehearsed falls
    (the first kept trials of each zone); modal models loaded and the room compiled before
    timing."""
    from fallgen.audio.fall import AudioSettings, FallRenderer
    from fallgen.config import RehearseConfig
    from fallgen.physics.drop import run_trial

    variant = world.variant(variant_id)
    events = []
    for t in range(20):
        for z in variant.zones:
            if len(events) < n:
                o = run_trial(world, variant, z, t, RehearseConfig(), 1)
                if o.event is not None:
                    events.append(o.event)
    r = FallRenderer(world, AudioSettings())
    for e in events:  # load (or solve) every modal model first, and compile the room
        r.render(e, np.random.default_rng(0))
    # as generation renders a fall whose agent stands clear of it: no scene is compiled (the
    # room's geoms come from a model compiled once per variant)
    t = time.perf_counter()
    for e in events:
        p = r.render(e, np.random.default_rng(0))
        assert np.isfinite(p).all()
    dt = time.perf_counter() - t
    impacts = sum(c.kind == "impact" for e in events for c in e.contacts)
    contacts = sum(len(e.contacts) for e in events)
    return {"falls": len(events), "ms_per_fall": round(1e3 * dt / len(events), 2),
            "impacts_per_fall": round(impacts / len(events), 1),
            "contacts_per_fall": round(contacts / len(events), 1),
            "ms_per_impact": round(1e3 * dt / impacts, 3),
            "ms_per_contact": round(1e3 * dt / contacts, 3)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pyimpact", help="python of the PyImpact environment")
    ap.add_argument("--reps", type=int, default=30)
    ap.add_argument("--falls", type=int, default=20, help="whole falls to render")
    args = ap.parse_args()
    world = load_world()
    lib, mats = world.categories, world.materials
    settings = ModalSettings()
    t0 = time.perf_counter()
    bodies = []
    slab_m = 0.15  # the floor: a patch of a 150 mm slab, as a bonded floor rings in a build
    for cat, var, mat, surf, speed in CASES:
        inst = lib.instance(cat, var, mat, 1.0)
        m = inst.material
        ref = modal_model(inst.geometry.vertices, inst.geometry.faces, m.poisson_ratio, settings,
                          shell=inst.geometry.shell)
        obj = SoundingBody(ref.scaled(m.youngs_modulus_pa, m.density_kg_m3, 1.0), m.loss_factor,
                           m.youngs_modulus_pa, m.poisson_ratio, inst.mass_kg,
                           float(np.clip(0.25 * inst.extents_m.min(), 0.001, 0.05)))
        s = mats.object(surf)
        pref = plate_model(PATCH_M, PATCH_M, slab_m, s.poisson_ratio, settings.n_modes)
        vol = PATCH_M ** 2 * slab_m
        floor = SoundingBody(pref.scaled(s.youngs_modulus_pa, s.density_kg_m3, 1.0),
                             max(s.loss_factor, 0.05), s.youngs_modulus_pa, s.poisson_ratio,
                             s.density_kg_m3 * vol, math.inf)
        point = inst.geometry.vertices[np.argmin(inst.geometry.vertices[:, 2])]
        bodies.append((obj, floor, inst, speed, point))
    t_solve = time.perf_counter() - t0

    times, modes = [], []
    for _ in range(args.reps):
        for obj0, floor0, inst, speed, point in bodies:
            t = time.perf_counter()
            # a new object pair every time (as PyImpact's "new pair" case): rescale the cached
            # reference modes and compute the radiation factors again
            obj = SoundingBody(obj0.modes.scaled(1e10, 1000.0, 1.0), obj0.loss_factor,
                               obj0.contact_modulus_pa, obj0.poisson_ratio, obj0.mass_kg,
                               obj0.contact_radius_m)
            floor = SoundingBody(floor0.modes.scaled(1e10, 1000.0, 1.0), floor0.loss_factor,
                                 floor0.contact_modulus_pa, floor0.poisson_ratio,
                                 floor0.mass_kg, floor0.contact_radius_m)
            h = hertz_impact(obj.contact_modulus_pa, obj.poisson_ratio, floor.contact_modulus_pa,
                             floor.poisson_ratio, obj.contact_radius_m, math.inf, obj.mass_kg,
                             math.inf, speed)
            j = inst.mass_kg * speed * (1 + inst.material.restitution)
            p = render(obj, [ModalHit(0.0, point, j, h.duration_s)], 2.0,
                       volume_m3=inst.geometry.volume_m3)
            p += render(floor, [ModalHit(0.0, np.array([0.13, 0.08, slab_m / 2]), j,
                                         h.duration_s, np.array([0.0, 0.0, -1.0]))], 2.0)
            times.append(time.perf_counter() - t)
            modes.append(int((obj.modes.omega < 0.45 * 44100 * 2 * math.pi).sum()
                             + (floor.modes.omega < 0.45 * 44100 * 2 * math.pi).sum()))
            assert np.isfinite(p).all()
    ours_ms = 1e3 * statistics.median(times)
    falls = _whole_falls(world, args.falls)
    out = {"bench": "impact", "machine": platform.node(), "sample_rate": 44100,
           "audio_s": 2.0, "ours_ms_median": round(ours_ms, 3),
           "ours_realtime_factor": round(2.0 / (ours_ms / 1e3), 1),
           "ours_modes_median": statistics.median(modes),
           "modal_solve_s": round(t_solve, 2), "impacts_timed": len(times)}
    out["falls"] = falls
    if args.pyimpact:
        r = subprocess.run([args.pyimpact, str(PEER)], capture_output=True, text=True,
                           check=True)
        peer = json.loads(r.stdout.strip().splitlines()[-1])
        out["pyimpact"] = peer
        out["pyimpact_modes"] = 20  # 10 per body
        out["speedup_vs_pyimpact_new_pair"] = round(peer["new_pair_ms_median"] / ours_ms, 2)
        out["speedup_vs_pyimpact_audio_second"] = round(
            (peer["new_pair_ms_median"] / peer["audio_s_median"]) / (ours_ms / 2.0), 2)
        # in a fall PyImpact is called once per impact (scrapes would be more calls) on a
        # pair it has already seen: its repeat-hit time
        out["speedup_vs_pyimpact_in_falls"] = round(
            peer["repeat_hit_ms_median"] / falls["ms_per_impact"], 2)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
