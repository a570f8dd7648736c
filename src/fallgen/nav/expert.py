"""The expert: shortest action sequences in the agent's own motion lattice.

From the start pose, ``move_forward`` (0.25 m along one of 12 headings) and the two turns span
a lattice of poses; positions are merged into 5 cm bins per heading (the first, cheapest pose to
reach a bin represents it). A bucket-queue Dijkstra over this lattice (compiled with Numba:
:mod:`fallgen.nav.lattice`) finds, for a cost per forward move and per turn, the cheapest pose
from which the object can be seen; the tilt steps that centre it vertically and ``found``
complete the sequence.

A goal pose: horizontal distance to the object at most ``SUCCESS_DISTANCE_M`` - 0.1 m, the
object within the horizontal field of view less a 10 degree margin, and a clear line of sight
from the camera (``line_of_sight(pose)``); candidates are confirmed in cost order by
``visible(pose)`` (the renderer's segmentation count), so the expert never ends where it cannot
actually see the object.

Two searches: forward moves first, turns second (cost 1000 per move, 1 per turn: the expert's
own path, the shortest l of SPL, so the expert's SPL is 1), and fewest actions (1 and 1: n* of
SNA).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fallgen.nav.agent import (DOWN, FORWARD, FOUND, HEADING_VECTORS, HEADINGS, LEFT, RIGHT,
                               STEP_FRACTIONS, STEP_M, SUCCESS_DISTANCE_M, TURN_DEG, UP,
                               AgentSpec, Pose)
from fallgen.nav.lattice import Lattice, trace
from fallgen.nav.occupancy import OccupancyGrid

BIN_M = 0.05
FOV_DEG = 90.0
MARGIN_DEG = 10.0
#: Candidate poses checked with the renderer before giving up.
MAX_RENDER_CHECKS = 200


@dataclass(frozen=True)
class Plan:
    actions: tuple[int, ...]
    goal: Pose
    path_m: float
    renders: int  # visibility checks made


class NoPath(RuntimeError):
    """No pose from which the object is visible can be reached."""


def _search(start: Pose, grid: OccupancyGrid, target, spec: AgentSpec, move_cost: int,
            turn_cost: int, line_of_sight: Callable[[Pose], bool],
            visible: Callable[[Pose], bool], max_view_m: float) -> tuple[Plan, int]:
    nbx = int(math.ceil(grid.shape[0] * grid.resolution / BIN_M)) + 1
    nby = int(math.ceil(grid.shape[1] * grid.resolution / BIN_M)) + 1
    size = nbx * nby * HEADINGS
    # the occupancy table of the simulator's check, with a border for "outside the grid"
    # (clearance 0 there, as grid.clearance_at has it)
    ok = np.full((grid.shape[0] + 2, grid.shape[1] + 2), 0.0 >= spec.radius_m)
    ok[1:-1, 1:-1] = grid.clearance >= spec.radius_m
    lat = Lattice(size=size, nby=nby, ok=ok, resolution=grid.resolution, bin_m=BIN_M,
                  step_m=STEP_M, step_fractions=STEP_FRACTIONS, heading_vectors=HEADING_VECTORS,
                  turn_deg=TURN_DEG, target=target, camera_height_m=spec.camera_height_m,
                  reach_m=SUCCESS_DISTANCE_M - 0.1, max_view_m=max_view_m,
                  half_fov_deg=FOV_DEG / 2 - MARGIN_DEG, move_cost=move_cost,
                  turn_cost=turn_cost, tilt_deg=start.tilt_deg, tilt_min_deg=spec.tilt_min_deg,
                  tilt_max_deg=spec.tilt_max_deg, tilt_step_deg=spec.tilt_step_deg,
                  actions=(FORWARD, LEFT, RIGHT))
    s0 = lat.start(start.x, start.y, start.heading)
    renders = 0
    result = None
    while result is None:
        # candidates whose total is below every unexpanded cost, cheapest first: each is
        # confirmed by rendering (a refused one is dropped and the search goes on)
        batch = lat.advance()
        if len(batch) == 0:
            break
        for total, s, t in batch.tolist():
            if renders >= MAX_RENDER_CHECKS:
                break
            # the line of sight is checked only now, for candidates in cost order (ray casts
            # for every candidate found would cost more than the whole search)
            pose = Pose(float(lat.px[s]), float(lat.py[s]), s % HEADINGS, start.tilt_deg)
            if not line_of_sight(pose):
                continue
            goal = Pose(pose.x, pose.y, pose.heading, start.tilt_deg + t * spec.tilt_step_deg)
            renders += 1
            if visible(goal):
                result = (total, s, t, goal)
                break
        if renders >= MAX_RENDER_CHECKS and result is None:
            break  # no candidate is rendered any more: none can be confirmed
    if result is None:
        raise NoPath(f"no reachable pose sees the object ({renders} candidate poses rendered)")
    total, s, t, goal = result
    moves = trace(lat.act, lat.parent, s0, s)
    actions = moves + [UP if t > 0 else DOWN] * abs(t) + [FOUND]
    path = moves.count(FORWARD) * STEP_M
    return Plan(tuple(actions), goal, path, renders), total


@dataclass(frozen=True)
class Expert:
    plan: Plan  # the expert's actions (fewest forward moves, then fewest turns)
    shortest_m: float  # l of SPL
    fewest_actions: int  # n* of SNA


def expert(start: Pose, grid: OccupancyGrid, target, line_of_sight: Callable[[Pose], bool],
           visible: Callable[[Pose], bool], spec: AgentSpec = AgentSpec(),
           max_view_m: float = math.inf) -> Expert:
    """Plan the expert's action sequence from ``start`` to a pose that sees ``target`` (the
    object's centre, room frame), and the optimum references of SPL and SNA. Poses farther
    than ``max_view_m`` from the object (camera to centre) are not tried: a small object there
    covers too few pixels to be seen (see :func:`max_view_distance`)."""
    plan = plan_to_see(start, grid, target, line_of_sight, visible, spec, max_view_m)
    fewest, _ = _search(start, grid, target, spec, 1, 1, line_of_sight, visible, max_view_m)
    return Expert(plan, plan.path_m, min(len(fewest.actions), len(plan.actions)))


def plan_to_see(start: Pose, grid: OccupancyGrid, target, line_of_sight: Callable[[Pose], bool],
                visible: Callable[[Pose], bool], spec: AgentSpec = AgentSpec(),
                max_view_m: float = math.inf) -> Plan:
    """The expert's own plan from ``start`` (fewest forward moves, then fewest turns; the
    first search of :func:`expert`), without the fewest-actions search."""
    plan, _ = _search(start, grid, target, spec, 1000, 1, line_of_sight, visible, max_view_m)
    return plan


def max_view_distance(extents_m, pixels: int, image_px: int = 300) -> float:
    """Distance beyond which an object with bounding-box ``extents_m`` covers fewer than
    ``pixels`` pixels of a ``FOV_DEG`` camera, ``image_px`` wide, even seen broadside (its two
    largest extents as a rectangle, small-angle projection)."""
    e = np.sort(np.asarray(extents_m, float))[::-1]
    rad_per_px = math.radians(FOV_DEG) / image_px
    return float(math.sqrt(e[0] * e[1] / pixels) / rad_per_px)
