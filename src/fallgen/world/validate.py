"""Geometric checks of a room variant: what makes a layout usable for the benchmark.

- every furniture part lies inside the room; no two items interpenetrate beyond a tolerance;
- every zone lies inside the room, rests on what supports it (the floor or the top face of a
  part), is free of furniture, and has free space above for its drop region;
- the floor is navigable: the free space for a robot of radius ``ROBOT_RADIUS_M`` is one
  connected region, large enough, and every zone can be approached within 2 m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallgen.world.geometry import Box, footprint_inside, penetration
from fallgen.world.rooms import RoomVariant

#: Interpenetration allowed between items, or between an item and a zone (m).
TOLERANCE_M = 0.01
#: Robot footprint radius used for the navigability check (m).
ROBOT_RADIUS_M = 0.2
#: Parts whose bottom is above this height do not block the robot (m).
ROBOT_HEIGHT_M = 1.3
#: Parts whose top is at most this high do not block the robot: it drives over them (rugs; the
#: same band as the agent's occupancy grid, :func:`fallgen.nav.occupancy.occupancy`).
ROBOT_STEP_M = 0.03
#: Occupancy grid resolution for the navigability check (m).
GRID_M = 0.05
#: The paper's success radius: an object must be approachable within it (m).
SUCCESS_RADIUS_M = 2.0


@dataclass(frozen=True)
class NavigabilityReport:
    free_area_m2: float
    largest_component_fraction: float
    unreachable_zones: tuple[str, ...]


def occupancy(variant: RoomVariant, grid_m: float = GRID_M, inflate_m: float = 0.0,
              height_m: float = ROBOT_HEIGHT_M) -> np.ndarray:
    """Boolean grid [ny, nx] of floor cells blocked for a robot (True = occupied).

    A cell is occupied if a part with bottom below ``height_m`` covers it (grown by
    ``inflate_m``), or it lies within ``inflate_m`` of a wall. Cell (j, i) has its centre at
    ((i + 0.5) g, (j + 0.5) g).
    """
    lx, ly, _ = variant.size_m
    nx, ny = int(math.ceil(lx / grid_m)), int(math.ceil(ly / grid_m))
    xs = (np.arange(nx) + 0.5) * grid_m
    ys = (np.arange(ny) + 0.5) * grid_m
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    occ = np.zeros(X.size, bool)
    for _, part in variant.parts():
        if part.box.zmin >= height_m or part.box.zmax <= ROBOT_STEP_M:
            continue
        flat = Box((part.box.center[0], part.box.center[1], 0.0),
                   (part.box.half[0], part.box.half[1], 1.0), part.box.yaw)
        occ |= flat.contains(pts, tol=inflate_m)
    occ = occ.reshape(ny, nx)
    if inflate_m > 0:
        occ |= (X < inflate_m) | (X > lx - inflate_m) | (Y < inflate_m) | (Y > ly - inflate_m)
    return occ


def navigability(variant: RoomVariant) -> NavigabilityReport:
    from scipy import ndimage

    occ = occupancy(variant, inflate_m=ROBOT_RADIUS_M)
    free = ~occ
    labels, n = ndimage.label(free)
    if n == 0:
        return NavigabilityReport(0.0, 0.0, tuple(z.id for z in variant.zones))
    sizes = np.bincount(labels.ravel())[1:]
    main = int(np.argmax(sizes)) + 1
    reach = labels == main
    ys, xs = np.nonzero(reach)
    cx, cy = (xs + 0.5) * GRID_M, (ys + 0.5) * GRID_M
    unreachable = []
    for z in variant.zones:
        d = np.hypot(cx - z.volume.center[0], cy - z.volume.center[1])
        if d.size == 0 or d.min() > SUCCESS_RADIUS_M - 0.25:
            unreachable.append(z.id)
    return NavigabilityReport(float(free.sum()) * GRID_M**2, float(sizes.max() / sizes.sum()),
                              tuple(unreachable))


def check_variant(v: RoomVariant, min_free_area_m2: float = 3.0) -> list[str]:
    """All problems found in one variant (empty list: the variant is fine)."""
    problems: list[str] = []
    lx, ly, h = v.size_m
    room = Box.from_bounds((0.0, 0.0, 0.0), (lx, ly, h))
    parts = list(v.parts())
    for item, p in parts:
        lo, hi = p.box.aabb()
        if (lo < -TOLERANCE_M).any() or (hi > np.array(v.size_m) + TOLERANCE_M).any():
            problems.append(f"{item.id}/{p.name} sticks out of the room")
    for i, (a, pa) in enumerate(parts):
        for b, pb in parts[i + 1:]:
            if a.id == b.id or a.floor_covering or b.floor_covering:  # things stand on rugs
                continue
            d = penetration(pa.box, pb.box)
            if d > TOLERANCE_M:
                problems.append(f"{a.id}/{pa.name} intersects {b.id}/{pb.name} by {d * 100:.1f} cm")
    supports = {f"{item.id}/{p.name}": p for item, p in parts}
    for z in v.zones:
        tag = f"zone {z.id} ({z.anchor})"
        lo, hi = z.volume.aabb()
        if (lo < -TOLERANCE_M).any() or (hi > np.array(v.size_m) + TOLERANCE_M).any():
            problems.append(f"{tag} lies outside the room")
        if z.support == "floor":
            if abs(z.volume.zmin) > TOLERANCE_M:
                problems.append(f"{tag} is not on the floor")
        else:
            sp = supports.get(z.support)
            if sp is None:
                problems.append(f"{tag} support {z.support} does not exist")
            elif abs(sp.box.zmax - z.volume.zmin) > TOLERANCE_M:
                problems.append(f"{tag} does not rest on {z.support} "
                                f"({z.volume.zmin:.3f} vs {sp.box.zmax:.3f} m)")
            elif not footprint_inside(z.volume, sp.box, tol=TOLERANCE_M):
                problems.append(f"{tag} overhangs its support {z.support}")
        for item, p in parts:
            if item.floor_covering and z.support == "floor":  # a zone on a rug
                continue
            if penetration(z.volume, p.box) > TOLERANCE_M:
                problems.append(f"{tag} volume intersects {item.id}/{p.name}")
            if penetration(z.drop, p.box) > TOLERANCE_M:
                problems.append(f"{tag} drop region intersects {item.id}/{p.name}")
        if z.drop.zmin < z.volume.zmin - TOLERANCE_M:
            problems.append(f"{tag} drop region starts below its settle volume")
        if not room.contains(np.array(z.drop.aabb()), tol=TOLERANCE_M).all():
            problems.append(f"{tag} drop region lies outside the room")
        if z.open_above and z.drop.zmax < 1.5:
            problems.append(f"{tag} is open above but its drop region ends at {z.drop.zmax:.2f} m")
    nav = navigability(v)
    if nav.free_area_m2 < min_free_area_m2:
        problems.append(f"only {nav.free_area_m2:.1f} m^2 of floor is free for the robot")
    if nav.largest_component_fraction < 0.9:
        problems.append(f"free floor is split: the largest region is "
                        f"{nav.largest_component_fraction:.0%} of it")
    for zid in nav.unreachable_zones:
        problems.append(f"zone {zid} cannot be approached within {SUCCESS_RADIUS_M} m")
    return problems
