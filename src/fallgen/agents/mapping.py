"""The modular agent's map of the room, built from its own depth images as it goes, and the
distance fields it plans with.

Everything is in the spawn's frame (the ``pose`` sensor's: x forward, y left of the spawn,
metres; heading counter-clockwise), on a grid of ``CELL_M`` cells with the spawn at its
centre. A depth pixel is back-projected through the camera (90 degree field of view, 300 x 300
pixels, ``AgentSpec.camera_height_m`` above the floor, the pose's heading and tilt): a point
below ``FLOOR_M`` marks its cell free (floor seen), a point within the robot's height band
(``FLOOR_M`` to ``BAND_HIGH_M``) marks it an obstacle; obstacles win over free. Cells the robot
has stood on are free; a forward move that did not happen marks the cell ahead blocked. Unknown
cells count as free for planning (optimistic: a plan through them is corrected when they are
seen).

Distance fields are Dijkstra over the cells where the robot's disk fits (clearance at least
its radius, unknown cells free), 8-connected without cutting corners
(:func:`fallgen.nav.geodesic.grid_edges`), computed in a window around what is known, the
robot and the goal.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from fallgen.nav.agent import HEADING_VECTORS, STEP_FRACTIONS, STEP_M, AgentSpec
from fallgen.nav.geodesic import grid_edges
from fallgen.vision.camera import FOV_DEG, HEIGHT, WIDTH

CELL_M = 0.1
#: cells a side (40 m: any room of ours from any spawn in it)
SIZE = 400
#: a point below this height (m) is floor; up to BAND_HIGH_M an obstacle to the robot
FLOOR_M = 0.04
BAND_HIGH_M = 1.25
#: diagonal steps of the planner's graph may pass between two cells where the robot does
#: not fit (see :meth:`EgoMap.field`)
CUT_CORNERS = True
#: how far (m) a surface point is pushed along its horizontal ray before it is binned
SURFACE_PUSH_M = 0.01
#: depth beyond this (m) is not mapped (far floor seen at a grazing angle)
MAX_RANGE_M = 7.0
#: the focal length of the camera in pixels (square pixels, 90 degrees across 300)
FOCAL_PX = (WIDTH / 2) / math.tan(math.radians(FOV_DEG / 2))
#: cells of margin around the planning window
MARGIN_CELLS = 12
#: the robot fits where the map's clearance is its radius less this (m): an obstacle is
#: known to a cell of a grid turned with the spawn's heading against the room, so the
#: clearance is up to ~half a cell short of the room's own (a move that still touches
#: something is stopped by the simulator, and the map remembers it: :meth:`EgoMap.block`)
FIT_SLACK_M = CELL_M / 2


@dataclass(frozen=True)
class AgentPose:
    """The agent's pose in the spawn's frame, from the ``pose`` sensor."""

    x: float
    y: float
    yaw: float  # rad, counter-clockwise
    tilt: float  # rad, up positive

    @classmethod
    def from_obs(cls, pose: np.ndarray) -> AgentPose:
        p = np.asarray(pose, float)
        return cls(float(p[0]), float(p[1]), float(p[2]), float(p[3]))

    @property
    def xy(self) -> np.ndarray:
        return np.array([self.x, self.y])

    @property
    def heading(self) -> int:
        """The heading in 30-degree steps (0 .. 11)."""
        return int(round(math.degrees(self.yaw) / 30.0)) % len(HEADING_VECTORS)

    @property
    def tilt_deg(self) -> int:
        return int(round(math.degrees(self.tilt)))


def camera_axes(yaw: float, tilt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(right, up, forward) unit vectors of the camera at heading ``yaw`` and ``tilt`` (the
    renderer's free camera: its right vector horizontal)."""
    f = np.array([math.cos(tilt) * math.cos(yaw), math.cos(tilt) * math.sin(yaw),
                  math.sin(tilt)])
    r = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    return r, np.cross(r, f), f


def back_project(depth: np.ndarray, rows: np.ndarray, cols: np.ndarray, pose: AgentPose,
                 camera_height_m: float) -> np.ndarray:
    """(N, 3) points (spawn frame; z above the floor) seen at pixels (``rows``, ``cols``) of
    a depth image (metres along the optical axis)."""
    z = depth[rows, cols].astype(float)
    xr = (cols + 0.5 - WIDTH / 2) / FOCAL_PX * z
    yu = (HEIGHT / 2 - rows - 0.5) / FOCAL_PX * z
    r, u, f = camera_axes(pose.yaw, pose.tilt)
    eye = np.array([pose.x, pose.y, camera_height_m])
    return eye + xr[:, None] * r + yu[:, None] * u + z[:, None] * f


def project(points: np.ndarray, pose: AgentPose, camera_height_m: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(row, col, depth) of spawn-frame ``points`` (N, 3) in the image at ``pose`` (rows and
    columns as floats; depth <= 0 behind the camera)."""
    r, u, f = camera_axes(pose.yaw, pose.tilt)
    rel = np.atleast_2d(points) - np.array([pose.x, pose.y, camera_height_m])
    z = rel @ f
    with np.errstate(divide="ignore", invalid="ignore"):
        col = rel @ r / z * FOCAL_PX + WIDTH / 2 - 0.5
        row = HEIGHT / 2 - 0.5 - rel @ u / z * FOCAL_PX
    return row, col, z


@functools.cache
def _all_centres() -> np.ndarray:
    c = EgoMap.centres(*np.mgrid[0:SIZE, 0:SIZE])
    c.setflags(write=False)
    return c


class EgoMap:
    """What the agent knows of the room (see the module's docstring)."""

    def __init__(self, spec: AgentSpec = AgentSpec(), stride: int = 3) -> None:
        self.spec, self.stride = spec, stride
        self.obstacle = np.zeros((SIZE, SIZE), bool)
        self.free = np.zeros((SIZE, SIZE), bool)
        self.visits = np.zeros((SIZE, SIZE), np.int32)
        self.blocked: set[tuple[int, int, int]] = set()
        r = np.arange(stride // 2, HEIGHT, stride)
        c = np.arange(stride // 2, WIDTH, stride)
        self._rows, self._cols = (a.ravel() for a in np.meshgrid(r, c, indexing="ij"))
        self._clear: np.ndarray | None = None

    # --- cells ----------------------------------------------------------------------------

    @staticmethod
    def cells(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cell indices (i, j) of spawn-frame points (..., 2), clipped into the map."""
        p = np.floor(np.asarray(xy, float) / CELL_M).astype(np.int64) + SIZE // 2
        p = np.clip(p, 0, SIZE - 1)
        return p[..., 0], p[..., 1]

    @staticmethod
    def centres(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        return np.stack([(np.asarray(i) - SIZE // 2 + 0.5) * CELL_M,
                         (np.asarray(j) - SIZE // 2 + 0.5) * CELL_M], axis=-1)

    @staticmethod
    def all_centres() -> np.ndarray:
        """(SIZE, SIZE, 2) the centre of every cell (computed once, read-only)."""
        return _all_centres()

    @property
    def known(self) -> np.ndarray:
        return self.free | self.obstacle

    # --- updates --------------------------------------------------------------------------

    def integrate(self, depth: np.ndarray, pose: AgentPose) -> None:
        """Add what a depth image (H, W) seen from ``pose`` shows."""
        d = depth.reshape(HEIGHT, WIDTH)
        z = d[self._rows, self._cols]
        ok = (z > 0) & (z < MAX_RANGE_M)
        pts = back_project(d, self._rows[ok], self._cols[ok], pose, self.spec.camera_height_m)
        i, j = self.cells(pts[:, :2])
        floor = pts[:, 2] < FLOOR_M
        band = ~floor & (pts[:, 2] <= BAND_HIGH_M)
        self.free[i[floor], j[floor]] = True
        # a surface point is put into the cell behind it (a wall's or a cabinet's face often
        # lies on a cell boundary, and the true grid's cell is the one it bounds)
        ray = pts[band, :2] - np.array([pose.x, pose.y])
        ray /= np.maximum(np.linalg.norm(ray, axis=1, keepdims=True), 1e-9)
        i, j = self.cells(pts[band, :2] + SURFACE_PUSH_M * ray)
        self.obstacle[i, j] = True
        self._clear = None

    def visit(self, xy: np.ndarray) -> None:
        """The robot stands at ``xy``: its footprint is free."""
        i, j = self.cells(xy)
        k = int(math.ceil(self.spec.radius_m / CELL_M))
        ii, jj = np.mgrid[i - k:i + k + 1, j - k:j + k + 1]
        inside = (ii >= 0) & (jj >= 0) & (ii < SIZE) & (jj < SIZE)
        near = np.hypot(*(self.centres(ii, jj) - np.asarray(xy)).transpose(2, 0, 1)) \
            <= self.spec.radius_m
        sel = inside & near
        self.free[ii[sel], jj[sel]] = True
        self.obstacle[ii[sel], jj[sel]] = False
        self.visits[i, j] += 1
        self._clear = None

    def block(self, xy: np.ndarray, heading: int) -> None:
        """A forward move from ``xy`` along ``heading`` did not happen: that move is not
        tried again from this cell, and something is ahead, within the robot's radius of
        the move's segment (marked where the disk would have ended)."""
        i, j = self.cells(xy)
        self.blocked.add((int(i), int(j), int(heading) % len(HEADING_VECTORS)))
        for f in (STEP_M + self.spec.radius_m / 2, STEP_M + self.spec.radius_m):
            ai, aj = self.cells(np.asarray(xy) + f * HEADING_VECTORS[heading])
            self.obstacle[ai, aj] = True
            self.free[ai, aj] = False
        self._clear = None

    # --- planning -------------------------------------------------------------------------

    @property
    def clearance(self) -> np.ndarray:
        """Metres from each cell centre to the nearest obstacle cell's edge (unknown: free)."""
        if self._clear is None:
            dist = distance_transform_edt(~self.obstacle) * CELL_M
            self._clear = np.where(self.obstacle, 0.0, np.maximum(dist - CELL_M / 2, 0.0))
        return self._clear

    def fits(self, xy: np.ndarray, slack_m: float = 0.0) -> np.ndarray:
        """(N,) whether the robot's disk fits at points (N, 2) as far as the map knows."""
        i, j = self.cells(np.atleast_2d(xy))
        return self.clearance[i, j] >= self.spec.radius_m - slack_m

    def move_fits(self, xy: np.ndarray, heading: int, slack_m: float = FIT_SLACK_M) -> bool:
        """Whether a forward move from ``xy`` along ``heading`` fits (every 5 cm, as the
        simulator checks it), and was not blocked from here before."""
        i, j = self.cells(xy)
        if (int(i), int(j), int(heading) % len(HEADING_VECTORS)) in self.blocked:
            return False
        b = np.asarray(xy) + STEP_M * HEADING_VECTORS[heading]
        pts = np.asarray(xy)[None, :] + STEP_FRACTIONS[:, None] * (b - np.asarray(xy))[None, :]
        return bool(self.fits(pts, slack_m).all())

    def window(self, *points: np.ndarray) -> tuple[slice, slice]:
        """The planning window: what is known, and ``points`` (..., 2), with a margin."""
        ii, jj = np.nonzero(self.known)
        for p in points:
            pi, pj = self.cells(np.asarray(p).reshape(-1, 2))
            ii, jj = np.concatenate([ii, pi]), np.concatenate([jj, pj])
        i0 = max(int(ii.min()) - MARGIN_CELLS, 0)
        j0 = max(int(jj.min()) - MARGIN_CELLS, 0)
        return (slice(i0, min(int(ii.max()) + MARGIN_CELLS + 1, SIZE)),
                slice(j0, min(int(jj.max()) + MARGIN_CELLS + 1, SIZE)))

    def field(self, win: tuple[slice, slice], sources: np.ndarray, costs: np.ndarray,
              slack_m: float = FIT_SLACK_M) -> np.ndarray:
        """(SIZE, SIZE) path length (+ the source's cost) to the nearest of the ``sources``
        (a boolean (SIZE, SIZE) mask; ``costs`` the same shape) through cells where the
        robot fits, within ``win``; inf elsewhere."""
        fit = self.clearance[win] >= self.spec.radius_m - slack_m
        src = sources[win] & fit
        out = np.full((SIZE, SIZE), np.inf)
        if not src.any():
            return out
        # a diagonal step between two cells where the robot fits may pass cells where it does
        # not by the cell rule (its clearance there is at least its radius less ~0.07 m): a
        # gap the robot's 0.25 m moves pass diagonally is a gap here too
        idx, rows, cols, weights = grid_edges(fit, CELL_M, cut_corners=CUT_CORNERS)
        n = int(fit.sum())
        s = idx[src]
        rows.append(np.full(len(s), n))
        cols.append(s)
        weights.append(np.maximum(costs[win][src], 1e-9))  # an edge of weight 0 is no edge
        graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows),
                                                      np.concatenate(cols))),
                           shape=(n + 1, n + 1)).tocsr()
        d = dijkstra(graph, directed=True, indices=n)
        sub = np.full(fit.shape, np.inf)
        sub[fit] = d[:n]
        out[win] = sub
        return out

    def value(self, field: np.ndarray, xy: np.ndarray) -> float:
        """The field at a point: the least, over its cell and the 8 beside it, of the cell's
        value plus the straight step to its centre."""
        i, j = self.cells(xy)
        i0, i1, j0, j1 = max(i - 1, 0), min(i + 2, SIZE), max(j - 1, 0), min(j + 2, SIZE)
        ii, jj = np.mgrid[i0:i1, j0:j1]
        step = np.linalg.norm(self.centres(ii, jj) - np.asarray(xy), axis=-1)
        return float((field[i0:i1, j0:j1] + step).min())

    def frontier(self) -> np.ndarray:
        """Known free cells where the robot fits with an unknown cell beside them."""
        known = self.known
        unknown_near = np.zeros_like(known)
        unknown_near[1:, :] |= ~known[:-1, :]
        unknown_near[:-1, :] |= ~known[1:, :]
        unknown_near[:, 1:] |= ~known[:, :-1]
        unknown_near[:, :-1] |= ~known[:, 1:]
        return self.free & ~self.obstacle & unknown_near & \
            (self.clearance >= self.spec.radius_m)


__all__ = ["AgentPose", "EgoMap", "CELL_M", "SIZE", "FOCAL_PX", "back_project", "project",
           "camera_axes"]
