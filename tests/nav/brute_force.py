"""The expert's optimum by brute force: breadth-first search over the agent's whole pose lattice
(positions unmerged, headings, tilts), each successor made by the action simulator and each
``found`` judged by the judge itself, so nothing of the expert's search is reused.

Positions are told apart exactly: every forward move adds 0.25 m (cos, sin) of a multiple of
30 degrees, and 2 cos, 2 sin of those angles are each an integer or +-sqrt(3); a position is
the start plus an integer combination of 1/8 m and sqrt(3)/8 m per axis, kept as those four
integers (read off the simulator's own heading vectors here, not from the expert's table).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import numpy as np

from fallgen.nav.agent import (ACTIONS, FORWARD, FOUND, AgentSpec, Pose, heading_vector, run,
                               step)
from fallgen.nav.occupancy import OccupancyGrid


def _parts(v: float) -> tuple[int, int]:
    """(i, j) with 8 v = i + j sqrt 3, for v a component of a 0.25 m step."""
    e = 8 * v
    if abs(e - round(e)) < 1e-9:
        return round(e), 0
    j = round(e / math.sqrt(3))
    assert abs(e - j * math.sqrt(3)) < 1e-9, v
    return 0, j


def _offsets() -> list[tuple[int, int, int, int]]:
    out = []
    for k in range(12):
        c, s = (0.25 * heading_vector(k)).tolist()
        out.append((*_parts(c), *_parts(s)))
    return out


def optimum(start: Pose, grid: OccupancyGrid, target_xy, visible: Callable[[Pose], bool],
            spec: AgentSpec = AgentSpec(), max_states: int = 2_000_000
            ) -> tuple[int | None, int | None]:
    """(fewest forward moves, fewest actions with ``found``) over every action sequence from
    ``start`` whose ``found`` succeeds, None where none does within the judge's action limit
    (``max_states`` bounds the work: RuntimeError beyond it)."""
    steps = _offsets()

    def succeeds(p: Pose) -> bool:
        return run(p, [FOUND], grid, target_xy, visible, spec).success

    judged: dict[Pose, bool] = {}

    def judge(p: Pose) -> bool:
        if p not in judged:
            judged[p] = succeeds(p)
        return judged[p]

    def successors(p: Pose, key):
        for a in range(len(ACTIONS)):
            if a == FOUND:
                continue
            q, moved = step(p, a, grid, spec)
            if not moved:
                continue  # a blocked action changes nothing: never on a shortest sequence
            k = key
            if a == FORWARD:
                o = steps[p.heading]
                k = (key[0] + o[0], key[1] + o[1], key[2] + o[2], key[3] + o[3])
            yield a, q, k

    def state(p: Pose, key):
        return key, p.heading, p.tilt_deg

    origin = (0, 0, 0, 0)
    # fewest actions: plain breadth-first search, found costing one more
    fewest = None
    seen = {state(start, origin)}
    queue = deque([(start, origin, 0)])
    while queue:
        p, key, depth = queue.popleft()
        if depth + 1 > 200:
            break
        if judge(p):
            fewest = depth + 1
            break
        for _, q, k in successors(p, key):
            s = state(q, k)
            if s not in seen:
                seen.add(s)
                if len(seen) > max_states:
                    raise RuntimeError("brute force: too many states")
                queue.append((q, k, depth + 1))
    # fewest forward moves: 0-1 breadth-first search (turns and tilts cost nothing)
    moves = None
    best = {state(start, origin): 0}
    queue = deque([(start, origin, 0)])
    while queue:
        p, key, cost = queue.popleft()
        if best.get(state(p, key), math.inf) < cost:
            continue
        if judge(p):
            moves = cost
            break
        for a, q, k in successors(p, key):
            c = cost + (a == FORWARD)
            s = state(q, k)
            if c < best.get(s, math.inf):
                best[s] = c
                if len(best) > max_states:
                    raise RuntimeError("brute force: too many states")
                (queue.append if a == FORWARD else queue.appendleft)((q, k, c))
    return moves, fewest


def in_frustum(pose: Pose, point, spec: AgentSpec = AgentSpec()) -> bool:
    """Whether ``point`` lies strictly inside the 90 degree view frustum of ``pose``."""
    yaw, tilt = pose.yaw_rad, math.radians(pose.tilt_deg)
    f = np.array([math.cos(tilt) * math.cos(yaw), math.cos(tilt) * math.sin(yaw),
                  math.sin(tilt)])
    r = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    u = np.cross(r, f)
    rel = np.asarray(point, float) - np.array([pose.x, pose.y, spec.camera_height_m])
    z = rel @ f
    return bool(z > 0 and abs(rel @ r) < z and abs(rel @ u) < z)
