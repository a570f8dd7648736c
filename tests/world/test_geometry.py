import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fallgen.world.geometry import Box, footprint_inside, overlap2d, penetration

coord = st.floats(-2, 2)
half = st.floats(0.05, 1.0)
yaw = st.floats(-math.pi, math.pi)
boxes = st.builds(lambda x, y, z, hx, hy, hz, a: Box((x, y, z), (hx, hy, hz), a),
                  coord, coord, coord, half, half, half, yaw)


def _sample_overlap(a: Box, b: Box, n: int = 4000) -> bool:
    rng = np.random.default_rng(0)
    local = rng.uniform(-1, 1, (n, 3)) * np.asarray(a.half)
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    pts = np.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1],
                    local[:, 2]], axis=1) + np.asarray(a.center)
    return bool(b.contains(pts).any())


@settings(max_examples=150, deadline=None)
@given(boxes, boxes)
def test_penetration_agrees_with_point_sampling(a, b):
    d = penetration(a, b)
    # Sample both boxes: a small box deep inside a large one holds few of the large one's samples.
    hit = _sample_overlap(a, b) or _sample_overlap(b, a)
    if hit:
        assert d > -1e-9
    if d > 0.05:  # deep overlaps are always found by sampling
        assert hit


def test_known_overlaps():
    a = Box((0, 0, 0.5), (0.5, 0.5, 0.5))
    b = Box((0.9, 0, 0.5), (0.5, 0.5, 0.5))
    assert math.isclose(overlap2d(a, b), 0.1, abs_tol=1e-12)
    # Rotated by 45 degrees, b's corner reaches 0.9 - 0.5*sqrt(2) = 0.193 into a's face.
    c = Box((0.9, 0, 0.5), (0.5, 0.5, 0.5), math.pi / 4)
    assert math.isclose(overlap2d(a, c), 0.5 - (0.9 - 0.5 * math.sqrt(2)), abs_tol=1e-9)
    up = Box((0, 0, 1.5), (0.5, 0.5, 0.5))
    assert penetration(a, up) <= 0.0


def test_placed_and_contains():
    local = Box((1.0, 0.0, 0.5), (0.1, 0.2, 0.5))
    w = local.placed((2.0, 3.0), math.pi / 2)
    assert np.allclose(w.center, (2.0, 4.0, 0.5))
    assert w.contains(np.array([[2.0, 4.0, 0.5], [2.15, 4.0, 0.5]])).tolist() == [True, True]
    assert not w.contains(np.array([[2.0, 4.15, 0.5]]))[0]
    assert footprint_inside(Box((0, 0, 0), (0.1, 0.1, 0.1)), Box((0, 0, 0), (0.2, 0.2, 0.2)))
    assert not footprint_inside(Box((0.15, 0, 0), (0.1, 0.1, 0.1)), Box((0, 0, 0), (0.2, 0.2, 0.2)))


def test_vectorised_part_footprints_overlap_as_overlap2d():
    """The rooms' batch overlap test (used for every zone's drop region) equals overlap2d."""
    from fallgen.world.rooms import _Footprints

    rng = np.random.default_rng(5)

    class _Item:
        def __init__(self, parts):
            self.id, self.parts = "item", parts

    class _Part:
        def __init__(self, name, box):
            self.name, self.box = name, box

    boxes = [Box(tuple(rng.uniform(0, 3, 3)), tuple(rng.uniform(0.05, 0.8, 3)),
                 float(rng.uniform(-math.pi, math.pi))) for _ in range(60)]
    fp = _Footprints([_Item([_Part(f"p{i}", b) for i, b in enumerate(boxes)])])
    for _ in range(20):
        other = Box(tuple(rng.uniform(0, 3, 3)), tuple(rng.uniform(0.05, 0.8, 3)),
                    float(rng.uniform(-math.pi, math.pi)))
        got = fp.overlap(np.arange(len(boxes)), other)
        want = np.array([overlap2d(b, other) for b in boxes])
        assert np.allclose(got, want, rtol=0, atol=1e-12)
        assert ((got > 0) == (want > 0)).all()


def test_box_set_gives_each_boxs_own_verdict_to_the_bit():
    """Many rotated boxes at once say what any one of them says (Box.contains), on random
    points and on points exactly on a face, a grown face and just beyond it."""
    from fallgen.world.geometry import BoxSet

    rng = np.random.default_rng(3)
    boxes = [Box(tuple(rng.uniform(0, 4, 3)), tuple(rng.uniform(0.05, 0.8, 3)),
                 float(rng.uniform(-math.pi, math.pi))) for _ in range(40)]
    many = BoxSet(boxes)
    checked = hits = 0
    for _ in range(300):
        pts = rng.uniform(-0.5, 4.5, (int(rng.integers(1, 12)), 3))
        tol = float(rng.choice([0.0, 0.03, 0.2]))
        want = any(b.contains(pts, tol).any() for b in boxes)
        assert many.any_contains(pts, tol) == want
        checked, hits = checked + 1, hits + want
    assert 0 < hits < checked  # both verdicts were met
    b = boxes[0]
    one = BoxSet([b])
    for tol in (0.0, 0.05):
        for k in (1.0, np.nextafter(1.0, 2.0), 0.999):
            # along the box's own x axis, at the face grown by tol (times k)
            d = (b.half[0] + tol) * k
            p = np.array([[b.center[0] + math.cos(b.yaw) * d, b.center[1] + math.sin(b.yaw) * d,
                           b.center[2]]])
            assert one.any_contains(p, tol) == bool(b.contains(p, tol)[0])
    assert not BoxSet([]).any_contains(np.zeros((3, 3)))
