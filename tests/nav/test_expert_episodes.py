"""The expert's references on built episodes against brute force: on the tiny build, the
stored l (shortest_path_m) and n* (fewest_actions), and the expert's answers from poses along
its own path, equal a breadth-first search over every pose of the unmerged lattice that asks
the renderer itself (no occlusion bound) about every claim."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from fallgen.nav.agent import STEP_M, VISIBLE_PIXELS, AgentSpec, Pose

#: Brute force is quick only for short optima: the forward moves it may have to prove absent.
MAX_MOVES = 3


def _brute():
    spec = importlib.util.spec_from_file_location("nav_brute_force",
                                                  Path(__file__).with_name("brute_force.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.xdist_group("tiny_build")
def test_stored_references_equal_brute_force_on_tiny_build_episodes(tiny_dataset, world):
    import fallgen.dataset
    from fallgen.env.source import EpisodeSource
    from fallgen.pipeline.settled import SettledRoom
    from fallgen.vision.camera import WIDTH, world_category_labels
    from fallgen.vision.gl import GLContext

    brute = _brute()
    ds = fallgen.dataset.open(tiny_dataset)
    source = EpisodeSource(ds)
    appearance = bool(ds.generate_settings().get("appearance", False))
    labels = world_category_labels(world)
    spec = AgentSpec()
    gl = GLContext(WIDTH)
    stored = fresh = 0
    try:
        for eid in ds.ids(None, None, None):
            ep = source.load(eid)
            room = SettledRoom(world, ep.event, gl, labels, spec, appearance=appearance)
            try:
                def renderer(p: Pose, room=room) -> bool:
                    return room.camera.shows(room.data, p, VISIBLE_PIXELS)

                row = ep.row
                if round(row["shortest_path_m"] / STEP_M) <= MAX_MOVES:
                    moves, fewest = brute.optimum(ep.spawn, room.grid, room.centre, renderer)
                    assert (moves * STEP_M, fewest) == (row["shortest_path_m"],
                                                       row["fewest_actions"]), eid
                    stored += 1
                # from poses along the expert's path, once few moves are left
                poses = [Pose(x, y, int(h), int(t)) for x, y, h, t in row["expert_poses"]]
                moves_left = [sum(a == 0 for a in row["expert_actions"][i:])
                              for i in range(len(poses))]
                picks = [i for i, m in enumerate(moves_left) if 1 <= m <= MAX_MOVES][:2]
                for i in picks:
                    start = Pose(poses[i].x, poses[i].y, poses[i].heading, 0)
                    ex = room.expert(start)
                    want = brute.optimum(start, room.grid, room.centre, renderer)
                    assert (round(ex.shortest_m / STEP_M), ex.fewest_actions) == want, (eid, i)
                    fresh += 1
            finally:
                room.close()
    finally:
        gl.close()
    assert stored + fresh >= 6, (stored, fresh)
