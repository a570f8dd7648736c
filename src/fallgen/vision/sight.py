"""Line of sight from the agent's camera to the target, by MuJoCo ray casts.

:func:`line_of_sight` says whether nothing but the target lies between the camera and one of a
few points inside the target (the expert's cheap test before it renders a candidate pose). It
casts one ray at a time (``mj_ray``, on the geom groups the camera draws) and stops at the first
clear one: ``mj_multiRay`` first bounds every geom as seen from the eye, which costs more than
the rays, and most candidate poses are blocked on every ray.

A box geom (a wall, a cabinet, a shelf board) that blocks one ray usually blocks the others.
The rays it enters (slab test, compiled with Numba) before their point and before they enter the
target's box are blocked whatever else they meet (their nearest hit is no farther, and cannot be
the target), so they are not cast: the verdict is exactly that of casting every ray, with
``RAY_MARGIN_M`` of slack for rounding in the slab test.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numba import njit

#: The geom groups views draw (MuJoCo's default visualisation options): 0, 1 and 2.
DRAWN_GROUPS = np.array(mujoco.MjvOption().geomgroup, np.uint8)
#: Slack (m) on the ray-box distances that spare a ray cast, for rounding.
RAY_MARGIN_M = 1e-6
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_IDENTITY = np.eye(3)
_ORIGIN = np.zeros(3)


@njit(cache=True)
def box_entries(eye, unit, lo, hi, rot, centre, out):
    """``out[i]``: the distance along ray i (from ``eye`` along the unit row ``unit[i]``) at
    which it enters the box [lo, hi] of the frame at ``centre`` whose axes are the columns of
    ``rot`` (slab test); inf if it misses the box (or the box is behind the eye), <= 0 from
    inside it."""
    p = np.empty(3)
    for k in range(3):
        p[k] = ((eye[0] - centre[0]) * rot[0, k] + (eye[1] - centre[1]) * rot[1, k]
                + (eye[2] - centre[2]) * rot[2, k])
    for i in range(unit.shape[0]):
        near, far = -math.inf, math.inf
        for k in range(3):
            u = unit[i, 0] * rot[0, k] + unit[i, 1] * rot[1, k] + unit[i, 2] * rot[2, k]
            if u == 0.0:  # parallel to the slab: inside it or never in the box
                if p[k] < lo[k] or p[k] > hi[k]:
                    near = math.inf
                continue
            a, b = (lo[k] - p[k]) / u, (hi[k] - p[k]) / u
            if a > b:
                a, b = b, a
            near, far = max(near, a), min(far, b)
        out[i] = near if near <= far and far >= 0.0 else math.inf


@njit(cache=True)
def mark_blocked(eye, unit, reach, size, rot, centre, blocked):
    """Set ``blocked[i]`` for the rays that enter the box geom (half sizes ``size``, frame
    ``rot``, ``centre``) more than ``RAY_MARGIN_M`` ahead of the eye and before ``reach[i]``."""
    hits = np.empty(unit.shape[0])
    box_entries(eye, unit, -size, size, rot, centre, hits)
    for i in range(unit.shape[0]):
        if RAY_MARGIN_M < hits[i] < reach[i]:
            blocked[i] = True


def line_of_sight(model: mujoco.MjModel, data: mujoco.MjData, owners, eye: np.ndarray,
                  points: np.ndarray, box: tuple[np.ndarray, np.ndarray],
                  target: str = "obj:target") -> bool:
    """Whether a ray from ``eye`` reaches one of ``points`` with nothing but ``target``'s geoms
    (``owners``: each geom's owner name) in the way; ``box`` = (lo, hi), an axis-aligned box
    holding every geom of the target."""
    v = points - eye
    dist = np.sqrt((v * v).sum(1))
    unit = v / dist[:, None]
    geomid = np.zeros(1, np.int32)
    types = model.geom_type
    blocked = reach = None
    for i, d in enumerate(dist.tolist()):
        if blocked is not None and blocked[i]:
            continue
        h = mujoco.mj_ray(model, data, eye, unit[i], DRAWN_GROUPS, 1, -1, geomid)
        g = int(geomid[0])
        if h < 0 or h >= d or owners[g] == target:
            return True
        if types[g] == _BOX:
            if reach is None:
                reach = np.empty(len(dist))
                box_entries(eye, unit, box[0], box[1], _IDENTITY, _ORIGIN, reach)
                reach = np.minimum(reach, dist) - RAY_MARGIN_M
                blocked = np.zeros(len(dist), np.bool_)
            mark_blocked(eye, unit, reach, model.geom_size[g], data.geom_xmat[g].reshape(3, 3),
                         data.geom_xpos[g], blocked)
    return False
