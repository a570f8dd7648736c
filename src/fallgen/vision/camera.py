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

import cv2
import mujoco
import numpy as np

from fallgen.nav.agent import AgentSpec, Pose
from fallgen.nav.occupancy import geom_box_corners
from fallgen.vision.gl import GLContext, SceneFrames
from fallgen.vision.faces import DRAWN_GROUPS
from fallgen.world.scene import WALL_OWNERS, Scene

WIDTH = HEIGHT = 300
FOV_DEG = 90.0
#: Shadow map size (pixels a side) where the scene's light casts shadows: ~6 cm a texel over
#: its cone in a room (soft-edged shadows of tables and chairs). The depth pass draws the map's
#: pixels: 1024 cost 6 ms more a view and 30 ms more a camera than 512 on a CPU renderer, 512
#: 3-4 ms more a view than 256 (MuJoCo's default 4096, ~40 ms a context). A scene standing
#: still draws it once, at its first colour view (vision/gl.py keeps it for the later ones).
SHADOW_MAP_PX = 256
#: Multisampling of the offscreen buffer (MuJoCo's default 4). Off: on a CPU renderer 4x MSAA
#: made a textured view's RGB 19.9 instead of 10.6 ms and RGB + depth + segmentation 24.9
#: instead of 13.6 ms (the multisampled draws and their resolve on every read; 3 variants,
#: 12 poses each, 2026-11-26), and it is what kept a paper-size build over its 15 minutes and
#: the environment under 100 steps a second. The price: polygon edges are not anti-aliased
#: (a stair step on high-contrast edges; the detail share is unchanged). Segmentation and
#: depth never used it.
OFFSCREEN_SAMPLES = 0
#: How far (pixels) beyond the projected outline of an object's boxes a drawn pixel's centre may
#: lie: float32 rounding in the renderer's projection is ~1e-4 pixel; tests/vision checks
#: that the bound holds over thousands of random views.
HULL_SLACK_PX = 0.05
#: A visibility count of a cropped render (see :meth:`SceneFrames.geoms`) decides a
#: threshold only this many pixels or more away from it (its pixels differ from the full
#: image's where an edge passes through a pixel centre: 2 counts in 1530 differed, by 1).
CROP_MARGIN_PX = 3


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
    if owner in WALL_OWNERS:  # not a wall cabinet ("wall_cab_n")
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
        m.vis.quality.offsamples = OFFSCREEN_SAMPLES
        m.vis.quality.shadowsize = SHADOW_MAP_PX if m.light_castshadow.any() else 0
        # room for every geom and site the default options draw, twice over (a scene's
        # arrays cost ~2 us a slot to make; SceneFrames refuses a full scene)
        self._max_geom = 2 * (m.ngeom + m.nsite) + 64
        self._context, self.size = context, size
        self._frames: SceneFrames | None = None  # made on the first draw (see frames)
        self.instances = tuple(sorted(set(scene.geom_owner)))
        inst_of_geom = np.array([self.instances.index(o) for o in scene.geom_owner], np.int16)
        cats = object_categories or {}
        self.categories = labels or category_labels(scene, cats)
        cat_of_geom = np.array([self.categories.index(_category(o, scene, cats))
                                for o in scene.geom_owner], np.int16)
        # lookup by geom id, with a slot for "no geom" (-1 -> last)
        self._inst = np.append(inst_of_geom, np.int16(-1))
        self._geoms_of: dict[str, list[int]] = {}
        self._drawn_geoms_of: dict[str, list[int]] = {}  # in the geom groups views draw
        for g, o in enumerate(scene.geom_owner):
            self._geoms_of.setdefault(o, []).append(g)
            if DRAWN_GROUPS[min(int(m.geom_group[g]), len(DRAWN_GROUPS) - 1)] \
                    and m.geom_rgba[g, 3] > 0:
                self._drawn_geoms_of.setdefault(o, []).append(g)
        self._cat = np.append(cat_of_geom, np.int16(-1))

    @property
    def frames(self) -> SceneFrames:
        """The scene's render context, made on first use: a camera asked only what its
        bounds answer without drawing (:meth:`shows` of a view that cannot show enough)
        uploads no meshes and textures (~6 ms a scene on a CPU renderer)."""
        if self._frames is None:
            self._frames = SceneFrames(self.scene.model, self._context, self._max_geom)
        return self._frames

    def close(self) -> None:
        if self._frames is not None:
            self._frames.close()
            self._frames = None
        if self._own_context:
            self._context.close()

    def _eye_and_forward(self, pose: Pose) -> tuple[np.ndarray, np.ndarray]:
        """The camera's position and unit view direction (room frame) at ``pose``."""
        yaw, tilt = pose.yaw_rad, math.radians(pose.tilt_deg)
        fwd = np.array([math.cos(tilt) * math.cos(yaw), math.cos(tilt) * math.sin(yaw),
                        math.sin(tilt)])
        return np.array([pose.x, pose.y, self.spec.camera_height_m]), fwd

    def _view_coordinates(self, pose: Pose, points: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x right, y up, z forward) of room-frame ``points`` (N, 3) in the camera's frame at
        ``pose`` (a free camera: its right vector is horizontal)."""
        eye, f = self._eye_and_forward(pose)
        r0, r1, r2 = math.sin(pose.yaw_rad), -math.cos(pose.yaw_rad), 0.0
        f0, f1, f2 = f.tolist()
        r = np.array([r0, r1, r2])
        # up = right x forward, as np.cross computes it (term for term)
        u = np.array([r1 * f2 - r2 * f1, r2 * f0 - r0 * f2, r0 * f1 - r1 * f0])
        rel = points - eye
        return rel @ r, rel @ u, rel @ f

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
        """The view from ``pose``: ``what="all"`` (RGB, depth and segmentation: two passes),
        ``"rgb"`` (the colour pass only), ``"depth"`` (depth and segmentation: one pass) or
        ``"segmentation"``. What was not rendered is an empty array."""
        if what not in ("all", "rgb", "depth", "segmentation"):
            raise ValueError(f"what={what!r}: one of all, rgb, depth, segmentation")
        f, cam = self.frames, self.camera(pose)
        rgb = depth = geom = None
        if what in ("all", "rgb"):
            rgb = f.rgb(data, cam)
        if what in ("all", "depth"):
            depth, geom = f.depth_and_geoms(data, cam)
        elif what == "segmentation":
            geom = f.geoms(data, cam)
        none = np.zeros((0, 0), np.int16)
        return View(rgb if rgb is not None else np.zeros((0, 0, 3), np.uint8),
                    depth if depth is not None else np.zeros((0, 0), np.float32),
                    self._inst[geom] if geom is not None else none,
                    self._cat[geom] if geom is not None else none, self.instances)

    def pixels_of(self, data: mujoco.MjData, pose: Pose, owner: str = "obj:target") -> int:
        """How many pixels of the view from ``pose`` show ``owner``: 0 without rendering when
        no pixel can (see :meth:`footprint`), else counted in a segmentation render of which
        only the pixels that can show it are read back."""
        bound, window = self.footprint(data, pose, owner)
        if bound == 0:
            return 0
        return self._count(data, pose, owner, window)

    def shows(self, data: mujoco.MjData, pose: Pose, pixels: int,
              owner: str = "obj:target") -> bool:
        """Whether at least ``pixels`` pixels of the view from ``pose`` show ``owner``
        (``pixels_of(...) >= pixels``), without rendering when fewer can (a flat button seen
        edge-on, an object far away). Only the window that can show it is drawn (see
        :meth:`SceneFrames.geoms`, ``crop``); a count within ``CROP_MARGIN_PX`` of
        ``pixels`` is settled by the full image's pixels."""
        bound, window = self.footprint(data, pose, owner)
        if bound < pixels:
            return False
        if window is not None:
            n = self._count(data, pose, owner, window, crop=True)
            if n >= pixels + CROP_MARGIN_PX or n < pixels - CROP_MARGIN_PX:
                return n >= pixels
        return self._count(data, pose, owner, window) >= pixels

    def _count(self, data: mujoco.MjData, pose: Pose, owner: str,
               window: tuple[int, int, int, int] | None, crop: bool = False) -> int:
        if owner not in self.instances:
            return 0
        geom = self.frames.geoms(data, self.camera(pose), window, crop)
        return int((self._inst[geom] == self.instances.index(owner)).sum())

    def footprint(self, data: mujoco.MjData, pose: Pose, owner: str
                  ) -> tuple[float, tuple[int, int, int, int] | None]:
        """An upper bound on the pixels of the view from ``pose`` that can show ``owner``, and
        the image window (row0, row1, col0, col1) that holds all of them (None: anywhere).

        The owner's drawn geoms lie inside their oriented boxes, so their pixels are pixels
        whose centres fall inside the image of a box: the convex hull of its 8 projected
        corners, grown by ``HULL_SLACK_PX`` for rounding (a pixel is drawn when its centre is
        covered; the renderer projects in float32). No bound (inf, None) when a corner is
        behind the camera; 0 when the boxes lie wholly outside the view frustum
        (:meth:`outside_view`)."""
        if self.outside_view(data, pose, owner):
            return 0, None
        geoms = self._drawn_geoms_of.get(owner, [])
        m = self.scene.model
        size = self.size
        half = size / 2
        scale = half / math.tan(math.radians(FOV_DEG / 2))
        hulls = []
        for g in geoms:
            x, y, z = self._view_coordinates(pose, geom_box_corners(m, data, g))
            if (z <= 1e-6).any():
                return math.inf, None
            # image coordinates (column, row) from the top-left corner, in pixels
            hulls.append(np.column_stack([half + scale * x / z, half - scale * y / z]))
        if not hulls:
            return 0, None
        pts = np.vstack(hulls)
        (cmin, rmin), (cmax, rmax) = pts.min(0).tolist(), pts.max(0).tolist()
        c0, r0 = (min(max(math.floor(v - 1), 0), size) for v in (cmin, rmin))
        c1, r1 = (min(max(math.ceil(v + 1), 0), size) for v in (cmax, rmax))
        if c1 <= c0 or r1 <= r0:
            return 0, None
        # pixel centres of the window: a row of columns and a column of rows (broadcast)
        cc = (np.arange(c0, c1) + 0.5)[None, :]
        rr = (np.arange(r0, r1) + 0.5)[:, None]
        inside = np.zeros((r1 - r0, c1 - c0), bool)
        for h in hulls:
            inside |= _in_grown_hull(h, cc, rr, HULL_SLACK_PX)
        return int(inside.sum()), (r0, r1, c0, c1)

    def outside_view(self, data: mujoco.MjData, pose: Pose, owner: str) -> bool:
        """Whether every corner of ``owner``'s geoms' oriented boxes is beyond one side of the
        view frustum (behind the camera, or past the left, right, top or bottom edge, with a
        margin): then no pixel can show it."""
        geoms = self._geoms_of.get(owner)
        if not geoms:
            return True
        m = self.scene.model
        pts = np.vstack([geom_box_corners(m, data, g) for g in geoms])
        x, y, z = self._view_coordinates(pose, pts)
        t = math.tan(math.radians(FOV_DEG / 2)) * 1.05  # 5 % wider than the image
        slack = 0.02  # m
        return bool((z < -slack).all() or (x > t * z + slack).all() or (-x > t * z + slack).all()
                    or (y > t * z + slack).all() or (-y > t * z + slack).all())


def _in_grown_hull(points: np.ndarray, x: np.ndarray, y: np.ndarray, grow: float) -> np.ndarray:
    """Whether each (x, y) (``x`` and ``y`` broadcast together) lies inside the convex hull
    of ``points`` (N, 2) grown by ``grow`` (every edge moved outward; for a degenerate hull,
    its bounding box grown)."""
    hull = cv2.convexHull(points.astype(np.float32)).reshape(-1, 2).astype(float)
    nxt = np.roll(hull, -1, axis=0)
    e = nxt - hull
    length = np.hypot(e[:, 0], e[:, 1])
    area2 = float(np.sum(hull[:, 0] * nxt[:, 1] - nxt[:, 0] * hull[:, 1]))  # twice the area
    if len(hull) < 3 or abs(area2) < 1e-9 or (length < 1e-9).any():
        lo, hi = points.min(0) - grow, points.max(0) + grow
        return (x >= lo[0]) & (x <= hi[0]) & (y >= lo[1]) & (y <= hi[1])
    sign = 1.0 if area2 > 0 else -1.0  # interior to the left of counter-clockwise edges
    # every edge at once: (edges, *shape of x and y)
    k = (slice(None),) + (None,) * np.broadcast(x, y).ndim
    px, py, ex, ey, n = hull[:, 0][k], hull[:, 1][k], e[:, 0][k], e[:, 1][k], length[k]
    return (sign * (ex * (y - py) - ey * (x - px)) / n >= -grow).all(0)
