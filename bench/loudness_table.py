"""Loudness calibration: the dry sound (free field, 1 m, no room) of reference drops onto a
parquet, a tiled and a floorboard floor, as the dataset renders them (the rehearsal's contact
recorder, then :class:`fallgen.audio.fall.FallRenderer`). Prints a Markdown table (peak and
loudest 125 ms Leq, dB SPL re 20 uPa, and the share of the fall's energy radiated).

    python bench/loudness_table.py [--heights 0.75 1.5]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mujoco
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from fallgen.audio.fall import AudioSettings, FallRenderer  # noqa: E402
from fallgen.audio.impact import radiated_energy_j  # noqa: E402
from fallgen.audio.mix import levels_db_spl  # noqa: E402
from fallgen.physics.drop import record_drop  # noqa: E402
from fallgen.physics.events import FallEvent, ObjectSpec  # noqa: E402
from fallgen.world.library import load_world  # noqa: E402

#: (label, category, variant, material)
OBJECTS = [
    ("steel tablespoon", "spoon", "tablespoon", "metal"),
    ("ceramic mug", "cup", "mug", "ceramic"),
    ("wine glass", "wineglass", "red_wine", "glass"),
    ("wooden box (block)", "box", "jewellery", "wood_hard"),
    ("golf ball", "golf_ball", "standard", "plastic_hard/golf_ball"),
    ("plastic toy car", "toy", "car", "plastic_hard"),
]
#: (label, room variant): parquet on a slab, tiles on a slab, floorboards on joists
FLOORS = [("wood parquet", "kitchen_galley-l1-m1"), ("ceramic tile", "kitchen_galley-l1-m2"),
          ("floorboards", "kitchen_island-l1-m2")]


def drop(world, vid: str, category: str, variant: str, material: str, height: float,
         steps: int = 1200) -> FallEvent:
    """The object let go, at rest, with its lowest point ``height`` above the floor, over the
    centre of the variant's largest floor zone (open floor)."""
    v = world.variant(vid)
    z = max((z for z in v.zones if z.kind == "floor"),
            key=lambda z: z.volume.half[0] * z.volume.half[1])
    inst = world.categories.instance(category, variant, material, 1.0)
    quat = np.array([0.96, 0.2, 0.1, 0.15]) / np.linalg.norm([0.96, 0.2, 0.1, 0.15])
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, quat)
    low = float((inst.geometry.vertices * inst.scale @ mat.reshape(3, 3).T)[:, 2].min())
    pos = (float(z.volume.center[0]), float(z.volume.center[1]), height - low)
    return record_drop(world, vid, z, ObjectSpec(category, variant, material, 1.0), pos, quat,
                       steps, event_id="cal")

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heights", type=float, nargs="+", default=[0.75, 1.5])
    args = ap.parse_args()
    world = load_world(REPO)
    renderer = FallRenderer(world, AudioSettings())
    print("| object (mass) | floor | drop | peak dB SPL | Leq 125 ms dB SPL | radiated / lost |")
    print("|---|---|---|---|---|---|")
    for label, cat, var, mat in OBJECTS:
        mass = world.categories.instance(cat, var, mat, 1.0).mass_kg
        for floor, vid in FLOORS:
            for h in args.heights:
                ev = drop(world, vid, cat, var, mat, h)
                p = renderer.render(ev, np.random.default_rng(0))
                peak, leq = levels_db_spl(p[None, :], 44100)
                ratio = radiated_energy_j(p, 44100) / renderer.energy_lost_j(ev)
                print(f"| {label} ({mass * 1000:.0f} g) | {floor} | {h:g} m | {peak:.1f} | "
                      f"{leq:.1f} | {ratio:.1e} |", flush=True)


if __name__ == "__main__":
    main()
