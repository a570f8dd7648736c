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


# --- the expert ---------------------------------------------------------------------------


def _box(target, half: float = 0.01) -> np.ndarray:
    """The corners of a small box around ``target``: what bounds the object for the expert."""
    from fallgen.nav.occupancy import BOX_SIGNS

    return np.asarray(target, float) + half * BOX_SIGNS


def _unblocked(grid, p: Pose, target) -> bool:
    """No occupied cell on the floor-plan segment from the pose to the target (every 1 cm)."""
    a, b = p.xy, np.asarray(target, float)[:2]
    n = max(int(np.linalg.norm(b - a) / 0.01), 1)
    pts = a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)
    cells = np.floor(pts / grid.resolution).astype(int)
    inside = (cells >= 0).all(1) & (cells < np.array(grid.shape)).all(1)
    return not grid.occupied[cells[inside, 0], cells[inside, 1]].any()


def _sight(target, grid=None, share: float = 1.0, salt: int = 0):
    """A visibility verdict consistent with a camera: the target's centre strictly inside the
    view frustum, nothing on the floor-plan segment to it (with ``grid``), and then a random
    ``share`` of such poses (a hash of the pose and ``salt``)."""
    from tests_nav_brute import in_frustum

    def seen(p: Pose) -> bool:
        if not in_frustum(p, target) or (grid is not None and not _unblocked(grid, p, target)):
            return False
        if share >= 1.0:
            return True
        h = hash((round(p.x * 1e9), round(p.y * 1e9), p.heading, p.tilt_deg, salt))
        return (h % 1000) < share * 1000

    return seen


@pytest.fixture(autouse=True, scope="module")
def _brute_force_module():
    """tests/nav/brute_force.py importable as ``tests_nav_brute``."""
    import importlib.util
    import sys
    from pathlib import Path

    spec_ = importlib.util.spec_from_file_location(
        "tests_nav_brute", Path(__file__).with_name("brute_force.py"))
    module = importlib.util.module_from_spec(spec_)
    spec_.loader.exec_module(module)
    sys.modules["tests_nav_brute"] = module
    yield module
    del sys.modules["tests_nav_brute"]


def _check_against_brute_force(e, start, g, target, seen, brute, spec=AgentSpec()):
    moves, fewest = brute.optimum(start, g, target, seen, spec)
    assert (round(e.shortest_m / STEP_M), e.fewest_actions) == (moves, fewest)
    o = run(start, e.plan.actions, g, target, seen, spec)
    assert o.success and o.path_m == e.shortest_m and o.spl(e.shortest_m) == 1.0
    assert len(e.plan.actions) >= e.fewest_actions


def test_expert_references_are_the_brute_force_optimum_on_small_maps(_brute_force_module,
                                                                    monkeypatch):
    """On small cluttered maps, the object 2.3-3.3 m from the start, with verdicts that a wall
    blocks and that hold on random shares of the poses, the expert's l and n* equal a
    breadth-first search over every pose of the unmerged lattice (tests/nav/brute_force.py),
    and its plan reaches l exactly. (Three tilts, so that the brute force stays quick.)"""
    rng = np.random.default_rng(12)
    spec = AgentSpec(tilt_min_deg=-15, tilt_max_deg=15)
    compared, refuted, moves = 0, 0, []
    while compared < 14:
        g, free = _cluttered(rng, (int(rng.integers(34, 44)), int(rng.integers(30, 40))),
                             int(rng.integers(0, 6)), 5)
        a, b = free[rng.choice(len(free), 2, replace=False)]
        if not 23 <= np.linalg.norm(a - b) <= 33:
            continue
        start = Pose(float((a[0] + rng.uniform(0.2, 0.8)) * 0.1),
                     float((a[1] + rng.uniform(0.2, 0.8)) * 0.1), int(rng.integers(12)),
                     int(rng.choice([0, -15, 15])))
        target = np.array([(b[0] + 0.5) * 0.1, (b[1] + 0.5) * 0.1, rng.uniform(0.3, 1.8)])
        seen = _sight(target, g if compared % 2 else None, 1.0 if compared % 3 else 0.3,
                      compared)
        try:
            e = expert(start, g, target, _box(target), seen, spec)
        except NoPath:
            assert _brute_force_module.optimum(start, g, target, seen, spec) == (None, None)
            continue
        _check_against_brute_force(e, start, g, target, seen, _brute_force_module, spec)
        compared += 1
        moves.append(round(e.shortest_m / STEP_M))
        # the check fails for a search whose goals stop 10 cm short of the judge's reach
        with monkeypatch.context() as m:
            m.setattr("fallgen.nav.expert.SUCCESS_DISTANCE_M", 1.9)
            short = expert(start, g, target, _box(target), seen, spec)
        if (short.shortest_m, short.fewest_actions) != (e.shortest_m, e.fewest_actions):
            with pytest.raises(AssertionError):
                _check_against_brute_force(short, start, g, target, seen,
                                           _brute_force_module, spec)
            refuted += 1
    assert min(moves) >= 1 and max(moves) >= 4, moves  # real paths, not claims on the spot
    assert refuted >= 5, refuted


def test_an_object_in_view_within_reach_needs_no_action_but_found():
    """An object on the floor 1.9 m ahead is in the 90 degree view at tilt 0: the optimum is
    ``found`` alone (no tilt toward the object's centre is needed)."""
    target = (2.5, 1.0, 0.02)
    start = Pose(0.6, 1.0, 0)
    seen = _sight(target)
    assert seen(start)
    e = expert(start, EMPTY, target, _box(target), seen)
    assert e.plan.actions == (FOUND,) and e.fewest_actions == 1 and e.shortest_m == 0.0


def test_expert_tilts_down_to_an_object_at_its_feet():
    """0.6 m ahead on the floor the object is 61 degrees below the horizon: out of the view
    at tilt 0 and -15, in it at -30: two ``look_down``, no move (fewest moves first)."""
    target = (1.2, 1.0, 0.02)
    start = Pose(0.6, 1.0, 0)
    e = expert(start, EMPTY, target, _box(target), _sight(target))
    assert e.plan.actions == (DOWN, DOWN, FOUND) and e.plan.goal.tilt_deg == -30
    assert e.fewest_actions == 3


def test_expert_goes_around_an_obstacle_and_scores_one():
    target = (5.0, 1.0, 0.05)
    start = Pose(2.0, 1.0, 0)
    seen = _sight(target, WALLED)
    e = expert(start, WALLED, target, _box(target), seen)
    o = run(start, e.plan.actions, WALLED, target, seen)
    assert o.success and o.spl(e.shortest_m) == 1.0  # exactly
    assert e.plan.actions[-1] == FOUND and o.visible is True
    # it had to pass the partition's open end (y > 3 m), its every step free for the robot
    assert max(p.y for p in o.poses) > 3.0 - 0.5
    assert all(WALLED.free_for(p.xy[None], 0.2)[0] for p in o.poses)


def test_the_second_search_takes_the_firsts_occlusion_verdicts(monkeypatch):
    """Both searches of the expert ask about the same positions: a position the first found
    hidden (``unseen``) is not asked about again by the fewest-actions search, and the
    references are those of searches that ask afresh (which ask again about some)."""
    from fallgen.nav.lattice import Lattice

    target = (5.0, 1.0, 0.05)
    start = Pose(2.0, 1.0, 0)
    seen = _sight(target, WALLED)
    searches: list[set] = []  # the hidden positions each search asked about
    init = Lattice.__init__

    def counted_init(self, **kw):
        searches.append(set())
        init(self, **kw)

    def unseen(p):  # hidden from the far side's upper half, met on the way round
        hidden = p.y > 1.5
        if hidden:
            searches[-1].add((round(p.x, 9), round(p.y, 9)))
        return hidden

    monkeypatch.setattr(Lattice, "__init__", counted_init)
    e = expert(start, WALLED, target, _box(target), seen, unseen=unseen)
    assert len(searches) == 2 and searches[0] and not searches[0] & searches[1]
    searches.clear()
    with monkeypatch.context() as m:
        m.setattr(Lattice, "know_positions", lambda self, keys, vals: None)
        fresh = expert(start, WALLED, target, _box(target), seen, unseen=unseen)
    assert searches[0] & searches[1]  # without the hand-over, asked by both searches
    assert (e.shortest_m, e.fewest_actions, e.plan) == \
        (fresh.shortest_m, fresh.fewest_actions, fresh.plan)


def test_expert_gives_up_within_its_limits_and_fails_cleanly():
    """Verdicts that never hold: the exact lattice never runs out (its positions are dense),
    so the search stops at its limits with SearchLimit (a NoPath)."""
    from fallgen.nav.expert import Limits, SearchLimit

    target = (5.0, 1.0, 0.05)
    calls = []

    def never(p):
        calls.append(p)
        return False

    with pytest.raises(SearchLimit):
        expert(Pose(1.0, 1.0, 0), WALLED, target, _box(target), never,
               limits=Limits(verdicts=500))
    assert 500 <= len(calls) <= 520  # the candidates' views were asked, then it stopped
    with pytest.raises(SearchLimit):
        expert(Pose(1.0, 1.0, 0), WALLED, target, _box(target), never,
               limits=Limits(states=50_000))


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
            e = expert(start, g, target, _box(target), _sight(target, g))
        except NoPath:
            continue
        pose = start
        for act in e.plan.actions:
            pose, moved = step(pose, act, g)
            assert moved, "a planned action was blocked"
        assert pose == e.plan.goal
        checked += 1
    assert checked >= 20


def test_lattice_keys_positions_exactly_whatever_the_order():
    """Two move orders that reach one point share its lattice key; points a fraction of a
    step apart (which 5 cm bins would merge) do not."""
    from fallgen.nav.lattice import LATTICE_STEPS, pack

    def key(headings, final=0):
        c = np.zeros(4, np.int64)
        x = np.zeros(2)
        for k in headings:
            c += LATTICE_STEPS[k]
            x = x + STEP_M * np.array([math.cos(math.radians(30 * k)),
                                       math.sin(math.radians(30 * k))])
        return int(pack(*c.tolist(), final, 12)), x

    k1, x1 = key([0, 2, 4, 1])
    k2, x2 = key([4, 1, 0, 2])
    assert k1 == k2 and np.allclose(x1, x2, atol=1e-12)
    # 0 then 1 then 11 against 0 twice: 2 cos(30) * 0.25 = 0.433 vs 0.5, 6.7 cm apart
    k3, x3 = key([0, 1, 11])
    k4, x4 = key([0, 0, 0])
    assert k3 != k4 and 0.05 < np.linalg.norm(x3 - x4) < 0.1
    # every step's lattice coordinates are its float step, exactly
    for k in range(12):
        a, b, c, d = LATTICE_STEPS[k].tolist()
        want = STEP_M * np.array([math.cos(math.radians(30 * k)), math.sin(math.radians(30 * k))])
        assert np.allclose([(a + b * math.sqrt(3)) / 8, (c + d * math.sqrt(3)) / 8], want,
                           atol=1e-15)
