"""The expert: shortest action sequences in the agent's own motion lattice, to the real
success set.

From the start pose, ``move_forward`` (0.25 m along one of 12 headings), the two turns and the
two tilts span the agent's pose lattice, taken exactly (no binning: :mod:`fallgen.nav.lattice`
keys every position by its four integer lattice coordinates). A pose is a goal when ``found``
there succeeds, as the judge (:class:`fallgen.nav.agent.Walk`) rules: the object's centre
within ``SUCCESS_DISTANCE_M`` horizontally (the judge's own distance) and ``visible(pose)`` (the
renderer's segmentation count, at least ``VISIBLE_PIXELS``). Tilts commute with every other
action, so a plan tilts last, by the fewest steps that bring the object into view.

Two A* searches, each exact for its costs:

- forward moves first, then turns and tilts (cost 1000 per move, 1 per turn and tilt step):
  the expert's own plan; its forward moves times 0.25 m are l of SPL, the shortest path to any
  pose from which ``found`` succeeds;
- fewest actions (1 each): n* of SNA, ``found`` included.

A candidate pose is rendered only when no cheaper one can remain (cost order), and only at the
tilts whose view frustum can hold the object (:func:`fallgen.nav.lattice.tilt_bound`); so the
references are exact over the renderer's verdicts, and the expert's SPL is 1. Its SNA is 1
where its plan (fewest moves first) also has the fewest actions, below 1 where fewer actions
need more moves (``tests/nav`` checks both searches against a brute-force breadth-first search).

Where no reachable pose sees the object, the search would enter states until its limits (the
lattice is dense); once it has grown long, the expert tries the proof of
:func:`fallgen.nav.hidden.hidden_everywhere` instead, and answers :class:`NoPath` where it holds
(it never holds where a pose sees the object, so no plan changes).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fallgen.nav.agent import (DOWN, FORWARD, FOUND, HEADING_VECTORS, LEFT, MAX_ACTIONS, RIGHT,
                               STEP_FRACTIONS, STEP_M, STEP_SAMPLES, SUCCESS_DISTANCE_M,
                               TURN_DEG, UP, AgentSpec, Pose, horizontal_distance_m)
from fallgen.nav.hidden import hidden_everywhere
from fallgen.nav.lattice import Lattice, LatticeFull, trace
from fallgen.nav.occupancy import OccupancyGrid
from fallgen.vision.sight import kernel_within

FOV_DEG = 90.0
#: ``may_see(pose, tilts)``: for each tilt (degrees) of the pose's position and heading,
#: whether the object can be visible there at all (False only where it cannot).
MaySee = Callable[[Pose, list[int]], "list[bool] | np.ndarray"]
#: ``unseen(pose)``: True only where no heading or tilt at the pose's position can see it.
Unseen = Callable[[Pose], bool]
#: Renderer verdicts one search may ask for before it gives up (:class:`SearchLimit`).
MAX_VISIBILITY_CHECKS = 1000
#: Lattice states one search may enter before it gives up (about 130 bytes each).
MAX_STATES = 2_000_000
#: A search that enters this many states or asks this many verdicts tries the proof that no
#: reachable pose sees the object (most searches end sooner; the proof costs ~0.01-1 s). The
#: lattice counts its states when its tables grow: the first time at 16 381 states. (On a
#: 250-episode slice of the paper-size configuration, 10 000 instead of 50 000 made the same
#: bytes, the 38 attempts given up 20 % faster, the episodes' planning no slower.)
PROOF_AFTER_STATES, PROOF_AFTER_VERDICTS = 10_000, 50


@dataclass(frozen=True)
class Plan:
    actions: tuple[int, ...]
    goal: Pose
    path_m: float
    renders: int  # visibility verdicts asked for


class NoPath(RuntimeError):
    """No pose from which the object is visible can be reached."""


class HiddenEverywhere(NoPath):
    """No pose the agent can reach sees the object, proven over the start's reachable cells
    (:func:`fallgen.nav.hidden.hidden_everywhere`): the same holds from any start whose
    reachable cells (:func:`fallgen.nav.hidden.reachable_cells`) are the same."""


class SearchLimit(NoPath):
    """The search gave up (:data:`MAX_VISIBILITY_CHECKS`, :data:`MAX_STATES`) before it could
    prove its answer optimal."""


def fewest_tilts(pose: Pose, at_least: int, spec: AgentSpec, visible: Callable[[Pose], bool],
                 may_see: MaySee | None = None) -> tuple[int | None, int]:
    """The signed fewest tilt steps (at least ``at_least``) from ``pose`` after which
    ``visible`` holds, the lower tilt first on ties; None if no tilt within the limits does.
    ``may_see``: which tilts ``visible`` can hold at, at most (the others are not asked).
    Also the number of verdicts asked for."""
    order = []
    for m in range(at_least, (spec.tilt_max_deg - spec.tilt_min_deg) // spec.tilt_step_deg + 1):
        for sign in ((-1, 1) if m else (1,)):
            t = pose.tilt_deg + sign * m * spec.tilt_step_deg
            if spec.tilt_min_deg <= t <= spec.tilt_max_deg:
                order.append((sign * m, t))
    if may_see is not None and order:
        keep = may_see(pose, [t for _, t in order])
        order = [o for o, k in zip(order, keep) if k]
    asked = 0
    for steps, t in order:
        asked += 1
        if visible(Pose(pose.x, pose.y, pose.heading, t)):
            return steps, asked
    return None, asked


def hidden_cells(start: Pose, ok: np.ndarray, resolution: float, target_xy,
                 spec: AgentSpec, sight: tuple) -> int | None:
    """The expert's proof that no pose reachable from ``start`` sees the object centred at
    ``target_xy`` (:func:`fallgen.nav.hidden.hidden_everywhere` over the cells within the
    judge's reach; ``ok``: the simulator's move table, ``sight``: the occlusion bound's
    arrays): how many cells it ran over where it holds, None where it does not."""
    return hidden_everywhere(ok, resolution, (start.x, start.y), target_xy,
                             SUCCESS_DISTANCE_M, spec.camera_height_m,
                             STEP_M / (STEP_SAMPLES - 1), sight)


def _prove_hidden(start: Pose, ok: np.ndarray, resolution: float, target_xy,
                  spec: AgentSpec, sight: tuple) -> None:
    """:class:`NoPath` where :func:`hidden_cells` holds. A search tries it once it has grown
    long (:data:`PROOF_AFTER_STATES`, :data:`PROOF_AFTER_VERDICTS`): where it holds, the
    search would go on until it had entered every state or hit its limits."""
    cells = hidden_cells(start, ok, resolution, target_xy, spec, sight)
    if cells is not None:
        raise HiddenEverywhere(f"the scene hides the object from every reachable cell within "
                               f"reach ({cells} cells)")


@dataclass(frozen=True)
class Limits:
    """How much one search may do before it gives up (:class:`SearchLimit`): renderer
    verdicts asked for, lattice states entered."""

    verdicts: int = MAX_VISIBILITY_CHECKS
    states: int = MAX_STATES


def _search(start: Pose, grid: OccupancyGrid, target, corners: np.ndarray, spec: AgentSpec,
            move_cost: int, turn_cost: int, visible: Callable[[Pose], bool],
            limits: Limits, may_see: MaySee | None, unseen: Unseen | None,
            sight: tuple | None, prove: bool, known: list | None = None
            ) -> tuple[Plan, int]:
    """One A* search (see :class:`fallgen.nav.lattice.Lattice`); ``known``: a list that
    carries the positions' occlusion verdicts from one search from ``start`` to the next
    (read when it holds them, filled when the search ends)."""
    ok = grid.move_table(spec.radius_m)
    target_xy = np.asarray(target, float)[:2]
    tilt_cost = min(move_cost, turn_cost)
    lat = Lattice(ok=ok, resolution=grid.resolution, step_m=STEP_M,
                  step_fractions=STEP_FRACTIONS, heading_vectors=HEADING_VECTORS,
                  turn_deg=TURN_DEG, target_xy=target_xy, corners=corners,
                  camera_height_m=spec.camera_height_m, reach_m=SUCCESS_DISTANCE_M,
                  half_fov_deg=FOV_DEG / 2, move_cost=move_cost, turn_cost=turn_cost,
                  tilt_cost=tilt_cost, tilt_deg=start.tilt_deg, tilt_min_deg=spec.tilt_min_deg,
                  tilt_max_deg=spec.tilt_max_deg, tilt_step_deg=spec.tilt_step_deg,
                  actions=(FORWARD, LEFT, RIGHT), max_actions=MAX_ACTIONS,
                  # the lattice asks about eyes within reach only (the proofs take it whole)
                  sight=None if sight is None else kernel_within(
                      sight, target_xy, SUCCESS_DISTANCE_M + 1e-6, spec.camera_height_m))
    lat.start(start.x, start.y, start.heading)
    if known:
        lat.know_positions(*known)
    confirmed: dict[int, int] = {}  # state -> its signed tilt steps, once rendered
    renders = 0
    prove = prove and sight is not None  # tried at most once, when the search grows long
    states = min(limits.states, PROOF_AFTER_STATES) if prove else limits.states
    while True:
        try:
            cand = lat.next_candidate(states)
        except LatticeFull as e:
            if states < limits.states:  # grown long: the proof (unless tried), then the rest
                if prove:
                    prove = False
                    _prove_hidden(start, ok, grid.resolution, target_xy, spec, sight)
                states = limits.states
                continue
            raise SearchLimit(f"gave up after {renders} verdicts: {e}") from None
        if cand is None:
            raise NoPath(f"no reachable pose sees the object ({renders} views rendered, "
                         f"{lat.states} poses searched)")
        total, s, bound = cand
        pose = Pose(float(lat.px[s]), float(lat.py[s]), lat.heading(s), start.tilt_deg)
        t = confirmed.get(s)
        if t is None:
            if horizontal_distance_m(pose, target_xy) > SUCCESS_DISTANCE_M:
                continue  # within the search's rounding slack, outside the judge's reach
            if prove and renders >= PROOF_AFTER_VERDICTS:
                prove = False
                _prove_hidden(start, ok, grid.resolution, target_xy, spec, sight)
            if renders >= limits.verdicts:
                raise SearchLimit(f"gave up after {renders} views rendered, {lat.states} "
                                  "poses searched")
            if unseen is not None and unseen(pose):
                lat.mark_unseen(s)
                continue
            t, asked = fewest_tilts(pose, bound, spec, visible, may_see)
            renders += asked
            if t is None:
                continue
            if abs(t) > bound:  # dearer than its bound: back in line at its exact total
                confirmed[s] = t
                lat.offer(total + (abs(t) - bound) * tilt_cost, s, t)
                continue
        goal = Pose(pose.x, pose.y, pose.heading, start.tilt_deg + t * spec.tilt_step_deg)
        moves = trace(lat.act, lat.parent, s)
        actions = moves + [UP if t > 0 else DOWN] * abs(t) + [FOUND]
        plan = Plan(tuple(actions), goal, moves.count(FORWARD) * STEP_M, renders)
        if known is not None:
            known[:] = lat.position_verdicts()
        return plan, total


@dataclass(frozen=True)
class Expert:
    plan: Plan  # the expert's actions (fewest forward moves, then fewest other actions)
    shortest_m: float  # l of SPL
    fewest_actions: int  # n* of SNA


def expert(start: Pose, grid: OccupancyGrid, target, corners: np.ndarray,
           visible: Callable[[Pose], bool], spec: AgentSpec = AgentSpec(),
           limits: Limits = Limits(), may_see: MaySee | None = None,
           unseen: Unseen | None = None, sight: tuple | None = None) -> Expert:
    """Plan the expert's action sequence from ``start`` to a pose from which ``found``
    succeeds on the object centred at ``target`` (room frame; ``corners``: points (N, 3) whose
    hull holds it, for the frustum test), and the optimum references of SPL and SNA.
    ``may_see``, ``unseen``: bounds that spare ``visible`` the views that cannot show the
    object (:data:`MaySee`, :data:`Unseen`); ``sight``: the occlusion bound's arrays
    (:attr:`fallgen.vision.sight.Occluders.kernel`), for the search to skip the positions it
    proves hidden without asking."""
    # the second search asks about the same positions: the first one's occlusion verdicts
    # are handed on (a position's verdict is the same whichever search asks)
    known: list = []
    plan = plan_to_see(start, grid, target, corners, visible, spec, limits, may_see, unseen,
                       sight, known)
    fewest, total = _search(start, grid, target, corners, spec, 1, 1, visible, limits,
                            may_see, unseen, sight, False, known)
    if total != len(fewest.actions) or total > len(plan.actions):
        raise AssertionError(f"fewest-actions search: {total} actions, plan "
                             f"{len(fewest.actions)}, expert {len(plan.actions)}")
    return Expert(plan, plan.path_m, total)


def plan_to_see(start: Pose, grid: OccupancyGrid, target, corners: np.ndarray,
                visible: Callable[[Pose], bool], spec: AgentSpec = AgentSpec(),
                limits: Limits = Limits(), may_see: MaySee | None = None,
                unseen: Unseen | None = None, sight: tuple | None = None,
                known: list | None = None) -> Plan:
    """The expert's own plan from ``start`` (fewest forward moves, then fewest turns and
    tilts; the first search of :func:`expert`), without the fewest-actions search.
    ``known``: filled with the search's position verdicts (see :func:`_search`)."""
    plan, _ = _search(start, grid, target, corners, spec, 1000, 1, visible, limits, may_see,
                      unseen, sight, True, known)
    if len(plan.actions) > MAX_ACTIONS:
        raise NoPath(f"the shortest plan takes {len(plan.actions)} actions, more than "
                     f"{MAX_ACTIONS}")
    return plan
