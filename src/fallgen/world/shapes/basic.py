"""Simple solids: spheres, cylinders, blocks, batteries, buttons."""

from __future__ import annotations

import math

import numpy as np

from fallgen.world import meshkit as mk
from fallgen.world.shapes._core import Shape, finish, need, shape


@shape("sphere", subdivisions=(1, 5))
def sphere(*, diameter_m: float = 0.0427, subdivisions: int = 3) -> Shape:
    """Sphere (golf ball, toy ball) as an icosphere; dimples are not modelled."""
    return finish(mk.sphere(diameter_m / 2, subdivisions=subdivisions))


@shape("cylinder", taper=(0.2, 5.0), edge_radius_m=(0.0, 1.0), segments=(8, 128))
def cylinder(*, diameter_m: float = 0.024, height_m: float = 0.044, taper: float = 1.0,
             edge_radius_m: float = 0.001, segments: int = 40) -> Shape:
    """Upright (truncated-cone) cylinder with rounded edges: corks, pillar candles, round
    coasters, discs. ``taper`` is the top diameter over the bottom one."""
    need(2 * edge_radius_m < min(height_m, diameter_m * min(1.0, taper)) * 0.999, "cylinder",
         "edge_radius_m", "must be less than half the height and the smaller radius")
    m = mk.rounded_cylinder(diameter_m / 2, height_m, top_radius=taper * diameter_m / 2,
                            edge_radius=edge_radius_m, segments=segments)
    return finish(m)


@shape("block", edge_radius_m=(0.0, 1.0), corner_radius_m=(0.0, 1.0))
def block(*, length_m: float = 0.04, width_m: float = 0.04, height_m: float = 0.04,
          edge_radius_m: float = 0.002, corner_radius_m: float = 0.0) -> Shape:
    """Box with rounded edges (toy blocks, square coasters, bars of soap...). A
    ``corner_radius_m`` larger than ``edge_radius_m`` rounds the vertical edges more."""
    rc = max(corner_radius_m, edge_radius_m)
    need(2 * rc < min(length_m, width_m), "block", "corner_radius_m", "too large for the plan size")
    need(2 * edge_radius_m < height_m, "block", "edge_radius_m", "must be less than half the height")
    if rc == edge_radius_m:
        m = mk.rounded_box((length_m, width_m, height_m), edge_radius_m)
    else:
        m = mk.rounded_slab((length_m, width_m, height_m), rc, edge_radius_m)
    return finish(m)


@shape("battery")
def battery(*, diameter_m: float = 0.0145, length_m: float = 0.0505,
            nub_diameter_m: float = 0.0055, nub_height_m: float = 0.001) -> Shape:
    """Cylindrical cell (AA, C, D...): body with rounded ends and the positive nub on top;
    ``length_m`` includes the nub."""
    R, L, rn, hn = diameter_m / 2, length_m, nub_diameter_m / 2, nub_height_m
    need(rn < 0.7 * R, "battery", "nub_diameter_m", "must be under 70% of the diameter")
    need(hn < 0.2 * L, "battery", "nub_height_m", "too tall")
    e = min(0.0008, 0.08 * R)
    prof = np.array([[0.0, 0.0], [0.8 * R, 0.0], [0.8 * R + e, -0.0], [R, 0.0], [R, L - hn - 0.0004],
                     [0.75 * R, L - hn], [rn, L - hn], [rn, L], [0.0, L]])
    prof = np.delete(prof, 2, axis=0)
    prof = mk.fillet_polyline(prof, [0, 0, e, e, 0, 0.0003, min(0.0005, rn / 3), 0])
    return finish(mk.Lathe.solid(prof, 36, min_len=1e-4).mesh())


@shape("shirt_button", holes=(0, 6))
def shirt_button(*, diameter_m: float = 0.0115, thickness_m: float = 0.0021, holes: int = 4,
                 hole_diameter_m: float = 0.0017, hole_spacing_m: float = 0.0033,
                 rim_width_m: float = 0.0015) -> Shape:
    """Sew-through button: disc with a raised rim, a dished centre and 2 or 4 (0-6) holes on a
    circle of diameter ``hole_spacing_m``."""
    R, t = diameter_m / 2, thickness_m
    need(rim_width_m < 0.4 * R, "shirt_button", "rim_width_m", "too wide")
    need(holes == 0 or hole_spacing_m / 2 + hole_diameter_m / 2 < R - rim_width_m, "shirt_button",
         "hole_spacing_m", "holes must lie inside the dish")
    need(holes < 2 or hole_spacing_m * math.sin(math.pi / holes) > hole_diameter_m * 1.2,
         "shirt_button", "hole_spacing_m", "holes overlap")
    prof = np.array([[0.0, 0.0], [R, 0.0], [R, 0.75 * t], [R - 0.35 * rim_width_m, t],
                     [R - rim_width_m, 0.8 * t], [0.6 * (R - rim_width_m), 0.65 * t],
                     [0.0, 0.65 * t]])
    prof = mk.fillet_polyline(prof, [0, t / 4, t / 4, t / 5, t / 5, t, 0])
    body = mk.Lathe.solid(prof, 40, min_len=5e-5).mesh()
    if holes:
        cuts = []
        for k in range(holes):
            a = 2 * math.pi * k / holes + (math.pi / holes if holes in (2, 4) else 0.0)
            c = (hole_spacing_m / 2 * math.cos(a), hole_spacing_m / 2 * math.sin(a), t / 2)
            cuts.append(mk.rounded_cylinder(hole_diameter_m / 2, 3 * t, segments=16, center=c))
        body = mk.difference(body, cuts, tolerance=1e-5)
    return finish(body)
