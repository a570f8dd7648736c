"""The expert's lattice search, compiled (Numba): a bucket-queue Dijkstra over the agent's own
motion lattice, run until candidate goal poses are ready to be confirmed.

:func:`fallgen.nav.expert._search` owns the search's arrays (:class:`Lattice`) and asks
:func:`advance` for the next batch of candidates, in cost order; it checks each with ray casts
and a render (Python callbacks, which compiled code cannot call) and calls :func:`advance`
again when all of a batch were refused. The search itself (states, costs, the 5 cm bins and
which pose represents one, parents, the forward moves' collision checks, the goal test and
the tilt choice) is :mod:`fallgen.nav.expert`'s design, step for step: the same IEEE
operations in the same order, so the same plans as the vectorised NumPy form it replaced
(``tests/nav`` keeps that form as its reference).

A state is ``bin * HEADINGS + heading`` with ``bin = floor(x / BIN_M) * nby + floor(y / BIN_M)``
(:func:`state_of`). Buckets (states by cost) are a ring of linked lists, one slot per cost, each
sorted by state when it is expanded; found candidates (by total cost, state, tilt steps) are a
binary heap of int64 keys.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: ``tilt`` value of a pose whose tilt limits cannot centre the object.
NO_TILT = np.iinfo(np.int64).min
#: Offset and span of the tilt steps in a found candidate's key.
_T_OFF, _T_SPAN = 32, 64
#: Indices into the float parameters.
(P_STEP, P_BIN, P_RES, P_REACH, P_VIEW, P_HALF_FOV, P_TURN_DEG, P_TX, P_TY, P_TZ,
 P_CAMERA) = range(11)
#: Indices into the integer parameters.
(I_NBY, I_SIZE, I_MOVE, I_TURN, I_TILT_MIN, I_TILT_MAX, I_TILT_STEP, I_TILT0, I_HI0,
 I_HI1, I_FORWARD, I_LEFT, I_RIGHT, I_HEADINGS) = range(14)
#: Indices into the counters: live bucket entries, entries made, lowest cost that may hold
#: one, pending forward moves, found heap size, forward batch stamp.
C_LIVE, C_ENTRIES, C_LOW, C_PENDING, C_FOUND, C_STAMP = range(6)


@njit(cache=True)
def _enter(head, nxt, states, counts, cost, s):
    """Put state ``s`` into the bucket of ``cost`` (a ring of buckets, one per cost: the live
    costs span less than the ring, see :func:`_lowest`)."""
    e = counts[C_ENTRIES]
    if e >= len(states):
        raise RuntimeError("lattice search: more bucket entries than its bound")
    slot = cost % len(head)
    states[e], nxt[e] = s, head[slot]
    head[slot] = e
    counts[C_ENTRIES] = e + 1
    counts[C_LIVE] += 1
    counts[C_LOW] = min(counts[C_LOW], cost)


@njit(cache=True)
def _lowest(head, counts):
    """The lowest cost with a live bucket (-1 if none). The live costs always lie within a
    move and a turn of each other (a bucket's expansion enters costs at most a move above it,
    and pending moves are made once a turn could cost as much), so one ring slot per cost
    over that span holds every live bucket alone; :func:`advance` checks it."""
    if counts[C_LIVE] == 0:
        return -1
    c = counts[C_LOW]
    while head[c % len(head)] < 0:
        c += 1
    counts[C_LOW] = c
    return c


@njit(cache=True)
def _push(h, n, key):
    i = n
    while i > 0:
        p = (i - 1) >> 1
        if h[p] <= key:
            break
        h[i] = h[p]
        i = p
    h[i] = key
    return n + 1


@njit(cache=True)
def _pop(h, n):
    """(smallest key, new size)."""
    top = h[0]
    n -= 1
    last = h[n]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= n:
            break
        if child + 1 < n and h[child + 1] < h[child]:
            child += 1
        if h[child] >= last:
            break
        h[i] = h[child]
        i = child
    h[i] = last
    return top, n


@njit(cache=True)
def free_at(ok, res, hi0, hi1, x, y):
    """The occupancy table ``ok`` (a border of "outside" around the grid) at (x, y)."""
    fi = min(max(np.floor(x / res), -1.0), hi0 - 1.0)
    fj = min(max(np.floor(y / res), -1.0), hi1 - 1.0)
    return ok[int(fi) + 1, int(fj) + 1]


@njit(cache=True)
def tilt_step(dist, tz, camera, tilt0, tilt_min, tilt_max, tilt_step_deg, half_fov):
    """Signed tilt steps from ``tilt0`` that bring an object at horizontal distance ``dist``
    and height ``tz`` nearest the view centre within ``half_fov`` (the lowest tilt on ties),
    ``NO_TILT`` if none can."""
    elev = math.degrees(math.atan2(tz - camera, max(dist, 1e-6)))
    best_off = math.inf
    best = 0
    t = tilt_min
    while t <= tilt_max:
        off = abs(elev - t)
        if off > half_fov:
            off = math.inf
        if off < best_off:
            best_off, best = off, t
        t += tilt_step_deg
    if not best_off < math.inf:
        return NO_TILT
    return (best - tilt0) // tilt_step_deg


@njit(cache=True)
def state_of(x, y, heading, bin_m, nby, headings):
    """The state of a pose at (x, y) with ``heading``: its 5 cm bin times the headings, plus
    the heading (out of range for a pose outside the grid's bins)."""
    return (np.int64(np.floor(x / bin_m)) * nby + np.int64(np.floor(y / bin_m))) * headings \
        + heading


@njit(cache=True)
def _move_forward(best, px, py, parent, act, mark, head, nxt, entries, pend_cost, pend_state,
                  pend_x, pend_y, counts, ok, dirs, fracs, fp, ip):
    """Every pending forward move, in the order the moves were queued (cost, then state): a
    bin's state goes to the first move that reaches it, if that lowers its cost."""
    size, nby, headings = ip[I_SIZE], ip[I_NBY], ip[I_HEADINGS]
    step, binm, res = fp[P_STEP], fp[P_BIN], fp[P_RES]
    hi0, hi1 = ip[I_HI0], ip[I_HI1]
    stamp = counts[C_STAMP] + 1
    counts[C_STAMP] = stamp
    for j in range(counts[C_PENDING]):
        st = pend_state[j]
        k = st % headings
        x0, y0 = pend_x[j], pend_y[j]
        x1 = x0 + step * dirs[k, 0]
        y1 = y0 + step * dirs[k, 1]
        clear = True
        for f in fracs:  # the simulator's own check of a forward move
            if not free_at(ok, res, hi0, hi1, x0 + f * (x1 - x0), y0 + f * (y1 - y0)):
                clear = False
                break
        if not clear:
            continue
        s = state_of(x1, y1, k, binm, nby, headings)
        if s < 0 or s >= size or mark[s] == stamp:
            continue
        mark[s] = stamp
        cost = pend_cost[j] + ip[I_MOVE]
        if best[s] > cost:
            best[s], px[s], py[s], parent[s], act[s] = cost, x1, y1, st, ip[I_FORWARD]
            _enter(head, nxt, entries, counts, cost, s)
    counts[C_PENDING] = 0


@njit(cache=True)
def advance(best, px, py, parent, act, mark, head, nxt, entries, pend_cost, pend_state,
            pend_x, pend_y, found, scratch, scratch_x, scratch_y, counts, ok, dirs, fracs, fp,
            ip):
    """Run the search until candidates are final (their total below every unexpanded cost);
    returns them, (M, 3) rows of (total cost, state, tilt steps) in the order to confirm
    them, or an empty array when the lattice is exhausted."""
    size, headings = ip[I_SIZE], ip[I_HEADINGS]
    move, turn = ip[I_MOVE], ip[I_TURN]
    tilt_cost = min(move, turn)
    fkey = size * _T_SPAN
    while True:
        c = _lowest(head, counts)
        has_c = c >= 0
        # the pending forward moves are made before bucket c when a turn could cost as much
        if counts[C_PENDING] > 0 and (not has_c or c + turn >= pend_cost[0] + move):
            _move_forward(best, px, py, parent, act, mark, head, nxt, entries, pend_cost,
                          pend_state, pend_x, pend_y, counts, ok, dirs, fracs, fp, ip)
            continue
        nf = counts[C_FOUND]
        if nf > 0 and (not has_c or found[0] // fkey < c):
            m = 0
            out = np.empty((nf, 3), np.int64)
            while nf > 0 and (not has_c or found[0] // fkey < c):
                key, nf = _pop(found, nf)
                out[m, 0] = key // fkey
                out[m, 1] = (key % fkey) // _T_SPAN
                out[m, 2] = key % _T_SPAN - _T_OFF
                m += 1
            counts[C_FOUND] = nf
            return out[:m]
        if not has_c:
            return np.empty((0, 3), np.int64)
        # bucket c: its states in state order (a state enters a bucket once: only when its
        # cost strictly drops to the bucket's), those still at cost c
        slot = c % len(head)
        e, n = head[slot], 0
        while e >= 0:
            s = entries[e]
            if best[s] > c:  # an entry of a higher cost in this slot: the ring is too short
                raise RuntimeError("lattice search: two live costs share a bucket")
            scratch[n] = s
            n += 1
            e = nxt[e]
        head[slot] = -1
        counts[C_LIVE] -= n
        scratch[:n].sort()
        m = 0
        for i in range(n):
            s = scratch[i]
            if best[s] == c:
                scratch[m], scratch_x[m], scratch_y[m] = s, px[s], py[s]
                m += 1
        n = m
        if n == 0:
            continue
        # goal candidates among the settled states
        for i in range(n):
            s = scratch[i]
            k = s % headings
            dx, dy = fp[P_TX] - scratch_x[i], fp[P_TY] - scratch_y[i]
            dist = math.hypot(dx, dy)
            if dist > fp[P_REACH] or math.hypot(dist, fp[P_TZ] - fp[P_CAMERA]) > fp[P_VIEW]:
                continue
            bearing = (math.degrees(math.atan2(dy, dx)) - fp[P_TURN_DEG] * k + 180.0) \
                % 360.0 - 180.0
            if abs(bearing) <= fp[P_HALF_FOV]:
                t = tilt_step(dist, fp[P_TZ], fp[P_CAMERA], ip[I_TILT0], ip[I_TILT_MIN],
                              ip[I_TILT_MAX], ip[I_TILT_STEP], fp[P_HALF_FOV])
                if t != NO_TILT:
                    total = c + abs(t) * tilt_cost + 1
                    nf = _push(found, nf, total * fkey + s * _T_SPAN + t + _T_OFF)
        counts[C_FOUND] = nf
        # expand: forward (queued, see the top of the loop) and the two turns (a turn stays
        # in its own bin, one state per source)
        p = counts[C_PENDING]
        for i in range(n):
            pend_cost[p], pend_state[p] = c, scratch[i]
            pend_x[p], pend_y[p] = scratch_x[i], scratch_y[i]
            p += 1
        counts[C_PENDING] = p
        if c + turn >= pend_cost[0] + move:
            _move_forward(best, px, py, parent, act, mark, head, nxt, entries, pend_cost,
                          pend_state, pend_x, pend_y, counts, ok, dirs, fracs, fp, ip)
        for d, a in ((1, ip[I_LEFT]), (-1, ip[I_RIGHT])):
            for i in range(n):
                s = scratch[i]
                k = s % headings
                s2 = s - k + (k + d) % headings
                if best[s2] > c + turn:
                    best[s2], px[s2], py[s2] = c + turn, scratch_x[i], scratch_y[i]
                    parent[s2], act[s2] = s, a
                    _enter(head, nxt, entries, counts, c + turn, s2)


def trace(act: np.ndarray, parent: np.ndarray, s0: int, s: int) -> list[int]:
    """The actions (``act`` of each state) along the ``parent`` links from state ``s0`` to
    state ``s``, in the order they are taken."""
    moves: list[int] = []
    while s != s0:
        moves.append(int(act[s]))
        s = int(parent[s])
    return moves[::-1]


class Lattice:
    """One search's state arrays (``size`` states) and constant parameters; :meth:`advance`
    runs it to the next candidates."""

    def __init__(self, *, size: int, nby: int, ok: np.ndarray, resolution: float,
                 bin_m: float, step_m: float, step_fractions: np.ndarray,
                 heading_vectors: np.ndarray, turn_deg: float, target: np.ndarray,
                 camera_height_m: float, reach_m: float, max_view_m: float,
                 half_fov_deg: float, move_cost: int, turn_cost: int, tilt_deg: int,
                 tilt_min_deg: int, tilt_max_deg: int, tilt_step_deg: int,
                 actions: tuple[int, int, int]) -> None:
        """``ok``: the occupancy table of the simulator's forward-move check, with a border
        for "outside the grid"; ``actions``: the ids of forward, left and right."""
        fp = np.zeros(11)
        fp[[P_STEP, P_BIN, P_RES, P_REACH, P_VIEW, P_HALF_FOV, P_TURN_DEG]] = (
            step_m, bin_m, resolution, reach_m, max_view_m, half_fov_deg, turn_deg)
        fp[[P_TX, P_TY, P_TZ, P_CAMERA]] = (*np.asarray(target, float), camera_height_m)
        ip = np.zeros(14, np.int64)
        ip[[I_NBY, I_SIZE, I_MOVE, I_TURN, I_TILT_MIN, I_TILT_MAX, I_TILT_STEP, I_TILT0,
            I_HI0, I_HI1, I_FORWARD, I_LEFT, I_RIGHT, I_HEADINGS]] = (
            nby, size, move_cost, turn_cost, tilt_min_deg, tilt_max_deg, tilt_step_deg,
            tilt_deg, ok.shape[0] - 1, ok.shape[1] - 1, *actions, len(heading_vectors))
        self._fp, self._ip = fp, ip
        self._ok = np.ascontiguousarray(ok, bool)
        self._dirs = np.ascontiguousarray(heading_vectors, float)
        self._fracs = np.ascontiguousarray(step_fractions, float)
        self.best = np.full(size, np.iinfo(np.int64).max, np.int64)
        self.px, self.py = np.zeros(size), np.zeros(size)
        self.parent = np.full(size, -1, np.int64)
        self.act = np.full(size, -1, np.int8)
        self._mark = np.zeros(size, np.int32)
        # buckets: a ring of list heads, one per cost (live costs span at most a move and a
        # turn), and the entries (each state makes 3 at most, and the start one)
        self._head = np.full(move_cost + turn_cost + 1, -1, np.int64)
        self._entries = (np.empty(3 * size + 1, np.int64), np.empty(3 * size + 1, np.int64))
        self._pending = (np.empty(size, np.int64), np.empty(size, np.int64),
                         np.empty(size), np.empty(size))
        self._found = np.empty(size, np.int64)
        self._scratch = (np.empty(size, np.int64), np.empty(size), np.empty(size))
        self._counts = np.zeros(6, np.int64)

    def start(self, x: float, y: float, heading: int) -> int:
        """Start the search at a pose; returns its state."""
        ip = self._ip
        s0 = int(state_of(x, y, heading, self._fp[P_BIN], ip[I_NBY], ip[I_HEADINGS]))
        self.best[s0], self.px[s0], self.py[s0] = 0, x, y
        _enter(self._head, *self._entries, self._counts, 0, s0)
        return s0

    def advance(self) -> np.ndarray:
        """The next candidates to confirm, (M, 3) rows of (total cost, state, tilt steps)
        in order; empty when the lattice is exhausted."""
        return advance(self.best, self.px, self.py, self.parent, self.act, self._mark,
                       self._head, *self._entries, *self._pending, self._found, *self._scratch,
                       self._counts, self._ok, self._dirs, self._fracs, self._fp, self._ip)
