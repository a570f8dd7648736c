"""GeodesicField on hand-made grids: a straight corridor measures its length, and a gap that
only a diagonal step joins (which the robot's 0.25 m moves along 30-degree headings pass) keeps
the distance finite."""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import distance_transform_edt

from fallgen.nav.geodesic import GeodesicField
from fallgen.nav.occupancy import OccupancyGrid


def _grid(free_cells: np.ndarray, res: float = 0.1) -> OccupancyGrid:
    occ = ~free_cells
    padded = np.pad(occ, 1, constant_values=True)
    dist = distance_transform_edt(~padded)[1:-1, 1:-1] * res
    clearance = np.maximum(dist - res / 2, 0.0)
    clearance[occ] = 0.0
    return OccupancyGrid(occ, res, clearance)


def test_corridor_distance_is_its_length_plus_the_last_leg():
    free = np.zeros((60, 9), bool)
    free[:, :] = True  # a 6 m x 0.9 m corridor: clearance 0.4 m along its middle
    g = GeodesicField(_grid(free), (5.85, 0.45), radius_m=0.2, reach_m=2.0)
    d = g.distance((0.45, 0.45))
    assert abs(d - 5.4) < 0.05  # straight along the middle row of cells


def test_a_gap_joined_only_diagonally_is_passable():
    # two regions where the robot fits, touching only at a corner (cells (14, 14) and
    # (15, 15)), as a tight gap of kitchen_galley-l2 came out on the 0.1 m grid
    fit = np.zeros((30, 30), bool)
    fit[0:15, 0:15] = True
    fit[15:30, 15:30] = True
    grid = OccupancyGrid(np.zeros_like(fit), 0.1, np.where(fit, 0.3, 0.1))
    g = GeodesicField(grid, (2.55, 2.55), radius_m=0.2, reach_m=0.3)
    d = g.distance((0.25, 0.25))
    # through the corner: the diagonal from (0.25, 0.25) to (2.55, 2.55) less the last leg
    assert math.isfinite(d) and abs(d - (math.hypot(2.3, 2.3))) < 0.1
