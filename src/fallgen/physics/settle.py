"""Step a MuJoCo scene until one free body settles, watching for instabilities.

Settled means: linear speed below ``lin_tol`` and angular speed below ``ang_tol`` continuously
for ``hold_s``. MuJoCo silently resets a simulation whose accelerations go bad, so the warning
counters (``mjWARN_BADQACC`` and friends) are checked as well as the state staying finite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class SettleCriteria:
    lin_tol_mps: float = 0.01
    ang_tol_radps: float = 0.1
    hold_s: float = 0.25
    timeout_s: float = 6.0


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


_WATCHED = ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_CONTACTFULL",
            "mjWARN_CNSTRFULL")


def mujoco_warnings(data: mujoco.MjData) -> dict[str, int]:
    """Counts of the MuJoCo warnings that mean a simulation cannot be trusted."""
    out = {}
    for name in _WATCHED:
        n = int(data.warning[int(getattr(mujoco.mjtWarning, name))].number)
        if n:
            out[name] = n
    return out


def simulate_until_settled(model: mujoco.MjModel, data: mujoco.MjData, body_id: int,
                           criteria: SettleCriteria = SettleCriteria(),
                           recorder=None, max_steps: int | None = None,
                           chunk: int = 1) -> SettleResult:
    """Step ``data`` until body ``body_id`` (with a free joint) settles or times out.

    ``recorder`` (e.g. a :class:`~fallgen.physics.contacts.ContactRecorder`) gets
    ``before_step``/``after_step`` around every step. ``max_steps`` replays exactly that many
    steps (the settle test still runs but does not stop the loop). Without a recorder, ``chunk``
    steps run in C between checks (the settle test, NaN and warnings are then checked every
    ``chunk`` steps; the trajectory is the same as stepping one by one).
    """
    jnt = model.body_jntadr[body_id]
    qadr, vadr = model.jnt_qposadr[jnt], model.jnt_dofadr[jnt]
    dt = model.opt.timestep
    if recorder is not None:
        chunk = 1
    hold = max(1, int(math.ceil(criteria.hold_s / (dt * chunk))))
    replay = max_steps is not None
    if max_steps is None:
        max_steps = int(round(criteria.timeout_s / dt))
    calm, settled_at = 0, None
    max_speed, min_z, unstable = 0.0, np.inf, False
    steps = 0
    while steps < max_steps:
        n = min(chunk, max_steps - steps)
        if recorder is not None:
            recorder.before_step(data)
            mujoco.mj_step(model, data)
            recorder.after_step(data)
        else:
            mujoco.mj_step(model, data, nstep=n)
        steps += n
        v = data.qvel[vadr:vadr + 6]
        z = data.qpos[qadr + 2]
        if not (np.isfinite(v).all() and np.isfinite(z)) or (
                steps % 50 == 0 or steps >= max_steps or n > 1) and mujoco_warnings(data):
            unstable = True
            break
        lin, ang = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2), \
            math.sqrt(v[3] ** 2 + v[4] ** 2 + v[5] ** 2)
        max_speed, min_z = max(max_speed, lin), min(min_z, float(z))
        calm = calm + 1 if (lin < criteria.lin_tol_mps and ang < criteria.ang_tol_radps) else 0
        if calm >= hold and settled_at is None:
            settled_at = (steps - hold * n) * dt
            if not replay:
                break
    return SettleResult(
        settled=settled_at is not None and not unstable,
        time_s=settled_at if settled_at is not None else data.time,
        pos=data.qpos[qadr:qadr + 3].copy(),
        quat=data.qpos[qadr + 3:qadr + 7].copy(),
        max_speed_mps=max_speed,
        min_z_m=min_z,
        unstable=unstable,
        warnings=mujoco_warnings(data),
        steps=steps,
    )
