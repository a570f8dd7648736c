"""The agent's discrete action space, an action simulator, and the paper's success metrics.

Actions (their integer codes are what datasets store): ``move_forward`` 0.25 m along the
heading, ``turn_left`` / ``turn_right`` 30 degrees, ``look_up`` / ``look_down`` one camera tilt
step (``AgentSpec.tilt_step_deg``, 15 degrees, within [``tilt_min_deg``, ``tilt_max_deg``]),
``found``. Headings are kept as whole 30-degree steps, so rotations are exact. A forward move is
checked along its segment (every 5 cm) against the occupancy grid with the robot's radius: if any
point would touch an obstacle the agent does not move at all (collisions stop motion; the action
still counts). Tilting beyond a limit leaves the tilt unchanged.

Judging (Gan et al. 2022): an episode succeeds when the agent executes ``found`` within
``MAX_ACTIONS`` actions, at most ``SUCCESS_DISTANCE_M`` (horizontal) from the object, with the
object visible in its egocentric view (``visible(pose)``: at least ``VISIBLE_PIXELS``
segmentation pixels of the object, decided by the caller's renderer). SPL = S l / max(p, l) with
p the distance travelled (``STEP_M`` per forward move made) and l the shortest path in the same
action space; SNA = S n* / max(n,
n*) with n the number of actions (``found`` included) and n* the fewest possible.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from fallgen.nav.occupancy import OccupancyGrid

ACTIONS = ("move_forward", "turn_left", "turn_right", "look_up", "look_down", "found")
FORWARD, LEFT, RIGHT, UP, DOWN, FOUND = range(6)
STEP_M = 0.25
TURN_DEG = 30
HEADINGS = 360 // TURN_DEG
MAX_ACTIONS = 200
SUCCESS_DISTANCE_M = 2.0
#: Segmentation pixels of the object (of 300 x 300) for it to count as seen. Small because
#: the smallest objects are small: a 12 mm shirt button on the floor covers ~4-6 pixels seen
#: from 1-1.2 m by a 90 degree, 300-pixel camera 1.1 m up.
VISIBLE_PIXELS = 4


@dataclass(frozen=True)
class AgentSpec:
    radius_m: float = 0.2
    height_m: float = 1.2
    camera_height_m: float = 1.1
    tilt_step_deg: int = 15
    tilt_min_deg: int = -60
    tilt_max_deg: int = 30


@dataclass(frozen=True)
class Pose:
    """Position on the floor (room frame), heading in 30-degree steps (counter-clockwise from
    +x) and camera tilt in degrees (up positive)."""

    x: float
    y: float
    heading: int  # 0 .. HEADINGS - 1
    tilt_deg: int = 0

    @property
    def yaw_rad(self) -> float:
        return self.heading * math.radians(TURN_DEG)

    @property
    def xy(self) -> np.ndarray:
        return np.array([self.x, self.y])


#: unit vectors of the 12 headings (the expert's planner uses the same table: same arithmetic)
HEADING_VECTORS = np.array([[math.cos(k * math.radians(TURN_DEG)),
                             math.sin(k * math.radians(TURN_DEG))] for k in range(HEADINGS)])
#: a forward move is checked at this many evenly spaced points (every 5 cm, both ends)
STEP_SAMPLES = int(round(STEP_M / 0.05)) + 1
STEP_FRACTIONS = np.linspace(0.0, 1.0, STEP_SAMPLES)


def horizontal_distance_m(pose: Pose, target_xy) -> float:
    """The judge's distance: horizontal, from ``pose`` to ``target_xy`` (the object's
    centre)."""
    return float(np.linalg.norm(pose.xy - np.asarray(target_xy, float)[:2]))


def heading_vector(heading: int) -> np.ndarray:
    return HEADING_VECTORS[heading % HEADINGS]


def step_points(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., STEP_SAMPLES, 2) points checked along forward moves from ``a`` to ``b`` (..., 2):
    one definition for the simulator and the planner, so that they never disagree."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a[..., None, :] + STEP_FRACTIONS[:, None] * (b - a)[..., None, :]


def segment_free(grid: OccupancyGrid, a: np.ndarray, b: np.ndarray, radius_m: float) -> bool:
    return bool(grid.free_for(step_points(a, b), radius_m).all())


def step(pose: Pose, action: int, grid: OccupancyGrid, spec: AgentSpec = AgentSpec()
         ) -> tuple[Pose, bool]:
    """The pose after ``action`` and whether it moved/turned/tilted as asked (False: blocked by
    an obstacle or a tilt limit; ``found`` changes nothing and returns True)."""
    if action == FORWARD:
        b = pose.xy + STEP_M * heading_vector(pose.heading)
        if segment_free(grid, pose.xy, b, spec.radius_m):
            return replace(pose, x=float(b[0]), y=float(b[1])), True
        return pose, False
    if action in (LEFT, RIGHT):
        return replace(pose, heading=(pose.heading + (1 if action == LEFT else -1)) % HEADINGS), True
    if action in (UP, DOWN):
        t = pose.tilt_deg + (spec.tilt_step_deg if action == UP else -spec.tilt_step_deg)
        if spec.tilt_min_deg <= t <= spec.tilt_max_deg:
            return replace(pose, tilt_deg=t), True
        return pose, False
    if action == FOUND:
        return pose, True
    raise ValueError(f"unknown action {action}")


@dataclass(frozen=True)
class Outcome:
    success: bool
    found_called: bool
    distance_m: float  # horizontal, final pose to the object
    #: the judge's visibility verdict at the last claim (None: no claim was made within reach,
    #: where the judge does not ask)
    visible: bool | None
    n_actions: int
    path_m: float
    poses: tuple[Pose, ...]  # after each action, the start first
    claims: int = 0  # ``found`` actions executed

    @property
    def kind(self) -> str:
        """``found`` (success), ``wrong_found`` (the last claim failed) or ``timeout``
        (the actions ran out, or the sequence ended, without a successful claim)."""
        if self.success:
            return "found"
        return "wrong_found" if self.found_called else "timeout"

    def spl(self, shortest_m: float) -> float:
        if not self.success:
            return 0.0
        return shortest_m / max(self.path_m, shortest_m) if max(self.path_m, shortest_m) > 0 \
            else 1.0

    def sna(self, fewest_actions: int) -> float:
        return fewest_actions / max(self.n_actions, fewest_actions) if self.success else 0.0


class Walk:
    """One episode in progress, one action at a time: the action simulator and the judge.

    :func:`run` feeds a whole sequence to a Walk; the environment (:mod:`fallgen.env`) feeds
    it one action per step: one implementation of the rules for the dataset's expert, the
    environment and ``fallgen evaluate``. The episode ends at a successful ``found``, when
    ``claims`` ``found`` actions have been made, or after ``max_actions`` actions. A ``found``
    succeeds when the agent stands within ``SUCCESS_DISTANCE_M`` (horizontally) of
    ``target_xy`` and ``visible(pose)``; ``visible`` is asked only then."""

    def __init__(self, start: Pose, grid: OccupancyGrid, target_xy,
                 visible: Callable[[Pose], bool], spec: AgentSpec = AgentSpec(),
                 claims: int = 1, max_actions: int = MAX_ACTIONS) -> None:
        if claims < 1:
            raise ValueError(f"claims must be at least 1 (got {claims})")
        self.grid, self.spec, self.visible = grid, spec, visible
        self.target_xy = np.asarray(target_xy, float)[:2]
        self.claims_allowed, self.max_actions = claims, max_actions
        self.pose = start
        self.poses = [start]
        self.path_m = 0.0
        self.n_actions = 0
        self.claims = 0
        self.success = False
        self.seen_at_claim: bool | None = None
        self.done = False

    def distance_m(self, pose: Pose | None = None) -> float:
        """Horizontal distance from ``pose`` (default: the current one) to the object."""
        return horizontal_distance_m(self.pose if pose is None else pose, self.target_xy)

    def act(self, action: int) -> bool:
        """Execute ``action``; whether it moved, turned or tilted as asked (see :func:`step`).
        Raises RuntimeError once the episode is over."""
        if self.done:
            raise RuntimeError("the episode is over: no more actions")
        a = int(action)
        nxt, ok = step(self.pose, a, self.grid, self.spec)
        self.n_actions += 1
        if a == FORWARD and ok:  # every move is STEP_M long: summed exactly (a power of two)
            self.path_m += STEP_M
        self.pose = nxt
        self.poses.append(nxt)
        if a == FOUND:
            self.claims += 1
            self.seen_at_claim = None
            if self.distance_m() <= SUCCESS_DISTANCE_M:
                self.seen_at_claim = bool(self.visible(nxt))
                self.success = self.seen_at_claim
            self.done = self.success or self.claims >= self.claims_allowed
        if self.n_actions >= self.max_actions:
            self.done = True
        return ok

    def succeed(self) -> None:
        """End the episode in success where the agent stands, without an action or a claim
        (an oracle's ``found``: the caller has judged the pose)."""
        if self.done:
            raise RuntimeError("the episode is over")
        self.success = self.seen_at_claim = self.done = True

    def outcome(self) -> Outcome:
        return Outcome(self.success, self.claims > 0, self.distance_m(), self.seen_at_claim,
                       self.n_actions, self.path_m, tuple(self.poses), self.claims)


def run(start: Pose, actions: Sequence[int], grid: OccupancyGrid, target_xy,
        visible: Callable[[Pose], bool], spec: AgentSpec = AgentSpec(), claims: int = 1
        ) -> Outcome:
    """Execute ``actions`` (until the episode ends: the first ``found`` with one claim, see
    :class:`Walk`, or after MAX_ACTIONS) and judge."""
    walk = Walk(start, grid, target_xy, visible, spec, claims)
    for a in actions:
        if walk.done:
            break
        walk.act(a)
    return walk.outcome()
