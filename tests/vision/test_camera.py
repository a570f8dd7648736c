"""The egocentric camera (fallgen.vision.camera): geometry of the view, depth in metres,
segmentation labels, headless and deterministic."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fallgen.nav.agent import AgentSpec, Pose
from fallgen.vision.camera import EgoCamera
from fallgen.world.scene import PlacedObject, build_scene

VARIANT = "kitchen_galley-l1-m1"


@pytest.fixture(scope="module")
def cam_scene(world):
    v = world.variant(VARIANT)
    inst = world.categories.instance("cup", "mug", "ceramic")
    scene = build_scene(v, world.materials, [PlacedObject("target", inst, (4.0, 1.8, 0.05))])
    d = scene.data()
    mujoco.mj_forward(scene.model, d)
    cam = EgoCamera(scene, {"target": "cup"})
    yield cam, d
    cam.close()


def test_view_arrays_and_labels(cam_scene):
    cam, d = cam_scene
    v = cam.render(d, Pose(2.5, 1.8, 0, -15))
    assert v.rgb.shape == (300, 300, 3) and v.rgb.dtype == np.uint8
    assert v.depth.shape == (300, 300) and v.depth.dtype == np.float32
    assert v.instance.shape == v.category.shape == (300, 300)
    assert "obj:target" in v.instances and "cup" in cam.categories and "floor" in cam.categories
    px = v.pixels_of("obj:target")
    assert px > 20
    # the cup's pixels are labelled with its category, and lie where a pinhole camera of the
    # model's vertical field of view, at the robot's camera height, tilted 15 degrees down,
    # projects the cup's centre of mass: straight ahead, 1.49 m away and 1.06 m below the eye
    mask = v.instance == v.instances.index("obj:target")
    assert (v.category[mask] == cam.categories.index("cup")).all()
    rows, cols = np.nonzero(mask)
    eye = np.array([2.5, 1.8, AgentSpec().camera_height_m])
    rel = d.xipos[cam.scene.object_body["target"]] - eye
    tilt = np.radians(-15.0)
    forward = rel[0] * np.cos(tilt) + rel[2] * np.sin(tilt)
    up = -rel[0] * np.sin(tilt) + rel[2] * np.cos(tilt)
    left = rel[1]
    focal = 150.0 / np.tan(np.radians(cam.scene.model.vis.global_.fovy / 2))
    assert cols.mean() == pytest.approx(149.5 - focal * left / forward, abs=1.0)
    assert rows.mean() == pytest.approx(149.5 - focal * up / forward, abs=2.0)
    again = cam.render(d, Pose(2.5, 1.8, 0, -15))
    assert np.array_equal(v.rgb, again.rgb) and np.array_equal(v.instance, again.instance)


def test_turning_away_hides_the_object(cam_scene):
    cam, d = cam_scene
    assert cam.pixels_of(d, Pose(2.5, 1.8, 6, 0)) == 0  # facing -x
    assert cam.pixels_of(d, Pose(2.5, 1.8, 0, 0)) > 0


def test_a_camera_makes_its_render_context_on_its_first_draw(world):
    """Views that the bounds answer without drawing (the object behind the camera) make no
    render context; the first draw makes it, and its pixels are those of a camera that drew
    from the start."""
    v = world.variant(VARIANT)
    inst = world.categories.instance("cup", "mug", "ceramic")
    scene = build_scene(v, world.materials, [PlacedObject("target", inst, (4.0, 1.8, 0.05))])
    d = scene.data()
    mujoco.mj_forward(scene.model, d)
    lazy, eager = EgoCamera(scene, {"target": "cup"}), EgoCamera(scene, {"target": "cup"})
    try:
        away, toward = Pose(2.5, 1.8, 6, 0), Pose(2.5, 1.8, 0, -15)
        assert eager.frames is not None
        assert not lazy.shows(d, away, 4) and lazy.pixels_of(d, away) == 0
        assert lazy._frames is None
        assert lazy.shows(d, toward, 4) and lazy._frames is not None
        a, b = lazy.render(d, toward), eager.render(d, toward)
        assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.instance, b.instance)
    finally:
        lazy.close()
        eager.close()


def test_depth_is_metres_along_the_view_axis(cam_scene):
    """The centre pixel's depth equals the distance MuJoCo's ray cast finds straight ahead."""
    cam, d = cam_scene
    pose = Pose(2.5, 1.2, 0, 0)
    v = cam.render(d, pose)
    eye = np.array([pose.x, pose.y, AgentSpec().camera_height_m])
    geomid = np.zeros(1, np.int32)
    dist = mujoco.mj_ray(cam.scene.model, d, eye, np.array([1.0, 0.0, 0.0]), None, 1, -1, geomid)
    centre = v.depth[148:152, 148:152].mean()
    assert centre == pytest.approx(dist, rel=0.02)


def test_frustum_cull_never_hides_a_visible_object(cam_scene):
    """pixels_of skips the render only when the object's boxes lie wholly outside the view:
    over random poses (all headings and tilts), a culled pose always renders 0 pixels of the
    object, and most poses facing away are culled."""
    cam, d = cam_scene
    rng = np.random.default_rng(3)
    culled = rendered_zero = 0
    for _ in range(120):
        pose = Pose(float(rng.uniform(0.5, 6.0)), float(rng.uniform(0.5, 3.0)),
                    int(rng.integers(12)), int(rng.choice([-60, -30, 0, 30])))
        px = cam.render(d, pose, "segmentation").pixels_of("obj:target")
        if cam.outside_view(d, pose, "obj:target"):
            culled += 1
            assert px == 0, pose
        rendered_zero += px == 0
        assert cam.pixels_of(d, pose) == px
    assert culled > 0.5 * rendered_zero > 0
    assert cam.outside_view(d, Pose(2.5, 1.8, 0, 0), "obj:nothing")


def test_shared_context_gives_mujoco_renderers_pixels(world):
    """Scenes drawn one after another in one shared GL context, with the camera's small
    offscreen buffer and no shadow map, give exactly the RGB, depth and segmentation of
    ``mujoco.Renderer`` on the model's default buffer (its own context per scene), for
    segmentation-only views and for full views (colour, then depth and segmentation)."""
    from fallgen.vision.gl import GLContext

    v = world.variant(VARIANT)
    inst = world.categories.instance("cup", "mug", "ceramic")
    shared = GLContext(300)
    try:
        for x in (4.0, 3.0):
            scene = build_scene(v, world.materials, [PlacedObject("target", inst, (x, 1.8, 0.05))])
            d = scene.data()
            mujoco.mj_forward(scene.model, d)
            cam = EgoCamera(scene, {"target": "cup"}, context=shared)
            poses = [Pose(2.5, 1.8, k, t) for k in (0, 1, 11) for t in (-30, 0)]
            segs = [cam.render(d, p, "segmentation") for p in poses]
            ours = [cam.render(d, p) for p in poses]
            cam.close()
            m = scene.model
            m.vis.global_.offwidth, m.vis.global_.offheight = 640, 480
            m.vis.quality.shadowsize = 4096
            ref = mujoco.Renderer(m, 300, 300)
            for k, (heading, tilt) in enumerate((k, t) for k in (0, 1, 11) for t in (-30, 0)):
                c = cam.camera(Pose(2.5, 1.8, heading, tilt))
                ref.update_scene(d, c)
                rgb = ref.render().copy()
                ref.enable_depth_rendering()
                ref.update_scene(d, c)
                depth = ref.render().copy()
                ref.disable_depth_rendering()
                ref.enable_segmentation_rendering()
                ref.update_scene(d, c)
                seg = ref.render()
                ref.disable_segmentation_rendering()
                ids = np.where((seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)) & (seg[..., 0] >= 0),
                               seg[..., 0], -1)
                assert np.array_equal(ours[k].rgb, rgb)
                assert np.array_equal(ours[k].depth, depth)
                assert np.array_equal(ours[k].instance, cam._inst[ids])
                assert np.array_equal(segs[k].instance, cam._inst[ids])
            ref.close()
            assert ours[0].pixels_of("obj:target") > 0 or ours[1].pixels_of("obj:target") > 0
    finally:
        shared.close()


def test_footprint_bounds_the_object_pixels_and_checks_skip_only_hidden_views(world):
    """The footprint (pixel centres inside the projected outline of the object's boxes) is
    an upper bound on the pixels a render shows, for objects of every shape in random poses
    and views; pixels_of (reading back only the footprint's window) counts what a full render
    counts, and shows(k) is pixels >= k, though most views that cannot show k pixels are
    decided without a render. A render cropped to the window (the frustum narrowed to it)
    gives the same pixels but for a rare one where an edge passes through a pixel centre."""
    rng = np.random.default_rng(11)
    v = world.variant(VARIANT)
    cats = world.categories
    chosen = [("shirt_button", None), ("cup", None), ("book", None), ("wineglass", None)]
    skipped = checked = cropped = differ = 0
    for cid, _ in chosen:
        cat = cats.categories[cid]
        var = cat.variants[0]
        inst = cats.instance(cid, var.name, next(iter(var.materials)))
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        scene = build_scene(v, world.materials, [PlacedObject(
            "target", inst, (4.0, 1.8, float(rng.uniform(0.02, 0.9))), tuple(q))])
        d = scene.data()
        mujoco.mj_forward(scene.model, d)
        cam = EgoCamera(scene, {"target": cid})
        try:
            for _ in range(40):
                pose = Pose(float(rng.uniform(1.5, 6.0)), float(rng.uniform(0.4, 3.0)),
                            int(rng.integers(12)), int(rng.choice([-45, -15, 0, 15])))
                full = cam.render(d, pose, "segmentation").pixels_of("obj:target")
                bound, window = cam.footprint(d, pose, "obj:target")
                assert full <= bound, (cid, pose)
                assert cam.pixels_of(d, pose) == full
                for k in (1, 4, 30):
                    assert cam.shows(d, pose, k) == (full >= k)
                if window is not None:
                    c = cam.camera(pose)
                    a = cam.frames.geoms(d, c, window)
                    b = cam.frames.geoms(d, c, window, crop=True)
                    assert a.shape == b.shape
                    differ += int((a != b).sum())
                    cropped += a.size
                    assert abs(cam._count(d, pose, "obj:target", window, crop=True) - full) <= 1
                skipped += bound < 4
                checked += 1
        finally:
            cam.close()
    assert skipped > 0.2 * checked
    assert cropped > 10_000 and differ <= 1e-3 * cropped, (differ, cropped)


def test_segmentation_draws_leave_out_only_geoms_that_cannot_show(world):
    """A segmentation draw leaves out the geoms whose bounding spheres lie outside the part of
    the view drawn or read (a cropped window, a window read back, the whole view): the same
    geom ids at every pixel as drawing them all, over random poses of objects of several
    shapes, while most of the room is left out of a cropped draw."""
    rng = np.random.default_rng(5)
    v = world.variant(VARIANT)
    cats = world.categories
    compared = hidden = total = 0
    for cid in ("cup", "book", "wineglass"):
        var = cats.categories[cid].variants[0]
        inst = cats.instance(cid, var.name, next(iter(var.materials)))
        scene = build_scene(v, world.materials, [PlacedObject(
            "target", inst, (float(rng.uniform(3.0, 5.0)), 1.8, float(rng.uniform(0.02, 0.9))))])
        d = scene.data()
        mujoco.mj_forward(scene.model, d)
        cam = EgoCamera(scene, {"target": cid})
        f = cam.frames
        try:
            for _ in range(30):
                pose = Pose(float(rng.uniform(0.5, 6.0)), float(rng.uniform(0.4, 3.0)),
                            int(rng.integers(12)), int(rng.choice([-45, -15, 0, 15])))
                c = cam.camera(pose)
                _, window = cam.footprint(d, pose, "obj:target")
                views = [(None, False)] + ([(window, False), (window, True)] if window else [])
                for win, crop in views:
                    f.cull = False
                    a = f.geoms(d, c, win, crop)
                    f.cull = True
                    b = f.geoms(d, c, win, crop)
                    assert np.array_equal(a, b), (cid, pose, win, crop)
                    compared += a.size
                    if crop:
                        out = f._outside(d, c, win)
                        hidden += int(out.sum())
                        total += len(out)
                depth_a, ids_a = f.depth_and_geoms(d, c)
                f.cull = False
                depth_b, ids_b = f.depth_and_geoms(d, c)
                f.cull = True
                assert np.array_equal(depth_a, depth_b) and np.array_equal(ids_a, ids_b)
        finally:
            cam.close()
    assert compared > 100_000 and total > 0
    assert hidden > 0.5 * total, (hidden, total)


_RENDER_DIGEST = """
import hashlib, sys
import fallgen, mujoco
from fallgen.nav.agent import Pose
from fallgen.vision.camera import EgoCamera
from fallgen.world.library import load_world
from fallgen.world.scene import PlacedObject, build_scene
w = load_world(sys.argv[1])
inst = w.categories.instance("cup", "mug", "ceramic")
scene = build_scene(w.variant(sys.argv[2]), w.materials,
                    [PlacedObject("target", inst, (4.0, 1.8, 0.05))])
d = scene.data()
mujoco.mj_forward(scene.model, d)
cam = EgoCamera(scene, {"target": "cup"})
h = hashlib.sha256()
for k in (0, 1, 11):
    v = cam.render(d, Pose(2.5, 1.8, k, -30))
    for a in (v.rgb, v.depth, v.instance):
        h.update(a.tobytes())
    h.update(str(cam.pixels_of(d, Pose(2.5, 1.8, k, -30))).encode())
cam.close()
print(h.hexdigest())
"""


def test_rasteriser_threads_do_not_change_pixels():
    """fallgen rasterises in the calling thread (``LP_NUM_THREADS=0``, set by the package and
    in every worker): the same RGB, depth, segmentation and pixel counts as Mesa's default of
    rasteriser threads of its own (each setting in its own process: Mesa reads it once)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    digests = []
    for threads in ("0", "2"):
        env = {**os.environ, "LP_NUM_THREADS": threads}
        out = subprocess.run([sys.executable, "-c", _RENDER_DIGEST, str(repo), VARIANT],
                             env=env, capture_output=True, text=True, check=True)
        digests.append(out.stdout.strip())
    assert len(digests[0]) == 64 and digests[0] == digests[1]
