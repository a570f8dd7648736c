"""The settled room of a fall event, as the agent sees and moves in it.

One definition for the generation of an episode (:mod:`fallgen.pipeline.episode`: its spawn,
first view, expert and check) and for the environment that replays it (:mod:`fallgen.env`):
the compiled scene with the target where it came to rest and the distractors and occluders where
they stood, its occupancy grid in the robot's height band, the agent's camera, and the test the
expert and the judge ask about poses: whether the object is visible (at least
``VISIBLE_PIXELS`` segmentation pixels). The answer is kept per pose (the scene is static), so a
pose is rendered once, and not at all where the scene's opaque faces leave fewer pixels of the
view able to show the object (:class:`fallgen.vision.sight.Occluders`: what can show from an
eye point, kept per eye point).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math

import mujoco
import numpy as np

from fallgen.nav.agent import STEP_M, STEP_SAMPLES, VISIBLE_PIXELS, AgentSpec, Pose
from fallgen.nav.expert import Expert, Limits, Plan, expert, hidden_cells, plan_to_see
from fallgen.nav.hidden import reachable_cells
from fallgen.nav.occupancy import OccupancyGrid, geom_box_corners, occupancy, room_samples
from fallgen.physics.drop import instance_of
from fallgen.physics.events import FallEvent
from fallgen.vision.camera import EgoCamera
from fallgen.vision.gl import GLContext
from fallgen.vision.camera import FOV_DEG, WIDTH
from fallgen.vision.faces import SceneFaces, geom_points
from fallgen.vision.sight import Occluders, Sight, near_distance
from fallgen.world.library import World
from fallgen.world.scene import LOOK, VIEW, PlacedObject, build_scene

#: How far a build's expert searches before it gives an event up (``search_limit``): 500 000
#: lattice states (the search's own default is 2 million; it checks when its tables grow, so
#: it gives up at 524 285, where 2 million meant 2 097 150). On a 250-episode slice of
#: the paper-size configuration (8 kitchen variants, one worker), 2 of the 500 searches that
#: found a plan entered more than this (731 632 and 787 346 states), none more than a
#: million, and the 3 that gave up at 2 million took 3-7 s each; side by side with the
#: 2-million limit, the slice's peak memory fell from 1034 to 901 MB and its CPU time from 120
#: to 104 s, and 1 of its 250 episodes was made from another event.
BUILD_LIMITS = Limits(states=500_000)


def settled_objects(world: World, event: FallEvent) -> list[PlacedObject]:
    """The event's objects at rest: the target (``target``), the distractors (``d0``, ...) and
    the occluders (``o0``, ...), all fixed."""
    out = [PlacedObject("target", instance_of(world, event.target), tuple(event.settle_pos),
                        tuple(event.settle_quat), free=False)]
    out += [PlacedObject(f"d{k}", instance_of(world, p.object), p.pos, p.quat, free=False)
            for k, p in enumerate(event.distractors)]
    out += [PlacedObject(f"o{k}", instance_of(world, p.object), p.pos, p.quat, free=False)
            for k, p in enumerate(event.occluders)]
    return out


class SettledRoom:
    """The settled room of ``event``, compiled, with its grid and camera (drawn in ``context``,
    a long-lived :class:`GLContext` of the camera's size). ``labels``: the dataset's category
    table; ``static``: the room variant's own occupancy layer (:func:`room_samples`), when the
    caller keeps it between episodes of one variant; ``room_faces``: the faces its room's own
    geoms are drawn with (:attr:`room_faces`, made on first use), likewise; ``appearance``:
    drawn with textures and shadows, in the look drawn from ``look_seed`` when given
    (:mod:`fallgen.world.look`). Close it to free its render context."""

    def __init__(self, world: World, event: FallEvent, context: GLContext,
                 labels: tuple[str, ...], spec: AgentSpec = AgentSpec(),
                 static: np.ndarray | None = None, appearance: bool = False,
                 look_seed: int | None = None, room_faces: SceneFaces | None = None) -> None:
        self.event, self.spec = event, spec
        self.variant = world.variant(event.room_variant)
        objects = settled_objects(world, event)
        settings = VIEW if not appearance else \
            LOOK if look_seed is None else dataclasses.replace(LOOK, look_seed=look_seed)
        self.scene = build_scene(self.variant, world.materials, objects, settings=settings)
        self.data = self.scene.data()
        mujoco.mj_forward(self.scene.model, self.data)
        self.object_categories = {o.name: o.instance.category for o in objects}
        self.camera = EgoCamera(self.scene, self.object_categories, spec, labels=labels,
                                context=context)
        try:
            if static is None:
                static = room_samples(self.scene, self.data, band_high_m=spec.height_m)
            self.static = static
            self.grid: OccupancyGrid = occupancy(self.scene, self.data,
                                                 band_high_m=spec.height_m, static=static)
            #: the corners of the target's geoms' boxes: the frustum test's bound of it
            self.corners = target_corners(self.scene, self.data)
            self.lo, self.hi = self.corners.min(0), self.corners.max(0)
            #: points whose hull holds the target as drawn (its meshes' vertices)
            self.outline = target_points(self.scene, self.data)
        except BaseException:
            self.camera.close()
            raise
        #: the object's centre (its bounding box's): what distances are measured to
        self.centre = (self.lo + self.hi) / 2
        self._seen: dict[Pose, bool] = {}
        self._sights: dict[tuple[float, float], Sight] = {}
        self._occluders: Occluders | None = None  # made on first use
        #: the faces the room's own geoms (not the objects') are drawn with, once made
        self.room_faces = room_faces

    def close(self) -> None:
        self.camera.close()

    def visible(self, pose: Pose) -> bool:
        """Whether at least ``VISIBLE_PIXELS`` pixels of the view from ``pose`` show the
        object (rendered once per pose)."""
        seen = self._seen.get(pose)
        if seen is None:
            sight = self.sight(pose)
            seen = self._seen[pose] = not sight.hidden and sight.max_pixels(
                pose.yaw_rad, math.radians(pose.tilt_deg), WIDTH, FOV_DEG, VISIBLE_PIXELS
            ) >= VISIBLE_PIXELS and self.camera.shows(self.data, pose, VISIBLE_PIXELS)
        return seen

    def unseen(self, pose: Pose) -> bool:
        """Whether the scene's opaque faces hide the object from the camera at ``pose``'s
        position, whatever its heading and tilt."""
        return self.sight(pose).hidden

    def may_see(self, pose: Pose, tilts: list[int]) -> np.ndarray:
        """For each tilt (degrees) of ``pose``'s position and heading, whether the view can
        show enough of the object to be visible (False only where it cannot)."""
        return self.sight(pose).may_show(pose.yaw_rad, np.radians(tilts), WIDTH, FOV_DEG,
                                         VISIBLE_PIXELS)

    def sight(self, pose: Pose) -> Sight:
        """What of the object the scene's opaque faces can let the camera at ``pose`` see,
        whatever its heading and tilt (kept per eye point)."""
        key = (round(pose.x, 9), round(pose.y, 9))  # one lattice point, reached any way
        s = self._sights.get(key)
        if s is None:
            s = self._sights[key] = self.occluders.look(
                np.array([pose.x, pose.y, self.spec.camera_height_m]))
        return s

    @property
    def occluders(self) -> Occluders:
        """The scene's faces that can hide the object (made on first use)."""
        if self._occluders is None:
            self._occluders = self._make_occluders()
        return self._occluders

    def _make_occluders(self) -> Occluders:
        m, owners = self.scene.model, self.scene.geom_owner
        if self.room_faces is None:
            self.room_faces = SceneFaces(m, self.data, [
                g for g in range(m.ngeom) if not owners[g].startswith("obj:")
                and owners[g] != "agent"])
        objects = SceneFaces(m, self.data, [g for g in range(m.ngeom) if owners[g].startswith(
            "obj:") and owners[g] != "obj:target"])
        return Occluders([self.room_faces, objects], self.outline, near_distance(m))

    def note_visible(self, pose: Pose, pixels: int) -> bool:
        """Record the object's pixel count in a full segmentation render from ``pose`` (the
        count :meth:`visible` settles on: no second render needed); whether it is visible."""
        seen = self._seen[pose] = pixels >= VISIBLE_PIXELS
        return seen

    def expert(self, start: Pose) -> Expert:
        """The expert's plan from ``start`` and the references of SPL and SNA (raises
        :class:`fallgen.nav.expert.NoPath`)."""
        return expert(start, self.grid, self.centre, self.corners, self.visible, self.spec,
                      limits=BUILD_LIMITS, may_see=self.may_see, unseen=self.unseen,
                      sight=self.occluders.kernel)

    def hidden_cells(self, start: Pose) -> int | None:
        """The expert's proof that no pose reachable from ``start`` sees the object
        (:func:`fallgen.nav.expert.hidden_cells`): the cells it ran over where it holds."""
        return hidden_cells(start, self.grid.move_table(self.spec.radius_m),
                            self.grid.resolution, self.centre[:2], self.spec,
                            self.occluders.kernel)

    def reachable_key(self, start: Pose) -> bytes | None:
        """A digest of the cells the agent can reach from ``start``, as the expert's proof
        that no reachable pose sees the object bounds them
        (:func:`fallgen.nav.hidden.reachable_cells`): that proof holds from every start with
        the same digest. None where they cannot be bounded."""
        cells = reachable_cells(self.grid.move_table(self.spec.radius_m), self.grid.resolution,
                                (start.x, start.y), STEP_M / (STEP_SAMPLES - 1))
        if cells is None:
            return None
        return hashlib.blake2b(np.ascontiguousarray(cells).tobytes(), digest_size=16).digest()

    def plan(self, start: Pose) -> Plan:
        """The expert's own plan from ``start`` (fewest forward moves, then fewest turns)
        without the fewest-actions search: what an oracle of the next action needs."""
        return plan_to_see(start, self.grid, self.centre, self.corners, self.visible,
                           self.spec, may_see=self.may_see, unseen=self.unseen,
                           sight=self.occluders.kernel)

    def object_distance_m(self, pose: Pose) -> float:
        """Horizontal distance from ``pose`` to the object's centre."""
        return math.hypot(pose.x - float(self.centre[0]), pose.y - float(self.centre[1]))


def target_corners(scene, data) -> np.ndarray:
    """(8 N, 3) world corners of the target's N geoms' oriented boxes."""
    m = scene.model
    b = scene.object_body["target"]
    return np.vstack([geom_box_corners(m, data, g) for g in range(m.ngeom)
                      if m.geom_bodyid[g] == b])


def target_points(scene, data) -> np.ndarray:
    """(N, 3) world points whose hull holds the target's geoms as drawn: the vertices of the
    hull of its meshes' vertices (and other geoms' box corners)."""
    from scipy.spatial import ConvexHull, QhullError

    m = scene.model
    b = scene.object_body["target"]
    pts = np.vstack([geom_points(m, data, g) for g in range(m.ngeom) if m.geom_bodyid[g] == b])
    try:
        return pts[ConvexHull(pts).vertices]
    except QhullError:  # flat or degenerate: every point
        return pts


def target_box(scene, data) -> tuple[np.ndarray, np.ndarray]:
    """The target's world bounding box (over its geoms' oriented boxes)."""
    pts = target_corners(scene, data)
    return pts.min(0), pts.max(0)


__all__ = ["SettledRoom", "settled_objects", "target_box"]
