"""Constants and small helpers shared by the :mod:`fallgen.world.meshkit` modules."""

import numpy as np

#: Points closer than this to the axis count as on it (m).
AXIS_EPS = 1e-9
#: Smallest convex-hull volume accepted for a collision piece (m^3).
MIN_PIECE_VOLUME = 1e-10
#: Default tolerance for the collision pieces covering the visual mesh (m).
COVER_TOL = 1e-3

_BIG = 10.0  # "infinite" extent for half-planes in 2-D, m


def capped_ring_faces(n: int, m: int) -> np.ndarray:
    """Triangles of a closed tube of ``n`` rings of ``m`` vertices capped by two apexes, for
    vertices ordered [start apex, ring 0 ..., ring n-1 ..., end apex]: a fan at each end and
    two triangles per quad between consecutive rings."""
    idx = 1 + np.arange(n * m).reshape(n, m)
    k = np.arange(m)
    k1 = (k + 1) % m
    faces = [np.column_stack([np.zeros(m, int), idx[0, k1], idx[0, k]])]
    for i in range(n - 1):
        a, b, c, d = idx[i, k], idx[i, k1], idx[i + 1, k1], idx[i + 1, k]
        faces += [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
    faces.append(np.column_stack([np.full(m, n * m + 1), idx[-1, k], idx[-1, k1]]))
    return np.vstack(faces)
