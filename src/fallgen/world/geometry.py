"""Oriented boxes (yaw-only rotation) and the overlap tests that room validation needs.

Rooms are made of axis-aligned boxes and vertical cylinders placed with a yaw about +z, so every
piece of furniture, fall-zone volume and drop region is a :class:`Box` with a yaw. Overlaps are
computed with the separating-axis theorem in the plane and an interval test in z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Box:
    """A box with centre ``center`` (m), half sizes ``half`` (m) and rotation ``yaw`` (rad) about +z."""

    center: tuple[float, float, float]
    half: tuple[float, float, float]
    yaw: float = 0.0

    @staticmethod
    def from_bounds(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> Box:
        lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
        return Box(tuple((lo_a + hi_a) / 2), tuple((hi_a - lo_a) / 2), 0.0)

    @property
    def zmin(self) -> float:
        return self.center[2] - self.half[2]

    @property
    def zmax(self) -> float:
        return self.center[2] + self.half[2]

    @property
    def size(self) -> tuple[float, float, float]:
        return (2 * self.half[0], 2 * self.half[1], 2 * self.half[2])

    def axes2d(self) -> np.ndarray:
        """Unit vectors of the box's local x and y axes in the world plane, shape (2, 2)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, s], [-s, c]])

    def corners2d(self) -> np.ndarray:
        """Footprint corners in counter-clockwise order, shape (4, 2)."""
        ax = self.axes2d()
        hx, hy = self.half[0], self.half[1]
        c = np.asarray(self.center[:2])
        return np.array(
            [c - hx * ax[0] - hy * ax[1], c + hx * ax[0] - hy * ax[1],
             c + hx * ax[0] + hy * ax[1], c - hx * ax[0] + hy * ax[1]]
        )

    def to_local(self, points: np.ndarray) -> np.ndarray:
        """World points (n, 3) -> the box's frame (centred, unrotated)."""
        p = np.atleast_2d(np.asarray(points, float)) - np.asarray(self.center)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        x = c * p[:, 0] + s * p[:, 1]
        y = -s * p[:, 0] + c * p[:, 1]
        return np.stack([x, y, p[:, 2]], axis=1)

    def contains(self, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """Whether each point (n, 3) lies inside the box grown by ``tol``."""
        q = np.abs(self.to_local(points))
        return np.all(q <= np.asarray(self.half) + tol, axis=1)

    def placed(self, xy: tuple[float, float], yaw: float, dz: float = 0.0) -> Box:
        """This box, given in a local frame, expressed in a frame placed at ``xy``/``yaw``."""
        c, s = math.cos(yaw), math.sin(yaw)
        x, y, z = self.center
        return Box(
            (xy[0] + c * x - s * y, xy[1] + s * x + c * y, z + dz), self.half, self.yaw + yaw
        )

    def shrunk(self, dx: float, dy: float = None, dz: float = 0.0) -> Box:  # type: ignore[assignment]
        dy = dx if dy is None else dy
        h = (max(self.half[0] - dx, 0.0), max(self.half[1] - dy, 0.0), max(self.half[2] - dz, 0.0))
        return Box(self.center, h, self.yaw)

    def with_z(self, zmin: float, zmax: float) -> Box:
        return Box((self.center[0], self.center[1], (zmin + zmax) / 2), (
            self.half[0], self.half[1], (zmax - zmin) / 2), self.yaw)

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        cs = self.corners2d()
        lo = np.array([cs[:, 0].min(), cs[:, 1].min(), self.zmin])
        hi = np.array([cs[:, 0].max(), cs[:, 1].max(), self.zmax])
        return lo, hi

    @property
    def quat(self) -> tuple[float, float, float, float]:
        """MuJoCo quaternion (w, x, y, z) of the yaw."""
        return (math.cos(self.yaw / 2), 0.0, 0.0, math.sin(self.yaw / 2))


class BoxSet:
    """Many boxes at once: whether any of them holds any of some points, with the same
    arithmetic as each box's :meth:`Box.contains` (so the same verdict, to the bit)."""

    def __init__(self, boxes: list[Box]) -> None:
        self.center = np.array([b.center for b in boxes], float).reshape(-1, 3)
        self.half = np.array([b.half for b in boxes], float).reshape(-1, 3)
        # math.cos and math.sin, as Box.to_local takes them (NumPy's may differ in the last bit)
        self.cos = np.array([math.cos(b.yaw) for b in boxes], float)
        self.sin = np.array([math.sin(b.yaw) for b in boxes], float)

    def any_contains(self, points: np.ndarray, tol: float = 0.0) -> bool:
        """Whether some box grown by ``tol`` holds some point of ``points`` (n, 3)."""
        if not len(self.center):
            return False
        p = np.atleast_2d(np.asarray(points, float))[None, :, :] - self.center[:, None, :]
        c, s = self.cos[:, None], self.sin[:, None]
        x = c * p[..., 0] + s * p[..., 1]
        y = -s * p[..., 0] + c * p[..., 1]
        lim = self.half + tol
        return bool(((np.abs(x) <= lim[:, 0:1]) & (np.abs(y) <= lim[:, 1:2])
                     & (np.abs(p[..., 2]) <= lim[:, 2:3])).any())


def overlap2d(a: Box, b: Box) -> float:
    """Penetration depth of the two footprints (> 0 overlapping, <= 0 separated by that gap)."""
    ca, cb = a.corners2d(), b.corners2d()
    depth = math.inf
    for axis in np.vstack([a.axes2d(), b.axes2d()]):
        pa, pb = ca @ axis, cb @ axis
        depth = min(depth, min(pa.max(), pb.max()) - max(pa.min(), pb.min()))
    return float(depth)


def overlapz(a: Box, b: Box) -> float:
    return min(a.zmax, b.zmax) - max(a.zmin, b.zmin)


def penetration(a: Box, b: Box) -> float:
    """Depth by which two boxes interpenetrate in 3-D (> 0 overlapping)."""
    return min(overlap2d(a, b), overlapz(a, b))


def footprint_inside(inner: Box, outer: Box, tol: float = 0.0) -> bool:
    """Whether ``inner``'s footprint lies inside ``outer``'s footprint (grown by ``tol``)."""
    corners = np.column_stack([inner.corners2d(), np.full(4, outer.center[2])])
    q = np.abs(outer.to_local(corners))
    return bool(np.all(q[:, :2] <= np.asarray(outer.half[:2]) + tol))
