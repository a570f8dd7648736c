"""How the rooms look (issue 29): textured surfaces and furniture at their real size and a
shadow-casting ceiling light in the scenes that are rendered, with the segmentation and depth
of the flat scene, deterministic, and more detail than flat colours."""

from __future__ import annotations

import gc

import mujoco
import numpy as np
import pytest

from fallgen.nav.agent import Pose
from fallgen.vision.camera import EgoCamera
from fallgen.vision.textures import detail_share
from fallgen.world.scene import LOOK, PhysicsSettings, build_scene

FLAT = PhysicsSettings(collision_meshes=False)
VARIANT = "kitchen_dining-l1-m2"  # tiles, concrete, a rug, curtains, veneer and stone
POSES = [Pose(3.0, 2.0, k, t) for k in (0, 3, 6, 9) for t in (0, -30)]


def _views(world, settings, what="all"):
    scene = build_scene(world.variant(VARIANT), world.materials, settings=settings)
    d = scene.data()
    mujoco.mj_forward(scene.model, d)
    cam = EgoCamera(scene)
    try:
        return [cam.render(d, p, what) for p in POSES]
    finally:
        cam.close()


@pytest.fixture(scope="module")
def flat_and_look(world):
    return _views(world, FLAT), _views(world, LOOK)


def test_segmentation_and_depth_are_the_flat_scenes(flat_and_look):
    for a, b in zip(*flat_and_look):
        assert a.instances == b.instances
        assert np.array_equal(a.instance, b.instance)
        assert np.array_equal(a.category, b.category)
        # the same depth up to float rounding (a textured box is the same box in another
        # local frame: see world.scene._face_frame)
        np.testing.assert_allclose(a.depth, b.depth, atol=1e-4)


def test_textured_views_have_detail_and_are_deterministic(world, flat_and_look):
    flat, look = flat_and_look
    d_flat = np.mean([detail_share(v.rgb) for v in flat])
    d_look = np.mean([detail_share(v.rgb) for v in look])
    assert d_look > 2 * d_flat and d_look > 0.25, (d_flat, d_look)
    again = _views(world, LOOK, "rgb")
    assert all(np.array_equal(a.rgb, b.rgb) for a, b in zip(look, again))


def test_a_shadow_darkens_the_floor_under_the_table(world):
    """The dining table seen from beside it, the ceiling light casting shadows or not (the same
    textures): with shadows, rug pixels darken, only darken, and the darkened ones lie under
    the table top (seen between its legs: nearer the top of the image than the rug in front)."""
    from fallgen.world.scene import Scene, build_spec

    v = world.variant(VARIANT)
    table = next(it for it in v.furniture if it.id == "table")
    pose = Pose(table.pose[0], table.pose[1] - 1.6, 3, -45)  # south of it, facing north

    def view(shadows: bool):
        spec, info = build_spec(v, world.materials, settings=LOOK)
        for light in spec.lights:
            light.castshadow = light.castshadow and shadows
        m = spec.compile()
        names = [m.geom(i).name for i in range(m.ngeom)]
        scene = Scene(m, spec, v, tuple(info[n][0] for n in names),
                      tuple(info[n][1] for n in names), {})
        d = scene.data()
        mujoco.mj_forward(m, d)
        cam = EgoCamera(scene)
        try:
            return cam.render(d, pose)
        finally:
            cam.close()

    lit, shaded = view(False), view(True)
    rug = lit.instance == lit.instances.index("rug")
    a = lit.rgb.astype(float).mean(axis=2)
    b = shaded.rgb.astype(float).mean(axis=2)
    dark = rug & (b < 0.8 * a)
    assert dark.sum() > 0.05 * rug.sum(), (dark.sum(), rug.sum())
    assert (b[rug] <= a[rug] + 1).all()  # a shadow never brightens
    rows = np.nonzero(rug)[0]
    assert np.nonzero(dark)[0].mean() < rows.mean()  # beyond the rug's near edge: under it


def test_a_dropped_camera_frees_its_gl_objects_in_its_own_context(world):
    """Two cameras, each with its own GL context: the first dropped without close() (the
    garbage collector frees it) must not free the second's textures and buffers, whose
    segmentation would then read texture colours."""
    v = world.variant(VARIANT)
    first = build_scene(v, world.materials, settings=FLAT)
    cam = EgoCamera(first)
    d = first.data()
    mujoco.mj_forward(first.model, d)
    cam.render(d, POSES[0])
    second = build_scene(v, world.materials, settings=LOOK)
    cam2 = EgoCamera(second)
    d2 = second.data()
    mujoco.mj_forward(second.model, d2)
    want = cam2.render(d2, POSES[0])
    del cam
    gc.collect()
    for p in POSES[:4]:
        cam2.render(d2, p, "rgb")
    got = cam2.render(d2, POSES[0])
    cam2.close()
    assert np.array_equal(got.instance, want.instance)
