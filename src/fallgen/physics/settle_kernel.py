"""The compiled settle loop of a recorded fall: :func:`settle_steps` runs
:func:`fallgen.physics.settle.simulate_until_settled`'s loop (chunks of steps, then the checks
between them) for a :class:`~fallgen.physics.contacts.ContactRecorder`, with
:func:`fallgen.physics.contact_kernel.run` making the steps.

The checks are those of the Python loop, with the same IEEE operations in the same order
(Numba contracts no multiply-adds; ``max``, ``min`` and ``min(1.0, dot)`` written out as Python
evaluates them): a fall settles, gives up or goes unstable at the same step, with the same
result, whichever loop runs it (``tests/physics/test_settle_kernel.py``). Between two chunks the
Python loop's interpreter work was ~26 us (1.9 s over the 72 374 chunks of 824 rehearsal
trials, ~10 % of their time); with this loop the trials took 8 % less time.

State lives in arrays the caller owns, so that a call that stops because the recorder's event
arrays are full (:data:`GROW`) resumes where it stopped once they have grown.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fallgen.physics.contact_kernel import run

#: Return codes of :func:`settle_steps`.
DONE, GROW = 0, 1
# -- float parameters
SP_LIN, SP_ANG, SP_POSE_M, SP_POSE_RAD, SP_DT, SP_MASS, SP_I0, SP_I1, SP_I2, SP_G, \
    SP_FLOOR = range(11)
N_SP = 11
# -- int state: the loop's counters and flags
SS_STEPS, SS_MAX, SS_CHUNK, SS_HOLD, SS_WINDOW, SS_EVERY, SS_CALM, SS_PENDING, SS_N, \
    SS_POSES, SS_HEAD, SS_REPLAY, SS_BOUND, SS_UNSTABLE, SS_GAVE_UP, SS_SETTLED = range(16)
N_SS = 16
# -- float state
SF_SETTLED_AT, SF_MAX_SPEED, SF_MIN_Z = range(3)
N_SF = 3


def state(max_steps: int, chunk: int, hold: int, window: int, every: int, replay: bool,
          bound: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fresh (int state, float state, pose ring) for :func:`settle_steps`."""
    ss = np.zeros(N_SS, np.int64)
    ss[[SS_MAX, SS_CHUNK, SS_HOLD, SS_WINDOW, SS_EVERY, SS_REPLAY, SS_BOUND]] = (
        max_steps, chunk, hold, window, every, int(replay), int(bound))
    sf = np.array([0.0, 0.0, np.inf])
    return ss, sf, np.zeros((window + 1, 7))


@njit(cache=True)
def below_for_good(z, v0, v1, v2, w0, w1, w2, mass, i0, i1, i2, g, floor_z):
    """Whether a body at height ``z`` (its centre of mass) moving at (v0, v1, v2) and spinning
    at (w0, w1, w2) (body frame; ``i0``..``i2`` its principal moments) can no longer bring its
    centre up to ``floor_z``: the rise all its kinetic energy could buy, with 50 % and 2 cm to
    spare (:class:`fallgen.physics.settle.EnergyFloor`)."""
    energy = 0.5 * mass * (v0 * v0 + v1 * v1 + v2 * v2) + 0.5 * (
        i0 * (w0 * w0) + i1 * (w1 * w1) + i2 * (w2 * w2))
    return z + 1.5 * energy / (mass * g) + 0.02 < floor_z


@njit(cache=True)
def _still(poses, count, head, tol_m, tol_rad):
    """Every pose of the ring (``count`` of them, the oldest at ``head``) within tolerance of
    the oldest (:func:`fallgen.physics.settle._still`)."""
    size = poses.shape[0]
    p00, p01, p02 = poses[head, 0], poses[head, 1], poses[head, 2]
    q00, q01, q02, q03 = poses[head, 3], poses[head, 4], poses[head, 5], poses[head, 6]
    for k in range(count):
        i = (head + k) % size
        d0 = poses[i, 0] - p00
        d1 = poses[i, 1] - p01
        d2 = poses[i, 2] - p02
        if d0 * d0 + d1 * d1 + d2 * d2 > tol_m * tol_m:
            return False
        dot = abs(poses[i, 3] * q00 + poses[i, 4] * q01 + poses[i, 5] * q02 + poses[i, 6] * q03)
        c = dot if dot < 1.0 else 1.0  # min(1.0, dot)
        if 2.0 * math.acos(c) > tol_rad:
            return False
    return True


@njit(cache=True)
def settle_steps(step_fn, m_addr, d_addr, body, bodyid, friction, pyramidal, lay, qvel, xmat,
                 xpos, qpos, P, st, sw, ei, ef, vf, vi, order, rank, pose, warn, watched,
                 xipos, sp, ss, sf, poses):
    """Step and check until the body settles (unless replaying), gives up, goes unstable or
    runs its steps (DONE), or the recorder's arrays need room (GROW: call again once grown).
    ``pose``: the body's 7 qpos; ``warn``: mjData's warning counts, ``watched`` the ones that
    mean an untrustworthy run; ``xipos``: the body's centre of mass (the give-up bound's)."""
    every = ss[SS_EVERY]
    size = poses.shape[0]
    while ss[SS_STEPS] < ss[SS_MAX]:
        if ss[SS_PENDING] == 0:  # a new chunk
            n = ss[SS_CHUNK]
            left = ss[SS_MAX] - ss[SS_STEPS]
            ss[SS_N] = n if n < left else left
            ss[SS_PENDING] = ss[SS_N]
        ss[SS_PENDING] -= run(step_fn, m_addr, d_addr, ss[SS_PENDING], body, bodyid, friction,
                              pyramidal, lay, qvel, xmat, xpos, qpos, P, st, sw, ei, ef, vf, vi,
                              order, rank)
        if ss[SS_PENDING] > 0:
            return GROW
        n = ss[SS_N]
        ss[SS_STEPS] += n
        steps = ss[SS_STEPS]
        v0, v1, v2, v3, v4, v5 = qvel[0], qvel[1], qvel[2], qvel[3], qvel[4], qvel[5]
        z = pose[2]
        finite = (math.isfinite(v0) and math.isfinite(v1) and math.isfinite(v2)
                  and math.isfinite(v3) and math.isfinite(v4) and math.isfinite(v5)
                  and math.isfinite(z))
        warned = False
        if steps % 50 == 0 or steps >= ss[SS_MAX] or n > 1:
            for i in watched:
                if warn[i] != 0:
                    warned = True
        if not finite or warned:
            ss[SS_UNSTABLE] = 1
            return DONE
        lin = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        ang = math.sqrt(v3 * v3 + v4 * v4 + v5 * v5)
        if lin > sf[SF_MAX_SPEED]:  # max(max_speed, lin)
            sf[SF_MAX_SPEED] = lin
        if z < sf[SF_MIN_Z]:  # min(min_z, z)
            sf[SF_MIN_Z] = z
        if lin < sp[SP_LIN] and ang < sp[SP_ANG]:
            ss[SS_CALM] += 1
        else:
            ss[SS_CALM] = 0
        sampled = steps % every == 0
        if sampled:  # the ring keeps the last window + 1 poses, the oldest at its head
            if ss[SS_POSES] < size:
                i = (ss[SS_HEAD] + ss[SS_POSES]) % size
                ss[SS_POSES] += 1
            else:
                i = ss[SS_HEAD]
                ss[SS_HEAD] = (ss[SS_HEAD] + 1) % size
            for j in range(7):
                poses[i, j] = pose[j]
        if sampled and ss[SS_BOUND] == 1 and ss[SS_REPLAY] == 0:
            if below_for_good(xipos[2], v0, v1, v2, v3, v4, v5, sp[SP_MASS], sp[SP_I0],
                              sp[SP_I1], sp[SP_I2], sp[SP_G], sp[SP_FLOOR]):
                ss[SS_GAVE_UP] = 1
                return DONE
        if ss[SS_SETTLED] == 0:
            if ss[SS_CALM] >= ss[SS_HOLD]:
                ss[SS_SETTLED] = 1
                sf[SF_SETTLED_AT] = (steps - ss[SS_HOLD] * n) * sp[SP_DT]
            elif sampled and ss[SS_POSES] == size and _still(
                    poses, size, ss[SS_HEAD], sp[SP_POSE_M], sp[SP_POSE_RAD]):
                ss[SS_SETTLED] = 1
                sf[SF_SETTLED_AT] = (steps - ss[SS_WINDOW] * every) * sp[SP_DT]
            if ss[SS_SETTLED] == 1 and ss[SS_REPLAY] == 0:
                return DONE
    return DONE


__all__ = ["DONE", "GROW", "below_for_good", "settle_steps", "state"]
