"""Constants shared by the :mod:`fallgen.world.meshkit` modules."""

#: Points closer than this to the axis count as on it (m).
AXIS_EPS = 1e-9
#: Smallest convex-hull volume accepted for a collision piece (m^3).
MIN_PIECE_VOLUME = 1e-10
#: Default tolerance for the collision pieces covering the visual mesh (m).
COVER_TOL = 1e-3

_BIG = 10.0  # "infinite" extent for half-planes in 2-D, m
