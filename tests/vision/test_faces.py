"""The faces' vertex sets: the fast unique rows are NumPy's, to the bit and in order."""

import numpy as np

from fallgen.vision.faces import unique_rows


def _mesh_rows(rng: np.random.Generator) -> np.ndarray:
    """A mesh's triangle corners as rows: a few vertices, each repeated across faces, some
    sharing coordinates (a box's corners share two of three)."""
    v = rng.normal(size=(int(rng.integers(1, 80)), 3)) * rng.choice([1e-3, 1.0, 50.0])
    v = v.round(int(rng.integers(0, 6)))
    return v[rng.integers(0, len(v), (int(rng.integers(1, 120)), 3))].reshape(-1, 3)


def test_unique_rows_are_numpys_rows_in_numpys_order():
    rng = np.random.default_rng(7)
    for _ in range(200):
        rows = _mesh_rows(rng) + 0.0  # no negative zero: the fast path
        got, want = unique_rows(rows), np.unique(rows, axis=0)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert got.tobytes() == want.tobytes()


def test_unique_rows_with_zeros_of_both_signs_or_nan_are_numpys():
    rng = np.random.default_rng(8)
    rows = _mesh_rows(rng)
    rows[::3, 1] = 0.0
    rows[1::3, 1] = -0.0
    rows[5, 2] = np.nan
    for a in (rows, rows[np.isfinite(rows).all(1)]):
        assert unique_rows(a).tobytes() == np.unique(a, axis=0).tobytes()
    assert unique_rows(np.zeros((0, 3))).shape == (0, 3)


def test_each_solid_keeps_its_separating_planes_in_order_then_zeros(world, zone_scene):
    """A room's faces against an object in it: each convex solid's planes are the directions
    (of its 12) along which it lies wholly on the eye's side of the object, in their order,
    with their support, then rows of zeros; its vertices, box and sphere are the part's."""
    from fallgen.vision.faces import FaceSet

    v = world.variant("study_office-l1-m1")
    z = zone_scene(v, v.zones[2], world.categories.instance("cup", "mug", "ceramic"))
    room, points = z.faces, z.points
    f = FaceSet([room], points, 0.002)
    n = len(room.dirs)
    assert n > 20 and f.planes.shape == (n, 12, 4) and len(f.nplanes) == n
    with_planes = 0
    for k in range(n):
        ok = (points @ room.dirs[k].T).min(0) >= room.support[k] + 0.002
        m = int(ok.sum())
        assert f.nplanes[k] == m
        np.testing.assert_array_equal(f.planes[k, :m, :3], room.dirs[k][ok])
        np.testing.assert_array_equal(f.planes[k, :m, 3], room.support[k][ok])
        assert not f.planes[k, m:].any()
        a, b = room.solid_start[k], room.solid_start[k + 1]
        np.testing.assert_array_equal(f.solid_verts[f.solid_start[k]:f.solid_start[k + 1]],
                                      room.solid_verts[a:b])
        with_planes += m > 0
    np.testing.assert_array_equal(f.solid_lo, room.solid_lo)
    np.testing.assert_array_equal(f.solid_spheres, room.solid_spheres)
    assert 0 < with_planes < n
