"""The occlusion proof (fallgen.vision.sight) and its cover test (fallgen.vision.cover):
the cover test against Shapely's polygon algebra, the proof against the renderer itself (no
view from an eye it calls hidden shows a pixel of the object), and the renderer's back-face
culling that the proof relies on."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import shapely

from fallgen.nav.agent import AgentSpec, Pose
from fallgen.vision.camera import EgoCamera
from fallgen.vision.cover import (MAX_VERTICES, convex_hull, covered, extents_polygon,
                                  subtract)
from fallgen.vision.sight import Occluders, Sight, gnomonic_frame, near_distance


def _cover(g: np.ndarray, polys: list[np.ndarray]) -> bool:
    cx = np.zeros((len(polys), 8))
    cy = np.zeros((len(polys), 8))
    cn = np.array([len(p) for p in polys], np.int64)
    for i, p in enumerate(polys):
        cx[i, :len(p)], cy[i, :len(p)] = p[:, 0], p[:, 1]
    return bool(covered(g[:, 0].copy(), g[:, 1].copy(), len(g), cx, cy, cn, len(polys),
                        1e-14, 4096))


def test_cover_agrees_with_shapely():
    """Random convex polygons under random triangles and quads (either orientation, shared
    edges, gaps): the verdict of Shapely's union and cover, every time, both ways often."""
    rng = np.random.default_rng(3)
    verdicts = []
    for trial in range(300):
        pts = rng.normal(size=(int(rng.integers(3, 12)), 2)) * 0.2
        hx, hy = np.empty(len(pts)), np.empty(len(pts))
        n = convex_hull(pts[:, 0].copy(), pts[:, 1].copy(), len(pts), hx, hy)
        g = np.column_stack([hx[:n], hy[:n]])
        ref_hull = shapely.convex_hull(shapely.multipoints(pts))
        assert shapely.Polygon(g).equals_exact(ref_hull.normalize(), 1e-12) or \
            abs(shapely.Polygon(g).area - ref_hull.area) < 1e-12
        polys = []
        if trial % 3 == 0:  # a grid of triangles sharing edges, maybe with one left out
            xs = np.linspace(-0.8, 0.8, 6)
            for i in range(5):
                for j in range(5):
                    a, b = (xs[i], xs[j]), (xs[i + 1], xs[j])
                    c, d = (xs[i + 1], xs[j + 1]), (xs[i], xs[j + 1])
                    polys += [np.array([a, b, c]), np.array([a, d, c])]  # second one clockwise
            if trial % 2:
                del polys[int(rng.integers(len(polys)))]
        else:
            for _ in range(int(rng.integers(1, 25))):
                c = rng.normal(size=2) * 0.3
                k = int(rng.integers(3, 5))
                ang = np.sort(rng.uniform(0, 2 * np.pi, k))
                polys.append(c + rng.uniform(0.1, 0.6) * np.column_stack([np.cos(ang),
                                                                          np.sin(ang)]))
        want = shapely.union_all([shapely.Polygon(p) for p in polys]).covers(shapely.Polygon(g))
        got = _cover(g, polys)
        assert got == want, trial
        verdicts.append(got)
    assert 0.2 < np.mean(verdicts) < 0.8


def test_the_extents_polygon_touches_each_extent_pushed_out_by_the_margin():
    """For random point sets: along each of the 2 x 16 directions the polygon reaches exactly
    the points' farthest extent plus the margin (its side lies there), and it holds every
    point with at least the margin to spare."""
    rng = np.random.default_rng(12)
    sides, margin = 16, 2e-4
    ang = np.pi * np.arange(2 * sides) / sides
    d = np.column_stack([np.cos(ang), np.sin(ang)])
    for _ in range(100):
        n = int(rng.integers(1, 700))
        pts = rng.normal(size=(n, 2)) * rng.choice([1e-3, 0.05, 1.0])
        hx, hy = np.empty(MAX_VERTICES), np.empty(MAX_VERTICES)
        m = extents_polygon(pts[:, 0].copy(), pts[:, 1].copy(), n, sides, margin, hx, hy)
        poly = np.column_stack([hx[:m], hy[:m]])
        reach = (pts @ d.T).max(0) + margin
        scale = 1.0 + np.abs(pts).max()
        np.testing.assert_allclose((poly @ d.T).max(0), reach, rtol=0, atol=1e-12 * scale)
        assert shapely.Polygon(poly).buffer(-margin * 0.999).contains(shapely.multipoints(pts))


def _pieces(g: np.ndarray, polys: list[np.ndarray], max_pieces: int) -> tuple[list, int]:
    cx = np.zeros((len(polys), 8))
    cy = np.zeros((len(polys), 8))
    cn = np.array([len(p) for p in polys], np.int64)
    for i, p in enumerate(polys):
        cx[i, :len(p)], cy[i, :len(p)] = p[:, 0], p[:, 1]
    xs, ys, ns, count = subtract(g[:, 0].copy(), g[:, 1].copy(), len(g), cx, cy, cn,
                                 len(polys), 1e-14, max_pieces)
    return [shapely.Polygon(np.column_stack([xs[i, :ns[i]], ys[i, :ns[i]]]))
            for i in range(count)], count


def test_the_pieces_left_are_the_difference_when_they_outgrow_their_first_room():
    """A square minus a 12 x 12 grid of small squares leaves far more convex pieces than the
    64 the subtraction first has room for: the pieces are disjoint and convex and their union
    is Shapely's difference; with room for fewer (max_pieces) it stops, and what it returns
    still holds the whole difference."""
    g = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    c = (np.arange(12) + 0.5) / 12
    polys = [np.array([[x - 0.02, y - 0.02], [x + 0.02, y - 0.02], [x + 0.02, y + 0.02],
                       [x - 0.02, y + 0.02]]) for x in c for y in c]
    want = shapely.Polygon(g).difference(shapely.union_all([shapely.Polygon(p)
                                                            for p in polys]))
    pieces, count = _pieces(g, polys, 4096)
    assert count > 64
    assert all(p.is_valid and abs(p.convex_hull.area - p.area) < 1e-15 for p in pieces)
    assert abs(sum(p.area for p in pieces) - want.area) < 1e-12
    assert shapely.union_all(pieces).symmetric_difference(want).area < 1e-12
    short, count = _pieces(g, polys, 100)
    assert 0 < count <= 128
    assert shapely.union_all(short).buffer(1e-12).covers(want)
    assert sum(p.area for p in short) > want.area + 1e-3  # some of it not yet taken away


def test_a_crack_between_two_faces_is_not_covered():
    """Two squares 1e-6 apart leave a crack through the polygon: not covered; touching, they
    cover it."""
    g = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    left = np.array([[-1, -1], [0, -1], [0, 1], [-1, 1]], float)
    for gap, want in ((1e-6, False), (0.0, True)):
        right = np.array([[gap, -1], [1, -1], [1, 1], [gap, 1]], float)
        assert _cover(g, [left, right]) is want


def _square_sight(extra: np.ndarray | None = None) -> Sight:
    """A sight of one square piece (+-0.05 tangent units, +-7.5 pixels) straight ahead of an
    eye at the origin looking along +x; ``extra``: a vertex put in after the second corner."""
    eye = np.zeros(3)
    frame = gnomonic_frame(eye, np.array([[1.0, 0.0, 0.0]]))
    sq = [(-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05)]
    if extra is not None:
        sq.insert(2, tuple(extra))
    xs, ys = np.zeros((1, 16)), np.zeros((1, 16))
    xs[0, :len(sq)], ys[0, :len(sq)] = zip(*sq)
    return Sight(eye, frame, (xs, ys, np.array([len(sq)], np.int64)))


def test_a_vertex_repeated_up_to_rounding_cuts_nothing_from_the_count():
    """A piece of the subtraction can hold a vertex twice, the copies apart by rounding; the
    line through them points anywhere. Here it is the square's diagonal: counted as a side,
    it would drop half the square's pixels."""
    clean = _square_sight().max_pixels(0.0, 0.0, 300, 90.0, 10 ** 6)
    assert 15 * 15 <= clean <= 17 * 17
    # the second corner again, 1e-13 along the other diagonal (in the image: (-1, 1))
    twin = _square_sight(np.array([0.05, -0.05]) + 1e-13 * np.array([-1.0, 1.0]))
    assert twin.max_pixels(0.0, 0.0, 300, 90.0, 10 ** 6) == clean


def test_the_renderer_culls_back_faces():
    """From inside a closed mesh cube a sphere outside is seen: its faces are drawn only from
    their front, as the occlusion proof assumes."""
    xml = """<mujoco><asset><mesh name="cube" vertex="-1 -1 -1 1 -1 -1 -1 1 -1 1 1 -1
    -1 -1 1 1 -1 1 -1 1 1 1 1 1"/></asset><worldbody><light pos="0 0 5"/>
    <geom type="mesh" mesh="cube" rgba="0 0 1 1" contype="0" conaffinity="0"/>
    <geom type="sphere" size="0.3" pos="3 0 0" rgba="1 0 0 1"/>
    <camera name="c" pos="0 0 0" xyaxes="0 -1 0 0 0 1"/></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    with mujoco.Renderer(m, 32, 32) as r:
        r.enable_segmentation_rendering()
        r.update_scene(d, "c")
        assert r.render()[16, 16, 0] == 1  # the sphere (geom 1), not the cube around the eye


def _views(camera, data, x, y):
    spec = camera.spec
    for h in range(12):
        for t in range(spec.tilt_min_deg, spec.tilt_max_deg + 1, spec.tilt_step_deg):
            yield Pose(x, y, h, t)


@pytest.mark.parametrize("variant_id", ["kitchen_galley-l1-m1", "study_office-l1-m1"])
def test_no_view_from_a_hidden_eye_shows_the_object(world, zone_scene, variant_id):
    """With the object in each fall zone (a book beside it), from random eyes at the camera's
    height: wherever the proof says hidden, every view (12 headings, 7 tilts) rendered in full
    shows no pixel of the object; and it says so for a good share of the eyes that see
    nothing. A wrong proof, in which faces behind the object hide it too, is refuted by the
    renderer."""
    rng = np.random.default_rng(5)
    v = world.variant(variant_id)
    lx, ly, _ = v.size_m
    cup = world.categories.instance("cup", "mug", "ceramic")
    book = world.categories.instance("book", world.categories.categories["book"].variants[0].name,
                                     next(iter(world.categories.categories["book"]
                                               .variants[0].materials)))
    spec = AgentSpec()
    hidden = blind = refuted = 0
    for zone in v.zones[::2]:
        z = zone_scene(v, zone, cup, beside=[("d0", book, (0.15, 0.0, 0.05))])
        scene, d, pos = z.scene, z.data, z.pos
        occ = Occluders([z.faces], z.points, near_distance(scene.model))
        wrong = Occluders([z.faces], z.points, near_distance(scene.model), behind_m=-10.0)
        camera = EgoCamera(scene, {"target": "cup", "d0": "book"}, spec)
        try:
            for _ in range(12):
                x, y = rng.uniform(0.2, lx - 0.2), rng.uniform(0.2, ly - 0.2)
                if math.hypot(x - pos[0], y - pos[1]) > 2.5:
                    continue
                eye = np.array([x, y, spec.camera_height_m])
                says, wrong_says = occ.hide(eye), wrong.hide(eye)
                if not (says or wrong_says):
                    continue
                pixels = sum(camera.pixels_of(d, p) for p in _views(camera, d, x, y))
                if says:
                    assert pixels == 0, (zone.id, x, y)
                    hidden += 1
                if wrong_says and pixels > 0:
                    refuted += 1
                blind += pixels == 0
        finally:
            camera.close()
    assert hidden >= 10 and hidden >= 0.5 * blind, (hidden, blind)
    assert refuted >= 1


def test_no_view_shows_more_pixels_than_the_bound(world, zone_scene):
    """From random eyes near the object in each fall zone, the views towards it (two
    headings, five tilts) rendered in full: none shows more of the object than
    :meth:`Sight.max_pixels` allows (the bound the expert skips renders by, counted without
    a cap), many show some of it, and a wrong proof's bound falls short somewhere."""
    rng = np.random.default_rng(11)
    v = world.variant("kitchen_lshape-l1-m1")
    lx, ly, _ = v.size_m
    jug = world.categories.instance("jug", "glass", "glass")
    spec = AgentSpec()
    views = shown = short = 0
    for zone in v.zones[1::2]:
        z = zone_scene(v, zone, jug, lift=0.08)
        scene, d, pos = z.scene, z.data, z.pos
        occ = Occluders([z.faces], z.points, near_distance(scene.model))
        wrong = Occluders([z.faces], z.points, near_distance(scene.model), behind_m=-10.0)
        camera = EgoCamera(scene, {"target": "jug"}, spec)
        try:
            for _ in range(10):
                x, y = rng.uniform(0.2, lx - 0.2), rng.uniform(0.2, ly - 0.2)
                if math.hypot(x - pos[0], y - pos[1]) > 2.0:
                    continue
                eye = np.array([x, y, spec.camera_height_m])
                sight, bad = occ.look(eye), wrong.look(eye)
                face = round(math.degrees(math.atan2(pos[1] - y, pos[0] - x)) / 30)
                for h in {face % 12, (face + 1) % 12}:
                    # the tilts judged together, as the expert asks: each as on its own
                    tilts = np.radians(np.arange(-60, 61, 30))
                    yaw = Pose(x, y, h).yaw_rad
                    assert sight.may_show(yaw, tilts, 300, 90.0, 4).tolist() == [
                        sight.max_pixels(yaw, float(t), 300, 90.0, 4) >= 4 for t in tilts]
                    for t in range(-60, 61, 30):
                        p = Pose(x, y, h, t)
                        yaw, tilt = p.yaw_rad, math.radians(t)
                        pixels = camera.pixels_of(d, p)
                        bound = sight.max_pixels(yaw, tilt, camera.frames.size, 90.0, 10 ** 6)
                        assert pixels <= bound, (zone.id, x, y, h, t, pixels, bound)
                        views += 1
                        shown += pixels > 0
                        short += pixels > bad.max_pixels(yaw, tilt, camera.frames.size, 90.0,
                                                         10 ** 6)
        finally:
            camera.close()
    assert views >= 200 and shown >= 20 and short >= 1, (views, shown, short)


def test_a_box_called_beside_the_image_box_projects_wholly_beyond_it():
    """The early test that drops a solid before projecting its vertices: every point of a box
    it calls beside the object's image box (random boxes, eyes and image boxes) has its image
    beyond one side of the box, or lies behind the eye; and it drops a good share of them."""
    from fallgen.vision.sight import _box_beside

    rng = np.random.default_rng(13)
    beside = 0
    for _ in range(2000):
        eye = rng.uniform(-1, 1, 3)
        w, p, q = gnomonic_frame(eye, rng.uniform(-3, 3, (8, 3)))
        lo = rng.uniform(-3, 3, 3)
        hi = lo + rng.uniform(0.01, 1.0, 3)
        x0, y0 = rng.uniform(-0.5, 0.3, 2)
        box = np.array([x0, y0, x0 + rng.uniform(0.01, 0.3), y0 + rng.uniform(0.01, 0.3)])
        if not _box_beside(lo[None], hi[None], 0, eye, w, p, q, box):
            continue
        beside += 1
        pts = lo + rng.uniform(0, 1, (300, 3)) * (hi - lo)
        pts = np.vstack([pts, [[(hi if c & b else lo)[a] for a, b in enumerate((1, 2, 4))]
                               for c in range(8)]]) - eye
        z = pts @ w
        front = z > 1e-9
        ix, iy = (pts @ p)[front] / z[front], (pts @ q)[front] / z[front]
        assert len(ix) == 0 or ix.max() < box[0] or ix.min() > box[2] or iy.max() < box[1] \
            or iy.min() > box[3]
    assert beside >= 300


def test_the_kernel_within_reach_gives_the_whole_kernels_verdicts(world, zone_scene):
    """The expert's lattice asks about eyes within reach of the object only, with a kernel
    that leaves out the faces no such eye looks at: from random eyes within reach its
    verdicts are those of the whole kernel, with fewer faces."""
    from fallgen.vision.sight import hidden_from, kernel_within

    v = world.variant("kitchen_lshape-l1-m1")
    cup = world.categories.instance("cup", "mug", "ceramic")
    rng = np.random.default_rng(14)
    spec = AgentSpec()
    agree = hidden = 0
    for zone in v.zones[::3]:
        z = zone_scene(v, zone, cup)
        pos = z.pos
        whole = Occluders([z.faces], z.points, near_distance(z.scene.model)).kernel
        near = kernel_within(whole, pos[:2], 2.0, spec.camera_height_m)
        assert len(near[0]) < len(whole[0])
        for _ in range(60):
            a, r = rng.uniform(0, 2 * np.pi), 2.0 * np.sqrt(rng.uniform())
            x, y = pos[0] + r * np.cos(a), pos[1] + r * np.sin(a)
            verdict = hidden_from(x, y, spec.camera_height_m, whole)
            assert hidden_from(x, y, spec.camera_height_m, near) == verdict
            agree += 1
            hidden += verdict
    assert agree >= 200 and 0 < hidden < agree, (agree, hidden)
