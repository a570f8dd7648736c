"""The room from above, for ``render_mode="rgb_array"``: the occupancy grid, the object, the
spawn, the path so far and the agent with its heading, drawn in a square panel (north up)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from fallgen.nav.agent import SUCCESS_DISTANCE_M, Pose
from fallgen.nav.occupancy import OccupancyGrid

FREE = (235, 235, 230)
OCCUPIED = (90, 90, 96)
PATH = (40, 110, 220)
AGENT = (20, 60, 180)
OBJECT = (220, 40, 40)
REACH = (240, 170, 170)
SPAWN = (40, 160, 60)


def top_down(grid: OccupancyGrid, target_xy, poses: Sequence[Pose], size: int = 300,
             radius_m: float = 0.2) -> np.ndarray:
    """(size, size, 3) uint8: the grid scaled to fit (aspect kept, margins white), the
    success circle around the object, the spawn, the path and the agent."""
    nx, ny = grid.shape
    r = grid.resolution
    scale = (size - 8) / max(nx * r, ny * r)  # pixels per metre
    w, h = int(round(nx * r * scale)), int(round(ny * r * scale))
    x0, y0 = (size - w) // 2, (size - h) // 2
    img = np.full((size, size, 3), 255, np.uint8)
    # cell (i, j) -> pixel block; rows from the top are north first
    cells = np.where(grid.occupied.T[::-1, :, None], np.array(OCCUPIED, np.uint8),
                     np.array(FREE, np.uint8))
    img[y0:y0 + h, x0:x0 + w] = cv2.resize(cells, (w, h), interpolation=cv2.INTER_NEAREST)

    def px(x: float, y: float) -> tuple[int, int]:
        return (int(round(x0 + x * scale)), int(round(y0 + h - y * scale)))

    t = np.asarray(target_xy, float)
    cv2.circle(img, px(t[0], t[1]), int(round(SUCCESS_DISTANCE_M * scale)), REACH, 1,
               cv2.LINE_AA)
    if poses:
        s = poses[0]
        cv2.drawMarker(img, px(s.x, s.y), SPAWN, cv2.MARKER_TILTED_CROSS, 8, 2)
        pts = np.array([px(p.x, p.y) for p in poses], np.int32)
        if len(pts) > 1:
            cv2.polylines(img, [pts], False, PATH, 1, cv2.LINE_AA)
        a = poses[-1]
        c = px(a.x, a.y)
        cv2.circle(img, c, max(2, int(round(radius_m * scale))), AGENT, 2, cv2.LINE_AA)
        tip = px(a.x + 2 * radius_m * math.cos(a.yaw_rad), a.y + 2 * radius_m * math.sin(a.yaw_rad))
        cv2.line(img, c, tip, AGENT, 2, cv2.LINE_AA)
    cv2.circle(img, px(t[0], t[1]), 4, OBJECT, -1, cv2.LINE_AA)
    return img


__all__ = ["top_down"]
