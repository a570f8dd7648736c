"""The proof that no reachable pose sees the object (fallgen.nav.hidden): its bound on where
the agent can be, checked with the action simulator, and the expert's early NoPath, checked
against the search that enters every state."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.ndimage import distance_transform_edt

from fallgen.nav.agent import FORWARD, STEP_M, STEP_SAMPLES, AgentSpec, Pose, step
from fallgen.nav.expert import Limits, NoPath, SearchLimit, expert
from fallgen.nav.hidden import reachable_cells
from fallgen.nav.occupancy import OccupancyGrid
from fallgen.vision.faces import SceneFaces
from fallgen.vision.sight import Occluders, near_distance


def _grid(occ, r=0.1):
    padded = np.pad(occ, 1, constant_values=True)
    d = distance_transform_edt(~padded)[1:-1, 1:-1] * r
    cl = np.maximum(d - r / 2, 0)
    cl[occ] = 0
    return OccupancyGrid(occ, r, cl)


def _reached(start: Pose, g, spec, moves: int) -> set[tuple[int, int]]:
    """The cells of every position the simulator reaches from ``start`` within ``moves``
    forward moves (turns free), positions merged to 1e-9 m."""
    seen, frontier, cells = set(), [start], set()
    for _ in range(moves + 1):
        nxt = []
        for p in frontier:
            for h in range(12):
                q = Pose(p.x, p.y, h, p.tilt_deg)
                key = (round(q.x, 9), round(q.y, 9), h)
                if key in seen:
                    continue
                seen.add(key)
                cells.add((int(np.floor(q.x / g.resolution)) + 1,
                           int(np.floor(q.y / g.resolution)) + 1))
                r, moved = step(q, FORWARD, g, spec)
                if moved:
                    nxt.append(r)
        frontier = nxt
    return cells


def test_every_position_the_simulator_reaches_lies_in_a_bounding_cell():
    """In random clutter (boxes, thin legs, gaps one cell wide on the diagonal), every position
    the action simulator reaches within 14 moves from random starts lies in a cell of the
    bound; and the bound is not everything: some maps hold free cells outside it."""
    rng = np.random.default_rng(11)
    spec = AgentSpec()
    outside = 0
    for trial in range(12):
        occ = np.zeros((36, 30), bool)
        occ[[0, -1], :] = occ[:, [0, -1]] = True
        occ[18, :] = True  # a partition with one gap
        occ[18, rng.integers(3, 27):][:3] = False
        for _ in range(10):
            x, y = rng.integers(2, 32), rng.integers(2, 26)
            occ[x:x + rng.integers(1, 4), y:y + rng.integers(1, 4)] = True
        g = _grid(occ)
        free = np.argwhere(g.clearance >= spec.radius_m)
        if not len(free):
            continue
        a = free[rng.integers(len(free))]
        start = Pose(float((a[0] + rng.uniform(0, 1)) * 0.1),
                     float((a[1] + rng.uniform(0, 1)) * 0.1), int(rng.integers(12)), 0)
        ok = g.move_table(spec.radius_m)
        bound = {tuple(c) for c in reachable_cells(ok, 0.1, (start.x, start.y),
                                                   STEP_M / (STEP_SAMPLES - 1)).tolist()}
        assert _reached(start, g, spec, 14) <= bound, trial
        outside += int(ok.sum()) > len(bound)
    assert outside >= 1


def test_no_bound_where_the_checks_skip_cells_or_the_outside_is_free():
    ok = np.zeros((12, 12), bool)
    ok[1:-1, 1:-1] = True
    assert reachable_cells(ok, 0.1, (0.5, 0.5), 0.05) is not None
    assert reachable_cells(ok, 0.1, (0.5, 0.5), 0.15) is None  # a move may jump a cell
    ok[0] = True
    assert reachable_cells(ok, 0.1, (0.5, 0.5), 0.05) is None


def _pen(h: float):
    """An agent penned in a 1 x 1 m corner of a room (x < 1.1, y < 1.0 m), a ball at eye
    height ``h`` beyond the pen's 2.5 m wall (x 1.2 m): ``scene(window)`` makes the
    occluders (with a window in the wall in line with the ball); also the grid, the start
    pose, the ball's centre and its box's corners."""
    def scene(window: bool):
        wall = ('<geom type="box" size="0.02 1.5 1.25" pos="1.2 1.5 1.25"/>' if not window else
                '<geom type="box" size="0.02 0.15 1.25" pos="1.2 0.15 1.25"/>'
                '<geom type="box" size="0.02 1.15 1.25" pos="1.2 1.85 1.25"/>')
        xml = f"""<mujoco><worldbody>{wall}
        <geom name="ball" type="sphere" size="0.05" pos="2.2 0.5 {h}"/></worldbody></mujoco>"""
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        faces = SceneFaces(m, d, [0, 1] if window else [0])
        pts = np.array([[2.2 + a * 0.05, 0.5 + b * 0.05, h + c * 0.05]
                        for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)])
        return Occluders([faces], pts, near_distance(m))

    occ = np.zeros((40, 30), bool)
    occ[[0, -1], :] = occ[:, [0, -1]] = True
    occ[11:13, :] = True  # the wall's footprint, x 1.1-1.3 m
    occ[:11, 10] = True  # the pen: x < 1.1, y < 1.0
    g = _grid(occ)
    start = Pose(0.55, 0.5, 0, 0)
    target = np.array([2.2, 0.5, h])
    corners = target + 0.05 * np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1)
                                        for c in (-1, 1)])
    return scene, g, start, target, corners


def test_expert_proves_no_path_where_the_search_runs_out():
    """An agent penned in a 1 x 1 m corner of a room, a ball beyond the pen's 2.5 m wall:
    the search alone enters states until its limit (SearchLimit); with the scene's occluders
    the expert answers NoPath, proven from the pen's cells. With a window in the wall the
    proof fails, and the search goes on to its own answer."""
    spec = AgentSpec()
    h = spec.camera_height_m

    scene, g, start, target, corners = _pen(h)
    never = (lambda p: False)  # what the renderer says: nothing of the ball shows
    small = Limits(states=150_000)
    try:
        expert(start, g, target, corners, never, spec, small)
        raise AssertionError("a plan to an object nothing shows")
    except SearchLimit:
        pass
    occluders = scene(window=False)
    try:
        expert(start, g, target, corners, never, spec, small, sight=occluders.kernel)
        raise AssertionError("a plan to an object nothing shows")
    except SearchLimit:
        raise AssertionError("the proof did not hold") from None
    except NoPath as e:
        assert "hides the object" in str(e)
    # a window in the wall (y 0.3-0.7 m), in line with the ball: not proven, the search goes on
    windowed = scene(window=True)
    try:
        expert(start, g, target, corners, never, spec, small, sight=windowed.kernel)
    except NoPath as e:
        assert isinstance(e, SearchLimit) or "hides the object" not in str(e)


def test_block_proofs_give_the_cell_proofs_verdict_with_fewer_region_proofs(monkeypatch):
    """The pen's cells within reach of the ball, taken in blocks (``BLOCK``) and cell by cell
    (blocks of one): the same verdict, every cell proven hidden behind the solid wall and none
    with a window in line with the ball; behind the wall the blocks need fewer region proofs
    than the cells (each cell's is one at least)."""
    import fallgen.nav.hidden as hidden

    spec = AgentSpec()
    h = spec.camera_height_m
    scene, g, start, target, _ = _pen(h)
    ok = g.move_table(spec.radius_m)
    spacing = STEP_M / (STEP_SAMPLES - 1)
    calls = [0]
    region = hidden.hidden_from_cell

    def counted(*a):
        calls[0] += 1
        return region(*a)

    monkeypatch.setattr(hidden, "hidden_from_cell", counted)
    out = {}
    for window in (False, True):
        kernel = scene(window).kernel
        for block in (1, hidden.BLOCK):
            monkeypatch.setattr(hidden, "BLOCK", block)
            calls[0] = 0
            verdict = hidden.hidden_everywhere(ok, g.resolution, (start.x, start.y), target[:2],
                                               2.0, h, spacing, kernel)
            out[window, block] = verdict, calls[0]
    cells, by_cell = out[False, 1]
    assert cells is not None and cells >= 30 and by_cell >= cells
    assert out[False, hidden.BLOCK][0] == cells
    assert out[False, hidden.BLOCK][1] < by_cell / 2
    assert out[True, 1][0] is None and out[True, hidden.BLOCK][0] is None
