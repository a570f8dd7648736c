"""The agent's egocentric camera: RGB, depth and segmentation of a compiled scene, headless.

Rendered by MuJoCo's offscreen renderer (``MUJOCO_GL=egl`` by default, set by ``fallgen`` before
MuJoCo is imported; ``osmesa`` also works). The camera sits at the agent's position at
``AgentSpec.camera_height_m``, looks along its heading, tilted by the pose's tilt (up positive),
with a 90 degree field of view (vertical = horizontal: the image is square), 300 x 300 pixels.

- ``rgb``: (H, W, 3) uint8;
- ``depth``: (H, W) float32 metres along the view axis (MuJoCo's linearised depth buffer);
- ``instance``: (H, W) int16, an index into ``View.instances`` (owner names: ``obj:target``,
  ``obj:d0``, furniture ids, ``wall_<side>``, ``floor``, ``ceiling``, ``agent``), -1 for none;
- ``category``: (H, W) int16, an index into ``CATEGORY_LABELS`` (-1 for none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from fallgen.nav.agent import AgentSpec, Pose
from fallgen.nav.occupancy import geom_box_corners
from fallgen.vision.gl import GLContext, SceneFrames
from fallgen.world.scene import Scene

WIDTH = HEIGHT = 300
FOV_DEG = 90.0


@dataclass(frozen=True)
class View:
    rgb: np.ndarray
    depth: np.ndarray
    instance: np.ndarray
    category: np.ndarray
    instances: tuple[str, ...]

    def pixels_of(self, owner: str) -> int:
        """How many pixels show ``owner`` (e.g. ``obj:target``)."""
        if owner not in self.instances:
            return 0
        return int((self.instance == self.instances.index(owner)).sum())


def category_labels(scene: Scene, object_categories: dict[str, str]) -> tuple[str, ...]:
    """Category of every owner: an object's category (``object_categories``: object name ->
    category id), a furniture item's type, or the room surface (floor, wall, ceiling)."""
    return tuple(sorted({_category(o, scene, object_categories) for o in set(scene.geom_owner)}))


def world_category_labels(world) -> tuple[str, ...]:
    """Every category label a scene of ``world`` can have (the same table for a whole
    dataset): object categories, furniture types, room surfaces, the agent."""
    names = {c.id for c in world.categories} | {"object", "floor", "wall", "ceiling", "agent"}
    for v in world.variants():
        names |= {f.type for f in v.furniture}
    return tuple(sorted(names))


def _category(owner: str, scene: Scene, object_categories: dict[str, str]) -> str:
    if owner.startswith("obj:"):
        return object_categories.get(owner[4:], "object")
    if owner.startswith("wall"):
        return "wall"
    if owner in ("floor", "ceiling", "agent"):
        return owner
    kinds = {f.id: f.type for f in scene.variant.furniture}
    return kinds.get(owner, owner)


class EgoCamera:
    """Renders views of one compiled scene (keep one per scene; pass a long-lived ``context``
    to draw many scenes in one GL context, see :mod:`fallgen.vision.gl`)."""

    def __init__(self, scene: Scene, object_categories: dict[str, str] | None = None,
                 spec: AgentSpec = AgentSpec(), size: int = WIDTH,
                 labels: tuple[str, ...] | None = None,
                 context: GLContext | None = None) -> None:
        """``labels``: the category table to index (default: this scene's own categories);
        ``context``: a GL context of ``size`` to draw in (default: one of its own, closed with
        the camera)."""
        self.scene, self.spec = scene, spec
        if context is not None and context.size != size:
            raise ValueError(f"GL context is {context.size} px, the camera {size} px")
        self._own_context = context is None
        context = context or GLContext(size)
        m = scene.model
        m.vis.global_.fovy = FOV_DEG
        m.vis.map.znear = 0.01  # of the model's extent: ~5 cm in a room
        # An offscreen buffer of the image's own size, and no shadow map when no light casts
        # shadows: the same pixels, but a context made 4x faster (the default 640 x 480
        # multisampled buffer and 4096^2 shadow map cost ~40 ms per scene on a CPU renderer).
        m.vis.global_.offwidth = m.vis.global_.offheight = size
        if not m.light_castshadow.any():
            m.vis.quality.shadowsize = 0
        self.frames = SceneFrames(m, context, max_geom=max(1000, 4 * m.ngeom))
        self.instances = tuple(sorted(set(scene.geom_owner)))
        inst_of_geom = np.array([self.instances.index(o) for o in scene.geom_owner], np.int16)
        cats = object_categories or {}
        self.categories = labels or category_labels(scene, cats)
        cat_of_geom = np.array([self.categories.index(_category(o, scene, cats))
                                for o in scene.geom_owner], np.int16)
        # lookup by geom id, with a slot for "no geom" (-1 -> last)
        self._inst = np.append(inst_of_geom, np.int16(-1))
        self._geoms_of: dict[str, list[int]] = {}
        for g, o in enumerate(scene.geom_owner):
            self._geoms_of.setdefault(o, []).append(g)
        self._cat = np.append(cat_of_geom, np.int16(-1))

    def close(self) -> None:
        self.frames.close()
        if self._own_context:
            self.frames.context.close()

    def _eye_and_forward(self, pose: Pose) -> tuple[np.ndarray, np.ndarray]:
        """The camera's position and unit view direction (room frame) at ``pose``."""
        yaw, tilt = pose.yaw_rad, math.radians(pose.tilt_deg)
        fwd = np.array([math.cos(tilt) * math.cos(yaw), math.cos(tilt) * math.sin(yaw),
                        math.sin(tilt)])
        return np.array([pose.x, pose.y, self.spec.camera_height_m]), fwd

    def camera(self, pose: Pose) -> mujoco.MjvCamera:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        eye, fwd = self._eye_and_forward(pose)
        d = 1.0
        cam.lookat[:] = eye + d * fwd
        cam.distance = d
        cam.azimuth = math.degrees(pose.yaw_rad)
        cam.elevation = pose.tilt_deg
        return cam

    def render(self, data: mujoco.MjData, pose: Pose, what: str = "all") -> View:
        """The view from ``pose``; ``what="segmentation"`` renders only the segmentation."""
        f, cam = self.frames, self.camera(pose)
        rgb = depth = None
        if what == "all":
            rgb = f.rgb(data, cam)
            depth = f.depth(data, cam)
        geom = f.geoms(data, cam)
        inst, cat = self._inst[geom], self._cat[geom]
        empty = np.zeros((0, 0), np.float32)
        return View(rgb if rgb is not None else np.zeros((0, 0, 3), np.uint8),
                    depth if depth is not None else empty, inst, cat, self.instances)

    def pixels_of(self, data: mujoco.MjData, pose: Pose, owner: str = "obj:target") -> int:
        """How many pixels of the view from ``pose`` show ``owner``: 0 without rendering when
        its geoms' bounding boxes lie wholly outside the view frustum, else counted in a
        segmentation render."""
        if self.outside_view(data, pose, owner):
            return 0
        return self.render(data, pose, "segmentation").pixels_of(owner)

    def outside_view(self, data: mujoco.MjData, pose: Pose, owner: str) -> bool:
        """Whether every corner of ``owner``'s geoms' oriented boxes is beyond one side of the
        view frustum (behind the camera, or past the left, right, top or bottom edge, with a
        margin): then no pixel can show it."""
        geoms = self._geoms_of.get(owner)
        if not geoms:
            return True
        m = self.scene.model
        pts = np.vstack([geom_box_corners(m, data, g) for g in geoms])
        eye, f = self._eye_and_forward(pose)
        r = np.array([math.sin(pose.yaw_rad), -math.cos(pose.yaw_rad), 0.0])
        u = np.cross(r, f)
        rel = pts - eye
        x, y, z = rel @ r, rel @ u, rel @ f
        t = math.tan(math.radians(FOV_DEG / 2)) * 1.05  # 5 % wider than the image
        slack = 0.02  # m
        return bool((z < -slack).all() or (x > t * z + slack).all() or (-x > t * z + slack).all()
                    or (y > t * z + slack).all() or (-y > t * z + slack).all())
