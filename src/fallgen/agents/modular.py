"""The modular planning agent (Gan et al. 2022, Sec. 5: the best agent family of the paper),
with its oracle switches.

Each step it (1) adds the depth image to its map (:class:`fallgen.agents.mapping.EgoMap`), (2)
updates its estimate of where the object is, (3) claims ``found`` when it sees the object
within reach, else (4) plans on the map (Dijkstra over the cells where it fits, unknown
space optimistic) and takes the action that makes the most progress: toward a place within
reach of the goal, or, with no goal, toward the nearest frontier of what it has seen.

The goal estimate comes from, in order: the ``location`` oracle (``object_position``: exact);
what it has seen of the object (the segmented pixels back-projected with depth); a
:class:`GoalPredictor` given at construction (e.g. an audio model: where the fall was heard,
with an uncertainty); else none (explore). What counts as the object in the segmentation: the
``category`` oracle's category (``object_category``), else the predictor's category, else any
object category (a distractor can then be taken for it). Seeing needs the ``segmentation``
oracle (``category_seg``) or a :class:`Detector`; without either the agent claims when it
faces the goal estimate within reach and its depth image shows nothing in front of it.

At the goal it turns to face the object and tilts toward it; a place from which it is not
seen is marked and the agent moves on to another within reach (nearer first). It is
deterministic: no random numbers.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from scipy.ndimage import label

from fallgen.agents.base import ORACLES
from fallgen.agents.mapping import CELL_M, FIT_SLACK_M, SIZE, AgentPose, EgoMap, back_project, \
    project
from fallgen.nav.agent import DOWN, FORWARD, FOUND, HEADING_VECTORS, HEADINGS, LEFT, \
    MAX_ACTIONS, RIGHT, STEP_M, SUCCESS_DISTANCE_M, TURN_DEG, UP, VISIBLE_PIXELS, AgentSpec
from fallgen.vision.camera import HEIGHT, WIDTH

#: where the agent goes to look at the object: within this (m) of it, horizontally
REACH_M = 1.5
#: it claims within this (m) of its estimate of the object (the judge: 2 m from the object's
#: centre): a little less for an estimate from what it saw (the median of the seen surface)
CLAIM_EXACT_M = SUCCESS_DISTANCE_M - 0.02
CLAIM_SEEN_M = SUCCESS_DISTANCE_M - 0.15
#: segmented pixels of the object for the agent to believe it sees it (the judge counts
#: VISIBLE_PIXELS of the object itself; the margin is for pixels of another object of the
#: same category near the estimate)
SEE_PIXELS = VISIBLE_PIXELS + 2
#: pixels whose points lie within this (m) of the estimate are the object's
NEAR_M = 0.35
#: camera tilt while travelling (down: the floor ahead is mapped)
TRAVEL_TILT_DEG = -15
#: the slack (m) of the robot's fit in the map (:data:`fallgen.agents.mapping.FIT_SLACK_M`),
#: then more when no way is left
SLACKS_M = (FIT_SLACK_M, 2 * FIT_SLACK_M)
#: cost of a turn, in metres of path, when choosing where to go
TURN_COST_M = 0.03
#: cost of coming back to a cell already stood on, per visit
REVISIT_COST_M = 0.1
#: places (m) around a spot from which the object was not seen are not tried again
FAILED_SPOT_M = 0.5


@dataclass(frozen=True)
class GoalEstimate:
    """Where and what the fallen object is, as a predictor believes: ``position`` (2,) or (3,)
    in the spawn's frame (x forward, y left, metres; z above the floor when given),
    ``radius_m`` its uncertainty (the agent searches that far around it), ``category`` the
    category id (None: unknown); ``categories`` the categories it could be, most likely
    first (empty: ``category`` alone), any of which the agent takes for the object."""

    position: np.ndarray | None
    radius_m: float = 1.0
    category: str | None = None
    categories: tuple[str, ...] = ()


@runtime_checkable
class GoalPredictor(Protocol):
    """Estimates the goal from the step-0 observation (the agent adds ``sensors`` to its
    own; e.g. ``("audio",)``)."""

    sensors: tuple[str, ...]

    def predict(self, obs: Mapping[str, np.ndarray]) -> GoalEstimate: ...


@runtime_checkable
class Detector(Protocol):
    """Segments object categories in an observation: (H, W) int array of indices into the
    dataset's category labels (-1: none), like the ``category_seg`` oracle. ``targets``
    (indices into the labels) are the categories the agent looks for: a detector may answer
    for those alone."""

    sensors: tuple[str, ...]

    def segment(self, obs: Mapping[str, np.ndarray], targets: np.ndarray) -> np.ndarray: ...


@dataclass
class _Candidate:
    point: np.ndarray  # (3,) spawn frame
    pixels: int  # the most pixels it was seen with


class ModularAgent:
    """The modular planner; ``oracles`` a subset of :data:`ORACLES`. ``category_labels``:
    the dataset's segmentation table (``FallenObjectsEnv.category_labels``);
    ``object_categories``: the categories a fallen object can have (what the agent looks for
    without the category oracle)."""

    def __init__(self, category_labels: Sequence[str], object_categories: Collection[str] = (),
                 oracles: Collection[str] = ORACLES, predictor: GoalPredictor | None = None,
                 detector: Detector | None = None, spec: AgentSpec = AgentSpec()) -> None:
        bad = sorted(set(oracles) - set(ORACLES))
        if bad:
            raise ValueError(f"unknown oracle {bad[0]!r}: {', '.join(ORACLES)}")
        self.oracles = tuple(o for o in ORACLES if o in oracles)
        self.labels = tuple(category_labels)
        self.object_idx = np.array(sorted(self.labels.index(c) for c in object_categories
                                          if c in self.labels), np.int64)
        self.predictor, self.detector, self.spec = predictor, detector, spec
        s = ["depth", "pose"]
        if "segmentation" in self.oracles:
            s.append("category_seg")
        if "category" in self.oracles:
            s.append("object_category")
        if "location" in self.oracles:
            s.append("object_position")
        for extra in (predictor, detector):
            s += [x for x in getattr(extra, "sensors", ()) if x not in s]
        self.sensors = tuple(s)
        self.reset()

    # --- episode state --------------------------------------------------------------------

    def reset(self) -> None:
        self.map = EgoMap(self.spec)
        self.n = 0
        self.goal: np.ndarray | None = None  # (3,) spawn frame
        self.goal_exact = False
        self.goal_radius = 0.0
        self.prior: np.ndarray | None = None  # the predictor's position
        self.candidates: list[_Candidate] = []
        self.rejected: list[np.ndarray] = []
        self.failed: list[np.ndarray] = []
        self.target_idx: np.ndarray = self.object_idx
        self.last: tuple[int, AgentPose] | None = None
        self.scan_left = 0
        self.stuck = 0

    # --- acting ---------------------------------------------------------------------------

    def act(self, obs: Mapping[str, np.ndarray]) -> int:
        pose = AgentPose.from_obs(obs["pose"])
        if self.n == 0:
            self._start(obs)
        self._after_last(pose)
        self.map.visit(pose.xy)
        self.map.integrate(np.asarray(obs["depth"]), pose)
        if "location" in self.oracles:
            self._locate(obs["object_position"], pose)
        seen = self._see(obs, pose)
        a = self._decide(obs, pose, seen)
        self.last = (a, pose)
        self.n += 1
        return a

    def _start(self, obs: Mapping[str, np.ndarray]) -> None:
        if "category" in self.oracles:
            self.target_idx = np.array([int(obs["object_category"])], np.int64)
        if self.predictor is not None:
            est = self.predictor.predict(obs)
            guess = [c for c in (est.categories or (est.category,)) if c in self.labels]
            if guess and "category" not in self.oracles:
                self.target_idx = np.array(sorted({self.labels.index(c) for c in guess}),
                                           np.int64)
            if est.position is not None and "location" not in self.oracles:
                p = np.asarray(est.position, float)
                z = p[2] if len(p) > 2 else 0.3
                self.prior = np.array([p[0], p[1], z])
                self.goal, self.goal_radius = self.prior.copy(), float(est.radius_m)
        if self.goal is None and "location" not in self.oracles:
            self.scan_left = HEADINGS - 3  # look around first: 10 views cover the room

    def _after_last(self, pose: AgentPose) -> None:
        """What the last action did: a forward move that did not happen is an obstacle; a
        claim that did not end the episode was wrong."""
        if self.last is None:
            return
        a, before = self.last
        if a == FORWARD and np.allclose(pose.xy, before.xy, atol=1e-4):
            self.map.block(before.xy, before.heading)
        if a == FOUND and self.goal is not None and not self.goal_exact:
            self.rejected.append(self.goal.copy())
            self.candidates = [c for c in self.candidates
                               if np.linalg.norm(c.point[:2] - self.goal[:2]) > NEAR_M]
            self.goal = self.prior.copy() if self.prior is not None else None

    def _locate(self, rel: np.ndarray, pose: AgentPose) -> None:
        """The location oracle: the object's centre relative to the camera (forward, left,
        up; the camera's heading)."""
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        f, left, up = (float(v) for v in rel)
        self.goal = np.array([pose.x + f * c - left * s, pose.y + f * s + left * c,
                              self.spec.camera_height_m + up])
        self.goal_exact = True

    # --- seeing ---------------------------------------------------------------------------

    def _segmentation(self, obs: Mapping[str, np.ndarray]) -> np.ndarray | None:
        if "segmentation" in self.oracles:
            return np.asarray(obs["category_seg"]).reshape(obs["depth"].shape[:2])
        if self.detector is not None:
            return np.asarray(self.detector.segment(obs, self.target_idx))
        return None

    def _see(self, obs: Mapping[str, np.ndarray], pose: AgentPose) -> int:
        """Pixels of the object (as the agent believes) in this view: near the goal when it
        is known, else those of the best candidate seen; updates the candidates."""
        seg = self._segmentation(obs)
        if seg is None:
            return -1  # cannot see: judged by depth at the claim
        depth = np.asarray(obs["depth"]).reshape(seg.shape)
        rows, cols = np.nonzero(np.isin(seg, self.target_idx))
        if len(rows) == 0:
            return 0
        pts = back_project(depth, rows, cols, pose, self.spec.camera_height_m)
        if self.goal_exact:
            return int((np.linalg.norm(pts - self.goal, axis=1) <= NEAR_M).sum())
        # clusters of the pixels by their cells on the floor plan (labelled in the cells'
        # bounding box only)
        i, j = self.map.cells(pts[:, :2])
        i, j = i - i.min(), j - j.min()
        img = np.zeros((i.max() + 1, j.max() + 1), bool)
        img[i, j] = True
        lab, k = label(img, structure=np.ones((3, 3)))
        ids = lab[i, j]
        for c in range(1, k + 1):
            sel = ids == c
            n = int(sel.sum())
            if n < SEE_PIXELS:
                continue
            p = np.median(pts[sel], axis=0)
            if any(np.linalg.norm(p[:2] - r[:2]) <= NEAR_M for r in self.rejected):
                continue
            for cand in self.candidates:
                if np.linalg.norm(cand.point[:2] - p[:2]) <= NEAR_M:
                    if n >= cand.pixels:
                        cand.point, cand.pixels = p, n
                    break
            else:
                self.candidates.append(_Candidate(p, n))
        if self.candidates:
            ref = self.prior
            if ref is not None:  # the one nearest where the predictor heard it
                best = min(self.candidates, key=lambda c: np.linalg.norm(c.point[:2] - ref[:2]))
            else:  # the one seen best (the first of equals: the earliest)
                best = max(self.candidates, key=lambda c: c.pixels)
            if self.goal is None or np.linalg.norm(self.goal - best.point) > 1e-9:
                self.goal, self.goal_radius, self.failed = best.point.copy(), 0.0, []
            return int((np.linalg.norm(pts - self.goal, axis=1) <= NEAR_M).sum())
        return 0

    def _sees_by_depth(self, obs: Mapping[str, np.ndarray], pose: AgentPose) -> bool:
        """Without segmentation: the goal is in the image and the depth there is no nearer
        than it (nothing in front of it)."""
        row, col, z = project(self.goal[None, :], pose, self.spec.camera_height_m)
        r, c, z = float(row[0]), float(col[0]), float(z[0])
        d = np.asarray(obs["depth"]).reshape(HEIGHT, WIDTH)
        if not (z > 0 and 5 <= r < d.shape[0] - 5 and 5 <= c < d.shape[1] - 5):
            return False
        patch = d[int(r) - 2:int(r) + 3, int(c) - 2:int(c) + 3]
        return bool(np.median(patch) >= z - 0.2)

    # --- deciding -------------------------------------------------------------------------

    def _decide(self, obs: Mapping[str, np.ndarray], pose: AgentPose, seen: int) -> int:
        last_chance = self.n >= MAX_ACTIONS - 1
        d = math.inf if self.goal is None else float(np.linalg.norm(pose.xy - self.goal[:2]))
        if self.goal is not None:
            claim_m = CLAIM_EXACT_M if self.goal_exact else CLAIM_SEEN_M
            if d <= claim_m and (seen >= SEE_PIXELS or (seen >= VISIBLE_PIXELS and
                                                         self.goal_exact)):
                return FOUND
            if d <= claim_m and seen < 0 and self._facing(pose) and \
                    self._sees_by_depth(obs, pose):
                return FOUND
            if last_chance and d <= SUCCESS_DISTANCE_M:
                return FOUND
        if self.scan_left > 0:
            self.scan_left -= 1
            return self._tilt_to(pose, TRAVEL_TILT_DEG) or LEFT
        if self.goal is not None and self._searching_goal():
            if d <= self._reach() + 1e-6 and not self._failed_here(pose):
                a = self._look(pose)
                if a is not None:
                    return a
                self.failed.append(pose.xy.copy())  # faced it, did not see it
            a = self._go(pose, self._goal_sources())
            if a is not None:
                return a
        a = self._go(pose, self._frontier_sources())
        if a is not None:
            return a
        # nowhere to go on the map: look around, and now and then try the way ahead
        self.stuck += 1
        return self._tilt_to(pose, TRAVEL_TILT_DEG) or (FORWARD if self.stuck % 4 == 0 else LEFT)

    def _searching_goal(self) -> bool:
        """Whether the goal is still worth going to: exact or seen goals always; a
        predicted one until every place around it was tried."""
        return self.goal_exact or self.goal_radius == 0.0 or len(self.failed) < 8

    def _failed_here(self, pose: AgentPose) -> bool:
        return any(np.linalg.norm(pose.xy - f) < FAILED_SPOT_M for f in self.failed)

    def _facing(self, pose: AgentPose) -> bool:
        return self._look(pose) is None

    def _look(self, pose: AgentPose) -> int | None:
        """Turn to the goal, then tilt toward it; None when already done."""
        v = self.goal[:2] - pose.xy
        want = int(round(math.degrees(math.atan2(v[1], v[0])) / TURN_DEG)) % HEADINGS
        a = _turn(pose.heading, want)
        if a is not None:
            return a
        elev = math.degrees(math.atan2(self.goal[2] - self.spec.camera_height_m,
                                       max(float(np.linalg.norm(v)), 1e-6)))
        step = self.spec.tilt_step_deg
        tilt = int(np.clip(round(elev / step) * step, self.spec.tilt_min_deg,
                           self.spec.tilt_max_deg))
        return self._tilt_to(pose, tilt)

    def _tilt_to(self, pose: AgentPose, tilt: int) -> int | None:
        t = pose.tilt_deg
        step = self.spec.tilt_step_deg
        if abs(t - tilt) < step / 2:
            return None
        return UP if tilt > t else DOWN

    def _high(self) -> bool:
        """Whether the goal is above the camera (on a high shelf or cabinet: seen over the
        edge it lies behind, so from farther away)."""
        return self.goal is not None and self.goal[2] > self.spec.camera_height_m

    def _reach(self) -> float:
        r = CLAIM_SEEN_M if self._high() else REACH_M
        return r + (self.goal_radius if not self.goal_exact else 0.0)

    def _goal_sources(self) -> tuple[np.ndarray, np.ndarray]:
        """Places within reach of the goal (nearer ones cheaper; farther ones for a goal
        above the camera), those that failed left out; for a predicted goal, within its
        uncertainty."""
        reach = self._reach()
        c = EgoMap.all_centres()
        d = np.linalg.norm(c - self.goal[:2], axis=-1)
        ok = d <= reach
        for f in self.failed:
            ok &= np.linalg.norm(c - f, axis=-1) >= FAILED_SPOT_M
        return ok, 0.5 * (np.maximum(reach - d, 0.0) if self._high() else d)

    def _frontier_sources(self) -> tuple[np.ndarray, np.ndarray]:
        """The frontier; with a prior (the predictor's position), nearer it cheaper."""
        fr = self.map.frontier()
        cost = np.zeros((SIZE, SIZE))
        if self.prior is not None:
            cost = 0.5 * np.linalg.norm(EgoMap.all_centres() - self.prior[:2], axis=-1)
        return fr, cost

    def _go(self, pose: AgentPose, sources: tuple[np.ndarray, np.ndarray]) -> int | None:
        """The action along the best plan to the nearest source; None when none can be
        reached (or the robot stands on one). When the map shuts every way, it is planned
        again with more slack (:data:`SLACKS_M`: a gap the map drew a little too narrow)."""
        src, cost = sources
        if not src.any():
            return None
        pts = [pose.xy] + ([self.goal[:2]] if self.goal is not None else [])
        win = self.map.window(*pts)
        # last, any cell the map holds no obstacle in: a way the map draws shut may still be
        # open, and a move the simulator refuses is remembered (EgoMap.block)
        for slack in SLACKS_M + (self.spec.radius_m - CELL_M / 4,):
            field = self.map.field(win, src, cost, slack)
            best, best_v = None, math.inf
            for k in range(HEADINGS):
                if not self.map.move_fits(pose.xy, k, slack):
                    continue
                q = pose.xy + STEP_M * HEADING_VECTORS[k]
                qi, qj = EgoMap.cells(q)
                v = self.map.value(field, q) + TURN_COST_M * _turns(pose.heading, k) \
                    + REVISIT_COST_M * float(self.map.visits[qi, qj])
                if v < best_v - 1e-9:
                    best, best_v = k, v
            if best is not None and math.isfinite(best_v):
                break
        else:
            return None
        i, j = EgoMap.cells(pose.xy)
        if src[i, j] and self.map.value(field, pose.xy) <= best_v:  # arrived
            return None
        a = self._tilt_to(pose, TRAVEL_TILT_DEG) if not self._near_goal(pose) else None
        if a is not None:
            return a
        return FORWARD if best == pose.heading else _turn(pose.heading, best)

    def _near_goal(self, pose: AgentPose) -> bool:
        return self.goal is not None and \
            float(np.linalg.norm(pose.xy - self.goal[:2])) <= self._reach() + 1.0


def _turns(h: int, k: int) -> int:
    d = (k - h) % HEADINGS
    return min(d, HEADINGS - d)


def _turn(h: int, k: int) -> int | None:
    d = (k - h) % HEADINGS
    if d == 0:
        return None
    return LEFT if d <= HEADINGS // 2 else RIGHT


__all__ = ["ModularAgent", "GoalEstimate", "GoalPredictor", "Detector", "ORACLES"]
