"""Line of sight (fallgen.vision.sight): the slab test against analytic cases, and the verdict
against casting every ray, in a furnished room with the target in every fall zone."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from fallgen.nav.agent import AgentSpec
from fallgen.nav.occupancy import BOX_SIGNS
from fallgen.pipeline.settled import target_box as _target_box
from fallgen.vision import sight
from fallgen.vision.sight import DRAWN_GROUPS, box_entries, line_of_sight
from fallgen.world.scene import PlacedObject, build_scene


def _entries(eye, unit, lo, hi, rot=None, centre=None):
    out = np.empty(len(unit))
    box_entries(np.asarray(eye, float), np.asarray(unit, float), np.asarray(lo, float),
                np.asarray(hi, float), np.eye(3) if rot is None else rot,
                np.zeros(3) if centre is None else centre, out)
    return out


def test_box_entries_analytic():
    lo, hi = [1.0, -1.0, -1.0], [3.0, 1.0, 1.0]
    s = 1 / math.sqrt(2)
    got = _entries([0, 0, 0], [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [s, s, 0]], lo, hi)
    assert got[0] == 1.0  # straight at the near face
    assert got[1] == math.inf  # away from it (the box is behind the eye)
    assert got[2] == math.inf  # parallel to the x slab, outside it
    assert got[3] == pytest.approx(math.sqrt(2))  # enters through the near face at (1, 1)
    inside = _entries([2, 0, 0], [[1, 0, 0], [0, 0, 1]], lo, hi)
    assert (inside <= 0).all()
    # an oriented box: the same box turned 90 degrees about z and moved to (0, 5, 0)
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # columns: its axes
    got = _entries([0, 0, 0], [[0, 1, 0]], [-1, -1, -1], [1, 1, 1], rot, np.array([0, 5.0, 0]))
    assert got[0] == pytest.approx(4.0)


def _every_ray(model, data, owners, eye, points):
    """The reference: cast every ray."""
    gid = np.zeros(1, np.int32)
    for p in points:
        v = p - eye
        d = float(np.sqrt((v * v).sum()))
        h = mujoco.mj_ray(model, data, eye, v / d, DRAWN_GROUPS, 1, -1, gid)
        if h < 0 or h >= d or owners[int(gid[0])] == "obj:target":
            return True
    return False


@pytest.mark.parametrize("variant_id", ["kitchen_galley-l1-m1", "study_office-l1-m1"])
def test_verdict_is_that_of_every_ray(world, variant_id, monkeypatch):
    """With the target in each fall zone (and a mesh distractor beside it), from random eyes
    across the room: the same verdict as casting all nine rays, with fewer casts."""
    rng = np.random.default_rng(5)
    v = world.variant(variant_id)
    lx, ly, _ = v.size_m
    cup = world.categories.instance("cup", "mug", "ceramic")
    book = world.categories.instance("book", world.categories.categories["book"].variants[0].name,
                                     next(iter(world.categories.categories["book"]
                                               .variants[0].materials)))
    casts = [0]
    cast = mujoco.mj_ray

    def counted(*a):
        casts[0] += 1
        return cast(*a)

    monkeypatch.setattr(sight.mujoco, "mj_ray", counted)
    verdicts, blocked, blocked_casts = [], 0, 0
    for zone in v.zones:
        c = zone.volume.center
        pos = (float(c[0]), float(c[1]), float(zone.volume.zmin) + 0.03)
        objs = [PlacedObject("target", cup, pos, free=False),
                PlacedObject("d0", book, (pos[0] + 0.15, pos[1], pos[2] + 0.05), free=False)]
        scene = build_scene(v, world.materials, objs)
        d = scene.data()
        mujoco.mj_forward(scene.model, d)
        m = scene.model
        lo, hi = _target_box(scene, d)
        centre = (lo + hi) / 2
        points = np.vstack([centre, centre + 0.75 * BOX_SIGNS * (hi - lo) / 2])
        for _ in range(40):
            eye = np.array([rng.uniform(0.2, lx - 0.2), rng.uniform(0.2, ly - 0.2),
                            AgentSpec().camera_height_m])
            ref = _every_ray(m, d, scene.geom_owner, eye, points)
            before = casts[0]
            got = line_of_sight(m, d, scene.geom_owner, eye, points, (lo, hi))
            assert got == ref, (zone.id, eye)
            verdicts.append(got)
            if not got:
                blocked += 1
                blocked_casts += casts[0] - before
    assert 0.1 < np.mean(verdicts) < 0.9
    assert blocked_casts < 0.5 * len(points) * blocked  # most blocked rays are not cast
