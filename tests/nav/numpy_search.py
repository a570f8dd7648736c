"""The expert's lattice search as it was written in NumPy (vectorised per cost level), kept as
the reference the compiled search (:mod:`fallgen.nav.lattice`) must match plan for plan."""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable

import numpy as np

from fallgen.nav.agent import (DOWN, FORWARD, FOUND, HEADING_VECTORS, HEADINGS, LEFT, RIGHT,
                               STEP_FRACTIONS, STEP_M, SUCCESS_DISTANCE_M, TURN_DEG, UP,
                               AgentSpec, Pose)
from fallgen.nav.expert import BIN_M, FOV_DEG, MARGIN_DEG, MAX_RENDER_CHECKS, NoPath
from fallgen.nav.lattice import trace
from fallgen.nav.occupancy import OccupancyGrid


NO_TILT = np.iinfo(np.int64).min


def tilt_steps(dist: np.ndarray, target, tilt_deg: int, spec: AgentSpec) -> np.ndarray:
    """Signed tilt steps, for poses at horizontal distances ``dist`` from ``target`` (all at
    tilt ``tilt_deg``), that bring the object's centre nearest the view centre within the
    vertical field of view less the margin; ``NO_TILT`` where the tilt limits cannot."""
    elev = np.degrees(np.arctan2(target[2] - spec.camera_height_m, np.maximum(dist, 1e-6)))
    tilts = np.arange(spec.tilt_min_deg, spec.tilt_max_deg + 1, spec.tilt_step_deg)
    off = np.abs(elev[:, None] - tilts[None, :])
    off[off > FOV_DEG / 2 - MARGIN_DEG] = np.inf
    best = np.argmin(off, axis=1)  # the first (lowest) tilt on ties
    steps = (tilts[best] - tilt_deg) // spec.tilt_step_deg
    return np.where(np.isfinite(off[np.arange(len(dist)), best]), steps, NO_TILT)


def _free_lookup(grid: OccupancyGrid, radius_m: float):
    """``grid.free_for(points, radius_m)`` as a function of coordinate arrays ``(x, y)`` of any
    shape (one table lookup per point: the search asks it about every forward move)."""
    # a border for "outside the grid" (clearance 0 there, as grid.clearance_at has it)
    ok = np.full((grid.shape[0] + 2, grid.shape[1] + 2), 0.0 >= radius_m)
    ok[1:-1, 1:-1] = grid.clearance >= radius_m
    r = grid.resolution
    hi = np.array(grid.shape) + 1

    def free(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        i = np.clip(np.floor(x / r), -1, hi[0] - 1).astype(np.int64) + 1
        j = np.clip(np.floor(y / r), -1, hi[1] - 1).astype(np.int64) + 1
        return ok[i, j]

    return free


def search(start: Pose, grid: OccupancyGrid, target, spec: AgentSpec, move_cost: int,
            turn_cost: int, line_of_sight: Callable[[Pose], bool],
            visible: Callable[[Pose], bool], max_view_m: float):
    nbx = int(math.ceil(grid.shape[0] * grid.resolution / BIN_M)) + 1
    nby = int(math.ceil(grid.shape[1] * grid.resolution / BIN_M)) + 1
    size = nbx * nby * HEADINGS
    best = np.full(size, np.iinfo(np.int64).max, np.int64)
    px, py = np.zeros(size), np.zeros(size)
    parent = np.full(size, -1, np.int64)
    act = np.full(size, -1, np.int8)
    dirs = HEADING_VECTORS
    target = np.asarray(target, float)
    renders = 0
    free = _free_lookup(grid, spec.radius_m)

    def key(x, y, k):
        return ((np.floor(x / BIN_M).astype(np.int64) * nby
                 + np.floor(y / BIN_M).astype(np.int64)) * HEADINGS + k)

    s0 = int(key(np.array([start.x]), np.array([start.y]), np.array([start.heading]))[0])
    best[s0], px[s0], py[s0] = 0, start.x, start.y
    buckets: dict[int, list[np.ndarray]] = {0: [np.array([s0])]}
    found: list[tuple[int, int, int]] = []  # heap of (total cost, state, tilt steps)
    tilt_cost = min(move_cost, turn_cost)
    result = None
    # Forward moves of settled states wait here (their costs, states, poses) until a turn
    # could cost as much as they do: with a move costing more than a turn, the turn buckets of
    # one move count are settled one after another and their forward moves are made in one
    # batch (the same states, costs and parents as moving forward at every bucket: a forward
    # move is still made before any turn that could tie with it).
    pending: list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def due(c: int | None) -> bool:  # must the pending moves be made before bucket c?
        return bool(pending) and (c is None or c + turn_cost >= pending[0][0] + move_cost)

    def move_forward() -> None:
        cost = np.concatenate([np.full(len(p[1]), p[0], np.int64) for p in pending])
        states, k, x0, y0 = (np.concatenate([p[i] for p in pending]) for i in range(1, 5))
        pending.clear()
        x1, y1 = x0 + STEP_M * dirs[k, 0], y0 + STEP_M * dirs[k, 1]
        # the simulator's own check of a forward move (the points of nav.agent.step_points)
        ok = free(x0[:, None] + STEP_FRACTIONS * (x1 - x0)[:, None],
                  y0[:, None] + STEP_FRACTIONS * (y1 - y0)[:, None]).all(1)
        # a forward move's bin is new: the first pose to reach it (in cost, then state order:
        # the order of `pending`) wins
        src, x, y, cost = states[ok], x1[ok], y1[ok], cost[ok] + move_cost
        s = key(x, y, k[ok])
        inside = (s >= 0) & (s < size)
        src, x, y, s, cost = src[inside], x[inside], y[inside], s[inside], cost[inside]
        s, first = np.unique(s, return_index=True)
        src, x, y, cost = src[first], x[first], y[first], cost[first]
        better = best[s] > cost
        s, src, x, y, cost = s[better], src[better], x[better], y[better], cost[better]
        best[s], px[s], py[s], parent[s], act[s] = cost, x, y, src, FORWARD
        for c1 in np.unique(cost).tolist():
            buckets.setdefault(c1, []).append(s[cost == c1])

    while buckets or found or pending:
        c = min(buckets) if buckets else None
        if due(c):
            move_forward()
            continue
        # candidates whose total is below every unexpanded cost are final: confirm the
        # cheapest by rendering (a refused one is dropped and the search goes on)
        while found and (c is None or found[0][0] < c) and result is None:
            total, s, t = heapq.heappop(found)
            if renders >= MAX_RENDER_CHECKS:
                found.clear()
                break
            # the line of sight is checked only now, for candidates in cost order (ray casts
            # for every candidate found would cost more than the whole search)
            if not line_of_sight(Pose(float(px[s]), float(py[s]), int(s % HEADINGS),
                                      start.tilt_deg)):
                continue
            goal = Pose(float(px[s]), float(py[s]), int(s % HEADINGS),
                        start.tilt_deg + t * spec.tilt_step_deg)
            renders += 1
            if visible(goal):
                result = (total, s, t, goal)
        if result is not None or c is None:
            break
        # (a state enters a bucket once: only when its cost strictly drops to the bucket's)
        states = np.sort(np.concatenate(buckets.pop(c)))
        states = states[best[states] == c]
        if len(states) == 0:
            continue
        k = states % HEADINGS
        # goal candidates among the settled states
        dx, dy = target[0] - px[states], target[1] - py[states]
        dist = np.hypot(dx, dy)
        bearing = (np.degrees(np.arctan2(dy, dx)) - TURN_DEG * k + 180) % 360 - 180
        eye = np.hypot(dist, target[2] - spec.camera_height_m)  # camera to object
        cand = np.nonzero((dist <= SUCCESS_DISTANCE_M - 0.1) & (eye <= max_view_m)
                          & (np.abs(bearing) <= FOV_DEG / 2 - MARGIN_DEG))[0]
        if len(cand):
            steps = tilt_steps(dist[cand], target, start.tilt_deg, spec)
            for s, t in zip(states[cand][steps != NO_TILT].tolist(),
                            steps[steps != NO_TILT].tolist()):
                heapq.heappush(found, (c + abs(t) * tilt_cost + 1, s, t))
        # expand: forward (later, see `pending`) and the two turns (a turn stays in its own
        # bin, state = bin * HEADINGS + heading, one state per source)
        x0, y0 = px[states], py[states]
        pending.append((c, states, k, x0, y0))
        if due(c):
            move_forward()
        for s, a in ((states - k + (k + 1) % HEADINGS, LEFT),
                     (states - k + (k - 1) % HEADINGS, RIGHT)):
            better = best[s] > c + turn_cost
            s, src = s[better], states[better]
            if len(s) == 0:
                continue
            best[s], px[s], py[s], parent[s], act[s] = c + turn_cost, x0[better], \
                y0[better], src, a
            buckets.setdefault(c + turn_cost, []).append(s)
    if result is None:
        raise NoPath(f"no reachable pose sees the object ({renders} candidate poses rendered)")
    total, s, t, goal = result
    moves = trace(act, parent, s0, s)  # the path back is not the search: shared
    actions = moves + [UP if t > 0 else DOWN] * abs(t) + [FOUND]
    path = moves.count(FORWARD) * STEP_M
    return tuple(actions), goal, path, renders, total
