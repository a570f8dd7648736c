"""The expert's search, compiled (Numba): A* over the agent's exact motion lattice, run until
the cheapest goal candidate is final.

Positions are not binned. A forward move adds 0.25 m along one of 12 headings, so every pose
the agent can reach lies at ``start + (a + b sqrt 3) / 8`` in x and ``(c + d sqrt 3) / 8`` in y
for integers a, b, c, d (cos and sin of multiples of 30 degrees are 0, +-1/2, +-sqrt(3)/2 and
+-1): two action sequences reach the same position exactly when they give the same four
integers, whatever their order. A state is those four integers and the heading
(:func:`pack`), kept in an open-addressing hash table; its float position is the one the
action simulator computes along the state's cheapest path (the same IEEE operations in the same
order: ``x + STEP * cos``, then the move's checks at ``x0 + f * (x1 - x0)``).

The search is A* with a consistent heuristic (the forward moves that the straight-line
distance to the success disk still needs, times the move's cost), so each state is expanded
once, at its optimal cost. A state within reach of the object whose view frustum can hold the
object at some tilt is a goal candidate, entered with a lower bound of its total (cost, the
tilt steps to the nearest tilt whose frustum holds the object, ``found``). A candidate is final
when no open state can lead to a cheaper one (its total is at most the lowest open cost plus
``found``); :meth:`Lattice.next_candidate` returns final candidates in total order, and the
caller (:mod:`fallgen.nav.expert`) confirms each with the renderer, or re-enters it with its
exact tilt cost, or drops it.

The arrays grow on demand: the compiled loop stops with :data:`GROW` when a table is nearly
full and :class:`Lattice` enlarges it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fallgen.vision.sight import hidden_from

#: Offset and span of each lattice coordinate in a packed key (|a|..|d| < 1024: 200 moves).
_OFF, _SPAN = 1024, 2048
#: Return codes of :func:`_run`.
FINAL, EXHAUSTED, GROW = 0, 1, 2
#: Tilt steps in a candidate key: offset and span.
_T_OFF, _T_SPAN = 32, 64
#: Candidate keys: total * _C_TOTAL + state * _T_SPAN + tilt steps + _T_OFF
_C_TOTAL = 1 << 37
#: Open keys: f * _O_F + state
_O_F = 1 << 31
#: Indices into the float parameters.
(P_STEP, P_RES, P_REACH, P_TX, P_TY, P_CAMERA, P_TURN_RAD, P_TAN, P_SLACK) = range(9)
#: Indices into the integer parameters.
(I_MOVE, I_TURN, I_TILT_COST, I_TILT0, I_TILT_MIN, I_TILT_MAX, I_TILT_STEP, I_HI0, I_HI1,
 I_FORWARD, I_LEFT, I_RIGHT, I_MAX_ACTIONS, I_HEADINGS) = range(14)
#: Counters: states, open heap size, candidate heap size, hash slots used.
C_STATES, C_OPEN, C_FOUND, C_USED = range(4)

#: The 12 headings' unit steps as lattice coordinates (a, b, c, d): 0.25 (cos, sin) of
#: 30 k degrees = ((a + b sqrt 3) / 8, (c + d sqrt 3) / 8).
LATTICE_STEPS = np.array([
    (2, 0, 0, 0), (0, 1, 1, 0), (1, 0, 0, 1), (0, 0, 2, 0), (-1, 0, 0, 1), (0, -1, 1, 0),
    (-2, 0, 0, 0), (0, -1, -1, 0), (-1, 0, 0, -1), (0, 0, -2, 0), (1, 0, 0, -1), (0, 1, -1, 0),
], np.int64)


@njit(cache=True)
def pack(a, b, c, d, heading, headings):
    """The hash key of lattice position (a, b, c, d) with ``heading``."""
    return (((((a + _OFF) * _SPAN + (b + _OFF)) * _SPAN + (c + _OFF)) * _SPAN + (d + _OFF))
            * headings + heading)


@njit(cache=True)
def position_key(a, b, c, d, headings):
    """The hash key that marks lattice position (a, b, c, d) as one from which the object
    cannot be seen (negative: apart from every state's key and from the empty slot, -1)."""
    return -(pack(a, b, c, d, 0, headings) + 2)


@njit(cache=True)
def free_at(ok, res, hi0, hi1, x, y):
    """The occupancy table ``ok`` (a border of "outside" around the grid) at (x, y)."""
    fi = min(max(np.floor(x / res), -1.0), hi0 - 1.0)
    fj = min(max(np.floor(y / res), -1.0), hi1 - 1.0)
    return ok[int(fi) + 1, int(fj) + 1]


@njit(cache=True)
def outside_view(corners, x, y, yaw, tilt_rad, camera, tan_half, slack):
    """Whether every point of ``corners`` (N, 3) is beyond one side of the view frustum of the
    camera at (x, y, ``camera``) looking along ``yaw`` and ``tilt_rad`` (a free camera: its
    right vector horizontal), the frustum's half-width ``tan_half`` with ``slack`` metres of
    margin: then no pixel of the view can show them."""
    ct, st = math.cos(tilt_rad), math.sin(tilt_rad)
    cy, sy = math.cos(yaw), math.sin(yaw)
    f0, f1, f2 = ct * cy, ct * sy, st
    r0, r1 = sy, -cy
    u0, u1, u2 = r1 * f2, -r0 * f2, r0 * f1 - r1 * f0
    behind = left = right = above = below = True
    for i in range(corners.shape[0]):
        dx, dy, dz = corners[i, 0] - x, corners[i, 1] - y, corners[i, 2] - camera
        vx = dx * r0 + dy * r1
        vy = dx * u0 + dy * u1 + dz * u2
        vz = dx * f0 + dy * f1 + dz * f2
        lim = tan_half * vz + slack
        behind = behind and vz < -slack
        right = right and vx > lim
        left = left and -vx > lim
        above = above and vy > lim
        below = below and -vy > lim
    return behind or left or right or above or below


@njit(cache=True)
def tilt_bound(corners, x, y, heading, fp, ip):
    """The fewest tilt steps from the start's tilt to a tilt whose frustum can hold the
    object from (x, y, ``heading``); -1 if none can."""
    best = -1
    t = ip[I_TILT_MIN]
    while t <= ip[I_TILT_MAX]:
        n = abs(t - ip[I_TILT0]) // ip[I_TILT_STEP]
        if best < 0 or n < best:
            if not outside_view(corners, x, y, heading * fp[P_TURN_RAD], math.radians(t),
                                fp[P_CAMERA], fp[P_TAN], fp[P_SLACK]):
                best = n
        t += ip[I_TILT_STEP]
    return best


@njit(cache=True)
def moves_to_reach(x, y, fp):
    """Forward moves that (x, y) needs at least to come within reach of the object: each
    move shortens the straight-line distance by at most a step."""
    d = math.hypot(fp[P_TX] - x, fp[P_TY] - y) - fp[P_REACH]
    if d <= 0.0:
        return 0
    return int(math.ceil(d / fp[P_STEP] - 1e-9))


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
def _slot(tab, key):
    """The hash slot of ``key``: where it is, or the empty slot where it would go."""
    mask = (len(tab) >> 1) - 1
    i = ((key * 0x5851F42D4C957F2D) >> 17) & mask
    while tab[2 * i] != -1 and tab[2 * i] != key:
        i = (i + 1) & mask
    return i


@njit(cache=True)
def rehash(tab, size):
    """A hash table of ``size`` slots holding the entries of ``tab``."""
    nt = np.full(2 * size, -1, np.int64)
    for i in range(len(tab) >> 1):
        if tab[2 * i] != -1:
            j = _slot(nt, tab[2 * i])
            nt[2 * j], nt[2 * j + 1] = tab[2 * i], tab[2 * i + 1]
    return nt


def position_table(n: int) -> np.ndarray:
    """An empty table with 2 ``n`` slots: each a key (-1: empty) and its value side by side
    (grown by :func:`rehash`)."""
    return np.full(4 * n, -1, np.int64)


@njit(cache=True)
def _enter_positions(tab, keys, vals):
    """Enter position verdicts (``keys`` from :func:`position_key`, ``vals`` -1 or -2) not in
    the table yet; how many were new."""
    new = 0
    for i in range(len(keys)):
        j = _slot(tab, keys[i])
        if tab[2 * j] != keys[i]:
            tab[2 * j], tab[2 * j + 1] = keys[i], vals[i]
            new += 1
    return new


@njit(cache=True)
def _run(g, px, py, par, act, nact, closed, coords, tab, oheap, fheap, counts, ok,
         dirs, fracs, steps, corners, fp, ip, sight):
    """Expand states until the cheapest candidate is final (FINAL: it is at the top of the
    candidate heap), the lattice is exhausted (EXHAUSTED) or a table needs room (GROW).
    ``sight``: the occlusion bound's arrays (:attr:`fallgen.vision.sight.Occluders.kernel`),
    or None: a position from which it proves the object hidden gives no candidate.

    The successors are offered in this loop, not by a helper that takes the state arrays: a
    compiled call counts a reference to each array it takes, in and out, an atomic operation
    each, and a helper of 17 arrays called three times a state was a quarter of a long
    search's time (helpers of one array, as the heap's and the table's, cost nothing
    measurable)."""
    move, turn, headings = ip[I_MOVE], ip[I_TURN], ip[I_HEADINGS]
    hi0, hi1, res = ip[I_HI0], ip[I_HI1], fp[P_RES]
    reach2 = fp[P_REACH] * fp[P_REACH] + 1e-9
    big = np.iinfo(np.int32).max
    while True:
        n_open = counts[C_OPEN]
        if counts[C_FOUND] > 0:
            top = fheap[0] // _C_TOTAL
            if n_open == 0 or top <= oheap[0] // _O_F + 1:
                return FINAL
        if n_open == 0:
            return EXHAUSTED
        if counts[C_STATES] + 3 > len(g) or 10 * (counts[C_USED] + 4) > 7 * (len(tab) >> 1) \
                or n_open + 3 > len(oheap) or counts[C_FOUND] + 1 > len(fheap):
            return GROW
        key, n_open = _pop(oheap, n_open)
        counts[C_OPEN] = n_open
        s = key % _O_F
        if closed[s] or key // _O_F != g[s] + move * moves_to_reach(px[s], py[s], fp):
            continue  # a stale entry: the state was reached more cheaply since
        closed[s] = True
        c, x0, y0 = g[s], px[s], py[s]
        k = coords[s, 4]
        # a goal candidate: within reach, and the object in a frustum at some tilt
        dx, dy = fp[P_TX] - x0, fp[P_TY] - y0
        seen = dx * dx + dy * dy <= reach2
        if seen:  # a position marked unseen (hval -1) gives no candidate; -2: may see
            pk = position_key(coords[s, 0], coords[s, 1], coords[s, 2], coords[s, 3], headings)
            j = _slot(tab, pk)
            if tab[2 * j] == pk:
                seen = tab[2 * j + 1] == -2
            elif sight is not None:
                seen = not hidden_from(x0, y0, fp[P_CAMERA], sight)
                tab[2 * j], tab[2 * j + 1] = pk, -2 if seen else -1
                counts[C_USED] += 1
        if seen:
            t = tilt_bound(corners, x0, y0, k, fp, ip)
            if t >= 0:
                total = c + t * ip[I_TILT_COST] + 1
                nf = _push(fheap, counts[C_FOUND], total * _C_TOTAL + s * _T_SPAN + t + _T_OFF)
                counts[C_FOUND] = nf
        if nact[s] + 2 > ip[I_MAX_ACTIONS]:  # no room left for another action and found
            continue
        # forward: the simulator's check along the move
        x1 = x0 + fp[P_STEP] * dirs[k, 0]
        y1 = y0 + fp[P_STEP] * dirs[k, 1]
        clear = True
        for f in fracs:
            if not free_at(ok, res, hi0, hi1, x0 + f * (x1 - x0), y0 + f * (y1 - y0)):
                clear = False
                break
        # the successors: forward (if clear), left, right
        for m in range(3):
            if m == 0:
                if not clear:
                    continue
                na, nb = coords[s, 0] + steps[k, 0], coords[s, 1] + steps[k, 1]
                nc, nd = coords[s, 2] + steps[k, 2], coords[s, 3] + steps[k, 3]
                nk, nx, ny, cost, action = k, x1, y1, c + move, ip[I_FORWARD]
            else:
                na, nb, nc, nd = coords[s, 0], coords[s, 1], coords[s, 2], coords[s, 3]
                nk = (k + 1) % headings if m == 1 else (k + headings - 1) % headings
                nx, ny, cost = x0, y0, c + turn
                action = ip[I_LEFT] if m == 1 else ip[I_RIGHT]
            skey = pack(na, nb, nc, nd, nk, headings)
            j = _slot(tab, skey)
            if tab[2 * j] == -1:
                s2 = counts[C_STATES]
                counts[C_STATES] = s2 + 1
                tab[2 * j], tab[2 * j + 1] = skey, s2
                counts[C_USED] += 1
                g[s2] = big
                closed[s2] = False
                coords[s2, 0], coords[s2, 1], coords[s2, 2], coords[s2, 3] = na, nb, nc, nd
                coords[s2, 4] = nk
            else:
                s2 = tab[2 * j + 1]
            if closed[s2] or g[s2] <= cost:
                continue
            g[s2], px[s2], py[s2], par[s2], act[s2] = cost, nx, ny, s, action
            nact[s2] = nact[s] + 1
            nkey = (cost + move * moves_to_reach(nx, ny, fp)) * _O_F + s2
            counts[C_OPEN] = _push(oheap, counts[C_OPEN], nkey)


def _doubled(a: np.ndarray, used: int) -> np.ndarray:
    """``a`` with twice the rows, its first ``used`` rows copied and the rest left
    unwritten (``np.resize`` would fill them, making every page of the new array resident at
    once beside the old one)."""
    out = np.empty((2 * len(a), *a.shape[1:]), a.dtype)
    out[:used] = a[:used]
    return out


class LatticeFull(RuntimeError):
    """The search needs more states than it is allowed."""


def trace(act: np.ndarray, parent: np.ndarray, s: int) -> list[int]:
    """The actions (``act`` of each state) along the ``parent`` links from the start (state
    0) to state ``s``, in the order they are taken."""
    moves: list[int] = []
    while s != 0:
        moves.append(int(act[s]))
        s = int(parent[s])
    return moves[::-1]


class Lattice:
    """One A* search over the exact motion lattice from a start pose, with its cost per
    forward move, turn and tilt step (``found`` costs 1).

    ``ok``: the occupancy table of the simulator's forward-move check, with a border for
    "outside the grid"; ``corners``: points (N, 3) that bound the object (its geoms' boxes'
    corners) for the frustum test; ``actions``: the ids of forward, left and right."""

    def __init__(self, *, ok: np.ndarray, resolution: float, step_m: float,
                 step_fractions: np.ndarray, heading_vectors: np.ndarray, turn_deg: float,
                 target_xy, corners: np.ndarray, camera_height_m: float, reach_m: float,
                 half_fov_deg: float, move_cost: int, turn_cost: int, tilt_cost: int,
                 tilt_deg: int, tilt_min_deg: int, tilt_max_deg: int, tilt_step_deg: int,
                 actions: tuple[int, int, int], max_actions: int,
                 capacity: int = 1 << 14, sight: tuple | None = None) -> None:
        fp = np.zeros(9)
        # the frustum test's margins: 5 % wider than the image, 2 cm (as the camera's own)
        fp[[P_STEP, P_RES, P_REACH, P_TX, P_TY, P_CAMERA, P_TURN_RAD, P_TAN, P_SLACK]] = (
            step_m, resolution, reach_m, float(target_xy[0]), float(target_xy[1]),
            camera_height_m, math.radians(turn_deg),
            math.tan(math.radians(half_fov_deg)) * 1.05, 0.02)
        ip = np.zeros(14, np.int64)
        ip[[I_MOVE, I_TURN, I_TILT_COST, I_TILT0, I_TILT_MIN, I_TILT_MAX, I_TILT_STEP, I_HI0,
            I_HI1, I_FORWARD, I_LEFT, I_RIGHT, I_MAX_ACTIONS, I_HEADINGS]] = (
            move_cost, turn_cost, tilt_cost, tilt_deg, tilt_min_deg, tilt_max_deg,
            tilt_step_deg, ok.shape[0] - 1, ok.shape[1] - 1, *actions, max_actions,
            len(heading_vectors))
        if len(heading_vectors) != len(LATTICE_STEPS):
            raise ValueError("the exact lattice is made for 12 headings")
        self._fp, self._ip = fp, ip
        self._sight = sight  # the occlusion bound's arrays (vision.sight.Occluders.kernel)
        self._ok = np.ascontiguousarray(ok, bool)
        self._dirs = np.ascontiguousarray(heading_vectors, float)
        self._fracs = np.ascontiguousarray(step_fractions, float)
        self._corners = np.ascontiguousarray(corners, float).reshape(-1, 3)
        self._counts = np.zeros(4, np.int64)
        n = int(capacity)
        # per state: its cost (int32: at most MAX_ACTIONS actions of small integer costs) and
        # lattice coordinates (int16: at most MAX_ACTIONS steps from the start), 128 bytes
        # with the tables below (2 million states are ~260 MB)
        self.g = np.empty(n, np.int32)
        self.px, self.py = np.empty(n), np.empty(n)
        self.parent = np.empty(n, np.int32)
        self.act = np.empty(n, np.int8)
        self._nact = np.empty(n, np.int32)
        self._closed = np.empty(n, np.bool_)
        self.coords = np.empty((n, 5), np.int16)
        # the hash table (open addressing, linear probing) at most 70 % full, each slot's key
        # and value side by side (a probe reads one cache line, not one in each of two arrays:
        # 7 % less time a state on searches of 700 000 states)
        self._tab = position_table(n)
        self._open = np.empty(3 * n + 1, np.int64)
        self._found = np.empty(n, np.int64)

    @property
    def states(self) -> int:
        """States entered so far."""
        return int(self._counts[C_STATES])

    def start(self, x: float, y: float, heading: int) -> None:
        """Start the search at a pose (state 0)."""
        c = self._counts
        key = int(pack(0, 0, 0, 0, heading, int(self._ip[I_HEADINGS])))
        j = int(_slot(self._tab, key))
        self._tab[2 * j], self._tab[2 * j + 1] = key, 0
        c[C_STATES], c[C_USED] = 1, 1
        self.g[0], self.px[0], self.py[0], self.parent[0], self.act[0] = 0, x, y, -1, -1
        self._nact[0], self._closed[0] = 0, False
        self.coords[0] = (0, 0, 0, 0, heading)
        f = int(self._ip[I_MOVE]) * int(moves_to_reach(x, y, self._fp))
        c[C_OPEN] = _push(self._open, 0, f * _O_F)

    def _grow(self) -> None:
        n = len(self.g)
        if self._counts[C_STATES] + 3 > n:
            for name in ("g", "px", "py", "parent", "act", "_nact", "_closed", "coords"):
                setattr(self, name, _doubled(getattr(self, name), n))
        if 10 * (self._counts[C_USED] + 4) > 7 * self._slots:
            self._tab = rehash(self._tab, 2 * self._slots)
        if self._counts[C_OPEN] + 3 > len(self._open):
            self._open = _doubled(self._open, int(self._counts[C_OPEN]))
        if self._counts[C_FOUND] + 1 > len(self._found):
            self._found = _doubled(self._found, int(self._counts[C_FOUND]))

    def next_candidate(self, max_states: int) -> tuple[int, int, int] | None:
        """The cheapest final candidate, taken out: (lower bound of its total, state, tilt
        steps bound), or None when the lattice holds no more; :class:`LatticeFull` once it
        would need more than ``max_states`` states."""
        while True:
            code = _run(self.g, self.px, self.py, self.parent, self.act, self._nact,
                        self._closed, self.coords, self._tab, self._open,
                        self._found, self._counts, self._ok, self._dirs, self._fracs,
                        LATTICE_STEPS, self._corners, self._fp, self._ip, self._sight)
            if code == GROW:
                if self.states + 3 > max_states:
                    raise LatticeFull(f"more than {max_states} lattice states")
                self._grow()
                continue
            if code == EXHAUSTED:
                return None
            key, self._counts[C_FOUND] = _pop(self._found, int(self._counts[C_FOUND]))
            key = int(key)
            return (key // _C_TOTAL, (key % _C_TOTAL) // _T_SPAN, key % _T_SPAN - _T_OFF)

    def offer(self, total: int, state: int, tilt_steps: int) -> None:
        """Enter a candidate again, with a higher total (its exact tilt cost)."""
        if self._counts[C_FOUND] + 1 > len(self._found):
            self._found = _doubled(self._found, int(self._counts[C_FOUND]))
        self._counts[C_FOUND] = _push(self._found, int(self._counts[C_FOUND]),
                                      total * _C_TOTAL + state * _T_SPAN + tilt_steps + _T_OFF)

    def mark_unseen(self, state: int) -> None:
        """The object cannot be seen from ``state``'s position (any heading, any tilt): the
        position's other states are no candidates."""
        if 10 * (self._counts[C_USED] + 1) > 7 * self._slots:
            self._tab = rehash(self._tab, 2 * self._slots)
        a, b, c, d = self.coords[state, :4].tolist()
        key = int(position_key(a, b, c, d, int(self._ip[I_HEADINGS])))
        j = int(_slot(self._tab, key))
        if self._tab[2 * j] != key:
            self._counts[C_USED] += 1
        self._tab[2 * j], self._tab[2 * j + 1] = key, -1

    def position_verdicts(self) -> tuple[np.ndarray, np.ndarray]:
        """The positions this search has judged (keys, and -1: the object hidden from there,
        -2: it may be seen): for another search from the same start, whose lattice keys the
        same positions alike (:meth:`know_positions`)."""
        keys, vals = self._tab[0::2], self._tab[1::2]
        m = keys < -1
        return keys[m].copy(), vals[m].astype(np.int32)

    def know_positions(self, keys: np.ndarray, vals: np.ndarray) -> None:
        """Take the position verdicts of an earlier search from the same start pose
        (:meth:`position_verdicts`): its occlusion proofs are not made again."""
        need = int(self._counts[C_USED]) + len(keys) + 4
        size = self._slots
        while 10 * need > 7 * size:
            size *= 2
        if size != self._slots:
            self._tab = rehash(self._tab, size)
        self._counts[C_USED] += _enter_positions(self._tab,
                                                 np.asarray(keys, np.int64),
                                                 np.asarray(vals, np.int32))

    @property
    def _slots(self) -> int:
        """Slots of the hash table."""
        return len(self._tab) >> 1

    def heading(self, state: int) -> int:
        return int(self.coords[state, 4])
