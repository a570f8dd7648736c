"""Occupancy, the action simulator, the metrics and the expert planner (fallgen.nav)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from fallgen.nav.agent import (DOWN, FORWARD, FOUND, LEFT, MAX_ACTIONS, RIGHT, STEP_M, UP,
                               AgentSpec, Pose, run, step)
from fallgen.nav.expert import NoPath, expert
from fallgen.nav.occupancy import OccupancyGrid, occupancy
from fallgen.world.scene import build_scene


def grid_from(occ, r=0.1):
    padded = np.pad(occ, 1, constant_values=True)
    d = distance_transform_edt(~padded)[1:-1, 1:-1] * r
    cl = np.maximum(d - r / 2, 0)
    cl[occ] = 0
    return OccupancyGrid(occ, r, cl)


EMPTY = grid_from(np.zeros((60, 40), bool))  # a 6 x 4 m empty room
WALL = np.zeros((60, 40), bool)
WALL[30:32, 0:30] = True  # a partition at x = 3.0-3.2 m, from y = 0 to 3 m
WALLED = grid_from(WALL)
ALWAYS = (lambda p: True)


def test_room_occupancy_marks_furniture_and_keeps_aisles(world):
    v = world.variant("kitchen_galley-l1-m1")
    g = occupancy(build_scene(v, world.materials, []))
    assert g.shape == (64, 36)
    for item in v.furniture:
        x, y, z = item.pose[:3]
        i, j = g.cell((x, y))
        r = int(np.ceil(max(item.size[:2]) / 2 / g.resolution)) + 1
        near = g.occupied[max(i - r, 0):i + r + 1, max(j - r, 0):j + r + 1]
        if z >= 1.2:  # a wall cabinet above the robot's height is no obstacle itself
            continue
        if item.type in ("basket", "box"):  # open containers: their walls, not the inside
            assert near.any(), item.id
        else:
            assert g.occupied[i, j], item.id
    assert 0.1 < g.occupied.mean() < 0.6
    assert (g.clearance >= 0.25).sum() > 200  # room to drive
    assert g.clearance[0].max() <= 0.1  # next to the west wall


def test_a_plants_foliage_is_an_obstacle(world):
    """A plant's foliage collides with nothing, but the robot cannot drive through it: the
    grid marks the cells under the leaves beyond the pot."""
    v = world.variant("study_lounge-l1-m1")
    scene = build_scene(v, world.materials, [])
    m = scene.model
    plant = next(it for it in v.furniture if it.id == "plant1")
    leaves = [g for g in range(m.ngeom) if scene.geom_owner[g] == "plant1"
              and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_ELLIPSOID]
    assert leaves and all(m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0 for g in leaves)
    g = occupancy(scene)
    x, y = plant.pose[:2]
    pot_r = next(p for p in plant.parts if p.name == "pot").box.half[0]
    # a point under the foliage, outside the pot (toward the room, away from the wall)
    out = np.array([x, y]) + (pot_r + 0.06) * np.array(
        [math.sin(plant.pose[3]), -math.cos(plant.pose[3])])
    assert g.occupied[g.cell(out)]


def test_room_layer_plus_objects_is_the_whole_grid(world):
    """The per-variant room layer (room_samples) with only the objects rasterised on top gives
    exactly the grid of rasterising everything, for scenes with objects on the floor."""
    from fallgen.nav.occupancy import room_samples
    from fallgen.world.scene import PlacedObject

    rng = np.random.default_rng(0)
    for vid in ("kitchen_galley-l1-m1", "study_office-l2-m1"):
        v = world.variant(vid)
        toaster = world.categories.instance("toaster", "steel", "metal/appliance")
        objs = [PlacedObject(f"d{k}", toaster,
                             (float(rng.uniform(0.5, v.size_m[0] - 0.5)),
                              float(rng.uniform(0.5, v.size_m[1] - 0.5)), 0.2), free=False)
                for k in range(4)]
        scene = build_scene(v, world.materials, objs)
        d = scene.data()
        import mujoco

        mujoco.mj_forward(scene.model, d)
        whole = occupancy(scene, d, band_high_m=1.0)
        layered = occupancy(scene, d, band_high_m=1.0,
                            static=room_samples(scene, d, band_high_m=1.0))
        bare = occupancy(scene, d, band_high_m=1.0, skip=("agent", "obj:"))
        assert np.array_equal(whole.occupied, layered.occupied)
        assert np.array_equal(whole.clearance, layered.clearance)
        assert (whole.occupied & ~bare.occupied).any()  # the objects did add cells


def test_objects_of_a_view_scene_occupy_their_visual_boxes(world):
    """An episode's settled room (VIEW: no collision pieces) rasterises each object's visual
    geom instead of its collision pieces: the same cells or a little more (a jug's box)."""
    import mujoco

    from fallgen.world.scene import VIEW, PlacedObject

    rng = np.random.default_rng(1)
    v = world.variant("kitchen_galley-l1-m1")
    for cat, variant, material in (("toaster", "steel", "metal/appliance"), ("jug", None, None)):
        c = world.categories[cat]
        variant = variant or c.variants[0].name
        material = material or next(iter(c.variants[0].materials))
        objs = [PlacedObject(f"d{k}", world.categories.instance(cat, variant, material),
                             (float(rng.uniform(0.5, v.size_m[0] - 0.5)),
                              float(rng.uniform(0.5, v.size_m[1] - 0.5)), 0.2), free=False)
                for k in range(4)]
        grids = []
        for settings in (VIEW, None):
            scene = build_scene(v, world.materials, objs, **({"settings": settings}
                                                             if settings else {}))
            names = [scene.model.geom(g).name for g in range(scene.model.ngeom)]
            assert any("/c" in n for n in names if n.startswith("obj:")) == (settings is None)
            d = scene.data()
            mujoco.mj_forward(scene.model, d)
            grids.append(occupancy(scene, d, band_high_m=1.0).occupied)
        bare = occupancy(scene, d, band_high_m=1.0, skip=("agent", "obj:")).occupied
        view, full = grids
        objects_view, objects_full = view & ~bare, full & ~bare
        assert objects_view.sum() > 0 and objects_full.sum() > 0
        # the visual box holds the pieces: every cell they cover, and at most one more each
        assert not (objects_full & ~objects_view).any(), cat
        assert (objects_view & ~objects_full).sum() <= len(objs), cat


def test_rotations_are_exact_and_tilt_is_limited():
    p = Pose(1.0, 1.0, 0)
    for _ in range(12):
        p, ok = step(p, LEFT, EMPTY)
        assert ok
    assert p == Pose(1.0, 1.0, 0)
    p, _ = step(p, RIGHT, EMPTY)
    assert p.heading == 11 and math.isclose(p.yaw_rad, math.radians(330))
    spec = AgentSpec()
    for _ in range(10):
        p, _ = step(p, DOWN, EMPTY)
    assert p.tilt_deg == spec.tilt_min_deg
    p, ok = step(p, DOWN, EMPTY)
    assert not ok and p.tilt_deg == spec.tilt_min_deg


def test_forward_moves_and_collisions_stop_motion():
    p, ok = step(Pose(1.0, 1.0, 0), FORWARD, EMPTY)
    assert ok and p.x == pytest.approx(1.0 + STEP_M) and p.y == pytest.approx(1.0)
    p, ok = step(Pose(1.0, 1.0, 2), FORWARD, EMPTY)  # 60 degrees
    assert p.x == pytest.approx(1.0 + STEP_M / 2) and p.y == pytest.approx(1.0 + STEP_M * 3 ** .5 / 2)
    # facing the partition 0.35 m away: the robot (radius 0.2) cannot close the gap to it
    start = Pose(2.6, 1.0, 0)
    p, ok = step(start, FORWARD, WALLED)
    assert not ok and p == start
    # walls of the room stop it too
    p, ok = step(Pose(0.3, 1.0, 6), FORWARD, EMPTY)
    assert not ok and p.x == 0.3


def test_spl_and_sna_of_hand_made_sequences():
    target = (3.0, 1.0, 0.0)
    start = Pose(0.5, 1.0, 0)
    # 4 forward (1 m), found: 1.5 m away, visible -> success
    o = run(start, [FORWARD] * 4 + [FOUND], EMPTY, target, ALWAYS)
    assert o.success and o.n_actions == 5 and o.path_m == pytest.approx(1.0)
    assert o.distance_m == pytest.approx(1.5)
    # with l = 0.75 m and n* = 4: SPL = 0.75 / 1.0, SNA = 4 / 5
    assert o.spl(0.75) == pytest.approx(0.75) and o.sna(4) == pytest.approx(0.8)
    # a detour: left, 2 forward, right... found while 2.5 m away: failure, SPL = SNA = 0
    o = run(start, [LEFT, FORWARD, RIGHT, FOUND], EMPTY, target, ALWAYS)
    assert not o.success and o.spl(0.75) == 0.0 and o.sna(4) == 0.0
    # close enough but the object is not in view: failure
    o = run(start, [FORWARD] * 4 + [FOUND], EMPTY, target, lambda p: False)
    assert o.found_called and not o.success
    # no found within the limit: failure, counted up to MAX_ACTIONS
    o = run(start, [LEFT] * 300, EMPTY, target, ALWAYS)
    assert not o.success and o.n_actions == MAX_ACTIONS and not o.found_called


def test_walk_judges_one_action_at_a_time_with_claims():
    from fallgen.nav.agent import Walk

    target = (3.0, 1.0, 0.0)
    start = Pose(0.5, 1.0, 0)
    # a wrong claim with one allowed ends the episode: outcome wrong_found
    w = Walk(start, EMPTY, target, ALWAYS)
    assert w.act(FOUND) and w.done and not w.success
    assert w.outcome().kind == "wrong_found" and w.outcome().claims == 1
    with pytest.raises(RuntimeError):
        w.act(FORWARD)
    # two claims (the original challenge): the first fails, the second, in reach, succeeds
    w = Walk(start, EMPTY, target, ALWAYS, claims=2)
    w.act(FOUND)
    assert not w.done
    for _ in range(4):
        w.act(FORWARD)
    w.act(FOUND)
    o = w.outcome()
    assert w.done and o.success and o.kind == "found" and o.claims == 2 and o.n_actions == 6
    assert o.path_m == 1.0  # exactly: STEP_M per move made
    # run() is a Walk fed the sequence: the same outcome
    assert run(start, [FOUND] + [FORWARD] * 4 + [FOUND], EMPTY, target, ALWAYS, claims=2) == o
    # a blocked move adds nothing to the path; the limit ends with outcome timeout
    w = Walk(Pose(0.3, 1.0, 6), EMPTY, target, ALWAYS, max_actions=3)
    assert not w.act(FORWARD) and w.path_m == 0.0
    w.act(LEFT), w.act(LEFT)
    assert w.done and w.outcome().kind == "timeout"
    # the visibility test is asked only for a claim within reach
    asked = []
    w = Walk(start, EMPTY, target, lambda p: asked.append(p) or True)
    w.act(FOUND)
    assert asked == [] and not w.success
    with pytest.raises(ValueError):
        Walk(start, EMPTY, target, ALWAYS, claims=0)


def test_expert_goes_around_an_obstacle_and_scores_one():
    target = (5.0, 1.0, 0.05)
    start = Pose(1.0, 1.0, 0)
    e = expert(start, WALLED, target, ALWAYS, ALWAYS)
    o = run(start, e.plan.actions, WALLED, target, ALWAYS)
    assert o.success and o.spl(e.shortest_m) == 1.0  # exactly
    assert o.sna(e.fewest_actions) > 0.8
    assert e.plan.actions[-1] == FOUND
    # it had to pass the partition's open end (y > 3 m)
    assert max(p.y for p in o.poses) > 3.0 - 0.5
    # every step of the way is free for the robot
    assert all(WALLED.free_for(p.xy[None], 0.2)[0] for p in o.poses)


def test_expert_tilts_down_to_an_object_at_its_feet():
    target = (2.0, 1.0, 0.02)
    e = expert(Pose(0.6, 1.0, 0), EMPTY, target, ALWAYS, ALWAYS)
    assert DOWN in e.plan.actions and UP not in e.plan.actions
    assert e.plan.goal.tilt_deg < 0


def test_expert_uses_the_renderer_verdict_and_fails_cleanly():
    target = (5.0, 1.0, 0.05)
    calls = []

    def never(p):
        calls.append(p)
        return False

    with pytest.raises(NoPath):
        expert(Pose(1.0, 1.0, 0), WALLED, target, ALWAYS, never)
    assert calls  # candidates were rendered and all refused


def _cluttered(rng, shape: tuple[int, int], boxes: int, side: int):
    """A walled grid of ``shape`` cells with ``boxes`` random boxes (and thin legs) of sides
    below ``side`` cells at off-grid places, and its cells with 0.3 m of clearance."""
    occ = np.zeros(shape, bool)
    occ[[0, -1], :] = occ[:, [0, -1]] = True
    for _ in range(boxes):
        x, y = rng.integers(2, shape[0] - 4), rng.integers(2, shape[1] - 4)
        occ[x:x + rng.integers(1, side), y:y + rng.integers(1, side)] = True
    g = grid_from(occ)
    return g, np.argwhere(g.clearance >= 0.3)


def test_expert_plans_execute_exactly_in_cluttered_rooms():
    """The planner checks forward moves with the simulator's own points (a disagreement once made
    an expert walk into a table corner: blocked moves, object out of view). In random clutter,
    every expert plan executes with every forward move taken and ends where it planned."""
    rng = np.random.default_rng(4)
    checked = 0
    for _ in range(40):
        g, free = _cluttered(rng, (50, 40), 12, 5)
        if len(free) < 2:
            continue
        a, b = free[rng.choice(len(free), 2, replace=False)]
        start = Pose(float((a[0] + rng.uniform(0.3, 0.7)) * 0.1),
                     float((a[1] + rng.uniform(0.3, 0.7)) * 0.1), int(rng.integers(12)))
        target = ((b[0] + 0.5) * 0.1, (b[1] + 0.5) * 0.1, 0.4)
        try:
            e = expert(start, g, target, ALWAYS, ALWAYS)
        except NoPath:
            continue
        pose = start
        for act in e.plan.actions:
            pose, moved = step(pose, act, g)
            assert moved or act in (UP, DOWN), "a planned move was blocked"
        assert (pose.x, pose.y, pose.heading) == (e.plan.goal.x, e.plan.goal.y,
                                                  e.plan.goal.heading)
        checked += 1
    assert checked >= 20


def _one_pose_tilt_steps(pose, target, spec):
    """The tilt rule for one pose, spelled out: the tilt nearest the object's elevation within
    the vertical field of view less the margin (the lowest on ties), None if there is none."""
    from fallgen.nav.expert import FOV_DEG, MARGIN_DEG

    d = float(np.hypot(target[0] - pose.x, target[1] - pose.y))
    elev = math.degrees(math.atan2(target[2] - spec.camera_height_m, max(d, 1e-6)))
    best = None
    for t in range(spec.tilt_min_deg, spec.tilt_max_deg + 1, spec.tilt_step_deg):
        if abs(elev - t) <= FOV_DEG / 2 - MARGIN_DEG and (
                best is None or abs(elev - t) < abs(elev - best)):
            best = t
    return None if best is None else (best - pose.tilt_deg) // spec.tilt_step_deg


def test_compiled_tilt_choice_and_free_lookup_match_their_references():
    """The compiled search's scalar forms agree exactly with one-pose definitions: the tilt
    rule spelled out for one pose, and OccupancyGrid.free_for (the simulator's check)."""
    from fallgen.nav.expert import FOV_DEG, MARGIN_DEG
    from fallgen.nav.lattice import NO_TILT, free_at, tilt_step

    rng = np.random.default_rng(7)
    spec = AgentSpec()
    for tilt in (0, -15, 30):
        target = np.array([3.0, 2.0, rng.uniform(0.0, 2.5)])
        xy = rng.uniform(0.0, 6.0, (400, 2))
        dist = np.hypot(target[0] - xy[:, 0], target[1] - xy[:, 1])
        dist[:3] = 0.0  # straight below or above
        for d in dist.tolist():
            g = tilt_step(d, target[2], spec.camera_height_m, tilt, spec.tilt_min_deg,
                          spec.tilt_max_deg, spec.tilt_step_deg, FOV_DEG / 2 - MARGIN_DEG)
            p = Pose(float(target[0] - d), float(target[1]), 0, tilt)  # same distance
            want = _one_pose_tilt_steps(p, target, spec)
            assert (g == NO_TILT) if want is None else g == want
    ok = np.full((WALLED.shape[0] + 2, WALLED.shape[1] + 2), False)
    ok[1:-1, 1:-1] = WALLED.clearance >= 0.2
    pts = rng.uniform(-1.0, 7.0, (5000, 2))
    pts[:50] = np.round(pts[:50] / 0.1) * 0.1  # on cell edges
    got = [free_at(ok, WALLED.resolution, WALLED.shape[0] + 1, WALLED.shape[1] + 1, x, y)
           for x, y in pts.tolist()]
    assert np.array_equal(got, WALLED.free_for(pts, 0.2))


def test_compiled_search_makes_the_plans_of_its_numpy_reference():
    """The compiled lattice search (fallgen.nav.lattice) against the vectorised NumPy search
    it replaced (tests/nav/numpy_search.py), in random clutter with arbitrary line-of-sight
    and visibility verdicts, both cost settings: the same actions, goal, path length, renders
    and total cost, and the same refusals."""
    import importlib.util
    from pathlib import Path

    from fallgen.nav.expert import _search

    spec_ = importlib.util.spec_from_file_location(
        "numpy_search", Path(__file__).with_name("numpy_search.py"))
    module = importlib.util.module_from_spec(spec_)
    spec_.loader.exec_module(module)
    reference = module.search

    rng = np.random.default_rng(11)
    spec = AgentSpec()
    compared = nopath = 0
    for trial in range(60):
        shape = (int(rng.integers(30, 70)), int(rng.integers(30, 70)))
        g, free = _cluttered(rng, shape, int(rng.integers(0, 16)), 6)
        if len(free) < 2:
            continue
        a, b = free[rng.choice(len(free), 2, replace=False)]
        start = Pose(float((a[0] + rng.uniform(0.2, 0.8)) * 0.1),
                     float((a[1] + rng.uniform(0.2, 0.8)) * 0.1), int(rng.integers(12)),
                     int(rng.choice([0, -15, 15])))
        target = np.array([(b[0] + 0.5) * 0.1, (b[1] + 0.5) * 0.1, rng.uniform(0.0, 2.0)])
        salt, p_los = int(rng.integers(1 << 30)), rng.uniform(0.2, 1.0)
        p_vis = rng.uniform(0.02, 1.0) if trial % 8 else 0.0  # never: refusals only

        def verdict(p: Pose, share: float, extra: int, salt: int = salt) -> bool:
            h = hash((round(p.x * 1e9), round(p.y * 1e9), p.heading, p.tilt_deg, salt, extra))
            return (h % 1000) < share * 1000

        def los(p: Pose, share: float = p_los) -> bool:
            return verdict(Pose(p.x, p.y, 0), share, 1)

        def vis(p: Pose, share: float = p_vis) -> bool:
            return verdict(p, share, 2)

        view = float(rng.choice([math.inf, 2.5, 1.2, 0.5]))  # 0.5: no candidate at all
        for costs in ((1000, 1), (1, 1)):
            try:
                plan, total = _search(start, g, target, spec, *costs, los, vis, view)
            except NoPath as e:
                with pytest.raises(NoPath) as ref_e:
                    reference(start, g, target, spec, *costs, los, vis, view)
                assert str(ref_e.value) == str(e)
                nopath += 1
                continue
            want = reference(start, g, target, spec, *costs, los, vis, view)
            assert (plan.actions, plan.goal, plan.path_m, plan.renders, total) == want, trial
            compared += 1
    assert compared >= 50 and nopath >= 3, (compared, nopath)


def test_lattice_ring_too_short_is_an_error_not_a_wrong_plan():
    """The bucket ring holds one slot per cost over a move and a turn; with fewer, two live
    costs would share a slot: the search stops with an error instead of mixing them."""
    from fallgen.nav.agent import HEADING_VECTORS, STEP_FRACTIONS, TURN_DEG
    from fallgen.nav.expert import BIN_M
    from fallgen.nav.lattice import Lattice

    spec = AgentSpec()
    g = EMPTY
    nbx = math.ceil(g.shape[0] * g.resolution / BIN_M) + 1
    nby = math.ceil(g.shape[1] * g.resolution / BIN_M) + 1
    ok = np.zeros((g.shape[0] + 2, g.shape[1] + 2), bool)
    ok[1:-1, 1:-1] = g.clearance >= spec.radius_m

    def lattice(ring: int | None) -> Lattice:
        lat = Lattice(size=nbx * nby * 12, nby=nby, ok=ok, resolution=g.resolution, bin_m=BIN_M,
                      step_m=STEP_M, step_fractions=STEP_FRACTIONS,
                      heading_vectors=HEADING_VECTORS, turn_deg=TURN_DEG,
                      target=np.array([5.5, 3.5, 0.4]), camera_height_m=spec.camera_height_m,
                      reach_m=1.9, max_view_m=math.inf, half_fov_deg=35.0, move_cost=1000,
                      turn_cost=1, tilt_deg=0, tilt_min_deg=spec.tilt_min_deg,
                      tilt_max_deg=spec.tilt_max_deg, tilt_step_deg=spec.tilt_step_deg,
                      actions=(FORWARD, LEFT, RIGHT))
        if ring is not None:
            lat._head = np.full(ring, -1, np.int64)
        lat.start(0.5, 0.5, 0)
        return lat

    assert len(lattice(None).advance()) > 0  # candidates near the far corner
    with pytest.raises(RuntimeError, match="share a bucket"):
        lattice(7).advance()
