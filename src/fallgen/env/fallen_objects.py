"""``FallenObjectsEnv``: an agent acts in the episodes of a built dataset (Gymnasium API).

Each episode replays the settled room of its fall event (the target where it came to rest, the
distractors and occluders), with the agent at its spawn; the step-0 observation is the dataset's
own (the same RGB, depth and segmentation, byte for byte, and the stored binaural clip). Actions
are the dataset's (:data:`fallgen.nav.agent.ACTIONS`), simulated and judged by
:class:`fallgen.nav.agent.Walk`, the rules the dataset's expert was checked with.

Observations (a ``Dict``; ``sensors`` chooses which; fixed shapes):

- ``rgb`` (300, 300, 3) uint8; ``depth`` (300, 300, 1) float32 metres along the optical axis;
- ``audio`` (2, T) float32, the episode's binaural clip (ear pressure / 20 Pa times the row's
  ``audio_gain``, row 0 the left ear) at step 0 and zeros after it, as in the paper (the fall is
  heard once); ``audio="repeat"`` gives the clip at every step;
- ``pose`` (4,) float32: position (forward, left) in metres in the spawn's frame, heading and
  camera tilt in radians relative to the spawn (heading counter-clockwise, tilt up positive);
- oracle sensors, opt-in, for modular agents and ablations: ``category_seg`` (300, 300, 1) int16
  into :attr:`FallenObjectsEnv.category_labels` (-1 for nothing), ``object_category`` (its index
  in the same table), ``object_position`` (3,) float32 (the object's centre relative to the
  camera: forward, left, up, metres; the camera's heading, tilt ignored), ``expert_action`` (the
  expert's next action from the current pose: the first action of the shortest plan, the
  dataset's own plan while the agent follows it; :data:`NO_PLAN` if none exists).

Rendering: the colour pass and the depth-and-segmentation pass are separate renders, each made
only when a sensor asks for it, and kept in a bounded per-episode cache keyed by the pose
(turning in place or coming back renders nothing). ``depth`` comes from the latter, exact to
float32; with ``rgb`` and without ``category_seg`` it is read from the colour pass's depth
buffer instead (the same values: :attr:`fallgen.vision.gl.SceneFrames.colour_depth_exact`),
and whether the object is in view is then decided as the judge does (a segmentation render
only where the object can show). A colour pass keeps the light's shadow map of the room, which
stands still, for the episode (:mod:`fallgen.vision.gl`).
Neither pass is multisampled (``OFFSCREEN_SAMPLES = 0`` in :mod:`fallgen.vision.camera`: on a
CPU renderer 4x multisampling nearly doubled a view's cost), so polygon edges in ``rgb`` are not
anti-aliased.

Reward (``reward="paper"``, the original challenge's): -0.01 per action; +10 for a successful
``found``; +1 when a move brings the agent closer to the object, -1 when farther (horizontal
distance to its centre), nothing when it did not move. ``reward="geodesic"`` (SoundSpaces'
shaping): -0.01 per action, +10 for success, plus the decrease of the geodesic distance
(:class:`fallgen.nav.geodesic.GeodesicField`; no shaping where it is not finite).

An episode ends at a successful ``found`` (terminated), when the ``claims`` allowed are used
(terminated; 1 by default, 2 as the original challenge), or after 200 actions (truncated).
``oracle_found=True`` (the paper's rule for its PPO agent) also ends it in success, with the
success reward, after the first action that leaves the agent within 2 m (horizontally) of the
object with the object in view (the judge's rule for a ``found``, asked after every action; the
``found`` action itself is not needed, and its claims still count). SPL and SNA are then those
of the path and the actions up to that step; ``claims`` is 0 when no ``found`` was made.
``info`` after every step: ``episode_id``, ``step``, ``moved``; at the end also the metrics
(:data:`END_KEYS`): success, spl, sna, soft_spl, path length, shortest path, fewest actions,
distance to the object (straight and geodesic), the step it was first seen (-1: never), the
claims made, the outcome (found, wrong_found, timeout). Soft SPL: the progress toward where the
object is within reach, 1 - r_T / r_0 (r: the geodesic distance to the 2 m circle, 0 inside),
times l / max(p, l). Nothing in ``info`` is a timing.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from fallgen.dataset.reader import Dataset
from fallgen.env.source import EpisodeData, EpisodeSource, check_hrtf, select
from fallgen.env.topdown import top_down
from fallgen.nav.agent import ACTIONS, FOUND, HEADINGS, MAX_ACTIONS, SUCCESS_DISTANCE_M, \
    TURN_DEG, VISIBLE_PIXELS, AgentSpec, Pose, Walk
from fallgen.nav.expert import NoPath
from fallgen.nav.geodesic import GeodesicField
from fallgen.vision.camera import HEIGHT, WIDTH, View

#: The observation keys every agent may use, and the opt-in oracle sensors.
BASIC_SENSORS = ("rgb", "depth", "audio", "pose")
ORACLE_SENSORS = ("category_seg", "object_category", "object_position", "expert_action")
SENSORS = BASIC_SENSORS + ORACLE_SENSORS
#: ``expert_action`` when no plan reaches a pose that sees the object from here.
NO_PLAN = len(ACTIONS)
STEP_REWARD = -0.01
SUCCESS_REWARD = 10.0
REWARDS = ("paper", "geodesic")
ORDERS = ("sequential", "shuffle")
#: Bounds of the spawn-relative position and of depth (finite Box bounds; rooms are < 15 m).
POSE_LIMIT_M = 64.0
DEPTH_MAX_M = 100.0
#: Keys ``info`` has after the last step, besides ``episode_id``, ``step`` and ``moved``.
END_KEYS = ("success", "is_success", "spl", "sna", "soft_spl", "path_length_m",
            "shortest_path_m", "fewest_actions", "distance_to_object_m", "geodesic_distance_m",
            "first_seen_step", "claims", "outcome")


class FallenObjectsEnv(gym.Env):
    """The Fallen Objects task in the episodes of a dataset built by fallgen.

    ``dataset``: the dataset directory; ``split``, ``room_kind``, ``categories``,
    ``episode_ids``: which episodes (all by default); ``order``: ``"sequential"`` (by id) or
    ``"shuffle"`` (a permutation drawn from the seed given to :meth:`reset`); ``rank`` of
    ``world_size``: this worker's disjoint slice. ``reset(options={"episode_id": N})`` plays
    episode N of the dataset whatever the selection. ``data_dir``: the world data the dataset
    was built with (default: the built-in data); a mismatch is detected at reset; ``world``: an
    already loaded :class:`fallgen.world.library.World` instead. ``view_cache``: views kept per
    episode (keyed by pose). ``hrtf``: the head the agent expects to hear with (``sphere``,
    ``sadie_ku100`` or a SOFA file, as a build config names it); a dataset whose clips were
    heard with another is refused (ValueError); None: not checked. ``oracle_found``: the
    episode ends in success as soon as the object is within 2 m and in view."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, dataset: str | Path, split: str | None = None, *,
                 room_kind: str | None = None, categories: Collection[str] | None = None,
                 episode_ids: Sequence[int] | None = None, order: str = "sequential",
                 rank: int = 0, world_size: int = 1,
                 sensors: Sequence[str] = BASIC_SENSORS, audio: str = "first",
                 claims: int = 1, reward: str = "paper", render_mode: str | None = None,
                 data_dir: str | Path | None = None, view_cache: int = 64,
                 world: Any = None, hrtf: str | None = None,
                 oracle_found: bool = False) -> None:
        sensors = tuple(sensors)
        bad = [s for s in sensors if s not in SENSORS]
        if bad or not sensors:
            raise ValueError(f"sensors {bad or sensors!r}: choose from {', '.join(SENSORS)}")
        for name, value, allowed in (("order", order, ORDERS), ("reward", reward, REWARDS),
                                     ("audio", audio, ("first", "repeat")),
                                     ("render_mode", render_mode, (None, "rgb_array"))):
            if value not in allowed:
                raise ValueError(f"{name}={value!r}: one of {', '.join(map(str, allowed))}")
        if int(claims) < 1:
            raise ValueError(f"claims={claims}: at least 1")
        from fallgen.vision.camera import world_category_labels
        from fallgen.world.library import load_world

        self.ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
        if hrtf is not None:
            check_hrtf(self.ds, hrtf)
        self.ids = select(self.ds, split, room_kind, categories, episode_ids, rank, world_size)
        self.sensors, self.audio_mode, self.claims = sensors, audio, int(claims)
        self.order, self.reward_mode, self.render_mode = order, reward, render_mode
        self.oracle_found = bool(oracle_found)
        self.spec_agent = AgentSpec()
        self.world = world if world is not None else load_world(data_dir)
        self.category_labels = tuple(world_category_labels(self.world))
        stored = tuple(self.ds.category_labels)
        if stored and stored != self.category_labels:
            raise ValueError(f"{self.ds.root}: category_labels: the dataset was built with "
                             "other world data than this environment loads (pass data_dir=)")
        self.source = EpisodeSource(self.ds)
        #: the views look as the dataset's do (textured where it was built with appearance)
        built = self.ds.generate_settings()
        self._appearance = bool(built.get("appearance", False))
        #: ... each episode in its own look, where the dataset drew one per episode
        self._look_root = self.ds.root_seed if built.get("appearance_randomization", False) \
            else None
        first = self.ds.row(self.ids[0])
        self.audio_shape = tuple(self.ds.arrays(first, ("audio",))["audio"].shape)
        self.observation_space = spaces.Dict(self._spaces())
        self.action_space = spaces.Discrete(len(ACTIONS))
        self._view_cache_size = max(0, int(view_cache))
        rgb, depth = "rgb" in sensors, "depth" in sensors or "category_seg" in sensors
        #: the render passes the sensors need (EgoCamera.render's ``what``)
        self._passes = "all" if rgb and depth else "rgb" if rgb else "depth" if depth else None
        #: rgb and depth without segmentation: both from one colour pass where it is exact
        self._colour_depth = rgb and "depth" in sensors and "category_seg" not in sensors
        self._gl = None
        self._room = None
        self._room_samples: OrderedDict[str, np.ndarray] = OrderedDict()
        self._ep: EpisodeData | None = None
        self._walk: Walk | None = None
        self._queue: list[int] = []
        self._cursor = 0
        self._order_drawn = False

    # --- spaces -------------------------------------------------------------------------------

    def _spaces(self) -> dict[str, spaces.Space]:
        n = len(self.category_labels)
        lim = POSE_LIMIT_M
        all_spaces = {
            "rgb": spaces.Box(0, 255, (HEIGHT, WIDTH, 3), np.uint8),
            "depth": spaces.Box(0.0, DEPTH_MAX_M, (HEIGHT, WIDTH, 1), np.float32),
            "audio": spaces.Box(-1.0, 1.0, self.audio_shape, np.float32),
            "pose": spaces.Box(np.array([-lim, -lim, -math.pi, -math.pi / 2], np.float32),
                               np.array([lim, lim, math.pi, math.pi / 2], np.float32),
                               dtype=np.float32),
            "category_seg": spaces.Box(-1, n - 1, (HEIGHT, WIDTH, 1), np.int16),
            "object_category": spaces.Discrete(n),
            "object_position": spaces.Box(-lim, lim, (3,), np.float32),
            "expert_action": spaces.Discrete(len(ACTIONS) + 1),
        }
        return {k: all_spaces[k] for k in self.sensors}

    # --- episodes -----------------------------------------------------------------------------

    def _next_episode(self) -> int:
        if not self._queue or self._cursor >= len(self._queue):
            self._queue = list(self.ids)
            if self.order == "shuffle":
                self._queue = [self._queue[i] for i in self.np_random.permutation(len(self._queue))]
            self._cursor = 0
        eid = self._queue[self._cursor]
        self._cursor += 1
        return eid

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode: ``options={"episode_id": N}`` picks it; otherwise the next of the
        selection. A ``seed`` restarts the selection's order (for ``"shuffle"``, a new
        permutation drawn from it), so a seeded reset always gives the same episode."""
        super().reset(seed=seed)
        if seed is not None:
            self._queue, self._cursor = [], 0
        options = options or {}
        unknown = set(options) - {"episode_id"}
        if unknown:
            raise ValueError(f"unknown reset options {sorted(unknown)} (episode_id only)")
        eid = options.get("episode_id")
        if eid is None:
            eid = self._next_episode()
        elif int(eid) not in self.ds:
            raise ValueError(f"no episode {eid} in {self.ds.root}")
        self._load(int(eid))
        obs = self._observe(first=True)
        return obs, self._info(moved=False)

    def _load(self, episode_id: int) -> None:
        from fallgen.pipeline.episode import appearance_seed
        from fallgen.pipeline.settled import SettledRoom
        from fallgen.vision.gl import GLContext

        if self._room is not None:
            self._room.close()
            self._room = None
        ep = self.source.load(episode_id)
        if self._gl is None:
            self._gl = GLContext(WIDTH)
        variant = ep.row["room_variant"]
        room = SettledRoom(self.world, ep.event, self._gl, self.category_labels,
                           self.spec_agent, self._room_samples.get(variant),
                           appearance=self._appearance,
                           look_seed=None if self._look_root is None
                           else appearance_seed(self._look_root, episode_id))
        self._room_samples[variant] = room.static
        self._room_samples.move_to_end(variant)
        while len(self._room_samples) > 16:
            self._room_samples.popitem(last=False)
        if room.grid.occupied.shape != ep.occupancy.shape or \
                not np.array_equal(room.grid.occupied, ep.occupancy.astype(bool)):
            room.close()
            raise ValueError(f"{self.ds.root / ep.row['media_file']}: occupancy/"
                             f"{ep.row['media_index']}: episode {episode_id}'s room differs from "
                             "the one it was generated in (other world data? pass data_dir=)")
        self._room, self._ep = room, ep
        self._spawn = ep.spawn
        self._walk = Walk(self._spawn, room.grid, room.centre, room.visible, self.spec_agent,
                          self.claims, MAX_ACTIONS)
        self._views: OrderedDict[tuple, View] = OrderedDict()
        self._first_seen = -1
        self._plan: tuple[tuple[int, ...], int, Pose] | None = None  # (actions, next, at pose)
        self._geo = GeodesicField(room.grid, room.centre, self.spec_agent.radius_m,
                                  SUCCESS_DISTANCE_M)
        self._geo_start = self._geo.distance(self._spawn.xy)
        self._geo_now = self._geo_start
        self._reach_start = self._geo.reach_distance(self._spawn.xy)
        self._ended: dict[str, Any] | None = None

    # --- stepping -----------------------------------------------------------------------------

    def step(self, action) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        walk = self._walk
        if walk is None:
            raise ResetNeeded("call reset() before step()")
        if walk.done:
            raise ResetNeeded("the episode is over: call reset()")
        if not self.action_space.contains(action):
            raise ValueError(f"action {action!r} is not in 0..{len(ACTIONS) - 1} "
                             f"({', '.join(ACTIONS)})")
        a = int(action)
        before, d_before = walk.pose, walk.distance_m()
        moved = walk.act(a)
        pose = walk.pose
        if self.oracle_found and not walk.done and \
                walk.distance_m() <= SUCCESS_DISTANCE_M and self._room.visible(pose):
            walk.succeed()
        reward = STEP_REWARD
        displaced = (pose.x, pose.y) != (before.x, before.y)
        geo = self._geo.distance(pose.xy) if displaced else self._geo_now
        if self.reward_mode == "paper":
            if displaced:
                d = walk.distance_m()
                reward += 1.0 if d < d_before else -1.0 if d > d_before else 0.0
        elif math.isfinite(geo) and math.isfinite(self._geo_now):
            reward += self._geo_now - geo
        self._geo_now = geo
        if walk.success:
            reward += SUCCESS_REWARD
        self._advance_plan(a, before, moved)
        obs = self._observe(first=False)
        terminated = walk.success or walk.claims >= self.claims
        truncated = walk.done and not terminated
        return obs, float(reward), bool(terminated), bool(truncated), self._info(moved)

    def _advance_plan(self, a: int, before: Pose, moved: bool) -> None:
        """Keep the expert's plan while the agent follows it (the rest of the plan is then
        still the expert's: the dataset's expert actions are replayed exactly)."""
        p = self._plan
        if p is not None and moved and a != FOUND and p[2] == before and p[1] < len(p[0]) \
                and p[0][p[1]] == a:
            self._plan = (p[0], p[1] + 1, self._walk.pose)
        else:
            self._plan = None

    def _expert_action(self) -> int:
        pose = self._walk.pose
        p = self._plan
        if p is None or p[2] != pose or p[1] >= len(p[0]):
            try:
                plan = self._room.plan(pose)
            except NoPath:
                self._plan = None
                return NO_PLAN
            p = self._plan = (plan.actions, 0, pose)
        return int(p[0][p[1]])

    # --- observations -------------------------------------------------------------------------

    def _view(self, pose: Pose) -> View:
        """The view from ``pose`` with the passes the sensors need (cached per pose)."""
        key = (round(pose.x, 6), round(pose.y, 6), pose.heading, pose.tilt_deg)
        v = self._views.get(key)
        if v is not None:
            self._views.move_to_end(key)
            return v
        cam, data = self._room.camera, self._room.data
        if self._passes is None:
            return View(np.zeros((0, 0, 3), np.uint8), np.zeros((0, 0), np.float32),
                        np.zeros((0, 0), np.int16), np.zeros((0, 0), np.int16), cam.instances)
        if self._colour_depth and cam.frames.colour_depth_exact:
            rgb, depth = cam.frames.rgb_and_depth(data, cam.camera(pose))
            none = np.zeros((0, 0), np.int16)
            v = View(rgb, depth, none, none, cam.instances)
        else:
            v = cam.render(data, pose, self._passes)
        if self._view_cache_size:
            self._views[key] = v
            while len(self._views) > self._view_cache_size:
                self._views.popitem(last=False)
        return v

    def _observe(self, first: bool) -> dict[str, np.ndarray]:
        pose, room, s = self._walk.pose, self._room, self.sensors
        v = self._view(pose)
        if v.instance.size:
            seen = room.note_visible(pose, v.pixels_of("obj:target"))
        else:
            seen = room.visible(pose)
        if seen and self._first_seen < 0:
            self._first_seen = self._walk.n_actions
        obs: dict[str, np.ndarray] = {}
        if "rgb" in s:
            obs["rgb"] = v.rgb
        if "depth" in s:
            obs["depth"] = np.minimum(v.depth, DEPTH_MAX_M)[..., None]
        if "audio" in s:
            obs["audio"] = self._ep.audio.copy() if first or self.audio_mode == "repeat" \
                else np.zeros(self.audio_shape, np.float32)
        if "pose" in s:
            obs["pose"] = self._relative_pose(pose)
        if "category_seg" in s:
            obs["category_seg"] = v.category[..., None]
        if "object_category" in s:
            obs["object_category"] = np.int64(self.category_labels.index(
                self._ep.row["category"]))
        if "object_position" in s:
            obs["object_position"] = self._object_position(pose)
        if "expert_action" in s:
            obs["expert_action"] = np.int64(self._expert_action())
        return obs

    def _relative_pose(self, pose: Pose) -> np.ndarray:
        s = self._spawn
        c, si = math.cos(s.yaw_rad), math.sin(s.yaw_rad)
        dx, dy = pose.x - s.x, pose.y - s.y
        turns = (pose.heading - s.heading) % HEADINGS
        heading = math.radians(turns * TURN_DEG)
        if heading > math.pi:
            heading -= 2 * math.pi
        return np.array([dx * c + dy * si, -dx * si + dy * c, heading,
                         math.radians(pose.tilt_deg)], np.float32)

    def _object_position(self, pose: Pose) -> np.ndarray:
        c, si = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
        d = self._room.centre - np.array([pose.x, pose.y, self.spec_agent.camera_height_m])
        return np.array([d[0] * c + d[1] * si, -d[0] * si + d[1] * c, d[2]], np.float32)

    # --- info and metrics ---------------------------------------------------------------------

    def _info(self, moved: bool) -> dict[str, Any]:
        walk = self._walk
        info: dict[str, Any] = {"episode_id": self._ep.episode_id, "step": walk.n_actions,
                                "moved": bool(moved)}
        if walk.done:
            info.update(self.metrics())
        return info

    def metrics(self) -> dict[str, Any]:
        """The episode's measures so far (final once it is over): :data:`END_KEYS`."""
        walk, row = self._walk, self._ep.row
        out = walk.outcome()
        shortest, fewest = float(row["shortest_path_m"]), int(row["fewest_actions"])
        spl = out.spl(shortest)
        g = self._geo_now
        # soft SPL: progress toward where the object is within reach (geodesic), times the
        # path's efficiency
        r0, r = self._reach_start, self._geo.reach_distance(walk.pose.xy)
        progress = max(0.0, 1.0 - r / r0) if r0 > 0 and math.isfinite(r) else float(r == 0)
        soft = progress * (shortest / max(shortest, out.path_m) if shortest > 0 else 1.0)
        return {"success": bool(out.success), "is_success": bool(out.success),
                "spl": float(spl), "sna": float(out.sna(fewest)), "soft_spl": float(soft),
                "path_length_m": float(out.path_m), "shortest_path_m": shortest,
                "fewest_actions": fewest, "distance_to_object_m": float(out.distance_m),
                "geodesic_distance_m": float(g), "first_seen_step": int(self._first_seen),
                "claims": int(out.claims), "outcome": out.kind}

    @property
    def episode(self) -> EpisodeData | None:
        """The current episode's row, event, audio and stored occupancy."""
        return self._ep

    @property
    def pose(self) -> Pose | None:
        """The agent's current pose (room frame)."""
        return None if self._walk is None else self._walk.pose

    @property
    def actions_taken(self) -> int:
        return 0 if self._walk is None else self._walk.n_actions

    # --- rendering and closing ----------------------------------------------------------------

    def render(self) -> np.ndarray | None:
        """``render_mode="rgb_array"``: (300, 600, 3) uint8, the agent's view beside the room
        from above (occupancy, object with its 2 m circle, spawn, path, agent)."""
        if self.render_mode is None or self._walk is None:
            return None
        pose = self._walk.pose
        rgb = self._view(pose).rgb
        if not rgb.size:
            rgb = self._room.camera.render(self._room.data, pose, "rgb").rgb
        m = top_down(self._room.grid, self._room.centre[:2], self._walk.poses, HEIGHT,
                     self.spec_agent.radius_m)
        return np.ascontiguousarray(np.concatenate([rgb, m], axis=1))

    def close(self) -> None:
        if self._room is not None:
            self._room.close()
            self._room = None
        if self._gl is not None:
            self._gl.close()
            self._gl = None
        self._walk = None
        super().close()


__all__ = ["FallenObjectsEnv", "SENSORS", "BASIC_SENSORS", "ORACLE_SENSORS", "NO_PLAN",
           "END_KEYS", "REWARDS", "VISIBLE_PIXELS"]
