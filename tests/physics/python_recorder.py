"""The contact recorder as it was written in Python (called around every ``mj_step``), kept as
the reference the compiled recorder (:mod:`fallgen.physics.contact_kernel`) must match event
for event and bit for bit."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from fallgen.physics.contacts import KINDS, ContactEvent, ContactParams

Vec = tuple[float, float, float]


def _sub(a, b) -> Vec:
    return a[0] - b[0], a[1] - b[1], a[2] - b[2]


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _point_velocity(v, w, x, p) -> Vec:
    """Velocity of the point ``p`` of a body whose origin ``x`` moves at ``v`` and which turns
    at ``w`` (world frame): v + w x (p - x)."""
    r0, r1, r2 = p[0] - x[0], p[1] - x[1], p[2] - x[2]
    return (v[0] + (w[1] * r2 - w[2] * r1), v[1] + (w[2] * r0 - w[0] * r2),
            v[2] + (w[0] * r1 - w[1] * r0))


def _body_frame(mat, x, p) -> Vec:
    """The world point ``p`` in the frame of a body at ``x`` with rotation ``mat`` (row-major
    3x3 as a flat sequence): mat^T (p - x)."""
    r0, r1, r2 = p[0] - x[0], p[1] - x[1], p[2] - x[2]
    return (mat[0] * r0 + mat[3] * r1 + mat[6] * r2, mat[1] * r0 + mat[4] * r1 + mat[7] * r2,
            mat[2] * r0 + mat[5] * r1 + mat[8] * r2)


def _kinematics(qvel, mat) -> tuple[Vec, Vec]:
    """(linear, angular) world velocity of a free body from its 6 joint velocities (the
    angular part in the body frame) and its rotation (row-major 3x3, flat)."""
    w0, w1, w2 = qvel[3], qvel[4], qvel[5]
    return (qvel[0], qvel[1], qvel[2]), (mat[0] * w0 + mat[1] * w1 + mat[2] * w2,
                                         mat[3] * w0 + mat[4] * w1 + mat[5] * w2,
                                         mat[6] * w0 + mat[7] * w1 + mat[8] * w2)



@dataclass
class _Episode:
    start_step: int
    geom_object: int
    point_world: Vec
    point_object: Vec
    normal: Vec
    approach_mps: float
    impulse: float = 0.0
    compressing: bool = True
    compression_steps: int = 0
    vn_last: float = 0.0  # normal velocity of the contact point after the previous step
    hop: bool = False  # a re-contact of a slide (see ContactParams), not an impact
    last_seen: int = 0
    # sustained-contact sample accumulators
    s_steps: int = 0
    s_force: float = 0.0
    s_slip: float = 0.0
    s_normal_speed: float = 0.0
    s_start_point: Vec | None = None
    s_start_step: int = 0
    s_point: Vec | None = None
    s_point_object: Vec | None = None
    events: list[ContactEvent] = field(default_factory=list)


class PythonRecorder:
    """Call :meth:`before_step` and :meth:`after_step` around every ``mj_step`` (of one
    ``MjData``).

    This runs at every step of every recorded fall, so it works on Python floats (NumPy calls
    on 3-vectors cost a microsecond each): a step without contact costs the read of the
    body's state before it, one with contact a few microseconds per contact point."""

    def __init__(self, model: mujoco.MjModel, body_id: int, geom_owner: tuple[str, ...],
                 geom_material: tuple[str, ...], params: ContactParams = ContactParams()) -> None:
        self.m = model
        self.body = body_id
        self.owner = geom_owner
        self.material = geom_material
        self.p = params
        self.dt = model.opt.timestep
        self.sample_steps = max(1, int(round(params.sample_s / self.dt)))
        self.step = 0
        self.open: dict[int, _Episode] = {}
        self.events: list[ContactEvent] = []
        self._force = np.zeros(6)
        self.vadr = int(model.jnt_dofadr[model.body_jntadr[body_id]])
        self._bodyid: list[int] = model.geom_bodyid.tolist()
        self._friction: list[float] = model.geom_friction[:, 0].tolist()
        self._data: mujoco.MjData | None = None  # the MjData the views below look into
        # the body's joint velocities, rotation and position before the step (raw)
        self._prev: tuple[list, list, list] = ([0.0] * 6, [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0],
                                               [0.0] * 3)
        # other geom -> last step in contact of its last closed episode
        self._last: dict[int, int] = {}

    # -- kinematics ---------------------------------------------------------------------------
    # The body has a free joint: qvel[0:3] is the world velocity of the body origin and
    # qvel[3:6] the angular velocity in the body frame; the velocity of a point p is
    # v + (R w) x (p - x).

    def _raw(self, d: mujoco.MjData) -> tuple[list, list, list]:
        if d is not self._data:
            self._data = d
            self._views = (d.qvel[self.vadr:self.vadr + 6], d.xmat[self.body],
                           d.xpos[self.body])
        q, mat, x = self._views
        return q.tolist(), mat.tolist(), x.tolist()

    def before_step(self, d: mujoco.MjData) -> None:
        self._prev = self._raw(d)

    def after_step(self, d: mujoco.MjData) -> None:
        self.step += 1
        if d.ncon == 0:
            if self.open:
                self._close_stale()
            return
        con = d.contact
        body, bodyid = self.body, self._bodyid
        hits = []
        for i, (g1, g2) in enumerate(con.geom.tolist()):
            first_mine = bodyid[g1] == body
            if first_mine != (bodyid[g2] == body):
                hits.append((i, g1, g2, first_mine))
        if not hits:
            if self.open:
                self._close_stale()
            return
        q, mat, x = self._raw(d)
        v, w = _kinematics(q, mat)
        seen: dict[int, list] = {}
        frames, points, force = con.frame, con.pos, self._force
        for i, g1, g2, first_mine in hits:
            if first_mine:
                mine, other, sign = g1, g2, -1.0
            else:
                mine, other, sign = g2, g1, 1.0
            mujoco.mj_contactForce(self.m, d, i, force)
            fn = float(force[0])
            s = seen.get(other)
            if s is not None:  # several contact points with one geom: sum forces
                s[3] += fn
            else:
                f0, f1, f2 = frames[i, :3].tolist()  # the frame's normal points geom1 -> geom2
                seen[other] = [mine, tuple(points[i].tolist()), (sign * f0, sign * f1, sign * f2),
                               fn]
        p = self.p
        for other, (mine, pos, n, fn) in seen.items():
            vp = _point_velocity(v, w, x, pos)  # the object's contact point (others static)
            vn = _dot(vp, n)  # > 0 separating
            t0, t1, t2 = vp[0] - vn * n[0], vp[1] - vn * n[1], vp[2] - vn * n[2]
            slip = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            ep = self.open.get(other)
            if ep is None:
                pq, pmat, px = self._prev
                vn0 = _dot(_point_velocity(*_kinematics(pq, pmat), px, pos), n)
                ep = _Episode(
                    start_step=self.step, geom_object=mine, point_world=pos,
                    point_object=_body_frame(mat, x, pos), normal=n,
                    approach_mps=max(0.0, -vn0), s_start_point=pos, s_start_step=self.step,
                    vn_last=vn0,
                )
                ep.hop = self._is_hop(other, ep, slip)
                self.open[other] = ep
            ep.last_seen = self.step
            if ep.compressing:
                ep.compression_steps += 1
                if vn >= -p.rest_speed_mps:
                    # Approach ended during this step: count the part of its impulse that
                    # brought the normal velocity to zero (linear in the step), not the rebound.
                    frac = min(1.0, max(0.0, -ep.vn_last / (vn - ep.vn_last))) \
                        if vn > ep.vn_last else 1.0
                    ep.impulse += frac * fn * self.dt
                    ep.compressing = False
                else:
                    ep.impulse += fn * self.dt
                    ep.compressing = ep.compression_steps * self.dt < p.max_compression_s
                ep.vn_last = vn
            elif (ep.approach_mps >= p.impact_speed_mps
                  and (self.step - ep.start_step + 1) * self.dt <= p.impact_contact_s):
                ep.s_start_point = None  # sampling starts after the impact's own contact
            else:
                self._sample(ep, other, pos, _body_frame(mat, x, pos), n, fn, vn, slip)
        if self.open:
            self._close_stale()

    def _is_hop(self, other: int, ep: _Episode, slip: float) -> bool:
        last = self._last.get(other)
        if last is None or slip < self.p.slip_speed_mps:
            return False
        gap_s = (ep.start_step - last) * self.dt
        mu = max(self._friction[ep.geom_object], self._friction[other])
        return gap_s <= self.p.hop_gap_s and ep.approach_mps <= self.p.hop_mu_factor * mu * slip

    def _close_stale(self) -> None:
        step, gap = self.step, self.p.gap_steps
        for other in [g for g, ep in self.open.items() if step - ep.last_seen >= gap]:
            self._close(other)

    # -- events -------------------------------------------------------------------------------
    def _sample(self, ep: _Episode, other: int, pos: Vec, pos_object: Vec, n: Vec, fn: float,
                vn: float, slip: float) -> None:
        ep.s_steps += 1
        ep.s_force += fn
        ep.s_slip += slip
        ep.s_normal_speed += abs(vn)
        ep.s_point, ep.s_point_object = pos, pos_object
        if ep.s_start_point is None:
            ep.s_start_point, ep.s_start_step = pos, self.step
        if ep.s_steps >= self.sample_steps:
            self._flush_sample(ep, other, n)

    def _flush_sample(self, ep: _Episode, other: int, n: Vec) -> None:
        if ep.s_steps == 0:
            return
        dur = ep.s_steps * self.dt
        slip = ep.s_slip / ep.s_steps
        r = _sub(ep.s_point, ep.s_start_point)
        travel = math.sqrt(_dot(r, r)) / dur
        kind = "scrape" if slip >= self.p.slip_speed_mps else (
            "roll" if travel >= self.p.roll_speed_mps else None)
        if kind is not None:
            ep.events.append(self._event(
                time=(ep.s_start_step - 1) * self.dt, kind=kind, ep=ep, other=other,
                point=ep.s_point, normal=n, normal_speed=ep.s_normal_speed / ep.s_steps,
                impulse=ep.s_force * self.dt, slip=slip, duration=dur,
                mean_force=ep.s_force / ep.s_steps, point_object=ep.s_point_object,
                travel=travel))
        ep.s_steps, ep.s_force, ep.s_slip, ep.s_normal_speed = 0, 0.0, 0.0, 0.0
        ep.s_start_point, ep.s_start_step = None, self.step + 1

    def _event(self, *, time, kind, ep, other, point, normal, normal_speed, impulse, slip,
               duration, mean_force, point_object=None, travel=0.0) -> ContactEvent:
        po = ep.point_object if point_object is None else point_object
        return ContactEvent(
            time_s=float(time), kind=kind, other=self.owner[other],
            geom_object=ep.geom_object, geom_other=other,
            material_object=self.material[ep.geom_object], material_other=self.material[other],
            point_world=tuple(float(x) for x in point), point_object=tuple(float(x) for x in po),
            normal=tuple(float(x) for x in normal), normal_speed_mps=float(normal_speed),
            impulse_ns=float(impulse), tangential_speed_mps=float(slip),
            duration_s=float(duration), mean_force_n=float(mean_force),
            travel_speed_mps=float(travel))

    def _close(self, other: int) -> None:
        ep = self.open.pop(other)
        self._flush_sample(ep, other, ep.normal)
        self._last[other] = ep.last_seen
        if ep.approach_mps >= self.p.impact_speed_mps and not ep.hop:
            dur = ep.compression_steps * self.dt
            self.events.append(self._event(
                time=(ep.start_step - 1) * self.dt, kind="impact", ep=ep, other=other,
                point=ep.point_world, normal=ep.normal, normal_speed=ep.approach_mps,
                impulse=ep.impulse, slip=0.0, duration=dur,
                mean_force=ep.impulse / dur if dur > 0 else 0.0))
        self.events.extend(ep.events)

    def finish(self) -> list[ContactEvent]:
        """Close open episodes; all events sorted by time (impacts first on ties)."""
        for other in list(self.open):
            self._close(other)
        return sorted(self.events, key=lambda e: (e.time_s, KINDS.index(e.kind), e.geom_other))
