"""Step a MuJoCo scene until one free body settles, watching for instabilities.

Settled means: linear speed below ``lin_tol`` and angular speed below ``ang_tol`` continuously
for ``hold_s``; or, for a body that keeps jittering in place (a thin key rocking on a counter at
0.01-0.2 rad/s in a discrete-time limit cycle of its soft contacts), a pose that has not moved by
more than ``pose_tol_m`` / ``pose_tol_rad`` over the last ``pose_window_s``. MuJoCo silently resets a simulation whose accelerations go bad, so the warning
counters (``mjWARN_BADQACC`` and friends) are checked as well as the state staying finite.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from fallgen.physics.mjraw import timers_off
from fallgen.physics.settle_kernel import below_for_good


@dataclass(frozen=True)
class SettleCriteria:
    lin_tol_mps: float = 0.01
    ang_tol_radps: float = 0.1
    hold_s: float = 0.25
    timeout_s: float = 6.0
    pose_window_s: float = 0.5
    pose_tol_m: float = 0.001
    pose_tol_rad: float = 0.0175  # 1 degree


@dataclass(frozen=True)
class SettleResult:
    settled: bool
    time_s: float  # when the body first met the criteria for the hold time (or the timeout)
    pos: np.ndarray  # (3,) final body position
    quat: np.ndarray  # (4,) final body orientation (w, x, y, z)
    max_speed_mps: float  # largest linear speed seen
    min_z_m: float  # lowest body-origin height seen
    unstable: bool  # NaN/inf state or a MuJoCo warning
    warnings: dict[str, int]
    steps: int = 0  # steps simulated
    # the body origin's lowest and highest x, y over the start and the states checked (every
    # step when recorded): with the body's bounding radius, the area the fall swept
    xy_min: tuple[float, float] = (math.inf, math.inf)
    xy_max: tuple[float, float] = (-math.inf, -math.inf)
    gave_up: bool = False  # stopped early because ``give_up`` said the trial was lost


_WATCHED = ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_CONTACTFULL",
            "mjWARN_CNSTRFULL")
_WATCHED_IDS = [int(getattr(mujoco.mjtWarning, name)) for name in _WATCHED]


def mujoco_warnings(data: mujoco.MjData) -> dict[str, int]:
    """Counts of the MuJoCo warnings that mean a simulation cannot be trusted."""
    counts = data.warning.number
    return {name: int(counts[i]) for name, i in zip(_WATCHED, _WATCHED_IDS) if counts[i]}


#: Pose sampling period of the "still in place" test (steps).
POSE_EVERY_STEPS = 10


@dataclass(frozen=True)
class EnergyFloor:
    """``give_up(data)`` of a fall into a zone whose floor is at ``floor_z``: whether the body
    (the only moving one; ``vadr`` its free joint's first dof) can no longer bring its centre of
    mass up to ``floor_z``: its height plus the rise all its kinetic energy (translation and
    rotation, ``inertia`` its principal moments) could buy, with 50 % and 2 cm to spare for the
    energy MuJoCo's soft contacts can return, is below it. A trial whose object fell off a
    table is then stopped when it lands, instead of rolling on the floor until it rests or times
    out (:func:`fallgen.physics.settle_kernel.below_for_good`, which the compiled settle loop
    calls too)."""

    body: int
    vadr: int
    mass: float
    inertia: tuple[float, float, float]
    g: float
    floor_z: float

    def __call__(self, d: mujoco.MjData) -> bool:
        v0, v1, v2, w0, w1, w2 = d.qvel[self.vadr:self.vadr + 6].tolist()  # w: body frame
        return bool(below_for_good(float(d.xipos[self.body, 2]), v0, v1, v2, w0, w1, w2,
                                   self.mass, *self.inertia, self.g, self.floor_z))


def _still(poses: deque, c: SettleCriteria) -> bool:
    """Every pose of the window within tolerance of the first."""
    p0, q0 = poses[0]
    for p, q in poses:
        d0, d1, d2 = p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]
        if d0 * d0 + d1 * d1 + d2 * d2 > c.pose_tol_m * c.pose_tol_m:
            return False
        dot = abs(q[0] * q0[0] + q[1] * q0[1] + q[2] * q0[2] + q[3] * q0[3])
        if 2.0 * math.acos(min(1.0, dot)) > c.pose_tol_rad:
            return False
    return True


def simulate_until_settled(model: mujoco.MjModel, data: mujoco.MjData, body_id: int,
                           criteria: SettleCriteria = SettleCriteria(),
                           recorder=None, max_steps: int | None = None,
                           chunk: int = 1,
                           give_up: Callable[[mujoco.MjData], bool] | None = None
                           ) -> SettleResult:
    """Step ``data`` until body ``body_id`` (with a free joint) settles or times out.

    ``chunk`` steps run in C between checks (the settle test, NaN and warnings are then checked
    every ``chunk`` steps; the trajectory is the same as stepping one by one). A ``recorder``
    (:class:`~fallgen.physics.contacts.ContactRecorder`) makes the steps and records every one
    of them; the sweep (``xy_min``, ``xy_max``) is then that of every step, else that of the
    states checked. ``max_steps`` replays exactly that many steps (the settle test still runs
    but does not stop the loop). ``give_up(data)``, asked at every pose sample of a run that is
    not a replay, stops a trial that can no longer be kept (``gave_up``; not settled).
    """
    timers_off()
    jnt = model.body_jntadr[body_id]
    qadr, vadr = model.jnt_qposadr[jnt], model.jnt_dofadr[jnt]
    dt = model.opt.timestep
    hold = max(1, int(math.ceil(criteria.hold_s / (dt * chunk))))
    replay = max_steps is not None
    if max_steps is None:
        max_steps = int(round(criteria.timeout_s / dt))
    # Poses are sampled every POSE_EVERY_STEPS steps whatever the chunk, so that runs in
    # different chunks reach the same "still in place" verdict at the same step.
    window = max(1, int(math.ceil(criteria.pose_window_s / (dt * POSE_EVERY_STEPS))))
    if recorder is not None and (give_up is None or isinstance(give_up, EnergyFloor)):
        # the same loop, compiled (fallgen.physics.settle_kernel)
        steps, unstable, gave_up, settled_at, max_speed, min_z = recorder.settle(
            data, qadr, max_steps, chunk, hold, window, POSE_EVERY_STEPS, replay, criteria,
            give_up, _WATCHED_IDS)
    else:
        steps, unstable, gave_up, settled_at, max_speed, min_z, sweep = _loop(
            model, data, qadr, vadr, max_steps, chunk, hold, window, replay, criteria, recorder,
            give_up)
        (x_lo, y_lo), (x_hi, y_hi) = sweep
    if recorder is not None:
        (x_lo, y_lo), (x_hi, y_hi) = recorder.sweep
    return SettleResult(
        settled=settled_at is not None and not unstable and not gave_up,
        time_s=settled_at if settled_at is not None else data.time,
        pos=data.qpos[qadr:qadr + 3].copy(),
        quat=data.qpos[qadr + 3:qadr + 7].copy(),
        max_speed_mps=max_speed,
        min_z_m=min_z,
        unstable=unstable,
        warnings=mujoco_warnings(data),
        steps=steps,
        xy_min=(x_lo, y_lo),
        xy_max=(x_hi, y_hi),
        gave_up=gave_up,
    )


def _loop(model: mujoco.MjModel, data: mujoco.MjData, qadr: int, vadr: int, max_steps: int,
          chunk: int, hold: int, window: int, replay: bool, criteria: SettleCriteria,
          recorder, give_up: Callable[[mujoco.MjData], bool] | None) -> tuple:
    """:func:`simulate_until_settled`'s loop in Python, for any ``give_up`` (and without a
    recorder): (steps, unstable, gave_up, settled_at or None, max speed, lowest z, the sweep
    of the states checked)."""
    dt = model.opt.timestep
    calm, settled_at, gave_up = 0, None, False
    max_speed, min_z, unstable = 0.0, np.inf, False
    x_lo = x_hi = float(data.qpos[qadr])
    y_lo = y_hi = float(data.qpos[qadr + 1])
    steps = 0
    poses: deque = deque(maxlen=window + 1)
    # views into data, read as Python floats after every step or chunk (NumPy scalar
    # arithmetic would cost more than the check itself; the same IEEE operations)
    qvel, qpos = data.qvel[vadr:vadr + 6], data.qpos[qadr:qadr + 7]
    warned, watched = data.warning.number, _WATCHED_IDS
    isfinite, sqrt = math.isfinite, math.sqrt
    while steps < max_steps:
        n = min(chunk, max_steps - steps)
        if recorder is not None:
            recorder.step(data, n)
        else:
            mujoco.mj_step(model, data, nstep=n)
        steps += n
        v0, v1, v2, v3, v4, v5 = qvel.tolist()
        q = qpos.tolist()
        x, y, z = q[0], q[1], q[2]
        if not (isfinite(v0) and isfinite(v1) and isfinite(v2) and isfinite(v3)
                and isfinite(v4) and isfinite(v5) and isfinite(z)) or (
                steps % 50 == 0 or steps >= max_steps or n > 1) and warned[watched].any():
            unstable = True
            break
        lin, ang = sqrt(v0 * v0 + v1 * v1 + v2 * v2), sqrt(v3 * v3 + v4 * v4 + v5 * v5)
        max_speed, min_z = max(max_speed, lin), min(min_z, z)
        x_lo, x_hi, y_lo, y_hi = min(x_lo, x), max(x_hi, x), min(y_lo, y), max(y_hi, y)
        calm = calm + 1 if (lin < criteria.lin_tol_mps and ang < criteria.ang_tol_radps) else 0
        sampled = steps % POSE_EVERY_STEPS == 0
        if sampled:
            poses.append((q[:3], q[3:]))
        if sampled and give_up is not None and not replay and give_up(data):
            gave_up = True
            break
        if settled_at is None:
            if calm >= hold:
                settled_at = (steps - hold * n) * dt
            elif sampled and len(poses) == window + 1 and _still(poses, criteria):
                settled_at = (steps - window * POSE_EVERY_STEPS) * dt
            if settled_at is not None and not replay:
                break
    return (steps, unstable, gave_up, settled_at, max_speed, min_z,
            ((x_lo, y_lo), (x_hi, y_hi)))
