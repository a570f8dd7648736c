"""Loudness calibration: the dry sound (free field, 1 m, no room) of reference drops onto a
parquet, a tiled and a floorboard floor, a rug on tiles and a thin carpet, as the dataset
renders them (the rehearsal's contact recorder, then :class:`fallgen.audio.fall.FallRenderer`).
Prints two Markdown tables: the floors under the ISO tapping machine against building
acoustics' measurements (:mod:`fallgen.audio.floors`), then the drops (peak and loudest 125 ms
Leq, dB SPL re 20 uPa, and the share of the fall's energy radiated); with ``--json FILE`` also
writes both as JSON (``floors``, ``drops``: what ``make report`` puts in docs/physics.md).

    python bench/loudness_table.py [--heights 0.75 1.5] [--json build/loudness.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from fallgen.audio.fall import AudioSettings, FallRenderer  # noqa: E402
from fallgen.audio.floors import check_floor  # noqa: E402
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
#: (label, room variant, on its rug): parquet on a slab, tiles on a slab, floorboards on joists,
#: a pile rug on tiles
FLOORS = [("wood parquet", "kitchen_galley-l1-m1", False),
          ("ceramic tile", "kitchen_galley-l1-m2", False),
          ("floorboards", "kitchen_island-l1-m2", False),
          ("rug on tiles", "kitchen_galley-l1-m2", True),
          ("thin carpet", "study_loft-l1-m2", False)]


def _rug_spot(v) -> tuple[float, float]:
    """A point on the variant's rug at least 0.3 m from any other part (and 0.25 m inside the
    rug's edge)."""
    rug = next(p.box for it in v.furniture if it.floor_covering for p in it.parts)
    others = [p.box for it in v.furniture if not it.floor_covering for p in it.parts]
    lo, hi = rug.aabb()
    for x in np.linspace(lo[0] + 0.25, hi[0] - 0.25, 15):
        for y in np.linspace(lo[1] + 0.25, hi[1] - 0.25, 15):
            if not any(b.contains(np.array([[x, y, 0.3]]), tol=0.3)[0] for b in others):
                return float(x), float(y)
    raise ValueError(f"{v.id}: no clear spot on its rug")


def drop(world, vid: str, category: str, variant: str, material: str, height: float,
         steps: int = 1200, on_rug: bool = False) -> FallEvent:
    """The object let go, at rest, with its lowest point ``height`` above the floor, over the
    centre of the variant's largest floor zone (open floor), or over its rug."""
    v = world.variant(vid)
    z = max((z for z in v.zones if z.kind == "floor"),
            key=lambda z: z.volume.half[0] * z.volume.half[1])
    xy = _rug_spot(v) if on_rug else (float(z.volume.center[0]), float(z.volume.center[1]))
    inst = world.categories.instance(category, variant, material, 1.0)
    quat = np.array([0.96, 0.2, 0.1, 0.15]) / np.linalg.norm([0.96, 0.2, 0.1, 0.15])
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, quat)
    low = float((inst.geometry.vertices * inst.scale @ mat.reshape(3, 3).T)[:, 2].min())
    pos = (*xy, height - low)
    return record_drop(world, vid, z, ObjectSpec(category, variant, material, 1.0), pos, quat,
                       steps, event_id="cal")

def _cell(x, fmt: str = "{:.0f}") -> str:
    return "-" if x is None else fmt.format(x)


def floors_table(world) -> list[dict]:
    """Every floor surface under the ISO 10140-5 tapping machine: L_n,w (ISO 717-2) beside EN
    ISO 12354-2's bare-floor law, and a covering's Delta L_w beside its measured range."""
    rows = []
    print("| floor | structure (m'') | L_n,w | bare structure L_n,w | EN ISO 12354-2 bare "
          "| Delta L_w | measured Delta L_w |")
    print("|---|---|---|---|---|---|---|")
    for s in world.materials.surfaces.values():
        if "floor" not in s.uses:
            continue
        c = check_floor(s, world.materials)
        rng = s.impact_improvement_db
        print(f"| {s.name} | {s.structure_thickness_m * 1000:.0f} mm {s.structure_material} "
              f"({c.mass_per_area:.0f} kg/m2) | {c.rating_db} | {_cell(c.bare_rating_db)} | "
              f"{_cell(c.bare_reference_db, '{:.1f}')} | {_cell(c.improvement_db)} | "
              f"{'-' if rng is None else f'{rng[0]:g}-{rng[1]:g}'} |", flush=True)
        rows.append({"floor": s.name, "structure_mm": round(s.structure_thickness_m * 1000),
                     "structure_material": s.structure_material,
                     "mass_per_area_kg_m2": round(c.mass_per_area, 1),
                     "rating_db": c.rating_db, "bare_rating_db": c.bare_rating_db,
                     "bare_reference_db": c.bare_reference_db,
                     "improvement_db": c.improvement_db,
                     "measured_improvement_db": None if rng is None else list(rng)})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heights", type=float, nargs="+", default=[0.75, 1.5])
    ap.add_argument("--json", type=Path, help="also write the tables as JSON here")
    args = ap.parse_args()
    world = load_world(REPO)
    floors = floors_table(world)
    drops = []
    print()
    renderer = FallRenderer(world, AudioSettings())
    print("| object (mass) | floor | drop | peak dB SPL | Leq 125 ms dB SPL | radiated / lost |")
    print("|---|---|---|---|---|---|")
    for label, cat, var, mat in OBJECTS:
        mass = world.categories.instance(cat, var, mat, 1.0).mass_kg
        for floor, vid, on_rug in FLOORS:
            for h in args.heights:
                ev = drop(world, vid, cat, var, mat, h, on_rug=on_rug)
                p = renderer.render(ev, np.random.default_rng(0))
                peak, leq = levels_db_spl(p[None, :], 44100)
                ratio = radiated_energy_j(p, 44100) / renderer.energy_lost_j(ev)
                print(f"| {label} ({mass * 1000:.0f} g) | {floor} | {h:g} m | {peak:.1f} | "
                      f"{leq:.1f} | {ratio:.1e} |", flush=True)
                drops.append({"object": label, "mass_g": round(mass * 1000), "floor": floor,
                              "room_variant": vid, "drop_m": h, "peak_db_spl": round(peak, 1),
                              "leq_125ms_db_spl": round(leq, 1),
                              "radiated_over_lost": float(f"{ratio:.2e}")})
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"heights_m": args.heights, "floors": floors,
                                         "drops": drops}, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
