"""Ground-truth occupancy of a compiled scene: a 2-D grid, free or occupied in the robot's height
band, and the clearance map that motion and planning check the robot's footprint against.

A cell (``resolution`` square, 0.1 m by default, cell (i, j) covers x in [i r, (i + 1) r),
y in [j r, (j + 1) r) of the room frame) is occupied when the footprint of any geom whose vertical
extent overlaps the band [``band_low_m``, ``band_high_m``] covers any of 3 x 3 sample points of the
cell. Footprints are the convex hull of each geom's oriented bounding box (exact for the boxes
furniture is made of, conservative for cylinders and object meshes). The floor and ceiling are
not obstacles; cells outside the room are.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.spatial import ConvexHull

from fallgen.world.scene import Scene


@dataclass(frozen=True)
class OccupancyGrid:
    occupied: np.ndarray  # (nx, ny) bool
    resolution: float  # m per cell
    clearance: np.ndarray  # (nx, ny) m from each cell centre to the nearest occupied cell's edge

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape

    def cell(self, xy) -> tuple[int, int]:
        """Cell index of a point (clipped into the grid)."""
        p = np.asarray(xy, float)[..., :2] / self.resolution
        i = np.clip(np.floor(p).astype(int), 0, np.array(self.shape) - 1)
        return int(i[..., 0]), int(i[..., 1])

    def move_table(self, radius_m: float) -> np.ndarray:
        """Whether a disk of ``radius_m`` fits at each cell, as the simulator's forward-move
        check reads it, with a border for "outside the grid" (clearance 0 there, as
        :meth:`clearance_at` has it): index (i + 1, j + 1) is cell (i, j)."""
        ok = np.full((self.shape[0] + 2, self.shape[1] + 2), 0.0 >= radius_m)
        ok[1:-1, 1:-1] = self.clearance >= radius_m
        return ok

    def clearance_at(self, xy: np.ndarray) -> np.ndarray:
        """(N,) clearance at points (N, 2); points outside the grid have 0."""
        p = np.atleast_2d(np.asarray(xy, float))[:, :2] / self.resolution
        i = np.floor(p).astype(int)
        inside = (i >= 0).all(1) & (i < np.array(self.shape)).all(1)
        out = np.zeros(len(p))
        out[inside] = self.clearance[i[inside, 0], i[inside, 1]]
        return out

    def free_for(self, xy: np.ndarray, radius_m: float) -> np.ndarray:
        """(N,) whether a disk of ``radius_m`` at each point touches nothing occupied."""
        return self.clearance_at(xy) >= radius_m


#: The 8 corners of a unit box, as +-1 signs per axis.
BOX_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


def geom_box_corners(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> np.ndarray:
    """(8, 3) world corners of geom ``g``'s oriented bounding box."""
    c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
    return data.geom_xpos[g] + (c + BOX_SIGNS * h) @ data.geom_xmat[g].reshape(3, 3).T


def _footprints(scene: Scene, data: mujoco.MjData, low: float, high: float,
                keep) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(hull equations, xy min, xy max) of every collision geom (and of the visual geoms of a
    body that has none, and the room's decor: a plant's foliage) in the band whose owner
    ``keep(owner)``."""
    m = scene.model
    solid = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    with_twins = set(m.geom_bodyid[solid].tolist()) - {0}  # the world body: furniture
    out = []
    for g in range(m.ngeom):
        owner = scene.geom_owner[g]
        if owner in ("floor", "ceiling") or not keep(owner):
            continue
        if not solid[g] and m.geom_bodyid[g] in with_twins:
            continue  # a visual geom whose body has collision geoms: those count
        corners = geom_box_corners(m, data, g)
        if corners[:, 2].max() < low or corners[:, 2].min() > high:
            continue
        xy = corners[:, :2]
        lo, hi = xy.min(0), xy.max(0)
        try:
            eq = ConvexHull(xy).equations  # rows (a, b, c): a x + b y + c <= 0 inside
        except Exception:  # degenerate (a zero-width geom): its segment's bounding box
            eq = np.array([[-1, 0, lo[0]], [1, 0, -hi[0]], [0, -1, lo[1]], [0, 1, -hi[1]]], float)
        out.append((eq, lo, hi))
    return out


#: Sample points per cell along each axis (3 x 3 per cell).
SUB = 3


def _samples(n: int, resolution: float) -> np.ndarray:
    """Coordinates of the SUB sample points of each of ``n`` cells along an axis, cell-major."""
    sub = (np.arange(SUB) + 0.5) / SUB
    return ((np.arange(n)[:, None] + sub[None, :]) * resolution).ravel()


def footprint_samples(scene: Scene, data: mujoco.MjData, resolution: float, band_low_m: float,
                      band_high_m: float, keep) -> np.ndarray:
    """(SUB nx, SUB ny) bool: the sample points covered by the footprint of a geom in the band
    whose owner ``keep(owner)``. Each footprint is tested only on the samples inside its
    bounding box (an OR over geoms: the order does not matter)."""
    lx, ly = scene.variant.size_m[:2]
    nx, ny = int(np.ceil(lx / resolution - 1e-9)), int(np.ceil(ly / resolution - 1e-9))
    xs, ys = _samples(nx, resolution), _samples(ny, resolution)
    hit = np.zeros((len(xs), len(ys)), bool)
    for eq, lo, hi in _footprints(scene, data, band_low_m, band_high_m, keep):
        # samples within the box, with a sample of slack each side (the test below decides)
        i0, i1 = np.searchsorted(xs, lo[0] - 1e-6) - 1, np.searchsorted(xs, hi[0] + 1e-6) + 1
        j0, j1 = np.searchsorted(ys, lo[1] - 1e-6) - 1, np.searchsorted(ys, hi[1] + 1e-6) + 1
        i0, j0 = max(i0, 0), max(j0, 0)
        if i0 >= i1 or j0 >= j1:
            continue
        x, y = xs[i0:i1, None], ys[None, j0:j1]
        inside = np.ones((len(x), y.shape[1]), bool)
        for a, b, c in eq:
            inside &= x * a + y * b + c <= 1e-9
        hit[i0:i1, j0:j1] |= inside
    return hit


def occupancy(scene: Scene, data: mujoco.MjData | None = None, resolution: float = 0.1,
              band_low_m: float = 0.03, band_high_m: float = 1.2,
              skip: tuple[str, ...] = ("agent",), static: np.ndarray | None = None
              ) -> OccupancyGrid:
    """The occupancy grid of ``scene`` (geoms at their positions in ``data``; default: the
    compiled positions). Geoms whose owner starts with one of ``skip`` are ignored (the agent
    itself; pass ``("agent", "obj:")`` to ignore loose objects too).

    ``static``: the samples of the room itself (:func:`footprint_samples` of every owner but
    the ``obj:`` objects, the same band and resolution), computed once per room variant; only
    the objects are then rasterised on top (the same grid as without it)."""
    if data is None:
        data = mujoco.MjData(scene.model)
        mujoco.mj_forward(scene.model, data)
    if static is None:
        hit = footprint_samples(scene, data, resolution, band_low_m, band_high_m,
                                lambda o: not o.startswith(skip))
    else:
        objects = footprint_samples(scene, data, resolution, band_low_m, band_high_m,
                                    lambda o: o.startswith("obj:") and not o.startswith(skip))
        hit = static | objects
    nx, ny = hit.shape[0] // SUB, hit.shape[1] // SUB
    occ = hit.reshape(nx, SUB, ny, SUB).any(axis=(1, 3))
    # the room's walls: pad with occupied cells, so clearance also counts the walls
    padded = np.pad(occ, 1, constant_values=True)
    dist = distance_transform_edt(~padded)[1:-1, 1:-1] * resolution
    # from a cell centre to the nearest occupied cell's edge, not its centre
    clearance = np.maximum(dist - resolution / 2, 0.0)
    clearance[occ] = 0.0
    return OccupancyGrid(occ, resolution, clearance)


def room_samples(scene: Scene, data: mujoco.MjData, resolution: float = 0.1,
                 band_low_m: float = 0.03, band_high_m: float = 1.2) -> np.ndarray:
    """The ``static`` layer of :func:`occupancy` for ``scene``'s room (everything but the
    agent and the ``obj:`` objects)."""
    return footprint_samples(scene, data, resolution, band_low_m, band_high_m,
                             lambda o: not o.startswith(("agent", "obj:")))
