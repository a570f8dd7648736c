"""Geodesic distance to the object through the robot's free space, on the occupancy grid.

The distance from a point p to the object: the shortest path for the robot's disk (through
cells whose clearance is at least its radius; 8-connected, a diagonal step between two such
cells even where the cells beside it are not: the robot's own 0.25 m moves along 12 headings
pass gaps that only a diagonal joins, and with the corner rule 6 of the 1000 test episodes of a
paper-size build had no finite distance from their spawn) to a free cell centre c, plus the straight
distance from c to the object, where that last leg is at most ``reach_m`` (the success
distance): how far the robot must go before it could claim the object, plus what is left to
it. Within ``reach_m`` of the object it is the straight distance. An object under a table or
behind a sofa is reached over the furniture by the last leg, as the judge measures it.

Also the distance to where the object is within reach (0 within ``reach_m``): soft SPL's
progress. Used by the environment's alternative reward (the decrease of the distance to the
object) and by soft SPL.
Cells 0.1 m: a path along the grid is at most ~8 % longer than the straight line (the 8
directions), and the start of the path is joined straight to the nearest free cell centres.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from fallgen.nav.occupancy import OccupancyGrid


def grid_edges(free: np.ndarray, resolution: float, cut_corners: bool = False
               ) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """The graph of the free cells of a 2-D grid: ``idx`` (each free cell's node number, -1
    elsewhere) and the edges (rows, cols, weights, lists of arrays, both directions):
    orthogonal and diagonal neighbours, a diagonal step only where both cells beside it are
    free (no corner is cut) unless ``cut_corners``, weighted by the distance between the cell
    centres."""
    nx, ny = free.shape
    idx = np.full((nx, ny), -1, np.int64)
    idx[free] = np.arange(int(free.sum()))
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    weights: list[np.ndarray] = []
    for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):  # each undirected edge once
        a = free[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
        b = free[max(0, di):nx - max(0, -di) or None, max(0, dj):ny - max(0, -dj) or None]
        ok = a & b
        if di and dj and not cut_corners:  # diagonal: both cells beside the step free too
            side1 = free[max(0, di):nx - max(0, -di) or None, max(0, -dj):ny - max(0, dj)]
            side2 = free[max(0, -di):nx - max(0, di), max(0, dj):ny - max(0, -dj) or None]
            ok &= side1 & side2
        ia = idx[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)][ok]
        ib = idx[max(0, di):nx - max(0, -di) or None, max(0, dj):ny - max(0, -dj) or None][ok]
        rows += [ia, ib]
        cols += [ib, ia]
        weights += [np.full(2 * len(ia), resolution * math.hypot(di, dj))]
    return idx, rows, cols, weights


class GeodesicField:
    """The geodesic distance from every free cell centre of ``grid`` to ``target_xy``."""

    def __init__(self, grid: OccupancyGrid, target_xy, radius_m: float, reach_m: float) -> None:
        self.grid, self.radius_m, self.reach_m = grid, radius_m, reach_m
        self.target = np.asarray(target_xy, float)[:2]
        r = grid.resolution
        nx, ny = grid.shape
        free = grid.clearance >= radius_m
        self.free = free
        idx, rows, cols, weights = grid_edges(free, r, cut_corners=True)
        n = int(free.sum())
        # two source nodes joined to every free cell within reach: n by the cell's straight
        # distance to the object (the distance to the object), n + 1 by nothing (the distance
        # to where the object is within reach)
        ii, jj = np.nonzero(free)
        centres = np.column_stack([(ii + 0.5) * r, (jj + 0.5) * r])
        straight = np.linalg.norm(centres - self.target, axis=1)
        near = np.flatnonzero(straight <= reach_m)
        for source, w in ((n, np.maximum(straight[near], 1e-9)), (n + 1, np.full(len(near), 1e-9))):
            rows.append(np.full(len(near), source))  # (an edge of weight 0 is no edge)
            cols.append(near)
            weights.append(w)
        graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(n + 2, n + 2)).tocsr()
        d = dijkstra(graph, directed=True, indices=[n, n + 1])
        self.field = np.full((nx, ny), np.inf)
        self.field[free] = d[0, :n]
        self.reach_field = np.full((nx, ny), np.inf)
        self.reach_field[free] = np.maximum(d[1, :n] - 1e-9, 0.0)

    def distance(self, xy) -> float:
        """The geodesic distance from point ``xy`` to the object: its straight distance
        within ``reach_m``, else the least, over the free cells around it (its own and the 8
        beside it), of the straight step to the cell's centre plus the cell's distance (inf
        when none is free)."""
        p = np.asarray(xy, float)[:2]
        straight = float(np.linalg.norm(p - self.target))
        if straight <= self.reach_m:
            return straight
        return self._around(self.field, p)

    def reach_distance(self, xy) -> float:
        """How far the robot at ``xy`` must go (through free space) to stand within
        ``reach_m`` of the object: 0 there."""
        p = np.asarray(xy, float)[:2]
        if float(np.linalg.norm(p - self.target)) <= self.reach_m:
            return 0.0
        return self._around(self.reach_field, p)

    def _around(self, field: np.ndarray, p: np.ndarray) -> float:
        r = self.grid.resolution
        i, j = (int(math.floor(v / r)) for v in p)
        i0, i1 = max(i - 1, 0), min(i + 2, field.shape[0])
        j0, j1 = max(j - 1, 0), min(j + 2, field.shape[1])
        if i0 >= i1 or j0 >= j1:
            return math.inf
        f = field[i0:i1, j0:j1]
        ci = (np.arange(i0, i1) + 0.5) * r
        cj = (np.arange(j0, j1) + 0.5) * r
        step = np.hypot(ci[:, None] - p[0], cj[None, :] - p[1])
        return float((f + step).min())


__all__ = ["GeodesicField", "grid_edges"]
