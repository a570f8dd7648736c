"""Contact events of one falling body, extracted step by step from MuJoCo.

A *contact episode* is an uninterrupted run of contact between the falling body and one other
geom (the floor, a shelf board, a distractor). Each episode that starts with the two approaching
faster than ``impact_speed_mps`` yields one ``impact`` event: when it started, where, the normal,
the relative normal speed just before contact, and the normal impulse delivered while the bodies
were still approaching (the compression phase: m v for a body hitting a fixed surface square on;
the whole contact delivers (1 + e) times that). The step in which the approach ends contributes
only the share of its impulse that stopped the approach (linear within the step). Resting contact is not an impact.
While an episode lasts, the contact is sampled every ``sample_s``: samples where the surfaces slip
faster than ``slip_speed_mps`` become ``scrape`` events; samples where the contact point travels
over the surface without slipping become ``roll`` events. Every bounce is its own episode.

Conventions: the normal points from the other surface toward the falling body; speeds are in
m/s, impulses in N s, forces in N; points are in world coordinates and in the body's frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fallgen.physics import contact_kernel as K
from fallgen.physics import mjraw
from fallgen.physics import settle_kernel as S

KINDS = ("impact", "scrape", "roll")


@dataclass(frozen=True)
class ContactParams:
    impact_speed_mps: float = 0.05  # slower approaches are resting contact, not impacts
    slip_speed_mps: float = 0.02  # tangential slip that makes a scrape
    roll_speed_mps: float = 0.02  # contact-point travel (without slip) that makes a roll
    sample_s: float = 0.01  # sampling period of sustained contact
    gap_steps: int = 2  # an episode ends after this many steps without contact
    rest_speed_mps: float = 1e-3  # normal speeds below this end the compression phase
    max_compression_s: float = 0.02  # ... and it never lasts longer than this
    # A sliding body under MuJoCo's soft, convex friction model is pushed off the surface by
    # ~mu v_t, or rocks between its leading and trailing edges, and comes straight back: a
    # re-contact with the same geom while slipping, approaching no faster than
    # hop_mu_factor x mu x slip, after a gap of at most hop_gap_s is part of the scrape, not an
    # impact. (A real bounce at v >= 0.15 m/s is airborne for 2 v / g >= 30 ms.)
    hop_gap_s: float = 0.03
    hop_mu_factor: float = 1.25
    # An impact's own contact (compression and rebound, a few steps) is not sampled for scrapes
    # and rolls: only contact that lasts longer than this after an impact's start is.
    impact_contact_s: float = 0.012


@dataclass(frozen=True)
class ContactEvent:
    time_s: float
    kind: str  # impact | scrape | roll
    other: str  # owner of the other geom: "floor", "wall_north", "<furniture id>", "obj:<name>"
    geom_object: int
    geom_other: int
    material_object: str
    material_other: str
    point_world: tuple[float, float, float]
    point_object: tuple[float, float, float]
    normal: tuple[float, float, float]  # from the other surface toward the object
    normal_speed_mps: float  # approach speed just before contact (impacts), else mean
    impulse_ns: float  # normal impulse: compression phase (impacts) or over the sample
    tangential_speed_mps: float  # slip speed at the contact point
    duration_s: float  # compression time (impacts) or sample length
    mean_force_n: float  # mean normal force over duration_s
    travel_speed_mps: float = 0.0  # speed of the contact point over the surface (scrape, roll)


class ContactRecorder:
    """Steps a simulation (:meth:`step`) and records the contacts of one free body as events
    (:meth:`finish`), following the rules of this module's docstring at every step.

    The per-step work is compiled (:mod:`fallgen.physics.contact_kernel`, which calls
    ``mj_step`` itself): a recorded step costs what ``mj_step`` costs, so a trial can be
    recorded as it is first simulated. One recorder follows one ``MjData`` from the state it
    first steps."""

    def __init__(self, model: mujoco.MjModel, body_id: int, geom_owner: tuple[str, ...],
                 geom_material: tuple[str, ...], params: ContactParams = ContactParams()) -> None:
        self.m = model
        self.body = body_id
        self.owner = geom_owner
        self.material = geom_material
        self.p = params
        self.dt = model.opt.timestep
        self.sample_steps = max(1, int(round(params.sample_s / self.dt)))
        ngeom = model.ngeom
        self._params = np.array([
            params.impact_speed_mps, params.slip_speed_mps, params.roll_speed_mps,
            params.gap_steps, params.rest_speed_mps, params.max_compression_s,
            params.hop_gap_s, params.hop_mu_factor, params.impact_contact_s, self.dt,
            self.sample_steps], float)
        self._bodyid = model.geom_bodyid.astype(np.int64)
        self._friction = model.geom_friction[:, 0].astype(float)
        self._pyramidal = int(model.opt.cone) == int(mujoco.mjtCone.mjCONE_PYRAMIDAL)
        self._layout = mjraw.layout().as_array()
        self._step_fn = mjraw.mj_step_address()
        mjraw.timers_off()
        jnt = model.body_jntadr[body_id]
        self._qadr = int(model.jnt_qposadr[jnt])
        self._vadr = int(model.jnt_dofadr[jnt])
        self._state = np.zeros(5, np.int64)
        self._sweep = np.zeros(4)
        self._ei = np.zeros((ngeom, K.N_EI), np.int64)
        self._ef = np.zeros((ngeom, K.N_EF))
        self._order = np.zeros(ngeom, np.int64)
        cap = 4 * ngeom + 1024
        self._vf = np.zeros((cap, K.N_VF))
        self._vi = np.zeros((cap, K.N_VI), np.int64)
        self._rank = np.zeros(cap, np.int64)
        self._data: mujoco.MjData | None = None
        self._events: list[ContactEvent] | None = None

    @property
    def step_count(self) -> int:
        """Steps recorded so far."""
        return int(self._state[K.S_STEP])

    @property
    def sweep(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The lowest and highest (x, y) of the body's origin over the start and every step."""
        s = self._sweep.tolist()
        return (s[K.W_XLO], s[K.W_YLO]), (s[K.W_XHI], s[K.W_YHI])

    def _attach(self, d: mujoco.MjData) -> None:
        """Follow ``d`` from its current state (the first call), or check it is the one."""
        if self._events is not None:
            raise RuntimeError("the recorder is finished")
        if self._data is None:
            self._data = d
            b, q = self.body, self._qadr
            self._views = (d.qvel[self._vadr:self._vadr + 6], d.xmat[b], d.xpos[b],
                           d.qpos[q:q + 2])
            x, y = self._views[3].tolist()
            self._sweep[:] = (x, x, y, y)
        elif d is not self._data:
            raise ValueError("a recorder follows one MjData")

    def step(self, d: mujoco.MjData, n: int = 1) -> None:
        """``mj_step`` ``n`` times, recording every step."""
        self._attach(d)
        qvel, xmat, xpos, qpos = self._views
        while n > 0:
            n -= K.run(self._step_fn, self.m._address, d._address, n, self.body, self._bodyid,
                       self._friction, self._pyramidal, self._layout, qvel, xmat, xpos, qpos,
                       self._params, self._state, self._sweep, self._ei, self._ef, self._vf,
                       self._vi, self._order, self._rank)
            if n > 0:
                self._grow()

    def settle(self, d: mujoco.MjData, qadr: int, max_steps: int, chunk: int, hold: int,
               window: int, every: int, replay: bool, criteria, bound, watched: list[int]
               ) -> tuple[int, bool, bool, float | None, float, float]:
        """The loop of :func:`fallgen.physics.settle.simulate_until_settled` (its arguments;
        ``bound``: an :class:`~fallgen.physics.settle.EnergyFloor` or None), recording every
        step, compiled (:mod:`fallgen.physics.settle_kernel`): (steps, unstable, gave up,
        settled at or None, largest speed, lowest z)."""
        self._attach(d)
        qvel, xmat, xpos, qpos = self._views
        ss, sf, poses = S.state(max_steps, chunk, hold, window, every, replay, bound is not None)
        sp = np.zeros(S.N_SP)
        sp[[S.SP_LIN, S.SP_ANG, S.SP_POSE_M, S.SP_POSE_RAD, S.SP_DT]] = (
            criteria.lin_tol_mps, criteria.ang_tol_radps, criteria.pose_tol_m,
            criteria.pose_tol_rad, self.dt)
        if bound is not None:
            sp[[S.SP_MASS, S.SP_I0, S.SP_I1, S.SP_I2, S.SP_G, S.SP_FLOOR]] = (
                bound.mass, *bound.inertia, bound.g, bound.floor_z)
        pose, xipos = d.qpos[qadr:qadr + 7], d.xipos[self.body]
        watch = np.asarray(watched, np.int64)
        while S.settle_steps(self._step_fn, self.m._address, d._address, self.body,
                             self._bodyid, self._friction, self._pyramidal, self._layout, qvel,
                             xmat, xpos, qpos, self._params, self._state, self._sweep, self._ei,
                             self._ef, self._vf, self._vi, self._order, self._rank, pose,
                             d.warning.number, watch, xipos, sp, ss, sf, poses) == S.GROW:
            self._grow()
        return (int(ss[S.SS_STEPS]), bool(ss[S.SS_UNSTABLE]), bool(ss[S.SS_GAVE_UP]),
                float(sf[S.SF_SETTLED_AT]) if ss[S.SS_SETTLED] else None,
                float(sf[S.SF_MAX_SPEED]), float(sf[S.SF_MIN_Z]))

    def _grow(self) -> None:
        self._vf = np.concatenate([self._vf, np.zeros_like(self._vf)])
        self._vi = np.concatenate([self._vi, np.zeros_like(self._vi)])
        self._rank = np.concatenate([self._rank, np.zeros_like(self._rank)])

    def finish(self) -> list[ContactEvent]:
        """Close open episodes; all events sorted by time (impacts first on ties)."""
        if self._events is None:
            while self._state[K.S_NEVENTS] + 2 * self.m.ngeom > len(self._vf):
                self._grow()
            K.finish(self._params, self._ei, self._ef, self._state, self._vf, self._vi,
                     self._order, self._rank)
            n = int(self._state[K.S_NEVENTS])
            vf, vi = self._vf[:n].tolist(), self._vi[:n].tolist()
            rank = self._rank.tolist()
            # the order events were made in: by episode closed, its impact before its samples
            made = sorted(range(n), key=lambda k: (rank[vi[k][K.K_SERIAL]], vi[k][K.K_SUB]))
            events = [self._event(vf[k], vi[k]) for k in made]
            self._events = sorted(events, key=lambda e: (e.time_s, KINDS.index(e.kind),
                                                         e.geom_other))
        return list(self._events)

    def _event(self, f: list[float], i: list[int]) -> ContactEvent:
        g_obj, g_other = i[K.K_GOBJ], i[K.K_GOTHER]
        return ContactEvent(
            time_s=f[K.V_TIME], kind=KINDS[i[K.K_KIND]], other=self.owner[g_other],
            geom_object=g_obj, geom_other=g_other, material_object=self.material[g_obj],
            material_other=self.material[g_other], point_world=tuple(f[K.V_PW:K.V_PW + 3]),
            point_object=tuple(f[K.V_PO:K.V_PO + 3]), normal=tuple(f[K.V_N:K.V_N + 3]),
            normal_speed_mps=f[K.V_NSPEED], impulse_ns=f[K.V_IMPULSE],
            tangential_speed_mps=f[K.V_SLIP], duration_s=f[K.V_DUR],
            mean_force_n=f[K.V_FORCE], travel_speed_mps=f[K.V_TRAVEL])
