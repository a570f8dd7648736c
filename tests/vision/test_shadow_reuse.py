"""Colour draws of a still scene (fallgen.vision.gl): the light's shadow map drawn once and
kept, the geoms outside the view left out, depth read from the colour draw. Each gives the
pixels of a camera that draws everything anew (the code before the shortcuts)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fallgen.nav.agent import Pose
from fallgen.vision.camera import EgoCamera
from fallgen.world.scene import LOOK, PlacedObject, build_scene

VARIANT = "kitchen_dining-l1-m2"  # tiles, a rug under the table, the ceiling light's shadows


def _scene(world, pos=(3.0, 2.0, 0.05), settings=LOOK):
    inst = world.categories.instance("toaster", "steel", "metal/appliance")
    scene = build_scene(world.variant(VARIANT), world.materials,
                        [PlacedObject("target", inst, pos)], settings=settings)
    d = scene.data()
    mujoco.mj_forward(scene.model, d)
    return scene, d


def _poses(n: int, seed: int) -> list[Pose]:
    rng = np.random.default_rng(seed)
    return [Pose(float(rng.uniform(0.8, 5.5)), float(rng.uniform(0.6, 3.4)),
                 int(rng.integers(12)), int(rng.choice([-45, -30, -15, 0, 15])))
            for _ in range(n)]


def _anew(frames) -> None:
    """Every colour draw as before: the map drawn again, every geom drawn."""
    frames.reuse_shadow_map = frames.cull_colour = False


def test_a_kept_shadow_map_gives_the_pixels_of_one_drawn_anew(world):
    scene, d = _scene(world)
    cam, ref = EgoCamera(scene), EgoCamera(scene)
    _anew(ref.frames)
    f = cam.frames
    try:
        assert f._shadow_fbo, "the textured scene's light casts shadows"
        culled = 0
        for pose in _poses(40, 3):
            c = cam.camera(pose)
            ours = f.rgb(d, c)
            culled += int(f._culled)
            assert np.array_equal(ours, ref.frames.rgb(d, c)), pose
        # the map was kept (its depth pass drew into the 1 x 1 sink) and geoms were left out
        assert f._sink is not None and culled > 20, culled
    finally:
        cam.close()
        ref.close()


def test_a_moved_object_draws_the_map_again(world):
    """Moving the object changes its shadow: the next colour draw sees another state and draws
    the map again (the pixels of a camera that never kept one); the map kept from before the
    move would give other pixels (the check can fail)."""
    scene, d = _scene(world, pos=(3.4, 1.4, 0.05))
    pose = Pose(3.4, 2.9, 9, -45)  # north of the object, looking south and down at it
    cam, ref = EgoCamera(scene), EgoCamera(scene)
    _anew(ref.frames)
    f = cam.frames
    try:
        c = cam.camera(pose)
        before = f.rgb(d, c)
        assert np.array_equal(f.rgb(d, c), before)  # kept
        stale_state = f._shadow_state
        d.qpos[:3] = (3.0, 1.4, 0.05)  # the object's free joint: 0.4 m west
        mujoco.mj_forward(scene.model, d)
        moved = f.rgb(d, c)
        assert f._shadow_state != stale_state
        assert np.array_equal(moved, ref.frames.rgb(d, c))
        # the map of the old state kept by force: the old shadow, other pixels
        f.rgb(_at(scene, d, (3.4, 1.4, 0.05)), c)  # draws the old state's map
        f._shadow_state = f._static_state(d)
        stale = f.rgb(d, c)
        assert (stale != moved).any(axis=2).sum() > 100
    finally:
        cam.close()
        ref.close()


def _at(scene, d, xyz):
    """A copy of ``d`` with the object at ``xyz``."""
    e = mujoco.MjData(scene.model)
    e.qpos[:] = d.qpos
    e.qpos[:3] = xyz
    mujoco.mj_forward(scene.model, e)
    return e


def test_colour_depth_is_the_segmentation_pass_depth(world):
    scene, d = _scene(world)
    cam = EgoCamera(scene)
    f = cam.frames
    try:
        assert f.colour_depth_exact
        for pose in _poses(30, 4):
            c = cam.camera(pose)
            rgb, depth = f.rgb_and_depth(d, c)
            seg_depth, _ = f.depth_and_geoms(d, c)
            assert np.array_equal(depth, seg_depth), pose
            assert np.array_equal(rgb, f.rgb(d, c))
    finally:
        cam.close()


def test_see_through_geoms_keep_depth_in_its_own_pass(world):
    """A half-transparent geom stays out of a colour draw's depth: such a scene refuses to
    read depth from it, and its colour draws draw every geom."""
    scene, d = _scene(world)
    scene.model.geom_rgba[0, 3] = 0.5
    cam = EgoCamera(scene)
    f = cam.frames
    try:
        assert not f.colour_depth_exact
        c = cam.camera(Pose(3.0, 2.0, 0, 0))
        with pytest.raises(ValueError, match="depth_and_geoms"):
            f.rgb_and_depth(d, c)
        f.rgb(d, c)
        f.rgb(d, c)
        assert not f._culled
    finally:
        cam.close()
